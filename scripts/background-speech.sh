#!/usr/bin/env bash
# Synthesises the speech of the built-in background model (src/detect/background.rs):
# the English text of scripts/background/en.txt read by 36 espeak-ng voices, and a
# sentence each in German, French and Spanish. None is a voice of the development sets
# (en+m1, en+m2, en+m7, en-us+f3, en-gb-x-rp+f1), of scripts/other-voices.py, or the
# plain voice the tests speak with.
# Writes mono 32-bit float WAVs at the working rate, 22.05 kHz, into OUT_DIR; then
#   cargo run --release --example background_model -- OUT_DIR src/detect/background.bin
# Needs espeak-ng and sox.
#   bash scripts/background-speech.sh OUT_DIR
set -euo pipefail
out=${1:?usage: background-speech.sh OUT_DIR}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export SOX_OPTS="-R -D"
speak() { # NAME VOICE TEXT_FILE
  espeak-ng -v "$2" -s 165 -f "$3" -w "$tmp/$1.wav"
  sox "$tmp/$1.wav" -r 22050 -c 1 -b 32 -e floating-point "$out/$1.wav"
}
i=0
for voice in en+f2 en+f4 en+m3 en+m5 en-us+m4 en+klatt3 en+Andy en+Annie \
  en-gb-scotland+m6 en-029+f5 en+grandma en+Storm en+adam en+Alex en+boris en+caleb \
  en+john en+max en+michel en+norbert en+travis en+victor en+belinda en+Alicia \
  en+Andrea en-us+Benjamin en+Denis en-029+Gene en-us+Hugo en+Iven \
  en-gb-scotland+Lee en-us+Michael en+Mike en-029+Paul en+Quincy en-us+Rob; do
  speak "en_$i" "$voice" "$here/background/en.txt"
  i=$((i + 1))
done
speak de de "$here/background/de.txt"
speak fr fr+m2 "$here/background/fr.txt"
speak es es+f3 "$here/background/es.txt"
