// Rewrites FaceCap's glb with its texture as a JPEG: the original carries it as KTX2 (Basis
// Universal, KHR_texture_basisu), which nothing in Debian decodes. three.js's Basis transcoder
// (npm `three`, pinned in .ci/dev) decodes it in headless Chromium to RGBA; the page encodes
// that as a JPEG. The glb is otherwise the same bytes: the image points at a new buffer view at
// the end of the binary chunk, the texture names it directly, KHR_texture_basisu is no longer
// used. The KTX2 bytes stay in the binary chunk unused (removing them would renumber the
// meshopt-compressed buffer views).
// usage: node make_jpeg_texture.mjs IN.glb OUT.glb NODE_MODULES_DIR
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';

const [input, output, modules] = process.argv.slice(2);
const { chromium } = createRequire(path.join(path.resolve(modules), 'x.js'))('playwright-core');
const threeDir = path.join(modules, 'three');

const glb = fs.readFileSync(input);
const jsonLength = glb.readUInt32LE(12);
const json = JSON.parse(glb.subarray(20, 20 + jsonLength).toString('utf8'));
const binStart = 20 + jsonLength + 8;
const bin = glb.subarray(binStart, binStart + glb.readUInt32LE(20 + jsonLength));
if (json.images.length !== 1 || json.images[0].mimeType !== 'image/ktx2') throw new Error('expected one KTX2 image');
const view = json.bufferViews[json.images[0].bufferView];
const ktx2 = bin.subarray(view.byteOffset || 0, (view.byteOffset || 0) + view.byteLength);

const browser = await chromium.launch({ executablePath: process.env.CHROMIUM || '/usr/bin/chromium', args: ['--no-sandbox'] });
const page = await browser.newPage();
await page.route('http://ref.test/**', (route) => {
  const rel = decodeURIComponent(new URL(route.request().url()).pathname);
  if (rel === '/') return route.fulfill({ contentType: 'text/html', body: '<!doctype html><body></body>' });
  route.fulfill({ contentType: rel.endsWith('.js') ? 'text/javascript' : 'application/wasm', body: fs.readFileSync(path.join(threeDir, rel.slice(7))) });
});
await page.goto('http://ref.test/');
await page.addScriptTag({ type: 'importmap', content: JSON.stringify({ imports: {
  three: 'http://ref.test/three/build/three.module.js', 'three/addons/': 'http://ref.test/three/examples/jsm/' } }) });
const result = await page.evaluate(async (bytes) => {
  const { KTX2Loader } = await import('three/addons/loaders/KTX2Loader.js');
  const loader = new KTX2Loader().setTranscoderPath('http://ref.test/three/examples/jsm/libs/basis/');
  // No GPU format: the transcoder writes plain RGBA8.
  loader.workerConfig = { astcSupported: false, astcHDRSupported: false, etc1Supported: false, etc2Supported: false,
    dxtSupported: false, bptcSupported: false, pvrtcSupported: false };
  const buffer = new Uint8Array(bytes).buffer;
  const texture = await new Promise((resolve, reject) => loader.parse(buffer, resolve, reject));
  const { data, width, height } = texture.mipmaps[0];
  const canvas = document.createElement('canvas');
  canvas.width = width; canvas.height = height;
  let opaque = true;
  for (let i = 3; i < data.length; i += 4) opaque &&= data[i] === 255;
  canvas.getContext('2d').putImageData(new ImageData(new Uint8ClampedArray(data.buffer, data.byteOffset, data.byteLength), width, height), 0, 0);
  return { jpeg: canvas.toDataURL('image/jpeg', 0.92), width, height, opaque, format: texture.format };
}, Array.from(ktx2));
await browser.close();
if (!result.opaque) throw new Error('the texture has alpha: a JPEG cannot keep it');
const jpeg = Buffer.from(result.jpeg.split(',')[1], 'base64');

const pad = (n) => (4 - (n % 4)) % 4;
const offset = bin.length + pad(bin.length);
const newBin = Buffer.concat([bin, Buffer.alloc(pad(bin.length)), jpeg, Buffer.alloc(pad(jpeg.length))]);
json.bufferViews.push({ buffer: 0, byteOffset: offset, byteLength: jpeg.length });
json.buffers[0].byteLength = newBin.length;
json.images[0] = { bufferView: json.bufferViews.length - 1, mimeType: 'image/jpeg' };
for (const t of json.textures) {
  if (t.extensions && t.extensions.KHR_texture_basisu) { t.source = t.extensions.KHR_texture_basisu.source; delete t.extensions.KHR_texture_basisu; }
  if (t.extensions && Object.keys(t.extensions).length === 0) delete t.extensions;
}
json.extensionsUsed = (json.extensionsUsed || []).filter((e) => e !== 'KHR_texture_basisu');
json.extensionsRequired = (json.extensionsRequired || []).filter((e) => e !== 'KHR_texture_basisu');
let text = Buffer.from(JSON.stringify(json), 'utf8');
text = Buffer.concat([text, Buffer.alloc(pad(text.length), 0x20)]);
const header = Buffer.alloc(12);
header.write('glTF', 0); header.writeUInt32LE(2, 4); header.writeUInt32LE(12 + 8 + text.length + 8 + newBin.length, 8);
const chunk = (len, type) => { const b = Buffer.alloc(8); b.writeUInt32LE(len, 0); b.write(type, 4); return b; };
fs.writeFileSync(output, Buffer.concat([header, chunk(text.length, 'JSON'), text, chunk(newBin.length, 'BIN\0'), newBin]));
console.log(`${input}: KTX2 ${ktx2.length} bytes -> JPEG ${result.width}x${result.height}, ${jpeg.length} bytes -> ${output}`);
