#!/usr/bin/env python3
"""Every floor the detector is held to on the development sets, measured and checked.

Reads what `run.sh` wrote (the summary and each sequence's detections) and scores the
sequences some floors are about with the dev sets' scorer: the rhythm at 150 bpm (each
D4 set's seq_02) and D1_noise_zingerbox's onset F1 at each noise level (its seq_00 to
seq_04; so too any other D1_noise_* set, such as `scripts/noise-sweeps.py` makes).
Prints one Markdown row per floor: what is asked, what was measured, whether it is met,
and where it is not, which sets miss it. A floor about sets that SETS_DIR does
not hold is left out, so the same command checks the sets of other voices and rooms
(`scripts/other-voices.py`, `scripts/room-sets.sh`). Exit status 0 when every floor is
met, 1 when some is not, 2 when the summary or a detection file is missing.

    bash ../shared/devsets/build.sh /tmp/devsets
    bash ../shared/devsets/run.sh target/release/onomato /tmp/devsets
    python3 scripts/floors.py /tmp/devsets [TAG]

TAG names the detection files and the summary as run.sh does (default `dev`). Needs only
Python's standard library and ../shared/devsets/score.py.
"""

import json
import pathlib
import subprocess
import sys

SCORE = pathlib.Path(__file__).resolve().parent.parent.parent / "shared" / "devsets" / "score.py"

# D1_noise_zingerbox's sequences, from the quietest noise to the loudest, and the onset
# F1 each must reach (a state-of-the-art causal detector's, less 0.02).
NOISE_LEVELS = [("-60 dB", 0.95), ("-50 dB", 0.93), ("-45 dB", 0.92), ("-40 dB", 0.87), ("-35 dB", 0.75)]


def fail(message):
    print(f"floors.py: {message}", file=sys.stderr)
    sys.exit(2)


def score(folder, seq, tag):
    truth = folder / f"{seq}.csv"
    detections = folder / f"{seq}.{tag}.json"
    if not truth.is_file() or not detections.is_file():
        fail(f"{detections}: expected {seq}'s truth and detections (run run.sh with TAG={tag} first)")
    out = subprocess.run(
        [sys.executable, str(SCORE), str(truth), str(detections)],
        capture_output=True,
        text=True,
    )
    if out.returncode != 0:
        fail(f"score.py on {detections}: {out.stderr.strip()}")
    return json.loads(out.stdout)


def main():
    if len(sys.argv) not in (2, 3):
        print(__doc__.split("\n\n")[2], file=sys.stderr)
        sys.exit(2)
    root = pathlib.Path(sys.argv[1])
    tag = sys.argv[2] if len(sys.argv) == 3 else "dev"
    summary_path = root / f"summary.{tag}.json"
    if not summary_path.is_file():
        fail(f"{summary_path}: no such summary (run run.sh with TAG={tag} on {root} first)")
    summary = json.loads(summary_path.read_text())
    sets = summary["sets"]
    positive = {k: v for k, v in sets.items() if not v["negative"]}
    negative = {k: v for k, v in sets.items() if v["negative"]}
    if not positive:
        fail(f"{summary_path}: no positive set")

    rows = []

    def floor(what, measured, met, missed=()):
        rows.append((what, measured, met, ", ".join(missed)))

    def judged(what, values, at_least=None, at_most=None, unit="", digits=3, extra=""):
        """One floor over several sets: `values` (set name to figure) must each be at
        least `at_least` or at most `at_most`; the row shows the worst."""
        if not values:
            return
        if at_least is not None:
            worst = min(values, key=values.get)
            missed_it = lambda v: v < at_least
        else:
            worst = max(values, key=values.get)
            missed_it = lambda v: v > at_most
        shown = lambda v: f"{v:.{digits}f}{unit}"
        missed = [f"{k} {shown(v)}" for k, v in sorted(values.items()) if missed_it(v)]
        floor(what, f"{shown(values[worst])} ({worst}{extra})", not missed, missed)

    def f1_of(prefixes):
        return {k: v["f1"] for k, v in positive.items() if k.startswith(prefixes)}

    mean = summary["mean_f1_positive"]
    floor("mean F1 over the positive sets ≥ 0.90", f"{mean:.3f}", mean >= 0.90)
    strict = ("D1_isolated", "D3", "D4", "D5", "D6")
    judged("no D1_isolated, D3, D4, D5 or D6 set under 0.85", f1_of(strict), at_least=0.85)
    judged("no D2 set under 0.60", f1_of("D2"), at_least=0.60)
    judged("D5 exact copies 1.00", f1_of("D5"), at_least=1.0)

    rhythms = {}
    for name in sorted(k for k in positive if k.startswith("D4")):
        if (root / name / "seq_02.csv").is_file():
            rhythms[name] = score(root / name, "seq_02", tag)["f1"]
    if rhythms:
        judged(
            "every rhythm at 150 bpm (D4 seq_02) ≥ 0.95",
            rhythms,
            at_least=0.95,
            extra=f"; highest {max(rhythms.values()):.3f}",
        )

    for name in sorted(k for k in positive if k.startswith("D1_noise_")):
        for i, (level, at_least) in enumerate(NOISE_LEVELS):
            onset_f1 = score(root / name, f"seq_{i:02d}", tag)["onset_f1"]
            floor(
                f"onset F1 of {name} at {level} ≥ {at_least:.2f}",
                f"{onset_f1:.3f}",
                onset_f1 >= at_least,
            )

    espeak = {k: v["false_per_min"] for k, v in negative.items() if k.startswith("N_speech_espeak")}
    judged("≤ 3 false events a minute on every espeak speech set", espeak, at_most=3.0, digits=2)
    for name in (k for k in negative if not k.startswith("N_speech_espeak")):
        rate = sets[name]["false_per_min"]
        floor(f"≤ 5 false events a minute on {name}", f"{rate:.2f}", rate <= 5.0)

    latency = {k: v["latency_ms_p95"] for k, v in positive.items() if v.get("latency_ms_p95") is not None}
    judged("decision latency p95 ≤ 30 ms on every set", latency, at_most=30.0, unit=" ms", digits=1)

    print("| floor | measured (worst set) | met | sets under it |")
    print("|---|---|---|---|")
    for what, measured, met, missed in rows:
        print(f"| {what} | {measured} | {'yes' if met else '**no**'} | {missed} |")
    unmet = sum(1 for row in rows if not row[2])
    print(f"\n{len(rows) - unmet} of {len(rows)} floors met")
    sys.exit(1 if unmet else 0)


if __name__ == "__main__":
    main()
