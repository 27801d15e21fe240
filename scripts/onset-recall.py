#!/usr/bin/env python3
"""How many annotated sounds the onset stage put an onset near at all, sequence by
sequence, whatever the later stages then decided.

The dev sets' onset F1 counts the events that fired, so a hit the onset stage found and
a later gate stopped counts as missed there. This runs `onomato analyze SEQ --explain
--format json` on every sequence of the given sets and counts, against the sequence's
annotation, the annotated sounds with an onset considered within 50 ms (recall), and
the onsets considered with no annotated sound within 50 ms (extra: a sound's own later
onsets among them, which the later stages take for its continuation).

    python3 scripts/onset-recall.py target/release/onomato SET_DIR [SET_DIR ...]

Needs only Python's standard library; the sets are made by ../shared/devsets/build.sh
(or `scripts/noise-sweeps.py`).
"""

import csv
import glob
import json
import os
import subprocess
import sys

from set_patterns import pattern_args


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    binary = os.path.abspath(sys.argv[1])
    for folder in sys.argv[2:]:
        _, args = pattern_args(folder)
        cells = []
        for wav in sorted(glob.glob(os.path.join(folder, "seq_*.wav"))):
            truth = [float(r["onset_s"]) for r in csv.DictReader(open(wav[:-4] + ".csv"))]
            run = subprocess.run(
                [binary, "analyze", os.path.abspath(wav), *args, "--explain", "--format", "json"],
                cwd=folder, capture_output=True, text=True, check=True)
            onsets = [o["time"] for o in json.loads(run.stdout)["onsets"]]
            found = sum(1 for t in truth if any(abs(o - t) <= 0.05 for o in onsets))
            extra = sum(1 for o in onsets if not any(abs(o - t) <= 0.05 for t in truth))
            recall = found / len(truth) if truth else float("nan")
            cells.append(f"{os.path.basename(wav)[:-4]} {recall:.3f} ({extra} extra)")
        print(f"{os.path.basename(os.path.normpath(folder))}: " + ", ".join(cells))


if __name__ == "__main__":
    main()
