#!/usr/bin/env bash
# The house format (.clang-format, ../shared/STYLE.md) on every C and C++ file of the
# checkout: lists each file clang-format would change and exits 1, or says how many files it
# checked. To fix one: clang-format -i FILE (or `git clang-format` for a change).
# Usage: scripts/check_format.sh [FILE ...]   (no files: every tracked source file)
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
cd "$top"
command -v clang-format >/dev/null || { echo "check_format: clang-format not installed (scripts/setup.sh)" >&2; exit 1; }
files=("$@")
if [ ${#files[@]} -eq 0 ]; then
    if git -C "$top" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
        mapfile -t files < <(git ls-files '*.c' '*.cpp' '*.h' '*.hpp')
    else
        mapfile -t files < <(find core drivers daemon tools tests bench fuzz examples \
                                  -name '*.c' -o -name '*.cpp' -o -name '*.h' -o -name '*.hpp' | sort)
    fi
fi
# Many files per clang-format process, one process per core: starting one per file costs
# most of the time. Each deviation is reported as "FILE:LINE:COL: error: ...".
report="$(printf '%s\0' "${files[@]}" |
          xargs -0 -n 40 -P "$(nproc)" clang-format --dry-run --Werror 2>&1 >/dev/null || true)"
mapfile -t bad < <(grep -oE '^[^:]+:[0-9]+:[0-9]+: error:' <<<"$report" | cut -d: -f1 | sort -u)
if [ ${#bad[@]} -gt 0 ]; then
    echo "check_format: ${#bad[@]} of ${#files[@]} files differ from .clang-format ($(clang-format --version)):" >&2
    printf '  %s\n' "${bad[@]}" >&2
    echo "fix with: clang-format -i FILE..." >&2
    exit 1
elif [ -n "$report" ]; then
    echo "check_format: clang-format failed:" >&2
    echo "$report" >&2
    exit 1
fi
echo "check_format: ${#files[@]} files follow .clang-format"
