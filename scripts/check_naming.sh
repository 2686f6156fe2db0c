#!/usr/bin/env bash
# The house naming rules (.clang-tidy's readability-identifier-naming, ../shared/STYLE.md
# item 3) on every C++ translation unit of a configured build folder: names every
# deviation as "FILE:LINE:COL: warning: ..." once and exits 1, or says how many units it
# checked. Math notation is allowed where the paper uses it (T_root_sensor, R, H, best_T);
# .clang-tidy says exactly what counts as such.
# Usage: scripts/check_naming.sh BUILD_DIR   (a folder configured by scripts/build.sh; its
# unity units include every source file, so each is checked once per unit it is in)
# A unit that passed is remembered in $LIDARFUSE_NAMING_CACHE (default
# ~/.cache/lidarfuse/naming) under a hash of everything clang-tidy's verdict depends on:
# its preprocessed text as clang sees it (with every #define, every comment, since NOLINT
# is one, and the file and line of every line), clang-tidy's version, .clang-tidy and this
# script's options, with the checkout's own path written as @TOP@ so that clones in other
# folders share what passed. Only passes are remembered: a finding is reported on every
# run until it is fixed.
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "$1" && pwd)"
tidy="$(command -v clang-tidy-14 || command -v clang-tidy || true)"
[ -n "$tidy" ] || { echo "check_naming: clang-tidy not installed (scripts/setup.sh)" >&2; exit 1; }
clangxx="$(command -v clang++-14 || command -v clang++ || true)"
[ -n "$clangxx" ] || { echo "check_naming: clang++ not installed (scripts/setup.sh)" >&2; exit 1; }
[ -f "$build/compile_commands.json" ] ||
    { echo "check_naming: $build/compile_commands.json missing: configure $build first" >&2; exit 1; }
cache="${LIDARFUSE_NAMING_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/lidarfuse/naming}"
mkdir -p "$cache"
# The units were configured for GCC; clang-tidy parses with clang, which does not know
# GCC's -Wshadow=local and -Wno-subobject-linkage.
tidy_args=(-p "$build" --quiet --config-file="$top/.clang-tidy"
           --checks='-*,readability-identifier-naming' --warnings-as-errors='*'
           --header-filter="^$top/(core|drivers|daemon|tools|tests|bench|fuzz|examples)/"
           --extra-arg=-Wno-unknown-warning-option)
# Our C++ units only (the C files are rosidl's generated message code), each with the
# arguments that preprocess it as its compile command does: "unit<TAB>folder<TAB>args".
mapfile -t units < <(python3 - "$build/compile_commands.json" <<'PY'
import json, shlex, sys
seen = set()
for entry in json.load(open(sys.argv[1])):
    name = entry["file"]
    if name.endswith(".c") or name in seen:
        continue
    seen.add(name)
    args = entry["arguments"] if "arguments" in entry else shlex.split(entry["command"])
    kept, skip = [], False
    for a in args[1:]:
        if skip:
            skip = False
        elif a == "-o":
            skip = True
        elif a != "-c":
            kept.append(a)
    print("\t".join([name, entry["directory"], shlex.join(kept)]))
PY
)
# The checkout's path as a sed pattern, for the keys (every character sed could read
# otherwise escaped).
# A finding as clang-tidy prints it: "FILE:LINE:COL: warning|error: ...".
finding_pattern='^/[^:]+:[0-9]+:[0-9]+: (warning|error):'
top_pattern="$(printf '%s' "$top" | sed 's/[][\\.*^$|/]/\\&/g')"
config_key="$({ "$tidy" --version; printf '%s\n' "${tidy_args[@]}"; cat "$top/.clang-tidy"; } |
              sed "s|$top_pattern|@TOP@|g" | sha256sum | cut -c1-64)"

# One unit: clang-tidy's report on stdout, or "cached <unit>" when this exact input passed
# before; non-zero when clang-tidy fails. A pass is remembered only when the preprocessing
# succeeded, so the key is the whole input.
check_unit() {
    local unit folder args key report status=0
    IFS=$'\t' read -r unit folder args <<<"$1"
    key="$(set -o pipefail; { echo "$config_key"; cd "$folder" &&
            eval "\"$clangxx\" -Wno-unknown-warning-option -E -dD -C $args"; } 2>/dev/null |
           sed "s|$top_pattern|@TOP@|g" | sha256sum | cut -c1-64)" || key=""
    if [ -n "$key" ] && [ -f "$cache/$key" ]; then echo "cached $unit"; return 0; fi
    eval "local tidy_args=($tidy_options)"
    report="$("$tidy" "${tidy_args[@]}" "$unit" 2>&1)" || status=$?
    [ -n "$report" ] && printf '%s\n' "$report"
    if [ "$status" -eq 0 ] && [ -n "$key" ] &&
        ! grep -qE "$finding_pattern" <<<"$report"; then
        touch "$cache/$key"
    fi
    return "$status"
}
tidy_options="$(printf '%q ' "${tidy_args[@]}")"
export -f check_unit
export tidy clangxx cache config_key tidy_options top_pattern finding_pattern
status=0
report="$(printf '%s\0' "${units[@]}" |
          xargs -0 -n 1 -P "$(nproc)" bash -c 'check_unit "$1"' _ 2>&1)" || status=$?
mapfile -t bad < <(grep -E "$finding_pattern" <<<"$report" | sort -u)
cached="$(grep -c '^cached ' <<<"$report" || true)"
if [ ${#bad[@]} -gt 0 ]; then
    echo "check_naming: ${#bad[@]} findings (names against .clang-tidy, or what clang itself reports):" >&2
    printf '  %s\n' "${bad[@]#"$top/"}" >&2
    exit 1
elif [ "$status" -ne 0 ]; then
    echo "check_naming: clang-tidy failed:" >&2
    echo "$report" >&2
    exit 1
fi
echo "check_naming: ${#units[@]} units follow .clang-tidy's naming rules, $cached of them unchanged since they last passed ($("$tidy" --version | grep -o 'version [0-9.]*'); cache $cache)"
