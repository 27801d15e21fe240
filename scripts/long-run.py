#!/usr/bin/env python3
"""Whether the detector drifts over a long stream: the same 13 minutes heard again and again.

One pass is every recording of N_speech_real (real speakers' command words, at 0.7 of
their level), and after every sixth one a sequence of D1_isolated_agh's hits (its
seq_00 to seq_02 in turn), about 13 minutes with 147 hits. The pass is repeated REPS
times into one recording, which `onomato analyze` hears whole, enrolled with the set's
takes. For each pass it prints the false events in its speech (events further than 2 s
from every annotated hit) and the hits found (an event of the hit's label within 50 ms).
A detector that learns from what it fires drifts: the same pass gives more false events
each time it comes round.

    ~/.cache/onomato-devsets-venv/bin/python scripts/long-run.py \\
        target/release/onomato /tmp/devsets [REPS]

Needs numpy and soundfile (the dev sets' venv, as ../shared/devsets/build.sh makes it).
"""

import bisect
import csv
import glob
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import soundfile as sf

from set_patterns import pattern_args

SPEECH_GAIN = 0.7
HITS_EVERY = 6


def read(path, rate):
    x, r = sf.read(path, dtype="float64")
    if x.ndim > 1:
        x = x.mean(axis=1)
    if r != rate:
        n = int(round(len(x) * rate / r))
        x = np.interp(np.linspace(0, len(x) - 1, n), np.arange(len(x)), x)
    return x


def one_pass(sets, rate):
    """The pass's samples and its hits' (onset seconds, label)."""
    speech = sorted(glob.glob(os.path.join(sets, "N_speech_real", "seq_*.wav")))
    hits = sorted(glob.glob(os.path.join(sets, "D1_isolated_agh", "seq_0[0-2].wav")))
    parts, truth, t = [], [], 0.0
    for i, path in enumerate(speech):
        x = read(path, rate) * SPEECH_GAIN
        parts.append(x)
        t += len(x) / rate
        if i % HITS_EVERY == 0:
            seq = hits[(i // HITS_EVERY) % len(hits)]
            y = read(seq, rate)
            with open(seq[:-4] + ".csv", newline="") as f:
                truth += [(t + float(r["onset_s"]), r["label"]) for r in csv.DictReader(f)]
            parts.append(y)
            t += len(y) / rate
    return np.concatenate(parts), truth


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: long-run.py ONOMATO_BIN DEVSETS_DIR [REPS]")
    binary, sets = os.path.abspath(sys.argv[1]), sys.argv[2]
    reps = int(sys.argv[3]) if len(sys.argv) > 3 else 6
    rate = 44100
    samples, truth = one_pass(sets, rate)
    length = len(samples) / rate
    truth_all = [(t + k * length, label) for k in range(reps) for t, label in truth]
    folder = os.path.join(sets, "D1_isolated_agh")
    _, args = pattern_args(folder)
    with tempfile.TemporaryDirectory() as tmp:
        wav = os.path.join(tmp, "long.wav")
        sf.write(wav, np.tile(samples, reps), rate, subtype="PCM_16")
        run = subprocess.run(
            [binary, "analyze", wav, *args, "--format", "json"],
            cwd=folder, capture_output=True, text=True, check=True)
    events = json.loads(run.stdout)["events"]
    onsets = sorted(t for t, _ in truth_all)

    def near_a_hit(t):
        i = bisect.bisect_left(onsets, t - 2.0)
        return i < len(onsets) and onsets[i] <= t + 2.0

    print(f"{reps} passes of {length / 60:.1f} min, {len(truth)} hits each\n")
    print("| pass | false events in its speech | hits found |")
    print("|---|---|---|")
    for k in range(reps):
        start, end = k * length, (k + 1) * length
        false = sum(1 for e in events if start <= e["time"] < end and not near_a_hit(e["time"]))
        found = sum(1 for t, label in truth_all if start <= t < end and any(
            e["pattern"] == label and abs(e["time"] - t) <= 0.05 for e in events))
        print(f"| {k + 1} | {false} | {found} of {len(truth)} |")


if __name__ == "__main__":
    main()
