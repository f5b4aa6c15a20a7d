// The camera: the user's face drives the rig. MediaPipe's face tracker (npm @mediapipe/face_mesh, its
// wasm and model served by the service itself at /vendor/face_mesh, nothing from elsewhere) finds 478
// landmarks a frame in the browser; each frame goes over the live socket ({"landmarks": ...}), which
// answers with the face's weights (an event) and its frame (the WebGL view). The first frame is the
// performer at rest: hold a neutral face as it starts. Stopped, the recording can be saved as a
// motion: the weights' keys, as the sequence routes take them. A module of the page: `page` hands it
// {state, live, $}.

export function createCamera(page) {
  const { state, live, $ } = page;
  let cam = null;

  function loadTracker() {
    if (window.FaceMesh) return Promise.resolve();
    return new Promise((resolve, reject) => {
      const s = document.createElement('script');
      s.src = 'vendor/face_mesh/face_mesh.js';
      s.onload = resolve;
      s.onerror = () => reject(new Error('the camera needs the face tracker, which this server does not serve (.ci/dev start installs it)'));
      document.head.append(s);
    });
  }

  async function start() {
    if (!live.open) throw new Error('the camera drives the face over the live socket, which is not open');
    $('say-state').textContent = 'loading the face tracker\u2026';
    await loadTracker();
    const mesh = new window.FaceMesh({ locateFile: (f) => `vendor/face_mesh/${f}` });
    mesh.setOptions({ maxNumFaces: 1, refineLandmarks: true, minDetectionConfidence: 0.5, minTrackingConfidence: 0.5 });
    await mesh.initialize();  // Before the camera: its first frames are the face at rest.
    let stream;
    try {
      stream = await navigator.mediaDevices.getUserMedia({ video: { width: 640, height: 480 } });
    } catch (e) {
      mesh.close();
      $('say-state').textContent = '';
      throw new Error(`no camera: ${e.message}`);
    }
    const video = document.createElement('video');
    Object.assign(video, { muted: true, playsInline: true, srcObject: stream });
    await video.play();
    cam = { stream, video, mesh, neutral: true, frames: 0, found: 0 };
    state.cameraLog = [];
    state.cameraPoints = [];  // The landmarks sent (the last 900 frames), as POST /capture takes them.
    mesh.onResults((r) => {
      if (!cam || cam.mesh !== mesh) return;
      ++cam.frames;
      const face = r.multiFaceLandmarks && r.multiFaceLandmarks[0];
      if (!face || !live.open) return;
      const w = video.videoWidth, h = video.videoHeight;
      const points = face.map((p) => [Math.round(p.x * w * 100) / 100, Math.round(p.y * h * 100) / 100, Math.round(p.z * w * 100) / 100]);
      const landmarks = { scheme: points.length === 478 ? 'mediapipe-478' : 'mediapipe-468', image: [w, h], points };
      if (cam.neutral) landmarks.neutral = true;
      cam.neutral = false;
      live.landmarks(landmarks, cam.frameAt, cam.frameTag);
      state.cameraPoints.push({ t: cam.frameAt, tag: cam.frameTag, image: [w, h], points });
      if (state.cameraPoints.length > 900) state.cameraPoints.shift();
      state.cameraFrames = ++cam.found;  // Counted for the browser test.
      $('say-state').textContent = `camera: ${cam.found} of ${cam.frames} frames found a face`;
    });
    const loop = async () => {
      if (!cam || cam.mesh !== mesh) return;
      if (video.readyState >= 2) {
        cam.frameAt = performance.now();  // The frame's time: what its results are stamped with.
        // A test's reader of the frame's own number (a video that carries one; camera_test.mjs).
        const hook = window.facespace && window.facespace.cameraHook;
        cam.frameTag = hook ? hook(video) : undefined;
        await mesh.send({ image: video });
      }
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
    $('say-cam').classList.add('on');
  }

  function stop() {
    if (!cam) return;
    cam.stream.getTracks().forEach((t) => t.stop());
    cam.mesh.close();
    cam = null;
    $('say-cam').classList.remove('on');
    $('say-state').textContent = '';
    const log = state.cameraLog || [];
    if (log.length < 2) return;
    // The recording as a motion: a button to save its keys (seconds from its first frame).
    const save = document.createElement('button');
    save.type = 'button';
    save.textContent = `save the recording (${((log[log.length - 1].t - log[0].t) / 1000).toFixed(1)} s)`;
    save.addEventListener('click', () => {
      const keys = log.map((e) => ({ time: +((e.t - log[0].t) / 1000).toFixed(3), weights: e.weights }));
      const a = document.createElement('a');
      a.href = URL.createObjectURL(new Blob([JSON.stringify({ keys }, null, 1)], { type: 'application/json' }));
      a.download = `${state.ready}.camera.json`;
      a.click();
      setTimeout(() => URL.revokeObjectURL(a.href), 1000);
    });
    $('say-state').append(save);
  }

  return { toggle: () => (cam ? Promise.resolve(stop()) : start()), stop, get on() { return cam !== null; } };
}
