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
echo "server RSS before: $(rss)"
echo "== mesh route, random weights per request, f32 (64 connections, ${secs}s)"
wrk -t1 -c64 -d"${secs}s" --timeout 5s --latency -s "$here/random_weights.lua" "http://127.0.0.1:$port/"
echo "== mesh route on the MakeHuman face (13,380 vertices, 286 shapes), 4 random controls per request, f32"
wrk -t1 -c64 -d"${secs}s" --timeout 5s --latency -s "$here/random_controls.lua" "http://127.0.0.1:$port/"
echo "== render route on the MakeHuman face, 512x512 PNG framed on the shapes, random controls (${secs}s)"
wrk -t1 -c8 -d"${secs}s" --timeout 10s --latency -s "$here/random_controls.lua" "http://127.0.0.1:$port/" -- render
echo "== /healthz (64 connections, ${secs}s)"
wrk -t1 -c64 -d"${secs}s" --timeout 5s --latency "http://127.0.0.1:$port/healthz"
echo "server RSS after: $(rss)"
curl -s "http://127.0.0.1:$port/metrics" | grep -E '^facespace_(blends_total|cache_requests_total|http_requests_total\{route="/v1/rigs/\{id\}/mesh")'
