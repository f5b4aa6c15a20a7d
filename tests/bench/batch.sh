#!/usr/bin/env bash
# Batch throughput on the bundled rig: variants per second for glb and png outputs, all cores.
# usage: batch.sh FACESPACE_BINARY [COUNT]
set -eu
bin=$1; n=${2:-1000}
src=$(cd "$(dirname "$0")/../.." && pwd)
rig=$src/assets/facecap/facecap.glb
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
run() {  # format, count, extra flags
  local fmt=$1 count=$2; shift 2
  local start end
  start=$(date +%s.%N)
  "$bin" batch "$rig" --sample uniform --count "$count" --seed 1 --active 8 --format "$fmt" --out "$tmp/$fmt" --no-sheet --quiet "$@" 2>/dev/null
  end=$(date +%s.%N)
  python3 -c "import sys,os; c=int(sys.argv[1]); s=float(sys.argv[3])-float(sys.argv[2]); b=sum(os.path.getsize(os.path.join(sys.argv[5],f)) for f in os.listdir(sys.argv[5])); print(f'{sys.argv[4]:>22}: {c} variants in {s:.2f} s = {c/s:.0f} variants/s, {b/c/1024:.0f} KiB each')" \
    "$count" "$start" "$end" "$fmt $*" "$tmp/$fmt"
  rm -rf "$tmp/$fmt"
}
echo "facespace batch on FaceCap (4,368 vertices, 52 shapes), $(nproc) cores"
run glb "$n"
run obj "$n"
run f32 "$n"
run png $((n / 4)) --width 512 --height 512
run png $((n / 4)) --width 256 --height 256
