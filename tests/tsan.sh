#!/usr/bin/env bash
# The concurrent suites under ThreadSanitizer (issue 61): tsan.sh BUILD_DIR (a -DFACESPACE_TSAN=ON build of
# api_tests, speech_tests and batch_tests). A data race, a lock-order inversion or a use of a destroyed mutex
# fails the run (halt_on_error), with both stacks; tests/tsan.supp names what is not ours to fix.
set -euo pipefail
dir=$1
root=$(cd "$(dirname "$0")/.." && pwd)
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$root/tests/tsan.supp${TSAN_OPTIONS:+:$TSAN_OPTIONS}"
status=0
# The front (fair shares, probes, the meter), WebSocket framing and the budgets; the live recognizers and
# espeak-ng from many threads; the job queue and its runs.
run() {  # run BINARY [gtest filter]
  local bin=$dir/$1 filter=${2:-*}
  echo "== tsan: $1 ($filter)"
  if ! "$bin" --gtest_filter="$filter" --gtest_brief=1; then
    echo "FAIL tsan: $1 ($filter)"
    status=1
  fi
}
run tests/api/api_tests
run tests/speech/speech_tests 'Sphinx.*:Espeak.*'
run tests/batch/batch_tests
exit $status
