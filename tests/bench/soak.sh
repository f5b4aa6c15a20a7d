#!/usr/bin/env bash
# Soak: `facespace serve` under a mixed load for a long time, its memory sampled throughout.
#   - FaceCap mesh route, 32 connections, random weights (tests/bench/random_weights.lua)
#   - MakeHuman mesh route, 32 connections, random controls (random_controls.lua)
#   - MakeHuman 512x512 renders, 64 connections (more than the render contexts: they queue)
# Every response is a new point, so the response cache cannot hide the work.
# Writes OUT/rss.tsv (seconds, RSS kB, threads, heap in use kB and response cache kB from
# /metrics: in-use flat while RSS moves is the allocator's fragmentation, in-use growing a
# leak), OUT/wrk-*.txt and, when gnuplot is
# installed, OUT/rss.png; prints the RSS figures, the growth over the second half and the
# RSS once the load has stopped.
# usage: soak.sh FACESPACE_BINARY [SECONDS=600] [OUT=build/soak]
set -euo pipefail
bin=$1; secs=${2:-600}; out=${3:-build/soak}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
port=$(python3 -c 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])')
"$bin" serve --host 127.0.0.1 --port "$port" --quiet 2>"$out/serve.log" &
pid=$!
trap 'kill $pid 2>/dev/null; wait $pid 2>/dev/null || true' EXIT
for _ in $(seq 1 100); do curl -fs "http://127.0.0.1:$port/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
url="http://127.0.0.1:$port/"
rss() { awk '/VmRSS/ {print $2}' /proc/$pid/status; }
gauges() { curl -s --max-time 10 "http://127.0.0.1:$port/metrics" | awk '/^facespace_heap_in_use_bytes/ {h=$2} /^facespace_cache_bytes/ {c=$2} END {printf "%d\t%d", h/1024, c/1024}'; }
start=$(date +%s)
printf 'seconds\trss_kb\tthreads\theap_kb\tcache_kb\n' >"$out/rss.tsv"
printf '0\t%s\t%s\t%s\n' "$(rss)" "$(ls /proc/$pid/task | wc -l)" "$(gauges)" >>"$out/rss.tsv"

wrk -t1 -c32 -d"${secs}s" --timeout 5s --latency -s "$here/random_weights.lua" "$url" >"$out/wrk-facecap-mesh.txt" &
w1=$!
wrk -t1 -c32 -d"${secs}s" --timeout 5s --latency -s "$here/random_controls.lua" "$url" >"$out/wrk-makehuman-mesh.txt" &
w2=$!
wrk -t1 -c64 -d"${secs}s" --timeout 30s --latency -s "$here/random_controls.lua" "$url" -- render >"$out/wrk-makehuman-render.txt" &
w3=$!
while kill -0 $w1 2>/dev/null || kill -0 $w2 2>/dev/null || kill -0 $w3 2>/dev/null; do
  sleep 5
  now=$(( $(date +%s) - start ))
  printf '%s\t%s\t%s\t%s\n' "$now" "$(rss)" "$(ls /proc/$pid/task | wc -l)" "$(gauges)" >>"$out/rss.tsv"
  if [ $((now % 60)) -lt 5 ]; then echo "soak: ${now}s of ${secs}s, RSS $(( $(rss) / 1024 )) MB, heap in use $(( $(gauges | cut -f1) / 1024 )) MB" >&2; fi
done
wait $w1 $w2 $w3
sleep 15
idle_after=$(rss)

for f in facecap-mesh makehuman-mesh makehuman-render; do
  echo "== $f"
  grep -E 'requests in|Requests/sec|99%|Socket errors|Non-2xx' "$out/wrk-$f.txt" || true
done
echo "RSS 15 s after the load stopped: $(( idle_after / 1024 )) MB"
python3 - "$out/rss.tsv" "$secs" <<'EOF'
import sys
rows = [tuple(map(float, l.split('\t'))) for l in open(sys.argv[1]).read().split('\n')[1:] if l]
secs = float(sys.argv[2])
mb = lambda kb: kb / 1024
half = [r for r in rows if r[0] >= secs / 2]
first_min = [r for r in rows if r[0] <= 60]
print(f"RSS: {mb(rows[0][1]):.0f} MB idle, {mb(max(r[1] for r in first_min)):.0f} MB max in the first minute, "
      f"{mb(max(r[1] for r in rows)):.0f} MB max, {mb(rows[-1][1]):.0f} MB at the end; threads {int(max(r[2] for r in rows))}")
if len(half) >= 2:
    n = len(half); mx = sum(r[0] for r in half) / n; my = sum(r[1] for r in half) / n
    slope = sum((r[0] - mx) * (r[1] - my) for r in half) / max(sum((r[0] - mx) ** 2 for r in half), 1e-9)
    print(f"second half: {mb(min(r[1] for r in half)):.0f}-{mb(max(r[1] for r in half)):.0f} MB, "
          f"trend {slope * 60 / 1024:+.2f} MB/min")
    my = sum(r[3] for r in half) / n
    hslope = sum((r[0] - mx) * (r[3] - my) for r in half) / max(sum((r[0] - mx) ** 2 for r in half), 1e-9)
    print(f"heap in use, second half: {mb(min(r[3] for r in half)):.0f}-{mb(max(r[3] for r in half)):.0f} MB, "
          f"trend {hslope * 60 / 1024:+.2f} MB/min; response cache {mb(half[-1][4]):.0f} MB")
EOF
if command -v gnuplot >/dev/null; then
  gnuplot -e "set terminal png size 900,400; set output '$out/rss.png'; set title 'facespace serve RSS under the soak load'; \
    set xlabel 'seconds'; set ylabel 'MB'; set yrange [0:*]; set grid; set key outside bottom center horizontal; \
    plot '$out/rss.tsv' using 1:(\$2/1024) skip 1 with lines lw 2 title 'RSS', \
         '' using 1:(\$4/1024) skip 1 with lines lw 2 title 'heap in use', '' using 1:(\$5/1024) skip 1 with lines lw 2 title 'response cache'"
  echo "plot: $out/rss.png"
fi
