#!/usr/bin/env bash
# Three `facespace serve` instances sharing one store behind the real nginx (Debian's), started
# with the documented config (service/deploy/nginx.conf) on loopback ports: requests spread, an
# upload through one instance is served by the others, a SIGKILL of one instance under load loses
# no GET (nginx retries it on another), and the rest keep serving. Batch jobs share one folder: a
# job is seen through every instance, runs on one, is resumed by another when that one is
# SIGKILLed, and a delete through an instance that does not run it stops it.
# usage: nginx_test.sh FACESPACE_BINARY SOURCE_DIR
set -u
bin=$1; src=$2
nginx_bin=$(command -v nginx || echo /usr/sbin/nginx)
if [ ! -x "$nginx_bin" ]; then
  echo "SKIP nginx is not installed (apt-get install nginx-light; .ci/dev test installs it)"
  exit 77
fi
tmp=$(mktemp -d); pids=(); npid=
cleanup() {
  [ -n "$npid" ] && kill "$npid" 2>/dev/null && wait "$npid" 2>/dev/null
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null; wait "$p" 2>/dev/null; done
  rm -rf "$tmp"
}
trap cleanup EXIT
. "$(dirname "$0")/testlib.sh"
py() { python3 -c "$@"; }
free_port() { py 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])'; }

mkdir -p "$tmp/store" "$tmp/nginx"
cp "$src/assets/facecap/facecap.glb" "$src/assets/facecap/facecap.manifest.json" "$tmp/store/"
cp "$src/assets/makehuman/makehuman.glb" "$tmp/store/"  # A bigger rig: a warm-up long enough to probe.
printf 'k3y-for-tests' >"$tmp/key"
K=(-H 'Authorization: Bearer k3y-for-tests')
ports=($(free_port) $(free_port) $(free_port)); front=$(free_port)
for i in 0 1 2; do
  "$bin" serve --host 127.0.0.1 --port "${ports[$i]}" --rigs "$tmp/store" --api-key-file "$tmp/key" --store-poll 0.2 \
    --jobs-dir "$tmp/jobs" --batch-threads 1 >"$tmp/log$i" 2>&1 & pids+=($!)
done
for i in 0 1 2; do
  for _ in $(seq 1 100); do curl -fs "http://127.0.0.1:${ports[$i]}/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
done

# The documented snippet, with this run's ports, inside a minimal main config of our own.
sed -e "s/127.0.0.1:8081/127.0.0.1:${ports[0]}/; s/127.0.0.1:8082/127.0.0.1:${ports[1]}/; s/127.0.0.1:8083/127.0.0.1:${ports[2]}/" \
    -e "s/listen 127.0.0.1:8080;/listen 127.0.0.1:$front;/" "$src/service/deploy/nginx.conf" >"$tmp/facespace.conf"
check "the documented config names three instances and the front port" sh -c "grep -c '127.0.0.1:${ports[0]}\|127.0.0.1:${ports[1]}\|127.0.0.1:${ports[2]}' '$tmp/facespace.conf' | grep -qx 3 && grep -q 'listen 127.0.0.1:$front;' '$tmp/facespace.conf'"
user_line=; [ "$(id -u)" -eq 0 ] && user_line="user root;"
cat >"$tmp/nginx.conf" <<EOF
$user_line
pid $tmp/nginx.pid;
error_log $tmp/nginx-error.log warn;
worker_processes 2;
events { worker_connections 1024; }
http {
  access_log $tmp/nginx-access.log;
  client_body_temp_path $tmp/nginx/body;
  proxy_temp_path $tmp/nginx/proxy;
  fastcgi_temp_path $tmp/nginx/fastcgi;
  uwsgi_temp_path $tmp/nginx/uwsgi;
  scgi_temp_path $tmp/nginx/scgi;
  include $tmp/facespace.conf;
}
EOF
"$nginx_bin" -p "$tmp/nginx" -c "$tmp/nginx.conf" -e "$tmp/nginx-error.log" -g 'daemon off;' >"$tmp/nginx.out" 2>&1 & npid=$!
F=http://127.0.0.1:$front
# Readiness probed through the proxy while the instances warm up (503 each, passed through as it is)
# must not take them out of the pool: a GET right after a 503 probe is served, not 502 (no live
# upstream). Then every instance is ready.
for _ in $(seq 1 100); do [ "$(curl -s -o /dev/null -w '%{http_code}' "$F/healthz")" != 000 ] && break; sleep 0.05; done  # nginx listening.
probes=
for _ in $(seq 1 200); do
  code=$(curl -s -o /dev/null -w '%{http_code}' "$F/readyz")
  [ "$code" = 503 ] && code="503:$(curl -s -o /dev/null -w '%{http_code}' "$F/v1/rigs")"
  probes="$probes$code "
done
for i in 0 1 2; do
  for _ in $(seq 1 300); do curl -fs "http://127.0.0.1:${ports[$i]}/readyz" >/dev/null 2>&1 && break; sleep 0.1; done
done
check "/readyz through nginx while warming: 503 (then GET /v1/rigs 200) or 200, never 502 ($(echo $probes | tr ' ' '\n' | sort | uniq -c | tr -s ' \n' ' '))" \
  sh -c "! echo '$probes' | grep -qv '^\(\(200\|503:200\) \)*\$'"
for _ in $(seq 1 100); do curl -fs "$F/readyz" >/dev/null 2>&1 && break; sleep 0.1; done
check "nginx ($("$nginx_bin" -v 2>&1 | sed 's/.*: //')) starts with the documented config: /readyz through it is 200" \
  test "$(curl -s -o /dev/null -w '%{http_code}' "$F/readyz")" = 200 || { cat "$tmp/nginx-error.log" "$tmp/nginx.out"; exit 1; }

# Requests spread over the instances.
for n in $(seq 1 60); do curl -s -o /dev/null "$F/v1/rigs/facecap/mesh?w.jawOpen=0.$((n % 10))&format=f32"; done
counts=$(for i in 0 1 2; do grep -c '^GET /v1/rigs/facecap/mesh' "$tmp/log$i"; done | tr '\n' ' ')
check "60 GETs through nginx reach every instance (${counts% })" sh -c "for n in $counts; do [ \$n -ge 5 ] || exit 1; done"

# An upload through one instance is served by the others (the shared store, --store-poll 0.2).
code=$(curl -s -o /dev/null -w '%{http_code}' -X PUT "${K[@]}" -F "rig=@$src/assets/facecap/facecap.glb" \
  -F "manifest=@$src/assets/facecap/facecap.manifest.json" "http://127.0.0.1:${ports[0]}/v1/rigs/shared")
seen() {  # seen ID CODE: every instance answers CODE for the rig (polled for up to 20 s).
  for _ in $(seq 1 200); do
    local all=1
    for i in 0 1 2; do [ "$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:${ports[$i]}/v1/rigs/$1")" = "$2" ] || all=0; done
    [ $all = 1 ] && return 0
    sleep 0.1
  done
  return 1
}
[ "$code" = 201 ] && seen shared 200 && ok "an upload to instance 1 (201) is served by instances 2 and 3" ||
  no "an upload to instance 1 ($code) is served by instances 2 and 3"
grep -q "rig 'shared' added on disk" "$tmp/log1" && ok "  ... instance 2 logs the rig added on disk" || no "  ... instance 2 logs the addition"
check "  ... and through nginx, whichever instance answers" sh -c "for n in 1 2 3 4 5 6; do [ \$(curl -s -o /dev/null -w '%{http_code}' '$F/v1/rigs/shared/mesh?w.jawOpen=1&format=f32') = 200 ] || exit 1; done"

# Under load, a SIGKILL of one instance: nginx retries the GETs it had sent there on the others.
cat >"$tmp/load.py" <<'EOF'
import http.client, random, sys, threading, time
host, port, n, conc = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
codes, lock = {}, threading.Lock()
def worker(k):
    rnd = random.Random(k)
    c = http.client.HTTPConnection(host, port, timeout=30)
    for _ in range(n // conc):
        path = "/v1/rigs/facecap/mesh?w.jawOpen=%.4f&w.mouthSmile_L=%.4f&format=f32" % (rnd.random(), rnd.random())
        try:
            c.request("GET", path); r = c.getresponse(); r.read(); code = r.status
        except http.client.IncompleteRead:
            # Cut mid-body: nginx had begun relaying this response when its instance died, and no
            # proxy can take back bytes it has sent. A client asks again (the GET is idempotent).
            c.close(); c = http.client.HTTPConnection(host, port, timeout=30); code = "cut"
        except Exception as e:
            c.close(); c = http.client.HTTPConnection(host, port, timeout=30); code = "error-" + type(e).__name__
        with lock: codes[code] = codes.get(code, 0) + 1
t0 = time.time()
ts = [threading.Thread(target=worker, args=(k,)) for k in range(conc)]
for t in ts: t.start()
for t in ts: t.join()
print(" ".join("%s:%d" % kv for kv in sorted(codes.items(), key=str)), "%.0f req/s" % (n / (time.time() - t0)))
EOF
python3 "$tmp/load.py" 127.0.0.1 "$front" 6000 16 >"$tmp/load.out" & lpid=$!
# Mid-load: once instance 3 has served 50 of this load's GETs (a busy machine is slower; wait for them, not a time).
served=$(grep -c '^GET /v1/rigs/facecap/mesh' "$tmp/log2")
for _ in $(seq 1 200); do [ "$(grep -c '^GET /v1/rigs/facecap/mesh' "$tmp/log2")" -ge $((served + 50)) ] && break; sleep 0.05; done
before=$(( $(grep -c '^GET /v1/rigs/facecap/mesh' "$tmp/log2") - served ))
kill -0 $lpid 2>/dev/null && mid=1 || mid=0
kill -9 "${pids[2]}"; wait "${pids[2]}" 2>/dev/null
wait $lpid
# Every GET is 200 but for the few (at most one per connection nginx had open to it) whose response
# was cut mid-body by the kill: nginx retries what it had not begun to relay, and a client asks again
# for what it had (seen once in a loaded ctest -j2 run: 200:5999 and one cut).
check "6000 GETs from 16 clients, instance 3 SIGKILLed mid-load (after serving $before): all 200 but the few cut mid-body ($(cat "$tmp/load.out"))" \
  sh -c "[ $mid = 1 ] && [ $before -gt 20 ] && ! grep -q error '$tmp/load.out' && python3 -c \"import re,sys; d=dict(kv.split(':') for kv in open(sys.argv[1]).read().split() if ':' in kv); sys.exit(0 if int(d['200'])+int(d.get('cut',0))==6000 and int(d.get('cut',0))<=4 else 1)\" '$tmp/load.out'"
check "  ... the other two keep serving, through nginx and directly" sh -c "for n in 1 2 3 4; do [ \$(curl -s -o /dev/null -w '%{http_code}' '$F/v1/rigs/facecap') = 200 ] || exit 1; done && [ \$(curl -s -o /dev/null -w '%{http_code}' 'http://127.0.0.1:${ports[0]}/healthz') = 200 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' 'http://127.0.0.1:${ports[1]}/healthz') = 200 ]"

# Slowloris through the front: 320 sockets from two addresses each sending a header byte a second
# hold none of the instances (nginx keeps them in its event loop); a probe through nginx is answered.
py '
import os, socket, sys, threading, time, urllib.request
port = int(sys.argv[1])
socks = []
for i in range(320):
    s = socket.socket(); s.bind(("127.0.0.%d" % (2 + i % 2), 0)); s.connect(("127.0.0.1", port))
    s.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n"); socks.append(s)
stop = threading.Event()
def drip():
    while not stop.is_set():
        for s in socks:
            try: s.send(b"X")
            except OSError: pass
        stop.wait(1.0)
t = threading.Thread(target=drip); t.start()
times = []
for _ in range(20):
    t0 = time.time()
    try: urllib.request.urlopen(f"http://127.0.0.1:{port}/v1/rigs/facecap/mesh?w.jawOpen=0.3&format=f32", timeout=5).read(); times.append(time.time() - t0)
    except OSError: times.append(99)
    time.sleep(0.05)
stop.set(); t.join()
times.sort(); p99 = times[-1]
# Every probe answered (each within its 5 s timeout) is the outcome; the p99 is a figure (tests/bench/bars.sh).
print(f"320 slow sockets through nginx: every probe answered, p99 {p99 * 1000:.0f} ms, median {times[10] * 1000:.0f} ms")
sys.exit(not (p99 < 99 and (os.environ.get("FACESPACE_BARS") != "1" or p99 <= 1.0)))' "$front" >"$tmp/slow" 2>&1; rc=$?
check "slowloris through nginx: $(tail -1 "$tmp/slow")" test $rc -eq 0

# A delete through nginx reaches the survivors.
code=$(curl -s -o /dev/null -w '%{http_code}' -X DELETE "${K[@]}" "$F/v1/rigs/shared")
for _ in $(seq 1 200); do
  [ "$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:${ports[0]}/v1/rigs/shared")" = 404 ] &&
    [ "$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:${ports[1]}/v1/rigs/shared")" = 404 ] && break
  sleep 0.1
done
check "a DELETE through nginx: 204, gone from both live instances" sh -c "[ $code = 204 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' 'http://127.0.0.1:${ports[0]}/v1/rigs/shared') = 404 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' 'http://127.0.0.1:${ports[1]}/v1/rigs/shared') = 404 ]"

# Batch jobs in the shared --jobs-dir, with instances 1 and 2 alive.
u() { echo "http://127.0.0.1:${ports[$1]}"; }
jget() {  # jget INSTANCE JOB PYTHON-EXPR: the expression over the job's JSON (d) through that instance
  curl -s "$(u "$1")/v1/jobs/$2" | python3 -c "import json,sys; d=json.load(sys.stdin); print($3)" 2>/dev/null
}
submit() {  # submit INSTANCE BODY: the job id
  curl -s -D "$tmp/hdr" -o /dev/null -X POST "${K[@]}" -H 'Content-Type: application/json' -d "$2" "$(u "$1")/v1/rigs/facecap/batch"
  grep -i '^location:' "$tmp/hdr" | tr -d '\r' | sed 's|.*/||'
}
job=$(submit 0 '{"sample":{"method":"convex","count":1500,"seed":4},"format":"png","width":64,"height":64}')
for _ in $(seq 1 100); do [ "$(jget 1 "$job" "d['done'] >= 40")" = True ] && break; sleep 0.1; done
runner_pid=$(sed -n 's/.*:\([0-9]*\)$/\1/p' "$tmp/jobs/$job/.claim" 2>/dev/null)
runner=-1; for i in 0 1; do [ "${pids[$i]}" = "$runner_pid" ] && runner=$i; done; other=$((1 - runner))
state0=$(jget 0 "$job" "d['state']"); state1=$(jget 1 "$job" "d['state']")
check "a job submitted through instance 1 runs on one instance (the claim names instance $((runner + 1))), running through both" \
  sh -c "[ $runner -ge 0 ] && [ '$state0' = running ] && [ '$state1' = running ]"
for _ in $(seq 1 200); do [ "$(jget "$other" "$job" "d['rate'] > 0 and 'eta_seconds' in d")" = True ] && break; sleep 0.1; done
eta=$(jget "$other" "$job" "str(d['rate']) + ' variants/s, eta ' + str(d.get('eta_seconds'))")
check "  ... the instance not running it shows the runner's rate and an ETA ($eta)" sh -c "echo '$eta' | grep -Eq '^[0-9.]+ variants/s, eta [0-9.]+$' && ! echo '$eta' | grep -q '^0.0 '"
check "  ... listed by both instances" sh -c "curl -s '$(u 0)/v1/jobs' | grep -q '$job' && curl -s '$(u 1)/v1/jobs' | grep -q '$job'"
job2=$(submit "$other" '{"sample":{"method":"uniform","count":3000,"seed":5},"format":"png","width":64,"height":64}')
for _ in $(seq 1 100); do [ "$(jget "$other" "$job2" "d['state']")" = running ] && break; sleep 0.1; done
code=$(curl -s -o /dev/null -w '%{http_code}' -X DELETE "${K[@]}" "$(u "$runner")/v1/jobs/$job2")
for _ in $(seq 1 200); do [ ! -e "$tmp/jobs/$job2" ] && break; sleep 0.1; done
check "a second job runs on the other instance; DELETE through the one not running it: 204, stopped and gone" \
  sh -c "[ $code = 204 ] && [ ! -e '$tmp/jobs/$job2' ] && [ \$(curl -s -o /dev/null -w '%{http_code}' '$(u "$other")/v1/jobs/$job2') = 404 ]"
done_before=$(jget "$other" "$job" "d['done']")
kill -9 "${pids[$runner]}"; wait "${pids[$runner]}" 2>/dev/null
for _ in $(seq 1 600); do [ "$(jget "$other" "$job" "d['state']")" = done ] && break; sleep 0.1; done
final=$(jget "$other" "$job" "d['state'] + ' ' + str(d['done'])")
check "instance $((runner + 1)) SIGKILLed after ${done_before:-?} of 1500 variants: instance $((other + 1)) resumes the job (logged) and finishes it ($final)" \
  sh -c "grep -q 'resuming job $job (' '$tmp/log$other' && [ '$final' = 'done 1500' ]"
check "  ... every variant once in the manifest, no temporary file left" py '
import json, os, sys
d = sys.argv[1]; L = [json.loads(l) for l in open(d + "/manifest.jsonl")]
sys.exit(not (sorted(l["index"] for l in L) == list(range(1500)) and not [f for f in os.listdir(d) if "tmp" in f]))' "$tmp/jobs/$job/out"
check "  ... one instance at a time: the other never ran it before the kill" sh -c "! grep -q 'resuming job $job' '$tmp/log$runner'"

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
