// Our renders beside three.js's (npm, pinned: GLTFLoader, physically based materials under its
// RoomEnvironment studio light, Khronos PBR Neutral tone mapping, sRGB out) in headless Chromium,
// the same glTF, weights and camera for both. Per asset: the silhouettes' overlap (intersection over
// union: geometry, morphs, skin and camera agree) and the mean linear colour of the model's pixels
// in each (materials and textures agree; the lights differ, so colours are near, not equal). Writes
// NAME.ours.png and NAME.three.png to OUT_DIR and one JSON line per asset to stdout.
// usage: node compare.mjs SERVICE_URL ASSETS_DIR THREE_DIR OUT_DIR < cases.json
import { chromium } from 'playwright-core';
import fs from 'node:fs';
import path from 'node:path';

const [service, assets, threeDir, outDir] = process.argv.slice(2);
const cases = JSON.parse(fs.readFileSync(0, 'utf8'));
const size = 256, fov = 30, background = [1, 0, 1];  // Magenta: no model here has it, so the silhouettes are exact.

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist'],
});
const page = await browser.newPage({ viewport: { width: size, height: size } });
const errors = [];
page.on('pageerror', (e) => errors.push(e.message));
// A made-up origin whose files come from disk: three's modules and the assets.
const types = { '.js': 'text/javascript', '.html': 'text/html', '.gltf': 'model/gltf+json', '.glb': 'model/gltf-binary',
  '.bin': 'application/octet-stream', '.png': 'image/png', '.jpg': 'image/jpeg', '.jpeg': 'image/jpeg' };
await page.route('http://ref.test/**', (route) => {
  const url = new URL(route.request().url());
  const rel = decodeURIComponent(url.pathname);
  const file = rel === '/' ? null : rel.startsWith('/three/') ? path.join(threeDir, rel.slice(7)) : path.join(assets, rel.slice(8));
  if (!file) return route.fulfill({ contentType: 'text/html', body: '<!doctype html><body style="margin:0"></body>' });
  if (!fs.existsSync(file)) return route.fulfill({ status: 404, body: 'not found' });
  route.fulfill({ contentType: types[path.extname(file).toLowerCase()] || 'application/octet-stream', body: fs.readFileSync(file) });
});
await page.goto('http://ref.test/');
await page.addScriptTag({ type: 'importmap', content: JSON.stringify({ imports: {
  three: 'http://ref.test/three/build/three.module.js', 'three/addons/': 'http://ref.test/three/examples/jsm/' } }) });

for (const c of cases) {
  // three.js: load, set the weights by target name, frame the model's box from (yaw, pitch).
  const order = (await (await fetch(`${service}/v1/rigs/${c.id}`)).json()).shapes.map((s) => s.name);
  const three = await page.evaluate(async ({ c, order, size, fov, background }) => {
    const THREE = await import('three');
    const { GLTFLoader } = await import('three/addons/loaders/GLTFLoader.js');
    const { KTX2Loader } = await import('three/addons/loaders/KTX2Loader.js');
    const { MeshoptDecoder } = await import('three/addons/libs/meshopt_decoder.module.js');
    const { RoomEnvironment } = await import('three/addons/environments/RoomEnvironment.js');
    const canvas = document.createElement('canvas');
    const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    const ktx2 = new KTX2Loader().setTranscoderPath('http://ref.test/three/examples/jsm/libs/basis/').detectSupport(renderer);
    const loader = new GLTFLoader().setKTX2Loader(ktx2).setMeshoptDecoder(MeshoptDecoder);
    const gltf = await loader.loadAsync('http://ref.test/assets/' + c.file);
    const scene = new THREE.Scene();
    scene.add(gltf.scene);
    scene.background = new THREE.Color().setRGB(...background, THREE.SRGBColorSpace);
    gltf.scene.traverse((o) => {
      if (!o.morphTargetDictionary) return;
      o.morphTargetInfluences.fill(0);
      for (const [name, w] of Object.entries(c.weights || {})) {
        // A target the file leaves unnamed in mesh.extras.targetNames has a number for a name in
        // three and ours from elsewhere (its accessor's name, or 'target_N'): our index then.
        const k = name in o.morphTargetDictionary ? o.morphTargetDictionary[name] : order.indexOf(name);
        if (k >= 0 && k < o.morphTargetInfluences.length) o.morphTargetInfluences[k] = w;
      }
    });
    gltf.scene.updateMatrixWorld(true);
    const box = new THREE.Box3().setFromObject(gltf.scene, true);
    const center = box.getCenter(new THREE.Vector3());
    const radius = box.getSize(new THREE.Vector3()).length() / 2;
    const dist = radius / Math.sin(THREE.MathUtils.degToRad(fov) / 2);
    const yaw = THREE.MathUtils.degToRad(c.yaw || 0), pitch = THREE.MathUtils.degToRad(c.pitch || 0);
    const eye = center.clone().add(new THREE.Vector3(Math.cos(pitch) * Math.sin(yaw), Math.sin(pitch), Math.cos(pitch) * Math.cos(yaw)).multiplyScalar(dist));
    const camera = new THREE.PerspectiveCamera(fov, 1, dist / 100, dist * 10);
    camera.position.copy(eye);
    camera.lookAt(center);
    renderer.setPixelRatio(1);
    renderer.setSize(size, size);
    renderer.toneMapping = THREE.NeutralToneMapping;
    renderer.outputColorSpace = THREE.SRGBColorSpace;
    const pmrem = new THREE.PMREMGenerator(renderer);
    scene.environment = pmrem.fromScene(new RoomEnvironment(), 0.04).texture;
    renderer.render(scene, camera);
    const png = canvas.toDataURL('image/png');
    renderer.dispose();
    return { png, eye: eye.toArray(), target: center.toArray() };
  }, { c, order, size, fov, background });
  // Ours: the render route, the same camera.
  const body = { weights: c.weights || {}, width: size, height: size, supersample: 2, background: '#ff00ff',
    camera: { eye: three.eye, target: three.target, fov } };
  const res = await fetch(`${service}/v1/rigs/${c.id}/render`, { method: 'POST', headers: { 'Content-Type': 'application/json', Accept: 'image/png' }, body: JSON.stringify(body) });
  const ours = Buffer.from(await res.arrayBuffer());
  if (res.status !== 200) { console.log(JSON.stringify({ name: c.name, error: `render ${res.status}: ${ours.toString().slice(0, 300)}` })); continue; }
  fs.writeFileSync(path.join(outDir, c.name + '.ours.png'), ours);
  fs.writeFileSync(path.join(outDir, c.name + '.three.png'), Buffer.from(three.png.split(',')[1], 'base64'));
  // Compare in the page: masks (pixels away from the background), overlap, mean colours.
  const m = await page.evaluate(async ({ a, b, background }) => {
    const load = async (src) => { const i = new Image(); i.src = src; await i.decode(); const cv = document.createElement('canvas');
      cv.width = i.width; cv.height = i.height; const x = cv.getContext('2d'); x.drawImage(i, 0, 0); return x.getImageData(0, 0, i.width, i.height).data; };
    const pa = await load(a), pb = await load(b);
    const bg = background.map((v) => Math.round(v * 255));
    const on = (p, i) => Math.max(Math.abs(p[i] - bg[0]), Math.abs(p[i + 1] - bg[1]), Math.abs(p[i + 2] - bg[2])) > 60;
    // Means in linear light, so the chromaticity does not move with the level of the light.
    const linear = (v) => { v /= 255; return v <= 0.04045 ? v / 12.92 : Math.pow((v + 0.055) / 1.055, 2.4); };
    let both = 0, either = 0, na = 0, nb = 0; const sa = [0, 0, 0], sb = [0, 0, 0];
    for (let i = 0; i < pa.length; i += 4) {
      const ia = on(pa, i), ib = on(pb, i);
      both += ia && ib; either += ia || ib;
      if (ia) { na++; for (let k = 0; k < 3; k++) sa[k] += linear(pa[i + k]); }
      if (ib) { nb++; for (let k = 0; k < 3; k++) sb[k] += linear(pb[i + k]); }
    }
    return { iou: both / Math.max(1, either), pixels: [na, nb], ours: sa.map((s) => s / Math.max(1, na)), three: sb.map((s) => s / Math.max(1, nb)) };
  }, { a: 'data:image/png;base64,' + ours.toString('base64'), b: three.png, background });
  const diff = Math.max(...m.ours.map((v, k) => Math.abs(v - m.three[k])));
  // Chromaticity (each channel over the sum): the lights' levels cancel, a wrong colour or texture shows.
  const chroma = (c) => c.map((v) => v / Math.max(1e-6, c[0] + c[1] + c[2]));
  const [ca, cb] = [chroma(m.ours), chroma(m.three)];
  const chromaDiff = Math.max(...ca.map((v, k) => Math.abs(v - cb[k])));
  const brightness = (m.ours[0] + m.ours[1] + m.ours[2]) / Math.max(1e-6, m.three[0] + m.three[1] + m.three[2]);
  const r3 = (v) => Math.round(v * 1000) / 1000;
  console.log(JSON.stringify({ name: c.name, iou: r3(m.iou), pixels: m.pixels, ours: m.ours.map(r3), three: m.three.map(r3), colour_diff: r3(diff), chroma_diff: r3(chromaDiff), brightness: r3(brightness) }));
}
if (errors.length) console.log(JSON.stringify({ errors }));
await browser.close();
