#!/usr/bin/env bash
# The house naming rules (.clang-tidy's readability-identifier-naming, ../shared/STYLE.md
# item 3) on every C++ translation unit of a configured build folder: names every
# deviation as "FILE:LINE:COL: warning: ..." once and exits 1, or says how many units it
# checked. Math notation is allowed where the paper uses it (T_root_sensor, R, H, best_T);
# .clang-tidy says exactly what counts as such.
# Usage: scripts/check_naming.sh BUILD_DIR   (a folder configured by scripts/build.sh; its
# unity units include every source file, so each is checked once per unit it is in)
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "$1" && pwd)"
tidy="$(command -v clang-tidy-14 || command -v clang-tidy || true)"
[ -n "$tidy" ] || { echo "check_naming: clang-tidy not installed (scripts/setup.sh)" >&2; exit 1; }
[ -f "$build/compile_commands.json" ] ||
    { echo "check_naming: $build/compile_commands.json missing: configure $build first" >&2; exit 1; }
# Our C++ units only: the C files are rosidl's generated message code.
mapfile -t units < <(python3 - "$build/compile_commands.json" <<'EOF'
import json, sys
seen = []
for entry in json.load(open(sys.argv[1])):
    name = entry["file"]
    if not name.endswith(".c") and name not in seen:
        seen.append(name)
print("\n".join(seen))
EOF
)
# The units were configured for GCC; clang-tidy parses with clang, which does not know
# GCC's -Wshadow=local and -Wno-subobject-linkage.
status=0
report="$(printf '%s\0' "${units[@]}" |
          xargs -0 -n 1 -P "$(nproc)" "$tidy" -p "$build" --quiet \
              --checks='-*,readability-identifier-naming' --warnings-as-errors='*' \
              --header-filter="^$top/(core|drivers|daemon|tools|tests|bench|fuzz|examples)/" \
              --extra-arg=-Wno-unknown-warning-option 2>&1)" || status=$?
mapfile -t bad < <(grep -E '^/[^:]+:[0-9]+:[0-9]+: (warning|error):' <<<"$report" | sort -u)
if [ ${#bad[@]} -gt 0 ]; then
    echo "check_naming: ${#bad[@]} findings (names against .clang-tidy, or what clang itself reports):" >&2
    printf '  %s\n' "${bad[@]#"$top/"}" >&2
    exit 1
elif [ "$status" -ne 0 ]; then
    echo "check_naming: clang-tidy failed:" >&2
    echo "$report" >&2
    exit 1
fi
echo "check_naming: ${#units[@]} units follow .clang-tidy's naming rules ($("$tidy" --version | grep -o 'version [0-9.]*'))"
