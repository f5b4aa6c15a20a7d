#!/usr/bin/env bash
# Side by side in one run: `facespace batch` and the three.js peer (peer/threejs_batch.mjs: three's
# CPU morph evaluation + GLTFExporter, pinned three) make the same N glb variants of FaceCap from
# the same seeded weight vectors, into the same filesystem (ours also as WebDataset tar shards, one
# sync a group). Each side runs 3 times; medians and the ratio are printed, and one variant's
# positions are compared between the two files.
# usage: batch_vs_threejs.sh FACESPACE_BINARY [N]
set -eu
bin=$(realpath "$1"); n=${2:-500}
src=$(cd "$(dirname "$0")/../.." && pwd)
rig=${FACESPACE_BENCH_RIG:-$src/../shared/assets/real/FaceCap/facecap_decoded.glb}
[ -f "$rig" ] || rig=$src/assets/facecap/facecap.glb
three=0.187.0
peer=$src/build/node-bench
if [ ! -d "$peer/node_modules/three" ] || ! grep -q "\"version\": \"$three\"" "$peer/node_modules/three/package.json"; then
  mkdir -p "$peer" && (cd "$peer" && npm install --no-audit --no-fund --silent --save-exact "three@$three" >/dev/null 2>&1)
fi
cp "$src/tests/bench/peer/threejs_batch.mjs" "$peer/"
tmp=$(mktemp -d "${TMPDIR:-/tmp}/fs-bench.XXXXXX"); trap "rm -rf $tmp" EXIT

ours() {  # jobs [archive] -> "wall_seconds batch_seconds" (after a sync, so neither side pays for the other's write-back)
  local out=$tmp/ours${2:+-$2}
  rm -rf "$out"; sync
  local start end line
  start=$(date +%s.%N)
  line=$("$bin" batch "$rig" --sample uniform --count "$n" --seed 1 --format glb --out "$out" --no-sheet --quiet --jobs "$1" ${2:+--archive $2} 2>&1 | grep "^batch:" | tail -1)
  end=$(date +%s.%N)
  python3 -c "import re,sys; print(float(sys.argv[2]) - float(sys.argv[1]), re.search(r'in ([0-9.]+) s,', sys.argv[3]).group(1))" "$start" "$end" "$line"
}
peer() {
  rm -rf "$tmp/peer"; sync
  (cd "$peer" && node threejs_batch.mjs "$rig" "$tmp/manifest.jsonl" "$tmp/peer" 2>"$tmp/peer.log" >"$tmp/peer.json") ||
    { cat "$tmp/peer.log" >&2; exit 1; }
  python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['seconds'])" "$tmp/peer.json"
}
ours "$(nproc)" >/dev/null && cp "$tmp/ours/manifest.jsonl" "$tmp/manifest.jsonl"
for i in 1 2 3; do
  echo "ours2 $(ours "$(nproc)")"; echo "ourstar $(ours "$(nproc)" tar)"; echo "ours1 $(ours 1)"; echo "peer $(peer)"
done > "$tmp/runs"
python3 - "$tmp" "$n" "$(nproc)" "$three" <<'PY'
import json, struct, statistics, sys
tmp, n, cores, three = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
runs = {}
for line in open(f"{tmp}/runs"):
    k, *v = line.split(); runs.setdefault(k, []).append([float(x) for x in v])
med = lambda k, i: statistics.median(r[i] for r in runs[k])
peer = med("peer", 0) / n * 1000
print(f"glb variants of FaceCap, {n} seeded uniform weight vectors, {cores} cores, 3 runs each (medians):")
for k, label in (("ours2", f"facespace batch, {cores} workers"), ("ourstar", f"  the same, --archive tar"), ("ours1", "facespace batch, 1 worker")):
    wall, work = med(k, 0) / n * 1000, med(k, 1) / n * 1000
    print(f"  {label:32} {work:6.3f} ms a variant ({1000 / work:6.0f}/s), {wall:6.3f} ms with the process's start"
          f"  -> {peer / work:5.1f}x three.js ({peer / wall:4.1f}x with start)")
print(f"  {'three.js ' + three + ' + GLTFExporter':32} {peer:6.3f} ms a variant ({1000 / peer:6.0f}/s), one thread (Node)")
def positions(path):
    b = open(path, "rb").read(); jl = struct.unpack("<I", b[12:16])[0]; j = json.loads(b[20:20 + jl]); bin0 = 28 + jl
    out = []
    for m in j["meshes"]:
        for p in m["primitives"]:
            a = j["accessors"][p["attributes"]["POSITION"]]; v = j["bufferViews"][a["bufferView"]]
            o = bin0 + v.get("byteOffset", 0) + a.get("byteOffset", 0)
            out.append(struct.unpack(f"<{3 * a['count']}f", b[o:o + 12 * a["count"]]))
    return out
a, b = positions(f"{tmp}/ours/v000007.glb"), positions(f"{tmp}/peer/v000007.glb")
flat = [x for p in a for x in p]
diag = sum((max(flat[c::3]) - min(flat[c::3])) ** 2 for c in range(3)) ** 0.5
gap = max(abs(x - y) for p, q in zip(a, b) for x, y in zip(p, q))
print(f"  variant 7: the two files' positions agree within {gap / diag:.1e} of the diagonal")
print(f"  20x three.js is {peer / 20:.3f} ms a variant, blending and encoding included")
PY
# The disk's floor: the same number of files of a variant's size made durable by our writer alone,
# nothing blended or encoded (tests/bench/durable_floor.cpp); a variant in a folder costs no less.
floor=$(dirname "$bin")/../tests/bench/durable_floor
if [ -x "$floor" ]; then
  "$floor" "$tmp/floor" "$n" "$(stat -c %s "$tmp/ours/v000007.glb")" | sed 's/^/  /'
fi
