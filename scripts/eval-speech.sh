#!/usr/bin/env bash
# False triggers on ordinary speech: a synthetic voice (espeak-ng) reads a paragraph;
# "tick", "pop", "pew", "boom" (impulse) and "shhh", "hooo" (continuous) are enrolled in
# the same voice; every event onomato reports on the paragraph is a false trigger.
# Prints events per minute for each method and threshold.
#   bash scripts/eval-speech.sh [THRESHOLD ...]      (needs espeak-ng and sox)
set -euo pipefail
cd "$(dirname "$0")/.."
thresholds=("$@")
[ "${#thresholds[@]}" -gt 0 ] || thresholds=(0.5 0.7 0.8 0.9)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export SOX_OPTS="-R -D"
cat > "$work/paragraph.txt" <<'TEXT'
The morning light came through the kitchen window while the kettle began to sing. She poured the water over the leaves and waited, watching the steam curl towards the ceiling. Outside, a neighbour was sweeping the path, and somewhere down the street a dog barked twice and then fell silent. It was going to be a long day, with meetings in the afternoon and a train to catch in the evening, but for now there was only the tea, the quiet, and the small sounds of a house waking up. She thought about the letter on the table, still unopened, and decided it could wait until after breakfast. The radio murmured the weather forecast: clouds in the morning, clearing by noon, and a chance of rain near the coast. Her brother had promised to call before nine, so she kept the phone close, though she knew he would probably forget again, as he always did when he was busy with the garden.
TEXT
espeak-ng -v en -w "$work/speech.wav" -f "$work/paragraph.txt"
enrol() {
  espeak-ng -v en -w "$work/$1-raw.wav" "$2"
  sox "$work/$1-raw.wav" "$work/$1.wav" silence 1 0.005 1% reverse silence 1 0.005 1% reverse
}
enrol tick tick; enrol pop pop; enrol pew pew; enrol boom boom; enrol shhh shhhhhhh; enrol hooo hoooooo
seconds=$(soxi -D "$work/speech.wav")
cargo build --release --quiet
for method in waveform spectral; do
  for t in "${thresholds[@]}"; do
    n=$(./target/release/onomato analyze "$work/speech.wav" --method "$method" --threshold "$t" --format csv \
      -p "tick=$work/tick.wav" -p "pop=$work/pop.wav" -p "pew=$work/pew.wav" -p "boom=$work/boom.wav" \
      -p "shhh=$work/shhh.wav:continuous" -p "hooo=$work/hooo.wav:continuous" | tail -n +2 | wc -l)
    awk -v m="$method" -v t="$t" -v n="$n" -v s="$seconds" \
      'BEGIN { printf "%-9s threshold %s: %3d events in %.0f s of speech = %.0f per minute\n", m, t, n, s, n * 60 / s }'
  done
done
