#!/usr/bin/env bash
# Rebuilds the bundled example from a synthetic voice (espeak-ng) with sox:
#   patterns/{tick,pop,boom}.wav  impulse patterns (one take each)
#   patterns/hoo.wav              a held "oooo" sung on one note, 0.63 s (continuous)
#   beat.wav                      10 s: the sounds at known times and levels, in light noise
#   beat.truth.csv                onset_s,label,end_s,gain of every sound placed in beat.wav
# Needs: espeak-ng, sox (apt-get install espeak-ng sox).
# Usage: examples/make-example.sh [OUTPUT_DIR]   (default: the folder of this script)
set -euo pipefail
# Repeatable noise, no dither: the same tools give the same bytes on every run.
export SOX_OPTS="-R -D"
out=${1:-$(dirname "$0")}
mkdir -p "$out"
cd "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rate=22050
mkdir -p patterns

# Cut leading and trailing silence, mono, 16-bit, working rate.
trim() { sox "$1" -r "$rate" -b 16 -c 1 "$2" silence 1 0.005 1% reverse silence 1 0.005 1% reverse; }

for word in tick pop boom; do
  espeak-ng -v en -w "$tmp/$word.wav" "$word"
  trim "$tmp/$word.wav" "patterns/$word.wav"
done
# A monotone voice (narrow pitch range), as a held "hoo" is sung on one note.
espeak-ng -v en -m -w "$tmp/hoo-raw.wav" '<speak><prosody range="x-low">oooooooooooo</prosody></speak>'
trim "$tmp/hoo-raw.wav" patterns/hoo.wav

# start_s label gain
timeline="0.40 tick 1.0
0.95 tick 0.5
1.50 pop 0.9
2.10 tick 0.8
2.45 boom 1.0
3.30 hoo 0.8
5.00 pop 0.6
5.45 tick 0.9
5.80 boom 0.7
6.60 tick 0.4
7.05 pop 1.0
7.60 boom 0.5
8.30 hoo 0.5"

inputs=()
echo "onset_s,label,end_s,gain" > beat.truth.csv
i=0
while read -r start label gain; do
  src="patterns/$label.wav"
  sox -v "$gain" "$src" "$tmp/part$i.wav" pad "$start"
  len=$(soxi -D "$src")
  if [ "$label" = hoo ]; then
    printf '%s,%s,%s,%s\n' "$start" "$label" "$(awk "BEGIN { printf \"%.4f\", $start + $len }")" "$gain" >> beat.truth.csv
  else
    printf '%s,%s,,%s\n' "$start" "$label" "$gain" >> beat.truth.csv
  fi
  inputs+=(-v 1 "$tmp/part$i.wav")
  i=$((i + 1))
done <<< "$timeline"
sox -n -r "$rate" -c 1 -b 16 "$tmp/noise.wav" synth 10 whitenoise vol 0.004
sox -m "${inputs[@]}" -v 1 "$tmp/noise.wav" -b 16 beat.wav trim 0 10
echo "wrote $(pwd)/beat.wav and patterns/"
