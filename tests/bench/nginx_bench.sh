#!/usr/bin/env bash
# req/s through nginx (service/deploy/nginx.conf) in front of 1, 2 and 3 `facespace serve`
# instances sharing the bundled rigs, against one instance without nginx, in the same run: the
# mesh route, a new random FaceCap weight vector per request, float32 out, wrk with 64 connections.
# usage: nginx_bench.sh FACESPACE_BINARY [SECONDS]
set -euo pipefail
bin=$1; secs=${2:-8}
here=$(cd "$(dirname "$0")" && pwd); src=$(cd "$here/../.." && pwd)
tmp=$(mktemp -d); pids=()
trap 'for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; rm -rf "$tmp"' EXIT
free_port() { python3 -c 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])'; }
ports=($(free_port) $(free_port) $(free_port)); front=$(free_port)
for i in 0 1 2; do
  "$bin" serve --host 127.0.0.1 --port "${ports[$i]}" --quiet 2>"$tmp/log$i" & pids+=($!)
done
for i in 0 1 2; do for _ in $(seq 1 100); do curl -fs "http://127.0.0.1:${ports[$i]}/healthz" >/dev/null 2>&1 && break; sleep 0.1; done; done
rate() { wrk -t1 -c64 -d"${secs}s" --timeout 5s --latency -s "$here/random_weights.lua" "$1" |
         awk '/Requests\/sec/ {r=$2} / 99%/ {p=$2} /Non-2xx|Socket errors/ {e=e $0 " "} END {printf "%s req/s, p99 %s %s\n", r, p, e}'; }
echo "one instance, no nginx: $(rate "http://127.0.0.1:${ports[0]}/")"
mkdir -p "$tmp/nginx"
for n in 1 2 3; do
  sed -e "s/127.0.0.1:8081/127.0.0.1:${ports[0]}/; s/127.0.0.1:8082/127.0.0.1:${ports[1]}/; s/127.0.0.1:8083/127.0.0.1:${ports[2]}/" \
      -e "s/listen 127.0.0.1:8080;/listen 127.0.0.1:$front;/" "$src/service/deploy/nginx.conf" >"$tmp/facespace.conf"
  [ $n -lt 3 ] && sed -i "/127.0.0.1:${ports[2]}/d" "$tmp/facespace.conf"
  [ $n -lt 2 ] && sed -i "/127.0.0.1:${ports[1]}/d" "$tmp/facespace.conf"
  cat >"$tmp/nginx.conf" <<EOF
$([ "$(id -u)" -eq 0 ] && echo "user root;")
pid $tmp/nginx.pid;
error_log $tmp/nginx-error.log warn;
worker_processes 2;
events { worker_connections 1024; }
http { access_log off; client_body_temp_path $tmp/nginx/body; proxy_temp_path $tmp/nginx/proxy;
       fastcgi_temp_path $tmp/nginx/fastcgi; uwsgi_temp_path $tmp/nginx/uwsgi; scgi_temp_path $tmp/nginx/scgi;
       include $tmp/facespace.conf; }
EOF
  nginx -p "$tmp/nginx" -c "$tmp/nginx.conf" -e "$tmp/nginx-error.log" -g 'daemon off;' & npid=$!
  for _ in $(seq 1 100); do curl -fs "http://127.0.0.1:$front/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
  echo "nginx + $n instance(s): $(rate "http://127.0.0.1:$front/")"
  kill "$npid"; wait "$npid" 2>/dev/null || true
done
