#!/usr/bin/env bash
# Rebuilds the two-soundtrack example (the paper's laser scene) from two synthetic
# voices (espeak-ng) with sox: one performer shoots, the other dodges.
#   duel/patterns/{pew,boom}.wav   the shooter's impulses (a male voice)
#   duel/patterns/hup.wav          the runner's jump (an impulse, a female voice)
#   duel/patterns/whoo.wav         the runner's slide: a held "oooo" on one note
#   duel/shots.wav, duel/moves.wav 8 s each, aligned at their start, in light noise
#   duel/{shots,moves}.truth.csv   onset_s,label,end_s,gain of every sound placed
# Render it with:  onomato render examples/duel/shots.wav --track examples/duel/moves.wav \
#                    -c config/duel.toml -o duel.mp4
# Needs: espeak-ng, sox (apt-get install espeak-ng sox).
# Usage: examples/make-duel.sh [OUTPUT_DIR]   (default: the duel folder beside this script)
set -euo pipefail
# Repeatable noise, no dither: the same tools give the same bytes on every run.
export SOX_OPTS="-R -D"
out=${1:-$(dirname "$0")/duel}
mkdir -p "$out/patterns"
cd "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rate=22050
seconds=8

# Cut leading and trailing silence, mono, 16-bit, working rate.
trim() { sox "$1" -r "$rate" -b 16 -c 1 "$2" silence 1 0.005 1% reverse silence 1 0.005 1% reverse; }

for word in pew boom; do
  espeak-ng -v en -w "$tmp/$word.wav" "$word"
  trim "$tmp/$word.wav" "patterns/$word.wav"
done
espeak-ng -v en-us+f3 -w "$tmp/hup.wav" "hup"
trim "$tmp/hup.wav" patterns/hup.wav
espeak-ng -v en-us+f3 -m -w "$tmp/whoo-raw.wav" '<speak><prosody range="x-low">oooooooooooo</prosody></speak>'
trim "$tmp/whoo-raw.wav" patterns/whoo.wav

# Places sounds ("start_s label gain" lines on stdin) in an 8 s soundtrack $1.wav with
# light noise, and writes $1.truth.csv.
place() {
  local name=$1 inputs=() i=0 start label gain len
  echo "onset_s,label,end_s,gain" > "$name.truth.csv"
  while read -r start label gain; do
    sox -v "$gain" "patterns/$label.wav" "$tmp/$name$i.wav" pad "$start"
    len=$(soxi -D "patterns/$label.wav")
    if [ "$label" = whoo ]; then
      printf '%s,%s,%s,%s\n' "$start" "$label" "$(awk "BEGIN { printf \"%.4f\", $start + $len }")" "$gain" >> "$name.truth.csv"
    else
      printf '%s,%s,,%s\n' "$start" "$label" "$gain" >> "$name.truth.csv"
    fi
    inputs+=(-v 1 "$tmp/$name$i.wav")
    i=$((i + 1))
  done
  sox -n -r "$rate" -c 1 -b 16 "$tmp/noise-$name.wav" synth "$seconds" whitenoise vol 0.004
  sox -m "${inputs[@]}" -v 1 "$tmp/noise-$name.wav" -b 16 "$name.wav" trim 0 "$seconds"
}

# The shooter: "pew" shoots low, "boom" high.
place shots <<'TIMES'
0.50 pew 1.0
1.40 boom 0.9
2.60 pew 0.7
3.50 boom 1.0
4.70 pew 1.0
5.40 pew 0.8
6.50 boom 0.8
TIMES
# The runner: jumps over each low shot and slides under each high one, in time (a shot
# reaches the runner 0.4 s after it is fired).
place moves <<'TIMES'
0.70 hup 1.0
1.50 whoo 0.9
2.80 hup 0.8
3.60 whoo 1.0
4.90 hup 1.0
5.60 hup 0.9
6.60 whoo 0.8
TIMES
echo "wrote $(pwd)/shots.wav, moves.wav and patterns/"
