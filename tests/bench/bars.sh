#!/usr/bin/env bash
# The speed bars of the end-to-end suites, held: the suites that assert outcomes in the test command (a
# probe answered, a frame for every session, a refusal's status) run here once more with FACESPACE_BARS=1,
# one at a time on the release binary, so that their figures (a p99, "within 300 ms") fail when missed.
# Run it on a quiet machine: these are the machine's figures as much as the code's.
#   bash tests/bench/bars.sh [BUILD_DIR]      (part of `bash .ci/dev bench`; FACESPACE_BAR_SUITES="a b" picks suites)
set -uo pipefail
build=${1:-build}
root=$(cd "$(dirname "$0")/../.." && pwd)
export FACESPACE_BARS=1
suites=(${FACESPACE_BAR_SUITES:-live_end_to_end browser_end_to_end hardening_rest_end_to_end hardening_listeners_end_to_end hostile_end_to_end bounded_end_to_end nginx_end_to_end})
failed=()
for suite in "${suites[@]}"; do
  echo "== $suite (bars held)"
  start=$SECONDS
  out=$(ctest --test-dir "$root/$build" -R "^${suite}\$" -V 2>&1)
  rc=$?
  # The bars' own lines, and any check that failed (ctest -V puts the test's number before each line).
  sed -E 's/^[0-9]+: //' <<<"$out" | grep -E '^(ok|FAIL) +bar: |^FAIL ' | sort -u
  [ $rc -eq 0 ] || failed+=("$suite")
  echo "   ($((SECONDS - start)) s)"
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "bars missed in: ${failed[*]}" >&2
  exit 1
fi
echo "every bar held"
