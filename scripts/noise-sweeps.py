#!/usr/bin/env python3
"""The noise sweep of D1_noise_zingerbox, made from the other speakers' isolated hits:
for the AGH kit and both mitrank name sets, one sequence of 20 s at each noise level
(-60, -50, -45, -40 and -35 dB), hits 30-300 ms apart at -6..0 dB, take 1 of each label
enrolling, as the development sets' generator makes zingerbox's (its `compose`, seeded
by each set's name). A check that the onset stage's noise floors hold for other voices
than the one the floors were set on. Uses the generator of ../shared/devsets (its venv,
with numpy and soundfile, as build.sh makes it).

    ~/.cache/onomato-devsets-venv/bin/python scripts/noise-sweeps.py /tmp/noise-sweeps
    bash ../shared/devsets/run.sh target/release/onomato /tmp/noise-sweeps
    python3 scripts/floors.py /tmp/noise-sweeps

Keep it a check: a setting chosen on these sets is fitted to them as well.
"""

import pathlib
import sys

from real_sets import build

LEVELS = [-60, -50, -45, -40, -35]


def mitrank(group):
    base = build.DATA / "mitrank_kit" / group
    classes = {c: sorted((base / c).glob("*.wav")) for c in ("kick", "hats", "snare")}
    rule = build.onset_end_noisy if group == "a" else build.onset_end
    return classes, rule


def sweep(out, name, classes, rule, who):
    rng = build.rng_for(name)
    patterns, takes, kinds, sr = build.enrol(classes, rule)
    seqs = [build.compose(rng, takes, sr, 20, (0.03, 0.3), (-6, 0), db) for db in LEVELS]
    build.save_set(out / name, patterns, kinds, seqs, sr,
                   about=f"{who} isolated hits, gaps 0.03-0.3 s, gains -6..0 dB; seq_00..04 noise "
                         + ", ".join(f"{d} dB" for d in LEVELS) + " (scripts/noise-sweeps.py)")


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = pathlib.Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    sweep(out, "D1_noise_agh", build.agh_takes(), build.onset_end, "AGH BeatboxBasics")
    for group in ("a", "b"):
        classes, rule = mitrank(group)
        sweep(out, f"D1_noise_mitrank_{group}", classes, rule, f"mitrank name set '{group}'")


if __name__ == "__main__":
    main()
