#!/usr/bin/env python3
"""Would a sound's energy envelope tell apart what its spectrum confuses? (`docs/classify.md`)

For every positive set given, runs `onomato analyze --explain --format json` on each
take (its first onset is where the detector places the take) and on each sequence. For
every onset that fired on its first window, with a runner-up pattern and an annotated
sound within 50 ms, it compares the envelope after the onset with the envelope after
each of the two patterns' takes' placements: the energy in 2.9 ms blocks over the
first 23 ms, in dB under the window's loudest block (floored 30 dB down), the mean
absolute difference in dB at the best of three alignments (-1, 0, +1 block). Prints,
over the onsets fired as the wrong pattern where the truth was the runner-up, how many
the envelope puts nearer the truth, and over those fired right, how many it puts nearer
the runner-up; then the confusions met three times or more.

    ~/.cache/onomato-devsets-venv/bin/python scripts/envelope-at-placement.py \\
        target/release/onomato /tmp/devsets/D[1-6]_*

Needs numpy and soundfile (the dev sets' venv has both).
"""

import collections
import csv
import json
import pathlib
import statistics
import subprocess
import sys

import numpy as np
import soundfile

from set_patterns import pattern_args

BLOCK_SECONDS = 0.0029
BLOCKS = 8
FLOOR_DB = -30.0


def fail(message):
    print(f"envelope-at-placement.py: {message}", file=sys.stderr)
    sys.exit(2)


def explain(binary, set_dir, wav, patterns):
    """The onsets `analyze --explain` considers in `wav`, the set's patterns enrolled as run.sh enrols them."""
    args = [binary, "analyze", str(wav.resolve()), "--explain", "--format", "json", *patterns]
    run = subprocess.run(args, cwd=set_dir, capture_output=True, text=True)
    if run.returncode != 0:
        fail(f"analyze failed on {wav}: {run.stderr.strip()}")
    return json.loads(run.stdout)["onsets"]


def mono(path):
    samples, rate = soundfile.read(str(path))
    return (samples if samples.ndim == 1 else samples.mean(axis=1)), rate


def envelope(samples, rate, time):
    block = int(round(BLOCK_SECONDS * rate))
    start = max(int(round(time * rate)), 0)
    window = samples[start : start + block * BLOCKS]
    window = np.pad(window, (0, block * BLOCKS - len(window)))
    energy = (window.reshape(BLOCKS, block) ** 2).mean(axis=1) + 1e-20
    return np.maximum(10 * np.log10(energy / energy.max()), FLOOR_DB)


def distance(a, b):
    return min(
        np.mean(np.abs(a[s:] - b[: BLOCKS - s])) if s >= 0 else np.mean(np.abs(a[:s] - b[-s:]))
        for s in (-1, 0, 1)
    )


def main():
    if len(sys.argv) < 3:
        fail("usage: envelope-at-placement.py ONOMATO_BIN SET_DIR...")
    binary = str(pathlib.Path(sys.argv[1]).resolve())
    wrong, right = [], []
    confused = collections.defaultdict(list)
    for set_dir in map(pathlib.Path, sys.argv[2:]):
        try:
            kinds, patterns = pattern_args(set_dir)
        except (OSError, ValueError, KeyError) as e:
            fail(f"{set_dir}/set.json: expected a dev set's set.json with kinds ({e})")
        takes = {}
        for name, kind in kinds.items():
            if kind != "impulse":
                continue
            path = set_dir / "patterns" / f"{name}.wav"
            samples, rate = mono(path)
            placed = explain(binary, set_dir, path, patterns)
            takes[name] = envelope(samples, rate, placed[0]["time"] if placed else 0.005)
        for wav in sorted(set_dir.glob("seq_*.wav")):
            with open(wav.with_suffix(".csv")) as f:
                truth = [(float(r["onset_s"]), r["label"]) for r in csv.DictReader(f)]
            samples, rate = mono(wav)
            for onset in explain(binary, set_dir, wav, patterns):
                best, second = onset["best"], onset["second"]
                if onset["outcome"] != "fired" or onset["waited_for"] is not None:
                    continue
                if best not in takes or second not in takes:
                    continue
                near = [(abs(t - onset["time"]), label) for t, label in truth if abs(t - onset["time"]) <= 0.05]
                if not near:
                    continue
                label = min(near)[1]
                heard = envelope(samples, rate, onset["time"])
                to_best, to_second = distance(heard, takes[best]), distance(heard, takes[second])
                if label == second:
                    wrong.append((to_best, to_second))
                    confused[(set_dir.name, label, best)].append(to_second < to_best)
                elif label == best:
                    right.append((to_best, to_second))
    if not wrong and not right:
        fail("no fired onset with a runner-up near an annotated sound")
    print("| onsets fired on their first window | count | envelope nearer the runner-up | "
          "median dB distance to the fired take less to the runner-up's |")
    print("|---|---|---|---|")
    for what, rows in (("as another pattern, their truth the runner-up", wrong), ("as their truth", right)):
        nearer = sum(1 for b, s in rows if s < b)
        median = statistics.median(b - s for b, s in rows) if rows else 0.0
        print(f"| {what} | {len(rows)} | {nearer} | {median:.2f} |")
    print("\n| set | truth | fired as | onsets | envelope nearer the truth |")
    print("|---|---|---|---|---|")
    for (name, label, fired), nearer in sorted(confused.items(), key=lambda kv: -len(kv[1])):
        if len(nearer) >= 3:
            print(f"| {name} | {label} | {fired} | {len(nearer)} | {sum(nearer)} |")


if __name__ == "__main__":
    main()
