#!/bin/bash
# The dev sets as they are and with each sequence's first quarter, half and three
# quarters of the analysis' hop (2.9 ms) cut: the same sounds, falling elsewhere
# between the frames. A figure that holds on all four is not where the sounds happened
# to fall; README, "Development sets".
#
#     bash scripts/phases.sh BINARY SETS_DIR [WORK_DIR [ANALYZE_ARGS...]]
#
# SETS_DIR is made by ../shared/devsets/build.sh; the cut copies go into WORK_DIR
# (default SETS_DIR-phases; made once, by scripts/room-sets.sh trim) and each is scored
# by ../shared/devsets/run.sh with TAG=${TAG:-phases}, ANALYZE_ARGS passed on to
# `onomato analyze` (such as --threshold 0.35). Prints each one's mean F1 and speech
# line and, last, the mean F1 of the four.
set -euo pipefail
[ $# -ge 2 ] || { sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
binary=$1 sets=${2%/} work=${3:-${2%/}-phases}
shift $(($# < 3 ? $# : 3))
here=$(cd "$(dirname "$0")" && pwd)
run=$here/../../shared/devsets/run.sh
[ -x "$binary" ] || { echo "phases.sh: $binary: no such executable (cargo build --release)" >&2; exit 1; }
[ -d "$sets" ] || { echo "phases.sh: $sets: no such folder of sets (../shared/devsets/build.sh)" >&2; exit 1; }
[ -f "$run" ] || { echo "phases.sh: $run: the dev sets' scorer is not beside this checkout" >&2; exit 1; }
tag=${TAG:-phases}
folders=("$sets")
for quarter in 1 2 3; do
    # A quarter of a hop is 16 samples at 22050 Hz.
    seconds=$(awk -v q="$quarter" 'BEGIN { printf "%.7f", q * 16 / 22050 }')
    out=$work/cut$quarter
    [ -d "$out" ] || bash "$here/room-sets.sh" "$sets" "$out" trim "$seconds" > /dev/null
    folders+=("$out")
done
total=0
for folder in "${folders[@]}"; do
    TAG=$tag bash "$run" "$binary" "$folder" "$@" > "$folder/run.$tag.txt" 2>&1 ||
        { echo "phases.sh: run.sh failed on $folder (see $folder/run.$tag.txt)" >&2; exit 1; }
    mean=$(grep -E '^mean F1' "$folder/run.$tag.txt")
    echo "$(basename "$folder"): $mean | $(grep -E '^false events' "$folder/run.$tag.txt")"
    total=$(awk -v t="$total" -v m="$(echo "$mean" | awk '{print $7}')" 'BEGIN { print t + m }')
done
awk -v t="$total" 'BEGIN { printf "mean F1 over the four: %.3f\n", t / 4 }'
