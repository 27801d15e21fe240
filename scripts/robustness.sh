#!/usr/bin/env bash
# Every protocol the detector is checked on beyond the development sets, in one table:
# the voices, takes and rooms that no setting was chosen on. Each row's sets are made
# once under WORK_DIR (a folder that is there is used as it is), scored by
# ../shared/devsets/run.sh, and printed as one Markdown row: the mean F1 over its
# positive sets, the worst of them, the mean per family, and the false events a minute
# over its speech sets.
#
#   bash ../shared/devsets/build.sh /tmp/devsets
#   bash scripts/robustness.sh target/release/onomato /tmp/devsets /tmp/robustness [ROW ...]
#
# With ROWs (the names in `rows` below), only those. The rows and what makes them:
# - voices, voices-more, exact: scripts/other-voices.py (six unheard espeak-ng voices,
#   six more, and the exact-copies protocol for their words);
# - exact-real: scripts/exact-real.py, the exact-copies protocol for the real sets'
#   own takes;
# - other-loops: scripts/other-loops.py, the beats protocol with the templates cut from
#   each other AGH loop and rsalazar recording (the dev sets' own choices included);
# - take2, take3: scripts/other-takes.py, the real sets enrolled from another take;
# - takes1-2, takes1-3: scripts/more-takes.py, the real sets enrolled from their first
#   two or three takes (scored with scripts/with-more-takes.sh), and the same folders
#   enrolled from take 1 alone (take1-of-2, take1-of-3), on the same later takes;
# - voice-takes, voices-takes, voices-more-takes: scripts/more-voice-takes.py, the
#   voice protocol of the dev sets and of both unheard folders with three takes a word;
# - noise-sweeps: scripts/noise-sweeps.py, zingerbox's noise sweep made of the other
#   kits' hits;
# - mouth, mouth-differ: scripts/mouth-sounds.py, synthetic mouth sounds (a chatter of
#   one click repeated, and one whose clicks differ);
# - knocks: scripts/knock-sounds.py, synthetic knocks on wood, marble and ceramic;
# - talk-30, talk-20: scripts/room-sets.sh ... talk, with the speech of the unheard
#   voice en+klatt (the voices row's N_speech_espeak_klatt, under WORK_DIR) as the talk;
# - every other row: scripts/room-sets.sh on the dev sets, with the arguments shown.
# Needs what build.sh, other-voices.py and room-sets.sh need (espeak-ng, sox, ffmpeg).
set -euo pipefail
usage="usage: robustness.sh ONOMATO_BIN SETS_DIR WORK_DIR [ROW ...]"
bin=${1:?$usage}
sets=${2:?$usage}
work=${3:?$usage}
shift 3
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
run=$here/../../shared/devsets/run.sh
venv=${DEVSETS_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/onomato-devsets-venv}
py=$venv/bin/python
[[ -f $run ]] || { echo "robustness.sh: $run not found" >&2; exit 1; }
[[ -x $py ]] || { echo "robustness.sh: no $py (make it: bash ../shared/devsets/build.sh DIR)" >&2; exit 1; }
[[ -d $sets/D1_isolated_agh ]] || { echo "robustness.sh: $sets holds no dev sets (bash ../shared/devsets/build.sh $sets)" >&2; exit 1; }
bin=$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")
[[ -x $bin ]] || { echo "robustness.sh: $bin is not an executable file" >&2; exit 1; }
mkdir -p "$work"

# name|what it is|how it is made|folder|scored through
rows=(
  "voices|six espeak-ng voices that no set, test or background speech uses: their words, rhythm and own speech|other-voices.py|voices|plain"
  "voices-more|six further voices|other-voices.py --more|voices-more|plain"
  "exact|exact copies of those twelve voices' words (the protocol of D5_exact)|other-voices.py --exact|exact|plain"
  "exact-real|exact copies of the real sets' own takes, bleed and room included (the protocol of D5_exact)|exact-real.py|exact-real|plain"
  "other-loops|the real beats enrolled from each other loop: AGH's five starts, rsalazar's rec2, rec3 and rec4 (the dev sets' own among them)|other-loops.py|other-loops|plain"
  "take2|the real sets enrolled from each label's second take|other-takes.py 1|take2|plain"
  "take3|... from its third take|other-takes.py 2|take3|plain"
  "take1-of-2|the real sets, take 1 alone enrolling, scored on the takes after the second|more-takes.py 2, take 1 alone|takes2|plain"
  "takes1-2|... takes 1 and 2 enrolling, on the same takes|more-takes.py 2|takes2|takes"
  "take1-of-3|the real sets, take 1 alone enrolling, scored on the takes after the third|more-takes.py 3, take 1 alone|takes3|plain"
  "takes1-3|... takes 1 to 3 enrolling, on the same takes|more-takes.py 3|takes3|takes"
  "voice-takes|the dev sets' voices, three takes of each word (at 145, 160 and 175 words a minute)|more-voice-takes.py, the dev voices|voice-takes|takes"
  "voices-takes|the six unheard voices, the same|more-voice-takes.py, voices|voices-takes|takes"
  "voices-more-takes|the six further voices, the same|more-voice-takes.py, voices-more|voices-more-takes|takes"
  "noise-sweeps|the noise sweep of D1_noise_zingerbox (-60 to -35 dB), made of the AGH and both mitrank kits' hits|noise-sweeps.py|noise-sweeps|plain"
  "mouth|synthetic mouth sounds: a tongue click, a cheek pop, a lip smack and a teeth chatter of one click repeated 45 ms apart, each instance's resonances up to 7 % off its take's|mouth-sounds.py|mouth|plain"
  "mouth-differ|... the chatter's clicks each of its own resonances (no sound repeated)|mouth-sounds.py --chatter-clicks-differ|mouth-differ|plain"
  "knocks|synthetic knocks on wood, marble and ceramic (struck plates; the ceramic rings 0.4 s), in the protocol of D6_knocks: rhythms at 150 bpm and eighths at 200 bpm included|knock-sounds.py|knocks|plain"
  "room-0.47s|a room of RT60 0.47 s (an office), takes and sequences|reverb 25|room25|plain"
  "room-1.32s|a room of RT60 1.32 s (bare, hard walls)|reverb 50|room50|plain"
  "room-0.47s-dry-takes|enrolled dry, performed in the 0.47 s room|reverb 25 100 sequences|room25s|plain"
  "room-1.32s-dry-takes|enrolled dry, performed in the 1.32 s room|reverb 50 100 sequences|room50s|plain"
  "louder-room|pink noise 28 dB under full scale, from 2 s into each sequence on (a fan switched on while the performer goes on; enrolled in quiet)|louder pinknoise -28 2|louder28|plain"
  "much-louder-room|... 22 dB under full scale|louder pinknoise -22 2|louder22|plain"
  "brown|brown noise (rumble) 30 dB under full scale|noise brownnoise -30|brown|plain"
  "pink|pink noise 40 dB under full scale|noise pinknoise -40|pink|plain"
  "pink-takes|enrolled in that pink noise, performed in quiet (the takes alone noisy)|noise pinknoise -40 takes|pink-takes|plain"
  "hum-50|mains buzz at 50 Hz and its harmonics, 40 dB down|hum 50 -40|hum50|plain"
  "hum-60|... at 60 Hz|hum 60 -40|hum60|plain"
  "gate|through a noise gate 10 dB over the room, held 0.1 s|gate 10|gate10|plain"
  "mp3-64|decoded from MP3 at 64 kbit/s|mp3 64|mp3-64|plain"
  "mp3-32|... at 32 kbit/s (a voice call)|mp3 32|mp3-32|plain"
  "quieter|the sequences 15 dB quieter than the takes (performed further from the microphone than enrolled)|gain -15 sequences|gain-15s|plain"
  "louder|the sequences 12 dB louder than the takes, clipped at full scale (performed closer than enrolled, an input gain set too high)|gain 12 sequences|gain12s|plain"
  "higher|the sequences a semitone higher than the takes (a voice that sits higher than when it enrolled)|pitch 100|pitch100|plain"
  "lower|... a semitone lower|pitch -100|pitch-100|plain"
  "silence|0.5 s of digital silence before each sequence|silence 0.5|silence|plain"
  "head|each sequence cut 2 ms before its first sound|head 0.002|head|plain"
  "rate-16k|every file at 16 kHz (a headset)|rate 16000|rate16k|plain"
  "rate-8k|every file at 8 kHz (a telephone)|rate 8000|rate8k|plain"
  "lowpass|every file low-passed at 6.3 kHz, at its own rate|lowpass 6300|lowpass|plain"
  "lowpass-seq|the sequences alone low-passed so (takes from a good microphone)|lowpass 6300 sequences|lowpass-seq|plain"
  "highpass|every file through a 2-pole high-pass at 300 Hz (a thin microphone: a laptop's, a phone's, a voice call's)|highpass 300|highpass|plain"
  "highpass-seq|the sequences alone high-passed so (enrolled through a full microphone)|highpass 300 sequences|highpass-seq|plain"
  "talk-30|someone else talking 30 dB under the sequences' peaks (an unheard voice reading; enrolled in quiet)|talk voices/N_speech_espeak_klatt/seq_00.wav -30|talk30|plain"
  "talk-20|... 20 dB under them|talk voices/N_speech_espeak_klatt/seq_00.wav -20|talk20|plain"
  "compress-2|through a gentle compressor, 2:1 over -20 dB, full scale kept (a voice chain's)|compress 2 -20|compress2|plain"
  "compress-4|... 4:1 over -30 dB (a streaming chain's)|compress 4 -30|compress4|plain"
  "compress-4-seq|the sequences alone so (enrolled without it)|compress 4 -30 sequences|compress4s|plain"
  "agc|... 8:1 over -40 dB, the room's noise 35 dB up (an automatic gain control's levelling)|compress 8 -40|compress8|plain"
)

make_folder() {  # name how folder
  local name=$1 how=$2 out=$work/$3
  [[ -d $out ]] && return 0
  echo "robustness.sh: making $out ($how)" >&2
  case $name in
    voices) "$py" "$here/other-voices.py" "$out" ;;
    voices-more) "$py" "$here/other-voices.py" --more "$out" ;;
    exact) "$py" "$here/other-voices.py" --exact "$out" ;;
    exact-real) "$py" "$here/exact-real.py" "$sets" "$out" ;;
    other-loops) "$py" "$here/other-loops.py" "$out" ;;
    take2) "$py" "$here/other-takes.py" 1 "$out" ;;
    take3) "$py" "$here/other-takes.py" 2 "$out" ;;
    take1-of-2 | takes1-2) "$py" "$here/more-takes.py" 2 "$out" ;;
    take1-of-3 | takes1-3) "$py" "$here/more-takes.py" 3 "$out" ;;
    voice-takes) "$py" "$here/more-voice-takes.py" "$sets" "$out" ;;
    voices-takes)
      make_folder voices other-voices.py voices
      "$py" "$here/more-voice-takes.py" "$work/voices" "$out"
      ;;
    voices-more-takes)
      make_folder voices-more "other-voices.py --more" voices-more
      "$py" "$here/more-voice-takes.py" "$work/voices-more" "$out"
      ;;
    noise-sweeps) "$py" "$here/noise-sweeps.py" "$out" ;;
    mouth) "$py" "$here/mouth-sounds.py" "$out" ;;
    mouth-differ) "$py" "$here/mouth-sounds.py" "$out" --chatter-clicks-differ ;;
    knocks) "$py" "$here/knock-sounds.py" "$out" ;;
    talk-30 | talk-20)
      make_folder voices other-voices.py voices
      # shellcheck disable=SC2206  # talk FILE (under WORK_DIR) LEVEL_DB, word by word
      local talk=($how)
      bash "$here/room-sets.sh" "$sets" "$out" talk "$work/${talk[1]}" "${talk[2]}" >/dev/null
      ;;
    *)
      # shellcheck disable=SC2086  # the room's arguments, word by word
      bash "$here/room-sets.sh" "$sets" "$out" $how >/dev/null
      ;;
  esac >&2
}

row() {  # name what how folder scoring
  local name=$1 what=$2 how=$3 folder=$work/$4 scoring=$5 summary=$work/$1.summary.json
  make_folder "$name" "$how" "$4"
  local binary=$bin
  if [[ $scoring == takes ]]; then
    binary=$here/with-more-takes.sh
    export ONOMATO=$bin
  fi
  TAG=robustness SUMMARY=$summary bash "$run" "$binary" "$folder" >/dev/null
  python3 - "$what" "$how" "$summary" <<'EOF'
import json, sys
what, how, path = sys.argv[1:]
s = json.load(open(path))
positive = {k: v for k, v in s["sets"].items() if v.get("f1") is not None}
worst = min(positive.items(), key=lambda kv: kv[1]["f1"]) if positive else None
families = " / ".join(f"{f} {v:.3f}" for f, v in s["mean_f1_by_family"].items())
f1 = s["mean_f1_positive"]
speech = s.get("false_per_min_negative")
script = how if how.split()[0].rstrip(",").endswith(".py") else f"room-sets.sh ... {how}"
made = f"`{script.split(',')[0]}`" + ("," + script.split(",", 1)[1] if "," in script else "")
print(f"| {what} | {made} | {f1:.3f} | " + (f"{worst[1]['f1']:.3f} ({worst[0]})" if worst else "-")
      + f" | {families} | " + (f"{speech:.2f}" if s.get("negative_sets") else "-") + " |")
EOF
}

wanted=("$@")
for w in "${wanted[@]}"; do
  known=0
  for r in "${rows[@]}"; do [[ ${r%%|*} == "$w" ]] && known=1; done
  [[ $known == 1 ]] || { echo "robustness.sh: no row '$w'; the rows: $(printf '%s ' "${rows[@]%%|*}")" >&2; exit 2; }
done
echo "| protocol | made by | mean F1 | worst set | per family | speech (false events a minute) |"
echo "|---|---|---|---|---|---|"
for r in "${rows[@]}"; do
  IFS='|' read -r name what how folder scoring <<<"$r"
  if [[ ${#wanted[@]} -gt 0 ]]; then
    keep=0
    for w in "${wanted[@]}"; do [[ $w == "$name" ]] && keep=1; done
    [[ $keep == 1 ]] || continue
  fi
  row "$name" "$what" "$how" "$folder" "$scoring"
done
