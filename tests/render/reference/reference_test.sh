#!/usr/bin/env bash
# Our renders against three.js's (a reference renderer, npm) on the glTF sample assets and the
# bundled rigs: the real service on loopback, three.js in Debian's headless Chromium, the same
# files, weights and camera. Checks per asset that the silhouettes agree (intersection over union
# >= 0.97: geometry, morph targets, skins and camera) and that the model's mean linear colour has the
# same chromaticity (within 0.04: materials, textures, colour spaces) and a brightness within a stop
# either way (the two studios' lights differ). Writes OUT_DIR/NAME.ours.png, NAME.three.png and sheet.png (ours on
# the left of each pair) for a person to look at.
# usage: reference_test.sh FACESPACE_BINARY SOURCE_DIR SHARED_ASSETS NODE_MODULES_DIR OUT_DIR
set -u
bin=$1; src=$2; shared=$3; node_modules=$4; out=$5
. "$src/tests/integration/testlib.sh"
mkdir -p "$out"
tmp=$(mktemp -d); pid=
cleanup() { [ -n "$pid" ] && kill "$pid" 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
if [ ! -x /usr/bin/chromium ] || [ ! -d "$node_modules/playwright-core" ] || [ ! -d "$node_modules/three" ]; then
  echo "FAIL chromium, playwright-core or three ($node_modules) is missing: run .ci/dev test"; exit 1
fi
# The store: each sample in a folder named as a rig id (lower case), the bundled rigs beside.
store=$tmp/store
mkdir -p "$store"
for d in MorphStressTest MorphPrimitivesTest AnimatedMorphSphere AnimatedMorphCube Fox CesiumMan; do
  cp -r "$shared/real/$d" "$store/$(echo "$d" | tr 'A-Z' 'a-z')"
done
cp "$src/assets/facecap/facecap.glb" "$src/assets/facecap/facecap.manifest.json" "$src/assets/makehuman/makehuman.glb" \
  "$src/assets/makehuman/makehuman.manifest.json" "$store/"
port=$(python3 -c 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])')
"$bin" serve --port "$port" --rigs "$store" --quiet >"$tmp/log" 2>&1 &
pid=$!
for _ in $(seq 1 100); do curl -fs "http://127.0.0.1:$port/readyz" >/dev/null 2>&1 && break; sleep 0.1; done
cat >"$tmp/cases.json" <<'CASES'
[
 {"name": "stress", "id": "morphstresstest", "file": "morphstresstest/MorphStressTest.gltf", "weights": {"Key 3": 1, "Key 6": 0.5}, "yaw": 30, "pitch": 20},
 {"name": "primitives", "id": "morphprimitivestest", "file": "morphprimitivestest/MorphPrimitivesTest.gltf", "weights": {"target_0": 1}, "yaw": 20, "pitch": 30},
 {"name": "sphere", "id": "animatedmorphsphere", "file": "animatedmorphsphere/AnimatedMorphSphere.gltf", "weights": {"Blob": 0.8}},
 {"name": "cube", "id": "animatedmorphcube", "file": "animatedmorphcube/AnimatedMorphCube.gltf", "weights": {"thin": 0.5}, "yaw": 30, "pitch": 20},
 {"name": "fox", "id": "fox", "file": "fox/Fox.glb", "yaw": 90, "pitch": 10},
 {"name": "cesiumman", "id": "cesiumman", "file": "cesiumman/CesiumMan.gltf", "yaw": 30},
 {"name": "facecap", "id": "facecap", "file": "facecap.glb", "weights": {"jawOpen": 0.6, "mouthSmile_L": 0.8, "mouthSmile_R": 0.8}, "yaw": 25, "pitch": 10},
 {"name": "makehuman", "id": "makehuman", "file": "makehuman.glb", "weights": {"nose-trans-down": 1}}
]
CASES
cp "$src/tests/render/reference/compare.mjs" "$node_modules/../reference_compare.mjs"
node "$node_modules/../reference_compare.mjs" "http://127.0.0.1:$port" "$store" "$node_modules/three" "$out" <"$tmp/cases.json" >"$tmp/results" 2>"$tmp/err"
check "the comparison ran (three.js in Chromium, our render route)" test -s "$tmp/results"
[ -s "$tmp/err" ] && tail -5 "$tmp/err"
printf '%-11s %6s %9s %9s %10s\n' asset iou chroma bright colour
while read -r line; do
  name=$(py 'import json,sys; print(json.loads(sys.argv[1]).get("name","?"))' "$line")
  py 'import json,sys; d=json.loads(sys.argv[1]); print("%-11s %6s %9s %9s %10s" % (d.get("name","errors"), d.get("iou"), d.get("chroma_diff"), d.get("brightness"), d.get("colour_diff")) if "iou" in d else d)' "$line"
  check "$name: silhouettes agree (IoU >= 0.97)" py 'import json,sys; sys.exit(not json.loads(sys.argv[1]).get("iou",0)>=0.97)' "$line"
  check "$name: same chromaticity (within 0.04), brightness within a stop" py 'import json,sys; d=json.loads(sys.argv[1]); sys.exit(not(d.get("chroma_diff",1)<=0.04 and 0.5<=d.get("brightness",0)<=2))' "$line"
  [ -f "$out/$name.ours.png" ] && oiiotool "$out/$name.ours.png" "$out/$name.three.png" --mosaic 2x1 -o "$tmp/pair_$name.png" 2>/dev/null
done <"$tmp/results"
check "eight assets compared" test "$(grep -c '"iou"' "$tmp/results")" -eq 8
ls "$tmp"/pair_*.png >/dev/null 2>&1 && oiiotool "$tmp"/pair_*.png --mosaic 2x4 -o "$out/sheet.png" 2>/dev/null
finish
