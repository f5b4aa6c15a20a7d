#!/usr/bin/env python3
"""Figures and lists in the docs that come from the code stay true: every route of the route table
(api/http/src/http/route_table.cpp) is in api/README.md's route table (by its path), and the README names the
place its test-command figure comes from rather than a number."""
import re
import sys
from pathlib import Path

root = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).resolve().parent.parent)
failures = []
table = (root / "api/http/src/http/route_table.cpp").read_text()
routes = re.findall(r'\{"(GET|POST|PUT|DELETE)", "(/[^"]*)"', table)
if len(routes) < 20:
    failures.append(f"read only {len(routes)} routes from route_table.cpp: the pattern no longer matches")
readme = (root / "api/README.md").read_text()
rows = "\n".join(line for line in readme.splitlines() if line.startswith("| `"))
for method, path in routes:
    # A row names the route by its whole path, or by its last part after another route's on the same row.
    last = path.rsplit("/", 1)[-1]
    if path not in rows and not re.search(r"`[^`]*" + re.escape("/" + last) + r"[`?]", rows) and f"`{last}`" not in rows:
        failures.append(f"api/README.md's route table lacks {method} {path}")
top = (root / "README.md").read_text()
if "== stage times" not in top:
    failures.append("README.md no longer says the test command's figure comes from its `== stage times` lines")
for f in failures:
    print("FAIL", f)
print(f"{len(routes)} routes checked against api/README.md; {len(failures)} failures")
sys.exit(1 if failures else 0)
