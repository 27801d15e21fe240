#!/usr/bin/env bash
# Real speakers' own talking as `--background`: each recording of the development sets'
# N_speech_real (one speaker's command words, made by ../shared/devsets/build.sh) is cut
# in two halves; the second half is analysed with the set's patterns, without and with
# the first half given as `--background`, and every event there is a false one. Prints
# the events per speaker both ways and the false events a minute over all second halves.
# Needs sox and python3.
#   bash scripts/own-speech-real.sh target/release/onomato SETS_DIR OUT_DIR
set -euo pipefail
bin=${1:?usage: own-speech-real.sh ONOMATO_BIN SETS_DIR OUT_DIR}
sets=${2:?usage: own-speech-real.sh ONOMATO_BIN SETS_DIR OUT_DIR}
out=${3:?usage: own-speech-real.sh ONOMATO_BIN SETS_DIR OUT_DIR}
set_dir=$sets/N_speech_real
[[ -f $set_dir/set.json ]] || { echo "own-speech-real.sh: no $set_dir (build the sets first)" >&2; exit 1; }
mkdir -p "$out"
export SOX_OPTS="-R -D"
mapfile -t pattern_args < <(python3 - "$set_dir" <<'PY'
import json, os, sys
folder = sys.argv[1]
for label, kind in json.load(open(os.path.join(folder, "set.json")))["kinds"].items():
    suffix = ":continuous" if kind == "continuous" else ""
    print("--pattern")
    print(f"{label}={os.path.join(folder, 'patterns', label + '.wav')}{suffix}")
PY
)
count() { python3 -c 'import json, sys; print(len(json.load(sys.stdin)["events"]))'; }
echo "| recording | second half (s) | false events without | with the first half as background |"
echo "|---|---|---|---|"
total_seconds=0 total_without=0 total_with=0
for wav in "$set_dir"/seq_*.wav; do
  name=$(basename "$wav" .wav)
  half=$(python3 -c "print($(soxi -D "$wav") / 2)")
  sox "$wav" "$out/$name.first.wav" trim 0 "$half"
  sox "$wav" "$out/$name.second.wav" trim "$half"
  without=$("$bin" analyze "$out/$name.second.wav" "${pattern_args[@]}" | count)
  with=$("$bin" analyze "$out/$name.second.wav" "${pattern_args[@]}" --background "$out/$name.first.wav" | count)
  echo "| $name | $(printf '%.1f' "$half") | $without | $with |"
  total_seconds=$(python3 -c "print($total_seconds + $half)")
  total_without=$((total_without + without))
  total_with=$((total_with + with))
done
python3 -c "
m = $total_seconds / 60
print(f'| all ({m:.2f} min) | | $total_without ({$total_without / m:.2f}/min) | $total_with ({$total_with / m:.2f}/min) |')
"
