#!/usr/bin/env python3
"""What became of the words a rhythm missed, by what came before each.

For every D4_voice_* set given (the voice protocol of ../shared/devsets and of
scripts/other-voices.py), this runs `onomato analyze seq_02.wav --explain --format json`
on the set's rhythm at 150 bpm and, for every word that no detection of its label
matches within 50 ms (the dev sets' scoring rule), takes the onset the detector
considered nearest it, within 50 ms. It counts that onset's outcome (the gate that
stopped it; `fired` when it fired as another pattern or was dated over 50 ms off;
`no onset`) by what came before
the word: a gap (the word before began more than 0.3 s earlier), a word that was found,
or a word that was missed too (a miss that spreads: the word then begins over sound no
pattern recognised).

    python3 scripts/rhythm-misses.py target/release/onomato /tmp/devsets/D4_voice_* ...

Needs only Python's standard library.
"""

import collections
import csv
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SCORE = os.path.join(HERE, "..", "..", "shared", "devsets", "score.py")


def pattern_args(set_dir):
    out = subprocess.run(
        ["python3", SCORE, "--pattern-args", set_dir], capture_output=True, text=True, check=True
    ).stdout
    return [a for a in out.split("\n") if a]


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: rhythm-misses.py ONOMATO_BIN D4_SET_DIR...")
    binary, sets = sys.argv[1], sys.argv[2:]
    counts = collections.Counter()
    words = 0
    for set_dir in sets:
        seq = os.path.join(set_dir, "seq_02.wav")
        if not os.path.exists(seq):
            sys.exit(f"rhythm-misses.py: {seq}: no rhythm (seq_02) in this set")
        run = subprocess.run(
            [binary, "analyze", seq, *pattern_args(set_dir), "--explain", "--format", "json"],
            capture_output=True,
            text=True,
        )
        if run.returncode != 0:
            sys.exit(f"rhythm-misses.py: analyze failed on {seq}: {run.stderr.strip()}")
        result = json.loads(run.stdout)
        events, onsets = result["events"], result["onsets"]
        with open(os.path.join(set_dir, "seq_02.csv"), newline="") as f:
            truth = [(float(r["onset_s"]), r["label"]) for r in csv.DictReader(f)]
        words += len(truth)
        found = [
            any(e["pattern"] == label and abs(e["time"] - t) <= 0.05 for e in events)
            for t, label in truth
        ]
        for i, (t, _) in enumerate(truth):
            if found[i]:
                continue
            near = [o for o in onsets if abs(o["time"] - t) <= 0.05]
            outcome = min(near, key=lambda o: abs(o["time"] - t))["outcome"] if near else "no onset"
            if i == 0 or t - truth[i - 1][0] > 0.3:
                before = "after a gap"
            elif found[i - 1]:
                before = "after a word found"
            else:
                before = "after a word missed"
            counts[(outcome, before)] += 1
    missed = sum(counts.values())
    print(f"{len(sets)} rhythms, {words} words, {missed} missed\n")
    print("| outcome | after a gap | after a word found | after a word missed |")
    print("|---|---|---|---|")
    for outcome in sorted({o for o, _ in counts}, key=lambda o: -sum(v for (p, _), v in counts.items() if p == o)):
        cells = [str(counts[(outcome, b)]) for b in ("after a gap", "after a word found", "after a word missed")]
        print(f"| {outcome} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
