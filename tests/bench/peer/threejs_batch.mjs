// The three.js peer of `facespace batch`: the same rig, the same weight vectors (read from our
// batch's manifest.jsonl), blended on the CPU with three's own morph evaluation
// (Mesh.getVertexPosition; normals by the same sum over morphAttributes.normal) and written as glb
// by three's GLTFExporter, one file per variant, into OUT. Prints one JSON line of figures.
// usage: node threejs_batch.mjs RIG.glb MANIFEST.jsonl OUT
import fs from 'node:fs';
import path from 'node:path';
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { GLTFExporter } from 'three/examples/jsm/exporters/GLTFExporter.js';

// GLTFExporter reads its Blobs back with FileReader, which Node lacks.
globalThis.FileReader = class {
  readAsArrayBuffer(blob) {
    blob.arrayBuffer().then((buffer) => { this.result = buffer; this.onloadend(); });
  }
};

// three's notes about our attributes (interleaved copies, normals renormalized) on every export: off.
const report = console.log;
console.log = console.warn = () => {};

const [rigPath, manifestPath, out] = process.argv.slice(2);
const bytes = fs.readFileSync(rigPath);
const gltf = await new GLTFLoader().parseAsync(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.length), '');
const meshes = [];
gltf.scene.traverse((o) => { if (o.isMesh && o.geometry.morphAttributes.position) meshes.push(o); });
const variants = fs.readFileSync(manifestPath, 'utf8').trim().split('\n').map((l) => JSON.parse(l))
  .sort((a, b) => a.index - b.index);
fs.mkdirSync(out, { recursive: true });

// Each morphed mesh gets a blended twin in its place: the same node transform and material, its
// attributes without the morph targets. The rig's mesh stays for getVertexPosition, hidden, so
// the exporter (onlyVisible) writes the whole scene with the twins, as ours writes every mesh.
const copies = meshes.map((mesh) => {
  const g = new THREE.BufferGeometry();
  g.setIndex(mesh.geometry.index);
  for (const [name, attr] of Object.entries(mesh.geometry.attributes)) g.setAttribute(name, attr.clone());
  const twin = new THREE.Mesh(g, mesh.material);
  twin.name = mesh.name;
  twin.position.copy(mesh.position);
  twin.quaternion.copy(mesh.quaternion);
  twin.scale.copy(mesh.scale);
  mesh.parent.add(twin);
  mesh.visible = false;
  return g;
});
const scene = gltf.scene;
const exporter = new GLTFExporter();
const v = new THREE.Vector3();

const start = performance.now();
let written = 0;
for (const variant of variants) {
  meshes.forEach((mesh, i) => {
    const influences = mesh.morphTargetInfluences.fill(0);
    for (const [name, w] of Object.entries(variant.weights)) {
      const k = (mesh.morphTargetDictionary || {})[name];
      if (k !== undefined) influences[k] = w;
    }
    const pos = copies[i].attributes.position;
    for (let j = 0; j < pos.count; ++j) pos.setXYZ(j, ...mesh.getVertexPosition(j, v).toArray());
    const base = mesh.geometry.attributes.normal, nrm = copies[i].attributes.normal;
    const targets = mesh.geometry.morphAttributes.normal || [];
    for (let j = 0; j < nrm.count; ++j) {
      let x = base.getX(j), y = base.getY(j), z = base.getZ(j);
      for (let k = 0; k < targets.length; ++k) {
        const w = influences[k];
        if (w === 0) continue;
        x += w * targets[k].getX(j); y += w * targets[k].getY(j); z += w * targets[k].getZ(j);
      }
      const l = Math.hypot(x, y, z) || 1;
      nrm.setXYZ(j, x / l, y / l, z / l);
    }
    pos.needsUpdate = nrm.needsUpdate = true;
  });
  const glb = await exporter.parseAsync(scene, { binary: true });
  fs.writeFileSync(path.join(out, variant.file), Buffer.from(glb));
  written += glb.byteLength;
}
const seconds = (performance.now() - start) / 1000;
report(JSON.stringify({ variants: variants.length, seconds, ms_per_variant: 1000 * seconds / variants.length,
  kib_per_variant: written / variants.length / 1024, three: THREE.REVISION }));
