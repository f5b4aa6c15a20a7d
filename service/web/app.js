// facespace character creator: sliders over a rig's shapes, a live render from the service,
// and a WebGL2 view of the float32 mesh. Plain JavaScript, no build step, no CDN.
'use strict';

import { createMeshView, drag } from './meshview.js';

const params = new URLSearchParams(location.search);
const API = (params.get('api') || '').replace(/\/$/, '');  // Another origin, or '' for this one.
const $ = (id) => document.getElementById(id);

// `weights` by shape, or `controls` by control when the rig has controls (MakeHuman modifiers):
// the sliders show one or the other.
const state = { rig: null, ready: null, detail: null, weights: {}, controls: {}, view: 'shaded', yaw: 0, pitch: 0, lastPng: null,
                motion: { name: '', duration: 0, time: 0, playing: false, last: 0 } };

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
  ...(usesControls() ? { controls: nonZero() } : { weights: state.speech ? speechWeights() : nonZero() }),
  ...(state.motion.name ? { animation: state.motion.name, time: +state.motion.time.toFixed(4) } : {}),
});

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
const kRegions = ['brow', 'eye', 'cheek', 'nose', 'jaw', 'mouth', 'tongue'];
function groupOrder(g) { return g === 'identity' ? 0 : g === 'expression' ? 1 : kRegions.includes(g) ? 2 + kRegions.indexOf(g) : 2 + kRegions.length; }

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
      label.textContent = s.name.includes('/') ? readableControl(s.name) : s.name;  // Controls: group/name.
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
      num.addEventListener('change', () => { setWeight(s.name, parseFloat(num.value)); schedule(); });
      row.append(label, range, num);
      details.appendChild(row);
    }
    box.appendChild(details);
  });
  $('filter').value = '';
  filterControls();
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
}

// Where the rig starts and resets: the neutral face, unless its manifest says its defaults.
const startValue = (s) => (state.detail.start === 'defaults' ? s.default || 0 : 0);

function reset() {
  for (const s of items()) setWeight(s.name, startValue(s), true);
  state.yaw = 0;
  state.pitch = 0;
  schedule();
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

// ---- motions: a rig's clip (an MMD motion, a glTF animation) played, paused, scrubbed ------------

function setupMotions() {
  const anims = state.detail.animations || [];
  const select = $('motion-name');
  select.textContent = '';
  const none = document.createElement('option');
  none.value = '';
  none.textContent = 'none: the sliders';
  select.appendChild(none);
  for (const a of anims) {
    const o = document.createElement('option');
    o.value = a.name;
    o.textContent = `${a.name} (${a.duration.toFixed(1)} s)`;
    select.appendChild(o);
  }
  $('motion').hidden = !anims.length;
  pickMotion('');
}

function pickMotion(name) {
  const a = (state.detail.animations || []).find((x) => x.name === name);
  Object.assign(state.motion, { name: a ? a.name : '', duration: a ? a.duration : 0, time: 0, playing: false });
  $('motion-name').value = state.motion.name;
  $('motion-time').max = String(state.motion.duration || 1);
  $('motion-play').disabled = $('motion-time').disabled = !a;
  showMotion();
  if (!a) showMotionWeights(null);
}

function showMotion() {
  $('motion-time').value = String(state.motion.time);
  $('motion-clock').textContent = `${state.motion.time.toFixed(2)} s`;
  $('motion-play').innerHTML = state.motion.playing ? '&#10074;&#10074;' : '&#9654;';
  $('motion-play').setAttribute('aria-label', state.motion.playing ? 'pause' : 'play');
}

// Playing: the clock runs in real time (looping), and each frame asks for the views at its time; the
// lanes send what they can (the newest time when a lane frees).
function tick(now) {
  const m = state.motion;
  if (!m.playing) return;
  m.time = (m.time + (now - m.last) / 1000) % (m.duration || 1);
  m.last = now;
  showMotion();
  refreshViews();
  requestAnimationFrame(tick);
}

$('motion-name').addEventListener('change', () => { pickMotion($('motion-name').value); schedule(); });
$('motion-play').addEventListener('click', () => {
  state.motion.playing = !state.motion.playing;
  state.motion.last = performance.now();
  showMotion();
  if (state.motion.playing) requestAnimationFrame(tick);
});
$('motion-time').addEventListener('input', () => {
  state.motion.time = parseFloat($('motion-time').value);
  showMotion();
  refreshViews();
});

// ---- speech: the face says a line (POST /speech: its keys and audio), played with the audio -----

// state.speech while one plays: {keys, audio (an <audio>), url}. The views then show the keys' weights at
// the audio's own clock (audio.currentTime), so the mouth follows what is heard.
function speechWeights() {
  const { keys, audio } = state.speech;
  const t = audio.currentTime;
  let i = 0;
  while (i + 1 < keys.length && keys[i + 1].time <= t) ++i;
  const b = keys[i], c = keys[Math.min(i + 1, keys.length - 1)];
  const u = c.time > b.time ? Math.min(1, Math.max(0, (t - b.time) / (c.time - b.time))) : 0;
  const f = u * u * (3 - 2 * u);  // The keys' smoothstep, as the service samples them.
  const w = {};
  for (const name of new Set([...Object.keys(b.weights), ...Object.keys(c.weights)])) {
    const v = (b.weights[name] || 0) + ((c.weights[name] || 0) - (b.weights[name] || 0)) * f;
    if (v !== 0) w[name] = +v.toFixed(5);
  }
  state.speechMax = Math.max(state.speechMax || 0, ...Object.values(w), 0);  // For the browser test.
  return w;
}

function setupSpeech() {
  stopSpeech();
  const can = !!(state.detail && state.detail.visemes);
  $('say').hidden = !can;
  $('say-state').textContent = '';
}

function stopSpeech() {
  if (!state.speech) return;
  state.speech.audio.pause();
  URL.revokeObjectURL(state.speech.url);
  state.speech = null;
  $('say-stop').hidden = true;
  refreshViews();
}

// `text`, or a WAV file: its keys over the face the sliders make, then the audio played and followed.
async function say(text, file) {
  const id = state.ready;
  if (!id) return;
  stopSpeech();
  $('say-state').textContent = text ? 'speaking\u2026' : 'listening\u2026';
  const path = `/v1/rigs/${encodeURIComponent(id)}/speech`;
  let answer, wav;
  try {
    if (text) {
      answer = await post(path, { text, format: 'json', with_audio: true, weights: nonZero() }).then((r) => r.json());
      wav = Uint8Array.from(atob(answer.audio_wav), (ch) => ch.charCodeAt(0));
    } else {
      const weights = encodeURIComponent(JSON.stringify(nonZero()));
      answer = await call(`${path}?format=json&weights=${weights}`, { method: 'POST', headers: { 'Content-Type': 'audio/wav' }, body: file })
        .then((r) => r.json());
      wav = file;
    }
  } catch (e) {
    $('say-state').textContent = '';
    throw e;
  }
  if (id !== state.ready) return;
  const url = URL.createObjectURL(new Blob([wav], { type: 'audio/wav' }));
  const audio = new Audio(url);
  state.speech = { keys: answer.keys, audio, url };
  state.speechMax = 0;
  const said = answer.visemes.filter((v) => v.viseme !== 'sil').length;
  $('say-state').textContent = `${answer.duration.toFixed(1)} s, ${said} visemes (${answer.source})`;
  if (answer.warnings && answer.warnings.length) showWarnings(answer.warnings);
  $('say-stop').hidden = false;
  const follow = () => {
    if (!state.speech || state.speech.audio !== audio) return;
    refreshViews();
    if (audio.ended) stopSpeech();
    else requestAnimationFrame(follow);
  };
  audio.addEventListener('playing', () => requestAnimationFrame(follow), { once: true });
  await audio.play();
}

$('say-go').addEventListener('click', () => {
  const text = $('say-text').value.trim();
  if (text) say(text).catch(showError);
});
$('say-text').addEventListener('keydown', (e) => { if (e.key === 'Enter') $('say-go').click(); });
$('say-file').addEventListener('change', () => { const f = $('say-file').files[0]; if (f) say(null, f).catch(showError); });
$('say-stop').addEventListener('click', stopSpeech);
for (const ev of ['dragover', 'drop']) {
  $('say').addEventListener(ev, (e) => {
    e.preventDefault();
    if (ev === 'drop' && e.dataTransfer.files[0]) say(null, e.dataTransfer.files[0]).catch(showError);
  });
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
  if (extrapolation) parts.push(extrapolation.message);  // "extrapolation: sum of weights 1.7 exceeds 1": said once.
  if (out.size) parts.push('out of range: ' + [...out].join(', '));
  for (const w of warnings) {
    if (!['extrapolation', 'out_of_range', 'control_out_of_range'].includes(w.code)) parts.push(w.message);
  }
  el.textContent = '\u26a0 ' + parts.join(' \u00b7 ');
  el.hidden = false;
}

// ---- URL: rig and weights in the hash, so a link reproduces the face ------------------------

function writeHash() {
  const w = Object.entries(nonZero()).map(([k, v]) => encodeURIComponent(k) + ':' + +v.toFixed(4)).join(',');
  history.replaceState(null, '', '#rig=' + encodeURIComponent(state.rig) + (usesControls() ? '&c=' : '&w=') + w +
                                 (state.view !== 'shaded' ? '&view=' + state.view : ''));
}

function readHash() {
  const h = new URLSearchParams(location.hash.slice(1));
  const weights = {};
  const key = h.has('c') ? 'c' : 'w';
  for (const pair of (h.get(key) || '').split(',').filter(Boolean)) {
    const i = pair.lastIndexOf(':');
    weights[decodeURIComponent(pair.slice(0, i))] = parseFloat(pair.slice(i + 1));
  }
  // A link's weights are the whole vector: shapes it does not name are 0, not their defaults.
  return { rig: h.get('rig'), weights: h.has(key) ? weights : null, view: h.get('view') };
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
  state.weights = {};
  state.controls = {};
  for (const s of items()) values()[s.name] = weights ? 0 : startValue(s);
  buildControls();
  setupMotions();
  setupSpeech();
  const unknown = [];
  for (const [k, v] of Object.entries(weights || {})) {
    if (shapeByName(k)) setWeight(k, v, true);
    else unknown.push(k);
  }
  // A link's weights this rig does not have are said, not dropped silently.
  if (unknown.length) notice(`Not in ${id}, left out: ${unknown.slice(0, 6).join(', ')}${unknown.length > 6 ? ', \u2026' : ''}`);
  gl.setTopology(topology);
  state.ready = id;
  schedule();
}

async function start() {
  const fromHash = readHash();
  if (['shaded', 'heatmap', 'wireframe', 'clay'].includes(fromHash.view)) state.view = $('view').value = fromHash.view;
  try {
    const { rigs } = await (await call('/v1/rigs')).json();
    for (const r of rigs) {
      const o = document.createElement('option');
      o.value = r.id;
      o.textContent = `${r.id} (${r.shapes} shapes)`;
      $('rig').appendChild(o);
    }
    if (!rigs.length) throw new Error('the service has no rigs');
    const known = rigs.some((r) => r.id === fromHash.rig);
    const first = known ? fromHash.rig : rigs[0].id;
    $('rig').value = first;
    await loadRig(first, fromHash.weights);
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
$('filter').addEventListener('input', filterControls);
drag($('preview'), (dx, dy) => { state.yaw += dx * 0.5; state.pitch = Math.max(-80, Math.min(80, state.pitch + dy * 0.5)); },
     () => schedule());
// On a phone the status line sticks at the top and the views under it: they stick at its height.
new ResizeObserver(() => document.documentElement.style.setProperty('--status-h', `${$('status').offsetHeight}px`)).observe($('status'));

window.facespace = { state, gl, loadRig, schedule };  // For tests and the console.
start();
