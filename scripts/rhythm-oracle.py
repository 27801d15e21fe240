#!/usr/bin/env python3
"""How much of each rhythm word's own sound its first decision window holds.

The voice protocol's rhythm (seq_02 of every D4_voice_* set, of ../shared/devsets and of
scripts/other-voices.py) sums words 0.2 s apart, so a word often begins under the one
before it. The sets' generator is deterministic, so this script builds each rhythm again
word by word, checks that the words summed with the noise give the set's seq_02.wav to
within two 16-bit steps, and measures for every word the power of its own samples over
the power of everything else (the other words and the noise) over its first 25 ms (the
detector's decision window) and its first 50 ms (the scoring's tolerance), from its
annotated onset. It then runs `onomato analyze` on the rhythm and counts the words found
(a detection of the word's label within 50 ms, the dev sets' scoring rule).

A word whose first 25 ms hold less of its own sound than of the rest cannot be told
from the mixture by what those 25 ms sound like; the last two columns are the F1 a
detector would reach that found every other word (over 25 ms, over 50 ms) and made no
false event.

    ~/.cache/onomato-devsets-venv/bin/python scripts/rhythm-oracle.py target/release/onomato \\
        /tmp/devsets/D4_voice_* /tmp/other-voices/D4_voice_* /tmp/more-voices/D4_voice_*

Needs the dev sets' Python (numpy, soundfile) and espeak-ng and sox, as the sets do.
"""

import csv
import importlib.util
import json
import os
import pathlib
import subprocess
import sys
import tempfile

import numpy as np
import soundfile as sf

HERE = pathlib.Path(__file__).resolve().parent
DEVSETS = HERE.parent.parent / "shared" / "devsets"
sys.path.insert(0, str(DEVSETS))
import build  # noqa: E402  (the development sets' generator)



def sibling(name, file):
    """A script beside this one, loaded as a module."""
    spec = importlib.util.spec_from_file_location(name, HERE / file)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


other_voices = sibling("other_voices", "other-voices.py")
rhythm_misses = sibling("rhythm_misses", "rhythm-misses.py")

WINDOWS_S = (0.025, 0.05)
STEP = 2.0 / 32768  # two 16-bit steps


def rhythm_words(voice, short, words):
    """The rhythm's words as build.d4_voice places them: [(onset_s, label, samples)], the
    noise, and the sample rate. build.compose is replaced by one that keeps each word
    apart and draws from the generator exactly as it does."""
    kept = []

    def compose(rng, takes, sr, length_s, gap_range, gain_db, noise_db, rhythm=None, order=None):
        n = int(length_s * sr)
        parts, t, k = [], 0.3, 0
        while True:
            label, x, on, end, kind = takes[rng.integers(len(takes))]
            if rhythm is not None:
                t = rhythm[k] if k < len(rhythm) else 1e9
            start = max(0, int((t - on) * sr))
            if start + len(x) >= n - int(0.3 * sr):
                break
            g = 10 ** (rng.uniform(*gain_db) / 20)
            y = np.zeros(n)
            y[start:start + len(x)] = g * x
            parts.append((start / sr + on, label, y))
            k += 1
            if rhythm is None:
                t = start / sr + on + (end - on) + rng.uniform(*gap_range)
        noise = 10 ** (noise_db / 20) * rng.standard_normal(n)
        kept.append((parts, noise, sr, rhythm is not None))
        return noise, []

    real_compose, real_save = build.compose, build.save_set
    build.compose, build.save_set = compose, lambda *a, **k: None
    try:
        with tempfile.TemporaryDirectory() as d:
            build.d4_voice(pathlib.Path(d), voice, short, words)
    finally:
        build.compose, build.save_set = real_compose, real_save
    parts, noise, sr, _ = next(k for k in kept if k[3])
    return parts, noise, sr


def f1_finding(words_found, words):
    """F1 of a detector that finds those words and no other, and makes no false event."""
    recall = words_found / words
    return 2 * recall / (1 + recall)


def main():
    if len(sys.argv) < 3:
        sys.exit("usage: rhythm-oracle.py ONOMATO_BIN D4_SET_DIR...")
    binary, sets = sys.argv[1], sys.argv[2:]
    voices = {short: (voice, words) for voice, short, words in
              build.VOICES + other_voices.VOICES + other_voices.MORE_VOICES}
    print("| voice | words | own sound over the rest in the first 25 ms | in the first 50 ms "
          "| found | found of those over the rest in 25 ms | F1 finding those of 25 ms alone | of 50 ms alone |")
    print("|---|---|---|---|---|---|---|---|")
    totals = np.zeros(5, int)
    for set_dir in sets:
        short = os.path.basename(os.path.normpath(set_dir)).removeprefix("D4_voice_")
        if short not in voices:
            sys.exit(f"rhythm-oracle.py: {set_dir}: no voice '{short}' in the dev sets' or "
                     "scripts/other-voices.py's lists")
        voice, words = voices[short]
        parts, noise, sr = rhythm_words(voice, short, words)
        total = noise + sum(y for _, _, y in parts)
        peak = np.abs(total).max()
        if peak > 0.99:
            total *= 0.99 / peak
            parts = [(on, label, y * 0.99 / peak) for on, label, y in parts]
        seq = os.path.join(set_dir, "seq_02.wav")
        heard, heard_sr = sf.read(seq)
        if heard_sr != sr or len(heard) != len(total) or np.abs(heard - total).max() > STEP:
            sys.exit(f"rhythm-oracle.py: {seq}: not the rhythm this voice's words give "
                     "(built by another version of the generator?)")
        with open(os.path.join(set_dir, "seq_02.csv"), newline="") as f:
            truth = [(float(r["onset_s"]), r["label"]) for r in csv.DictReader(f)]
        if [(round(on, 4), label) for on, label, _ in parts] != [(round(t, 4), l) for t, l in truth]:
            sys.exit(f"rhythm-oracle.py: {set_dir}: the words rebuilt are not seq_02.csv's")
        run = subprocess.run([binary, "analyze", seq, *rhythm_misses.pattern_args(set_dir), "--format", "json"],
                             capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"rhythm-oracle.py: analyze failed on {seq}: {run.stderr.strip()}")
        events = json.loads(run.stdout)["events"]
        own = {w: 0 for w in WINDOWS_S}
        found = found_own = 0
        for on, label, y in parts:
            at = int(round(on * sr))
            holds = {}
            for w in WINDOWS_S:
                span = slice(at, at + int(w * sr))
                holds[w] = np.sum(y[span] ** 2) >= np.sum((total[span] - y[span]) ** 2)
                own[w] += holds[w]
            hit = any(e["pattern"] == label and abs(e["time"] - on) <= 0.05 for e in events)
            found += hit
            found_own += hit and holds[WINDOWS_S[0]]
        n = len(parts)
        print(f"| {short} | {n} | {own[WINDOWS_S[0]]} | {own[WINDOWS_S[1]]} | {found} | {found_own} "
              f"| {f1_finding(own[WINDOWS_S[0]], n):.2f} | {f1_finding(own[WINDOWS_S[1]], n):.2f} |")
        totals += [n, own[WINDOWS_S[0]], own[WINDOWS_S[1]], found, found_own]
    n, o25, o50, found, found_own = totals
    print(f"| all | {n} | {o25} | {o50} | {found} | {found_own} | {f1_finding(o25, n):.2f} "
          f"| {f1_finding(o50, n):.2f} |")


if __name__ == "__main__":
    main()
