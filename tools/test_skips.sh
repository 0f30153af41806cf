#!/usr/bin/env bash
# Prints each skipped GoogleTest test of a CTest log with the reason it gave (ctest itself lists
# only the names). Usage: tools/test_skips.sh [BUILD_DIR/Testing/Temporary/LastTest.log]
set -euo pipefail
log=${1:-build/Testing/Temporary/LastTest.log}
[ -f "$log" ] || exit 0
awk '
  /^\[ RUN      \] / { name = $4; reason = ""; in_skip = 0; next }
  /: Skipped$/       { in_skip = 1; next }
  /^\[  SKIPPED \] / { if (in_skip) { print "skipped: " name ": " reason; count++ } in_skip = 0; next }
  in_skip            { reason = (reason == "" ? $0 : reason " " $0) }
  END                { if (count) print count " test(s) skipped, each with its reason above" }
' "$log"
