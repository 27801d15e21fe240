#!/bin/bash
# Copies of sets in the dev sets' format (../shared/devsets/README.md) heard in another
# room: every WAV, the enrolment takes with the sequences (the performer enrols and
# performs in the same room), every truth file as it is. A check that the detector
# holds up in rooms that no dev set has.
#
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR reverb [REVERBERANCE [ROOM_SCALE [sequences]]]
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR noise TYPE LEVEL_DB [sequences|takes]
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR hum FREQUENCY LEVEL_DB
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR rate RATE [sequences]
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR lowpass HZ [sequences]
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR highpass HZ [sequences]
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR gain DB [sequences]
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR pitch CENTS
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR dc OFFSET
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR mp3 KBITS [sequences]
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR silence SECONDS
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR trim SECONDS
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR head SECONDS
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR gate OVER_DB [HOLD_SECONDS]
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR talk FILE LEVEL_DB
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR compress RATIO THRESHOLD_DB [sequences]
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR louder TYPE LEVEL_DB AT_SECONDS
#     bash ../shared/devsets/run.sh target/release/onomato OUT_DIR
#
# reverb: sox's reverb, REVERBERANCE and ROOM_SCALE its percentages (default 50, 100);
# with `sequences`, the sequences alone, the takes only as much quieter as the chain
# makes the sequences (enrolled close to the microphone, performed in the room).
# noise: sox's TYPE (whitenoise, pinknoise, brownnoise) at LEVEL_DB (its peaks that
# far under full scale) added to each file; `sequences` as for reverb (enrolled in a
# quiet room); `takes`, the takes alone (enrolled in a noisy room, performed in a quiet
# one).
# hum: mains buzz (a ground loop, a lamp's dimmer) of FREQUENCY Hz and its harmonics up
# to the 8th, the k-th at 1/k of the fundamental (a sawtooth's spectrum), its peaks
# LEVEL_DB under full scale, added to each file.
# rate: each file resampled to RATE Hz, 16-bit (an input that carries less: a headset at
# 16 kHz); with `sequences`, the sequences alone, the takes left as they were recorded
# (enrolled through one microphone, heard through another).
# lowpass: each file low-passed at HZ, at its own rate, 16-bit (a narrow source
# resampled to a full rate on its way in); `sequences` as for rate.
# highpass: each file through a 2-pole high-pass at HZ (12 dB an octave under it, sox's
# highpass), 16-bit: a small microphone's thin bass, a low-cut switch, a voice call's
# filter; `sequences` as for rate (enrolled through a full microphone, performed
# through a thin one).
# gain: each file DB louder (or quieter, negative), 16-bit: what passes full scale clips
# (an input gain set too high); with `sequences`, the sequences alone, the takes as they
# were (enrolled close to the microphone, performed further from it, or the other way).
# pitch: the sequences CENTS higher (lower, negative), their timing kept (sox's pitch),
# the takes as they were: a performer whose voice sits higher or lower than when they
# enrolled. sox's pitch moves each sound by a few milliseconds, which the truth does not
# follow (well within the 50 ms the scoring allows).
# dc: every file OFFSET (of full scale) higher, 16-bit or as it was: a microphone's or
# a converter's DC offset; what passes full scale clips.
# mp3: every file through an MP3 encoder at KBITS kbit/s and back (ffmpeg, LAME; a
# recording shared or streamed in a lossy format), 16-bit, gapless, so the truth holds;
# `sequences` as for rate (a short take encoded alone loses its start to the encoder).
# silence: each sequence begins after SECONDS of digital silence (a recording exported
# with silence before it, a microphone that delivers zeros until it starts), its truth
# moved as far; the takes as they were.
# trim: each sequence's first SECONDS cut, its truth moved as far earlier, the takes as
# they were: the same sounds, falling elsewhere between the analysis' frames (a
# fraction of a hop, 2.9 ms, tells how much of a set's figure is where its sounds
# fall).
# head: each sequence cut SECONDS before its first annotated sound (a recording trimmed
# to its first sound; 0.002 leaves 2 ms of room), its truth moved as far earlier, the
# takes as they were.
# gate: a noise gate on every file, as a live performer or a streamer sets one before
# the detector: in 5 ms blocks, open from the first block whose RMS stands OVER_DB over
# the set's room (the 10th percentile block of its sequences, digital silence left out;
# the takes go through the same gate) until HOLD_SECONDS (default 0.1) after the last
# such block, digital silence while closed; no look-ahead, so a sound's soft start under
# the threshold is cut, as a gate cuts it.
# talk: the recording FILE (someone else talking: a television, a colleague) under each
# sequence, from its start, repeated as long as the sequence, its peaks LEVEL_DB under
# the sequence's own peak (a set recorded quietly hears the talk as quietly), mixed at
# equal weight as the noise is; the takes as they were (enrolled in quiet). The speech
# sets get it too, so their false events count what the talk fires.
# compress: a compressor on every file, as a streaming chain, a voice-call app or a
# laptop's input sets one before the detector (sox's compand: 5 ms attack, 100 ms
# release, a 6 dB soft knee, no look-ahead): over THRESHOLD_DB each decibel in gives
# 1/RATIO out, and the output is raised so that full scale stays full scale, which
# raises the room's noise and the sounds' tails as much; it starts settled on a quiet
# input (a compressor that has run before the stream begins: sox's default, settled on
# full scale, would make each file's room swell by the make-up gain over its first
# 0.4 s); `sequences` as for rate.
# louder: sox's TYPE noise at LEVEL_DB (as for noise) added to each sequence from
# AT_SECONDS on, faded in over 0.3 s (a fan switched on, a window opened on a street:
# a room that gets louder for good while the performer goes on); the takes as they were.
# All repeatable (sox -R).
set -euo pipefail
usage() {
    sed -n '2,/^# All repeatable/p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
}
[ $# -ge 3 ] || usage
src=$1 out=$2 kind=$3
shift 3
case $kind in
    reverb)
        [ $# -le 3 ] || usage
        reverberance=${1:-50} room_scale=${2:-100} which=${3:-all}
        case $which in
            all | sequences) ;;
            *) echo "room-sets.sh: reverb $reverberance $room_scale $which: expected nothing or 'sequences' after the room scale" >&2; exit 2 ;;
        esac
        # 4 dB down first so that the tail added to the loudest hits does not clip;
        # 50 % HF damping and no pre-delay are sox's defaults. The files and the
        # impulse measured below go through this one chain.
        chain=(gain -4 reverb "$reverberance" 50 "$room_scale")
        ;;
    noise)
        [ $# -ge 2 ] && [ $# -le 3 ] || usage
        noise_type=$1 level_db=$2 which=${3:-all}
        case $which in
            all | sequences | takes) ;;
            *) echo "room-sets.sh: noise $noise_type $level_db $which: expected nothing, 'sequences' or 'takes' after the level" >&2; exit 2 ;;
        esac
        case $noise_type in
            whitenoise | pinknoise | brownnoise) ;;
            *) echo "room-sets.sh: noise type $noise_type: expected whitenoise, pinknoise or brownnoise" >&2; exit 2 ;;
        esac
        added="$noise_type, peaks $level_db dB"
        [ "$which" = all ] || added="$added, the $which alone"
        ;;
    hum)
        [ $# -eq 2 ] || usage
        hum_hz=$1 level_db=$2
        case $hum_hz in
            50 | 60) ;;
            *) echo "room-sets.sh: hum frequency $hum_hz: expected 50 or 60 (Hz)" >&2; exit 2 ;;
        esac
        sines=() weights=()
        # Each harmonic a third of 1/k, so that their sum cannot clip before `gain -n`
        # sets the buzz's peaks.
        for k in 1 2 3 4 5 6 7 8; do
            sines+=(sine $((hum_hz * k)))
            weights+=("${k}v$(awk -v k="$k" 'BEGIN { printf "%.4f", 1 / (3 * k) }')")
        done
        mix=$(IFS=,; echo "${weights[*]}")
        added="$hum_hz Hz hum and 7 harmonics, peaks $level_db dB"
        ;;
    rate | lowpass | highpass)
        [ $# -ge 1 ] && [ $# -le 2 ] || usage
        hz=$1 which=${2:-all}
        if [ "$kind" = rate ]; then
            expected="a sample rate in Hz, such as 16000" after="the rate" made="at $hz Hz"
        elif [ "$kind" = lowpass ]; then
            expected="a frequency in Hz, such as 6300" after="the frequency" made="low-passed at $hz Hz"
        else
            expected="a frequency in Hz, such as 300" after="the frequency" made="high-passed at $hz Hz"
        fi
        case $hz in
            '' | *[!0-9]*) echo "room-sets.sh: $kind $hz: expected $expected" >&2; exit 2 ;;
        esac
        case $which in
            all) added="every file $made" ;;
            sequences) added="the sequences $made, the takes as they were" ;;
            *) echo "room-sets.sh: $kind $hz $which: expected nothing or 'sequences' after $after" >&2; exit 2 ;;
        esac
        ;;
    gain)
        [ $# -ge 1 ] && [ $# -le 2 ] || usage
        gain_db=$1 which=${2:-all}
        [[ $gain_db =~ ^-?[0-9]+(\.[0-9]+)?$ ]] || { echo "room-sets.sh: gain $gain_db: expected decibels, such as 12 or -30" >&2; exit 2; }
        case $which in
            all) added="every file at $gain_db dB, clipped at full scale" ;;
            sequences) added="the sequences at $gain_db dB, clipped at full scale, the takes as they were" ;;
            *) echo "room-sets.sh: gain $gain_db $which: expected nothing or 'sequences' after the gain" >&2; exit 2 ;;
        esac
        ;;
    pitch)
        [ $# -eq 1 ] || usage
        cents=$1 which=sequences
        [[ $cents =~ ^-?[0-9]+$ ]] || { echo "room-sets.sh: pitch $cents: expected cents, such as 200 or -100" >&2; exit 2; }
        added="the sequences $cents cents higher, the takes as they were"
        ;;
    dc)
        [ $# -eq 1 ] || usage
        offset=$1
        [[ $offset =~ ^-?0?\.[0-9]+$ ]] || { echo "room-sets.sh: dc $offset: expected a fraction of full scale, such as 0.01" >&2; exit 2; }
        added="every file $offset of full scale higher (a DC offset)"
        ;;
    mp3)
        [ $# -ge 1 ] && [ $# -le 2 ] || usage
        kbits=$1 which=${2:-all}
        [[ $kbits =~ ^[0-9]+$ ]] || { echo "room-sets.sh: mp3 $kbits: expected kbit/s, such as 64" >&2; exit 2; }
        command -v ffmpeg > /dev/null || { echo "room-sets.sh: mp3 needs ffmpeg (apt install ffmpeg)" >&2; exit 1; }
        case $which in
            all) added="every file through MP3 at $kbits kbit/s and back" ;;
            sequences) added="the sequences through MP3 at $kbits kbit/s and back, the takes as they were" ;;
            *) echo "room-sets.sh: mp3 $kbits $which: expected nothing or 'sequences' after the bit rate" >&2; exit 2 ;;
        esac
        ;;
    silence | trim | head)
        [ $# -eq 1 ] || usage
        seconds=$1
        [[ $seconds =~ ^[0-9]+(\.[0-9]+)?$ ]] || { echo "room-sets.sh: $kind $seconds: expected seconds, such as 0.5" >&2; exit 2; }
        which=sequences
        if [ "$kind" = silence ]; then
            lead=$seconds
            added="the sequences after $seconds s of digital silence, the takes as they were"
        elif [ "$kind" = head ]; then
            added="each sequence cut $seconds s before its first sound, the takes as they were"
        else
            lead=-$seconds
            added="the sequences' first $seconds s cut, the takes as they were"
        fi
        ;;
    gate)
        [ $# -ge 1 ] && [ $# -le 2 ] || usage
        over_db=$1 hold=${2:-0.1}
        [[ $over_db =~ ^[0-9]+(\.[0-9]+)?$ ]] || { echo "room-sets.sh: gate $over_db: expected decibels over the room, such as 10" >&2; exit 2; }
        [[ $hold =~ ^[0-9]+(\.[0-9]+)?$ ]] || { echo "room-sets.sh: gate $over_db $hold: expected the hold in seconds, such as 0.1" >&2; exit 2; }
        added="every file through a noise gate $over_db dB over its room, held $hold s"
        ;;
    talk)
        [ $# -eq 2 ] || usage
        talk_file=$1 level_db=$2 which=sequences
        [ -f "$talk_file" ] || { echo "room-sets.sh: talk $talk_file: no such recording" >&2; exit 2; }
        talk_seconds=$(soxi -D "$talk_file" 2> /dev/null) || { echo "room-sets.sh: talk $talk_file: not a recording sox can read" >&2; exit 2; }
        awk -v d="$talk_seconds" 'BEGIN { exit !(d > 0) }' || { echo "room-sets.sh: talk $talk_file: expected some sound, found $talk_seconds s" >&2; exit 2; }
        [[ $level_db =~ ^-[0-9]+(\.[0-9]+)?$ ]] || { echo "room-sets.sh: talk $talk_file $level_db: expected decibels under the sequence's peak, such as -20" >&2; exit 2; }
        added="$(basename "$talk_file") under the sequences, its peaks $level_db dB under theirs, the takes as they were"
        ;;
    compress)
        [ $# -ge 2 ] && [ $# -le 3 ] || usage
        ratio=$1 threshold_db=$2 which=${3:-all}
        [[ $ratio =~ ^[0-9]+(\.[0-9]+)?$ ]] && awk -v r="$ratio" 'BEGIN { exit !(r >= 1) }' \
            || { echo "room-sets.sh: compress $ratio: expected a ratio of at least 1, such as 4" >&2; exit 2; }
        [[ $threshold_db =~ ^-[0-9]+(\.[0-9]+)?$ ]] || { echo "room-sets.sh: compress $ratio $threshold_db: expected a threshold in decibels under full scale, such as -30" >&2; exit 2; }
        case $which in
            all) added="every file through a $ratio:1 compressor over $threshold_db dB, full scale kept" ;;
            sequences) added="the sequences through a $ratio:1 compressor over $threshold_db dB, full scale kept, the takes as they were" ;;
            *) echo "room-sets.sh: compress $ratio $threshold_db $which: expected nothing or 'sequences' after the threshold" >&2; exit 2 ;;
        esac
        # Full scale in comes out at threshold * (1 - 1/ratio); the make-up gain lifts it back.
        makeup_db=$(awk -v r="$ratio" -v t="$threshold_db" 'BEGIN { printf "%.3f", -t * (1 - 1 / r) }')
        compand=(compand 0.005,0.1 "6:-120,-120,$threshold_db,$threshold_db,0,-$makeup_db" "$makeup_db" -120)
        ;;
    louder)
        [ $# -eq 3 ] || usage
        noise_type=$1 level_db=$2 at=$3 which=sequences
        case $noise_type in
            whitenoise | pinknoise | brownnoise) ;;
            *) echo "room-sets.sh: louder $noise_type: expected whitenoise, pinknoise or brownnoise" >&2; exit 2 ;;
        esac
        [[ $level_db =~ ^-[0-9]+(\.[0-9]+)?$ ]] || { echo "room-sets.sh: louder $noise_type $level_db: expected decibels under full scale, such as -28" >&2; exit 2; }
        [[ $at =~ ^[0-9]+(\.[0-9]+)?$ ]] || { echo "room-sets.sh: louder $noise_type $level_db $at: expected the seconds into each sequence where the noise begins, such as 2" >&2; exit 2; }
        added="$noise_type, peaks $level_db dB, from $at s into each sequence, the takes as they were"
        ;;
    *) echo "room-sets.sh: room kind $kind: expected reverb, noise, hum, rate, lowpass, highpass, gain, pitch, dc, mp3, silence, trim, head, gate, talk, compress or louder" >&2; exit 2 ;;
esac
command -v sox > /dev/null || { echo "room-sets.sh: sox is needed (apt install sox)" >&2; exit 1; }
[ -d "$src" ] || { echo "room-sets.sh: $src: no such folder of sets" >&2; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
if [ "$kind" = gate ]; then
    # The gate's two steps over raw 32-bit float samples, in 5 ms blocks:
    #   room OVER_DB RAW:RATE...           the threshold, OVER_DB over the 10th percentile block
    #   gate IN OUT RATE THRESHOLD_DB HOLD the samples through the gate
    cat > "$tmp/gate.py" <<'PY'
import array, math, sys


def samples(raw):
    x = array.array("f")
    with open(raw, "rb") as f:
        x.frombytes(f.read())
    return x


def blocks(x, rate):
    """(start, end, level dB or None for digital silence) of each 5 ms block."""
    block = max(1, round(0.005 * rate))
    for at in range(0, len(x), block):
        chunk = x[at:at + block]
        power = sum(v * v for v in chunk) / len(chunk)
        yield at, at + len(chunk), 10 * math.log10(power) if power > 0 else None


if sys.argv[1] == "room":
    levels = sorted(level for arg in sys.argv[3:] for raw, rate in [arg.rsplit(":", 1)]
                    for _, _, level in blocks(samples(raw), int(rate)) if level is not None)
    print(f"{levels[len(levels) // 10] + float(sys.argv[2]):.2f}" if levels else "0")
else:
    src, dst, rate, threshold_db, hold = sys.argv[2:7]
    x = samples(src)
    hold_blocks, left = round(float(hold) / 0.005), 0
    for start, end, level in list(blocks(x, int(rate))):
        if level is not None and level >= float(threshold_db):
            left = hold_blocks + 1
        if left == 0:
            x[start:end] = array.array("f", bytes(4 * (end - start)))
        else:
            left -= 1
    with open(dst, "wb") as f:
        x.tofile(f)
PY
fi
count=0
for set in "$src"/*/; do
    set=${set%/}
    [ -f "$set/set.json" ] || continue
    name=$(basename "$set")
    mkdir -p "$out/$name/patterns"
    cp "$set/set.json" "$out/$name/"
    for csv in "$set"/seq_*.csv; do
        if [ "$kind" = silence ] || [ "$kind" = trim ] || [ "$kind" = head ]; then
            # Every time in the truth (onset_s, end_s) later by the silence, earlier by
            # the cut; head cuts where the first sound begins less SECONDS, on a whole
            # sample, and prints the samples cut (for sox).
            rate=$(soxi -r "${csv%.csv}.wav" 2> /dev/null)
            python3 - "$csv" "$out/$name/$(basename "$csv")" "$kind" "${lead:-$seconds}" "$rate" \
                > "$tmp/$name-$(basename "$csv" .csv).cut" <<'PY'
import csv, sys
src, dst, kind, seconds, rate = sys.argv[1:3] + [sys.argv[3], float(sys.argv[4]), int(sys.argv[5])]
with open(src, newline="") as f:
    reader = csv.DictReader(f)
    rows, fields = list(reader), reader.fieldnames
if kind == "head":
    first = min((float(r["onset_s"]) for r in rows), default=seconds)
    cut = max(0, round((first - seconds) * rate))
    shift = -cut / rate
    print(cut)
else:
    shift = seconds
for row in rows:
    for key in ("onset_s", "end_s"):
        if row.get(key):
            row[key] = f"{float(row[key]) + shift:.4f}"
with open(dst, "w", newline="") as f:
    writer = csv.DictWriter(f, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
PY
        else
            cp "$csv" "$out/$name/"
        fi
    done
    if [ "$kind" = gate ]; then
        # The set's room: the 10th percentile of its sequences' 5 ms blocks.
        raws=()
        for wav in "$set"/seq_*.wav; do
            raw=$tmp/$(basename "$wav" .wav).f32
            sox -R -V1 "$wav" -t f32 -c 1 "$raw"
            raws+=("$raw:$(soxi -r "$wav" 2> /dev/null)")
        done
        threshold_db=$(python3 "$tmp/gate.py" room "$over_db" "${raws[@]}")
        rm -f "$tmp"/seq_*.f32
    fi
    for wav in "$set"/seq_*.wav "$set"/patterns/*.wav; do
        rel=${wav#"$set"/}
        if [ "${which:-all}" = takes ] && [ "${rel#patterns/}" = "$rel" ]; then
            cp "$wav" "$out/$name/$rel"
        elif [ "${which:-all}" = sequences ] && [ "${rel#patterns/}" != "$rel" ]; then
            if [ "$kind" = reverb ]; then
                sox -R -V1 "$wav" "$out/$name/$rel" "${chain[@]:0:2}"
            else
                cp "$wav" "$out/$name/$rel"
            fi
        elif [ "$kind" = reverb ]; then
            sox -R -V1 "$wav" "$out/$name/$rel" "${chain[@]}"
        elif [ "$kind" = mp3 ]; then
            ffmpeg -loglevel error -y -i "$wav" -c:a libmp3lame -b:a "${kbits}k" "$tmp/coded.mp3"
            ffmpeg -loglevel error -y -i "$tmp/coded.mp3" -ac 1 -c:a pcm_s16le "$out/$name/$rel"
        elif [ "$kind" = compress ]; then
            sox -R -V1 "$wav" "$out/$name/$rel" "${compand[@]}"
        elif [ "$kind" = pitch ]; then
            sox -R -V1 "$wav" "$out/$name/$rel" pitch "$cents"
        elif [ "$kind" = dc ]; then
            sox -R -V1 "$wav" "$out/$name/$rel" dcshift "$offset"
        elif [ "$kind" = gain ]; then
            sox -R -V1 "$wav" -b 16 "$out/$name/$rel" gain "$gain_db"
        elif [ "$kind" = lowpass ]; then
            sox -R -V1 "$wav" -b 16 "$out/$name/$rel" sinc -"$hz"
        elif [ "$kind" = highpass ]; then
            sox -R -V1 "$wav" -b 16 "$out/$name/$rel" highpass -2 "$hz"
        elif [ "$kind" = rate ]; then
            sox -R -V1 "$wav" -b 16 -r "$hz" "$out/$name/$rel"
        elif [ "$kind" = silence ]; then
            sox -R -V1 "$wav" "$out/$name/$rel" pad "$seconds" 0
        elif [ "$kind" = trim ]; then
            sox -R -V1 "$wav" "$out/$name/$rel" trim "$seconds"
        elif [ "$kind" = head ]; then
            sox -R -V1 "$wav" "$out/$name/$rel" trim "$(cat "$tmp/$name-$(basename "$wav" .wav).cut")s"
        elif [ "$kind" = gate ]; then
            # The samples as raw 32-bit floats through the gate, written back in the
            # file's own encoding.
            rate=$(soxi -r "$wav" 2> /dev/null)
            sox -R -V1 "$wav" -t f32 -c 1 "$tmp/in.f32"
            python3 "$tmp/gate.py" gate "$tmp/in.f32" "$tmp/out.f32" "$rate" "$threshold_db" "$hold"
            sox -R -V1 -t f32 -r "$rate" -c 1 "$tmp/out.f32" \
                -e "$(soxi -e "$wav" 2> /dev/null | sed 's/ .*//; s/Signed/signed-integer/; s/Floating/floating-point/')" \
                -b "$(soxi -b "$wav" 2> /dev/null)" "$out/$name/$rel"
        else
            seconds=$(soxi -D "$wav" 2> /dev/null)
            rate=$(soxi -r "$wav" 2> /dev/null)
            if [ "$kind" = noise ]; then
                sox -R -V1 -n -r "$rate" -c 1 -b 32 -e floating-point "$tmp/noise.wav" \
                    synth "$seconds" "$noise_type" vol "$level_db" dB
            elif [ "$kind" = louder ]; then
                # As long as the sequence from AT_SECONDS (at least a hundredth of a
                # second, so that sox has a noise to make), silence before it.
                after=$(awk -v d="$seconds" -v a="$at" 'BEGIN { r = d - a; print (r > 0.01 ? r : 0.01) }')
                sox -R -V1 -n -r "$rate" -c 1 -b 32 -e floating-point "$tmp/noise.wav" \
                    synth "$after" "$noise_type" vol "$level_db" dB fade t 0.3 pad "$at" 0 trim 0 "$seconds"
            elif [ "$kind" = talk ]; then
                # Repeated whole until it is as long as the file, then cut to it.
                repeats=$(awk -v a="$seconds" -v b="$talk_seconds" 'BEGIN { print int(a / b) }')
                peak_db=$(sox -V1 "$wav" -n stats 2>&1 | awk '$1 == "Pk" && $2 == "lev" { print $4 }')
                [[ $peak_db =~ ^-?[0-9]+(\.[0-9]+)?$ ]] || { echo "room-sets.sh: $wav: expected some sound to lay the talk under, found a peak of ${peak_db:-nothing} dB" >&2; exit 1; }
                sox -R -V1 "$talk_file" -r "$rate" -c 1 -b 32 -e floating-point "$tmp/noise.wav" \
                    repeat "$repeats" trim 0 "$seconds" \
                    gain -n "$(awk -v p="$peak_db" -v l="$level_db" 'BEGIN { print p + l }')"
            else
                sox -R -V1 -n -r "$rate" -c 8 -b 32 -e floating-point "$tmp/buzz.wav" \
                    synth "$seconds" "${sines[@]}"
                sox -R -V1 "$tmp/buzz.wav" "$tmp/noise.wav" remix "$mix" gain -n "$level_db"
            fi
            sox -R -V1 -m "$wav" "$tmp/noise.wav" "$out/$name/$rel"
        fi
    done
    count=$((count + 1))
done
[ "$count" -gt 0 ] || { echo "room-sets.sh: $src holds no set (no */set.json)" >&2; exit 1; }
if [ "$kind" != reverb ]; then
    echo "room-sets.sh: $count sets in $out ($added)"
    exit 0
fi
# The room this makes: an impulse through the same chain, its reverberation time (T20 of
# the Schroeder decay curve, from -5 to -25 dB, times 3) and the direct sound's energy
# over the reverberation's.
room=$(python3 - "${chain[@]}" <<'PY'
import math, struct, subprocess, sys
rate, seconds = 48000, 4
impulse = [0.0] * (rate * seconds)
impulse[0] = 0.5
raw = ["-t", "raw", "-r", str(rate), "-b", "32", "-e", "floating-point", "-c", "1"]
y = subprocess.run(["sox", "-V1", *raw, "-", *raw, "-", *sys.argv[1:]],
                   input=struct.pack(f"<{len(impulse)}f", *impulse), capture_output=True, check=True).stdout
y = struct.unpack(f"<{len(y) // 4}f", y)
direct, tail = y[:2], y[2:]
left, curve = sum(v * v for v in tail), []
for v in tail:
    curve.append(left)
    left -= v * v
db = [10 * math.log10(max(c, 1e-30) / curve[0]) for c in curve]
at = lambda level: next(i for i, d in enumerate(db) if d < level) / rate
print(f"RT60 {3 * (at(-25) - at(-5)):.2f} s, direct to reverberant {10 * math.log10(sum(v * v for v in direct) / curve[0]):.1f} dB")
PY
)
heard="every file"
[ "$which" = all ] || heard="the sequences alone"
echo "room-sets.sh: $count sets in $out (reverberance $reverberance %, room scale $room_scale %: $room; $heard)"
