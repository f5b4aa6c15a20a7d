// The motion bar: a rig's clip (an MMD motion, a glTF animation) played, paused, scrubbed. A module of
// the page: `page` hands it {state, $, refreshViews, schedule, showMotionWeights}.

import { fillSelect } from './dom.js';

export function createMotions(page) {
  const { state, $, refreshViews, schedule, showMotionWeights } = page;

  function setupMotions() {
    const anims = state.detail.animations || [];
    fillSelect($('motion-name'), 'none: the sliders', anims.map((a) => [a.name, `${a.name} (${a.duration.toFixed(1)} s)`]));
    $('motion').hidden = !anims.length;
    pickMotion('');
  }

  function pickMotion(name) {
    const a = (state.detail.animations || []).find((x) => x.name === name);
    Object.assign(state.motion, { name: a ? a.name : '', duration: a ? a.duration : 0, time: 0, playing: false, maxSum: 0 });
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

  return { setup: setupMotions };
}
