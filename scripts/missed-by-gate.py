#!/usr/bin/env python3
"""What stopped each true sound that was missed, over development sets.

For every impulse of every positive set's truth that no detection of the same label
matches within 50 ms (the dev sets' scoring rule), this runs
`onomato analyze SEQ --explain --format json` and takes the onset the detector
considered nearest the true time, within 50 ms. It counts that onset's outcome: the gate
that stopped it, `fired_as_other` when it fired as another pattern, or `no_onset` when
no onset was considered there.

    python3 scripts/missed-by-gate.py target/release/onomato /tmp/devsets [SET ...]

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


def missed(binary, folder):
    kinds, args = pattern_args(folder)
    outcomes = collections.Counter()
    truths = 0
    for wav in sorted(glob.glob(os.path.join(folder, "seq_*.wav"))):
        rows = list(csv.DictReader(open(wav[:-4] + ".csv")))
        truth = [(float(r["onset_s"]), r["label"]) for r in rows if kinds[r["label"]] == "impulse"]
        if not truth:
            continue
        run = subprocess.run(
            [binary, "analyze", os.path.abspath(wav), *args, "--explain", "--format", "json"],
            cwd=folder, capture_output=True, text=True, check=True)
        found = json.loads(run.stdout)
        for time, label in truth:
            truths += 1
            if any(e["pattern"] == label and abs(e["time"] - time) <= 0.05 for e in found["events"]):
                continue
            near = [o for o in found["onsets"] if abs(o["time"] - time) <= 0.05]
            if not near:
                outcomes["no_onset"] += 1
                continue
            onset = min(near, key=lambda o: abs(o["time"] - time))
            outcome = onset["outcome"]
            outcomes["fired_as_other" if outcome in ("fired", "copy") else outcome] += 1
    return truths, outcomes


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    binary, root, only = os.path.abspath(sys.argv[1]), sys.argv[2], sys.argv[3:]
    total = collections.Counter()
    all_truths = 0
    for name in sorted(os.listdir(root)):
        folder = os.path.join(root, name)
        if not os.path.isfile(os.path.join(folder, "set.json")) or (only and name not in only):
            continue
        truths, outcomes = missed(binary, folder)
        if truths == 0:
            continue
        all_truths += truths
        total += outcomes
        detail = ", ".join(f"{k} {v}" for k, v in outcomes.most_common())
        print(f"{name:24s} impulses {truths:4d} missed {sum(outcomes.values()):3d}: {detail}")
    detail = ", ".join(f"{k} {v}" for k, v in total.most_common())
    print(f"{'all':24s} impulses {all_truths:4d} missed {sum(total.values()):3d}: {detail}")


if __name__ == "__main__":
    main()
