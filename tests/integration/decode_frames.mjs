// Decodes the live socket's delta frames as a browser would, with meshoptimizer's own JavaScript
// decoder (npm meshoptimizer), and compares each with the float32 frame of the same point.
//   node decode_frames.mjs NODE_MODULES DIR   (DIR/frames.json: [{"tag", "delta", "f32"}, ...])
// Prints {"frames", "worst", "diagonal"}: the largest distance of a vertex from its float32 place.
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { pathToFileURL } from 'node:url';

const [modules, dir] = process.argv.slice(2);
const { MeshoptDecoder } = await import(pathToFileURL(join(modules, 'meshoptimizer/meshopt_decoder.module.js')).href);
await MeshoptDecoder.ready;

const list = JSON.parse(readFileSync(join(dir, 'frames.json'), 'utf8'));
let held = null, worst = 0, diagonal = 0, frames = 0;
for (const f of list) {
  const bytes = readFileSync(join(dir, f.delta));
  const buf = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.length);
  const head = new DataView(buf, 16, 24);
  const n = head.getUint32(0, true), codec = head.getUint32(4, true), step = head.getFloat32(8, true);
  const origin = [head.getFloat32(12, true), head.getFloat32(16, true), head.getFloat32(20, true)];
  const got = new Int16Array(4 * n);
  const body = new Uint8Array(buf, 40);
  if (codec === 1) MeshoptDecoder.decodeVertexBuffer(new Uint8Array(got.buffer), n, 8, body);
  else got.set(new Int16Array(buf.slice(40)));
  if (f.tag === 'dkey') held = new Int16Array(4 * n);
  if (!held) throw new Error('a delta before a keyframe');
  for (let i = 0; i < 4 * n; ++i) held[i] += got[i];
  const f32b = readFileSync(join(dir, f.f32));
  const p = new Float32Array(f32b.buffer.slice(f32b.byteOffset + 16, f32b.byteOffset + 16 + 12 * n));
  if (!diagonal) {
    const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    for (let v = 0; v < n; ++v) for (let k = 0; k < 3; ++k) { lo[k] = Math.min(lo[k], p[3 * v + k]); hi[k] = Math.max(hi[k], p[3 * v + k]); }
    diagonal = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  }
  for (let v = 0; v < n; ++v) {
    const d = Math.hypot(origin[0] + step * held[4 * v] - p[3 * v], origin[1] + step * held[4 * v + 1] - p[3 * v + 1],
      origin[2] + step * held[4 * v + 2] - p[3 * v + 2]);
    worst = Math.max(worst, d);
  }
  ++frames;
}
console.log(JSON.stringify({ frames, worst, diagonal }));
