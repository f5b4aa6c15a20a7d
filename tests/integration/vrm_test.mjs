// Loads a VRM of ours in three.js with @pixiv/three-vrm (as a web avatar app would) and checks it
// against facespace's own meshes:
//   node vrm_test.mjs FILE.vrm DIR [--v0] [--avatar]
// DIR holds rest.json and EXPRESSION.json for each expression to check (facespace blend --format json,
// world space). Checks: the humanoid's required bones are found, every expression of the files is
// there, and setting one to 1 moves the vertices to where facespace puts them (within 1e-5 of the
// bounding box's diagonal). --v0: a VRM 0.x, turned to face +z as apps do (VRMUtils.rotateVRM0) before
// comparing. --avatar (vrm_avatar.mjs): its terms, springs (the hair swings after the head turns and comes
// to rest), colliders, node constraints (evaluated) and MToon materials. Prints one line per check; exit 0
// when all hold.
import fs from 'node:fs';
import path from 'node:path';
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { VRMLoaderPlugin, VRMUtils } from '@pixiv/three-vrm';
import { checkAvatar } from './vrm_avatar.mjs';

const [file, dir] = process.argv.slice(2).filter((a) => !a.startsWith('--'));
const v0 = process.argv.includes('--v0');
const bytes = fs.readFileSync(file);
const loader = new GLTFLoader();
// Node has no image decoder: every image is an empty texture (what binds do to a texture is still seen).
loader.register((parser) => { parser.loadImageSource = () => Promise.resolve(new THREE.Texture()); return { name: 'no_image_decoding' }; });
loader.register((parser) => new VRMLoaderPlugin(parser));
const gltf = await loader.parseAsync(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength), '');
const vrm = gltf.userData.vrm;
let bad = 0;
const fail = (msg) => { console.log('FAIL ' + msg); bad = 1; };
if (!vrm) { console.log('FAIL no VRM in the file'); process.exit(1); }
console.log(`VRM ${vrm.meta.metaVersion}: "${vrm.meta.name ?? vrm.meta.title}", licence ${vrm.meta.licenseUrl ?? vrm.meta.licenseName}`);
if (v0 !== (vrm.meta.metaVersion === '0')) fail(`meta version ${vrm.meta.metaVersion}, expected ${v0 ? '0' : '1'}`);
if (v0) VRMUtils.rotateVRM0(vrm);

const required = ['hips', 'spine', 'head', 'leftUpperArm', 'leftLowerArm', 'leftHand', 'rightUpperArm', 'rightLowerArm', 'rightHand',
  'leftUpperLeg', 'leftLowerLeg', 'leftFoot', 'rightUpperLeg', 'rightLowerLeg', 'rightFoot'];
const found = required.filter((b) => vrm.humanoid.getRawBoneNode(b));
console.log(`humanoid: ${found.length} of ${required.length} required bones found`);
if (found.length !== required.length) fail('missing bones: ' + required.filter((b) => !found.includes(b)).join(', '));

// Every primitive's vertices in world space, in glTF mesh and primitive order (facespace's JSON order).
const meshes = [];
vrm.scene.traverse((o) => {
  if (!o.isMesh) return;
  const a = gltf.parser.associations.get(o) || {};
  meshes.push({ o, key: (a.meshes ?? 0) * 10000 + (a.primitives ?? 0) });
});
meshes.sort((x, y) => x.key - y.key);
function positions() {
  vrm.scene.updateMatrixWorld(true);
  const out = [];
  const v = new THREE.Vector3();
  for (const { o } of meshes) {
    const n = o.geometry.attributes.position.count;
    const p = new Float64Array(3 * n);
    for (let i = 0; i < n; ++i) {
      o.getVertexPosition(i, v);
      v.applyMatrix4(o.matrixWorld);
      p[3 * i] = v.x; p[3 * i + 1] = v.y; p[3 * i + 2] = v.z;
    }
    out.push(p);
  }
  return out;
}
const ours = (name) => JSON.parse(fs.readFileSync(path.join(dir, name + '.json'), 'utf8')).primitives.map((p) => p.positions);

const rest = ours('rest');
if (rest.length !== meshes.length) fail(`${meshes.length} meshes in three.js, ${rest.length} primitives of ours`);
const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
for (const p of rest) for (let i = 0; i < p.length; ++i) { lo[i % 3] = Math.min(lo[i % 3], p[i]); hi[i % 3] = Math.max(hi[i % 3], p[i]); }
const diagonal = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
const tolerance = 1e-5 * diagonal;

function compare(label, theirs, mine) {
  let worst = 0, moved = 0;
  for (let k = 0; k < mine.length && k < theirs.length; ++k) {
    if (mine[k].length !== theirs[k].length) { fail(`${label}: primitive ${k} has ${theirs[k].length / 3} vertices in three.js, ${mine[k].length / 3} of ours`); return; }
    for (let i = 0; i < mine[k].length; ++i) {
      worst = Math.max(worst, Math.abs(theirs[k][i] - mine[k][i]));
      moved = Math.max(moved, Math.abs(mine[k][i] - rest[k][i]));
    }
  }
  const ok = worst <= tolerance;
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${label}: moves up to ${moved.toExponential(3)}, three-vrm differs by ${worst.toExponential(3)} (tolerance ${tolerance.toExponential(3)})`);
  if (!ok) bad = 1;
}

vrm.update(0);
compare('rest', positions(), rest);
const names = fs.readdirSync(dir).filter((f) => f.endsWith('.json') && f !== 'rest.json').map((f) => f.slice(0, -5)).sort();
for (const name of names) {
  if (!vrm.expressionManager.getExpression(name)) { fail(`expression ${name} is not in the VRM`); continue; }
  vrm.expressionManager.resetValues();
  vrm.expressionManager.setValue(name, 1);
  vrm.update(0);
  compare(name, positions(), ours(name));
}
vrm.expressionManager.resetValues();
console.log(`${names.length} expressions checked; ${Object.keys(vrm.expressionManager.expressionMap).length} in the VRM`);
if (process.argv.includes('--avatar') && !checkAvatar(vrm, gltf, v0, meshes)) bad = 1;
// --binds: what "tint" and "slide" (vrm_edit.py binds) do to the face material (glTF material 1) at 1, as JSON.
if (process.argv.includes('--binds')) {
  const name = gltf.parser.json.materials[1].name;
  const face = meshes.flatMap(({ o }) => (Array.isArray(o.material) ? o.material : [o.material])).find((m) => m.name === name);
  if (!face) fail('no three.js material for glTF material 1');
  else {
    const seen = {};
    for (const name of ['tint', 'slide']) {
      vrm.expressionManager.resetValues();
      vrm.expressionManager.setValue(name, 1);
      vrm.update(0);
      seen[name] = { color: face.color.toArray(), offset: face.map ? face.map.offset.toArray() : null, repeat: face.map ? face.map.repeat.toArray() : null };
    }
    vrm.expressionManager.resetValues();
    console.log('binds: ' + JSON.stringify(seen));
  }
}
process.exit(bad);
