#!/usr/bin/env bash
# Every example of the README, run as written against the quick-start server: the shell blocks (but the
# quick start's own two commands) and the example cells of the route and command tables, in the order
# they appear, in a scratch folder where `build/service/facespace`, `build/api-key` and `assets/` are
# what they are in a checkout after `bash .ci/dev start`. The server is `facespace serve` on the bundled
# rigs with the key file, as `.ci/dev start` runs it, on a free port in place of 8080. An example passes
# when it exits 0 and curl met no HTTP error (a `curl` function adds --fail-with-body).
# usage: readme_test.sh FACESPACE_BINARY SOURCE_DIR
set -u
bin=$1; src=$2
tmp=$(mktemp -d); pid=
[ -n "${ASAN_OPTIONS:-}" ] && export ASAN_OPTIONS="$ASAN_OPTIONS:detect_leaks=0"  # As service_test.sh.
cleanup() { [ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
. "$(dirname "$0")/testlib.sh"

work=$tmp/work
mkdir -p "$work/build/service" "$tmp/store" "$tmp/jobs"
ln -s "$bin" "$work/build/service/facespace"
ln -s "$src/assets" "$work/assets"
(umask 077 && od -An -tx1 -N16 /dev/urandom | tr -d ' \n' >"$work/build/api-key")
port=$(py 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])')
"$bin" serve --host 127.0.0.1 --port "$port" --api-key-file "$work/build/api-key" --store "$tmp/store" --jobs-dir "$tmp/jobs" \
  >"$tmp/log" 2>&1 &
pid=$!
for _ in $(seq 600); do curl -sf "http://127.0.0.1:$port/readyz" >/dev/null && break; sleep 0.1; done
check "the quick-start server (bundled rigs, the key file) is ready" curl -sf "http://127.0.0.1:$port/readyz" -o /dev/null

# The examples, a line each (a block's continued lines joined), from the README itself.
py '
import re, sys
text = open(sys.argv[1]).read()
out = []
for block in re.findall(r"```sh\n(.*?)```", text, re.S):
    if ".ci/dev" in block or "sbatch" in block:
        continue  # The quick start (what made this server); the commands of a Slurm cluster (slurm_test.sh runs them).
    out += [line for line in block.replace("\\\n", " ").splitlines() if line.strip()]
for row in re.findall(r"^\|.*\|$", text, re.M):
    cells = [c.strip() for c in row.strip("|").split(" | ")]
    for cell in cells:
        m = re.fullmatch(r"`((?:curl|build/service/facespace) [^`]*)`", cell)
        if m and "[" not in m.group(1).split("serve")[-1][:2] and not m.group(1).startswith("build/service/facespace serve"):
            out.append(m.group(1))
open(sys.argv[2], "w").write("\n".join(out) + "\n")
' "$src/README.md" "$tmp/examples"
n=$(wc -l <"$tmp/examples")
check "the README has its examples ($n)" test "$n" -ge 25

cat >"$tmp/env.sh" <<EOF
U=http://127.0.0.1:$port
curl() { command curl --fail-with-body "\$@"; local rc=\$?; [ \$rc -eq 23 ] && rc=0; return \$rc; }  # 23: a reader (head) closed early.
EOF
k=0
while IFS= read -r line; do
  k=$((k + 1))
  run=${line//127.0.0.1:8080/127.0.0.1:$port}
  (cd "$work" && timeout 300 bash -c ". '$tmp/env.sh'; $run" >"$tmp/out.$k" 2>&1)
  rc=$?
  if [ $rc -eq 0 ]; then
    ok "README example $k: ${line:0:150}"
  else
    no "README example $k (exit $rc): ${line:0:150}"
    head -c 600 "$tmp/out.$k" | sed 's/^/     /'; echo
  fi
done <"$tmp/examples"
# What some examples leave behind, looked at.
check "the README's sequence example wrote a glb per frame into frames/ (31)" test "$(ls "$work/frames" 2>/dev/null | grep -c '\.glb$')" -eq 31
check "the README's fit found the face of face.obj (jawOpen 0.6, mouthSmile_L 0.5)" py '
import json, sys; w = json.load(open(sys.argv[1]))["weights"]
sys.exit(not (abs(w["jawOpen"] - 0.6) < 0.02 and abs(w["mouthSmile_L"] - 0.5) < 0.02))' "$work/fit.json"
check "the README's upload made the rig 'my', which renders" curl -sf "http://127.0.0.1:$port/v1/rigs/my/render?w.jawOpen=1" -o "$tmp/my.png"
finish
