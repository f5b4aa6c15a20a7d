#!/usr/bin/env bash
# The landmarks FaceCap and Uka carry (iBUG 300-W's 68, in their manifests), drawn where a labelled batch
# says they are: a 512² front render of each rig's neutral face from `facespace batch --labels landmarks`,
# each landmark a dot (red: visible, blue: hidden) from its KEY.json "xy". Writes OUT (render/docs/landmarks.png).
# usage: landmarks_picture.sh FACESPACE_BINARY OUT.png
set -eu
bin=$(realpath "$1"); out=$2
src=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
for rig in facecap/facecap.glb uka/MS_Uka.pmx; do
  name=$(basename "${rig%%/*}")
  echo '{"id": "front", "weights": {}}' > "$tmp/v.jsonl"
  "$bin" batch "$src/assets/$rig" --variants "$tmp/v.jsonl" --labels landmarks --width 512 --height 512 --zoom 1.4 --no-sheet -q -o "$tmp/$name" >/dev/null 2>&1
  python3 - "$tmp/$name/front.json" "$tmp/$name/front.png" "$tmp/$name.png" <<'PY'
import json, subprocess, sys
j = json.load(open(sys.argv[1]))
args = ["oiiotool", sys.argv[2], "--ch", "R,G,B"]
for i, l in enumerate(j["landmarks"]):
    x, y = (int(v) for v in l["xy"])
    args += [f"--box:color={'1,0.05,0.05' if l['visible'] else '0.1,0.3,1'}:fill=1", f"{x - 2},{y - 2},{x + 2},{y + 2}",
             f"--text:x={x + 4}:y={y - 3}:size=11:color=0.1,0.1,0.6:font=/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", str(i + 1)]
subprocess.run(args + ["-o", sys.argv[3]], check=True)
PY
done
oiiotool "$tmp/facecap.png" "$tmp/uka.png" --mosaic 2x1 -o "$out"
echo "wrote $out"
