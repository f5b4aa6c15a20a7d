// A character kept: the rig (and the version it was made on), the weights or control values, the
// expressions, the view and camera, as a small JSON file the page saves and opens, and the last few
// kept in the browser (localStorage) to come back to.

export const kFormat = 'facespace-character';
const kRecentKey = 'facespace.recent';
const kRecentMax = 8;

// The file's contents for `face` ({rig, version, weights, controls, expressions, view, yaw, pitch}).
export function characterFile(face) {
  return JSON.stringify({ format: kFormat, version: 1, saved: new Date().toISOString(), ...face }, null, 2) + '\n';
}

// A character from a file's text; an Error saying what is wrong when it is none.
export function parseCharacter(text) {
  let c;
  try {
    c = JSON.parse(text);
  } catch (e) {
    throw new Error('not a character file: it is not JSON');
  }
  if (!c || typeof c !== 'object' || c.format !== kFormat) throw new Error(`not a character file: it has no "format": "${kFormat}"`);
  if (typeof c.rig !== 'string' || !c.rig) throw new Error('not a character file: it names no rig');
  for (const key of ['weights', 'controls', 'expressions']) {
    const m = c[key] ?? {};
    if (typeof m !== 'object' || Array.isArray(m) || Object.values(m).some((v) => typeof v !== 'number' || !Number.isFinite(v))) {
      throw new Error(`not a character file: "${key}" must map names to numbers`);
    }
    c[key] = m;
  }
  return c;
}

// The characters kept in this browser, newest first (none when storage is unavailable).
export function recentCharacters() {
  try {
    const list = JSON.parse(localStorage.getItem(kRecentKey) || '[]');
    return Array.isArray(list) ? list.filter((c) => c && c.format === kFormat) : [];
  } catch (e) {
    return [];
  }
}

// Keeps `face` first among the recent ones (the same rig and face once), at most kRecentMax.
export function rememberCharacter(face, name) {
  const entry = { format: kFormat, version: 1, name, saved: new Date().toISOString(), ...face };
  const key = (c) => JSON.stringify([c.rig, c.weights, c.controls, c.expressions]);
  const list = [entry, ...recentCharacters().filter((c) => key(c) !== key(entry))].slice(0, kRecentMax);
  try {
    localStorage.setItem(kRecentKey, JSON.stringify(list));
  } catch (e) { /* Storage full or off: nothing kept, nothing lost. */ }
  return list;
}
