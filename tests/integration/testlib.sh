# Shared by the shell test suites: counters, checks, the closing line. Source it, then call
# `check "what" COMMAND...` for each check and `finish` at the end.
pass=0; fail=0; failed=
ok() { pass=$((pass + 1)); echo "ok   $*"; }
no() { fail=$((fail + 1)); failed+="FAIL $*"$'\n'; echo "FAIL $*"; }
check() { local what=$1; shift; if "$@"; then ok "$what"; else no "$what"; fi; }
both() { sh -c "$1" && "${@:2}"; }  # check "what" both "SHELL CONDITION" COMMAND...: both must hold.
# Debian's python3 (what .ci/dev installs) where there is one: a version manager's shim on PATH costs
# each of a suite's hundreds of checks a few hundred milliseconds.
python=python3; [ -x /usr/bin/python3 ] && python=/usr/bin/python3
py() { "$python" -c "$1" "${@:2}"; }
# The failures again at the end, where a CI log cut in the middle still shows them.
finish() { [ $fail -eq 0 ] || printf '\nfailed:\n%s' "$failed"; echo "$pass passed, $fail failed"; [ $fail -eq 0 ]; }
