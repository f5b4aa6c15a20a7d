// vrm_test.mjs --avatar: what makes an avatar of ours play in VRM apps, checked in @pixiv/three-vrm.
//   terms:       the meta's usage terms, printed (the caller's grep holds them to the manifest's)
//   springs:     spring joints on the hair, ears, tail and skirt; colliders on the head and the body; after the
//                head turns 30 degrees, the hair lags behind the head's rigid turn (secondary motion) and within
//                1 s of vrm.update comes to rest
//   constraints: present, and evaluated: a source turned, its destination turns by the constraint's weight
//   materials:   MToon, with outlines where the model has edges
import * as THREE from 'three';

function say(ok, text) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${text}`);
  return ok;
}

function terms(vrm, v0) {
  const m = vrm.meta;
  if (v0) {
    console.log(`terms: allowedUser ${m.allowedUserName}, violent ${m.violentUssageName}, sexual ${m.sexualUssageName}, commercial ${m.commercialUssageName}, licence ${m.licenseName}`);
    return true;
  }
  console.log(`terms: violent ${m.allowExcessivelyViolentUsage}, sexual ${m.allowExcessivelySexualUsage}, antisocialOrHate ${m.allowAntisocialOrHateUsage}, ` +
    `politicalOrReligious ${m.allowPoliticalOrReligiousUsage}, credit ${m.creditNotation}, avatar ${m.avatarPermission}, commercial ${m.commercialUsage}, ` +
    `redistribution ${m.allowRedistribution}, modification ${m.modification}, thumbnail ${m.thumbnailImage ? m.thumbnailImage.width + 'x' + m.thumbnailImage.height : 'none'}`);
  return true;
}

// The vertices of the primitives drawn with `material` that are above `above` (world y) at rest, in `frame`'s
// space (the hair: her tail is drawn in the hair's material too, and follows her hips, not her head).
function verticesIn(meshes, material, frame, above) {
  const out = [];
  const v = new THREE.Vector3();
  const inverse = frame.matrixWorld.clone().invert();
  for (const { o } of meshes) {
    const mats = Array.isArray(o.material) ? o.material : [o.material];
    if (!mats.some((m) => m.name === material || m.name === material + ' (Outline)')) continue;
    for (let i = 0; i < o.geometry.attributes.position.count; ++i) {
      if (o.geometry.attributes.position.getY(i) < above) continue;
      o.getVertexPosition(i, v);
      v.applyMatrix4(o.matrixWorld).applyMatrix4(inverse);
      out.push(v.x, v.y, v.z);
    }
  }
  return out;
}
const largest = (a, b) => a.reduce((m, x, i) => Math.max(m, Math.abs(x - b[i])), 0);

function springs(vrm, meshes) {
  const sbm = vrm.springBoneManager;
  if (!say(!!sbm, 'a spring bone manager')) return false;
  const joints = [...sbm.joints].map((j) => j.bone.name);
  const count = (part) => joints.filter((n) => n.includes(part)).length;
  const colliders = [...sbm.colliders].map((c) => c.parent?.name ?? '');
  let ok = say(count('髪') >= 20 && count('耳') >= 2 && count('尾') >= 2 && count('裾') >= 6,
    `spring joints: ${joints.length} (hair ${count('髪')}, ears ${count('耳')}, tail ${count('尾')}, skirt ${count('裾')})`);
  ok = say(colliders.includes('頭') && colliders.some((n) => n.startsWith('上半身')) && colliders.length >= 10,
    `colliders: ${colliders.length}, on ${[...new Set(colliders)].slice(0, 8).join(', ')} ...`) && ok;
  // The hair's vertices (world) as the head's rigid turn would carry them: the swinging bones keep the turns
  // they had settled into; then what the springs make of the turn, frame by frame.
  const head = vrm.humanoid.getNormalizedBoneNode('head');
  const neck = vrm.humanoid.getRawBoneNode('neck') ?? vrm.humanoid.getRawBoneNode('head');
  vrm.scene.updateMatrixWorld(true);
  const shoulders = neck.getWorldPosition(new THREE.Vector3()).y - 0.1;
  const hair = () => { vrm.scene.updateMatrixWorld(true); return verticesIn(meshes, '髪', vrm.scene, shoulders); };
  for (let i = 0; i < 180; ++i) vrm.update(1 / 60);  // Settle under gravity before the turn.
  const swinging = [...sbm.joints].map((j) => [j.bone, j.bone.quaternion.clone()]);
  head.rotation.y = Math.PI / 6;
  vrm.humanoid.update();
  for (const [bone, q] of swinging) bone.quaternion.copy(q);
  const rigid = hair();
  let lag = 0, previous = rigid, last = 0;
  for (let i = 0; i < 60; ++i) {
    vrm.update(1 / 60);
    const now = hair();
    lag = Math.max(lag, largest(now, rigid));
    last = largest(now, previous);
    previous = now;
  }
  const rest = largest(previous, rigid);
  ok = say(rigid.length > 0 && lag > 0.005 && last < 2e-4 && rest < 0.2 * lag,
    `secondary motion: after a 30° head turn the hair leaves the head's rigid turn by up to ${(lag * 1000).toFixed(1)} mm; ` +
    `after 1 s it moves ${(last * 1000).toFixed(3)} mm a frame, ${(rest * 1000).toFixed(2)} mm from the rigid turn (${rigid.length / 3} vertices)`) && ok;
  head.rotation.y = 0;
  for (let i = 0; i < 120; ++i) vrm.update(1 / 60);
  return ok;
}

function constraints(vrm) {
  const ncm = vrm.nodeConstraintManager;
  const list = ncm ? [...ncm.constraints] : [];
  if (!say(list.length >= 2, `node constraints: ${list.length} (${list.map((c) => `${c.destination.name} <- ${c.source.name} x${c.weight}`).join(', ')})`)) return false;
  let ok = true;
  for (const c of list) {
    const before = c.destination.quaternion.clone();
    c.source.rotateY(0.5);
    vrm.update(0);
    const turned = before.angleTo(c.destination.quaternion);
    c.source.rotateY(-0.5);
    vrm.update(0);
    ok = say(Math.abs(turned - 0.5 * c.weight) < 1e-4, `constraint ${c.destination.name}: its source turned 0.5 rad, it turned ${turned.toFixed(5)} (weight ${c.weight})`) && ok;
  }
  return ok;
}

function materials(vrm) {
  const all = vrm.materials ?? [];
  const toon = all.filter((m) => m.isMToonMaterial && !m.isOutline);
  const outlines = all.filter((m) => m.isMToonMaterial && m.isOutline);
  return say(toon.length >= 8 && outlines.length >= 4, `MToon materials: ${toon.length}, with outlines: ${outlines.length}`);
}

export function checkAvatar(vrm, gltf, v0, meshes) {
  let ok = terms(vrm, v0);
  ok = springs(vrm, meshes) && ok;
  if (!v0) ok = constraints(vrm) && ok;
  ok = materials(vrm) && ok;
  return ok;
}
