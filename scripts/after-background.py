#!/usr/bin/env python3
"""What the sound did after each onset that the background stage took for speech.

For every onset of the given sets whose outcome was `background` (`onomato analyze
--explain --format json`), this reads the recording after it: the power of each 25 ms
window from 25 to 150 ms on against the first one's, dB, and how voiced the stretch
from VOICING_FROM to VOICING_TO seconds on is (the highest autocorrelation at a lag of
one period of 60-400 Hz, over the autocorrelation at lag 0). Each onset is one of:

- `hit`: an annotated impulse of the pattern its first window named lies within 50 ms,
  and nothing of that pattern fired there at its first look or as a copy: a hit the
  background took;
- `speech`: an onset of a speech set (a set with no annotation, N_speech_*);
- `other label`, `other`: in a positive set, near an annotated sound of another
  pattern, or near none (a sound's later onsets, the room).

It prints, for each kind, the median of each window's power and of the voicing, then
how many of each kind a rule "its window ending AT ms on fell at least FALL dB, voicing
under V" keeps.

    ~/.cache/onomato-devsets-venv/bin/python scripts/after-background.py \\
        target/release/onomato /tmp/devsets/D1_* /tmp/devsets/N_speech_*

Needs numpy and soundfile (the dev sets' venv, as ../shared/devsets/build.sh makes it).
"""

import csv
import glob
import json
import os
import subprocess
import sys

import numpy as np
import soundfile as sf

from set_patterns import pattern_args

VOICING_FROM = 0.025
VOICING_TO = 0.075
# Where each 25 ms window compared with the first begins, seconds after the onset.
WINDOWS = (0.025, 0.05, 0.075, 0.1, 0.125)


def after(x, sr, t):
    i = int(t * sr)

    def db(a, b):
        seg = x[i + int(a * sr):i + int(b * sr)]
        return 10 * np.log10(np.mean(seg ** 2) + 1e-12) if len(seg) else -120.0

    first = db(0, 0.025)
    falls = [db(a, a + 0.025) - first for a in WINDOWS]
    seg = x[i + int(VOICING_FROM * sr):i + int(VOICING_TO * sr)]
    voicing = 0.0
    lo, hi = int(sr / 400), int(sr / 60)
    if len(seg) > hi:
        seg = seg - seg.mean()
        ac = np.correlate(seg, seg, "full")[len(seg) - 1:]
        if ac[0] > 0:
            voicing = float(ac[lo:hi].max() / ac[0])
    return falls, voicing


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    binary = os.path.abspath(sys.argv[1])
    rows = []
    for folder in sys.argv[2:]:
        _, args = pattern_args(folder)
        for wav in sorted(glob.glob(os.path.join(folder, "seq_*.wav"))):
            x, sr = sf.read(wav, dtype="float64")
            if x.ndim > 1:
                x = x.mean(axis=1)
            run = subprocess.run(
                [binary, "analyze", os.path.abspath(wav), *args, "--explain", "--format", "json"],
                cwd=folder, capture_output=True, text=True, check=True)
            found = json.loads(run.stdout)
            annotation = wav[:-4] + ".csv"
            truth = []
            if os.path.exists(annotation):
                truth = [(float(r["onset_s"]), r["label"]) for r in csv.DictReader(open(annotation))]
            for onset in found["onsets"]:
                if onset["outcome"] != "background":
                    continue
                near = [label for time, label in truth if abs(time - onset["time"]) <= 0.05]
                # Fired at its first look, or as a copy (not by the second look, which
                # is what this measures).
                fired = any(o["best"] == onset["best"] and o["outcome"] in ("fired", "copy")
                            and abs(o["time"] - onset["time"]) <= 0.05 for o in found["onsets"])
                if not truth:
                    kind = "speech"
                elif onset["best"] in near and not fired:
                    kind = "hit"
                elif near:
                    kind = "other label"
                else:
                    kind = "other"
                falls, voicing = after(x, sr, onset["time"])
                rows.append((kind, falls, voicing))
    kinds = ("hit", "speech", "other label", "other")
    print("| kind | onsets | " + " | ".join(f"{int(a * 1000)}-{int(a * 1000) + 25} ms (dB)" for a in WINDOWS)
          + " | voicing |")
    print("|---|---|" + "---|" * (len(WINDOWS) + 1))
    for kind in kinds:
        some = [r for r in rows if r[0] == kind]
        if not some:
            continue
        falls = np.median(np.array([r[1] for r in some]), axis=0)
        voicing = np.median([r[2] for r in some])
        print(f"| {kind} | {len(some)} | " + " | ".join(f"{f:.1f}" for f in falls) + f" | {voicing:.2f} |")
    print()
    print("| rule | " + " | ".join(kinds) + " |")
    print("|---|" + "---|" * len(kinds))
    # The window that ends at `at`.
    for at, k in ((0.05, 0), (0.075, 1), (0.1, 2)):
        for fall in (8, 10, 12):
            for most in (0.3, 0.4, 1.01):
                counts = [sum(1 for r in rows if r[0] == kind and r[1][k] <= -fall and r[2] < most)
                          for kind in kinds]
                voiced = "any voicing" if most > 1 else f"voicing under {most}"
                print(f"| fell {fall} dB by {int(at * 1000)} ms, {voiced} | "
                      + " | ".join(str(c) for c in counts) + " |")


if __name__ == "__main__":
    main()
