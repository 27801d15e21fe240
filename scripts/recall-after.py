#!/usr/bin/env python3
"""How many of the annotated sounds are found, second by second after a time in each
sequence: how long the detector takes to hear a room that changed at that time
(`scripts/room-sets.sh ... louder`, whose noise begins AT seconds into each sequence).

    bash scripts/room-sets.sh /tmp/devsets /tmp/louder22 louder pinknoise -22 2
    TAG=after bash ../shared/devsets/run.sh target/release/onomato /tmp/louder22
    python3 scripts/recall-after.py /tmp/louder22 2 after [TAG ...]

Reads the files `run.sh` left (seq_*.TAG.json beside each seq_*.csv) of every positive
set in SETS_DIR, and prints a Markdown table: per whole second after AT (the row "-1"
holds the sounds before AT, the last row every sound from its second on), the share of
annotated sounds that an event of the same label matches within 50 ms (the dev sets'
scoring rule), per TAG. Needs only Python's standard library.
"""

import collections
import csv
import glob
import json
import os
import sys

LAST = 12


def recall_by_second(root, at, tag):
    found = collections.defaultdict(lambda: [0, 0])
    for out in sorted(glob.glob(os.path.join(root, "D*", f"seq_*.{tag}.json"))):
        events = json.load(open(out))["events"]
        truth = out[: -len(f".{tag}.json")] + ".csv"
        for row in csv.DictReader(open(truth)):
            t, label = float(row["onset_s"]), row["label"]
            second = min(int(t - at), LAST) if t >= at else -1
            hit = any(e["pattern"] == label and abs(e["time"] - t) <= 0.05 for e in events)
            found[second][0] += 1
            found[second][1] += hit
    return found


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    root, at, tags = sys.argv[1], float(sys.argv[2]), sys.argv[3:]
    tables = [recall_by_second(root, at, tag) for tag in tags]
    if not tables[0]:
        sys.exit(f"recall-after.py: no seq_*.{tags[0]}.json under {root}/D*")
    print(f"| seconds after {at:g} s | sounds | " + " | ".join(tags) + " |")
    print("|---|---|" + "---|" * len(tags))
    for second in sorted(tables[0]):
        name = "before" if second < 0 else f"{second}+" if second == LAST else str(second)
        shares = (f"{t[second][1] / t[second][0]:.3f}" if t[second][0] else "-" for t in tables)
        print(f"| {name} | {tables[0][second][0]} | " + " | ".join(shares) + " |")


if __name__ == "__main__":
    main()
