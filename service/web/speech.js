// The Say bar: the face says a line (POST /v1/rigs/{id}/speech: its keys and audio), played with the
// audio, from typed text or a WAV dropped or picked. A module of the page: `page` hands it the page's
// state and the calls it shares ({state, $, post, call, nonZero, refreshViews, showWarnings, showError, save}).

export function createSpeech(page) {
  const { state, $, post, call, nonZero, refreshViews, showWarnings, showError, save, live } = page;

  // state.speech while one plays: {keys, audio (an <audio>), url}. The views then show the keys' weights at
  // the audio's own clock (audio.currentTime), so the mouth follows what is heard.
  function speechWeights() {
    if (state.speech.live) return live.weights();
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
    if (state.speech.live) return live.stopSay();
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
    if (text && live.say(text)) return;  // Over the live socket: it starts while it is made.
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
  $('say-mic').addEventListener('click', () => live.toggleMic().catch(showError));
  // The typed line as a video of the face saying it (format webm: VP9 + Opus), saved as a file.
  $('say-webm').addEventListener('click', async () => {
    const text = $('say-text').value.trim(), id = state.ready;
    if (!text || !id) return;
    $('say-state').textContent = 'making the video\u2026';
    try {
      const r = await post(`/v1/rigs/${encodeURIComponent(id)}/speech`, { text, format: 'webm', weights: nonZero() });
      save(await r.blob(), `${id}.webm`);
      $('say-state').textContent = '';
    } catch (e) {
      $('say-state').textContent = '';
      showError(e);
    }
  });
  for (const ev of ['dragover', 'drop']) {
    $('say').addEventListener(ev, (e) => {
      e.preventDefault();
      if (ev === 'drop' && e.dataTransfer.files[0]) say(null, e.dataTransfer.files[0]).catch(showError);
    });
  }

  return { weights: speechWeights, setup: setupSpeech, stop: stopSpeech };
}
