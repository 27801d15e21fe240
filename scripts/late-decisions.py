#!/usr/bin/env python3
"""Why decisions come later than 30 ms, set by set (`docs/latency.md`).

Reads what `run.sh` wrote (the summary and each sequence's detections) and matches each
detection to its truth with the dev sets' scorer (same label, closest pairs first,
within 50 ms). For every set whose decision latency p95 exceeds 30 ms it counts the
matched impulses decided more than 30 ms after their annotated onset (`emitted_at` less
the truth's onset), and splits them by why: a decision that waited more than 30 ms
after the onset the detector placed (a pair of patterns alike at first, decided over as
many windows as part them; a word over a fired word's tail, judged over two; a word
dated back to where its soft start began), and an onset placed 3 ms or more after its annotation (by
label). Prints a Markdown table; then, for each set with onsets placed late, how far
the first 10 ms after those annotated onsets stand over the 40-10 ms before them (the
room) and under the loudest 5 ms of the sound (up to 100 ms on, or the next annotated
onset), and how late the onsets were placed (medians, and the 90th percentile of the
placement), read from the 16-bit PCM sequences.

    bash ../shared/devsets/build.sh /tmp/devsets
    bash ../shared/devsets/run.sh target/release/onomato /tmp/devsets
    python3 scripts/late-decisions.py /tmp/devsets [TAG]

TAG names the detection files and the summary as run.sh does (default `dev`). Needs only
Python's standard library and ../shared/devsets/score.py.
"""

import array
import importlib.util
import math
import json
import pathlib
import statistics
import sys
import wave

SCORE = pathlib.Path(__file__).resolve().parent.parent.parent / "shared" / "devsets" / "score.py"
LATE = 0.030
PLACED_LATE = 0.003


def fail(message):
    print(f"late-decisions.py: {message}", file=sys.stderr)
    sys.exit(2)


def scorer():
    if not SCORE.is_file():
        fail(f"{SCORE}: no such file (the dev sets' scorer)")
    spec = importlib.util.spec_from_file_location("score", SCORE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def power_db(samples, rate, start, end):
    """Mean power (dB) of `samples` from `start` to `end` seconds."""
    a, b = max(0, int(start * rate)), max(0, int(end * rate))
    chunk = samples[a:b]
    if not chunk:
        return float("nan")
    return 10 * math.log10(sum(x * x for x in chunk) / len(chunk) + 1e-20)


def read_pcm16(path):
    """The samples of a 16-bit PCM mono WAV, or None for any other kind."""
    with wave.open(str(path)) as w:
        if w.getsampwidth() != 2 or w.getnchannels() != 1:
            return None, None
        frames = w.readframes(w.getnframes())
        return [v / 32768 for v in array.array("h", frames)], w.getframerate()


def instance_levels(samples, rate, onset, next_onset):
    """How far the first 10 ms after `onset` stand over the 40-10 ms before it, and
    under the loudest 5 ms of the sound (to 100 ms on, or `next_onset`)."""
    first = power_db(samples, rate, onset, onset + 0.010)
    room = power_db(samples, rate, onset - 0.040, onset - 0.010)
    end = min(onset + 0.100, next_onset)
    blocks = [power_db(samples, rate, t, t + 0.005) for t in frange(onset, end - 0.005, 0.005)]
    loudest = max(blocks) if blocks else first
    return first - room, loudest - first


def frange(start, stop, step):
    t = start
    while t <= stop:
        yield t
        t += step


def main():
    if len(sys.argv) not in (2, 3):
        fail("usage: late-decisions.py SETS_DIR [TAG]")
    sets, tag = pathlib.Path(sys.argv[1]), sys.argv[2] if len(sys.argv) == 3 else "dev"
    summary_path = sets / f"summary.{tag}.json"
    if not summary_path.is_file():
        fail(f"{summary_path}: no summary (run ../shared/devsets/run.sh with TAG={tag} first)")
    summary = json.loads(summary_path.read_text())["sets"]
    score = scorer()
    print("| set | matched impulses | latency p95 (ms) | decided over 30 ms after the annotated onset"
          " | of which the decision waited (over 30 ms after the onset's time)"
          " | of which placed 3 ms or more after the annotated onset | those by label |")
    print("|---|---|---|---|---|---|---|")
    levels = []
    for name, result in sorted(summary.items()):
        p95 = result.get("latency_ms_p95")
        if result.get("negative") or p95 is None or p95 <= LATE * 1000:
            continue
        matched = late = waited = placed_late = 0
        by_label = {}
        measured = []
        for truth_path in sorted((sets / name).glob("seq_*.csv")):
            detections_path = truth_path.with_suffix(f".{tag}.json")
            if not detections_path.is_file():
                fail(f"{detections_path}: no detections")
            truth = score.load_truth(truth_path)
            detections = score.load_detections(detections_path)
            samples, rate = read_pcm16(truth_path.with_suffix(".wav"))
            onsets = sorted(r["t"] for r in truth)
            for i, j in score.match(truth, detections):
                t, d = truth[i], detections[j]
                if t["end"] is not None or d["emitted"] is None:
                    continue
                matched += 1
                if d["emitted"] - t["t"] <= LATE:
                    continue
                late += 1
                waited += d["emitted"] - d["t"] > LATE
                if d["t"] - t["t"] >= PLACED_LATE:
                    placed_late += 1
                    by_label[t["label"]] = by_label.get(t["label"], 0) + 1
                    if samples is not None:
                        later = [o for o in onsets if o > t["t"]]
                        over_room, under_loudest = instance_levels(
                            samples, rate, t["t"], later[0] if later else t["t"] + 1.0)
                        measured.append((over_room, under_loudest, d["t"] - t["t"]))
        labels = ", ".join(f"{n} {label}" for label, n in sorted(by_label.items(), key=lambda x: -x[1]))
        print(f"| {name} | {matched} | {p95:.1f} | {late} | {waited} | {placed_late} | {labels} |")
        if measured:
            placed = sorted(m[2] for m in measured)
            levels.append(
                f"- {name}: the first 10 ms {statistics.median(m[0] for m in measured):.1f} dB over the"
                f" room, {statistics.median(m[1] for m in measured):.1f} dB under the loudest 5 ms;"
                f" placed {1000 * statistics.median(placed):.1f} ms after the annotation"
                f" (90th percentile {1000 * placed[math.ceil(0.9 * len(placed)) - 1]:.1f} ms)")
    if levels:
        print()
        print("\n".join(levels))


if __name__ == "__main__":
    main()
