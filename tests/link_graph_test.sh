#!/bin/bash
# Issue 49's link graph, from `cmake --graphviz` on a scratch configure of the tree: the evaluator and
# the unit tests of core and formats reach neither the renderer (OSMesa, libav*) nor speech (espeak-ng,
# PocketSphinx), nor the render, speech and lip-sync targets. Each target's file lists all it reaches.
src=${1:-$(dirname "$0")/..}
src=$(cd "$src" && pwd)
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
if ! cmake -S "$src" -B "$scratch" -DFACESPACE_BUILD_BENCH=OFF --graphviz="$scratch/deps.dot" >"$scratch/log" 2>&1; then
  cat "$scratch/log"; exit 2
fi
heavy='OSMESA|osmesa|LIBAV|libav|ESPEAK|espeak|POCKETSPHINX|pocketsphinx|"facespace_offscreen"|"facespace_speech"|"facespace_lipsync"'
fail=0
check() {  # target, what it must reach (a sanity check that the graph is read)
  local file="$scratch/deps.dot.$1"
  if [ ! -f "$file" ]; then echo "FAIL no graph for $1"; fail=1; return; fi
  if ! grep -q "\"$2\"" "$file"; then echo "FAIL $1 does not reach $2: the graph is not what this test reads"; fail=1; return; fi
  local bad
  bad=$(grep -oE "label = \"[^\"]*\"" "$file" | grep -E "$heavy" | sort -u)
  if [ -n "$bad" ]; then echo "FAIL $1 reaches:"; echo "$bad" | sed 's/^/  /'; fail=1; else echo "ok   $1 reaches none of the renderer's and speech's libraries"; fi
}
check facespace_evaluator facespace_formats
check core_tests facespace_formats
check core_alloc_tests facespace_formats
check physics_tests facespace_evaluator
# And the graph does show the heavy libraries where they are: the service links them.
if grep -qE "$heavy" "$scratch/deps.dot.facespace"; then echo "ok   facespace (the service) reaches them"; else echo "FAIL the service reaches no renderer: the pattern is wrong"; fail=1; fi
exit $fail
