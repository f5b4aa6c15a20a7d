#!/usr/bin/env bash
# End-to-end tests of the facespace command line on real assets.
# usage: cli_test.sh FACESPACE_BINARY SHARED_ASSETS_DIR SOURCE_DIR [NODE_MODULES_DIR]
set -u
bin=$1; A=$2/real; M=$2/more; src=$3; node_modules=${4:-}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
. "$(dirname "$0")/testlib.sh"

rig=$src/assets/facecap/facecap.glb
stress=$A/MorphStressTest/MorphStressTest.gltf

# info
"$bin" info "$rig" >"$tmp/info" 2>"$tmp/err"
check "info: exit 0 on the bundled rig" test $? -eq 0
check "info: lists jawOpen in group jaw with its partner column" grep -Eq '^ +24 +jawOpen +jaw' "$tmp/info"
check "info: the bundled FaceCap loads without a warning (its texture is a JPEG)" sh -c "! grep -q 'warning' '$tmp/err'"
"$bin" info "$A/FaceCap/facecap.glb" >/dev/null 2>"$tmp/err"
check "info: the original FaceCap's KTX2 texture is reported dropped" grep -q 'warning: texture_dropped: image 0 (image/ktx2)' "$tmp/err"
"$bin" info --json "$rig" 2>/dev/null >"$tmp/info.json"
check "info --json: 52 shapes, mouthSmile_L paired with mouthSmile_R, ARKit alias" \
  py 'import json,sys; d=json.load(open(sys.argv[1])); s={x["name"]:x for x in d["shapes"]}; sys.exit(not(len(d["shapes"])==52 and s["mouthSmile_L"]["partner"]=="mouthSmile_R" and s["mouthSmile_L"]["aliases"]==["mouthSmileLeft"] and d["vertices"]==4368))' "$tmp/info.json"

# every command: --help prints its usage and exits 0; an unknown flag and a bad value are usage errors (exit 2) with a message
for cmd in info blend render sheet sequence fit batch mirror compress convert serve; do
  "$bin" $cmd --help >"$tmp/help" 2>"$tmp/err"; rc=$?
  check "$cmd --help: usage on stdout, exit 0" sh -c "[ $rc -eq 0 ] && head -1 '$tmp/help' | grep -q '^usage: facespace $cmd' && grep -q -- '--help' '$tmp/help' && [ ! -s '$tmp/err' ]"
  "$bin" $cmd --bogus >"$tmp/out" 2>"$tmp/err"; rc=$?
  check "$cmd --bogus: exit 2 naming the option, with the usage" sh -c "[ $rc -eq 2 ] && grep -q \"unknown option '--bogus'\" '$tmp/err' && grep -q '^usage: facespace $cmd' '$tmp/err'"
done
for bad in "--fps 0" "--fps -3" "--reduce -1"; do
  "$bin" sequence "$rig" --keys '[{"time":0},{"time":1}]' $bad -o "$tmp/x.json" >"$tmp/out" 2>"$tmp/err"; rc=$?
  check "sequence $bad: exit 2 with a message naming the flag" sh -c "[ $rc -eq 2 ] && grep -q -- '${bad%% *}' '$tmp/err'"
done
"$bin" blend "$rig" --output="$tmp/eq.json" --set=jawOpen=0.5 2>/dev/null
check "flags take --flag=VALUE too" py 'import json,sys; d=json.load(open(sys.argv[1])); sys.exit(not len(d["primitives"]))' "$tmp/eq.json"

# blend: weights in every form give the same mesh
"$bin" blend "$stress" --weights '[0.5,0,0,0,0,0,0,0.25]' -o "$tmp/a.json" 2>/dev/null
"$bin" blend "$stress" --weights '{"Key 1":0.5,"Key 8":0.25}' -o "$tmp/b.json" 2>/dev/null
"$bin" blend "$stress" --set 'Key 1=0.5' --set 7=0.25 -o "$tmp/c.json" 2>/dev/null
echo '{"Key 1":0.5,"Key 8":0.25}' >"$tmp/w.json"
"$bin" blend "$stress" --weights @"$tmp/w.json" -o "$tmp/d.json" 2>/dev/null
check "blend: dense array, name map, --set (name and index) and @FILE agree byte for byte" \
  sh -c "cmp -s '$tmp/a.json' '$tmp/b.json' && cmp -s '$tmp/a.json' '$tmp/c.json' && cmp -s '$tmp/a.json' '$tmp/d.json'"
"$bin" blend "$stress" --weights '[0.5,0,0,0,0,0,0,0.25]' -o "$tmp/a2.json" 2>/dev/null
check "blend: deterministic output" cmp -s "$tmp/a.json" "$tmp/a2.json"
check "blend: JSON has 2 primitives of 24 and 1504 vertices with normals" \
  py 'import json,sys; d=json.load(open(sys.argv[1])); p=d["primitives"]; sys.exit(not(len(p)==2 and len(p[0]["positions"])==72 and len(p[1]["positions"])==4512 and len(p[1]["normals"])==4512 and p[1]["primitive"]==1 and d["warnings"]==[]))' "$tmp/a.json"

# warnings
"$bin" blend "$stress" --weights '{"Key 1":0.9,"Key 2":0.8}' -o "$tmp/e.json" 2>"$tmp/err"; rc=$?
check "blend: extrapolation warns with the sum and exits 0" sh -c "[ $rc -eq 0 ] && grep -q 'warning: extrapolation: sum of weights 1.7 exceeds 1' '$tmp/err'"
"$bin" blend "$rig" --set jawOpen=0.9 --set mouthSmile_L=0.8 -q -o "$tmp/q.json" 2>"$tmp/qerr"; rc=$?
check "blend -q: the same extrapolating point writes its file and says nothing" sh -c "[ $rc -eq 0 ] && [ -s '$tmp/q.json' ] && [ ! -s '$tmp/qerr' ]"
check "blend: the JSON body carries the warning too" py 'import json,sys; d=json.load(open(sys.argv[1])); sys.exit(not(d["warnings"][0]["code"]=="extrapolation" and d["warnings"][0]["value"]==1.7))' "$tmp/e.json"
"$bin" blend "$stress" --set 'Key 3=-0.5' --mode absolute -o "$tmp/f.json" 2>"$tmp/err"
check "blend: out-of-range weight named; absolute mode sum warning" sh -c "grep -q \"out_of_range: weight -0.5 of 'Key 3'\" '$tmp/err' && grep -q 'absolute_sum' '$tmp/err'"

# errors: clear message, non-zero exit below 128 (never a signal)
err_case() {  # name, expected-substring, args...
  local name=$1 needle=$2; shift 2
  "$bin" "$@" >"$tmp/out" 2>"$tmp/err"; local rc=$?
  if [ $rc -ne 0 ] && [ $rc -lt 128 ] && grep -q -- "$needle" "$tmp/err"; then ok "error: $name"; else no "error: $name (exit $rc: $(head -c 300 "$tmp/err"))"; fi
}
err_case "unknown shape suggests the closest and lists valid ones" "did you mean 'Key 1'" blend "$stress" --weights '{"Key1":1}' -o "$tmp/x.json"
err_case "unknown shape lists valid ones" "valid shapes: Key 1, Key 2" blend "$stress" --weights '{"nope":1}' -o "$tmp/x.json"
err_case "index out of range" "out of range" blend "$stress" --weights '[0,0,0,0,0,0,0,0,1]' -o "$tmp/x.json"
err_case "NaN weight" "finite" blend "$stress" --set 'Key 1=nan' -o "$tmp/x.json"
err_case "infinite weight" "finite" blend "$stress" --set 'Key 1=inf' -o "$tmp/x.json"
err_case "wrong type" "must be a number" blend "$stress" --weights '{"Key 1":"half"}' -o "$tmp/x.json"
err_case "malformed JSON" "malformed JSON" blend "$stress" --weights '{"Key 1":' -o "$tmp/x.json"
err_case "unknown format" "format" blend "$stress" -o "$tmp/x.png"
err_case "missing rig file" "cannot open" blend "$tmp/none.glb" -o "$tmp/x.json"
head -c 100000 "$A/FaceCap/facecap.glb" >"$tmp/trunc.glb"
err_case "truncated glb" "truncated glb" info "$tmp/trunc.glb"
printf 'glTF\002\000\000\000\377\377\377\377' >"$tmp/hdr.glb"
err_case "glb header lying about its length" "truncated" info "$tmp/hdr.glb"
head -c 3000 /dev/urandom >"$tmp/noise.gltf"
err_case "random bytes" "error:" info "$tmp/noise.gltf"
check "error: nothing written on failure" test ! -e "$tmp/x.json"

# formats
for fmt in glb obj f32; do
  "$bin" blend "$rig" --set jawOpen=0.7 -o "$tmp/out.$fmt" 2>/dev/null
  check "blend: -o .$fmt is written" test -s "$tmp/out.$fmt"
done
check "blend: f32 holds positions and normals of 4368 vertices" test "$(stat -c %s "$tmp/out.f32")" -eq $((4368 * 6 * 4))
check "blend: OBJ has 4368 v, 4368 vn and 8042 faces" sh -c "[ \$(grep -c '^v ' '$tmp/out.obj') -eq 4368 ] && [ \$(grep -c '^vn ' '$tmp/out.obj') -eq 4368 ] && [ \$(grep -c '^f ' '$tmp/out.obj') -eq 8042 ]"
"$bin" blend "$rig" --set jawOpen=0.7 --format json -o - 2>/dev/null >"$tmp/stdout.json"
check "blend: -o - writes JSON to stdout" py 'import json,sys; json.load(open(sys.argv[1]))' "$tmp/stdout.json"
"$bin" blend "$rig" --set jawOpen=0.7 --keep-targets -o "$tmp/rig.glb" 2>/dev/null
"$bin" info "$tmp/rig.glb" >"$tmp/rinfo" 2>/dev/null
check "blend --keep-targets: the glb is a rig again, jawOpen defaulting to 0.7" grep -Eq '^ +24 +jawOpen +default +\[0, 1\] +0.7 ' "$tmp/rinfo"

# the blended glb, with and without targets, is valid for the Khronos validator
if [ -n "$node_modules" ] && [ -d "$node_modules/gltf-validator" ]; then
  "$bin" blend "$stress" --set 'Key 2=0.5' -o "$tmp/stress.glb" 2>/dev/null
  "$bin" blend "$stress" --set 'Key 2=0.5' --keep-targets -o "$tmp/stress_rig.glb" 2>/dev/null
  NODE_PATH=$node_modules node "$src/tests/integration/validate_gltf.js" "$tmp/out.glb" "$tmp/rig.glb" "$tmp/stress.glb" "$tmp/stress_rig.glb" >"$tmp/val" 2>&1
  rc=$?; cat "$tmp/val"
  check "glTF validator: 0 errors on blended and rig exports" test $rc -eq 0
else
  no "glTF validator not installed (run .ci/dev test, which installs gltf-validator from npm)"
fi

# OBJ sequence: the ICT FaceKit frames as a rig
ict=$M/OBJ/ICT-FaceKit_subset
"$bin" info "$ict/generic_neutral_mesh.obj" "$ict/jawOpen.obj" "$ict/eyeBlink_L.obj" >"$tmp/ict" 2>&1
check "OBJ sequence: 28911 vertices (the 26719 OBJ vertices split at UV seams), shapes named after their files" sh -c "grep -q 'vertices   28911' '$tmp/ict' && grep -q ' jawOpen ' '$tmp/ict' && grep -q ' eyeBlink_L ' '$tmp/ict'"
"$bin" blend "$ict/generic_neutral_mesh.obj" "$ict/jawOpen.obj" --set jawOpen=1 -o "$tmp/ict.obj" 2>/dev/null
check "OBJ sequence: jawOpen at 1 reproduces jawOpen.obj's vertices" \
  py 'import sys
a=[list(map(float,l.split()[1:4])) for l in open(sys.argv[1]) if l.startswith("v ")]
b=[list(map(float,l.split()[1:4])) for l in open(sys.argv[2]) if l.startswith("v ")]
sys.exit(not(len(a)==len(b)==26719 and max(abs(x-y) for p,q in zip(a,b) for x,y in zip(p,q))<1e-4))' "$tmp/ict.obj" "$ict/jawOpen.obj"

# renders
"$bin" render "$rig" --set jawOpen=0.6 --width 200 --height 150 --yaw 20 -o "$tmp/r.png" 2>"$tmp/err"
check "render: a 200x150 PNG" py 'import sys,struct; d=open(sys.argv[1],"rb").read(); sys.exit(not(d[:8]==b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", d[16:24])==(200,150)))' "$tmp/r.png"
for fmt in jpg exr tif; do
  "$bin" render "$rig" --width 64 --height 64 --view normals -o "$tmp/r.$fmt" 2>/dev/null
  check "render: -o .$fmt decodes as a 64x64 image" sh -c "iinfo '$tmp/r.$fmt' 2>/dev/null | grep -q '64 x   64'"
done
"$bin" render "$rig" --set jawOpen=0.9 --set mouthSmile_L=0.8 --view heatmap -o "$tmp/h.png" 2>"$tmp/err"
check "render: extrapolation warning on stderr" grep -q 'warning: extrapolation: sum of weights 1.7 exceeds 1' "$tmp/err"
err_case "render: unknown view" "--view" render "$rig" --view xray -o "$tmp/x.png"
err_case "render: bad camera JSON" "camera" render "$rig" --camera '{"yaw":"left"}' -o "$tmp/x.png"
err_case "render: unknown image format" "image format" render "$rig" -o "$tmp/x.bmp"
printf '{"label":"neutral"}\n{"weights":{"jawOpen":1},"label":"jawOpen"}\n{"weights":{"eyeBlink_L":1},"label":"blink"}\n' >"$tmp/cells.jsonl"
"$bin" sheet "$rig" --cells @"$tmp/cells.jsonl" --columns 3 --width 128 --height 128 -o "$tmp/sheet.png" 2>/dev/null
check "sheet: three labelled 128x128 cells in a row" sh -c "iinfo '$tmp/sheet.png' | grep -Eq ' 400 x +1[5-9][0-9]'"
err_case "sheet: a cell with an unknown shape" "cells/1/weights/nope" sheet "$rig" --cells '[{},{"weights":{"nope":1}}]' -o "$tmp/x.png"

# skeletons
fox=$A/Fox/Fox.glb
"$bin" blend "$fox" -o "$tmp/fox0.json" 2>/dev/null
"$bin" blend "$fox" --animation Walk --time 0.3 -o "$tmp/fox1.json" 2>/dev/null
"$bin" blend "$fox" --animation 1 --time 0.3 --loop -o "$tmp/fox2.json" 2>/dev/null
"$bin" blend "$fox" --animation Walk --time 5 -o "$tmp/fox_clamp.json" 2>/dev/null
"$bin" blend "$fox" --animation Walk --time 0.71 -o "$tmp/fox_end.json" 2>/dev/null
"$bin" blend "$fox" --animation Walk --time 5 --loop -o "$tmp/fox_loop.json" 2>/dev/null
check "blend --animation NAME|INDEX --time: the pose moves the mesh" sh -c "! cmp -s '$tmp/fox0.json' '$tmp/fox1.json' && cmp -s '$tmp/fox1.json' '$tmp/fox2.json'"
check "blend: time past the clip clamps to its end, --loop wraps instead" sh -c "cmp -s '$tmp/fox_clamp.json' '$tmp/fox_end.json' && ! cmp -s '$tmp/fox_clamp.json' '$tmp/fox_loop.json'"
"$bin" blend "$fox" --pose '{"b_Head_05":{"euler":[0,40,0]}}' --skinning dual_quaternion -o "$tmp/fox3.glb" 2>/dev/null
check "blend --pose --skinning dual_quaternion writes a glb" test -s "$tmp/fox3.glb"
err_case "blend: unknown joint" "unknown joint 'nose'" blend "$fox" --pose '{"nose":{"euler":[0,0,1]}}' -o "$tmp/x.json"
err_case "blend: --time without --animation" "need an animation" blend "$fox" --time 1 -o "$tmp/x.json"
err_case "blend: bad --skinning" "skinning" blend "$fox" --skinning cubic -o "$tmp/x.json"
"$bin" info "$fox" >"$tmp/foxinfo" 2>&1
check "info lists the skeleton and the clips with durations" sh -c "grep -q 'skeleton   1 skin(s), 24 joints' '$tmp/foxinfo' && grep -q 'Walk  *0.708 s' '$tmp/foxinfo'"

# sequences
K='[{"time":0},{"time":1,"shape":"jawOpen"},{"time":2,"weights":{"mouthSmile_L":1}}]'
"$bin" sequence "$rig" --keys "$K" --transition smoothstep --times '[0.25,1.5]' -o "$tmp/seq.json" 2>/dev/null
check "sequence --times: frames with smoothstep in-betweens" py 'import json,sys; d=json.load(open(sys.argv[1])); f=d["frames"]; sys.exit(not(f[0]["weights"]=={"jawOpen":0.15625} and f[1]["weights"]=={"jawOpen":0.5,"mouthSmile_L":0.5} and len(f[0]["primitives"])==4))' "$tmp/seq.json"
"$bin" sequence "$rig" --keys "$K" --fps 5 --format obj -o "$tmp/frames" 2>"$tmp/err"
check "sequence --fps 5 --format obj: 11 frame files and a progress report" sh -c "[ \$(ls '$tmp/frames' | grep -c '^frame_000[01][0-9].obj$') -eq 11 ] && grep -q 'frames: 11 of 11 written' '$tmp/err'"
"$bin" sequence "$A/AnimatedMorphCube/AnimatedMorphCube.gltf" --from-animation 0 --reduce 0.001 -o "$tmp/red.json" 2>"$tmp/err"
check "sequence --from-animation --reduce: fewer keys within the tolerance" py 'import json,sys; d=json.load(open(sys.argv[1])); sys.exit(not(d["kept"] < 20 and d["removed"] > 100 and d["max_error"] <= 0.001))' "$tmp/red.json"
"$bin" sequence "$rig" --keys "$K" --bake 0.5 -o "$tmp/baked.json" 2>/dev/null
check "sequence --bake 0.5: a new key with the in-between weights" py 'import json,sys; k=json.load(open(sys.argv[1]))["keys"]; sys.exit(not(len(k)==4 and k[1]=={"time":0.5,"weights":{"jawOpen":0.5}}))' "$tmp/baked.json"
ict=$M/OBJ/ICT-FaceKit_subset
"$bin" sequence "$ict/generic_neutral_mesh.obj" "$ict/jawOpen.obj" "$ict/eyeBlink_L.obj" --obj-times 0,0.5,1.5 --times '[0.25,1.0]' -o "$tmp/ictseq.json" 2>/dev/null
check "sequence of OBJ frames with times: one shape per frame" py 'import json,sys; f=json.load(open(sys.argv[1]))["frames"]; sys.exit(not(f[0]["weights"]=={"jawOpen":0.5} and f[1]["weights"]=={"jawOpen":0.5,"eyeBlink_L":0.5}))' "$tmp/ictseq.json"
err_case "sequence: decreasing times" "keys/1/time" sequence "$rig" --keys '[{"time":1},{"time":0}]' --times '[0]' -o "$tmp/x.json"
err_case "sequence: unknown transition" "transition" sequence "$rig" --keys "$K" --transition bounce --times '[0]' -o "$tmp/x.json"
err_case "sequence: --obj-times count" "2 times for 3 OBJ files" sequence "$ict/generic_neutral_mesh.obj" "$ict/jawOpen.obj" "$ict/eyeBlink_L.obj" --obj-times 0,1 --times '[0]' -o "$tmp/x.json"

# fitting
"$bin" blend "$rig" --set jawOpen=0.6 --set mouthSmile_L=0.3 -o "$tmp/t.json" 2>/dev/null
"$bin" fit "$rig" "$tmp/t.json" -o "$tmp/fit.json" 2>"$tmp/err"
check "fit TARGET.json: recovers the weights blend used" py 'import json,sys; w=json.load(open(sys.argv[1]))["weights"]; sys.exit(not(abs(w["jawOpen"]-0.6)<2e-3 and abs(w["mouthSmile_L"]-0.3)<2e-3 and abs(w["cheekPuff"])<2e-3))' "$tmp/fit.json"
"$bin" blend "$rig" --set jawOpen=0.6 --set mouthSmile_L=0.3 -o "$tmp/t.obj" 2>/dev/null
"$bin" fit "$rig" "$tmp/t.obj" --bounded -o "$tmp/fit2.json" 2>/dev/null
check "fit TARGET.obj (world space, as blend writes it): the same weights" py 'import json,sys; w=json.load(open(sys.argv[1]))["weights"]; sys.exit(not(abs(w["jawOpen"]-0.6)<2e-3 and abs(w["mouthSmile_L"]-0.3)<2e-3))' "$tmp/fit2.json"
err_case "fit: a target of another rig" "the target has 1 primitives, the rig 4" fit "$rig" "$A/Fox/Fox.glb" -o "$tmp/x.json"

# keeping the space small: mirror, compress, lod
"$bin" mirror "$rig" mouthSmile_L --as smileMirror -o "$tmp/mirrored.glb" 2>"$tmp/err"; rc=$?
check "mirror: exit 0, reports the new shape" sh -c "[ $rc -eq 0 ] && grep -q \"mirror: 'mouthSmile_L' -> 'smileMirror'\" '$tmp/err'"
"$bin" mirror "$rig" mouthSmile_L --as smileMirror --compress none -o "$tmp/mirrored_plain.glb" 2>/dev/null
"$bin" blend "$tmp/mirrored.glb" --set smileMirror=0.7 --set jawOpen=0.3 -q -o "$tmp/mc.json"; "$bin" blend "$tmp/mirrored_plain.glb" --set smileMirror=0.7 --set jawOpen=0.3 -q -o "$tmp/mp.json"
check "mirror: the input's EXT_meshopt_compression is kept (lossless: the same mesh), $(stat -c %s "$tmp/mirrored.glb") bytes against $(stat -c %s "$tmp/mirrored_plain.glb") with --compress none" sh -c "grep -q EXT_meshopt_compression '$tmp/mirrored.glb' && [ \$(stat -c %s '$tmp/mirrored.glb') -lt \$(( \$(stat -c %s '$tmp/mirrored_plain.glb') * 2 / 3 )) ] && cmp -s '$tmp/mc.json' '$tmp/mp.json'"
if [ -n "$node_modules" ] && [ -d "$node_modules/gltf-validator" ]; then
  NODE_PATH=$node_modules node "$src/tests/integration/validate_gltf.js" "$tmp/mirrored.glb" >"$tmp/val" 2>&1; rc=$?
  check "glTF validator: 0 errors on the meshopt-compressed mirror ($(tail -1 "$tmp/val"))" test $rc -eq 0
fi
"$bin" info "$tmp/mirrored.glb" -q >"$tmp/mirrored.txt"
check "mirror: the written rig keeps its name, credit and groups (its manifest beside it); the new shape in its source's group" sh -c "grep -q '^rig  *FaceCap head (ARKit 52)' '$tmp/mirrored.txt' && grep -q '^credit  *Face Cap model' '$tmp/mirrored.txt' && grep -Eq 'jawOpen +jaw ' '$tmp/mirrored.txt' && grep -Eq 'smileMirror +mouth ' '$tmp/mirrored.txt' && [ -s '$tmp/mirrored.manifest.json' ]"
"$bin" blend "$tmp/mirrored.glb" --set smileMirror=1 -o "$tmp/m1.json" 2>/dev/null
"$bin" blend "$rig" --set mouthSmile_R=1 -o "$tmp/m2.json" 2>/dev/null
"$bin" blend "$rig" -o "$tmp/m0.json" 2>/dev/null
check "mirror: the written rig's new shape reproduces the authored right smile (mean error < 1% of its displacement)" py '
import json,sys,math
a,b,z=[json.load(open(f))["primitives"] for f in sys.argv[1:4]]
err=dis=0; n=0
for pa,pb,pz in zip(a,b,z):
    for i in range(0,len(pa["positions"]),3):
        d=math.dist(pb["positions"][i:i+3],pz["positions"][i:i+3])
        if d>0: err+=math.dist(pa["positions"][i:i+3],pb["positions"][i:i+3]); dis+=d; n+=1
sys.exit(not(n>100 and err<0.01*dis))' "$tmp/m1.json" "$tmp/m2.json" "$tmp/m0.json"
"$bin" compress "$rig" --json >"$tmp/comp.json" 2>/dev/null
check "compress --json: components, errors within the bound, sizes" py 'import json,sys; d=json.load(open(sys.argv[1])); p=d["pca"]; q=d["quantized"]; sys.exit(not(d["shapes"]==52 and 0<p["components"]<=52 and p["max_error"]<=p["error_bound"] and q["bits"]==16 and q["bytes"]<d["sparse_bytes"] and q["max_error"]<1e-5*d["diagonal"]))' "$tmp/comp.json"
"$bin" blend "$rig" --set jawOpen=1 --lod 2 -o "$tmp/lod.json" 2>"$tmp/err"
check "blend --lod 2: about a quarter of the triangles, fewer vertices, reported" both "grep -Eq 'lod 2: 20[0-9][0-9] of 8042 triangles' '$tmp/err'" py 'import json,sys; p=json.load(open(sys.argv[1]))["primitives"]; sys.exit(not(sum(len(x["positions"]) for x in p)//3 < 2000))' "$tmp/lod.json"
err_case "blend --lod 7 is refused" "level of detail" blend "$rig" --lod 7 -o "$tmp/x.json"

# MakeHuman: convert, controls
MH=$M/MakeHumanFace
mkdir -p "$tmp/mh"
"$bin" convert "$MH/base.obj" --targets "$MH/targets/nose" --targets "$MH/targets/eyes" --modifiers "$MH/modifiers/modeling_modifiers.json" -o "$tmp/mh/mh.glb" 2>"$tmp/err"; rc=$?
check "convert MakeHuman (nose, eyes): 14517 vertices (13,380 split at UV seams), shapes and controls, glb and manifest" sh -c "[ $rc -eq 0 ] && grep -Eq 'convert: 14517 vertices, 26756 triangles, [0-9]+ shapes .*, [0-9]+ controls' '$tmp/err' && [ -s '$tmp/mh/mh.glb' ] && [ -s '$tmp/mh/mh.manifest.json' ]"
mkdir -p "$tmp/mh2"
"$bin" convert "$MH/base.obj" --targets "$MH/targets/nose" --targets "$MH/targets/eyes" --modifiers "$MH/modifiers/modeling_modifiers.json" -o "$tmp/mh2/mh.glb" 2>/dev/null
check "convert is deterministic (glb and manifest byte-identical)" sh -c "cmp -s '$tmp/mh/mh.glb' '$tmp/mh2/mh.glb' && cmp -s '$tmp/mh/mh.manifest.json' '$tmp/mh2/mh.manifest.json'"
check "convert: the manifest holds two-sided controls, groups and l/r partners" py 'import json,sys; m=json.load(open(sys.argv[1])); c=m["controls"]; s=m["shapes"]; sys.exit(not(c["nose/nose-trans-down|up"]=={"group":"nose","negative":"nose-trans-down","positive":"nose-trans-up"} and s["l-eye-bag-decr"]["partner"]=="r-eye-bag-decr" and s["nose-trans-up"]["group"]=="nose"))' "$tmp/mh/mh.manifest.json"
if [ -n "$node_modules" ] && [ -d "$node_modules/gltf-validator" ]; then
  NODE_PATH=$node_modules node "$src/tests/integration/validate_gltf.js" "$tmp/mh/mh.glb" "$src/assets/makehuman/makehuman.glb" >"$tmp/val" 2>&1; rc=$?
  check "convert: the converted glb and the bundled MakeHuman glb pass the Khronos validator ($(tr '\n' ' ' <"$tmp/val"))" test $rc -eq 0
else
  no "convert: glTF validator not installed (run .ci/dev test, which installs gltf-validator from npm)"
fi
"$bin" blend "$tmp/mh/mh.glb" --controls '{"nose/nose-trans-down|up": -0.4}' -o "$tmp/mc1.json" 2>/dev/null
"$bin" blend "$tmp/mh/mh.glb" --weights '{"nose-trans-down": 0.4}' -o "$tmp/mc2.json" 2>/dev/null
"$bin" blend "$tmp/mh/mh.glb" --controls '{"nose/nose-trans-down|up": 0.4}' -o "$tmp/mc3.json" 2>/dev/null
"$bin" blend "$tmp/mh/mh.glb" --weights '{"nose-trans-up": 0.4}' -o "$tmp/mc4.json" 2>/dev/null
check "controls both ways: -0.4 drives nose-trans-down 0.4, +0.4 nose-trans-up 0.4" sh -c "cmp -s '$tmp/mc1.json' '$tmp/mc2.json' && cmp -s '$tmp/mc3.json' '$tmp/mc4.json' && ! cmp -s '$tmp/mc1.json' '$tmp/mc3.json'"
"$bin" blend "$tmp/mh/mh.glb" --controls '{"nose/nose-trans-down|up": -1.5}' -o "$tmp/x.json" 2>"$tmp/err"
check "a control outside its range warns with its name" grep -q "warning: control_out_of_range: control 'nose/nose-trans-down|up' = -1.5 is outside its range \[-1, 1\]" "$tmp/err"
err_case "an unknown control lists the controls" "unknown control 'nose/nose-up'; controls: " blend "$tmp/mh/mh.glb" --controls '{"nose/nose-up": 1}' -o "$tmp/x.json"
mkdir -p "$tmp/badt/t" && printf '# a target\n10 0 0 0.1\n10 0.1 0 0\n' >"$tmp/badt/t/dup.target"
err_case "convert: a duplicate index in a target file names file and line" "dup.target:3: vertex 10 is given twice (first on line 2)" convert "$MH/base.obj" --targets "$tmp/badt/t" -o "$tmp/x.glb"
printf '99999 0 0 1\n' >"$tmp/badt/t/dup.target"
err_case "convert: an index beyond the mesh names file and line" "dup.target:1: vertex index 99999 is beyond the mesh" convert "$MH/base.obj" --targets "$tmp/badt/t" -o "$tmp/x.glb"
"$bin" convert "$MH/base.obj" --targets "$MH/targets" --modifiers "$MH/modifiers/modeling_modifiers.json" -o "$tmp/mh/all.glb" 2>/dev/null
"$bin" info --json "$tmp/mh/all.glb" >"$tmp/all.json" 2>/dev/null
check "convert the whole targets/ folder (the issue's command): every target once, same stems in two folders told apart by folder" py 'import json,sys; n=[s["name"] for s in json.load(open(sys.argv[1]))["shapes"]]; sys.exit(not(len(n)==470 and len(set(n))==470 and "expression/units/asian/eye-left-slit" in n and "nose-trans-up" in n))' "$tmp/all.json"
ict=$M/OBJ/ICT-FaceKit_subset
"$bin" convert "$ict/generic_neutral_mesh.obj" "$ict/jawOpen.obj" "$ict/eyeBlink_L.obj" -o "$tmp/ict.glb" 2>/dev/null
"$bin" info --json "$tmp/ict.glb" >"$tmp/ict.json" 2>/dev/null
check "convert an OBJ sequence: the glb holds its two shapes" py 'import json,sys; d=json.load(open(sys.argv[1])); sys.exit(not([s["name"] for s in d["shapes"]]==["jawOpen","eyeBlink_L"]))' "$tmp/ict.json"

# batch variant generation
B="$tmp/batch"
"$bin" batch "$rig" --sample uniform --count 40 --seed 5 --active 6 --format glb --out "$B/a" 2>"$tmp/err"; rc=$?
check "batch --sample uniform: exit 0, 40 glb files, manifest, batch.json and a contact sheet" sh -c "[ $rc -eq 0 ] && [ \$(ls '$B/a' | grep -c '^v0000[0-3][0-9].glb$') -eq 40 ] && [ \$(wc -l <'$B/a/manifest.jsonl') -eq 40 ] && [ -s '$B/a/batch.json' ] && [ -s '$B/a/sheet.png' ]"
check "batch: a progress report with the rate, and a summary" sh -c "grep -q 'variants: 40/40' '$tmp/err' && grep -q 'variants/s' '$tmp/err'"
check "batch: its warnings summarised in one line (the 40 variants' codes counted against the manifest's)" py '
import json,sys,re
lines=[json.loads(l) for l in open(sys.argv[1]+"/manifest.jsonl")]
n=sum(1 for l in lines if any(w["code"]=="extrapolation" for w in l["warnings"]))
err=open(sys.argv[2]).read()
m=re.search(r"warnings: (none in the 40 variants generated|extrapolation in (\d+) of 40 variants)", err)
sys.exit(not(m and (n==0 if m.group(1).startswith("none") else int(m.group(2))==n)))' "$B/a" "$tmp/err"
check "batch manifest: id, file, size and sha256 of every file; 6 shapes moved in range; warnings recorded" py '
import json,sys,hashlib,os
d=sys.argv[1]; lines=[json.loads(l) for l in open(d+"/manifest.jsonl")]
ok=[l["index"] for l in lines]==list(range(40))
for l in lines:
    b=open(os.path.join(d,l["file"]),"rb").read()
    ok &= l["id"]=="v%06d"%l["index"] and l["bytes"]==len(b) and l["sha256"]==hashlib.sha256(b).hexdigest()
    ok &= len(l["weights"])==6 and all(0<=w<=1 for w in l["weights"].values())
    ok &= any(w["code"]=="extrapolation" for w in l["warnings"]) == (sum(l["weights"].values())>1)
sys.exit(not ok)' "$B/a"
check "batch variant file: the blend of its manifest weights (same bytes as facespace blend)" sh -c "
  w=\$(python3 -c 'import json,sys; print(json.dumps(json.loads(open(sys.argv[1]).readlines()[7])[\"weights\"]))' '$B/a/manifest.jsonl')
  '$bin' blend '$rig' --weights \"\$w\" -o '$tmp/b7.glb' 2>/dev/null && cmp -s '$tmp/b7.glb' '$B/a/v000007.glb'"
"$bin" batch "$rig" --sample uniform --count 40 --seed 5 --active 6 --format glb --out "$B/b" --jobs 1 --quiet 2>/dev/null
check "batch: the same seed gives byte-identical files (1 job vs all cores)" diff -r "$B/a" "$B/b"
"$bin" batch "$rig" --sample uniform --count 40 --seed 6 --active 6 --format glb --out "$B/c" --quiet --no-sheet 2>/dev/null
check "batch: another seed gives other variants" sh -c "! cmp -s '$B/a/v000000.glb' '$B/c/v000000.glb'"
rm "$B/b/v000011.glb"; printf '{"index":39,"id":"v0000' >>"$B/b/manifest.jsonl"; : >"$B/b/.fs-tmp-v000012.glb"; touch -d "1 minute ago" "$B/b/.fs-tmp-v000012.glb"
"$bin" batch "$rig" --sample uniform --count 40 --seed 5 --active 6 --format glb --out "$B/b" 2>"$tmp/err"
check "batch resume: only the missing variant is redone; torn manifest line and temp file cleaned" sh -c "grep -q '(1 generated, 39 already there)' '$tmp/err' && diff -r '$B/a' '$B/b'"
err_case "batch: a folder of another batch is refused" "holds another batch" batch "$rig" --sample uniform --count 40 --seed 9 --format glb --out "$B/a"
"$bin" batch "$rig" --sample convex --count 300 --seed 2 --format obj --out "$B/i" --jobs 2 --no-sheet 2>/dev/null & pid=$!
until [ -s "$B/i/manifest.jsonl" ] || ! kill -0 $pid 2>/dev/null; do sleep 0.05; done; kill -INT $pid; wait $pid; rc=$?
n=$(ls "$B/i" | grep -c '\.obj$')
check "batch interrupted (SIGINT): exit 130, no temporary or half-written file ($n of 300 done)" sh -c "[ $rc -eq 130 ] && [ $n -lt 300 ] && ! ls -a '$B/i' | grep -q tmp && [ \$(wc -l <'$B/i/manifest.jsonl') -eq $n ]"
"$bin" batch "$rig" --sample convex --count 300 --seed 2 --format obj --out "$B/i" --jobs 2 --no-sheet 2>/dev/null & pid=$!
n0=$(wc -l <"$B/i/manifest.jsonl"); until [ "$(wc -l <"$B/i/manifest.jsonl")" -gt "$n0" ] || ! kill -0 $pid 2>/dev/null; do sleep 0.05; done; kill -9 $pid; wait $pid 2>/dev/null
"$bin" batch "$rig" --sample convex --count 300 --seed 2 --format obj --out "$B/i" --no-sheet 2>/dev/null
"$bin" batch "$rig" --sample convex --count 300 --seed 2 --format obj --out "$B/j" --no-sheet --quiet 2>/dev/null
check "batch after SIGINT and kill -9: resuming gives exactly the uninterrupted result" diff -r "$B/i" "$B/j"
check "batch --sample convex: no variant extrapolates (sum <= 1, no warnings)" py 'import json,sys; L=[json.loads(l) for l in open(sys.argv[1])]; sys.exit(not(len(L)==300 and all(sum(l["weights"].values())<=1+1e-6 and l["warnings"]==[] for l in L)))' "$B/j/manifest.jsonl"
# Shards share one folder; merge makes it what one process writes.
for i in 1 3; do "$bin" batch "$rig" --sample uniform --count 40 --seed 5 --active 6 --format glb --out "$B/s" --shard $i/3 --quiet 2>/dev/null; done
check "batch --shard I/3: each shard its own manifest and record, no sheet, disjoint variants" sh -c "[ \$(wc -l <'$B/s/manifest.shard-1-of-3.jsonl') -eq 14 ] && [ \$(wc -l <'$B/s/manifest.shard-3-of-3.jsonl') -eq 13 ] && [ -s '$B/s/shard-3-of-3.json' ] && [ ! -e '$B/s/sheet.png' ] && [ ! -e '$B/s/v000001.glb' ] && [ -e '$B/s/v000002.glb' ]"
err_case "batch merge: a shard not run is named" "have not finished: 2/3" batch merge "$B/s"
check "batch merge refused: nothing changed" sh -c "[ -e '$B/s/manifest.shard-1-of-3.jsonl' ] && [ ! -e '$B/s/manifest.jsonl' ]"
SLURM_ARRAY_TASK_ID=11 SLURM_ARRAY_TASK_MIN=10 SLURM_ARRAY_TASK_MAX=12 "$bin" batch "$rig" --sample uniform --count 40 --seed 5 --active 6 --format glb --out "$B/s" --shard auto --quiet 2>"$tmp/err"
check "batch --shard auto from a Slurm array (ids 10..12, task 11): shard 2/3" grep -q "shard 2/3 (SLURM_ARRAY_TASK_ID=11 of 3 tasks)" "$tmp/err"
"$bin" batch merge "$B/s" 2>"$tmp/err"; rc=$?
check "batch merge: exit 0; the folder is byte-identical to one process's (manifest, sheet, files; shard files gone)" both "[ $rc -eq 0 ] && grep -q '3 shards, 40 variants' '$tmp/err'" diff -r "$B/a" "$B/s"
JOB_COMPLETION_INDEX=1 "$bin" batch "$rig" --sample uniform --count 40 --seed 5 --active 6 --format glb --out "$B/k" --shard auto --shards 2 --quiet 2>"$tmp/err"
check "batch --shard auto --shards 2 from a Kubernetes Indexed Job (JOB_COMPLETION_INDEX=1): shard 2/2" sh -c "grep -q 'shard 2/2 (JOB_COMPLETION_INDEX=1 of 2)' '$tmp/err' && [ \$(wc -l <'$B/k/manifest.shard-2-of-2.jsonl') -eq 20 ]"
printf 'x' | dd of="$B/k/v000003.glb" bs=1 seek=100 conv=notrunc 2>/dev/null
JOB_COMPLETION_INDEX=0 "$bin" batch "$rig" --sample uniform --count 40 --seed 5 --active 6 --format glb --out "$B/k" --shard auto --shards 2 --quiet 2>/dev/null
err_case "batch merge: a variant file changed after it was written" "v000003.glb' does not match its manifest line's sha256" batch merge "$B/k"
err_case "batch --shard auto outside a scheduler" "no scheduler's task index" batch "$rig" --sample uniform --count 4 --out "$B/x" --shard auto
JOB_COMPLETION_INDEX=0 err_case "batch --shard auto: a Kubernetes index needs the count" "needs --shards N" batch "$rig" --sample uniform --count 4 --out "$B/x" --shard auto
SLURM_ARRAY_TASK_ID=3 SLURM_ARRAY_TASK_COUNT=4 err_case "batch --shard auto --shards 3: an array id past the shards" "is not below --shards 3" batch "$rig" --sample uniform --count 4 --out "$B/x" --shard auto --shards 3
SLURM_ARRAY_TASK_ID=1 SLURM_ARRAY_TASK_COUNT=1 SLURM_ARRAY_TASK_MIN=1 SLURM_ARRAY_TASK_MAX=1 err_case "batch --shard auto: part of an array again, without --shards, in a folder of 2 shards" "holds shards of 2 but the scheduler gives 1" batch "$rig" --sample uniform --count 40 --seed 5 --active 6 --format glb --out "$B/k" --shard auto
SLURM_ARRAY_TASK_ID=9 SLURM_ARRAY_TASK_COUNT=4 SLURM_ARRAY_TASK_MIN=0 err_case "batch --shard auto: an index outside the array" "is not one of 4" batch "$rig" --sample uniform --count 4 --out "$B/x" --shard auto
err_case "batch merge: a folder without shards" "holds no shards" batch merge "$B/a"
"$bin" batch "$rig" --sample grid --shapes jawOpen,mouthSmile_L --count 9 --format json --out "$B/g" --no-sheet 2>/dev/null
check "batch --sample grid over two shapes: 3 x 3 steps over their ranges" py 'import json,sys; L=[json.loads(l)["weights"] for l in open(sys.argv[1])]; sys.exit(not(len(L)==9 and L[0]=={} and L[4]=={"jawOpen":0.5,"mouthSmile_L":0.5} and L[8]=={"jawOpen":1,"mouthSmile_L":1}))' "$B/g/manifest.jsonl"
"$bin" batch "$rig" --sample gaussian --count 200 --seed 3 --spread 0.1 --center '{"jawOpen":0.5}' --shapes jawOpen,mouthSmile_L,mouthSmile_R --symmetric --fix eyeBlink_L=1 --format json --out "$B/n" --no-sheet 2>/dev/null
check "batch --sample gaussian: mean near the centre, spread near 0.1, symmetric pair equal, fixed weight held" py '
import json,sys,statistics as st
L=[json.loads(l)["weights"] for l in open(sys.argv[1])]
j=[l.get("jawOpen",0) for l in L]
ok=len(L)==200 and abs(st.mean(j)-0.5)<0.03 and abs(st.pstdev(j)-0.1)<0.02
ok&=all(l.get("mouthSmile_L",0)==l.get("mouthSmile_R",0) and l["eyeBlink_L"]==1 for l in L)
sys.exit(not ok)' "$B/n/manifest.jsonl"
printf '{"id":"smile","weights":{"mouthSmile_L":1,"mouthSmile_R":1}}\n\n{"jawOpen":0.5}\n' >"$tmp/variants.jsonl"
"$bin" batch "$rig" --variants "$tmp/variants.jsonl" --format png --width 128 --height 128 --out "$B/e" 2>/dev/null
check "batch --variants FILE.jsonl --format png: named and numbered variants, 128x128 PNG" sh -c "[ -s '$B/e/smile.png' ] && [ -s '$B/e/v000001.png' ] && [ \$(oiiotool --info '$B/e/smile.png' | grep -c '128 x  128') -eq 1 ]"
err_case "batch: unknown shape in --fix" "did you mean 'jawOpen'" batch "$rig" --sample uniform --count 3 --fix jawopn=1 --out "$B/x"
err_case "batch: unknown method" "/sample/method" batch "$rig" --sample random --count 3 --out "$B/x"
err_case "batch: --variants and --sample together" "one of them" batch "$rig" --sample uniform --variants "$tmp/variants.jsonl" --out "$B/x"
printf '{"id":"../evil","weights":{}}\n' >"$tmp/evil.jsonl"
err_case "batch: a path trick in a variant id" "/variants/0/id" batch "$rig" --variants "$tmp/evil.jsonl" --out "$B/x"


# MD5 (Bob): info names the skeleton and the clip; a render at a clip time is a picture
"$bin" info "$M/MD5/Bob/Bob.md5mesh" >"$tmp/bob.info" 2>"$tmp/err"; rc=$?
check "info Bob.md5mesh: 33 joints, 6 meshes, 1027 triangles, the clip Bob, texture warnings" sh -c "[ $rc -eq 0 ] && grep -q 'skeleton   1 skin(s), 33 joints' '$tmp/bob.info' && grep -q 'triangles  1027' '$tmp/bob.info' && grep -Eq '^animation 0 +Bob +5.792 s' '$tmp/bob.info' && grep -q 'warning: texture_not_loaded' '$tmp/err'"
"$bin" render "$M/MD5/Bob/Bob.md5mesh" --animation Bob --time 1.5 --width 96 --height 96 -o "$tmp/bob.png" 2>/dev/null
check "render Bob.md5mesh at t=1.5: a 96x96 PNG" py 'import sys,struct; d=open(sys.argv[1],"rb").read(); sys.exit(not(d[:8]==b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", d[16:24])==(96,96)))' "$tmp/bob.png"

# FBX and COLLADA: info, a blend at in-between weights equals the converted glb's (its manifest
# carries the in-betweens), the glb is valid, a render of an animated skin is a picture
inb="$M/FBX/ufbx_maya_blend_inbetween/maya_blend_inbetween_7500_binary.fbx"
"$bin" info "$inb" >"$tmp/inb.info" 2>/dev/null; rc=$?
check "info maya_blend_inbetween.fbx: 5 shapes, 3 of them in-betweens (1 of LiftTop, 2 of MoveToSide)" sh -c "[ $rc -eq 0 ] && grep -q 'shapes     5' '$tmp/inb.info' && [ \$(grep -c ' inbetween ' '$tmp/inb.info') -eq 3 ]"
"$bin" convert "$inb" -o "$tmp/inb.glb" >/dev/null 2>&1
"$bin" blend "$inb" --set LiftTop=0.5 --set MoveToSide=-0.3 -o "$tmp/inb_src.json" 2>/dev/null
"$bin" blend "$tmp/inb.glb" --set LiftTop=0.5 --set MoveToSide=-0.3 -o "$tmp/inb_glb.json" 2>/dev/null
check "convert .fbx -> .glb: the blend at in-between weights is the source's" py 'import json,sys
a=json.load(open(sys.argv[1]))["primitives"]; b=json.load(open(sys.argv[2]))["primitives"]
sys.exit(not(len(a)==len(b)==1 and max(abs(x-y) for x,y in zip(a[0]["positions"],b[0]["positions"]))<1e-6 and len(a[0]["positions"])==96*3))' "$tmp/inb_src.json" "$tmp/inb_glb.json"
"$bin" convert "$M/Collada/CTS_morph_two_targets/morph_two_targets.dae" -o "$tmp/dae.glb" >/dev/null 2>&1
if [ -n "$node_modules" ] && [ -d "$node_modules/gltf-validator" ]; then
  NODE_PATH=$node_modules node "$src/tests/integration/validate_gltf.js" "$tmp/inb.glb" "$tmp/dae.glb" >"$tmp/val" 2>&1
  rc=$?; cat "$tmp/val"
  check "glTF validator: 0 errors on glbs converted from FBX and COLLADA" test $rc -eq 0
else
  no "glTF validator not installed: the glbs converted from FBX and COLLADA are not validated (run .ci/dev test, which installs gltf-validator from npm)"
fi
axes="$M/FBX/ufbx_maya_axes_anim/maya_axes_anim_7700_ascii.fbx"
"$bin" convert "$axes" -o "$tmp/axes.glb" >/dev/null 2>&1
"$bin" blend "$axes" --animation 0 --time 0.3 --set X1=0.4 -o "$tmp/axes_src.json" 2>/dev/null
"$bin" blend "$tmp/axes.glb" --animation 0 --time 0.3 --set X1=0.4 -o "$tmp/axes_glb.json" 2>/dev/null
check "convert maya_axes_anim.fbx -> .glb keeps the skin and the clip: the posed, skinned, morphed blend is the source's" py 'import json,sys
a=json.load(open(sys.argv[1]))["primitives"]; b=json.load(open(sys.argv[2]))["primitives"]
sys.exit(not(len(a)==len(b)==6 and max(abs(x-y) for p,q in zip(a,b) for x,y in zip(p["positions"],q["positions"]))<1e-5))' "$tmp/axes_src.json" "$tmp/axes_glb.json"
if [ -n "$node_modules" ] && [ -d "$node_modules/gltf-validator" ]; then
  NODE_PATH=$node_modules node "$src/tests/integration/validate_gltf.js" "$tmp/axes.glb" >"$tmp/val" 2>&1
  check "glTF validator: 0 errors on the converted skinned, animated FBX" test $? -eq 0
else
  no "glTF validator not installed: the converted skinned, animated FBX is not validated (run .ci/dev test)"
fi
"$bin" render "$axes" --animation 0 --time 0.3 --width 96 --height 96 -o "$tmp/axes.png" 2>/dev/null
check "render maya_axes_anim.fbx (skin + blend shape + node animation) at t=0.3: a 96x96 PNG" py 'import sys,struct; d=open(sys.argv[1],"rb").read(); sys.exit(not(d[:8]==b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", d[16:24])==(96,96)))' "$tmp/axes.png"
"$bin" info "$M/Collada/CTS_skin_on_morph/skin_on_morph.dae" >"$tmp/som.info" 2>/dev/null
check "info skin_on_morph.dae: a skin of 2 joints over a morph of 1 shape" sh -c "grep -q 'skeleton   1 skin(s), 2 joints' '$tmp/som.info' && grep -q 'shapes     1' '$tmp/som.info'"
printf 'Kaydara FBX Binary  \0\032\0\114\035\0\0\200\0\0\0\0' >"$tmp/cut.fbx"
"$bin" info "$tmp/cut.fbx" >/dev/null 2>"$tmp/err"; rc=$?
check "info on a truncated FBX: exit 1 and the byte offset named" sh -c "[ $rc -eq 1 ] && grep -q 'FBX byte' '$tmp/err'"


# MikuMikuDance: the bundled PMX with its motions, the PMD of the same model; convert keeps the skin,
# the motions as glTF animations and the credit; the converted glb blends as the source at a motion
# frame and is valid; a contact sheet of every shape.
uka="$src/assets/uka/MS_Uka.pmx"
"$bin" info "$uka" >"$tmp/uka.info" 2>"$tmp/uka.err"; rc=$?
check "info MS_Uka.pmx: 49955 vertices, 213 shapes (4 of them material morphs, 7 bone morphs), 302 joints, 40 motions (stand and 39 expressions), the credit; unmatched motion names reported" sh -c "[ $rc -eq 0 ] && grep -q '^vertices   49955' '$tmp/uka.info' && grep -q '^shapes     213' '$tmp/uka.info' && grep -q '302 joints' '$tmp/uka.info' && [ \$(grep -c '^animation ' '$tmp/uka.info') -eq 40 ] && grep -q 'Nagoya Institute of Technology' '$tmp/uka.info' && grep -q 'motion_names_unmatched' '$tmp/uka.err'"
"$bin" info "$uka" --verbose >/dev/null 2>"$tmp/uka.verbose"
check "Uka's load warnings: one line per kind, counted ($(wc -l <"$tmp/uka.err") lines), each of them with --verbose ($(wc -l <"$tmp/uka.verbose"))" sh -c "[ \$(grep -c '^warning: motion_names_unmatched' '$tmp/uka.err') -eq 1 ] && grep -Eq 'and [0-9]+ more motion_names_unmatched warnings: --verbose lists them' '$tmp/uka.err' && [ \$(grep -c '^warning: motion_names_unmatched' '$tmp/uka.verbose') -gt 30 ] && [ \$(wc -l <'$tmp/uka.err') -le 4 ]"
"$bin" info "$M/MMD/Uka_PMD/MS_Uka.pmd" --json >"$tmp/pmd.json" 2>/dev/null
check "info MS_Uka.pmd: 49955 vertices, 120 expressions (121 skins with the base), each its own shape under its own name (あ's English name mouth_a_geo_C is another morph's)" py 'import json,sys
d=json.load(open(sys.argv[1])); s=d["shapes"]; names=[x["name"] for x in s]
sys.exit(not(d["vertices"]==49955 and len(s)==120 and "mouth_a_geo_C" in names and "あ" in names and len(set(names))==120
             and not any(n.endswith("_2") for n in names) and not any("mouth_a_geo_C" in x.get("aliases",[]) for x in s)))' "$tmp/pmd.json"
"$bin" convert "$uka" -o "$tmp/uka.glb" >/dev/null 2>&1
"$bin" blend "$uka" --motion 01_happy --frame 150 -o "$tmp/uka_src.json" 2>/dev/null
"$bin" blend "$tmp/uka.glb" --motion 01_happy --frame 150 -o "$tmp/uka_glb.json" 2>/dev/null
"$bin" blend "$uka" -o "$tmp/uka_rest.json" 2>/dev/null
check "convert .pmx -> .glb: at frame 150 of 01_happy over the base motion (stand, with IK and grants solved into the glb's clips) the blend is the source's (and not the rest)" py 'import json,sys
a=json.load(open(sys.argv[1]))["primitives"]; b=json.load(open(sys.argv[2]))["primitives"]; r=json.load(open(sys.argv[3]))["primitives"]
d=max(abs(x-y) for p,q in zip(a,b) for x,y in zip(p["positions"],q["positions"]))
m=max(abs(x-y) for p,q in zip(a,r) for x,y in zip(p["positions"],q["positions"]))
sys.exit(not(len(a)==len(b)==12 and d<1e-6 and m>1e-3))' "$tmp/uka_src.json" "$tmp/uka_glb.json" "$tmp/uka_rest.json"
check "convert .pmx -> .glb: 40 animations, 302 joints, the credit as asset.copyright; it says which shapes move bones and colour materials" py 'import json,struct,sys
b=open(sys.argv[1],"rb").read(); n=struct.unpack_from("<I",b,12)[0]; j=json.loads(b[20:20+n])
w={x["code"]:x["message"] for x in j["asset"]["extras"]["warnings"]}
sys.exit(not(len(j["animations"])==40 and len(j["skins"][0]["joints"])==302 and "Nagoya Institute of Technology" in j["asset"]["copyright"]
  and w.get("bone_morphs_not_exported","").startswith("24 shapes with MMD bone morphs") and "material_morphs_not_exported" in w))' "$tmp/uka.glb"
# Every other PMX morph kind (tests/data/every_morph_kind.pmx, written by pmx_test's EveryMorphKind): a UV
# morph moves vertex 1's UV by (0.25, -0.5); the flip "f" at 0.4 picks it whole.
kinds=$src/tests/data/every_morph_kind.pmx
"$bin" convert "$kinds" -o "$tmp/kinds.glb" >/dev/null 2>"$tmp/kinds.err"
"$bin" blend "$kinds" --weights '{"f":0.4}' -o "$tmp/kinds.obj" 2>/dev/null
check "PMX UV and flip morphs: a flip at 0.4 picks the UV morph whole (vt 1.25 1.5); the rig's UV morph leaves as a TEXCOORD_0 target, its flip with a warning; additional-UV and impulse morphs are named as not applied" py 'import json,struct,sys
b=open(sys.argv[1],"rb").read(); n=struct.unpack_from("<I",b,12)[0]; j=json.loads(b[20:20+n])
t=j["meshes"][0]["primitives"][0]["targets"]; names=j["meshes"][0]["extras"]["targetNames"]
err=open(sys.argv[3]).read()
sys.exit(not("vt 1.25 1.5" in open(sys.argv[2]).read() and names==["v","uv","g","f"] and all("TEXCOORD_0" in x for x in t)
  and "1 additional-UV-1 morph" in err and "1 impulse morph" in err
  and any(w["code"]=="flip_morphs_not_exported" and w["message"].startswith("1 shape as MMD flip morphs") for w in j["asset"]["extras"]["warnings"])))' "$tmp/kinds.glb" "$tmp/kinds.obj" "$tmp/kinds.err"
if [ -n "$node_modules" ] && [ -d "$node_modules/gltf-validator" ]; then
  NODE_PATH=$node_modules node "$src/tests/integration/validate_gltf.js" "$tmp/uka.glb" "$tmp/kinds.glb" >"$tmp/val" 2>&1
  rc=$?; cat "$tmp/val"
  check "glTF validator: 0 errors on the glbs converted from PMX (skin, 213 targets, 40 motions; UV morphs as TEXCOORD_0 targets)" test $rc -eq 0
else
  no "glTF validator not installed: the glb converted from PMX is not validated (run .ci/dev test)"
fi
"$bin" sheet "$uka" --cells shapes:mouth --columns 8 --width 64 --height 64 -o "$tmp/uka_sheet.png" 2>/dev/null
check "sheet --cells shapes:mouth: one 64-pixel cell per mouth shape (8 columns)" py 'import sys,struct; d=open(sys.argv[1],"rb").read(); w,h=struct.unpack(">II", d[16:24]); sys.exit(not(d[:4]==b"\x89PNG" and w>=8*64 and h>=3*64))' "$tmp/uka_sheet.png"
# Motion layers: stand (the base, looping) and 08_surprise from t = 1 s; 08_surprise keys 瞳小 0.4 from
# its frame 15 (0.5 s in). Before the overlay starts, 瞳小 is 0; after, 0.4; the body stands throughout.
"$bin" sequence "$uka" --layers '[{"motion":"stand","loop":true},{"motion":"08_surprise","time":1}]' --times '[0.5,1.5]' -o "$tmp/layers.json" 2>/dev/null
check "sequence --layers: an overlay starts at its time over the looping base (瞳小 0 then 0.4), frames in world space" py 'import json,sys
d=json.load(open(sys.argv[1])); f=d["frames"]
sys.exit(not(d["space"]=="world" and abs(f[0]["weights"].get("瞳小",0))<1e-6 and abs(f[1]["weights"]["瞳小"]-0.4)<1e-6))' "$tmp/layers.json"
"$bin" sequence "$uka" --layers '[{"motion":"stand","loop":true},{"motion":"08_surprise","time":1}]' --times '[0.5,1.5]' --format weights -q -o "$tmp/layers_w.json"
check "sequence --format weights: the same frames' weights with their pose (the bones the motion moves), no meshes" py 'import json,sys
a=json.load(open(sys.argv[1]))["frames"]; b=json.load(open(sys.argv[2]))["frames"]
sys.exit(not(len(a)==len(b)==2 and all(x["weights"]==y["weights"] and "primitives" not in y and len(y["pose"])>10 for x,y in zip(a,b))))' "$tmp/layers.json" "$tmp/layers_w.json"
"$bin" blend "$uka" --layers '[{"motion":"stand"},{"motion":"nosuch"}]' -o "$tmp/x.json" 2>"$tmp/err"; rc=$?
check "blend --layers with an unknown motion: an error naming the layer" sh -c "[ $rc -ne 0 ] && grep -q 'layers/1.*unknown animation' '$tmp/err'"
"$bin" sheet "$uka" --cells shapes:nosuch -o "$tmp/x.png" 2>"$tmp/err"; rc=$?
check "sheet --cells shapes:nosuch: an error listing the groups" sh -c "[ $rc -ne 0 ] && grep -q 'groups:.*mouth' '$tmp/err'"


# A material morph: Uka's blush (赤み) shows the see-through cheek material, which her manifest colours
# (her textures are not shipped): at 1, pixels on her face turn pinker (red over green up by 30 of 255)
# than at 0, where her manifest's skin colour is already warm; at 0 against 0, none.
for w in 0 1; do
  "$bin" render "$uka" --set "赤み=$w" --camera '{"frame":"shapes"}' --width 192 --height 192 -o "$tmp/blush$w.png" 2>/dev/null
  oiiotool "$tmp/blush$w.png" -ch R,G,B -o "$tmp/blush$w.ppm" 2>/dev/null
done
check "material morph 赤み: the render at 1 has a pink patch on each cheek, at 0 none" py 'import sys
def px(path):
    d=open(path,"rb").read(); parts=d.split(b"\n",3); w,h=map(int,parts[1].split()); return w*h,parts[3]
def pinker(a,b):
    (n,p),(_,q)=px(a),px(b)
    return sum(1 for i in range(0,3*n,3) if (q[i]-q[i+1])-(p[i]-p[i+1])>30)
a,b=pinker(sys.argv[1],sys.argv[1]),pinker(sys.argv[1],sys.argv[2]); print("pinker pixels", a, b); sys.exit(not(a==0 and b>200))' "$tmp/blush0.ppm" "$tmp/blush1.ppm"

# MMD textures from the model's folder (Uka's own are not shipped: a red PNG for the face and a green
# BMP, named .png as the model names it, for the body): the render shows both colours.
mkdir -p "$tmp/ukatex/tex"; cp "$uka" "$tmp/ukatex/"
py 'import struct,zlib,sys
d=sys.argv[1]; w=h=4
raw=b"".join(b"\0"+bytes((255,0,0))*w for _ in range(h))
ch=lambda t,x: struct.pack(">I",len(x))+t+x+struct.pack(">I",zlib.crc32(t+x)&0xffffffff)
open(d+"/face.png","wb").write(b"\x89PNG\r\n\x1a\n"+ch(b"IHDR",struct.pack(">IIBBBBB",w,h,8,2,0,0,0))+ch(b"IDAT",zlib.compress(raw))+ch(b"IEND",b""))
px=bytes((0,255,0))*w*h
open(d+"/body.png","wb").write(b"BM"+struct.pack("<IHHI",54+len(px),0,0,54)+struct.pack("<IiiHHIIiiII",40,w,h,1,24,0,len(px),2835,2835,0,0)+px)' "$tmp/ukatex/tex"
"$bin" info "$tmp/ukatex/MS_Uka.pmx" 2>"$tmp/tex.err" >/dev/null
"$bin" render "$tmp/ukatex/MS_Uka.pmx" --camera '{"frame":"all"}' --width 128 --height 192 --format png -o "$tmp/ukatex.png" 2>/dev/null
check "MMD textures: face.png (PNG) and body.png (a BMP) read from tex/, the render shows red and green; the missing ones reported" sh -c "! grep -q \"texture 'tex/face.png'\" '$tmp/tex.err' && ! grep -q \"texture 'tex/body.png'\" '$tmp/tex.err' && grep -q \"texture 'tex/eye.png' is not read: no such file\" '$tmp/tex.err' && python3 -c '
import sys,subprocess,struct,zlib
d=open(sys.argv[1],\"rb\").read(); w,h=struct.unpack(\">II\",d[16:24]); bd,ct=d[24],d[25]
at=8; idat=b\"\"
while at<len(d):
    n=struct.unpack(\">I\",d[at:at+4])[0]; t=d[at+4:at+8]
    if t==b\"IDAT\": idat+=d[at+8:at+8+n]
    at+=12+n
raw=zlib.decompress(idat); bpp=4 if ct==6 else 3; stride=w*bpp; prev=bytearray(stride); red=green=0; i=0
for y in range(h):
    f=raw[i]; line=bytearray(raw[i+1:i+1+stride]); i+=1+stride
    for x in range(stride):
        a=line[x-bpp] if x>=bpp else 0; b=prev[x]; c=prev[x-bpp] if x>=bpp else 0
        if f==1: line[x]=(line[x]+a)&255
        elif f==2: line[x]=(line[x]+b)&255
        elif f==3: line[x]=(line[x]+(a+b)//2)&255
        elif f==4:
            p=a+b-c; pa,pb,pc=abs(p-a),abs(p-b),abs(p-c); line[x]=(line[x]+(a if pa<=pb and pa<=pc else b if pb<=pc else c))&255
    prev=line
    for x in range(w):
        r,g,b=line[x*bpp:x*bpp+3]
        red+=r>120 and g<60 and b<60; green+=g>120 and r<60 and b<60
sys.exit(not(red>20 and green>20))' '$tmp/ukatex.png'"

# What a new user met (issue 20): each of these failed on the build before.
err_case "render --format jpeg -o x.png: the bytes would belie the name" "does not match the output name" render "$rig" --format jpeg -o "$tmp/x.png"
err_case "blend --format glb -o x.json: likewise" "does not match the output name" blend "$rig" --format glb -o "$tmp/x.json"
"$bin" blend "$rig" --weights '[0.1,0.2]' -o "$tmp/short.json" 2>"$tmp/err"
check "blend with a dense array shorter than the shapes warns (weights_short: 2 values for 52 shapes)" grep -q "warning: weights_short: the weights array has 2 values for the rig's 52 shapes" "$tmp/err"
"$bin" blend "$rig" --weights '{"jawOpen":0.3,"mouthSmile_L":0.5}' -o "$tmp/rt.json" 2>/dev/null
"$bin" fit "$rig" "$tmp/rt.json" -o "$tmp/rt.fit.json" 2>"$tmp/err"
check "fit on an exact round trip: no out-of-range warnings for round-off" both "! grep -q 'outside its range' '$tmp/err'" py 'import json,sys; w=json.load(open(sys.argv[1]))["weights"]; sys.exit(not(abs(w["jawOpen"]-0.3)<1e-3 and min(w.values())>=0))' "$tmp/rt.fit.json"
"$bin" blend "$rig" --set jawOpen=0.5 --space mesh -o "$tmp/mesh.json" 2>/dev/null
check "blend --space mesh: the JSON says mesh and holds FaceCap's quantized units; the default says world" both "grep -q '\"space\":\"mesh\"' '$tmp/mesh.json' && grep -q '\"space\":\"world\"' '$tmp/rt.json'" py 'import json,sys; p=json.load(open(sys.argv[1]))["primitives"][0]["positions"]; sys.exit(not(max(abs(x) for x in p) > 100))' "$tmp/mesh.json"
"$bin" sequence "$rig" --keys '[{"time":0,"weights":{"jawOpen":0.9,"mouthSmile_L":0.9}},{"time":1,"weights":{}}]' --fps 20 --format obj -o "$tmp/seqw" 2>"$tmp/err"
check "sequence to a log (stderr not a terminal): one summary line and each warning code once" sh -c "[ \$(grep -c '^frames:' '$tmp/err') = 1 ] && grep -q '^frames: 21 of 21 written' '$tmp/err' && [ \$(grep -c 'extrapolation' '$tmp/err') = 1 ] && grep -q 'extrapolation in 9 of 21 frames' '$tmp/err'"
err_case "an unknown animation suggests the closest" "unknown animation 'Survay' (did you mean 'Survey'?)" sequence "$fox" --from-animation Survay --fps 10 -o "$tmp/x.json"
err_case "an unknown control suggests the closest" "(did you mean 'nose/nose-trans-down|up'?)" blend "$tmp/mh/mh.glb" --controls '{"nose/nose-trans-down|upp": 1}' -o "$tmp/x.json"
"$bin" info "$tmp/mh/mh.glb" >"$tmp/info.txt" 2>/dev/null
check "info lists a rig's controls (MakeHuman)" sh -c "grep -q '^controls ' '$tmp/info.txt' && grep -Eq '^  nose/nose-trans-down\|up +nose +\[-1, 1\] +nose-trans-down \| nose-trans-up' '$tmp/info.txt'"
"$bin" info --json "$fox" >"$tmp/fox.json" 2>/dev/null
"$bin" info --json "$tmp/mh/mh.glb" >"$tmp/mhinfo.json" 2>/dev/null
check "info --json is the rig route's document: animations and load warnings (Fox)" py 'import json,sys; d=json.load(open(sys.argv[1])); sys.exit(not([a["name"] for a in d["animations"]]==["Survey","Walk","Run"] and "load_warnings" in d))' "$tmp/fox.json"
check "  ... and controls (MakeHuman)" py 'import json,sys; d=json.load(open(sys.argv[1])); sys.exit(not(any(c["name"]=="nose/nose-trans-down|up" for c in d["controls"])))' "$tmp/mhinfo.json"
mkdir -p "$tmp/linked" && ln -s "$MH/targets/nose" "$tmp/linked/nose"
"$bin" convert "$MH/base.obj" --targets "$tmp/linked" --modifiers "$MH/modifiers/modeling_modifiers.json" -o "$tmp/mh/linked.glb" 2>"$tmp/err"; rc=$?
check "convert follows a linked targets folder; the modifiers whose targets are missing are one warning naming them" sh -c "[ $rc -eq 0 ] && grep -Eq 'convert: 14517 vertices, 26756 triangles, [1-9][0-9]* shapes' '$tmp/err' && grep -q 'warning: modifier_targets_missing: [0-9]* modifier(s) name targets that were not found' '$tmp/err' && grep -q 'head/head-age-decr|incr' '$tmp/err'"
mkdir -p "$tmp/notargets"
err_case "convert with a targets folder holding no .target files is an error" "no .target files under" convert "$MH/base.obj" --targets "$tmp/notargets" -o "$tmp/x.glb"

check "project: a LICENSE, and the README's credits say FaceCap has no formal license and MakeHuman is CC0" \
  sh -c "grep -q 'MIT License' '$src/LICENSE' && grep -q 'no formal' '$src/README.md' && grep -q 'CC0' '$src/README.md'"
"$bin" info "$src/assets/makehuman/makehuman.glb" >/dev/null 2>"$tmp/err"
check "the bundled MakeHuman loads without warnings, as its CREDITS say" sh -c "! grep -q warning '$tmp/err' && ! grep -q 'the load reports' '$src/assets/makehuman/CREDITS.md'"

# Faces by name (issue 37). Expressions and gaze on the CLI; a sequence's blinks; Uka as a VRM 1.0 that
# three.js with @pixiv/three-vrm loads and moves as we do.
"$bin" blend "$src/assets/facecap/facecap.glb" --expression happy=1 --gaze 15,0 --format json -o "$tmp/face_a.json" -q
"$bin" blend "$src/assets/facecap/facecap.glb" --weights '{"mouthSmile_L":1,"mouthSmile_R":1,"cheekSquint_L":0.5,"cheekSquint_R":0.5,"eyeSquint_L":0.4,"eyeSquint_R":0.4,"eyeLookOut_L":0.5,"eyeLookIn_R":0.5}' --format json -o "$tmp/face_b.json" -q
check "blend --expression happy=1 --gaze 15,0: the same mesh as happy's weights and eyeLookOut_L, eyeLookIn_R at 15/30" cmp -s "$tmp/face_a.json" "$tmp/face_b.json"
"$bin" batch "$src/assets/facecap/facecap.glb" --sample uniform --count 2 --shapes jawOpen --expressions '{"happy":1}' --gaze '{"yaw":15,"pitch":0}' --format f32 --out "$tmp/face_batch" -q
check "batch --expressions --gaze: every variant has happy's weights and the gaze's on top of its sampled jawOpen" py 'import json,sys
v=[json.loads(l)["weights"] for l in open(sys.argv[1])]
sys.exit(not(len(v)==2 and all(w["mouthSmile_L"]==1 and w["eyeSquint_R"]==0.4 and w["eyeLookOut_L"]==0.5 and 0<w.get("jawOpen",0)<=1 for w in v)))' "$tmp/face_batch/manifest.jsonl"
err_case "blend --expression with a typo: an error naming the closest expression" "did you mean 'happy'" blend "$src/assets/facecap/facecap.glb" --expression hapy=1 -o "$tmp/x.json"
"$bin" sequence "$src/assets/facecap/facecap.glb" --keys '[{"time":0},{"time":60}]' --blink 15 --fps 50 --format weights -q -o "$tmp/blinks.json"
check "sequence --blink 15: 12 to 18 closings of both eyes in 60 s, each over within half a second" py 'import json,sys
f=json.load(open(sys.argv[1]))["frames"]; c=[x["weights"].get("eyeBlink_L",0) for x in f]
starts=[i for i in range(1,len(c)) if c[i]>0.9>=c[i-1]]; longest=max(sum(1 for _ in g) for k,g in __import__("itertools").groupby(c,lambda v:v>0) if k)
sys.exit(not(12<=len(starts)<=18 and all(x["weights"].get("eyeBlink_R",0)==x["weights"].get("eyeBlink_L",0) for x in f) and longest<=25))' "$tmp/blinks.json"
"$bin" blend "$uka" --format vrm -o "$tmp/uka.vrm" -q; rc=$?
check "blend --format vrm: Uka as a VRM 1.0 (15 required humanoid bones, 18 presets, 69 custom expressions, a bone look-at; springs, node constraints, MToon; a 512² thumbnail)" py 'import json,struct,sys
b=open(sys.argv[1],"rb").read(); n=struct.unpack_from("<I",b,12)[0]; j=json.loads(b[20:20+n]); v=j["extensions"]["VRMC_vrm"]
used=set(j["extensionsUsed"]); t=v["meta"].get("thumbnailImage",-1)
sys.exit(not(v["specVersion"]=="1.0" and {"VRMC_vrm","VRMC_springBone","VRMC_node_constraint","VRMC_materials_mtoon"}<=used and v["humanoid"]["humanBones"]["head"]["node"]>=0
  and len(v["expressions"]["preset"])==18 and len(v["expressions"]["custom"])==69 and v["lookAt"]["type"]=="bone" and "animations" not in j
  and len(j["extensions"]["VRMC_springBone"]["springs"])>=50 and j["images"][t]["mimeType"]=="image/png"))' "$tmp/uka.vrm"
check "Uka's VRM terms are her authors': violent, sexual, antisocial/hate, political/religious usage false, credit required, from the manifest's \"terms\" (her README)" py 'import json,struct,sys
b=open(sys.argv[1],"rb").read(); n=struct.unpack_from("<I",b,12)[0]; m=json.loads(b[20:20+n])["extensions"]["VRMC_vrm"]["meta"]
sys.exit(not(m["allowExcessivelyViolentUsage"] is False and m["allowExcessivelySexualUsage"] is False and m["allowAntisocialOrHateUsage"] is False
  and m["allowPoliticalOrReligiousUsage"] is False and m["creditNotation"]=="required" and m["otherLicenseUrl"].endswith("/by/4.0/")
  and "Usage Guideline" in m["extras"]["termsSource"]))' "$tmp/uka.vrm"
mkdir -p "$tmp/uka_noterms"; cp "$uka" "$tmp/uka_noterms/MS_Uka.pmx"
py 'import json,sys; m=json.load(open(sys.argv[1])); m.pop("terms"); json.dump(m,open(sys.argv[2],"w"),ensure_ascii=False)' "$src/assets/uka/MS_Uka.manifest.json" "$tmp/uka_noterms/MS_Uka.manifest.json"
"$bin" blend "$tmp/uka_noterms/MS_Uka.pmx" --format vrm -o "$tmp/noterms.vrm" -q
check "a rig whose terms nobody stated gets VRM's most restrictive ones (only its author, non-profit, nothing excessive, no redistribution, no modification)" py 'import json,struct,sys
b=open(sys.argv[1],"rb").read(); n=struct.unpack_from("<I",b,12)[0]; m=json.loads(b[20:20+n])["extensions"]["VRMC_vrm"]["meta"]
sys.exit(not(m["avatarPermission"]=="onlyAuthor" and m["commercialUsage"]=="personalNonProfit" and not any(m[k] for k in ("allowExcessivelyViolentUsage","allowExcessivelySexualUsage",
  "allowPoliticalOrReligiousUsage","allowAntisocialOrHateUsage","allowRedistribution")) and m["modification"]=="prohibited" and m["creditNotation"]=="required"))' "$tmp/noterms.vrm"
err_case "blend --format vrm of a rig without a skeleton: an error saying what a humanoid lacks" "cannot be a VRM humanoid: no bone for hips" blend "$src/assets/facecap/facecap.glb" --format vrm -o "$tmp/x.vrm"
"$bin" blend "$uka" --format vrm0 -o "$tmp/uka0.vrm" -q
check "blend --format vrm0: Uka as a VRM 0.x (the VRM extension: 0.x meta, 87 blend shape groups, springs, MToon material properties)" py 'import json,struct,sys
b=open(sys.argv[1],"rb").read(); n=struct.unpack_from("<I",b,12)[0]; j=json.loads(b[20:20+n]); v=j["extensions"]["VRM"]
sys.exit(not(j["extensionsUsed"]==["VRM"] and v["meta"]["violentUssageName"]=="Disallow" and v["meta"]["licenseName"]=="CC_BY" and len(v["blendShapeMaster"]["blendShapeGroups"])==87
  and len(v["secondaryAnimation"]["boneGroups"])>=40 and v["materialProperties"][1]["shader"]=="VRM/MToon" and v["firstPerson"]["lookAtTypeName"]=="Bone"))' "$tmp/uka0.vrm"
# Our own meshes for every face the VRMs carry: the 18 presets, blush and pale (material colour binds), ARKit's 52 by
# name and the 15 visemes by OVR's names (at their weights in Uka's viseme map).
mkdir -p "$tmp/vrm_expected"
"$bin" info "$uka" --json >"$tmp/uka_info.json" 2>/dev/null
keys=$(py 'import json,sys
presets=["happy","angry","sad","relaxed","surprised","aa","ih","ou","ee","oh","blink","blinkLeft","blinkRight","lookUp","lookDown","lookLeft","lookRight","neutral","blush","pale"]
arkit="browDownLeft browDownRight browInnerUp browOuterUpLeft browOuterUpRight cheekPuff cheekSquintLeft cheekSquintRight eyeBlinkLeft eyeBlinkRight eyeLookDownLeft eyeLookDownRight eyeLookInLeft eyeLookInRight eyeLookOutLeft eyeLookOutRight eyeLookUpLeft eyeLookUpRight eyeSquintLeft eyeSquintRight eyeWideLeft eyeWideRight jawForward jawLeft jawOpen jawRight mouthClose mouthDimpleLeft mouthDimpleRight mouthFrownLeft mouthFrownRight mouthFunnel mouthLeft mouthLowerDownLeft mouthLowerDownRight mouthPressLeft mouthPressRight mouthPucker mouthRight mouthRollLower mouthRollUpper mouthShrugLower mouthShrugUpper mouthSmileLeft mouthSmileRight mouthStretchLeft mouthStretchRight mouthUpperUpLeft mouthUpperUpRight noseSneerLeft noseSneerRight tongueOut".split()
ovr=dict(sil="sil",PP="PP",FF="FF",TH="TH",DD="DD",kk="kk",CH="CH",SS="SS",nn="nn",RR="RR",aa="aa",E="E",I="ih",O="oh",U="ou")
vis=json.load(open(sys.argv[1]))["visemes"]
faces=[(n,{"expressions":{n:1}}) for n in presets]+[(n,{"weights":{n:1}}) for n in arkit]+[("viseme_"+k,{"weights":vis[v]}) for k,v in ovr.items()]
json.dump([n for n,_ in faces],open(sys.argv[2],"w"))
print(json.dumps([{"time":0}]+[dict(time=i+1,**f) for i,(n,f) in enumerate(faces)]))' "$tmp/uka_info.json" "$tmp/vrm_names.json")
"$bin" sequence "$uka" --keys "$keys" --times "[$(seq -s, 0 87)]" --transition step -q -o "$tmp/vrm_frames.json"
py 'import json,sys
names=["rest"]+json.load(open(sys.argv[3])); f=json.load(open(sys.argv[1]))["frames"]
for n,x in zip(names,f): json.dump({"primitives":x["primitives"]},open(sys.argv[2]+"/"+n+".json","w"))' "$tmp/vrm_frames.json" "$tmp/vrm_expected" "$tmp/vrm_names.json"
"$bin" info "$tmp/uka.vrm" >/dev/null 2>"$tmp/err"; rc=$?
check "our VRM loads back: its expressions, look-at and terms, no load error" sh -c "[ $rc -eq 0 ] && ! grep -q 'error' '$tmp/err'"
"$src/tests/integration/vrm_edit.py" hostile "$tmp/uka.vrm" "$tmp/vrm_hostile"
for f in "$tmp"/vrm_hostile/*.vrm; do
  name=$(basename "$f" .vrm); member=$(py 'import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])' "$tmp/vrm_hostile/faults.json" "$name")
  err_case "a VRM with $name: an error naming $member" "$member" info "$f"
done
"$src/tests/integration/vrm_edit.py" binds "$tmp/uka.vrm" "$tmp/binds.vrm"
for e in none tint slide; do
  "$bin" render "$tmp/binds.vrm" $( [ $e = none ] || echo "--expression $e=1" ) --width 128 --height 128 -o "$tmp/binds_$e.png" -q
  "$bin" blend "$tmp/binds.vrm" $( [ $e = none ] || echo "--expression $e=1" ) --format glb -o "$tmp/binds_$e.glb" -q
done
check "a VRM's material colour bind (tint, to [1, 0.1, 0.1]) renders: the face turns red (mean red up, green down)" py 'import subprocess,sys
def mean(p):
    out=subprocess.run(["oiiotool","--stats",p],capture_output=True,text=True).stdout
    return [float(x) for x in next(l for l in out.splitlines() if "Stats Avg" in l).split(":")[1].split()[:3]]
a,b=mean(sys.argv[1]),mean(sys.argv[2]); print("mean rgb", a, "->", b)
sys.exit(not(b[0]>a[0]-0.5 and b[1]<a[1]-10))' "$tmp/binds_none.png" "$tmp/binds_tint.png"
check "a VRM's texture transform bind (slide, offset 0.25) renders: the face's texture moves (the pictures differ)" sh -c "! cmp -s '$tmp/binds_none.png' '$tmp/binds_slide.png'"
py 'import json,struct,sys
def rd(p):
    b=open(p,"rb").read(); n=struct.unpack_from("<I",b,12)[0]; return json.loads(b[20:20+n]), b[20+n+8:]
def uv(p):
    j,b=rd(p)
    for m in j["meshes"]:
        for pr in m["primitives"]:
            if pr.get("material")==1:
                a=j["accessors"][pr["attributes"]["TEXCOORD_0"]]; bv=j["bufferViews"][a["bufferView"]]
                return struct.unpack_from("<%df"%(2*a["count"]),b,bv.get("byteOffset",0)+a.get("byteOffset",0))
u0,u1=uv(sys.argv[1]),uv(sys.argv[3]); d=[u1[i]-u0[i] for i in range(len(u0))]
print(json.dumps({"tint":rd(sys.argv[2])[0]["materials"][1]["pbrMetallicRoughness"]["baseColorFactor"][:3],"slide":[max(d[0::2]),max(d[1::2]),min(d[0::2]),min(d[1::2])]}))' \
  "$tmp/binds_none.glb" "$tmp/binds_tint.glb" "$tmp/binds_slide.glb" >"$tmp/binds_ours.json"
if [ -n "$node_modules" ] && [ -d "$node_modules/@pixiv/three-vrm" ]; then
  for f in uka uka0; do
    NODE_PATH=$node_modules node "$src/tests/integration/validate_gltf.js" "$tmp/$f.vrm" >"$tmp/val" 2>&1; rc=$?; cat "$tmp/val"
    check "glTF validator: 0 errors on Uka's VRM ($f)" test $rc -eq 0
  done
  # An ES module finds its packages beside it (NODE_PATH is CommonJS's): it runs from the packages' folder.
  cp "$src/tests/integration/vrm_test.mjs" "$src/tests/integration/vrm_avatar.mjs" "$node_modules/.."
  node "$node_modules/../vrm_test.mjs" "$tmp/uka.vrm" "$tmp/vrm_expected" --avatar >"$tmp/vrm_out" 2>&1; rc=$?; cat "$tmp/vrm_out"
  check "three.js + @pixiv/three-vrm load Uka's VRM 1.0: humanoid bones, all 87 expressions (ARKit's 52, 15 visemes) moving the vertices as ours (1e-5 of the diagonal); the hair swings and comes to rest; constraints evaluated; MToon" \
    sh -c "[ $rc -eq 0 ] && grep -q '15 of 15 required bones' '$tmp/vrm_out' && grep -q '87 expressions checked; 87 in the VRM' '$tmp/vrm_out' && grep -q '^ok   secondary motion' '$tmp/vrm_out'"
  node "$node_modules/../vrm_test.mjs" "$tmp/uka0.vrm" "$tmp/vrm_expected" --v0 --avatar >"$tmp/vrm0_out" 2>&1; rc=$?; cat "$tmp/vrm0_out"
  check "three-vrm's 0.x path loads Uka's VRM 0.x: its expressions (happy, blink, aa and all 87) as ours within 1e-5 of the diagonal, springs swinging, look-at by bones" \
    sh -c "[ $rc -eq 0 ] && grep -q '^VRM 0' '$tmp/vrm0_out' && grep -q '87 expressions checked; 87 in the VRM' '$tmp/vrm0_out' && grep -q '^ok   happy' '$tmp/vrm0_out' && grep -q '^ok   secondary motion' '$tmp/vrm0_out'"
  node "$node_modules/../vrm_test.mjs" "$tmp/binds.vrm" "$tmp/vrm_expected" --binds >"$tmp/binds_out" 2>&1; cat "$tmp/binds_out" | tail -1
  check "three-vrm and we agree on the binds: tint's colour and slide's UV offset" py 'import json,sys
theirs=json.loads(next(l for l in open(sys.argv[1]) if l.startswith("binds: "))[7:]); ours=json.load(open(sys.argv[2])); print("ours", ours)
sys.exit(not(all(abs(a-b)<1e-5 for a,b in zip(theirs["tint"]["color"],ours["tint"])) and abs(ours["slide"][0]-theirs["slide"]["offset"][0])<1e-5
  and abs(ours["slide"][2]-theirs["slide"]["offset"][0])<1e-5 and abs(ours["slide"][1]-theirs["slide"]["offset"][1])<1e-6))' "$tmp/binds_out" "$tmp/binds_ours.json"
else
  no "@pixiv/three-vrm not installed: the VRM is not loaded in three.js (run .ci/dev test)"
fi

# Lip sync (issue 38): text to keys, audio and a video; recorded speech back to visemes; a rig without a mouth.
"$bin" speak "$src/assets/facecap/facecap.glb" --text "Please pass the map." -o "$tmp/speak.json" -q; rc=$?
check "speak --text: phonemes with espeak-ng's times, visemes with closures, keys of FaceCap's mouth shapes" py 'import json,sys
j=json.load(open(sys.argv[1])); v=j["visemes"]
sys.exit(not(j["source"]=="espeak-ng" and len(j["phonemes"])>8 and sum(1 for x in v if x["viseme"]=="PP")>=2 and v[0]["start"]==0
  and abs(v[-1]["end"]-j["duration"])<1e-6 and any("jawOpen" in k["weights"] for k in j["keys"])))' "$tmp/speak.json"
"$bin" speak "$src/assets/facecap/facecap.glb" --text "Please pass the map." -o "$tmp/speak.wav" -q
"$bin" speak "$src/assets/facecap/facecap.glb" --audio "$tmp/speak.wav" --transcript "Please pass the map." -o "$tmp/heard.json" -q
check "speak --audio --transcript: its own WAV heard back, aligned, closures found" py 'import json,sys
j=json.load(open(sys.argv[1])); sys.exit(not(j["source"]=="pocketsphinx-aligned" and sum(1 for x in j["visemes"] if x["viseme"]=="PP")>=2))' "$tmp/heard.json"
"$bin" speak "$uka" --text "Good morning." --width 128 --height 128 --fps 25 -o "$tmp/speak.webm" -q; rc=$?
check "speak -o X.webm: Uka speaking, VP9 + Opus as ffprobe reads them" sh -c "[ $rc -eq 0 ] && ffprobe -v error -show_entries stream=codec_name -of csv=p=0 '$tmp/speak.webm' | tr '\n' ' ' | grep -q 'vp9 opus'"
err_case "speak -o x.mp4: refused, naming the formats it writes (not JSON into x.mp4)" "speak writes .json, .wav, .webm or .ndjson" speak "$src/assets/facecap/facecap.glb" --text "Hello" -o "$tmp/x.mp4"
check "  ... and writes no x.mp4" test ! -e "$tmp/x.mp4"
err_case "speak on a rig without a mouth: says what it lacks" "has no mouth to speak with" speak "$A/AnimatedMorphCube/AnimatedMorphCube.gltf" --text "Hello" -o "$tmp/x.json"

# capture: a tracker's landmarks as the rig's weights (issue 64), as the route does
python3 "$src/tests/integration/capture_frames.py" "$src/assets/trackers/mediapipe/canonical_face_model.obj" "$tmp/frames.json"
"$bin" capture "$src/assets/facecap/facecap.glb" "$tmp/frames.json" -o "$tmp/captured.json" 2>"$tmp/err"; rc=$?
check "capture: 20 keys, jawOpen the largest weight once the jaw turns, the time per frame said" py 'import json,sys
d=json.load(open(sys.argv[1])); w=d["keys"][19]["weights"]
sys.exit(not(len(d["keys"])==20 and d["keys"][0]["weights"]=={} and max(w, key=w.get)=="jawOpen" and "ms a frame" in open(sys.argv[2]).read()))' "$tmp/captured.json" "$tmp/err"
err_case "capture with a frame of 3 points: names the frame" "/frames/0" capture "$src/assets/facecap/facecap.glb" <(echo '{"image":[640,480],"frames":[[[1,2,3],[1,2,3],[1,2,3]]]}') -o "$tmp/x.json"

finish
