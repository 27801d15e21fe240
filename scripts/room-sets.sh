#!/bin/bash
# Copies of sets in the dev sets' format (../shared/devsets/README.md) heard in a
# reverberant room: every WAV, the enrolment takes with the sequences, through sox's
# reverb (the performer enrols and performs in the same room), every truth file as it is.
# A check that the detector holds up in a room with a tail, which no dev set has.
#
#     bash scripts/room-sets.sh SETS_DIR OUT_DIR [REVERBERANCE [ROOM_SCALE]]
#     bash ../shared/devsets/run.sh target/release/onomato OUT_DIR
#
# REVERBERANCE and ROOM_SCALE are sox reverb's percentages (default 50 and 100).
set -euo pipefail
if [ $# -lt 2 ] || [ $# -gt 4 ]; then
    sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
fi
src=$1 out=$2 reverberance=${3:-50} room_scale=${4:-100}
command -v sox > /dev/null || { echo "room-sets.sh: sox is needed (apt install sox)" >&2; exit 1; }
[ -d "$src" ] || { echo "room-sets.sh: $src: no such folder of sets" >&2; exit 1; }
count=0
for set in "$src"/*/; do
    set=${set%/}
    [ -f "$set/set.json" ] || continue
    name=$(basename "$set")
    mkdir -p "$out/$name/patterns"
    cp "$set/set.json" "$out/$name/"
    for csv in "$set"/seq_*.csv; do cp "$csv" "$out/$name/"; done
    for wav in "$set"/seq_*.wav "$set"/patterns/*.wav; do
        rel=${wav#"$set"/}
        # 4 dB down first so that the tail added to the loudest hits does not clip;
        # 50 % HF damping and no pre-delay are sox's defaults.
        sox -R -V1 "$wav" "$out/$name/$rel" gain -4 reverb "$reverberance" 50 "$room_scale"
    done
    count=$((count + 1))
done
[ "$count" -gt 0 ] || { echo "room-sets.sh: $src holds no set (no */set.json)" >&2; exit 1; }
# The room this makes: an impulse through the same chain, its reverberation time (T20 of
# the Schroeder decay curve, from -5 to -25 dB, times 3) and the direct sound's energy
# over the reverberation's.
room=$(python3 - "$reverberance" "$room_scale" <<'PY'
import math, struct, subprocess, sys
rate, seconds = 48000, 4
impulse = [0.0] * (rate * seconds)
impulse[0] = 0.5
raw = ["-t", "raw", "-r", str(rate), "-b", "32", "-e", "floating-point", "-c", "1"]
y = subprocess.run(["sox", "-V1", *raw, "-", *raw, "-", "gain", "-4", "reverb", *sys.argv[1:2], "50", *sys.argv[2:3]],
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
echo "room-sets.sh: $count sets in $out (reverberance $reverberance %, room scale $room_scale %: $room)"
