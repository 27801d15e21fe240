#!/usr/bin/env python3
"""How near to a take's waveform the sounds of a set come: the measurement behind the
copies stage's constants (`src/detect/copies.rs`, `docs/classify.md` "Exact copies by
their waveform").

For every set folder given (the dev sets' format), the normalised cross-correlation of
each impulse take's first SPAN seconds from its start with the sequence, at the best lag
within 25 ms of a point, as the stage computes it (here at the files' own rate):

- at every onset `onomato analyze --explain` reports that did not fire: the highest
  similarity any take reaches, with the takes that take part in the stage (enough
  independent samples) and with every take;
- with `--copies`, at every annotated onset, against its own take: the lowest (the sets
  of exact copies, where every instance is a take).

    ~/.cache/onomato-devsets-venv/bin/python scripts/copy-similarity.py \\
        target/release/onomato [--copies] [--span 0.25] SET_DIR...

Needs numpy and soundfile (the dev sets' venv has both). Prints one Markdown row a set.
"""

import argparse
import csv
import json
import pathlib
import subprocess
import sys

import numpy as np
import soundfile as sf

SCORE = pathlib.Path(__file__).resolve().parent.parent.parent / "shared" / "devsets" / "score.py"
MAX_LAG_SECONDS = 0.025
COPY_SIMILARITY = 0.9


def mono(path):
    x, rate = sf.read(str(path), dtype="float64")
    return (x.mean(axis=1) if x.ndim > 1 else x), rate


def independent_samples(x):
    """Length over the sum of the squared normalised autocorrelation (every lag)."""
    n = len(x)
    spectrum = np.fft.rfft(x, 2 * n)
    acf = np.fft.irfft(np.abs(spectrum) ** 2)[:n]
    if acf[0] <= 0:
        return 0.0
    rho = acf / acf[0]
    return n / (1.0 + 2.0 * np.sum(rho[1:] ** 2))


def best_similarity(x, take, at, lag):
    """Highest normalised cross-correlation of `take` with x starting within `lag` of `at`."""
    start = max(0, at - lag)
    segment = x[start:at + lag + len(take)]
    if len(segment) < len(take):
        return 0.0
    count = len(segment) - len(take) + 1
    numerator = np.correlate(segment, take, mode="valid")
    squares = np.concatenate([[0.0], np.cumsum(segment ** 2)])
    window = np.sqrt(squares[len(take):len(take) + count] - squares[:count])
    r = numerator / (window * np.linalg.norm(take) + 1e-12)
    return float(r.max())


def pattern_args(folder):
    out = subprocess.run([sys.executable, str(SCORE), "--pattern-args", str(folder)],
                         capture_output=True, text=True, check=True).stdout
    return [a for a in out.splitlines() if a]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("onomato")
    parser.add_argument("sets", nargs="+", type=pathlib.Path)
    parser.add_argument("--copies", action="store_true")
    parser.add_argument("--span", type=float, default=0.25)
    args = parser.parse_args()
    enough = (3.0 / COPY_SIMILARITY) ** 2
    print("| set | onsets not fired | highest, takes that take part | highest, every take | copies: lowest with its own take |")
    print("|---|---|---|---|---|")
    for folder in args.sets:
        kinds = json.loads((folder / "set.json").read_text())["kinds"]
        takes = {}
        for name, kind in kinds.items():
            if kind == "impulse":
                y, rate = mono(folder / "patterns" / f"{name}.wav")
                takes[name] = y[:int(args.span * rate)]
        taking_part = {n for n, t in takes.items() if independent_samples(t) >= enough}
        count, best_part, best_any, lowest_copy = 0, (0.0, "-"), (0.0, "-"), (1.0, "-")
        extra = pattern_args(folder)
        for wav in sorted(folder.glob("seq_*.wav")):
            x, rate = mono(wav)
            lag = int(MAX_LAG_SECONDS * rate)
            run = subprocess.run([args.onomato, "analyze", str(wav), *extra, "--explain",
                                  "--format", "json"], capture_output=True, text=True, check=True)
            onsets = json.loads(run.stdout[run.stdout.index("{"):])["onsets"]
            for onset in onsets:
                if onset["outcome"] in ("fired", "same_onset", "copy"):
                    continue
                count += 1
                at = int(onset["time"] * rate)
                for name, take in takes.items():
                    s = best_similarity(x, take, at, lag)
                    where = f"{wav.stem} {onset['time']:.2f} s {name}"
                    if s > best_any[0]:
                        best_any = (s, where)
                    if name in taking_part and s > best_part[0]:
                        best_part = (s, where)
            if args.copies:
                for row in csv.DictReader(open(wav.with_suffix(".csv"))):
                    if row["label"] in takes:
                        s = best_similarity(x, takes[row["label"]], int(float(row["onset_s"]) * rate), lag)
                        if s < lowest_copy[0]:
                            lowest_copy = (s, f"{wav.stem} {float(row['onset_s']):.2f} s {row['label']} at {float(row['gain']):.2f}")
        copies = f"{lowest_copy[0]:.3f} ({lowest_copy[1]})" if args.copies else "-"
        print(f"| {folder.name} | {count} | {best_part[0]:.3f} ({best_part[1]}) | "
              f"{best_any[0]:.3f} ({best_any[1]}) | {copies} |")


if __name__ == "__main__":
    main()
