#!/usr/bin/env python3
"""Onsets that followed a fired impulse closely, over development sets.

For every impulse that fired, this takes the next onset the detector scored within
MAX_MS (100 by default) after it, if that onset fired too or was taken for the fired
impulse's own later sound (`continuation`), and prints both: the time between them,
each one's pattern, strength and score, and whether an annotated impulse of that
pattern lies within 50 ms of it (the dev sets' scoring rule: `T`, else `F`, with the
labels annotated there). Then a count by gap: pairs where both were annotated sounds
of their patterns, each its own, are two sounds; every other pair is one sound heard
twice, or a sound and a false event.

    python3 scripts/close-events.py target/release/onomato /tmp/devsets [MAX_MS] [SET ...]

Needs only Python's standard library; the sets are made by ../shared/devsets/build.sh.
"""

import collections
import csv
import glob
import json
import os
import subprocess
import sys

from set_patterns import pattern_args


def status(onset, truth):
    """`T` when an annotated sound of the onset's pattern lies within 50 ms of it (the
    labels annotated there in brackets), and which one (the nearest, or None)."""
    near = [(abs(time - onset["time"]), i, label) for i, (time, label) in enumerate(truth)
            if abs(time - onset["time"]) <= 0.05]
    own = [i for _, i, label in sorted(near) if label == onset["best"]]
    labels = ",".join(label for _, _, label in sorted(near))
    return ("T" if own else "F") + (f"({labels})" if labels else ""), own[0] if own else None


def pairs(binary, folder, max_s):
    kinds, args = pattern_args(folder)
    for wav in sorted(glob.glob(os.path.join(folder, "seq_*.wav"))):
        annotation = wav[:-4] + ".csv"
        truth = []
        if os.path.exists(annotation):
            truth = [(float(r["onset_s"]), r["label"]) for r in csv.DictReader(open(annotation))]
        run = subprocess.run(
            [binary, "analyze", os.path.abspath(wav), *args, "--explain", "--format", "json"],
            cwd=folder, capture_output=True, text=True, check=True)
        onsets = [o for o in json.loads(run.stdout)["onsets"] if o["best"] is not None]
        for i, first in enumerate(onsets):
            if first["outcome"] != "fired" or kinds.get(first["best"]) != "impulse":
                continue
            for later in onsets[i + 1:]:
                gap = later["time"] - first["time"]
                if gap > max_s:
                    break
                if later["outcome"] in ("fired", "continuation"):
                    yield (os.path.basename(wav)[:-4], gap, first, later, *status(first, truth),
                           *status(later, truth))
                    break


def describe(onset, mark):
    return f"{onset['best']} s={onset['strength']:.2f} score={onset['best_score']:.2f} {mark}"


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    binary, root = os.path.abspath(sys.argv[1]), sys.argv[2]
    rest = sys.argv[3:]
    max_ms = float(rest.pop(0)) if rest and rest[0].replace(".", "", 1).isdigit() else 100.0
    by_gap = collections.Counter()
    for name in sorted(os.listdir(root)):
        folder = os.path.join(root, name)
        if not os.path.isfile(os.path.join(folder, "set.json")) or (rest and name not in rest):
            continue
        for seq, gap, first, later, a, sound_a, b, sound_b in pairs(binary, folder, max_ms / 1000):
            print(f"{name:24s} {seq} {first['time']:8.4f} +{gap * 1000:5.1f} ms  "
                  f"{describe(first, a):34s} -> {later['outcome']:12s} {describe(later, b)}")
            bucket = "under 45 ms" if gap < 0.045 else "45 ms or more"
            two = sound_a is not None and sound_b is not None and sound_a != sound_b
            by_gap[(bucket, later["outcome"], "two sounds" if two else "one sound")] += 1
    for (bucket, outcome, kind), n in sorted(by_gap.items()):
        print(f"{bucket:14s} then {outcome:12s} {kind:10s} {n}")


if __name__ == "__main__":
    main()
