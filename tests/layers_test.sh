#!/bin/bash
# The layers of README.md's "Layout of the code", checked against the includes: each folder's
# sources include facespace headers only from their own layer and the layers below it.
#   core <- core/formats <- api/evaluator <- api/batch <- api <- service; render/picture (what a picture
#   is, the Renderer interface) under the evaluator, render (what draws) beside it; core/physics and
#   core/speech beside formats; api/lipsync (speech plans, their video) over the evaluator, render and speech.
src=${1:-$(dirname "$0")/..}
cd "$src" || exit 2
fail=0
# folder (sources to check, excluding sub-layers) | header prefixes it may include
check() {
  local folder=$1 allowed=$2 exclude=$3
  local bad
  bad=$(grep -rnoE '#include "facespace/[a-z_]+/[a-z_./]+"' $folder --include=*.cpp --include=*.h |
        { if [ -n "$exclude" ]; then grep -vE "$exclude"; else cat; fi; } |
        grep -vE "\"facespace/($allowed)")
  if [ -n "$bad" ]; then
    echo "FAIL $folder includes above its layer:"; echo "$bad" | sed 's/^/  /'; fail=1
  else
    echo "ok   $folder: $allowed"
  fi
}
evaluator_headers='evaluator/'
check core 'core/' '^core/(formats|physics|speech|files)/'
check core/formats 'core/|formats/'
check core/physics 'core/|physics/'
check core/speech 'core/|speech/'
check core/files 'core/|files/'
check render/picture 'core/|render/picture\.h'
check render 'core/|render/' '^render/picture/'
check api/evaluator "core/|formats/|render/picture\.h|physics/|$evaluator_headers"
check api/lipsync "core/|formats/|render/|speech/|$evaluator_headers|lipsync/"
check api/batch "core/|formats/|render/picture\.h|files/|$evaluator_headers|batch/"
check api 'core/|formats/|render/|speech/|api/|evaluator/|batch/|lipsync/' '^api/(evaluator|batch|lipsync)/'
# httplib stays in the HTTP layer: the evaluator and batch never see it.
if grep -rlq 'httplib' api/evaluator api/batch; then echo "FAIL httplib below the HTTP layer: $(grep -rl httplib api/evaluator api/batch)"; fail=1; else echo "ok   no httplib in api/evaluator, api/batch"; fi
exit $fail
