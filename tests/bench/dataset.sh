#!/usr/bin/env bash
# Labelled samples a second (issue 52): `facespace batch --labels depth,normals,segmentation,landmarks
# --archive tar` of FaceCap and Uka at 256² and 512², camera, light and background drawn per sample,
# every core (a maker process a job; WORKERS=threads for threads); beside the same batch as plain PNG
# renders. 3 runs each, medians, the batch's own seconds (its line), not the process start.
# usage: dataset.sh FACESPACE_BINARY [N256] [N512]
set -eu
bin=$(realpath "$1"); n256=${2:-1500}; n512=${3:-400}
src=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d "${TMPDIR:-/tmp}/fs-dataset.XXXXXX"); trap 'rm -rf "$tmp"' EXIT
random='{"camera": {"yaw": [-30, 30], "pitch": [-10, 10]}, "light": {"yaw": [-60, 60], "exposure": [-0.5, 0.5]}, "background": "random"}'
rate() {  # rig size count what... -> samples a second
  local rig=$1 size=$2 count=$3; shift 3
  rm -rf "$tmp/out"; sync
  "$bin" batch "$src/assets/$rig" --sample uniform --count "$count" --seed 1 --active 4 --sum-at-most-one --width "$size" --height "$size" \
    --randomize "$random" --archive tar --no-sheet --workers "${WORKERS:-processes}" -o "$tmp/out" "$@" 2>&1 | sed -n 's/.* \([0-9.]*\) variants\/s.*/\1/p' | tail -1
}
printf '%-8s %-5s %-12s %s\n' rig size labels "samples/s (3 runs, median)"
for rig in facecap/facecap.glb uka/MS_Uka.pmx; do
  for size in 256 512; do
    count=$([ "$size" = 256 ] && echo "$n256" || echo "$n512")
    for what in png labelled; do
      args=(--format png)
      [ "$what" = labelled ] && args=(--labels depth,normals,segmentation,landmarks)
      runs=$(for i in 1 2 3; do rate "$rig" "$size" "$count" "${args[@]}"; done | sort -n | tr '\n' ' ')
      printf '%-8s %-5s %-12s %s\n' "$(basename "${rig%%/*}")" "$size" "$what" "$(echo "$runs" | awk '{print $2 "  (" $1 "-" $3 ")"}')"
    done
  done
done
