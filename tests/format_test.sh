#!/usr/bin/env bash
# The code follows .clang-format (EXAMPLES.md: Google style, 100 columns), as Debian's clang-format
# reads it: every C++ file git tracks (or, outside a checkout, every one under the code's folders).
#   format_test.sh SOURCE_DIR
# To fix what it names: clang-format -i FILE...
set -euo pipefail
cd "$1"
command -v clang-format >/dev/null || { echo "FAIL clang-format is not installed (.ci/dev test installs it)"; exit 1; }
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files -co --exclude-standard -- '*.cpp' '*.h' | while read -r f; do [ -f "$f" ] && echo "$f"; done)
else
  mapfile -t files < <(find core api render service tests -name '*.cpp' -o -name '*.h')
fi
[ "${#files[@]}" -gt 100 ] || { echo "FAIL only ${#files[@]} C++ files found under $1"; exit 1; }
# One run over them all; each file that differs is named in its warnings ("FILE:LINE:COL: error: ...").
mapfile -t bad < <(clang-format --dry-run -Werror "${files[@]}" 2>&1 | sed -n 's/^\([^:]*\):[0-9]*:[0-9]*: error: .*/\1/p' | sort -u)
if [ "${#bad[@]}" -gt 0 ]; then
  echo "FAIL ${#bad[@]} of ${#files[@]} files are not as .clang-format writes them (clang-format -i FILE):"
  printf '  %s\n' "${bad[@]}"
  exit 1
fi
echo "ok: ${#files[@]} C++ files as .clang-format writes them ($(clang-format --version | head -1))"
