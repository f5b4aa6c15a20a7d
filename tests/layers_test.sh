#!/bin/bash
# The layers of README.md's "Layout of the code", checked against the includes. Each library is one
# folder, named as its target (facespace_NAME) and its headers' path (include/facespace/NAME/), and
# each folder with code under core/, render/ and api/ is one library; a library's sources include
# facespace headers only from the libraries it depends on (listed here as plain dependencies: no
# folder nests in another, so no exclusions).
src=${1:-$(dirname "$0")/..}
cd "$src" || exit 2
fail=0
# folder | the libraries whose headers it may include (its own included)
check() {
  local folder=$1 allowed=$2 name=${1##*/}
  local bad
  bad=$(grep -rnoE '#include "facespace/[a-z_]+/[a-z_./]+"' "$folder" --include=*.cpp --include=*.h |
        grep -vE "\"facespace/($name|$allowed)/")
  if [ -n "$bad" ]; then
    echo "FAIL $folder includes above its layer:"; echo "$bad" | sed 's/^/  /'; fail=1
  else
    echo "ok   $folder: $name over ${allowed//|/, }"
  fi
  # The folder is its library: a CMakeLists.txt making facespace_NAME, headers under include/facespace/NAME.
  if ! grep -qE "add_library\(facespace_$name\b" "$folder/CMakeLists.txt" 2>/dev/null; then
    echo "FAIL $folder: no facespace_$name target in its CMakeLists.txt"; fail=1
  fi
  local stray
  stray=$(find "$folder" -path "$folder/include/*" -name '*.h' ! -path "$folder/include/facespace/$name/*")
  if [ -n "$stray" ]; then echo "FAIL $folder: headers outside include/facespace/$name: $stray"; fail=1; fi
  # Its namespace is its name: facespace::NAME (or one nested in it). The engine's is inline, as its
  # names (Rig, Status, Weights) are the vocabulary every library speaks: facespace::engine::Rig,
  # written Rig; every other library's names are qualified where they are used (formats::LoadGltf).
  local want="facespace::$name" wrong
  if [ "$name" = engine ]; then  # namespace facespace { inline namespace engine {
    want="facespace { inline namespace engine"
    wrong=$(grep -rnE '^\s*namespace facespace' "$folder" --include=*.cpp --include=*.h | grep -vE 'namespace facespace \{$'
            grep -rLE '^inline namespace engine \{$' "$folder" --include=*.cpp --include=*.h | xargs -r grep -lE '^namespace facespace \{$')
  else
    wrong=$(grep -rnE '^\s*namespace facespace' "$folder" --include=*.cpp --include=*.h | grep -vE "namespace $want( \{|::)")
  fi
  if [ -n "$wrong" ]; then echo "FAIL $folder: a namespace other than $want:"; echo "$wrong" | sed 's/^/  /'; fail=1; fi
}
# core
check core/engine 'engine'
check core/formats 'engine'
check core/physics 'engine'
check core/speech 'engine'
check core/files 'engine'
check core/derive 'engine'
# render: what a picture is, then what draws it
check render/picture 'engine'
check render/oiio 'oiio'
check render/offscreen 'engine|picture|oiio'
# api: a request to bytes, speech plans, batches, the network server, the HTTP routes
check api/evaluator 'engine|formats|picture|physics'
check api/lipsync 'engine|formats|picture|offscreen|speech|evaluator'
check api/batch 'engine|formats|picture|files|evaluator'
check api/net 'engine'
check api/http 'engine|formats|picture|offscreen|speech|evaluator|batch|lipsync|net|files|derive'
# Every folder with code is one of the libraries above (a new one is added here, with its layer).
known=" core/engine core/derive core/formats core/physics core/speech core/files render/picture render/oiio render/offscreen api/evaluator api/lipsync api/batch api/net api/http "
for dir in core/* render/* api/*; do
  [ -d "$dir" ] || continue
  if find "$dir" -name '*.cpp' -o -name '*.h' | grep -q . && [[ "$known" != *" $dir "* ]]; then
    echo "FAIL $dir has code but is not a library of this test"; fail=1
  fi
done
# httplib stays in the network and HTTP layers: the evaluator and batch never see it.
if grep -rlq 'httplib' api/evaluator api/batch; then echo "FAIL httplib below the HTTP layer: $(grep -rl httplib api/evaluator api/batch)"; fail=1; else echo "ok   no httplib in api/evaluator, api/batch"; fi
# The network server knows no routes: nothing of the HTTP layer (problems, routes) in it.
if grep -rqE '#include "(problem|routes/)|Problem::' api/net; then echo "FAIL api/net knows the HTTP layer: $(grep -rlE '#include "(problem|routes/)|Problem::' api/net)"; fail=1; else echo "ok   api/net knows no routes or problems"; fi
exit $fail
