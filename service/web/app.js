// facespace character creator: sliders over a rig's shapes, a live render from the service,
// and a WebGL2 view of the float32 mesh. Plain JavaScript, no build step, no CDN.
'use strict';

import { createMeshView, drag } from './meshview.js';
import { History } from './history.js';
import { characterFile, parseCharacter, recentCharacters, rememberCharacter } from './character.js';
import { loadSheets, releaseSheets, showCell } from './thumbs.js';
import { createSpeech } from './speech.js';
import { createLive } from './live.js';
import { createCamera } from './camera.js';
import { createMotions } from './motion.js';
import { fillSelect } from './dom.js';

const params = new URLSearchParams(location.search);
const API = (params.get('api') || '').replace(/\/$/, '');  // Another origin, or '' for this one.
const $ = (id) => document.getElementById(id);

// `weights` by shape, or `controls` by control when the rig has controls (MakeHuman modifiers):
// the sliders show one or the other.
// `expressions` by name (the rig's presets: happy, blink, ...), on top of either.
const state = { rig: null, ready: null, detail: null, weights: {}, controls: {}, expressions: {}, view: 'shaded', yaw: 0, pitch: 0,
                lastPng: null, motion: { name: '', duration: 0, time: 0, playing: false, last: 0, maxSum: 0 } };
const edits = new History();  // Undo and redo (history.js).

// ---- service calls -------------------------------------------------------------------------

async function call(path, options = {}) {
  const res = await fetch(API + path, options);
  if (!res.ok) {
    let detail = res.status + ' ' + res.statusText;
    try {
      const p = await res.json();
      if (p.detail) detail = p.detail;
    } catch (e) { /* not problem+json */ }
    const err = new Error(detail);
    err.status = res.status;
    throw err;
  }
  return res;
}

const post = (path, body, signal) =>
  call(path, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body), signal });

function showError(e) {
  if (e && e.name === 'AbortError') return;
  $('error').textContent = e ? 'Error: ' + e.message : '';
  $('error').hidden = !e;
}

// ---- weights and sliders -------------------------------------------------------------------

function nonZeroOf(map) {
  const w = {};
  for (const [k, v] of Object.entries(map)) if (v !== 0) w[k] = v;
  return w;
}
const usesControls = () => state.detail && state.detail.controls && state.detail.controls.length > 0;
const values = () => (usesControls() ? state.controls : state.weights);
const nonZero = () => nonZeroOf(values());
// The request members for the current point: {"weights": ...} or {"controls": ...}, and the motion
// playing (its clip and time: what it animates, the rest from the sliders).
const point = () => ({
  ...(usesControls() ? { controls: nonZero() } : { weights: state.speech ? speech.weights() : nonZero() }),
  ...(Object.keys(nonZeroOf(state.expressions)).length ? { expressions: nonZeroOf(state.expressions) } : {}),
  ...(state.motion.name ? { animation: state.motion.name, time: +state.motion.time.toFixed(4) } : {}),
});

// ---- undo, redo and keeping a character --------------------------------------------------------

// What the user set, as history.js and character files keep it.
const snapshot = () => ({ weights: nonZeroOf(state.weights), controls: nonZeroOf(state.controls), expressions: nonZeroOf(state.expressions) });

// An edit ended: the face as it now is becomes a step of the history.
function commit() {
  edits.commit(snapshot());
  showHistory();
}

function showHistory() {
  $('undo').disabled = !edits.canUndo();
  $('redo').disabled = !edits.canRedo();
}

// Shows `face` (a snapshot): every slider at its value (0 when it names none), the presets as it says.
function applyFace(face) {
  for (const s of items()) setWeight(s.name, (usesControls() ? face.controls : face.weights)[s.name] || 0, true);
  state.expressions = { ...face.expressions };
  showPresets();
  schedule();
}

function step(face) {
  if (!face) return;
  applyFace(face);
  showHistory();
}

// The character file of the face shown, and the face kept among the recent ones.
function face() {
  return { rig: state.rig, rig_version: state.detail.version || '', ...snapshot(), view: state.view, yaw: state.yaw, pitch: state.pitch };
}

function saveCharacter() {
  const c = face();
  save(new Blob([characterFile(c)], { type: 'application/json' }), `${state.rig}.character.json`);
  rememberCharacter(c, `${state.rig} ${new Date().toLocaleString()}`);
  showRecent();
}

// A character (from a file or the recent list) opened: its rig loaded if it is another, its face shown,
// an edit that undo can step back from.
async function openCharacter(c) {
  if (![...$('rig').options].some((o) => o.value === c.rig)) throw new Error(`this service has no rig "${c.rig}" for that character`);
  if (c.rig !== state.rig) {
    $('rig').value = c.rig;
    await loadRig(c.rig, c.weights);
  }
  if (c.rig_version && state.detail.version && c.rig_version !== state.detail.version) notice(`${c.rig} has changed since this character was kept`);
  if (['shaded', 'heatmap', 'wireframe', 'clay'].includes(c.view)) state.view = $('view').value = c.view;
  state.yaw = Number.isFinite(c.yaw) ? c.yaw : 0;
  state.pitch = Number.isFinite(c.pitch) ? c.pitch : 0;
  applyFace({ weights: c.weights, controls: c.controls, expressions: c.expressions });
  commit();
}

function showRecent() {
  fillSelect($('recent'), 'Recent\u2026', recentCharacters().map((c, i) => [String(i), c.name || c.rig]));
  $('recent').disabled = $('recent').options.length < 2;
}

// ---- presets: the rig's expressions, one click each ------------------------------------------------

// A chip per expression the rig has (happy, sad, blink, ...), with a picture of it; clicking one shows it
// at full value (and clicking it again takes it off).
function buildPresets() {
  const bar = $('presets');
  bar.textContent = '';
  const names = Object.keys(state.detail.expressions || {});
  bar.hidden = !names.length;
  for (const name of names) {
    const chip = document.createElement('button');
    chip.type = 'button';
    chip.className = 'preset';
    chip.dataset.name = name;
    chip.setAttribute('aria-pressed', 'false');
    const pic = document.createElement('span');
    pic.className = 'thumb';
    chip.append(pic, document.createTextNode(name));
    chip.addEventListener('click', () => {
      state.expressions = state.expressions[name] ? {} : { [name]: 1 };
      showPresets();
      schedule();
      commit();
    });
    bar.appendChild(chip);
  }
  const id = state.rig;
  const binds = names.map((n) => ({ weights: state.detail.expressions[n].weights || {} }));
  loadSheets(post, `/v1/rigs/${encodeURIComponent(id)}`, binds, { view: 'shaded', camera: { frame: 'shapes' } },
             (url, first, count) => {
               const chips = bar.querySelectorAll('.preset .thumb');
               for (let i = 0; i < count; ++i) showCell(chips[first + i], url, i, count, 40);
             }, () => state.rig === id);
}

function showPresets() {
  for (const chip of document.querySelectorAll('#presets .preset')) {
    chip.setAttribute('aria-pressed', String(!!state.expressions[chip.dataset.name]));
  }
}

// The sliders' items: shapes (not driven ones), or controls.
function items() {
  return usesControls() ? state.detail.controls : state.detail.shapes.filter((s) => !s.driven);
}
function shapeByName(name) { return items().find((s) => s.name === name); }

// A slider row showing `value`: the slider, and the number box to 3 decimals.
function showValue(row, value) {
  row.querySelector('input[type=range]').value = value;
  row.querySelector('input[type=number]').value = +value.toFixed(3);
}

function setWeight(name, value, fromPartner) {
  const s = shapeByName(name);
  if (!s || !Number.isFinite(value)) return;
  values()[name] = value;
  const row = document.querySelector(`.shape[data-name="${CSS.escape(name)}"]`);
  if (row) showValue(row, value);
  if (!fromPartner && $('mirror').checked && s.partner) setWeight(s.partner, value, true);
}

// Groups: identity, expression, then a face's regions from the top down (ARKit-named rigs), then the rest by name.
// MMD's groups by the same regions (its whole-face morphs first; "other" and "system" last).
const kRegions = ['face', 'brow', 'eyebrow', 'eye', 'cheek', 'nose', 'jaw', 'mouth', 'tongue'];
function groupOrder(g) {
  if (g === 'identity' || g === 'expression') return g === 'identity' ? 0 : 1;
  return kRegions.includes(g) ? 2 + kRegions.indexOf(g) : ['other', 'default', 'system'].includes(g) ? 99 : 2 + kRegions.length;
}

// The sliders, one <details> per group. A rig with many (MakeHuman's 146 controls, Uka's 200
// expressions) opens with only its first group unfolded; the filter finds any slider by name.
const kFoldAbove = 60;

// A MakeHuman modifier's name as words that fit the row: "cheek/l-cheek-trans-down|up" reads
// "cheek move L (down/up)", "chin/chin-width-decr|incr" "chin width"; the whole name stays in the tooltip.
function readableControl(name) {
  let n = name.slice(name.indexOf('/') + 1);
  let side = '';
  const sided = n.match(/^([lr])-(.*)$/);
  if (sided) [side, n] = [sided[1] === 'l' ? ' L' : ' R', sided[2]];
  let ends = '';
  n = n.replace(/-([a-z]+)\|([a-z]+)$/, (all, low, high) => {
    if (!(low === 'decr' && high === 'incr')) ends = ` (${low}/${high})`;
    return '';
  });
  const words = n.split('-').map((w) => ({ trans: 'move', rot: 'turn', vert: 'vertical', horiz: 'horizontal' }[w] || w));
  return words.join(' ') + side + ends;
}

function buildControls() {
  const box = $('sliders');
  box.textContent = '';
  const groups = new Map();
  for (const s of items()) {  // Driven shapes (in-betweens, correctives) follow their sliders: not shown.
    if (!groups.has(s.group)) groups.set(s.group, []);
    groups.get(s.group).push(s);
  }
  const names = [...groups.keys()].sort((a, b) => groupOrder(a) - groupOrder(b) || a.localeCompare(b));
  const fold = items().length > kFoldAbove;
  names.forEach((g, index) => {
    const details = document.createElement('details');
    details.open = !fold || index === 0;
    details.dataset.open = details.open ? '1' : '';  // The user's choice, restored when a filter is cleared.
    details.addEventListener('toggle', () => { if (!$('filter').value) details.dataset.open = details.open ? '1' : ''; });
    const summary = document.createElement('summary');
    const h = document.createElement('h2');
    h.textContent = g === 'default' ? 'other' : g;
    const count = document.createElement('span');
    count.className = 'count';
    count.textContent = groups.get(g).length;
    summary.append(h, count);
    details.appendChild(summary);
    for (const s of groups.get(g)) {
      const row = document.createElement('div');
      row.className = 'shape';
      row.dataset.name = s.name;
      row.dataset.search = [s.name, ...(s.aliases || [])].join(' ').toLowerCase();
      const label = document.createElement('label');
      // Controls as words; a name in another script with its English alias beside it ("まばたき · blink").
      const english = (s.aliases || []).find((a) => /^[\x20-\x7e]+$/.test(a));
      label.textContent = s.name.includes('/') ? readableControl(s.name) : english && !/^[\x20-\x7e]+$/.test(s.name) ? `${s.name} \u00b7 ${english}` : s.name;
      label.title = `${s.name} [${s.min}, ${s.max}]` + (s.partner ? ` (partner ${s.partner})` : '') +
                    (s.negative ? ` (${s.negative} below 0, ${s.positive} above)` : '') +
                    (s.aliases && s.aliases.length ? ` (also ${s.aliases.join(', ')})` : '');
      const range = document.createElement('input');
      Object.assign(range, { type: 'range', min: s.min, max: s.max, step: 0.01, value: values()[s.name] || 0 });
      range.setAttribute('aria-label', s.name);
      const num = document.createElement('input');
      Object.assign(num, { type: 'number', step: 0.05, value: values()[s.name] || 0 });
      num.setAttribute('aria-label', s.name + ' value');
      range.addEventListener('input', () => { setWeight(s.name, parseFloat(range.value)); schedule(); });
      range.addEventListener('change', commit);  // Let go: one edit, however long the drag.
      num.addEventListener('change', () => { setWeight(s.name, parseFloat(num.value)); schedule(); commit(); });
      const pic = document.createElement('span');
      pic.className = 'thumb';
      pic.title = `what ${s.name} does`;
      row.append(pic, label, range, num);
      details.appendChild(row);
    }
    box.appendChild(details);
  });
  $('filter').value = '';
  filterControls();
  loadShapeThumbs();
}

// Each slider's picture: its shape alone at full weight (a control: its positive shape), in the order
// the rows show them.
function loadShapeThumbs() {
  const rows = [...document.querySelectorAll('#sliders .shape')];
  const id = state.rig;
  const cells = rows.map((row) => {
    const s = shapeByName(row.dataset.name);
    return { weights: { [usesControls() ? s.positive : s.name]: 1 } };
  });
  loadSheets(post, `/v1/rigs/${encodeURIComponent(id)}`, cells, { view: 'shaded', camera: { frame: 'shapes' } },
             (url, first, count) => {
               for (let i = 0; i < count; ++i) showCell(rows[first + i].querySelector('.thumb'), url, i, count, 28);
             }, () => state.rig === id);
}

// Shows the sliders whose name (or alias) holds every word typed, unfolding the groups that have
// one; an empty filter shows all, folded as the user left them.
function filterControls() {
  const words = $('filter').value.toLowerCase().split(/\s+/).filter(Boolean);
  let shown = 0, total = 0;
  for (const details of document.querySelectorAll('#sliders details')) {
    let inGroup = 0;
    for (const row of details.querySelectorAll('.shape')) {
      const match = words.every((w) => row.dataset.search.includes(w));
      row.hidden = !match;
      inGroup += match ? 1 : 0;
      ++total;
    }
    shown += inGroup;
    details.hidden = inGroup === 0;
    details.open = words.length ? inGroup > 0 : details.dataset.open === '1';
  }
  $('filter-count').textContent = words.length ? `${shown} of ${total}` : `${total}`;
}

// Seeded (mulberry32): the same seed gives the same face.
function rng(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6D2B79F5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

function randomise() {
  const r = rng(parseInt($('seed').value, 10) || 0);
  const free = items();
  for (const s of free) setWeight(s.name, 0, true);
  // A handful of shapes, each uniform within its range: a plausible face rather than every slider at once.
  const count = Math.min(6, free.length);
  const pool = free.slice();
  for (let i = 0; i < count; ++i) {
    const s = pool.splice(Math.floor(r() * pool.length), 1)[0];
    setWeight(s.name, +(s.min + (s.max - s.min) * r()).toFixed(3));
  }
  $('seed').value = (parseInt($('seed').value, 10) || 0) + 1;
  schedule();
  commit();
}

// Where the rig starts and resets: the neutral face, unless its manifest says its defaults.
const startValue = (s) => (state.detail.start === 'defaults' ? s.default || 0 : 0);

function reset() {
  for (const s of items()) setWeight(s.name, startValue(s), true);
  state.expressions = {};
  showPresets();
  state.yaw = 0;
  state.pitch = 0;
  schedule();
  commit();
}

// ---- refresh: three lanes, the mesh, the check and the render, each at its own pace -------------
// A lane has at most one request in flight; weights that change meanwhile are sent when it answers,
// so a dragged slider moves the WebGL view at the service's pace (not after the drag) and the slower
// render follows as it can. An answer for a rig no longer shown is dropped.

function schedule() {
  if (!usesControls() && !state.motion.name) {  // Else the service's check says the sum of the shapes driven.
    let sum = 0;
    for (const v of Object.values(state.weights)) sum += v;
    $('sum').textContent = +sum.toFixed(4);
  }
  writeHash();
  state.changed = performance.now();
  refreshViews();
}

function refreshViews() {
  for (const lane of Object.values(lanes)) kick(lane);
}

// `gap`: the least time between a lane's answer and its next request, so that renders (tens of ms of the
// service's CPU each) leave room for the meshes a drag needs.
const lanes = {
  mesh: { busy: false, dirty: false, gap: 0, run: refreshMesh },
  check: { busy: false, dirty: false, gap: 0, run: refreshCheck },
  render: { busy: false, dirty: false, gap: 200, run: refreshRender },
};

function kick(lane) {
  if (lane.busy) {
    lane.dirty = true;
    return;
  }
  lane.busy = true;
  lane.dirty = false;
  lane.run().catch(showError).finally(() => setTimeout(() => {
    lane.busy = false;
    if (lane.dirty) kick(lane);
  }, lane.gap));
}

async function refreshCheck() {
  const id = state.ready;  // The rig whose sliders and topology are set; none while one loads.
  if (!id) return;
  const check = await post(`/v1/rigs/${encodeURIComponent(id)}/check`, point()).then((r) => r.json());
  if (id !== state.ready) return;
  $('sum').textContent = +check.sum.toFixed(4);
  showWarnings(check.warnings);
  if (state.motion.name && !usesControls()) showMotionWeights(check.weights);
}

// While a motion is picked, the sliders show the weights it plays at its time (the check's answer,
// marked as driven); the user's own come back when the motion is set to none.
function showMotionWeights(weights) {
  for (const row of document.querySelectorAll('.shape')) {
    showValue(row, weights ? weights[row.dataset.name] || 0 : values()[row.dataset.name] || 0);
    row.classList.toggle('driven', !!weights);
  }
}

async function refreshMesh() {
  const id = state.ready;  // The rig whose sliders and topology are set; none while one loads.
  if (!id) return;
  if (live.send(point())) return;  // Its frame comes back over the socket.
  const mesh = await post(`/v1/rigs/${encodeURIComponent(id)}/mesh`, { ...point(), format: 'f32' }).then((r) => r.arrayBuffer());
  if (id !== state.ready) return;
  showError(null);
  gl.update(new Float32Array(mesh));
  $('views').classList.remove('loading');
  state.meshUpdates = (state.meshUpdates || 0) + 1;  // Counted for the browser test.
}

async function refreshRender() {
  // While a slider moves, the render waits for it to rest (150 ms): its draw and PNG would take the
  // CPU the WebGL view's meshes need to follow the drag; a motion playing does not wait.
  while (!state.motion.playing && performance.now() - (state.changed || 0) < 150) await new Promise((r) => setTimeout(r, 50));
  const id = state.ready;  // The rig whose sliders and topology are set; none while one loads.
  if (!id) return;
  const at = point();
  const png = await post(`/v1/rigs/${encodeURIComponent(id)}/render`,
                         { ...at, view: state.view, width: 512, height: 512, camera: { yaw: state.yaw, pitch: state.pitch, frame: 'shapes' } })
                    .then((r) => r.blob());
  if (id !== state.ready) return;
  if (state.lastPng) URL.revokeObjectURL(state.lastPng.url);
  state.lastPng = { blob: png, url: URL.createObjectURL(png) };
  $('preview').src = state.lastPng.url;
}

function showWarnings(warnings) {
  const out = new Set(warnings.filter((w) => w.code === (usesControls() ? 'control_out_of_range' : 'out_of_range')).map((w) => w.shape));
  for (const row of document.querySelectorAll('.shape')) row.classList.toggle('out', out.has(row.dataset.name));
  const el = $('warning');
  if (!warnings.length) {
    el.hidden = true;
    el.textContent = '';
    return;
  }
  const extrapolation = warnings.find((w) => w.code === 'extrapolation');
  const parts = [];
  // An authored motion whose own keys go past the authored space (Uka's sum 4): said once, quietly, with
  // the largest sum it has reached; the user's own point past it stays a warning.
  const motion = state.motion.name && !usesControls();
  if (extrapolation && motion) {
    state.motion.maxSum = Math.max(state.motion.maxSum, extrapolation.value || 0);
    parts.push(`${state.motion.name}'s own keys go past the authored space (sum up to ${+state.motion.maxSum.toFixed(2)})`);
  } else if (extrapolation) {
    parts.push(extrapolation.message);  // "extrapolation: sum of weights 1.7 exceeds 1": said once.
  }
  if (out.size) parts.push('out of range: ' + [...out].join(', '));
  for (const w of warnings) {
    if (!['extrapolation', 'out_of_range', 'control_out_of_range'].includes(w.code)) parts.push(w.message);
  }
  el.textContent = (motion ? '\u24d8 ' : '\u26a0 ') + parts.join(' \u00b7 ');
  el.title = el.textContent;
  el.className = motion ? 'warning motion' : 'warning';
  el.hidden = false;
}

// ---- URL: rig and weights in the hash, so a link reproduces the face ------------------------

// {name: 0.5, other: 1} as "name:0.5,other:1" (pairsOf reads it back).
const pairsText = (map) => Object.entries(map).map(([k, v]) => encodeURIComponent(k) + ':' + +v.toFixed(4)).join(',');

function writeHash() {
  const w = pairsText(nonZero());
  const e = pairsText(nonZeroOf(state.expressions));
  history.replaceState(null, '', '#rig=' + encodeURIComponent(state.rig) + (usesControls() ? '&c=' : '&w=') + w + (e ? '&e=' + e : '') +
                                 (state.view !== 'shaded' ? '&view=' + state.view : ''));
}

// "name:0.5,other:1" as {name: 0.5, other: 1}.
function pairsOf(text) {
  const out = {};
  for (const pair of (text || '').split(',').filter(Boolean)) {
    const i = pair.lastIndexOf(':');
    out[decodeURIComponent(pair.slice(0, i))] = parseFloat(pair.slice(i + 1));
  }
  return out;
}

function readHash() {
  const h = new URLSearchParams(location.hash.slice(1));
  const key = h.has('c') ? 'c' : 'w';
  // A link's weights are the whole vector: shapes it does not name are 0, not their defaults.
  return { rig: h.get('rig'), weights: h.has(key) ? pairsOf(h.get(key)) : null, expressions: pairsOf(h.get('e')), view: h.get('view') };
}

// ---- downloads -----------------------------------------------------------------------------

function save(blob, name) {
  const a = document.createElement('a');
  a.href = URL.createObjectURL(blob);
  a.download = name;
  document.body.appendChild(a);
  a.click();
  setTimeout(() => { URL.revokeObjectURL(a.href); a.remove(); }, 1000);
}

async function download(format) {
  try {
    const r = await post(`/v1/rigs/${encodeURIComponent(state.rig)}/mesh`, { ...point(), format });
    save(await r.blob(), `${state.rig}.${format}`);
  } catch (e) { showError(e); }
}

const gl = createMeshView($('gl'));
const motions = createMotions({ state, $, refreshViews, schedule, showMotionWeights });
const live = createLive({ state, gl, $, showError, refreshViews, refreshMesh: () => kick(lanes.mesh), nonZero, api: API });
const speech = createSpeech({ state, $, post, call, nonZero, refreshViews, showWarnings, showError, save, live });
const camera = createCamera({ state, live, $ });
$('say-cam').addEventListener('click', () => camera.toggle().catch(showError));

// ---- start ---------------------------------------------------------------------------------

async function loadRig(id, weights) {
  state.rig = id;
  state.ready = null;  // Until its detail and topology are in, the lanes send nothing (the old rig's weights on the new rig).
  // Until the new rig's face is drawn, the views say so instead of showing the last rig's.
  $('views').classList.add('loading');
  $('views').dataset.loading = `Loading ${id}\u2026`;
  $('preview').removeAttribute('src');
  const path = `/v1/rigs/${encodeURIComponent(id)}`;
  let detail, topology;
  try {
    [detail, topology] = await Promise.all([call(path).then((r) => r.json()), call(`${path}/topology`).then((r) => r.json())]);
  } finally {
    if (state.rig === id && !detail) $('views').classList.remove('loading');  // Failed: the error says why.
  }
  if (state.rig !== id) return;  // Another rig was picked meanwhile.
  state.detail = detail;
  // The credit the rig's license asks for, shown with it.
  $('credit').textContent = state.detail.credit ? `Model: ${state.detail.credit}` : '';
  $('credit').hidden = !state.detail.credit;
  $('dl-vrm').hidden = !state.detail.has_skeleton;  // The service says why when the skeleton is no humanoid.
  state.weights = {};
  state.controls = {};
  state.expressions = {};
  for (const s of items()) values()[s.name] = weights ? 0 : startValue(s);
  releaseSheets();  // The last rig's pictures.
  buildControls();
  buildPresets();
  motions.setup();
  speech.setup();
  const unknown = [];
  for (const [k, v] of Object.entries(weights || {})) {
    if (shapeByName(k)) setWeight(k, v, true);
    else unknown.push(k);
  }
  // A link's weights this rig does not have are said, not dropped silently.
  if (unknown.length) notice(`Not in ${id}, left out: ${unknown.slice(0, 6).join(', ')}${unknown.length > 6 ? ', \u2026' : ''}`);
  gl.setTopology(topology);
  state.ready = id;
  camera.stop();  // Another rig: a new socket, and a new face at rest.
  live.connect(id);
  edits.clear(snapshot());  // A rig's history starts at the face it opens with.
  showHistory();
  schedule();
}

async function start() {
  const fromHash = readHash();
  if (['shaded', 'heatmap', 'wireframe', 'clay'].includes(fromHash.view)) state.view = $('view').value = fromHash.view;
  try {
    const { rigs } = await (await call('/v1/rigs')).json();
    fillSelect($('rig'), null, rigs.map((r) => [r.id, `${r.id} (${r.shapes} shapes)`]));
    if (!rigs.length) throw new Error('the service has no rigs');
    const known = rigs.some((r) => r.id === fromHash.rig);
    const first = known ? fromHash.rig : rigs[0].id;
    $('rig').value = first;
    await loadRig(first, fromHash.weights);
    if (Object.keys(fromHash.expressions).length) applyFace({ ...snapshot(), expressions: fromHash.expressions });
    if (fromHash.rig && !known) notice(`No rig \u201c${fromHash.rig}\u201d here: showing ${first}`);
  } catch (e) {
    showError(e);
  }
}

$('rig').addEventListener('change', () => loadRig($('rig').value).catch(showError));
$('view').addEventListener('change', () => { state.view = $('view').value; schedule(); });
$('reset').addEventListener('click', reset);
$('randomise').addEventListener('click', randomise);
$('dl-glb').addEventListener('click', () => download('glb'));
$('dl-obj').addEventListener('click', () => download('obj'));
$('dl-vrm').addEventListener('click', () => download('vrm'));
$('dl-png').addEventListener('click', () => state.lastPng && save(state.lastPng.blob, `${state.rig}.png`));
$('dl-json').addEventListener('click', () =>
  save(new Blob([JSON.stringify(point(), null, 2)], { type: 'application/json' }), `${state.rig}.weights.json`));
// A short-lived line in the status bar ("Link copied"), for actions with nothing else to show.
let noticeTimer = 0;
function notice(text) {
  $('notice').textContent = text;
  $('notice').hidden = false;
  clearTimeout(noticeTimer);
  noticeTimer = setTimeout(() => { $('notice').hidden = true; }, 4000);
}

async function share() {
  writeHash();
  try {
    await navigator.clipboard.writeText(location.href);
    notice('\u2713 Link copied: it opens this face');
  } catch (e) {  // No clipboard (a page served over plain HTTP from another host): the address bar has it.
    notice('Copy the link from the address bar: it opens this face');
  }
}

$('share').addEventListener('click', share);
$('undo').addEventListener('click', () => step(edits.undo()));
$('redo').addEventListener('click', () => step(edits.redo()));
document.addEventListener('keydown', (e) => {  // Ctrl+Z, Ctrl+Shift+Z (and Ctrl+Y), outside text boxes.
  if (!(e.ctrlKey || e.metaKey) || ['INPUT', 'TEXTAREA'].includes(e.target.tagName) && e.target.type !== 'range') return;
  const key = e.key.toLowerCase();
  if (key === 'z' || key === 'y') {
    e.preventDefault();
    step(key === 'y' || e.shiftKey ? edits.redo() : edits.undo());
  }
});
$('save').addEventListener('click', saveCharacter);
$('open').addEventListener('change', async () => {
  const file = $('open').files[0];
  $('open').value = '';
  if (!file) return;
  try {
    await openCharacter(parseCharacter(await file.text()));
    notice(`\u2713 Opened ${file.name}`);
  } catch (e) { showError(e); }
});
$('recent').addEventListener('change', () => {
  const c = recentCharacters()[parseInt($('recent').value, 10)];
  $('recent').value = '';
  if (c) openCharacter(c).catch(showError);
});
showRecent();
$('filter').addEventListener('input', filterControls);
drag($('preview'), (dx, dy) => { state.yaw += dx * 0.5; state.pitch = Math.max(-80, Math.min(80, state.pitch + dy * 0.5)); },
     () => schedule());
// On a phone the status line sticks at the top and the views under it: they stick at its height.
new ResizeObserver(() => document.documentElement.style.setProperty('--status-h', `${$('status').offsetHeight}px`)).observe($('status'));

window.facespace = { state, gl, loadRig, schedule, edits, point, openCharacter, parseCharacter };  // For tests and the console.
start();
