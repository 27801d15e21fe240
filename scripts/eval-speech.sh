#!/usr/bin/env bash
# False triggers on ordinary speech: a synthetic voice (espeak-ng) reads a paragraph;
# "tick", "pop", "pew", "boom" (impulse) and "shhh", "hooo" (continuous) are enrolled in
# the same voice; every event onomato reports on the paragraph is a false trigger.
# The paragraph is tests/data/speech-paragraph.txt, which tests/voices.rs also reads.
# Prints events per minute for each method and threshold (spectral: with the default
# speech guard, and without it).
#   bash scripts/eval-speech.sh [THRESHOLD ...]      (needs espeak-ng and sox)
set -euo pipefail
cd "$(dirname "$0")/.."
thresholds=("$@")
[ "${#thresholds[@]}" -gt 0 ] || thresholds=(0.5 0.7 0.8 0.9)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export SOX_OPTS="-R -D"
espeak-ng -v en -w "$work/speech.wav" -f tests/data/speech-paragraph.txt
enrol() {
  espeak-ng -v en -w "$work/$1-raw.wav" "$2"
  sox "$work/$1-raw.wav" "$work/$1.wav" silence 1 0.005 1% reverse silence 1 0.005 1% reverse
}
enrol tick tick; enrol pop pop; enrol pew pew; enrol boom boom; enrol shhh shhhhhhh; enrol hooo hoooooo
seconds=$(soxi -D "$work/speech.wav")
cargo build --release --quiet
for variant in waveform spectral "spectral --speech-guard 0"; do
  for t in "${thresholds[@]}"; do
    # shellcheck disable=SC2086 # the variant's extra flags split on purpose
    n=$(./target/release/onomato analyze "$work/speech.wav" --method $variant --threshold "$t" --format csv \
      -p "tick=$work/tick.wav" -p "pop=$work/pop.wav" -p "pew=$work/pew.wav" -p "boom=$work/boom.wav" \
      -p "shhh=$work/shhh.wav:continuous" -p "hooo=$work/hooo.wav:continuous" | tail -n +2 | wc -l)
    awk -v m="$variant" -v t="$t" -v n="$n" -v s="$seconds" \
      'BEGIN { printf "%-26s threshold %s: %3d events in %.1f s of speech = %.1f per minute\n", m, t, n, s, n * 60 / s }'
  done
done
