#!/usr/bin/env bash
# What a recording of the user's own talking, given as `--background`, does on the voice
# protocol of the development sets: for every espeak-ng voice with a D4_voice_<v> set in
# SETS_DIR (made by ../shared/devsets/build.sh or scripts/other-voices.py), that voice
# reads scripts/background/en.txt (another text than the sets' paragraph, 44 s) into
# OWN_DIR/<v>.wav; then ../shared/devsets/run.sh scores the voice's words (D4_voice_<v>)
# and its own speech (N_speech_espeak_<v>) without and with that recording, and a table
# prints each voice's F1 and false events a minute of its speech, both ways.
# Needs espeak-ng, sox and what run.sh needs.
#   bash scripts/own-speech.sh target/release/onomato SETS_DIR OWN_DIR
set -euo pipefail
bin=${1:?usage: own-speech.sh ONOMATO_BIN SETS_DIR OWN_DIR}
sets=${2:?usage: own-speech.sh ONOMATO_BIN SETS_DIR OWN_DIR}
own=${3:?usage: own-speech.sh ONOMATO_BIN SETS_DIR OWN_DIR}
here=$(cd "$(dirname "$0")" && pwd)
run=$here/../../shared/devsets/run.sh
[[ -f $run ]] || { echo "own-speech.sh: $run not found" >&2; exit 1; }
mkdir -p "$own"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
export SOX_OPTS="-R -D"
rows=()
for set in "$sets"/D4_voice_*/; do
  v=$(basename "$set"); v=${v#D4_voice_}
  [[ -d $sets/N_speech_espeak_$v ]] || continue
  # set.json's "about" names the voice: "espeak-ng VOICE: words ...".
  voice=$(sed -n 's/.*"about": "espeak-ng \([^:]*\):.*/\1/p' "$set/set.json")
  [[ -n $voice ]] || { echo "own-speech.sh: no espeak-ng voice in $set/set.json" >&2; exit 1; }
  espeak-ng -v "$voice" -s 165 -f "$here/background/en.txt" -w "$tmp/$v.wav"
  sox "$tmp/$v.wav" -r 22050 -c 1 -b 32 -e floating-point "$own/$v.wav"
  for way in without with; do
    args=()
    [[ $way == with ]] && args=(--background "$own/$v.wav")
    ONLY="D4_voice_$v,N_speech_espeak_$v" TAG="own-$way" SUMMARY="$tmp/$v.$way.json" \
      bash "$run" "$bin" "$sets" "${args[@]}" >/dev/null
  done
  rows+=("$v")
done
python3 - "$tmp" "${rows[@]}" <<'PY'
import json, sys
tmp, voices = sys.argv[1], sys.argv[2:]
def figures(v, way):
    sets = json.load(open(f"{tmp}/{v}.{way}.json"))["sets"]
    return sets[f"D4_voice_{v}"]["f1"], sets[f"N_speech_espeak_{v}"]["false_per_min"]
print("| voice | F1 without | F1 with | own speech without (/min) | with (/min) |")
print("|---|---|---|---|---|")
total = {"without": [0, 0], "with": [0, 0]}
for v in voices:
    (f0, s0), (f1, s1) = figures(v, "without"), figures(v, "with")
    total["without"][0] += f0; total["without"][1] += s0
    total["with"][0] += f1; total["with"][1] += s1
    print(f"| {v} | {f0:.3f} | {f1:.3f} | {s0:.2f} | {s1:.2f} |")
n = max(len(voices), 1)
print(f"| mean | {total['without'][0] / n:.3f} | {total['with'][0] / n:.3f} | "
      f"{total['without'][1] / n:.2f} | {total['with'][1] / n:.2f} |")
PY
