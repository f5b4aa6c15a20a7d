// The live socket (GET /v1/rigs/{id}/live, a WebSocket), one per rig shown. While it is open the WebGL
// view's meshes come from it: a slider move is one small message (what changed), the answer one binary
// frame (16 bytes, then the float32 mesh), at most 60 a second, the newest state winning. Say speaks over
// it too: audio chunks played as they arrive (Web Audio) and visemes on the audio's clock, the mouth
// following them. Closed or refused, the page falls back to HTTP. Where meshoptimizer's decoder is
// served (/vendor, from npm) the frames are the smallest the page can draw: delta frames, 16-bit
// positions of what moved (about a fortieth of the float32 bytes), the normals made by the view. A module of the page: `page` hands it
// {state, gl, $, showError, refreshViews, refreshMesh, nonZero, api (the API's base URL, '' for this origin)}.

export function createLive(page) {
  const { state, gl, $, showError, refreshViews, refreshMesh, nonZero, api } = page;
  const live = { ws: null, rig: null, open: false, sent: {}, id: 0, held: null };
  // meshoptimizer's decoder, loaded once; null where the server does not serve it.
  const decoder = import('./vendor/meshopt_decoder.module.js')
    .then(async (m) => { await m.MeshoptDecoder.ready; return m.MeshoptDecoder; })
    .catch(() => null);
  decoder.then((d) => { live.decoderReady = d; });

  function connect(id) {
    close();
    if (typeof WebSocket === 'undefined') return;
    const url = new URL(`${api}/v1/rigs/${encodeURIComponent(id)}/live`, location.href);  // The API's origin, this page's or another.
    url.protocol = url.protocol === 'https:' ? 'wss:' : 'ws:';
    const ws = new WebSocket(url);
    ws.binaryType = 'arraybuffer';
    Object.assign(live, { ws, rig: id, open: false, sent: {}, held: null });
    ws.onmessage = (e) => (typeof e.data === 'string' ? onText(JSON.parse(e.data)) : onBinary(e.data));
    ws.onclose = () => {
      if (live.ws !== ws) return;
      live.open = false;
      if (state.speech && state.speech.live) stopSay();
    };
  }

  function close() {
    if (live.mic) stopMic();
    if (live.ws) live.ws.close(1000);
    Object.assign(live, { ws: null, rig: null, open: false, sent: {} });
  }

  // The point's change as one message; false when the socket cannot carry it (closed, another rig, a motion).
  function send(p) {
    if (!live.open || live.rig !== state.ready || p.animation !== undefined) return false;
    const message = {};
    for (const key of ['weights', 'expressions', 'controls']) {
      const now = p[key] || {}, before = live.sent[key] || {}, diff = {};
      for (const [name, v] of Object.entries(now)) if (before[name] !== v) diff[name] = v;
      for (const name of Object.keys(before)) if (!(name in now)) diff[name] = null;
      if (Object.keys(diff).length) message[key] = diff;
      live.sent[key] = { ...now };
    }
    if (!Object.keys(message).length) return true;
    message.id = ++live.id;
    live.ws.send(JSON.stringify(message));
    return true;
  }

  function onText(m) {
    if (m.event === 'ready') {
      live.open = true;
      const ws = live.ws;
      decoder.then((d) => { if (d && live.ws === ws) ws.send(JSON.stringify({ frames: { kind: 'delta' } })); });
      refreshMesh();  // The face as the sliders have it, now over the socket (the render has it already).
    } else if (m.viseme && state.speech && state.speech.live) {
      state.speech.visemes.push(m);
    } else if (m.viseme && live.mic) {
      state.heardVisemes = (state.heardVisemes || 0) + 1;  // Counted for the browser test.
    } else if (m.event === 'say' && state.speech && state.speech.live) {
      if (m.state === 'start' && state.speech.clock === null) state.speech.clock = m.clock;
      if (m.state === 'end' || m.state === 'stopped') state.speech.made = true;
    } else if (m.event === 'weights') {
      // The camera's face, solved: kept (the last 2,000) for the browser test and a recording, at the
      // time its video frame was taken.
      const log = state.cameraLog || (state.cameraLog = []);
      const sent = (live.sentAt && live.sentAt.get(m.id)) || { t: performance.now() };
      log.push({ t: sent.t, tag: sent.tag, weights: m.weights });
      if (log.length > 2000) log.shift();
    } else if (m.event === 'error') {
      showError(new Error(m.detail));
    }
  }

  function onBinary(buf) {
    const tag = String.fromCharCode(...new Uint8Array(buf, 0, 4));
    if ((tag === 'mesh' || tag === 'dkey' || tag === 'dlta') && live.rig === state.ready) {
      if (tag === 'mesh') gl.update(new Float32Array(buf, 16));
      else if (!delta(tag, buf)) return;
      state.meshUpdates = (state.meshUpdates || 0) + 1;
      state.liveFrames = (state.liveFrames || 0) + 1;  // Counted for the browser test.
      state.liveKinds = { ...state.liveKinds, [tag]: ((state.liveKinds || {})[tag] || 0) + 1 };
      $('views').classList.remove('loading');
    } else if (tag === 'pcm1') {
      play(buf);
    }
  }

  // A delta frame (api/README.md, "Frames a network carries"): decoded, added to the grid coordinates
  // held, drawn; false (and a keyframe asked for) when there is none to add to.
  function delta(tag, buf) {
    const d = live.decoderReady;
    const head = new DataView(buf, 16, 24);
    const n = head.getUint32(0, true), codec = head.getUint32(4, true), step = head.getFloat32(8, true);
    if (!d && codec === 1) return false;
    if (tag === 'dlta' && (!live.held || live.held.length !== 4 * n)) {
      live.ws.send(JSON.stringify({ frames: { kind: 'delta' } }));  // Asks for a keyframe.
      return false;
    }
    const got = live.got && live.got.length === 4 * n ? live.got : (live.got = new Int16Array(4 * n));
    if (codec === 1) d.decodeVertexBuffer(new Uint8Array(got.buffer), n, 8, new Uint8Array(buf, 40));
    else got.set(new Int16Array(buf.slice(40)));
    if (tag === 'dkey') live.held = new Int16Array(4 * n);
    const held = live.held;
    const pos = live.pos && live.pos.length === 3 * n ? live.pos : (live.pos = new Float32Array(3 * n));
    const o = [head.getFloat32(12, true), head.getFloat32(16, true), head.getFloat32(20, true)];
    for (let v = 0; v < n; ++v) {
      for (let k = 0; k < 3; ++k) {
        held[4 * v + k] += got[4 * v + k];
        pos[3 * v + k] = o[k] + step * held[4 * v + k];
      }
    }
    gl.updatePositions(pos);
    return true;
  }

  // One audio chunk, scheduled at its place on the say's clock.
  function play(buf) {
    const s = state.speech;
    if (!s || !s.live) return;
    const head = new DataView(buf), rate = head.getUint32(8, true), first = head.getUint32(12, true);
    const pcm = new Int16Array(buf, 16, (buf.byteLength - 16) / 2);
    const audio = s.ctx.createBuffer(1, pcm.length, rate);
    const channel = audio.getChannelData(0);
    for (let i = 0; i < pcm.length; ++i) channel[i] = pcm[i] / 32768;
    if (s.base === null) s.base = s.ctx.currentTime + 0.05 - first / rate;  // Session clock -> audio context time.
    const source = s.ctx.createBufferSource();
    source.buffer = audio;
    source.connect(s.ctx.destination);
    source.start(Math.max(s.ctx.currentTime, s.base + first / rate));
    s.end = Math.max(s.end, first / rate + pcm.length / rate);
    s.samples += pcm.length;
  }

  // The weights at the audio's clock: the sliders', with the viseme said (and the next, faded in over its
  // last 60 ms) on top, as the rig's viseme map says it.
  function weights() {
    const s = state.speech, map = (state.detail && state.detail.visemes) || {};
    const out = { ...nonZero() };
    if (s.base === null) return out;
    const t = s.ctx.currentTime - s.base;
    const i = s.visemes.findIndex((v) => v.start <= t && t < v.end);
    if (i < 0) return out;
    const v = s.visemes[i], next = s.visemes[i + 1];
    const f = next ? Math.min(1, Math.max(0, (t - (v.end - 0.06)) / 0.06)) : 0;
    const add = (name, w) => { for (const [k, x] of Object.entries(map[name] || {})) out[k] = Math.min(1, (out[k] || 0) + x * w); };
    add(v.viseme, 1 - f);
    if (next) add(next.viseme, f);
    for (const k of Object.keys(out)) out[k] = +out[k].toFixed(4);
    state.speechMax = Math.max(state.speechMax || 0, ...Object.values(out), 0);  // For the browser test.
    return out;
  }

  // Say over the socket: false when it cannot (closed), so the page says it over HTTP instead.
  function say(text) {
    if (!live.open || live.rig !== state.ready) return false;
    const ctx = new AudioContext();
    state.speech = { live: true, ctx, base: null, clock: null, visemes: [], end: 0, samples: 0, made: false };
    state.speechMax = 0;
    live.ws.send(JSON.stringify({ say: { text } }));
    $('say-stop').hidden = false;
    $('say-state').textContent = 'speaking (live)\u2026';
    const follow = () => {
      const s = state.speech;
      if (!s || s.ctx !== ctx) return;
      refreshViews();
      if (s.made && s.base !== null && ctx.currentTime - s.base > s.end) {
        const said = s.visemes.filter((v) => v.viseme !== 'sil').length;
        stopSay(`${(s.samples / 22050).toFixed(1)} s, ${said} visemes (espeak-ng, live)`);
      } else {
        requestAnimationFrame(follow);
      }
    };
    requestAnimationFrame(follow);
    return true;
  }

  function stopSay(status) {
    const s = state.speech;
    if (!s || !s.live) return;
    if (!s.made && live.open) live.ws.send(JSON.stringify({ stop: true }));
    s.ctx.close();
    state.speech = null;
    state.liveSaid = (state.liveSaid || 0) + 1;  // Counted for the browser test.
    $('say-stop').hidden = true;
    $('say-state').textContent = status || '';
    refreshViews();
  }

  // The microphone: the browser's capture at 16 kHz, sent as 16-bit PCM while the server listens; its
  // visemes come back with frames of the mouth (the sliders' face with the viseme on top).
  async function toggleMic() {
    if (live.mic) return stopMic();
    if (!live.open || !navigator.mediaDevices) return;
    const stream = await navigator.mediaDevices.getUserMedia({ audio: { channelCount: 1, echoCancellation: true, noiseSuppression: true } });
    const ctx = new AudioContext({ sampleRate: 16000 });
    const source = ctx.createMediaStreamSource(stream);
    const tap = ctx.createScriptProcessor(512, 1, 1);  // 32 ms a chunk.
    tap.onaudioprocess = (e) => {
      if (!live.mic || !live.open) return;
      const f = e.inputBuffer.getChannelData(0), pcm = new Int16Array(f.length);
      for (let i = 0; i < f.length; ++i) pcm[i] = Math.max(-32768, Math.min(32767, Math.round(f[i] * 32767)));
      live.ws.send(pcm.buffer);
      state.micChunks = (state.micChunks || 0) + 1;  // Counted for the browser test.
    };
    source.connect(tap);
    tap.connect(ctx.destination);
    live.mic = { stream, ctx };
    live.ws.send(JSON.stringify({ listen: { rate: 16000, frames: true } }));
    $('say-mic').classList.add('on');
    $('say-state').textContent = 'listening (live)\u2026';
  }

  function stopMic() {
    if (!live.mic) return;
    live.mic.stream.getTracks().forEach((t) => t.stop());
    live.mic.ctx.close();
    live.mic = null;
    if (live.open) live.ws.send(JSON.stringify({ listen: false }));
    $('say-mic').classList.remove('on');
    $('say-state').textContent = '';
  }

  // A face tracker's frame (camera.js) taken at time `t`: the face's weights come back as an event
  // (logged at `t`), the face as a frame.
  function landmarks(l, t = performance.now(), tag = undefined) {
    if (!live.open) return;
    live.ws.send(JSON.stringify({ landmarks: l, id: ++live.id }));
    (live.sentAt || (live.sentAt = new Map())).set(live.id, { t, tag });
    if (live.sentAt.size > 256) live.sentAt.delete(live.sentAt.keys().next().value);
  }

  return { connect, close, send, say, stopSay, weights, toggleMic, landmarks, get open() { return live.open; } };
}
