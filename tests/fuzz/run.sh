#!/usr/bin/env bash
# Replays the committed regression inputs of every libFuzzer target, then runs each on seed corpora
# from the real assets and the test requests for its share of SECONDS (at least 10 s), as many at
# once as there are cores. Prints executions and coverage per target.
# usage: run.sh BUILD_DIR SECONDS [SHARED_ASSETS]
set -u
build=$1; budget=$2
src=$(cd "$(dirname "$0")/../.." && pwd)
shared=${3:-$src/../shared/assets}
corpus=$build/corpus
targets="fuzz_gltf fuzz_obj fuzz_md5 fuzz_fbx fuzz_dae fuzz_pmx fuzz_vmd fuzz_request fuzz_http fuzz_speech fuzz_live fuzz_made fuzz_mocap"
for t in $targets; do mkdir -p "$corpus/$t"; done
set -- $targets
seconds=$((budget / $#)); [ $seconds -ge 10 ] || seconds=10
# Seeds: every real glb/gltf we have (small ones whole), OBJ files and targets, the test requests.
for f in "$src"/assets/*/*.glb "$shared"/real/*/*.glb "$shared"/real/*/*.gltf; do
  [ -f "$f" ] && [ "$(stat -c %s "$f")" -lt 3000000 ] && cp "$f" "$corpus/fuzz_gltf/$(basename "$f")"
done
for f in "$shared"/more/OBJ/ICT-FaceKit_subset/*.obj; do [ -f "$f" ] && { printf '\0'; head -c 200000 "$f"; } >"$corpus/fuzz_obj/$(basename "$f")"; done
for f in "$shared"/more/MakeHumanFace/targets/nose/*.target; do [ -f "$f" ] && { printf '\1'; cat "$f"; } >"$corpus/fuzz_obj/$(basename "$f")"; done
# A MakeHuman proxy fitted to the fuzzer's four-vertex base (and the real eyes, whose indices are beyond it).
printf '\2obj_file p.obj\nx_scale 0 1 1.0\ny_scale 0 3 2.0\nverts 0\n0 1 2 0.5 0.3 0.2 0.01 0 0\n1\n3 2 1 0.2 0.2 0.6 0 0 0.1\n' >"$corpus/fuzz_obj/proxy.mhclo"
[ -f "$shared/more/MakeHumanFace/eyes/high-poly.mhclo" ] && { printf '\2'; head -c 20000 "$shared/more/MakeHumanFace/eyes/high-poly.mhclo"; } >"$corpus/fuzz_obj/eyes.mhclo"
md5=$shared/more/MD5/Bob
if [ -f "$md5/Bob.md5mesh" ]; then
  { printf '\0'; cat "$md5/Bob.md5mesh"; } >"$corpus/fuzz_md5/bob"
  { printf '\1'; cat "$md5/Bob.md5mesh"; printf '\0'; head -c 60000 "$md5/Bob.md5anim"; } >"$corpus/fuzz_md5/bob_anim_cut"
  { printf '\1'; cat "$md5/Bob.md5mesh"; printf '\0'; cat "$md5/Bob.md5anim"; } >"$corpus/fuzz_md5/bob_anim"
fi
for f in "$shared"/more/FBX/*/*.fbx; do [ -f "$f" ] && cp "$f" "$corpus/fuzz_fbx/$(basename "$f")"; done
for f in "$shared"/more/Collada/*/*.dae; do [ -f "$f" ] && cp "$f" "$corpus/fuzz_dae/$(basename "$f")"; done
[ -f "$shared/more/MMD/Uka/MS_Uka.pmx" ] && cp "$shared/more/MMD/Uka/MS_Uka.pmx" "$corpus/fuzz_pmx/uka.pmx"
[ -f "$shared/more/MMD/Uka_PMD/MS_Uka.pmd" ] && cp "$shared/more/MMD/Uka_PMD/MS_Uka.pmd" "$corpus/fuzz_pmx/uka.pmd"
cp "$src/tests/data/every_morph_kind.pmx" "$corpus/fuzz_pmx/every_morph_kind.pmx"  # UV, flip, impulse morphs: small.
# Speech: a WAV from flite (8 kHz) and a few from espeak's rates and sample formats; timed phonemes in IPA and ARPAbet.
if command -v flite >/dev/null; then
  flite -t "Please pass the map." -o "$corpus/fuzz_speech/flite.raw" && { printf '\0'; head -c 20000 "$corpus/fuzz_speech/flite.raw"; } >"$corpus/fuzz_speech/flite.wav"
  rm -f "$corpus/fuzz_speech/flite.raw"
fi
printf '\1_ 0 0.1\nh 0.1 0.15\nə 0.15 0.2\nl 0.2 0.3\nˈəʊ 0.3 0.5\n_ 0.5 0.53\nm 0.53 0.6\n' >"$corpus/fuzz_speech/ipa"
printf '\1SIL 0 0.2\nP 0.2 0.25\nAE1 0.25 0.4\nS 0.4 0.5\n+NSN+ 0.5 0.9\nM 0.9 0.92\nUW 0.92 1.3\n' >"$corpus/fuzz_speech/arpabet"
for f in "$src"/assets/uka/motion/*.vmd; do [ -f "$f" ] && cp "$f" "$corpus/fuzz_vmd/$(basename "$f")"; done
python3 - "$corpus" <<'PY'
import json, os, sys
c = sys.argv[1]
req = [
  (0, {"weights": {"jawOpen": 0.5, "mouthSmile_L": 1.2}, "mode": "absolute", "normals": "recompute", "format": "glb", "lod": 1}),
  (0, {"weights": [0.1, 0.2], "pose": {"Hips": {"euler": [0, 30, 0]}}, "animation": 0, "time": 0.5, "loop": True}),
  (0, {"controls": {"nose/nose-trans-down|up": -0.4}, "blend": [{"animation": 0, "time": 1, "weight": 0.5, "mask": ["Hips"]}]}),
  (1, {"weights": {"jawOpen": 1}, "view": "heatmap", "width": 64, "height": 64, "camera": {"yaw": 20, "frame": "shapes"}, "background": "#ff000080"}),
  (2, {"cells": [{"weights": {"jawOpen": 1}, "label": "a"}, {"weights": {"eyeBlink_L": 1}}], "columns": 2}),
  (3, {"keys": [{"time": 0}, {"time": 1, "shape": "jawOpen"}, {"time": 2, "weights": {"eyeBlink_L": 1}, "transition": "cubic-bezier(0.1,0.7,1,0.1)"}], "times": [0.5, 1.5], "smooth": True}),
  (4, {"sample": {"method": "gaussian", "count": 5, "seed": 3, "center": {"jawOpen": 0.5}, "spread": 0.2, "symmetric": True, "active": 3}, "format": "png"}),
  (4, {"sample": {"method": "grid", "shapes": ["jawOpen", "mouthSmile_L"], "count": 9}}),
  (4, {"sample": {"method": "uniform", "count": 9}, "labels": ["depth", "landmarks"], "archive": "tar", "shard_samples": 4,
       "randomize": {"seed": 2, "camera": {"yaw": [-30, 30]}, "light": {"exposure": [-1, 1]}, "background": "random",
                     "expressions": {"happy": [0, 1]}, "gaze": {"yaw": [-10, 10]}}}),
  (255, {"regions": {"skin": {"meshes": ["head"]}, "eyes": {"meshes": ["eyeLeft"]}}, "landmarks": {"scheme": "x",
         "points": [{"name": "a", "mesh": "head", "vertex": 3}, {"name": "b", "mesh": "head", "vertices": [1, 2, 3], "weights": [0.2, 0.3, 0.5]}]}}),
  (5, {"target": {"primitives": [{"positions": [0, 0, 0]}]}, "bounded": True, "rigid_align": True}),
  (254, {"from": "facecap", "as": "head-arkit", "shapes": ["arkit", "visemes"], "landmarks": {"scheme": "ibug-300w-68",
         "points": [{"name": "nose_1", "vertex": 3}, {"name": "eye_l_1", "position": [0.01, 0.02, 0.03]}, {"name": "x", "mesh": "m", "vertex": 0}]}}),
  (253, {"scheme": "mediapipe-468", "image": [640, 480], "fps": 30, "neutral": 0,
         "frames": [[[i % 50, i // 50, 0] for i in range(468)]]}),
]
for i, (k, body) in enumerate(req):
    with open(os.path.join(c, "fuzz_request", f"seed{i}"), "wb") as f:
        f.write(bytes([k]) + json.dumps(body).encode())
http = [
  "GET /v1/rigs/facecap/mesh?w.jawOpen=0.5&format=obj&lod=1 HTTP/1.1\r\nHost: x\r\n\r\n",
  "GET /v1/rigs HTTP/1.1\r\nHost: x\r\nOrigin: http://front.test\r\n\r\n",
  "OPTIONS /v1/rigs/facecap/mesh HTTP/1.1\r\nHost: x\r\nOrigin: http://front.test\r\nAccess-Control-Request-Method: POST\r\n\r\n",
  "GET /v1/rigs/facecap/render?w.jawOpen=1&width=16&height=16 HTTP/1.1\r\nHost: x\r\nIf-None-Match: \"x\"\r\n\r\n",
  "GET /v1/rigs/facecap/topology HTTP/1.1\r\nHost: x\r\n\r\n",
  "DELETE /v1/rigs/x HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer fuzz-key\r\n\r\n",
  # The front's framing: chunks with an extension and a trailer, a request pipelined behind another.
  "POST /v1/rigs/facecap/check HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n"
  "5;x=1\r\n{\"wei\r\ne\r\nghts\":{\"0\":1}}\r\n0\r\nX-T: 1\r\n\r\n",
  "\r\nGET /healthz HTTP/1.1\r\nHost: x\r\nExpect: 100-continue\r\nContent-Length: 0\r\n\r\nGET /readyz HTTP/1.1\r\n\r\n",
]
bodies = [
  ("POST", "/v1/rigs/facecap/mesh", {"weights": {"jawOpen": 0.5}, "format": "f32"}),
  ("POST", "/v1/rigs/facecap/check", {"weights": {"jawOpen": 2}, "strict": True}),
  ("POST", "/v1/rigs/facecap/sequence/sample", {"keys": [{"time": 0}, {"time": 1, "shape": "jawOpen"}], "times": [0.5]}),
  ("POST", "/v1/rigs/facecap/sequence/stream", {"keys": [{"time": 0}, {"time": 1, "shape": "jawOpen"}], "fps": 4, "format": "ndjson"}),
  ("POST", "/v1/rigs/facecap/batch", {"sample": {"method": "uniform", "count": 2}}),
  ("POST", "/v1/rigs/facecap/sheet", {"cells": [{"weights": {}}], "width": 16, "height": 16}),
]
for m, p, b in bodies:
    t = json.dumps(b)
    http.append(f"{m} {p} HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {len(t)}\r\n\r\n{t}")
small = open(os.path.join(os.path.dirname(c), "..", "..", "shared", "assets", "real", "SimpleMorph", "SimpleMorph.gltf"), "rb").read() if False else b""
for i, h in enumerate(http):
    with open(os.path.join(c, "fuzz_http", f"seed{i}"), "wb") as f:
        f.write(h.encode())
PY
f="$shared/real/TriangleWithoutIndices/TriangleWithoutIndices.gltf"
[ -f "$shared/real/SimpleMorph/SimpleMorph.gltf" ] && f="$shared/real/SimpleMorph/SimpleMorph.gltf"
if [ -f "$f" ]; then
  { printf 'PUT /v1/rigs/up HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer fuzz-key\r\nContent-Type: model/gltf+json\r\nContent-Length: %s\r\n\r\n' "$(stat -c %s "$f")"; cat "$f"; } >"$corpus/fuzz_http/put"
fi
# Live: the RFC's masked "Hello", a 16-bit length and a fragmented message with a ping between (cap byte first).
printf '\1\x81\x85\x37\xfa\x21\x3d\x7f\x9f\x4d\x51\x58' >"$corpus/fuzz_live/hello"
printf '\1\x01\x82\0\0\0\0{"\x89\x80\0\0\0\0\x80\x81\0\0\0\0}' >"$corpus/fuzz_live/fragments"
# Datagrams (issue 64): a VMC bundle of a blend and its Apply as VSeeFace sends it, and an iPhone's iFacialMocap line.
python3 - "$corpus/fuzz_mocap" <<'PY'
import os, struct, sys
def s(x): x = x.encode() + b"\0"; return x + b"\0" * (-len(x) % 4)
val = s("/VMC/Ext/Blend/Val") + s(",sf") + s("Blink_L") + struct.pack(">f", 0.5)
apply = s("/VMC/Ext/Blend/Apply") + s(",")
bone = s("/VMC/Ext/Bone/Pos") + s(",sfffffff") + s("Head") + struct.pack(">7f", 0, 1.4, 0, 0, 0, 0, 1)
bundle = b"#bundle\0" + struct.pack(">II", 0, 1) + b"".join(struct.pack(">I", len(m)) + m for m in (val, bone, apply))
open(os.path.join(sys.argv[1], "vmc"), "wb").write(b"\0" + bundle)
open(os.path.join(sys.argv[1], "blob"), "wb").write(b"\0" + s("/b") + s(",bTNhd") + struct.pack(">I", 3) + b"xyz\0" + b"\0" * 16)
line = b"mouthSmile_R-35|eyeBlink_L-100|jawOpen&12.5|=head#-21.4,-6.0,-6.6,-0.03,-0.1,-0.65|rightEye#6.0,2.4,0.2|leftEye#6.0,-1.6,-0.1|"
open(os.path.join(sys.argv[1], "ifacialmocap"), "wb").write(b"\1" + line)
PY
# A maker's messages (api/batch/src/maker.h): a tar sample, a folder variant of two files, a maker's error.
python3 - "$corpus/fuzz_made" <<'PY'
import os, struct, sys
def piece(b): return struct.pack("<Q", len(b)) + b
def made(head, tail, total, codes, tar, files):
    m = struct.pack("<Q", 0) + piece(b"") + piece(b"") + piece(head) + piece(tail) + struct.pack("<d", total) + piece(codes) + piece(tar)
    return m + struct.pack("<Q", len(files)) + b"".join(piece(n) + piece(b) for n, b in files)
seeds = {
  "tar": made(b'{"id":"v000001","index":1,', b',"files":[]}', 2.5, b"extrapolation\n", b"v000001.json" + b"\0" * 500, []),
  "folder": made(b'{"id":"v000002"', b"}", 0.25, b"", b"", [(b"v000002.obj", b"v 0 0 0\n"), (b"v000002.png", b"\x89PNG\r\n")]),
  "error": struct.pack("<Q", 3) + piece(b"/weights/jawOpen: not a number") + piece(b"invalid-weights"),
}
for name, b in seeds.items():
    open(os.path.join(sys.argv[1], name), "wb").write(b)
PY
export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1:intercept_tls_get_addr=0 LSAN_OPTIONS=suppressions=$src/tests/lsan.supp UBSAN_OPTIONS=halt_on_error=1
# One target: its regression inputs, then the timed run; what it found in $build/$t.summary, its
# exit code in $build/$t.rc. Targets run as many at once as there are cores.
run_target() {
  local t=$1 failed=0 rc execs rate cov crashes
  mkdir -p "$build/artifacts/$t"
  {
    # Regressions first: every input once; then the timed run.
    if [ -d "$src/tests/fuzz/regressions/$t" ] && ls "$src/tests/fuzz/regressions/$t"/* >/dev/null 2>&1; then
      "$build/tests/fuzz/$t" "$src/tests/fuzz/regressions/$t"/* >"$build/$t.regress.log" 2>&1 || { echo "FAIL $t regression inputs"; tail -30 "$build/$t.regress.log"; failed=1; }
    fi
    "$build/tests/fuzz/$t" "$corpus/$t" -max_total_time="$seconds" -rss_limit_mb=4096 -max_len=1048576 -timeout=30 \
      -print_final_stats=1 -artifact_prefix="$build/artifacts/$t/" >"$build/$t.log" 2>&1
    rc=$?
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$build/$t.log" | grep -o '[0-9]*$')
    rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$build/$t.log" | grep -o '[0-9]*$')
    cov=$(grep -o 'cov: [0-9]*' "$build/$t.log" | tail -1 | grep -o '[0-9]*')
    crashes=$(ls "$build/artifacts/$t" | wc -l)
    printf '%-14s %12s %10s %8s %6s\n' "$t" "${execs:-?}" "${rate:-?}" "${cov:-?}" "$crashes"
    if [ $rc -ne 0 ] || [ "$crashes" -ne 0 ]; then echo "FAIL $t (exit $rc): see $build/$t.log"; grep -A25 'ERROR\|==ERROR\|runtime error\|deadly signal' "$build/$t.log" | head -40
      # The input itself, so a crash found on a CI machine can be replayed anywhere (base64 -d > file).
      for a in "$build/artifacts/$t"/*; do
        [ -f "$a" ] || continue
        echo "input $(basename "$a") ($(stat -c %s "$a") bytes), base64 (first 16 KiB):"; head -c 16384 "$a" | base64 -w 120
      done
      failed=1; fi
  } >"$build/$t.summary" 2>&1
  echo $failed >"$build/$t.rc"
}
fail=0
at_once=$(nproc)
for t in $targets; do
  while [ "$(jobs -rp | wc -l)" -ge "$at_once" ]; do wait -n; done
  run_target "$t" &
done
wait
printf '%-14s %12s %10s %8s %6s\n' target executions exec/s cov crashes
for t in $targets; do
  cat "$build/$t.summary"
  [ "$(cat "$build/$t.rc" 2>/dev/null)" = 0 ] || fail=1
done
exit $fail
