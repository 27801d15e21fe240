"""The sequences of the exact-copies protocol (D5_exact in ../shared/devsets/build.py):
exact copies of takes at -12..0 dB, gaps 80-500 ms, in white noise 50 dB down, 15 s
each. Shared by `other-voices.py --exact` (espeak-ng words) and `exact-real.py` (the
real sets' own takes)."""

import numpy as np


def sequences(rng, takes, sr, count, onset_in_take=0.0):
    """`count` sequences of copies of `takes` ({label: samples} at `sr`), each with its
    truth rows (onset, label, "", gain); a copy's onset lies `onset_in_take` seconds
    into it. Draws from `rng` as build.py's d5_exact does."""
    names = sorted(takes)
    seqs = []
    for _ in range(count):
        n = int(15 * sr)
        s = 10 ** (-50 / 20) * rng.standard_normal(n)
        rows, t = [], int(0.3 * sr)
        while True:
            k = names[rng.integers(len(names))]
            p = takes[k]
            if t + len(p) > n - sr // 5:
                break
            g = 10 ** (rng.uniform(-12, 0) / 20)
            s[t:t + len(p)] += g * p
            rows.append((t / sr + onset_in_take, k, "", g))
            t += len(p) + int(rng.uniform(0.08, 0.5) * sr)
        seqs.append((s, rows))
    return seqs
