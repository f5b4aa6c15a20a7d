#!/usr/bin/env bash
# HTTP load: wrk beside `facespace serve` on loopback, 64 keep-alive connections.
#   1. the mesh route on the bundled rig, a new random weight vector per request, float32 out
#   2. the same on the MakeHuman face with random controls, and its render route
#   3. /healthz, for comparison
# usage: load.sh FACESPACE_BINARY [SECONDS]   (bounded: each run stops after SECONDS, default 15)
set -euo pipefail
bin=$1; secs=${2:-15}
here=$(cd "$(dirname "$0")" && pwd)
port=$(python3 -c 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])')
"$bin" serve --host 127.0.0.1 --port "$port" --quiet 2>/tmp/facespace_load.log &
pid=$!
trap 'kill $pid 2>/dev/null' EXIT
for _ in $(seq 1 100); do curl -fs "http://127.0.0.1:$port/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
rss() { awk '/VmRSS/ {print $2 " kB"}' /proc/$pid/status; }
cpu_ticks() { awk '{print $14 + $15}' /proc/$pid/stat; }
# One wrk run, shown whole; then its requests per second and the server's CPU per request (from
# /proc, steadier than requests per second on a shared VM) into $rate and $cpu_us.
run() {
  local c0 out n
  c0=$(cpu_ticks)
  out=$(wrk "$@")
  echo "$out"
  n=$(awk '/requests in/ {print $1}' <<<"$out")
  rate=$(awk '/Requests\/sec/ {print $2}' <<<"$out")
  cpu_us=$(python3 -c "print(round(($(cpu_ticks) - $c0) * 1e6 / $(getconf CLK_TCK) / max($n, 1), 1))")
  echo "server CPU: $cpu_us us a request"
}
echo "server RSS before: $(rss)"
echo "== mesh route, random weights per request, f32 (64 connections, ${secs}s)"
run -t1 -c64 -d"${secs}s" --timeout 5s --latency -s "$here/random_weights.lua" "http://127.0.0.1:$port/"
mesh_rate=$rate mesh_cpu=$cpu_us
echo "== mesh route on the MakeHuman face (13,380 vertices, 286 shapes), 4 random controls per request, f32"
run -t1 -c64 -d"${secs}s" --timeout 5s --latency -s "$here/random_controls.lua" "http://127.0.0.1:$port/"
echo "== render route on the MakeHuman face, 512x512 PNG framed on the shapes, random controls (${secs}s)"
run -t1 -c8 -d"${secs}s" --timeout 10s --latency -s "$here/random_controls.lua" "http://127.0.0.1:$port/" -- render
echo "== /healthz (64 connections, ${secs}s)"
run -t1 -c64 -d"${secs}s" --timeout 5s --latency "http://127.0.0.1:$port/healthz"
echo "server RSS after: $(rss)"
curl -s "http://127.0.0.1:$port/metrics" | grep -E '^facespace_(blends_total|cache_requests_total|http_requests_total\{route="/v1/rigs/\{id\}/mesh")'
echo "== FaceCap mesh route against /healthz in the same run: $mesh_rate / $rate req/s = $(python3 -c "print(round($mesh_rate / $rate, 3))")x;" \
  "server CPU a request $mesh_cpu / $cpu_us us"
