#!/usr/bin/env python3
"""What deciding clear onsets over a shorter window first would gain (`docs/latency.md`).

Reads the explanations of two runs of `run.sh` over the same sets, one at the default
decision window and one at a shorter one (`decision_seconds` in a config), both with
`--explain`. The onset stage does not depend on the window, so each onset of the short
run is paired with the default run's onset at the same time (within 1 ms). An onset is
"clear" at the short window when it fired there on its first window with a best score
of at least T and a margin of at least M over the runner-up. For each (T, M) it prints
how many clear onsets the default run fired as the same pattern (they would be decided
sooner), how much sooner (the median of the two runs' `decided_at`), and how many the
default run decided otherwise for a reason that depends on the window (the background,
the threshold, another pattern, ...): each of those would be an event the default
detector does not make. Outcomes set by what came before (the speech guard, the quiet
before) are left out, since an early decision would see the same history.

    printf '[detector.spectral]\\ndecision_seconds = 0.015\\n' > /tmp/d15.toml
    TAG=exd bash ../shared/devsets/run.sh target/release/onomato /tmp/devsets --explain
    TAG=ex15 bash ../shared/devsets/run.sh target/release/onomato /tmp/devsets --explain \\
        --config /tmp/d15.toml
    python3 scripts/early-decision.py /tmp/devsets exd ex15

Needs only Python's standard library.
"""

import collections
import json
import pathlib
import statistics
import sys

# Outcomes that depend on what came before an onset, not on its window.
BY_HISTORY = {"speech_guard", "quiet_before"}
CLEAR = [(0.8, 0.2), (0.9, 0.2), (0.9, 0.3), (0.95, 0.3)]


def fail(message):
    print(f"early-decision.py: {message}", file=sys.stderr)
    sys.exit(2)


def onsets(path):
    try:
        return json.loads(path.read_text())["onsets"]
    except (OSError, ValueError, KeyError) as e:
        fail(f"{path}: expected the JSON of `analyze --explain --format json` ({e})")


def main():
    if len(sys.argv) != 4:
        fail("usage: early-decision.py SETS_DIR DEFAULT_TAG SHORT_TAG")
    sets, default_tag, short_tag = pathlib.Path(sys.argv[1]), sys.argv[2], sys.argv[3]
    if not sets.is_dir():
        fail(f"no sets folder {sets}")
    pairs = []
    for set_dir in sorted(p for p in sets.iterdir() if (p / "set.json").is_file()):
        for long_path in sorted(set_dir.glob(f"seq_*.{default_tag}.json")):
            short_path = long_path.with_name(long_path.name.replace(f".{default_tag}.", f".{short_tag}."))
            if not short_path.is_file():
                fail(f"{short_path} is missing: run run.sh with TAG={short_tag} and --explain")
            by_time = {round(o["time"], 3): o for o in onsets(long_path)}
            for short in onsets(short_path):
                for dt in (0.0, -0.001, 0.001):
                    long = by_time.get(round(short["time"] + dt, 3))
                    if long:
                        pairs.append((set_dir.name, short, long))
                        break
    if not pairs:
        fail(f"no explained onsets under {sets} for tags {default_tag} and {short_tag}")
    fired = sum(1 for _, _, long in pairs if long["outcome"] == "fired")
    print(f"{len(pairs)} onsets paired; the default run fired {fired}\n")
    print("| best score at least | margin at least | clear, fired alike by the default | "
          "decided sooner by (median, ms) | decided otherwise by the default, over the window | "
          "of which on speech sets | why |")
    print("|---|---|---|---|---|---|---|")
    for t, m in CLEAR:
        clear = [
            (name, short, long)
            for name, short, long in pairs
            if short["outcome"] == "fired"
            and short["waited_for"] is None
            and short["best_score"] >= t
            and short["best_score"] - (short["second_score"] or 0.0) >= m
        ]
        alike = [(s, l) for _, s, l in clear if l["outcome"] == "fired" and l["best"] == s["best"]]
        other = [
            (name, l)
            for name, s, l in clear
            if not (l["outcome"] == "fired" and l["best"] == s["best"]) and l["outcome"] not in BY_HISTORY
        ]
        sooner = statistics.median(1000 * (l["decided_at"] - s["decided_at"]) for s, l in alike) if alike else 0.0
        why = collections.Counter("another pattern" if l["outcome"] == "fired" else l["outcome"] for _, l in other)
        speech = sum(1 for name, _ in other if name.startswith("N_"))
        why_text = ", ".join(f"{k} {v}" for k, v in why.most_common())
        print(f"| {t} | {m} | {len(alike)} ({len(alike) / fired:.0%}) | {sooner:.1f} | {len(other)} | {speech} | {why_text} |")


if __name__ == "__main__":
    main()
