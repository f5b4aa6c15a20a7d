#!/usr/bin/env bash
# The web page in Debian's headless Chromium (playwright-core), against the real service on
# loopback, served by the service itself and from another origin (a static server) over CORS.
# usage: browser_test.sh FACESPACE_BINARY SOURCE_DIR NODE_MODULES_DIR OUT_DIR
set -u
bin=$1; src=$2; node_modules=$3; out=$4
mkdir -p "$out"
tmp=$(mktemp -d); pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; rm -rf "$tmp"; }
trap cleanup EXIT
if [ ! -x /usr/bin/chromium ] || [ ! -d "$node_modules/playwright-core" ]; then
  echo "FAIL chromium (/usr/bin/chromium) or playwright-core ($node_modules) is missing: run .ci/dev test"; exit 1
fi
free_port() { python3 -c 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])'; }
port=$(free_port); web=$(free_port)
mkdir -p "$tmp/store" && cp "$src/assets/facecap/facecap.glb" "$src/assets/facecap/facecap.manifest.json" \
  "$src/assets/makehuman/makehuman.glb" "$src/assets/makehuman/makehuman.manifest.json" "$tmp/store/"
mkdir -p "$tmp/store/uka/motion" && cp "$src/assets/uka/MS_Uka.pmx" "$src/assets/uka/MS_Uka.manifest.json" "$tmp/store/uka/" &&
  cp "$src/assets/uka/motion/stand.vmd" "$src/assets/uka/motion/01_happy.vmd" "$tmp/store/uka/motion/"  # Her base and one authored expression.
"$bin" serve --port "$port" --rigs "$tmp/store" --jobs-dir "$tmp/jobs" --cors-origin "http://127.0.0.1:$web" --quiet >"$tmp/log" 2>&1 &
pids+=($!)
python3 -m http.server "$web" --bind 127.0.0.1 --directory "$src/service/web" >/dev/null 2>&1 &
pids+=($!)
for _ in $(seq 1 100); do curl -fs "http://127.0.0.1:$port/healthz" >/dev/null 2>&1 && curl -fs "http://127.0.0.1:$web/" >/dev/null 2>&1 && break; sleep 0.1; done
cp "$src/tests/integration/browser_test.mjs" "$node_modules/../browser_test.mjs"
node "$node_modules/../browser_test.mjs" "http://127.0.0.1:$port" "http://127.0.0.1:$web/index.html" "$out"
