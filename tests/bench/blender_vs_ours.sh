#!/usr/bin/env bash
# Labelled samples side by side (issue 52): Blender 3.4 (Debian's; peer/blender_dataset.py: its glTF importer,
# seeded shape keys, a render with depth and normal passes as one multilayer EXR a sample, as BlenderProc makes
# them) against `facespace batch --labels depth,normals,segmentation,landmarks --archive tar` of the same rig,
# size and weight sampling, same run, this machine's every core. All three engines run headless here (llvmpipe);
# Workbench has no normal pass, so its EXR holds the picture and depth only. An engine that fails is said and skipped.
# usage: blender_vs_ours.sh FACESPACE_BINARY [N_BLENDER] [N_OURS] [SIZE]   (needs: apt-get install blender)
set -eu
bin=$(realpath "$1"); nb=${2:-20}; no=${3:-1500}; size=${4:-256}
src=$(cd "$(dirname "$0")/../.." && pwd)
# Blender's FaceCap without meshopt compression (Blender 3.4's importer has no EXT_meshopt_compression); ours
# the bundled one, the same mesh, with its manifest's landmarks.
rig=${FACESPACE_BENCH_RIG:-$src/../shared/assets/real/FaceCap/facecap_decoded.glb}
command -v blender >/dev/null || { echo "blender is not installed (apt-get install blender)" >&2; exit 1; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/fs-blender.XXXXXX"); trap 'rm -rf "$tmp"' EXIT
for engine in BLENDER_WORKBENCH BLENDER_EEVEE CYCLES; do
  mkdir -p "$tmp/$engine"
  line=$(blender -b --factory-startup -P "$src/tests/bench/peer/blender_dataset.py" -- "$rig" "$tmp/$engine" "$nb" "$size" "$engine" 2>&1 |
         grep '^{"engine"' || true)
  if [ -z "$line" ]; then echo "blender $engine: did not render here"; continue; fi
  python3 -c "import json,sys; j=json.loads(sys.argv[1]); print(f\"blender {j['engine']}: {j['per_sample_ms']:.1f} ms a sample ({1000/j['per_sample_ms']:.2f}/s), {j['samples']} samples at {j['size']}²\")" "$line"
done
line=$("$bin" batch "$src/assets/facecap/facecap.glb" --sample uniform --count "$no" --seed 1 --active 4 --sum-at-most-one --width "$size" --height "$size" \
  --labels depth,normals,segmentation,landmarks --archive tar --no-sheet -o "$tmp/ours" 2>&1 | grep "^batch:" | tail -1)
echo "ours: $line"
