#!/usr/bin/env python3
"""Zingerbox's sequences scored as they are and without the copies of the take whose
annotated onset is a lip click 70 ms before its "b" (`docs/onset-stage.md`, "A lip
click 70 ms before a b").

A copy of that take is a true "b" that no "b" detection matches within 50 ms while a
"b" fires 60-80 ms after it; its truth row and that detection are removed and the rest
scored with the dev sets' scorer. Prints one Markdown row per sequence: copies
removed, F1 as is and without them, onset F1 as is and without them.

    bash ../shared/devsets/run.sh target/release/onomato /tmp/devsets
    python3 scripts/without-lip-click.py /tmp/devsets [TAG]

TAG names the detection files as run.sh does (default `dev`). Needs only Python's
standard library and ../shared/devsets/score.py.
"""

import csv
import json
import os
import pathlib
import subprocess
import sys
import tempfile

SCORE = pathlib.Path(__file__).resolve().parent.parent.parent / "shared" / "devsets" / "score.py"


def score(truth, detections):
    out = subprocess.run(
        [sys.executable, str(SCORE), truth, detections], capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout)


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    sets, tag = sys.argv[1], sys.argv[2] if len(sys.argv) == 3 else "dev"
    print("| sequence | copies | F1 | without them | onset F1 | without them |")
    print("|---|---|---|---|---|---|")
    for name in ("D1_isolated_zingerbox", "D1_noise_zingerbox"):
        folder = os.path.join(sets, name)
        seqs = sorted(f[:-4] for f in os.listdir(folder) if f.startswith("seq_") and f.endswith(".csv"))
        for seq in seqs:
            base = os.path.join(folder, seq)
            found = base + f".{tag}.json"
            if not os.path.exists(found):
                sys.exit(f"{found}: no detections; run run.sh with TAG={tag} first")
            rows = list(csv.DictReader(open(base + ".csv")))
            detections = json.load(open(found))
            events = detections["events"]
            dropped_rows, dropped_events = [], set()
            for row in rows:
                t = float(row["onset_s"])
                if row["label"] != "b":
                    continue
                if any(e["pattern"] == "b" and abs(e["time"] - t) < 0.05 for e in events):
                    continue
                late = [i for i, e in enumerate(events) if e["pattern"] == "b" and 0.06 <= e["time"] - t <= 0.08]
                if late:
                    dropped_rows.append(row)
                    dropped_events.update(late)
            with tempfile.TemporaryDirectory() as tmp:
                truth = os.path.join(tmp, "truth.csv")
                with open(truth, "w", newline="") as f:
                    writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
                    writer.writeheader()
                    writer.writerows(r for r in rows if r not in dropped_rows)
                rest = os.path.join(tmp, "detections.json")
                kept = dict(detections)
                kept["events"] = [e for i, e in enumerate(events) if i not in dropped_events]
                json.dump(kept, open(rest, "w"))
                before, after = score(base + ".csv", found), score(truth, rest)
            print(
                f"| {name} {seq} | {len(dropped_rows)} | {before['f1']:.3f} | {after['f1']:.3f} "
                f"| {before['onset_f1']:.3f} | {after['onset_f1']:.3f} |"
            )


if __name__ == "__main__":
    main()
