#!/usr/bin/env bash
# End-to-end tests of `facespace serve`: the real server on an ephemeral loopback port with a
# temporary store, driven with curl.
# usage: service_test.sh FACESPACE_BINARY SHARED_ASSETS_DIR SOURCE_DIR NODE_MODULES_DIR
set -u
bin=$1; A=$2/real; M=$2/more; src=$3; node_modules=${4:-}
tmp=$(mktemp -d); pid=
# Under ASan (the `sanitized` label), the servers this suite starts and stops skip LeakSanitizer's
# exit-time check: with some 80 threads (the front's, Mesa's), its tracer now and then crashes itself
# at exit ("Tracer caught signal 11 ... LeakSanitizer has encountered a fatal error"), seen once in about
# seven runs here (likely what failed the last CI run). AddressSanitizer and UBSan stay on; the routes' leaks are checked in
# process by the API tests.
[ -n "${ASAN_OPTIONS:-}" ] && export ASAN_OPTIONS="$ASAN_OPTIONS:detect_leaks=0"
cleanup() { [ -n "$pid" ] && kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null; umount "$tmp/full" 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
. "$(dirname "$0")/testlib.sh"

store=$tmp/store; mkdir -p "$store/stress"
cp "$src/assets/facecap/facecap.glb" "$src/assets/facecap/facecap.manifest.json" "$store/"
cp "$A/MorphStressTest/"* "$store/stress/"; mv "$store/stress/MorphStressTest.gltf" "$store/stress/stress.gltf"
head -c 5000 "$A/Fox/Fox.glb" >"$store/broken.glb"
cp "$A/SimpleMorph/SimpleMorph.gltf" "$store/Bad_Id.gltf"
printf 'k3y-for-tests' >"$tmp/key"
port=$(py 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])')
U=http://127.0.0.1:$port

start() {
  "$bin" serve --host 127.0.0.1 --port "$port" --rigs "$store" --api-key-file "$tmp/key" --max-body 2000000 --max-response 1000000 --max-frames 40000 \
    --cors-origin http://front.test --jobs-dir "$tmp/jobs" "$@" >>"$tmp/log" 2>&1 &
  pid=$!
  for _ in $(seq 1 600); do curl -fs "$U/healthz" >/dev/null 2>&1 && return 0; sleep 0.1; done
  # A sanitizer's report from its first line (where it says what and where), else the log's end.
  no "the server did not answer /healthz within 60 s; its log says:"
  if grep -q "ERROR: AddressSanitizer\|runtime error:" "$tmp/log"; then grep -m1 -A45 "ERROR: AddressSanitizer\|runtime error:" "$tmp/log"; else tail -30 "$tmp/log"; fi
  finish; exit 1
}
# c ARGS...: status code; body in $tmp/body, headers in $tmp/hdr.
c() { curl -s -o "$tmp/body" -D "$tmp/hdr" -w '%{http_code}' "$@"; }
hdr() { grep -i "^$1:" "$tmp/hdr" | head -1 | cut -d' ' -f2- | tr -d '\r'; }
jq_() { py "import json,sys; d=json.load(open(sys.argv[1])); sys.exit(0 if ($1) else 1)" "$tmp/body"; }
problem() {  # status code, then a Python condition on the problem body
  [ "$1" = "$2" ] && grep -qi '^content-type: application/problem+json' "$tmp/hdr" && \
    jq_ "d['status']==$2 and d['type'].startswith('urn:facespace:problem:') and d['title'] and d['detail'] and ($3)"
}

start
check "startup: a broken rig and a bad id are reported and skipped" \
  sh -c "grep -q 'skipping broken rig.*broken.glb' '$tmp/log' && grep -q \"'Bad_Id' is not a valid rig id\" '$tmp/log'"

# read routes
check "GET /healthz" test "$(c "$U/healthz")" = 200
code=$(curl -s -o /dev/null -w '%{http_code}' "$U/readyz")
for _ in $(seq 100); do [ "$(curl -s -o /dev/null -w '%{http_code}' "$U/readyz")" = 200 ] && break; sleep 0.1; done  # Ready once warmed.
check "GET /readyz: 503 while warming (Retry-After) or 200, then 200 ($code first)" sh -c "[ $code = 503 ] || [ $code = 200 ]"
check "GET /readyz counts 2 rigs" sh -c "[ \$(curl -s -o '$tmp/body' -w '%{http_code}' '$U/readyz') = 200 ] && grep -q '\"rigs\":2' '$tmp/body'"
code=$(c "$U/v1/rigs")
check "GET /v1/rigs lists facecap and stress with counts" both "[ $code = 200 ]" jq_ "[r['id'] for r in d['rigs']]==['facecap','stress'] and d['rigs'][0]['shapes']==52 and d['rigs'][0]['vertices']==4368 and d['rigs'][0]['has_skeleton']==False"
code=$(c "$U/v1/rigs/facecap")
check "GET /v1/rigs/facecap: shapes with index, group, range, default, moved, partner; bounding box; primitives" \
  sh -c "[ $code = 200 ]"
check "  ... whose fields hold the right values" jq_ "d['shapes'][24]['name']=='jawOpen' and d['shapes'][24]['group']=='jaw' and d['shapes'][24]['min']==0 and d['shapes'][24]['max']==1 and d['shapes'][24]['vertices_moved']>1000 and d['shapes'][37]['partner']=='mouthSmile_R' and len(d['primitives'])==4 and all(d['bounding_box']['min'][i] < d['bounding_box']['max'][i] for i in range(3)) and d['load_warnings']==[]"
check "GET unknown rig: 404 problem" sh -c "true" && problem "$(c "$U/v1/rigs/nobody")" 404 "'nobody' in d['detail']" && ok "  ... names the id" || no "  ... 404 problem for an unknown rig"

# mesh: same bytes as the CLI
W='{"jawOpen":0.9,"mouthSmile_L":0.8}'
code=$(c -X POST -H 'Content-Type: application/json' -d "{\"weights\":$W,\"format\":\"json\"}" "$U/v1/rigs/facecap/mesh")
"$bin" blend "$store/facecap.glb" --weights "$W" -o "$tmp/cli.json" 2>/dev/null
check "POST mesh (json): 200, byte-identical to the CLI's output" sh -c "[ $code = 200 ] && cmp -s '$tmp/body' '$tmp/cli.json'"
check "  ... Facespace-Weight-Sum: 1.7" test "$(hdr Facespace-Weight-Sum)" = 1.7
check "  ... Facespace-Warnings: extrapolation;value=1.7" test "$(hdr Facespace-Warnings)" = "extrapolation;value=1.7"
check "  ... JSON warnings list" jq_ "d['warnings'][0]['code']=='extrapolation' and d['warnings'][0]['value']==1.7"
etag=$(hdr ETag)
check "  ... a strong ETag" sh -c "echo '$etag' | grep -Eq '^\"[0-9a-f]{16}\"$'"
check "  ... If-None-Match: 304" test "$(c -X POST -H 'Content-Type: application/json' -H "If-None-Match: $etag" -d "{\"weights\":$W,\"format\":\"json\"}" "$U/v1/rigs/facecap/mesh")" = 304
code=$(c "$U/v1/rigs/facecap/mesh?w.jawOpen=0.5&format=obj")
"$bin" blend "$store/facecap.glb" --set jawOpen=0.5 -o "$tmp/cli.obj" 2>/dev/null
check "GET mesh ?w.jawOpen=0.5&format=obj: model/obj, same as the CLI" sh -c "[ $code = 200 ] && cmp -s '$tmp/body' '$tmp/cli.obj'" && \
  check "  ... Content-Type model/obj, Cache-Control for GET" sh -c "grep -qi '^content-type: model/obj' '$tmp/hdr' && grep -qi '^cache-control: public' '$tmp/hdr'"
code=$(c -H 'Accept: model/gltf-binary' "$U/v1/rigs/facecap/mesh?w.jawOpen=0.5")
check "Accept: model/gltf-binary gives a glb" sh -c "[ $code = 200 ] && head -c 4 '$tmp/body' | grep -q glTF && grep -qi '^content-type: model/gltf-binary' '$tmp/hdr'"
code=$(c -H 'Accept: application/octet-stream' "$U/v1/rigs/facecap/mesh?w.jawOpen=0.5")
check "Accept: application/octet-stream gives float32 positions + normals" sh -c "[ $code = 200 ] && [ \$(stat -c %s '$tmp/body') -eq $((4368 * 24)) ]"
check "Accept: image/png on the mesh route: 406" problem "$(c -H 'Accept: image/png' "$U/v1/rigs/facecap/mesh?w.jawOpen=0.5")" 406 "True"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"weights":{"jawOpen":1.5},"strict":true}' "$U/v1/rigs/facecap/mesh")
check "strict=true with warnings: 422 with the warnings" problem "$code" 422 "[w['code'] for w in d['warnings']]==['extrapolation','out_of_range'] and d['warnings'][1]['shape']=='jawOpen'"
code=$(c -X POST -H 'Content-Type: application/json' -d '[0.5, 0, 0.25]' "$U/v1/rigs/stress/check")
check "POST check needs an object body: 422" problem "$code" 422 "True"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"weights":[0.5,0,0,0,0,0,0.4,0.3]}' "$U/v1/rigs/stress/check")
check "POST check: sum and warnings, no mesh" sh -c "[ $code = 200 ]" && jq_ "abs(d['sum']-1.2)<1e-6 and d['warnings'][0]['code']=='extrapolation' and 'primitives' not in d" && ok "  ... values" || no "  ... check values"

# renders
pngsize() { py 'import sys,struct; d=open(sys.argv[1],"rb").read(); print("%dx%d" % struct.unpack(">II", d[16:24]) if d[:4]==b"\x89PNG" else "not-png")' "$tmp/body"; }
code=$(c "$U/v1/rigs/facecap/render?w.jawOpen=0.9&w.mouthSmile_L=0.8&width=256&height=192&yaw=15")
check "GET render: 200, a 256x192 PNG" sh -c "[ $code = 200 ] && grep -qi '^content-type: image/png' '$tmp/hdr' && [ '$(pngsize)' = 256x192 ]"
check "  ... with the extrapolation warning headers" test "$(hdr Facespace-Warnings)" = "extrapolation;value=1.7"
check "  ... Server-Timing names the render's steps" sh -c "echo '$(hdr Server-Timing)' | grep -Eq '^blend;dur=[0-9.]+, draw;dur=[0-9.]+, encode;dur=[0-9.]+$'"
cp "$tmp/body" "$tmp/whole.png"; head -c 100 "$tmp/whole.png" > "$tmp/first100"
code=$(c -r 0-99 "$U/v1/rigs/facecap/render?w.jawOpen=0.9&w.mouthSmile_L=0.8&width=256&height=192&yaw=15")
check "  ... the same again: from the cache (Server-Timing: cache), and a Range request is 206 with those 100 bytes" \
  sh -c "[ $code = 206 ] && [ '$(hdr Server-Timing)' = 'cache;desc=\"hit\"' ] && [ \$(wc -c < '$tmp/body') = 100 ] && cmp -s '$tmp/body' '$tmp/first100'"
code=$(c "$U/v1/rigs/facecap/render?w.jawOpen=0.9&width=256&height=256&format=webp")
check "GET render format=webp: image/webp (RIFF....WEBP), smaller than the PNG" \
  sh -c "[ $code = 200 ] && grep -qi '^content-type: image/webp' '$tmp/hdr' && [ \"\$(head -c 4 '$tmp/body')\" = RIFF ] && [ \$(wc -c < '$tmp/body') -lt \$(wc -c < '$tmp/whole.png') ]"
code=$(c "$U/v1/rigs/facecap/render?w.jawOpen=0.9&w.mouthSmile_L=0.8&width=256&height=192&yaw=15")
etag=$(hdr ETag)
check "  ... ETag, and If-None-Match gives 304" test "$(c -H "If-None-Match: $etag" "$U/v1/rigs/facecap/render?w.jawOpen=0.9&w.mouthSmile_L=0.8&width=256&height=192&yaw=15")" = 304
code=$(c "$U/v1/rigs/facecap/render?w.jawOpen=0.5&view=heatmap&width=64&height=64")
check "GET a 64x64 heatmap (its legend's title above the image once aborted the server): 200, and the server serves on" \
  sh -c "[ $code = 200 ] && [ '$(pngsize)' = 64x64 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/healthz') = 200 ]"
code=$(c -X POST -H 'Content-Type: application/json' -H 'Accept: image/jpeg' -d '{"weights":{"jawOpen":0.5},"width":128,"height":128,"view":"wireframe","camera":{"yaw":30,"pitch":10}}' "$U/v1/rigs/facecap/render")
check "POST render with Accept: image/jpeg" sh -c "[ $code = 200 ] && grep -qi '^content-type: image/jpeg' '$tmp/hdr' && head -c 3 '$tmp/body' | od -An -tx1 | grep -q 'ff d8 ff'"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"format":"exr","width":64,"height":64,"background":"transparent"}' "$U/v1/rigs/facecap/render")
check "POST render format exr: image/x-exr" sh -c "[ $code = 200 ] && grep -qi '^content-type: image/x-exr' '$tmp/hdr' && head -c 4 '$tmp/body' | od -An -tx1 | grep -q '76 2f 31 01'"
check "render: Accept image/gif is 406" problem "$(c -H 'Accept: image/gif' "$U/v1/rigs/facecap/render?width=64&height=64")" 406 "True"
ct() { curl -s -o /dev/null -w '%{http_code} %{content_type}' -H "Accept: $1" "$U/v1/rigs/facecap/$2"; }
check "Accept with q: image/png;q=0, image/jpeg gives a JPEG (q=0 is 'not acceptable')" test "$(ct 'image/png;q=0, image/jpeg' 'render?width=32&height=32')" = "200 image/jpeg"
check "Accept with q: image/png;q=0.5, image/tiff gives TIFF (the higher q wins, not the first listed)" test "$(ct 'image/png;q=0.5, image/tiff' 'render?width=32&height=32')" = "200 image/tiff"
check "Accept with q: application/json;q=0.0, model/obj;q=0.1 on the mesh route gives OBJ" test "$(ct 'application/json;q=0.0, model/obj;q=0.1' 'mesh?w.jawOpen=0.5')" = "200 model/obj"
check "Accept with q: model/gltf-binary;q=0 alone is 406" test "$(ct 'model/gltf-binary;q=0' 'mesh?w.jawOpen=0.5' | cut -d' ' -f1)" = 406
check "Accept: a browser's default (text/html,...,*/*;q=0.8) gives JSON" test "$(ct 'text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8' 'mesh?w.jawOpen=0.5')" = "200 application/json"
check "render: a size over the limit is 422 naming width" problem "$(c "$U/v1/rigs/facecap/render?width=4000")" 422 "d['errors'][0]['parameter']=='width'"
check "render: an unknown view is 422 at /view" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"view":"xray"}' "$U/v1/rigs/facecap/render")" 422 "d['errors'][0]['pointer']=='/view'"
check "render: a look-at camera without target is 422" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"camera":{"eye":[0,0,1]}}' "$U/v1/rigs/facecap/render")" 422 "d['errors'][0]['pointer']=='/camera'"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"cells":[{"label":"neutral"},{"weights":{"jawOpen":1},"label":"jaw"},{"weights":{"eyeBlink_L":1,"eyeBlink_R":1},"label":"blink"}],"columns":3,"width":96,"height":96}' "$U/v1/rigs/facecap/sheet")
check "POST sheet: a PNG of 3 labelled cells" sh -c "[ $code = 200 ] && [ '$(pngsize | cut -dx -f1)' = 304 ]"
# Speech (issue 38): bad fields named; a rig without a mouth; a video over a minute refused before it is drawn.
check "speech: empty text is 422 at /text" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"text":" "}' "$U/v1/rigs/facecap/speech")" 422 "d['errors'][0]['pointer']=='/text'"
check "speech: an unknown voice is 422 at /voice" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"text":"hi","voice":"en-uss"}' "$U/v1/rigs/facecap/speech")" 422 "d['errors'][0]['pointer']=='/voice' and 'did you mean' in d['detail']"
check "speech: a body that is not audio is 422 at /audio" problem "$(c -X POST -H 'Content-Type: audio/wav' --data-binary 'not a wav' "$U/v1/rigs/facecap/speech")" 422 "d['errors'][0]['pointer']=='/audio'"
check "speech: a rig without a mouth (MorphStressTest) is 422 no-mouth" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"text":"hi"}' "$U/v1/rigs/stress/speech")" 422 "d['type'].endswith('no-mouth') and 'jawOpen' in d['detail']"
long=$(py 'print(" ".join(["The quick brown fox jumps over the lazy dog."] * 20))')
check "speech: a video of over a minute is 422 at /text, not drawn (with the key: within its CPU budget)" problem "$(c -X POST -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: application/json' -d "{\"text\":\"$long\",\"rate\":120,\"format\":\"webm\"}" "$U/v1/rigs/facecap/speech")" 422 "d['errors'][0]['pointer']=='/text' and d['type'].endswith('video-too-long')"
check "speech: the same video anonymously is 422 over-budget before any speech is made (issue 48)" problem "$(c -X POST -H 'Content-Type: application/json' -d "{\"text\":\"$long\",\"rate\":120,\"format\":\"webm\"}" "$U/v1/rigs/facecap/speech")" 422 "d['type'].endswith('over-budget') and d['errors'][0]['pointer']=='/fps'"
check "sheet: a bad cell is 422 at its pointer, nothing rendered" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"cells":[{},{"weights":{"nope":1}}]}' "$U/v1/rigs/facecap/sheet")" 422 "d['errors'][0]['pointer']=='/cells/1/weights/nope'"
cells=$(py 'import json; print(json.dumps({"cells":[{}]*65}))')
check "sheet: more cells than the limit is 422" problem "$(c -X POST -H 'Content-Type: application/json' -d "$cells" "$U/v1/rigs/facecap/sheet")" 422 "d['errors'][0]['pointer']=='/cells'"
seq 1 32 | xargs -P 16 -I{} sh -c "curl -s -o /dev/null -w '%{http_code}\n' '$U/v1/rigs/facecap/render?w.jawOpen=0.{}&width=128&height=128'" >"$tmp/rcodes"
check "16 concurrent render clients, 32 renders: all 200" sh -c "[ \$(grep -c '^200$' '$tmp/rcodes') -eq 32 ]"

# sequences
SEQ='"keys":[{"time":0,"weights":{}},{"time":1,"shape":"jawOpen"},{"time":2,"weights":{"mouthSmile_L":1}}],"transition":"smoothstep"'
code=$(c -X POST -H 'Content-Type: application/json' -d "{$SEQ,\"times\":[0.25,1.5]}" "$U/v1/rigs/facecap/sequence/sample")
check "sequence/sample: frames with time, weights and the mesh route's primitives" sh -c "[ $code = 200 ]" && \
  check "  ... w_C = smoothstep(u): 0.15625 at t=0.25; half and half at t=1.5" jq_ "len(d['frames'])==2 and d['frames'][0]['weights']=={'jawOpen':0.15625} and d['frames'][1]['weights']=={'jawOpen':0.5,'mouthSmile_L':0.5} and len(d['frames'][0]['primitives'])==4 and d['warnings']==[]"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"keys":[{"time":0},{"time":1,"shape":"jawOpen"}],"transition":"cubic-bezier(0.3,-0.5,0.7,1.5)","times":[0.1]}' "$U/v1/rigs/facecap/sequence/sample")
check "sequence/sample: a transition leaving [0, 1] warns (and the negative weight too)" sh -c "[ $code = 200 ]" && jq_ "[w['code'] for w in d['warnings']][:1]==['transition_extrapolation']" && ok "  ... transition_extrapolation" || no "  ... transition_extrapolation warning"
times=$(py 'print(",".join(str(i / 10) for i in range(40)))')
code=$(c -X POST -H 'Content-Type: application/json' -d "{$SEQ,\"times\":[$times]}" "$U/v1/rigs/facecap/sequence/sample")
check "sequence/sample over --max-response (40 frames of FaceCap, ~8 MB, limit 1 MB): 422 response-too-large naming the limit and /times" \
  problem "$code" 422 "d['type'].endswith('response-too-large') and '--max-response' in d['detail'] and d['errors'][0]['pointer']=='/times'"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"keys":[{"time":0},{"time":60,"shape":"jawOpen"}],"fps":1000}' "$U/v1/rigs/facecap/sequence/stream")
check "sequence/stream over --max-frames (60001 frames, limit 40000): 422 naming the limit" problem "$code" 422 "'--max-frames' in d['detail']"
code=$(c "$U/openapi.json")
check "/openapi.json states this server's limits" jq_ "{k: v for k, v in d['info']['x-facespace-limits'].items() if k in ('max_body','max_render','max_sheet_cells','max_response','max_frames','anonymous_cpu_seconds','keyed_cpu_seconds')}=={'max_body':2000000,'max_render':2048,'max_sheet_cells':64,'max_response':1000000,'max_frames':40000,'anonymous_cpu_seconds':2.0,'keyed_cpu_seconds':600.0} and d['info']['x-facespace-limits']['max_connections']==4096 and d['info']['x-facespace-limits']['body_budget_mb']==1024 and d['info']['x-facespace-limits']['keyed_deadline']==1800 and '--anonymous-cpu' in d['info']['description'] and '--max-response' in d['info']['description'] and d['components']['schemas']['RenderRequest']['properties']['width']['maximum']==2048"
check "sequence: decreasing key times are 422 at the key" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"keys":[{"time":1},{"time":0}],"times":[0]}' "$U/v1/rigs/facecap/sequence/sample")" 422 "d['errors'][0]['pointer']=='/keys/1/time'"
check "sequence: an unknown transition is 422" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"keys":[{"time":0}],"transition":"bounce","times":[0]}' "$U/v1/rigs/facecap/sequence/sample")" 422 "d['errors'][0]['pointer']=='/transition'"
check "sequence: an unknown shape key is 422" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"keys":[{"time":0,"shape":"nose"}],"times":[0]}' "$U/v1/rigs/facecap/sequence/sample")" 422 "d['errors'][0]['pointer']=='/keys/0/shape'"
curl -sN -X POST -H 'Content-Type: application/json' -d "{$SEQ,\"fps\":10,\"format\":\"ndjson\"}" "$U/v1/rigs/facecap/sequence/stream" >"$tmp/stream.ndjson"
check "sequence/stream ndjson: 21 frames at 10 fps over 2 s, one JSON line each" py 'import json,sys
lines=[json.loads(l) for l in open(sys.argv[1])]
sys.exit(not(len(lines)==21 and lines[10]["time"]==1 and lines[10]["weights"]=={"jawOpen":1} and lines[5]["frame"]==5))' "$tmp/stream.ndjson"
curl -s -o "$tmp/stream.f32" -w '%{time_starttransfer} %{time_total}' -X POST -H 'Content-Type: application/json' -d "{$SEQ,\"fps\":400,\"format\":\"f32\"}" "$U/v1/rigs/facecap/sequence/stream" >"$tmp/timing"
check "sequence/stream f32: 801 length-prefixed frames of 4368 positions" py 'import sys,struct
d=open(sys.argv[1],"rb").read(); n=0; o=0
while o < len(d):
  L=struct.unpack("<I", d[o:o+4])[0]; assert L==4368*12; o+=4+L; n+=1
sys.exit(not(n==801 and o==len(d)))' "$tmp/stream.f32"
# Streaming, not built whole: over 2001 frames (105 MB) the first arrives long before the last, even
# when the machine is busy with other tests (the 801 frames above take 0.07 s, too few to tell).
curl -s -o /dev/null -w '%{time_starttransfer} %{time_total}' -X POST -H 'Content-Type: application/json' -d "{$SEQ,\"fps\":1000,\"format\":\"f32\"}" "$U/v1/rigs/facecap/sequence/stream" >"$tmp/timing"
check "sequence/stream: the first frame arrives long before the last ($(cat "$tmp/timing"))" py 'import sys; a,b=map(float,open(sys.argv[1]).read().split()); sys.exit(not(a < b/3))' "$tmp/timing"
before=$(curl -s "$U/metrics" | awk '/^facespace_blends_total/ {print $2}')
LONG='"keys":[{"time":0,"weights":{}},{"time":30,"shape":"jawOpen"}],"fps":1000,"format":"f32"'
curl -s -N -D "$tmp/lhdr" -X POST -H 'Content-Type: application/json' -d "{$LONG}" "$U/v1/rigs/facecap/sequence/stream" | head -c 1000000 | wc -c >"$tmp/got"
sleep 1
after=$(curl -s "$U/metrics" | awk '/^facespace_blends_total/ {print $2}')
check "sequence/stream: a client that closes stops the work (30001 frames of 52 KB asked, 1 MB read, $((after - before)) computed)" \
  sh -c "grep -q '^HTTP/1.1 200' '$tmp/lhdr' && grep -qi '^facespace-frames: 30001' '$tmp/lhdr' && [ \$(cat '$tmp/got') -eq 1000000 ] && [ $((after - before)) -gt 10 ] && [ $((after - before)) -lt 2000 ]"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"keys":[{"time":0},{"time":1,"weights":{"jawOpen":0.5}},{"time":2,"weights":{"jawOpen":1}},{"time":3,"weights":{"jawOpen":0.2}}],"tolerance":0.0001}' "$U/v1/rigs/facecap/sequence/reduce")
check "sequence/reduce: the collinear middle key goes, the turning one stays" sh -c "[ $code = 200 ]" && jq_ "d['kept']==3 and d['removed']==1 and [k['time'] for k in d['keys']]==[0,2,3] and d['max_error']<=0.0001" && ok "  ... keys 0, 2, 3 kept" || no "  ... reduce result"

# fitting
"$bin" blend "$store/facecap.glb" --set jawOpen=0.6 --set eyeBlink_L=0.8 -o "$tmp/target.json" 2>/dev/null
py 'import json,sys; t=json.load(open(sys.argv[1])); json.dump({"target": t, "bounded": True}, open(sys.argv[2], "w"))' "$tmp/target.json" "$tmp/fitbody.json"
code=$(c -X POST -H 'Content-Type: application/json' --data-binary @"$tmp/fitbody.json" "$U/v1/rigs/facecap/fit")
check "POST fit: recovers jawOpen 0.6 and eyeBlink_L 0.8 with a tiny residual" sh -c "[ $code = 200 ]" && jq_ "abs(d['weights']['jawOpen']-0.6)<2e-3 and abs(d['weights']['eyeBlink_L']-0.8)<2e-3 and d['residual']['max']<0.01" && ok "  ... values" || no "  ... fit values"
check "POST fit with a target of another size: 422" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"target":{"primitives":[{"positions":[0,0,0]}]}}' "$U/v1/rigs/facecap/fit")" 422 "d['errors'][0]['pointer']=='/target'"

# errors
check "malformed JSON: 400 problem" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"weights":' "$U/v1/rigs/facecap/mesh")" 400 "'malformed' in d['detail']"
check "unknown shape: 422 naming it, with a suggestion" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"weights":{"jawOpn":1}}' "$U/v1/rigs/facecap/mesh")" 422 "d['errors'][0]['pointer']=='/weights/jawOpn' and \"did you mean 'jawOpen'\" in d['errors'][0]['detail']"
check "wrong type: 422 at its pointer" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"weights":{"jawOpen":"NaN"}}' "$U/v1/rigs/facecap/mesh")" 422 "d['errors'][0]['pointer']=='/weights/jawOpen'"
check "NaN in the query: 422 naming the parameter" problem "$(c "$U/v1/rigs/facecap/mesh?w.jawOpen=nan")" 422 "d['errors'][0]['parameter']=='w.jawOpen' and 'finite' in d['errors'][0]['detail']"
check "index out of range: 422" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"weights":{"99":1}}' "$U/v1/rigs/facecap/mesh")" 422 "'out of range' in d['detail']"
check "bad mode: 422 at /mode" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"mode":"sideways"}' "$U/v1/rigs/facecap/mesh")" 422 "d['errors'][0]['pointer']=='/mode'"
check "unknown query parameter: 422" problem "$(c "$U/v1/rigs/facecap/mesh?jawOpen=1")" 422 "d['errors'][0]['parameter']=='jawOpen'"
check "text/plain body: 415" problem "$(c -X POST -H 'Content-Type: text/plain' -d '{}' "$U/v1/rigs/facecap/mesh")" 415 "True"
head -c 3000000 /dev/zero >"$tmp/big"
# Refusals from the headers come at once (-m 5: the server used to wait out its 10 s read timeout).
check "body over --max-body (curl sends Expect: 100-continue): 413 problem at once, naming the limit" problem "$(c -m 5 -X POST -H 'Content-Type: application/json' --data-binary @"$tmp/big" "$U/v1/rigs/facecap/mesh")" 413 "'--max-body' in d['detail'] and '2000000' in d['detail']"
check "  ... without Expect too" problem "$(c -m 5 -X POST -H 'Expect:' -H 'Content-Type: application/json' --data-binary @"$tmp/big" "$U/v1/rigs/facecap/mesh")" 413 "True"
check "POST of JSON with no body (no Content-Length): 411 at once" problem "$(c -m 5 -X POST -H 'Content-Type: application/json' "$U/v1/rigs/facecap/mesh")" 411 "'Content-Length' in d['detail']"
delete_mesh() { problem "$(c -X DELETE "$U/v1/rigs/facecap/mesh")" 405 "True" && [ "$(hdr Allow)" = "GET, HEAD, POST, OPTIONS" ]; }
check "DELETE on the mesh route: 405 with Allow: GET, HEAD, POST, OPTIONS" delete_mesh
patch_rig() { problem "$(c -m 5 -X PATCH -H 'Content-Type: application/json' "$U/v1/rigs/facecap")" 405 "True" && [ "$(hdr Allow)" = "GET, HEAD, PUT, DELETE, OPTIONS" ]; }
check "PATCH on a rig: 405 at once" patch_rig
options_rig() { [ "$(c -X OPTIONS "$U/v1/rigs/facecap")" = 204 ] && [ "$(hdr Allow)" = "GET, HEAD, PUT, DELETE, OPTIONS" ]; }
check "OPTIONS on a rig: the Allow of its 405" options_rig
long_url() { problem "$(c "$U/v1/rigs/facecap/mesh?w.jawOpen=$(head -c 9000 /dev/zero | tr '\0' 1)")" 414 "d['type'].endswith('uri-too-long')"; }
check "a request line over 8 KB: 414 problem document" long_url
check "  ... logged with no made-up duration" grep -q '^- (request line over 8,192 bytes) 414 [0-9]* -$' "$tmp/log"
check "unknown route: 404 problem" problem "$(c "$U/v2/nothing")" 404 "True"

# uploads
fox=$A/Fox/Fox.glb
put_without_key() { problem "$(c -X PUT -H 'Content-Type: model/gltf-binary' --data-binary @"$fox" "$U/v1/rigs/fox")" 401 "True" && grep -qi '^www-authenticate: bearer' "$tmp/hdr"; }
check "PUT without key: 401 + WWW-Authenticate: Bearer" put_without_key
check "PUT with an empty Bearer token (an unread key file): 401 saying the token is empty" problem "$(c -X PUT -H 'Authorization: Bearer ' -H 'Content-Type: model/gltf-binary' --data-binary @"$fox" "$U/v1/rigs/fox")" 401 "'token is empty' in d['detail']"
check "PUT with a wrong key: 403" problem "$(c -X PUT -H 'Authorization: Bearer nope' -H 'Content-Type: model/gltf-binary' --data-binary @"$fox" "$U/v1/rigs/fox")" 403 "True"
check "PUT with the key in another header: 401" problem "$(c -X PUT -H 'X-Api-Key: k3y-for-tests' -H 'Content-Type: model/gltf-binary' --data-binary @"$fox" "$U/v1/rigs/fox")" 401 "True"
K=(-H 'Authorization: Bearer k3y-for-tests')
check "PUT with the key: 201 + Location" sh -c "[ \$(curl -s -o /dev/null -D '$tmp/hdr' -w '%{http_code}' -X PUT -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: model/gltf-binary' --data-binary @'$fox' '$U/v1/rigs/fox') = 201 ] && grep -qi '^location: /v1/rigs/fox' '$tmp/hdr'"
check "PUT again: 200 replaced" test "$(c -X PUT "${K[@]}" -H 'Content-Type: model/gltf-binary' --data-binary @"$fox" "$U/v1/rigs/fox")" = 200
check "PUT a .gltf with embedded buffers (CesiumMan): 201" test "$(c -X PUT "${K[@]}" -H 'Content-Type: model/gltf+json' --data-binary @"$A/CesiumMan/CesiumMan.gltf" "$U/v1/rigs/cesium-man")" = 201
check "PUT a .gltf pointing at external files: 422, refused" problem "$(c -X PUT "${K[@]}" -H 'Content-Type: model/gltf+json' --data-binary @"$A/SimpleMorph/SimpleMorph.gltf" "$U/v1/rigs/simple")" 422 "'refused' in d['detail']"
check "PUT with a wrong Content-Type: 415" problem "$(c -X PUT "${K[@]}" -H 'Content-Type: text/plain' --data-binary @"$fox" "$U/v1/rigs/fox2")" 415 "True"
check "PUT an octet stream of no rig format: 415 naming the accepted types" problem "$(c -X PUT "${K[@]}" -H 'Content-Type: application/octet-stream' --data-binary 'just bytes' "$U/v1/rigs/fox2")" 415 "'model/vnd.collada+xml' in d['detail']"
fbx="$M/FBX/ufbx_maya_blend_inbetween/maya_blend_inbetween_7500_binary.fbx"
check "PUT an FBX as an octet stream with its file name: 201, stored as .fbx" sh -c "[ \$(curl -s -o /dev/null -w '%{http_code}' -X PUT -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: application/octet-stream' -H 'Content-Disposition: attachment; filename=\"cube.fbx\"' --data-binary @'$fbx' '$U/v1/rigs/inbetween') = 201 ] && [ -f '$store/inbetween.fbx' ]"
check "the uploaded FBX blends: LiftTop at its in-between weight" test "$(c "$U/v1/rigs/inbetween/mesh?w.LiftTop=0.5&format=obj")" = 200
check "PUT a COLLADA file as model/vnd.collada+xml: 201" test "$(c -X PUT "${K[@]}" -H 'Content-Type: model/vnd.collada+xml' --data-binary @"$M/Collada/CTS_skin_on_morph/skin_on_morph.dae" "$U/v1/rigs/skin-on-morph")" = 201
head -c 4000 "$fbx" >"$tmp/cut.fbx"
check "PUT a truncated FBX: 422 naming FBX, the stored one kept" problem "$(c -X PUT "${K[@]}" -H 'Content-Type: application/octet-stream' -H 'Content-Disposition: attachment; filename=cube.fbx' --data-binary @"$tmp/cut.fbx" "$U/v1/rigs/inbetween")" 422 "'FBX' in d['detail']"
check "DELETE the uploaded FBX and COLLADA rigs: 204, the file gone" sh -c "[ \$(curl -s -o /dev/null -w '%{http_code}' -X DELETE -H 'Authorization: Bearer k3y-for-tests' '$U/v1/rigs/inbetween') = 204 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' -X DELETE -H 'Authorization: Bearer k3y-for-tests' '$U/v1/rigs/skin-on-morph') = 204 ] && [ ! -f '$store/inbetween.fbx' ]"
check "PUT to a path-trick id: 404/422, nothing written outside the store" sh -c "c1=\$(curl -s -o /dev/null -w '%{http_code}' -X PUT -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: model/gltf-binary' --data-binary @'$fox' '$U/v1/rigs/..%2Fescape'); [ \"\$c1\" = 422 ] || [ \"\$c1\" = 404 ]; [ ! -e '$tmp/escape.glb' ]"
check "PUT to an upper-case id: 422" problem "$(c -X PUT "${K[@]}" -H 'Content-Type: model/gltf-binary' --data-binary @"$fox" "$U/v1/rigs/Fox")" 422 "True"
# A rig with its manifest: one multipart upload (rig + manifest parts), or a second PUT to
# /manifest; kept across restarts (checked below), replaced by a plain PUT of the rig alone.
printf '{"name": "Face two", "credit": "test credit", "shapes": {"jawOpen": {"group": "mouth", "max": 0.5}}}' >"$tmp/m1.json"
code=$(c -X PUT "${K[@]}" -F "rig=@$store/facecap.glb;type=model/gltf-binary" -F "manifest=@$tmp/m1.json;type=application/json" "$U/v1/rigs/face2")
check "PUT multipart rig + manifest: 201, the manifest's name and credit" both "[ $code = 201 ]" jq_ "d['name']=='Face two' and d['credit']=='test credit'"
c "$U/v1/rigs/face2" >/dev/null
check "  ... GET the rig: the manifest's group and range on jawOpen" jq_ "d['shapes'][24]['name']=='jawOpen' and d['shapes'][24]['group']=='mouth' and d['shapes'][24]['max']==0.5"
check "  ... kept beside the rig file in the store" sh -c "[ -s '$store/face2.glb' ] && cmp -s '$store/face2.manifest.json' '$tmp/m1.json'"
code=$(c "$U/v1/rigs/face2/manifest")
check "  ... GET /manifest: the rig's manifest as JSON" both "[ $code = 200 ]" jq_ "d['name']=='Face two' and d['shapes']['jawOpen']['max']==0.5 and d['shapes']['jawOpen']['group']=='mouth'"
etag=$(hdr ETag)
check "  ... with If-None-Match of its ETag: 304, no body" sh -c "[ -n '$etag' ] && [ \"\$(curl -s -o '$tmp/nm' -w '%{http_code}' -H 'If-None-Match: $etag' '$U/v1/rigs/face2/manifest')\" = 304 ] && [ ! -s '$tmp/nm' ]"
check "  ... multipart with the rig part named by its file name (no type): 200" test "$(c -X PUT "${K[@]}" -F "rig=@$store/facecap.glb" -F "manifest=@$tmp/m1.json" "$U/v1/rigs/face2")" = 200
check "  ... an unknown part: 422 naming it, did you mean" problem "$(c -X PUT "${K[@]}" -F "rig=@$store/facecap.glb" -F "manifets=@$tmp/m1.json" "$U/v1/rigs/face2")" 422 "d['errors'][0]['pointer']=='/manifets' and \"'manifest'\" in d['detail']"
check "  ... no rig part: 422 naming /rig" problem "$(c -X PUT "${K[@]}" -F "manifest=@$tmp/m1.json" "$U/v1/rigs/face2")" 422 "d['errors'][0]['pointer']=='/rig'"
printf '{"name": "Face two", "shapes": {"jawOpen": {"max": 0.5}}}' >"$tmp/mbad.json"
check "  ... a manifest that does not apply: 422 at its pointer under /manifest, nothing replaced" problem "$(c -X PUT "${K[@]}" -F "rig=@$fox;type=model/gltf-binary" -F "manifest=@$tmp/mbad.json;type=application/json" "$U/v1/rigs/face2")" 422 "d['errors'][0]['pointer']=='/manifest/shapes/jawOpen' and 'jawOpen' in d['detail']"
check "  ... (the stored rig and manifest unchanged)" sh -c "[ -s '$store/face2.glb' ] && [ ! -e '$store/face2.fbx' ] && cmp -s '$store/face2.manifest.json' '$tmp/m1.json'"
v_before=$(curl -s "$U/v1/rigs/face2" | py 'import json,sys; print(json.load(sys.stdin)["version"])')
code=$(c -X PUT "${K[@]}" -H 'Content-Type: application/json' -d '{"name": "Face three", "shapes": {"jawOpen": {"max": 2}}}' "$U/v1/rigs/face2/manifest")
check "PUT /manifest: 200, the new name, a new version" both "[ $code = 200 ]" jq_ "d['name']=='Face three' and d['version']!='$v_before'"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"weights":{"jawOpen":1.5}}' "$U/v1/rigs/face2/check")
check "  ... its range applies: jawOpen 1.5 is inside [0, 2], no out_of_range" both "[ $code = 200 ]" jq_ "not [w for w in d['warnings'] if w['code']=='out_of_range']"
check "  ... an unknown member: 422 naming it with the closest name" problem "$(c -X PUT "${K[@]}" -H 'Content-Type: application/json' -d '{"shapse": {}}' "$U/v1/rigs/face2/manifest")" 422 "d['errors'][0]['pointer']=='/shapse' and \"'shapes'\" in d['detail']"
problem "$(c -X PUT "${K[@]}" -H 'Content-Type: application/json' -d '{"shapes": {"jawOpen": {"partner": "nobody"}}}' "$U/v1/rigs/face2/manifest")" 422 "d['errors'][0]['pointer']=='/shapes/jawOpen/partner'" && \
  curl -s "$U/v1/rigs/face2" | grep -q '"name":"Face three"' && ok "  ... an unknown shape: 422 at its pointer, the manifest kept" || no "  ... an unknown shape in a manifest"
check "  ... malformed JSON: 400; without the key: 401; an unknown rig: 404" sh -c "[ \$(curl -s -o /dev/null -w '%{http_code}' -X PUT -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: application/json' -d '{' '$U/v1/rigs/face2/manifest') = 400 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' -X PUT -H 'Content-Type: application/json' -d '{}' '$U/v1/rigs/face2/manifest') = 401 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' -X PUT -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: application/json' -d '{}' '$U/v1/rigs/nobody/manifest') = 404 ]"
cp "$store/face2.manifest.json" "$tmp/m3.json"
# The flow of a new user: convert a rig, upload it with the manifest convert wrote beside it.
"$bin" convert "$M/FBX/ufbx_maya_blend_inbetween/maya_blend_inbetween_7500_binary.fbx" -o "$tmp/inb.glb" >/dev/null 2>&1
code=$(c -X PUT "${K[@]}" -F "rig=@$tmp/inb.glb" -F "manifest=@$tmp/inb.manifest.json" "$U/v1/rigs/converted")
check "a converted rig uploaded with its manifest keeps its name" both "[ $code = 201 ]" jq_ "d['name']=='maya_blend_inbetween_7500_binary'"
code=$(c "$U/v1/rigs/converted")
check "  ... and its in-betweens" both "[ $code = 200 ]" jq_ "[i['slider'] for i in d['inbetweens']]==['LiftTop','MoveToSide']"
test "$(curl -s -o /dev/null -w '%{http_code}' -X DELETE "${K[@]}" "$U/v1/rigs/converted")" = 204 || no "  ... DELETE the converted rig"

c "$U/v1/rigs/facecap" >/dev/null; v1=$(py 'import json,sys; print(json.load(open(sys.argv[1]))["version"])' "$tmp/body")
head -c 100000 "$store/facecap.glb" >"$tmp/trunc.glb"
check "a bad upload over an existing rig: 422" problem "$(c -X PUT "${K[@]}" -H 'Content-Type: model/gltf-binary' --data-binary @"$tmp/trunc.glb" "$U/v1/rigs/facecap")" 422 "'truncated' in d['detail']"
c "$U/v1/rigs/facecap" >/dev/null; v2=$(py 'import json,sys; print(json.load(open(sys.argv[1]))["version"])' "$tmp/body")
check "  ... the old rig keeps serving, unchanged on disk, no temp file left" sh -c "[ '$v1' = '$v2' ] && cmp -s '$store/facecap.glb' '$src/assets/facecap/facecap.glb' && [ -z \"\$(ls -A '$store' | grep tmp)\" ]"
c "$U/v1/rigs/fox" >/dev/null
check "GET an uploaded skinned rig: joints and animations with durations" jq_ "len(d['skeleton']['skins'][0]['joints'])==24 and d['has_skeleton'] and [a['name'] for a in d['animations']]==['Survey','Walk','Run'] and abs(d['animations'][0]['duration']-3.4166)<0.01"
# skeletons (the uploaded Fox)
code=$(c -X POST -H 'Content-Type: application/json' -d '{"format":"json"}' "$U/v1/rigs/fox/mesh"); cp "$tmp/body" "$tmp/fox_rest.json"
code2=$(c -X POST -H 'Content-Type: application/json' -d '{"format":"json","animation":"Run","time":0.4}' "$U/v1/rigs/fox/mesh"); cp "$tmp/body" "$tmp/fox_run.json"
"$bin" blend "$A/Fox/Fox.glb" --animation Run --time 0.4 -o "$tmp/fox_cli.json" 2>/dev/null
check "POST mesh with animation + time: the pose moves the fox, same bytes as the CLI" sh -c "[ $code = 200 ] && [ $code2 = 200 ] && ! cmp -s '$tmp/fox_rest.json' '$tmp/fox_run.json' && cmp -s '$tmp/fox_run.json' '$tmp/fox_cli.json'"
code=$(c "$U/v1/rigs/fox/mesh?format=json&animation=Run&time=0.4")
check "GET mesh ?animation=Run&time=0.4: the same mesh" sh -c "[ $code = 200 ] && cmp -s '$tmp/body' '$tmp/fox_cli.json'"
check "pose naming an unknown joint: 422 at its pointer" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"pose":{"tail":{"euler":[0,0,30]}}}' "$U/v1/rigs/fox/mesh")" 422 "d['errors'][0]['pointer']=='/pose/tail' and 'unknown joint' in d['errors'][0]['detail']"
check "a zero quaternion: 422" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"pose":{"b_Head_05":{"rotation":[0,0,0,0]}}}' "$U/v1/rigs/fox/mesh")" 422 "d['errors'][0]['pointer']=='/pose/b_Head_05/rotation'"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"format":"json","pose":{"b_Head_05":{"rotation":[0,0,0.5,1]}}}' "$U/v1/rigs/fox/mesh")
check "a non-unit quaternion is normalised with a warning" sh -c "[ $code = 200 ] && grep -qi '^facespace-warnings: quaternion_normalised' '$tmp/hdr'"
check "an unknown animation: 422 listing the clips" problem "$(c "$U/v1/rigs/fox/mesh?animation=Dance&time=1")" 422 "'Survey, Walk, Run' in d['detail']"
check "time without animation: 422" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"time":1}' "$U/v1/rigs/fox/mesh")" 422 "d['errors'][0]['pointer']=='/animation'"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"blend":[{"animation":"Walk","time":0.3,"weight":0.7},{"animation":"Run","time":0.3,"weight":0.3,"mask":["b_Spine01_02"]}],"width":128,"height":128,"camera":{"yaw":90}}' "$U/v1/rigs/fox/render")
check "POST render with a blend of clips and a mask" sh -c "[ $code = 200 ] && [ '$(pngsize)' = 128x128 ]"
check "uploaded rig serves meshes" test "$(c "$U/v1/rigs/fox/mesh?format=f32")" = 200
check "DELETE without key: 401" problem "$(c -X DELETE "$U/v1/rigs/cesium-man")" 401 "True"
check "DELETE with key: 204, then 404" sh -c "[ \$(curl -s -o /dev/null -w '%{http_code}' -X DELETE -H 'Authorization: Bearer k3y-for-tests' '$U/v1/rigs/cesium-man') = 204 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/v1/rigs/cesium-man') = 404 ] && [ ! -e '$store/cesium-man.gltf' ]"

# CORS
code=$(c -X OPTIONS -H 'Origin: http://front.test' -H 'Access-Control-Request-Method: POST' -H 'Access-Control-Request-Headers: content-type' "$U/v1/rigs/facecap/mesh")
check "CORS preflight from an allowed origin: 204 with allow-origin, methods, headers" sh -c "[ $code = 204 ] && grep -qi '^access-control-allow-origin: http://front.test' '$tmp/hdr' && grep -qi '^access-control-allow-methods:.*POST' '$tmp/hdr' && grep -qi '^access-control-allow-headers:.*content-type' '$tmp/hdr'"
c -H 'Origin: http://front.test' "$U/v1/rigs/facecap/mesh?w.jawOpen=0.5" >/dev/null
check "CORS: warning headers and ETag exposed" sh -c "grep -qi '^access-control-expose-headers:.*Facespace-Warnings.*ETag' '$tmp/hdr'"
c -H 'Origin: http://evil.test' "$U/v1/rigs/facecap/mesh?w.jawOpen=0.5" >/dev/null
check "CORS: other origins get no allow-origin" sh -c "! grep -qi '^access-control-allow-origin' '$tmp/hdr'"

# 32 concurrent clients
seq 1 320 | xargs -P 32 -I{} sh -c "curl -s -o /dev/null -w '%{http_code}\n' '$U/v1/rigs/facecap/mesh?w.jawOpen=0.{}&format=f32'" >"$tmp/codes"
check "32 concurrent clients, 320 requests: all 200" sh -c "[ \$(grep -c '^200$' '$tmp/codes') -eq 320 ]"

# metrics and OpenAPI
c "$U/metrics" >/dev/null
check "metrics: requests by route and status, latency histogram, blends, warnings, rigs loaded" sh -c "grep -q 'facespace_http_requests_total{route=\"/v1/rigs/{id}/mesh\",status=\"200\"}' '$tmp/body' && grep -q 'facespace_http_request_duration_seconds_bucket{route=\"/v1/rigs/{id}/mesh\",le=\"+Inf\"}' '$tmp/body' && grep -Eq '^facespace_blends_total [1-9]' '$tmp/body' && grep -Eq '^facespace_weight_warnings_total\{code=\"extrapolation\"\} [1-9]' '$tmp/body' && grep -q '^facespace_rigs_loaded 4' '$tmp/body'"
c "$U/openapi.json" >/dev/null; cp "$tmp/body" "$tmp/openapi.json"
check "OpenAPI: 3.1 and every route the server answers is described" py '
import json,sys
d=json.load(open(sys.argv[1]))
want={"/healthz":{"get"},"/readyz":{"get"},"/metrics":{"get"},"/openapi.json":{"get"},"/v1/rigs":{"get"},
      "/v1/rigs/{id}":{"get","put","delete"},"/v1/rigs/{id}/manifest":{"get","put"},"/v1/rigs/{id}/mesh":{"get","post"},"/v1/rigs/{id}/check":{"post"},
      "/v1/rigs/{id}/render":{"get","post"},"/v1/rigs/{id}/sheet":{"post"},"/v1/rigs/{id}/sequence/sample":{"post"},
      "/v1/rigs/{id}/sequence/stream":{"post"},"/v1/rigs/{id}/sequence/reduce":{"post"},"/v1/rigs/{id}/fit":{"post"},
      "/v1/rigs/{id}/batch":{"post"},"/v1/rigs/{id}/derive":{"post"},"/v1/rigs/{id}/capture":{"post"},"/v1/rigs/{id}/topology":{"get"},"/v1/jobs":{"get"},"/v1/jobs/{job}":{"get","delete"},"/v1/jobs/{job}/manifest.jsonl":{"get"},
      "/v1/jobs/{job}/files/{name}":{"get"},"/v1/jobs/{job}/results.zip":{"get"},
      "/v1/rigs/{id}/speech":{"post"},"/v1/voices":{"get"},"/v1/rigs/{id}/live":{"get"}}
got={p:{m for m in v if m in ("get","put","post","delete","patch")} for p,v in d["paths"].items()}
sys.exit(not(d["openapi"].startswith("3.1") and got==want))' "$tmp/openapi.json"
if [ -n "$node_modules" ] && [ -d "$node_modules/@seriousme/openapi-schema-validator" ]; then
  cp "$src/tests/integration/validate_openapi.mjs" "$node_modules/../validate_openapi.mjs"
  check "OpenAPI: valid under the OpenAPI 3.1 schema" node "$node_modules/../validate_openapi.mjs" "$tmp/openapi.json"
  # A client generated from the document itself calls every operation it lists (weights as the
  # document declares them: w[NAME]=VALUE), each answer checked.
  cp "$src/tests/integration/openapi_client_test.mjs" "$node_modules/../openapi_client_test.mjs"
  node "$node_modules/../openapi_client_test.mjs" "$U" k3y-for-tests "$store/facecap.glb" >"$tmp/client.out" 2>&1; rc=$?
  sed 's/^/     /' "$tmp/client.out"
  check "OpenAPI: a client generated from the document (swagger-client) calls every operation, each answer checked" test $rc -eq 0
  # Redocly's recommended rules: no error (warnings are shown).
  if [ -x "$node_modules/.bin/redocly" ]; then
    "$node_modules/.bin/redocly" lint --format=stylish "$tmp/openapi.json" >"$tmp/lint.out" 2>&1; rc=$?
    grep -E '^ +[0-9]+:[0-9]+ +(error|warning)' "$tmp/lint.out" | sed 's/^/     /'
    check "OpenAPI: Redocly's recommended lint reports no error" test $rc -eq 0
  else
    no "Redocly CLI not installed (run .ci/dev test)"
  fi
  # Types from the document (openapi-typescript, default options), a client script compiled against
  # them with tsc --strict, and run: ten operations on this server.
  if [ -x "$node_modules/.bin/tsc" ] && [ -x "$node_modules/.bin/openapi-typescript" ]; then
    typed=$tmp/typed; mkdir -p "$typed"; ln -s "$node_modules" "$typed/node_modules"
    cp "$src/tests/integration/typed_client.ts" "$typed/"
    "$node_modules/.bin/openapi-typescript" "$tmp/openapi.json" -o "$typed/api.d.ts" >"$typed/gen.out" 2>&1 || cat "$typed/gen.out"
    (cd "$typed" && "$node_modules/.bin/tsc" --strict --target es2022 --module nodenext --moduleResolution nodenext typed_client.ts) \
      >"$typed/tsc.out" 2>&1; rc=$?
    sed 's/^/     /' "$typed/tsc.out"
    check "OpenAPI: openapi-typescript's types of the document compile a ten-operation client under tsc --strict" test $rc -eq 0
    node "$typed/typed_client.js" "$U" k3y-for-tests >"$typed/run.out" 2>&1; rc=$?
    sed 's/^/     /' "$typed/run.out"
    check "OpenAPI: the typed client's ten operations answer as their types say" test $rc -eq 0
  else
    no "TypeScript and openapi-typescript not installed (run .ci/dev test)"
  fi
else
  no "OpenAPI validator not installed (run .ci/dev test)"
fi
check "access log: one line per request with method, path, status, bytes, duration" grep -Eq '^GET /v1/rigs/facecap 200 [0-9]+ [0-9.]+ms$' "$tmp/log"

check "a file whose name is no rig id is said once, not at every look at the store (1 s)" test "$(grep -c "'Bad_Id' is not a valid rig id" "$tmp/log")" -eq 1

# graceful shutdown and restart
kill -TERM "$pid"; wait "$pid"; rc=$?; pid=
check "SIGTERM: exits 0" test $rc -eq 0
[ $rc -eq 0 ] || { echo "     exit $rc; the log ends:"; tail -30 "$tmp/log" | sed 's/^/     /'; }
start
check "restart keeps uploaded rigs" test "$(c "$U/v1/rigs/fox")" = 200
check "restart: the deleted rig stays deleted" test "$(c "$U/v1/rigs/cesium-man")" = 404
code=$(c "$U/v1/rigs/face2")
check "restart: an uploaded rig keeps its manifest (name and range)" both "[ $code = 200 ]" jq_ "d['name']=='Face three' and d['shapes'][24]['max']==2"
code=$(c -X PUT "${K[@]}" -H 'Content-Type: model/gltf-binary' --data-binary @"$store/facecap.glb" "$U/v1/rigs/face2")
check "  ... a plain PUT of the rig alone replaces it without a manifest: named by its id, file gone" both "[ $code = 200 ] && [ ! -e '$store/face2.manifest.json' ]" jq_ "d['name']=='face2'"
check "  ... DELETE removes the rig and its manifest" sh -c "curl -s -X PUT -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: application/json' -d '{\"name\": \"x\"}' '$U/v1/rigs/face2/manifest' >/dev/null && [ -e '$store/face2.manifest.json' ] && [ \$(curl -s -o /dev/null -w '%{http_code}' -X DELETE -H 'Authorization: Bearer k3y-for-tests' '$U/v1/rigs/face2') = 204 ] && [ ! -e '$store/face2.manifest.json' ] && [ ! -e '$store/face2.glb' ]"

# startup errors
"$bin" serve --port notaport >"$tmp/o" 2>&1; rc=$?
check "startup: a bad flag exits non-zero with one clear line" sh -c "[ $rc -ne 0 ] && grep -q 'port must be' '$tmp/o'"
"$bin" serve --rigs "$tmp/nowhere" --port 0 >"$tmp/o" 2>&1; rc=$?
check "startup: an unreadable store exits non-zero" sh -c "[ $rc -ne 0 ] && grep -q 'not a readable directory' '$tmp/o'"

# level of detail
code=$(c "$U/v1/rigs/facecap/mesh?w.jawOpen=1&lod=2&format=json")
check "GET mesh ?lod=2: fewer vertices than the full mesh" both "[ $code = 200 ]" jq_ "sum(len(p['positions']) for p in d['primitives'])//3 < 2000"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"weights":{"jawOpen":1},"lod":1,"width":128,"height":128}' "$U/v1/rigs/facecap/render")
check "POST render with lod 1: a PNG" sh -c "[ $code = 200 ] && grep -qi '^content-type: image/png' '$tmp/hdr'"
code=$(c "$U/v1/rigs/facecap/topology?lod=1")
check "GET topology: triangle lists per primitive, indices within each primitive's vertices" both "[ $code = 200 ]" jq_ "len(d['primitives'])==4 and all(max(p['indices'])<p['vertices'] and len(p['indices'])%3==0 for p in d['primitives'] if p['indices'])"
problem "$(c "$U/v1/rigs/facecap/mesh?lod=9")" 422 "d['errors'][0]['parameter']=='lod'" && ok "lod=9: 422 naming the parameter" || no "lod out of range"

# batch jobs
restart() { kill -TERM "$pid"; wait "$pid"; pid=; start "$@"; }
restart --max-batch 1000 --batch-threads 2
wait_job() { for _ in $(seq 1 1200); do c "$U/v1/jobs/$1" >/dev/null; jq_ "d['state'] in ('done','failed','cancelled','lost')" && return 0; sleep 0.1; done; return 1; }
BODY='{"sample":{"method":"uniform","count":24,"seed":5,"active":6},"format":"glb"}'
code=$(c -X POST "${K[@]}" -H 'Content-Type: application/json' -d "$BODY" "$U/v1/rigs/facecap/batch"); loc=$(hdr Location); job=${loc##*/}
check "POST batch: 202 with Location /v1/jobs/{id} and the job's state" both "[ $code = 202 ] && echo '$loc' | grep -Eq '^/v1/jobs/[0-9a-f]{32}$'" jq_ "d['state'] in ('queued','running') and d['total']==24 and d['links']['self']=='$loc'"
wait_job "$job"
check "GET job: done, 24 of 24, progress 1, links to results.zip and the sheet" jq_ "d['state']=='done' and d['done']==24 and d['progress']==1 and d['links']['results']=='$loc/results.zip' and d['links']['sheet']=='$loc/files/sheet.png'"
code=$(c "$U$loc/results.zip")
check "results.zip: 200 application/zip, a valid archive of the manifest, batch.json, sheet and 24 glb whose sha256 match" sh -c "[ $code = 200 ] && [ \"\$(grep -i '^content-type:' '$tmp/hdr' | tr -d '\r')\" = 'Content-Type: application/zip' ]" && py '
import zipfile,json,hashlib,sys
z=zipfile.ZipFile(sys.argv[1]); n=z.namelist()
m=[json.loads(l) for l in z.read("manifest.jsonl").decode().splitlines()]
ok=z.testzip() is None and n[:3]==["manifest.jsonl","batch.json","sheet.png"] and len(n)==27 and len(m)==24
ok&=all(hashlib.sha256(z.read(l["file"])).hexdigest()==l["sha256"] and len(z.read(l["file"]))==l["bytes"] for l in m)
sys.exit(not ok)' "$tmp/body" && cp "$tmp/body" "$tmp/results.zip"
"$bin" batch "$store/facecap.glb" --sample uniform --count 24 --seed 5 --active 6 --format glb --out "$tmp/clibatch" --quiet 2>/dev/null
mkdir -p "$tmp/unz" && (cd "$tmp/unz" && python3 -c 'import zipfile,sys; zipfile.ZipFile(sys.argv[1]).extractall()' "$tmp/results.zip")
check "the job's variants are byte-identical to facespace batch's for the same request" sh -c "for f in '$tmp/clibatch'/v*.glb; do cmp -s \"\$f\" '$tmp/unz/'\$(basename \"\$f\") || exit 1; done && cmp -s '$tmp/clibatch/manifest.jsonl' '$tmp/unz/manifest.jsonl'"
code=$(c "$U$loc/files/v000003.glb")
check "GET files/v000003.glb: the variant on its own URL" sh -c "[ $code = 200 ] && cmp -s '$tmp/body' '$tmp/unz/v000003.glb' && grep -qi '^content-type: model/gltf-binary' '$tmp/hdr'"
problem "$(c "$U$loc/files/..%2Fjob.json")" 404 "True" && ok "files/..%2Fjob.json: 404, nothing outside the job's output" || no "files path trick"
code=$(c "$U/v1/jobs")
check "GET /v1/jobs lists the job" both "[ $code = 200 ]" jq_ "d['jobs'][0]['id']=='$job'"
problem "$(c "$U/v1/jobs/0123456789abcdef0123456789abcdef")" 404 "d['type'].endswith('job-not-found')" && ok "unknown job: 404 problem" || no "unknown job"
problem "$(c "$U/v1/jobs/..%2F..%2Fetc")" 404 "True" && ok "job id path trick: 404" || no "job id path trick"
problem "$(c -X POST "${K[@]}" -H 'Content-Type: application/json' -d '{"sample":{"method":"uniform","count":3,"fixed":{"jawopn":1}}}' "$U/v1/rigs/facecap/batch")" 422 "d['errors'][0]['pointer']=='/sample/fixed/jawopn' and 'jawOpen' in d['detail']" && ok "batch: unknown shape is 422 naming /sample/fixed/jawopn" || no "batch unknown shape"
problem "$(c -X POST "${K[@]}" -H 'Content-Type: application/json' -d '{"sample":{"method":"uniform","count":5000}}' "$U/v1/rigs/facecap/batch")" 422 "d['errors'][0]['pointer']=='/sample/count' and '1000' in d['detail']" && ok "batch over --max-batch: 422 naming /sample/count" || no "batch size limit"
problem "$(c -X POST "${K[@]}" -H 'Content-Type: application/json' -d '{"sample":' "$U/v1/rigs/facecap/batch")" 400 "True" && ok "batch: malformed JSON is 400" || no "batch malformed"
problem "$(c -X POST "${K[@]}" -H 'Content-Type: application/json' -d '{"variants":[{"id":"../x","weights":{}}]}' "$U/v1/rigs/facecap/batch")" 422 "d['errors'][0]['pointer']=='/variants/0/id'" && ok "batch: a path in a variant id is 422" || no "batch variant id"
problem "$(c -X POST "${K[@]}" -H 'Content-Type: application/json' -d "$BODY" "$U/v1/rigs/nobody/batch")" 404 "True" && ok "batch of an unknown rig: 404" || no "batch unknown rig"
problem "$(c -X DELETE "$U$loc")" 401 "True" && problem "$(c -X POST -H 'Content-Type: application/json' -d "$BODY" "$U/v1/rigs/facecap/batch")" 401 "True" && ok "batch routes mutate the disk: POST batch and DELETE job need the key (401 without)" || no "batch auth"
code=$(c -X DELETE "${K[@]}" "$U$loc")
check "DELETE job: 204, then 404, its files gone" sh -c "[ $code = 204 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U$loc') = 404 ] && [ ! -e '$tmp/jobs/$job' ]"

# queue bound, restart and loss
restart --max-jobs 2 --batch-threads 1
BIG='{"sample":{"method":"convex","count":1000,"seed":1},"format":"png","width":32,"height":32}'
c -X POST "${K[@]}" -H 'Content-Type: application/json' -d "$BIG" "$U/v1/rigs/facecap/batch" >/dev/null; big=$(hdr Location)
c -X POST "${K[@]}" -H 'Content-Type: application/json' -d '{"sample":{"method":"uniform","count":10},"format":"f32"}' "$U/v1/rigs/stress/batch" >/dev/null; small=$(hdr Location)
code=$(c -X POST "${K[@]}" -H 'Content-Type: application/json' -d "$BODY" "$U/v1/rigs/facecap/batch")
check "a third job past --max-jobs 2: 429 with Retry-After" sh -c "[ $code = 429 ] && [ \"\$(grep -i '^retry-after:' '$tmp/hdr' | tr -dc 0-9)\" -ge 1 ] && grep -q 'job-queue-full' '$tmp/body'"
for _ in $(seq 1 600); do c "$U$big" >/dev/null; jq_ "d['done'] >= 5" && break; sleep 0.05; done
kill -TERM "$pid"; wait "$pid"; pid=
done_before=$(wc -l <"$tmp/jobs/${big##*/}/out/manifest.jsonl")
mv "$store/stress" "$tmp/stress-away"
start --max-jobs 2 --batch-threads 2
check "restart: the unfinished job resumes (logged), after $done_before variants" sh -c "grep -q 'resuming 1 unfinished batch job' '$tmp/log' && [ $done_before -lt 1000 ]"
c "$U$small" >/dev/null
check "restart: a job whose rig was removed is reported lost, with the reason" jq_ "d['state']=='lost' and \"rig 'stress' was removed\" in d['error']"
wait_job "${big##*/}"
check "the resumed job completes: 1000 of 1000, every file once in the manifest" jq_ "d['state']=='done' and d['done']==1000" && \
  py 'import json,sys,os; L=[json.loads(l) for l in open(sys.argv[1]+"/manifest.jsonl")]; sys.exit(not(sorted(l["index"] for l in L)==list(range(1000)) and len([f for f in os.listdir(sys.argv[1]) if f.endswith(".png") and f!="sheet.png"])==1000 and not [f for f in os.listdir(sys.argv[1]) if "tmp" in f]))' "$tmp/jobs/${big##*/}/out" && ok "  ... manifest and files complete, no temporary file" || no "  ... resumed job's files"

# shape semantics from the manifest: derived (mask, mirror), in-betweens, correctives, statistics
cp "$src/assets/facecap/facecap.glb" "$store/semantic.glb"
cat >"$store/semantic.manifest.json" <<'JSON'
{"derived": {"jawOpen_left": {"from": "jawOpen", "mask": {"side": "+x", "falloff": 500}},
             "smileMirror": {"from": "mouthSmile_L", "mirror": "x"}},
 "inbetweens": {"jawOpen": [{"shape": "mouthFunnel", "weight": 0.5}]},
 "correctives": {"cheekPuff": {"drivers": ["mouthSmile_L", "eyeBlink_L"], "mode": "product"}},
 "statistics": {"stddev": {"jawOpen": 0.2}, "bound": 3}}
JSON
restart
code=$(c "$U/v1/rigs/semantic")
check "GET a rig with manifest semantics: derived shapes, driven flags, in-betweens, correctives, statistics" both "[ $code = 200 ]" jq_ "
  [x['name'] for x in d['shapes']][-2:]==['jawOpen_left','smileMirror'] and
  [x['name'] for x in d['shapes'] if x['driven']]==['cheekPuff','mouthFunnel'] and
  d['inbetweens']==[{'slider':'jawOpen','full':1.0,'keys':[{'shape':'mouthFunnel','weight':0.5}]}] and
  d['correctives'][0]=={'shape':'cheekPuff','drivers':['mouthSmile_L','eyeBlink_L'],'mode':'product'} and d['statistics']['components']==1"
c -X POST -H 'Content-Type: application/json' -d '{"weights":{"jawOpen":0.75},"format":"json"}' "$U/v1/rigs/semantic/mesh" >/dev/null; cp "$tmp/body" "$tmp/sem.json"
"$bin" blend "$store/facecap.glb" --weights '{"jawOpen":0.5,"mouthFunnel":0.5}' -o "$tmp/plain.json" 2>/dev/null
check "in-between: jawOpen 0.75 blends halfway between its 0.5 key and its own shape" py 'import json,sys; a,b=[json.load(open(f))["primitives"] for f in sys.argv[1:3]]; sys.exit(not(all(x["positions"]==y["positions"] for x,y in zip(a,b))))' "$tmp/sem.json" "$tmp/plain.json"
c -X POST -H 'Content-Type: application/json' -d '{"weights":{"mouthSmile_L":0.5,"eyeBlink_L":0.8},"format":"json"}' "$U/v1/rigs/semantic/mesh" >/dev/null; cp "$tmp/body" "$tmp/sem2.json"
"$bin" blend "$store/facecap.glb" --weights '{"mouthSmile_L":0.5,"eyeBlink_L":0.8,"cheekPuff":0.4}' -o "$tmp/plain2.json" 2>/dev/null
check "corrective: cheekPuff follows mouthSmile_L x eyeBlink_L" py 'import json,sys; a,b=[json.load(open(f))["primitives"] for f in sys.argv[1:3]]; sys.exit(not(all(max(abs(p-q) for p,q in zip(x["positions"],y["positions"]))<1e-3 for x,y in zip(a,b))))' "$tmp/sem2.json" "$tmp/plain2.json"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"weights":{"jawOpen":0.8,"cheekPuff":0.3}}' "$U/v1/rigs/semantic/check")
check "check: Mahalanobis 4 sigma warns implausible; a weight on a driven shape warns driven_shape" both "[ $code = 200 ] && grep -qi '^facespace-warnings:.*implausible' '$tmp/hdr' && grep -qi '^facespace-warnings:.*driven_shape' '$tmp/hdr'" jq_ "abs(d['mahalanobis']-4)<1e-5"

# controls (the bundled MakeHuman face)
cp "$src/assets/makehuman/makehuman.glb" "$src/assets/makehuman/makehuman.manifest.json" "$store/"
restart
code=$(c "$U/v1/rigs/makehuman")
check "GET the MakeHuman rig: 352 shapes (286 face targets, 66 derived expressions, its derivation said) and 146 controls with groups, ranges, shapes and partners" both "[ $code = 200 ]" jq_ "
  len(d['shapes'])==352 and len(d['controls'])==146 and d['derivation']['source']=='FaceCap head (ARKit 52)' and len(d['derivation']['shapes'])==66 and
  {'name':'nose/nose-trans-down|up','group':'nose','min':-1,'max':1,'negative':'nose-trans-down','positive':'nose-trans-up','partner':None} in d['controls'] and
  [c['partner'] for c in d['controls'] if c['name']=='eyes/l-eye-bag-decr|incr']==['eyes/r-eye-bag-decr|incr']"
c -X POST -H 'Content-Type: application/json' -d '{"controls":{"nose/nose-trans-down|up":-0.4},"format":"f32"}' "$U/v1/rigs/makehuman/mesh" >/dev/null; cp "$tmp/body" "$tmp/ctl1"
c -X POST -H 'Content-Type: application/json' -d '{"weights":{"nose-trans-down":0.4},"format":"f32"}' "$U/v1/rigs/makehuman/mesh" >/dev/null; cp "$tmp/body" "$tmp/ctl2"
c "$U/v1/rigs/makehuman/mesh?c.nose%2Fnose-trans-down%7Cup=-0.4&format=f32" >/dev/null; cp "$tmp/body" "$tmp/ctl3"
check "controls in the body and as c.NAME query parameters give the shapes' mesh" sh -c "cmp -s '$tmp/ctl1' '$tmp/ctl2' && cmp -s '$tmp/ctl1' '$tmp/ctl3' && [ \$(stat -c %s '$tmp/ctl1') -eq $((15593 * 24)) ]"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"controls":{"nose/nose-trans-down|up":1.5,"head/head-oval":0.5}}' "$U/v1/rigs/makehuman/check")
check "check: a control past its range is named in the warnings" both "[ $code = 200 ] && grep -qi '^facespace-warnings:.*control_out_of_range' '$tmp/hdr'" jq_ "d['weights']=={'head-oval':0.5,'nose-trans-up':1.5} and any(w['code']=='control_out_of_range' and w['shape']=='nose/nose-trans-down|up' for w in d['warnings'])"
problem "$(c -X POST -H 'Content-Type: application/json' -d '{"controls":{"nose/nope":1}}' "$U/v1/rigs/makehuman/mesh")" 422 "d['errors'][0]['pointer']=='/controls/nose~1nope'" && ok "an unknown control: 422 naming /controls/nose~1nope" || no "unknown control"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"controls":{"nose/nose-trans-down|up":1},"width":256,"height":256,"camera":{"frame":"shapes"}}' "$U/v1/rigs/makehuman/render")
check "render of the MakeHuman face with a control, framed on the shapes: a PNG" sh -c "[ $code = 200 ] && grep -qi '^content-type: image/png' '$tmp/hdr'"

# retarget: weights in another vocabulary (issue 63)
"$bin" blend "$A/AnimatedMorphCube/AnimatedMorphCube.gltf" --keep-targets -o "$tmp/twoshapes.glb" 2>/dev/null
c -X PUT -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: model/gltf-binary' --data-binary @"$tmp/twoshapes.glb" "$U/v1/rigs/cube" >/dev/null
c -X POST -H 'Content-Type: application/json' -d '{"vocabulary":"mmd","weights":{"あ":1},"format":"f32"}' "$U/v1/rigs/facecap/mesh" >/dev/null; cp "$tmp/body" "$tmp/rt1"
c -X POST -H 'Content-Type: application/json' -d '{"weights":{"jawOpen":0.8,"mouthLowerDown_L":0.3,"mouthLowerDown_R":0.3},"format":"f32"}' "$U/v1/rigs/facecap/mesh" >/dev/null; cp "$tmp/body" "$tmp/rt2"
c "$U/v1/rigs/facecap/mesh?vocabulary=mmd&w.%E3%81%82=1&format=f32" >/dev/null; cp "$tmp/body" "$tmp/rt3"
check "MMD's あ on FaceCap (body and query) is the mesh of its table: jawOpen 0.8, the lower lip down 0.3, byte for byte" sh -c "cmp -s '$tmp/rt1' '$tmp/rt2' && cmp -s '$tmp/rt1' '$tmp/rt3' && [ \$(stat -c %s '$tmp/rt1') -gt 100000 ]"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"vocabulary":"mmd","weights":{"まばたき":1,"う":0.5}}' "$U/v1/rigs/facecap/check")
check "MMD's まばたき closes both of FaceCap's eyes, う rounds its lips" both "[ $code = 200 ]" jq_ "abs(d['weights']['eyeBlink_L']-1)<1e-5 and abs(d['weights']['eyeBlink_R']-1)<1e-5 and abs(d['weights']['mouthPucker']-0.5)<1e-5"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"vocabulary":"arkit","weights":{"eyeBlinkLeft":1,"jawOpen":0.4,"mouthSmileRight":0.6}}' "$U/v1/rigs/makehuman/check")
check "ARKit's names (Apple's spelling) onto the derived MakeHuman: its own shapes, exactly" both "[ $code = 200 ]" jq_ "d['weights']=={'eyeBlink_L':1,'jawOpen':0.4,'mouthSmile_R':0.6}"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"vocabulary":"facecap","weights":{"mouthFunnel":0.7}}' "$U/v1/rigs/makehuman/check")
check "another rig's shapes as the vocabulary (facecap onto makehuman)" both "[ $code = 200 ]" jq_ "d['weights']=={'mouthFunnel':0.7}"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"vocabulary":"arkit","weights":{"jawOpen":1}}' "$U/v1/rigs/cube/check")
check "a rig with none of the names: 200, warned vocabulary_unexpressed naming jawOpen" both "[ $code = 200 ] && grep -qi '^facespace-warnings:.*vocabulary_unexpressed' '$tmp/hdr'" jq_ "d['weights']=={} and any(w['code']=='vocabulary_unexpressed' and w['shape']=='jawOpen' for w in d['warnings'])"
c -X DELETE -H 'Authorization: Bearer k3y-for-tests' "$U/v1/rigs/cube" >/dev/null
problem "$(c -X POST -H 'Content-Type: application/json' -d '{"vocabulary":"arkit","weights":{"jawOpn":1}}' "$U/v1/rigs/facecap/mesh")" 422 "d['errors'][0]['pointer']=='/weights/jawOpn' and 'jawOpen' in d['errors'][0]['detail']" && ok "an unknown ARKit name: 422 at /weights/jawOpn with the closest" || no "unknown vocabulary name"
problem "$(c -X POST -H 'Content-Type: application/json' -d '{"vocabulary":"nobody","weights":{"x":1}}' "$U/v1/rigs/facecap/mesh")" 422 "d['errors'][0]['pointer']=='/vocabulary'" && ok "a vocabulary naming no rig: 422 at /vocabulary" || no "vocabulary no rig"
problem "$(c -X POST -H 'Content-Type: application/json' -d '{"vocabulary":"../etc","weights":{"x":1}}' "$U/v1/rigs/facecap/mesh")" 422 "d['errors'][0]['pointer']=='/vocabulary'" && ok "a vocabulary that is no id: 422 at /vocabulary" || no "vocabulary path"

# capture: a tracker's landmarks as the rig's weights (issue 64)
python3 "$src/tests/integration/capture_frames.py" "$src/assets/trackers/mediapipe/canonical_face_model.obj" "$tmp/frames.json"
code=$(c -X POST -H 'Content-Type: application/json' --data-binary @"$tmp/frames.json" "$U/v1/rigs/facecap/capture")
check "capture: 20 frames of MediaPipe's landmarks (the jaw turned open from frame 5) on FaceCap: 20 keys, the rest frames still, jawOpen the largest weight once open" both "[ $code = 200 ] && grep -qi '^server-timing: solve;dur=.*register;dur=' '$tmp/hdr'" jq_ "
  len(d['keys'])==20 and d['frames']==20 and d['keys'][0]=={'time':0,'weights':{}} and abs(d['keys'][10]['time']-1/3)<1e-9 and
  max(d['keys'][19]['weights'], key=d['keys'][19]['weights'].get)=='jawOpen' and d['keys'][19]['weights']['jawOpen']>0.3 and len(d['head'])==20"
code=$(c -X POST -H 'Content-Type: application/json' --data-binary @"$tmp/frames.json" "$U/v1/rigs/facecap/capture")
check "capture again: the registration kept (Server-Timing register kept)" sh -c "[ $code = 200 ] && grep -qi '^server-timing:.*desc=\"kept\"' '$tmp/hdr'"
code=$(c -X POST -H 'Content-Type: application/json' --data-binary @"$tmp/frames.json" "$U/v1/rigs/makehuman/capture")
check "capture onto the derived MakeHuman: jawOpen the largest weight" both "[ $code = 200 ]" jq_ "max(d['keys'][19]['weights'], key=d['keys'][19]['weights'].get)=='jawOpen'"
problem "$(c -X POST -H 'Content-Type: application/json' -d '{"image":[640,480],"frames":[[[1,2,3]]]}' "$U/v1/rigs/facecap/capture")" 422 "d['errors'][0]['pointer']=='/frames/0'" && ok "capture: a frame of 1 point: 422 at /frames/0" || no "capture short frame"
problem "$(c -X POST -H 'Content-Type: application/json' -d '{"frames":[]}' "$U/v1/rigs/facecap/capture")" 422 "[e['pointer'] for e in d['errors']]==['/frames','/image']" && ok "capture: no frames, no image: 422 naming both" || no "capture no frames"

# hardening: upload limits, slow and broken clients, keys never logged
restart --max-vertices 1000 --max-shapes 1 --read-timeout 2
code=$(c -X PUT -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: model/gltf-binary' --data-binary @"$A/Fox/Fox.glb" "$U/v1/rigs/bigfox")
check "upload over --max-vertices: 413 naming the limit, nothing stored" sh -c "[ $code = 413 ] && grep -q 'at most 1000 (--max-vertices)' '$tmp/body' && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/v1/rigs/bigfox') = 404 ] && [ ! -e '$store/bigfox.glb' ]"
code=$(c -X PUT -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: model/gltf-binary' --data-binary @"$tmp/twoshapes.glb" "$U/v1/rigs/twoshapes")
check "upload over --max-shapes: 413 naming the limit" sh -c "[ $code = 413 ] && grep -q 'at most 1 (--max-shapes)' '$tmp/body'"
py '
import socket, sys, time, urllib.request
host, port = "127.0.0.1", int(sys.argv[1])
# 40 slowloris clients: each sends part of a request, then a byte now and then, never finishing.
slow = []
for _ in range(40):
    s = socket.create_connection((host, port)); s.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\nX-Slow: "); slow.append(s)
t = time.time(); body = urllib.request.urlopen(f"http://{host}:{port}/healthz", timeout=3).read(); fast = time.time() - t
# The server cuts them off after its read timeout (2 s here).
deadline = time.time() + 6; closed = 0
for s in slow:
    s.settimeout(max(0.1, deadline - time.time()))
    try:
        closed += s.recv(100) == b"" or True
    except (socket.timeout, ConnectionResetError):
        pass
# A body announced far over the limit is refused from its headers, before it is sent.
b = socket.create_connection((host, port)); b.settimeout(3)
b.sendall(b"POST /v1/rigs/facecap/mesh HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 10000000000\r\n\r\n{")
head = b.recv(200)
ok = body == b"{\"status\":\"ok\"}" and fast < 1.0 and closed == 40 and head.startswith(b"HTTP/1.1 413")
print(f"healthz with 40 slow clients in {fast*1000:.0f} ms; {closed}/40 slow clients cut off; oversized body: {head[:12]!r}")
sys.exit(not ok)' "$port" >"$tmp/slow" 2>&1; rc=$?
check "slow clients: 40 partial requests do not starve others and are cut off after --read-timeout; a 10 GB Content-Length gets 413 from its headers ($(cat "$tmp/slow" | tail -1))" test $rc -eq 0
py '
import os, select, signal, socket, sys, time
port, pid = int(sys.argv[1]), int(sys.argv[2])
# 64 clients connect at once while the server is paused (as when its cores are busy): the kernel
# completes each handshake only if the listen backlog has room; beyond it, the SYN is dropped and
# the client retries 1 s later.
os.kill(pid, signal.SIGSTOP)
try:
    socks = []
    for _ in range(64):
        s = socket.socket(); s.setblocking(False); s.connect_ex(("127.0.0.1", port)); socks.append(s)
    pending, deadline = set(socks), time.time() + 0.5
    while pending and time.time() < deadline:
        _, done, _ = select.select([], list(pending), [], max(0.0, deadline - time.time()))
        pending -= {s for s in done if s.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR) == 0}
    connected = 64 - len(pending)
finally:
    os.kill(pid, signal.SIGCONT)
answered = 0
for s in socks:
    s.setblocking(True); s.settimeout(5)
    try:
        s.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n")
        answered += s.recv(12) == b"HTTP/1.1 200"
    except OSError:
        pass
print(f"{connected}/64 connected within 0.5 s while the server was paused, {answered}/64 answered 200")
sys.exit(not (connected == 64 and answered == 64))' "$port" "$pid" >"$tmp/burst" 2>&1; rc=$?
check "a burst of 64 connections while the server is busy: all accepted at once (listen backlog), none waits for a SYN retry ($(tail -1 "$tmp/burst"))" test $rc -eq 0
timeout 20 "$bin" serve --host 127.0.0.1 --port "$port" --rigs "$store" >"$tmp/second" 2>&1
check "a second server on the same port refuses to start (no silent SO_REUSEPORT sharing)" sh -c "[ $? = 1 ] && grep -q 'cannot listen on 127.0.0.1:$port' '$tmp/second' && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/healthz') = 200 ]"
py '
import socket, sys
s = socket.create_connection(("127.0.0.1", int(sys.argv[1]))); s.settimeout(3)
s.sendall(b"GET /v1/\x8e\x96gs/x%ff HTTP/1.1\r\nHost: x\r\n\r\n")
sys.exit(not s.recv(200).startswith(b"HTTP/1.1 404"))' "$port"
check "a path of invalid UTF-8 (found by fuzz_http; it used to kill the server): 404 problem, and the server stays up" sh -c "[ $? -eq 0 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/healthz') = 200 ]"
check "the API key never appears in the log" sh -c "! grep -q 'k3y-for-tests' '$tmp/log'"

# storage faults: kill -9 while an upload is arriving, a full disk, a corrupt file
restart
good=$(ls "$store" | sort | tr '\n' ' ')
py '
import socket, sys, time
body = open(sys.argv[2], "rb").read()
s = socket.create_connection(("127.0.0.1", int(sys.argv[1])))
s.sendall(b"PUT /v1/rigs/killed HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer k3y-for-tests\r\nContent-Type: model/gltf-binary\r\nContent-Length: %d\r\n\r\n" % len(body))
s.sendall(body[: len(body) // 2]); time.sleep(30)' "$port" "$A/Fox/Fox.glb" & slowpid=$!
sleep 0.5; kill -9 "$pid"; wait "$pid" 2>/dev/null; pid=; kill "$slowpid" 2>/dev/null
start
check "kill -9 while an upload arrives: after restart the rig is absent, no temporary file, every earlier rig served" sh -c "[ \$(curl -s -o /dev/null -w '%{http_code}' '$U/v1/rigs/killed') = 404 ] && [ \"\$(ls '$store' | sort | tr '\n' ' ')\" = '$good' ] && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/v1/rigs/facecap') = 200 ]"
# A full disk: the server may write at most 64 KiB per file (RLIMIT_FSIZE, SIGXFSZ ignored: writes fail with EFBIG, as on ENOSPC).
kill -TERM "$pid"; wait "$pid"; pid=
(trap '' XFSZ; ulimit -f 64; exec "$bin" serve --host 127.0.0.1 --port "$port" --rigs "$store" --api-key-file "$tmp/key" --jobs-dir "$tmp/jobs" --quiet >>"$tmp/log2" 2>&1) & pid=$!
for _ in $(seq 1 600); do curl -fs "$U/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
cp "$store/facecap.glb" "$tmp/facecap.before"
code=$(c -X PUT -H 'Authorization: Bearer k3y-for-tests' -H 'Content-Type: model/gltf-binary' --data-binary @"$A/Fox/Fox.glb" "$U/v1/rigs/facecap")
check "file size limit during an upload (EFBIG): 507 storage-full, the old rig still served and unchanged on disk, no temporary file" sh -c "[ $code = 507 ] && grep -q 'storage-full' '$tmp/body' && cmp -s '$store/facecap.glb' '$tmp/facecap.before' && ! ls -a '$store' | grep -q tmp && [ \$(curl -s '$U/v1/rigs/facecap' | python3 -c 'import json,sys; print(json.load(sys.stdin)[\"shapes\"].__len__())') = 52 ]"
kill -TERM "$pid"; wait "$pid"; pid=
# A really full disk: the store and the jobs folder on a 1 MiB tmpfs.
full=$tmp/full; mkdir -p "$full"
if mount -t tmpfs -o size=1m,mode=0755 tmpfs "$full" 2>"$tmp/mount.err"; then
  mkdir -p "$full/store" "$full/jobs"
  cp "$store/facecap.glb" "$store/facecap.manifest.json" "$full/store/"
  head -c 600000 /dev/zero >"$full/filler"   # about 80 KB left: no room for Fox (163 KB)
  "$bin" serve --host 127.0.0.1 --port "$port" --rigs "$full/store" --api-key-file "$tmp/key" --jobs-dir "$full/jobs" --quiet >>"$tmp/log3" 2>&1 & pid=$!
  for _ in $(seq 1 600); do curl -fs "$U/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
  code=$(c -X PUT "${K[@]}" -H 'Content-Type: model/gltf-binary' --data-binary @"$A/Fox/Fox.glb" "$U/v1/rigs/fox")
  check "tmpfs full (ENOSPC): a new rig is 507 storage-full naming the cause, nothing stored, no temporary file" sh -c "[ $code = 507 ] && grep -q 'No space left on device' '$tmp/body' && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/v1/rigs/fox') = 404 ] && [ \"\$(ls -A '$full/store' | sort | tr '\n' ' ')\" = 'facecap.glb facecap.manifest.json ' ]"
  code=$(c -X PUT "${K[@]}" -H 'Content-Type: model/gltf-binary' --data-binary @"$A/Fox/Fox.glb" "$U/v1/rigs/facecap")
  check "tmpfs full: replacing a rig is 507, the old one unchanged on disk and still served" sh -c "[ $code = 507 ] && cmp -s '$full/store/facecap.glb' '$store/facecap.glb' && [ \$(curl -s '$U/v1/rigs/facecap' | python3 -c 'import json,sys; print(len(json.load(sys.stdin)[\"shapes\"]))') = 52 ]"
  code=$(c -X POST "${K[@]}" -H 'Content-Type: application/json' -d '{"sample":{"method":"uniform","count":20,"seed":1},"format":"glb"}' "$U/v1/rigs/facecap/batch")
  check "tmpfs full: a batch whose variants cannot fit is refused at once, 507 storage-full with the estimate, no job folder" sh -c "[ $code = 507 ] && grep -q 'the batch would write about' '$tmp/body' && [ \$(ls '$full/jobs' | wc -l) = 0 ]"
  head -c 10000000 /dev/zero >"$full/filler2" 2>/dev/null   # the rest, to the last block
  code=$(c -X POST "${K[@]}" -H 'Content-Type: application/json' -d '{"sample":{"method":"uniform","count":20,"seed":1},"format":"glb"}' "$U/v1/rigs/facecap/batch")
  check "tmpfs with no byte left: starting a batch is 507 storage-full, no job folder left behind" sh -c "[ $code = 507 ] && grep -q 'storage-full' '$tmp/body' && [ \$(ls '$full/jobs' | wc -l) = 0 ]"
  check "  ... and the service still answers" test "$(c "$U/v1/rigs/facecap/mesh?w.jawOpen=1&format=f32")" = 200
  rm -f "$full/filler" "$full/filler2"
  code=$(c -X PUT "${K[@]}" -H 'Content-Type: model/gltf-binary' --data-binary @"$A/Fox/Fox.glb" "$U/v1/rigs/fox")
  check "tmpfs with space again: the same upload is 201" test "$code" = 201
  kill -TERM "$pid"; wait "$pid"; pid=
  "$bin" serve --host 127.0.0.1 --port "$port" --rigs "$full/store" --api-key-file "$tmp/key" --jobs-dir "$full/jobs" --quiet >>"$tmp/log3" 2>&1 & pid=$!
  for _ in $(seq 1 600); do curl -fs "$U/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
  check "tmpfs: after a restart facecap and fox are served, nothing half-written in the store" sh -c "[ \$(curl -s -o /dev/null -w '%{http_code}' '$U/v1/rigs/facecap') = 200 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/v1/rigs/fox') = 200 ] && [ \"\$(ls -A '$full/store' | sort | tr '\n' ' ')\" = 'facecap.glb facecap.manifest.json fox.glb ' ]"
  kill -TERM "$pid"; wait "$pid"; pid=
  umount "$full"
else
  echo "SKIP tmpfs full-disk checks: cannot mount a tmpfs here ($(head -c 200 "$tmp/mount.err")); the RLIMIT_FSIZE check above stands in"
fi
# A corrupt file on disk (bytes flipped in the middle of a rig): reported and skipped at start, the others served.
cp "$store/facecap.glb" "$store/corrupt.glb"
python3 -c 'import sys; p=sys.argv[1]; b=bytearray(open(p,"rb").read()); b[20:4000]=b"\xff"*3980; open(p,"wb").write(b)' "$store/corrupt.glb"
: >"$tmp/log"
start
check "a corrupt rig file: reported at start and skipped; every other rig served" sh -c "grep -q 'skipping broken rig.*corrupt.glb' '$tmp/log' && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/v1/rigs/corrupt') = 404 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/v1/rigs/facecap') = 200 ] && [ \$(curl -s -o /dev/null -w '%{http_code}' '$U/v1/rigs/makehuman') = 200 ]"


# With no --rigs (the README's command), the bundled rigs are served read-only and uploads go to
# the state folder, never into the checkout's assets/. They used to land in assets/.
ls -A "$src/assets" | sort >"$tmp/assets.before"
port4=$(py 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])')
XDG_STATE_HOME="$tmp/state" "$bin" serve --host 127.0.0.1 --port "$port4" --api-key-file "$tmp/key" --quiet >>"$tmp/log4" 2>&1 & pid4=$!
for _ in $(seq 1 300); do curl -fs "http://127.0.0.1:$port4/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
K4=(-H 'Authorization: Bearer k3y-for-tests')
code=$(c -X PUT "${K4[@]}" -H 'Content-Type: model/gltf-binary' --data-binary @"$A/Fox/Fox.glb" "http://127.0.0.1:$port4/v1/rigs/fox")
check "no --rigs: an upload lands in \$XDG_STATE_HOME/facespace/rigs, the checkout's assets/ untouched" \
  sh -c "[ $code = 201 ] && [ -s '$tmp/state/facespace/rigs/fox.glb' ] && ls -A '$src/assets' | sort | cmp -s - '$tmp/assets.before'"
check "  ... the bundled rig cannot be replaced: 409 read-only" problem "$(c -X PUT "${K4[@]}" -H 'Content-Type: model/gltf-binary' --data-binary @"$A/Fox/Fox.glb" "http://127.0.0.1:$port4/v1/rigs/facecap")" 409 "d['type'].endswith('read-only')"
problem "$(c -X DELETE "${K4[@]}" "http://127.0.0.1:$port4/v1/rigs/facecap")" 409 True && [ "$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port4/v1/rigs/facecap")" = 200 ] && \
  ok "  ... nor deleted: 409, and still served" || no "  ... nor deleted: 409, and still served"
check "  ... nor its manifest replaced: 409" problem "$(c -X PUT "${K4[@]}" -H 'Content-Type: application/json' -d '{"name": "mine"}' "http://127.0.0.1:$port4/v1/rigs/facecap/manifest")" 409 "d['type'].endswith('read-only')"
kill $pid4; wait $pid4 2>/dev/null
XDG_STATE_HOME="$tmp/state" "$bin" serve --host 127.0.0.1 --port "$port4" --quiet >>"$tmp/log4" 2>&1 & pid4=$!
for _ in $(seq 1 300); do curl -fs "http://127.0.0.1:$port4/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
check "  ... and after a restart the upload is served beside the bundled rigs" sh -c "curl -s 'http://127.0.0.1:$port4/v1/rigs' | grep -q '\"id\":\"fox\"' && curl -s 'http://127.0.0.1:$port4/v1/rigs' | grep -q '\"id\":\"facecap\"'"
kill $pid4; wait $pid4 2>/dev/null

# An MD5 rig (Bob: .md5mesh + .md5anim) in a folder of another store: served with its skeleton and
# clip; the mesh at a clip time differs from the rest pose; a render of it is a PNG.
mkdir -p "$tmp/md5store/bob"
cp "$2/more/MD5/Bob/Bob.md5mesh" "$tmp/md5store/bob/bob.md5mesh"; cp "$2/more/MD5/Bob/Bob.md5anim" "$tmp/md5store/bob/"
port2=$(py 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])')
"$bin" serve --host 127.0.0.1 --port "$port2" --rigs "$tmp/md5store" --quiet >>"$tmp/log2" 2>&1 & pid2=$!
for _ in $(seq 1 600); do curl -fs "http://127.0.0.1:$port2/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
c "http://127.0.0.1:$port2/v1/rigs/bob" >/dev/null
check "MD5 in the store: 33 joints, the clip 'Bob' of 139/24 s" jq_ "d['skeleton']['joints']==33 and d['animations'][0]['name']=='Bob' and abs(d['animations'][0]['duration']-139/24)<1e-4 and d['triangles']==1027"
curl -s -o "$tmp/bob_rest.f32" "http://127.0.0.1:$port2/v1/rigs/bob/mesh?format=f32"
curl -s -o "$tmp/bob_anim.f32" "http://127.0.0.1:$port2/v1/rigs/bob/mesh?format=f32&animation=Bob&time=1.5"
check "MD5: the mesh at t=1.5 s of the clip is not the rest pose (same size)" sh -c "[ \$(stat -c %s '$tmp/bob_rest.f32') -eq \$(stat -c %s '$tmp/bob_anim.f32') ] && ! cmp -s '$tmp/bob_rest.f32' '$tmp/bob_anim.f32'"
code=$(curl -s -o "$tmp/bob.png" -w '%{http_code}' "http://127.0.0.1:$port2/v1/rigs/bob/render?animation=Bob&time=1.5&width=128&height=128")
check "MD5: a render at t=1.5 s is a 128x128 PNG" py 'import sys,struct; d=open(sys.argv[1],"rb").read(); sys.exit(not(sys.argv[2]=="200" and d[:8]==b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", d[16:24])==(128,128)))' "$tmp/bob.png" "$code"
kill $pid2; wait $pid2 2>/dev/null

# The bundled MMD model in a store folder ("uka": the folder names it, its file stem MS_Uka is no id):
# its credit, the VMD motions as clips; "motion" + "frame" is "animation" + "time" at 30 frames a second;
# the sequence routes play a motion; bad motion requests are 422 naming the field.
mkdir -p "$tmp/mmdstore/uka"
cp -r "$src/assets/uka/MS_Uka.pmx" "$src/assets/uka/MS_Uka.manifest.json" "$src/assets/uka/motion" "$tmp/mmdstore/uka/"
port3=$(py 'import socket;s=socket.socket();s.bind(("127.0.0.1",0));print(s.getsockname()[1])')
"$bin" serve --host 127.0.0.1 --port "$port3" --rigs "$tmp/mmdstore" --quiet >>"$tmp/log3" 2>&1 & pid3=$!
for _ in $(seq 1 600); do curl -fs "http://127.0.0.1:$port3/healthz" >/dev/null 2>&1 && break; sleep 0.1; done
U3=http://127.0.0.1:$port3/v1/rigs/uka
c "$U3" >/dev/null
check "MMD in the store: uka, 302 joints, 213 shapes, the credit line, 40 motions (01_happy 10 s, stand 4 s)" jq_ "d['skeleton']['joints']==302 and d['shapes'].__len__()==213 and 'Nagoya Institute of Technology, Moonshot R&D Goal 1 Avatar Symbiotic Society' in d['credit'] and len(d['animations'])==40 and d['animations'][1]['name']=='01_happy' and abs(d['animations'][1]['duration']-10)<1e-6 and d['animations'][-1]['name']=='stand' and abs(d['animations'][-1]['duration']-4)<1e-6"
curl -s -o "$tmp/uka_rest.f32" "$U3/mesh?format=f32"
curl -s -o "$tmp/uka_f150.f32" "$U3/mesh?format=f32&motion=01_happy&frame=150"
curl -s -o "$tmp/uka_t5.f32" -X POST -H 'Content-Type: application/json' -d '{"animation":"01_happy","time":5,"format":"f32"}' "$U3/mesh"
check "MMD: motion 01_happy at frame 150 is animation 01_happy at 5 s, and not the rest pose" sh -c "cmp -s '$tmp/uka_f150.f32' '$tmp/uka_t5.f32' && ! cmp -s '$tmp/uka_f150.f32' '$tmp/uka_rest.f32' && [ \$(stat -c %s '$tmp/uka_rest.f32') -eq 1198920 ]"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"motion":"01_happy","times":[0,5]}' "$U3/sequence/sample")
check "MMD: sequence/sample plays a motion: at 5 s its morph keys (にこり, 笑い, ワ and the blush 赤み, a material morph, at 1), at 0 s the rest" sh -c "[ $code = 200 ] && python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); f=d[\"frames\"]; w={k:v for k,v in f[1][\"weights\"].items() if v}; sys.exit(not(w=={\"にこり\":1,\"笑い\":1,\"ワ\":1,\"赤み\":1} and not any(f[0][\"weights\"].values())))' '$tmp/body'"
code=$(c -X POST -H 'Content-Type: application/json' -d '{"motion":"01_happy","fps":30}' "$U3/sequence/stream")
check "MMD: sequence/stream plays a motion: 301 frames at 30 a second" sh -c "[ $code = 200 ] && [ \"\$(grep -i '^facespace-frames:' '$tmp/hdr' | tr -d '\r' | cut -d' ' -f2)\" = 301 ] && [ \$(wc -l <'$tmp/body') = 301 ]"
check "MMD: an unknown motion is 422 naming /motion and listing the motions" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"motion":"nope","frame":1}' "$U3/mesh")" 422 "d['errors'][0]['pointer']=='/motion' and '01_happy' in d['errors'][0]['detail']"
check "MMD: time and frame together is 422 naming the field" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"motion":"01_happy","frame":1,"time":2}' "$U3/mesh")" 422 "d['errors'][0]['pointer'] in ('/time','/frame')"
check "MMD: frame without a motion is 422" problem "$(c -X POST -H 'Content-Type: application/json' -d '{"frame":1}' "$U3/mesh")" 422 "'motion' in d['errors'][0]['detail']"
code=$(curl -s -o "$tmp/uka.png" -w '%{http_code}' "$U3/render?motion=01_happy&frame=150&width=128&height=128&camera=%7B%22frame%22%3A%22shapes%22%7D")
check "MMD: a render at frame 150 (camera framing the shapes) is a 128x128 PNG" py 'import sys,struct; d=open(sys.argv[1],"rb").read(); sys.exit(not(sys.argv[2]=="200" and d[:8]==b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", d[16:24])==(128,128)))' "$tmp/uka.png" "$code"
kill $pid3; wait $pid3 2>/dev/null

finish
