#!/usr/bin/env python3
"""The dev sets' beats protocol (D2) with the templates cut from other loops.

D2_beats_agh cuts each label's template from the first AGH loop that has it, in the
library's order, and tests on the loops it did not cut from; D2_beats_rsalazar cuts
them from rec2 and tests on rec3, rec4 and rec6. Which loop enrols is one choice among
several. This script makes the same sets with each other choice, using the dev sets'
own generator (its loops, annotations, cut and writer):

- `D2_beats_agh_from_<loop>`: the library's loops in turn, starting from each loop
  (the first start is D2_beats_agh itself, made again and checked file by file);
- `D2_beats_rsalazar` (made again and checked the same way), then
  `D2_beats_rsalazar_from_rec3` and `_from_rec4`: rsalazar's templates cut from rec3 or
  from rec4 (its labels moved one step, as the dev set does) instead of rec2, tested on
  the other two of rec2, rec3 and rec4, and rec6. rec6's labels that the source lacks
  are cut from their first onset in rec6 and that span blanked, as the dev set does.

    ~/.cache/onomato-devsets-venv/bin/python scripts/other-loops.py /tmp/other-loops
    bash ../shared/devsets/run.sh target/release/onomato /tmp/other-loops

Needs the dev sets' Python (numpy, soundfile) and ../shared/data.
"""

import filecmp
import pathlib
import sys
import tempfile

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "shared" / "devsets"))
import build  # noqa: E402  (the development sets' generator)


def agh_from(out, start):
    """D2_beats_agh with the loops taken from `start` on (wrapping round); returns the set's folder."""
    loops = build.agh_loops()
    order = loops[start:] + loops[:start]
    patterns, used, seqs, sr0 = {}, set(), [], None
    for wav, truth in order:
        x, sr0 = build.mono(wav)
        for i, (_, label) in enumerate(truth):
            if label not in patterns:
                a, b = build.beat_cut(x, sr0, truth, i)
                patterns[label] = x[a:b]
                used.add(wav)
    tests = [(wav, t) for wav, t in order if wav not in used]
    for wav, truth in tests:
        y, _ = build.mono(wav)
        seqs.append((y, [(on, label, "", 1.0) for on, label in truth]))
    folder = out / ("D2_beats_agh" if start == 0 else f"D2_beats_agh_from_{order[0][0].stem}")
    build.save_set(folder, patterns, {k: "impulse" for k in patterns}, seqs, sr0,
                   about="AGH pattern loops: templates from " + ", ".join(w.stem for w in sorted(used))
                         + "; seqs: " + ", ".join(w.stem for w, _ in tests))
    return folder


def rsalazar_truth(base, rec):
    truth = build.read_truth(base / f"rsalazar_rec{rec}.csv")
    if rec == 4:  # its derived labels are one step late (../shared/data/beatbox/README.md)
        truth = [(on, truth[i + 1 if i + 1 < len(truth) else i + 1 - 16][1]) for i, (on, _) in enumerate(truth)]
    return truth


def rsalazar_from(out, source):
    """D2_beats_rsalazar with the templates cut from rec`source`."""
    name = "D2_beats_rsalazar" if source == 2 else f"D2_beats_rsalazar_from_rec{source}"
    rng = build.rng_for(name)
    base = build.DATA / "beatbox/beats"
    x, sr = build.mono(base / f"rsalazar_rec{source}.wav")
    truth = rsalazar_truth(base, source)
    patterns = {}
    for i, (_, label) in enumerate(truth):
        if build.clean(label) not in patterns:
            a, b = build.beat_cut(x, sr, truth, i)
            patterns[build.clean(label)] = x[a:b]
    seqs, tested = [], [r for r in (2, 3, 4) if r != source] + [6]
    for rec in tested:
        y, sr_y = build.mono(base / f"rsalazar_rec{rec}.wav")
        if sr_y != sr:
            raise build.BuildError(f"rsalazar_rec{rec}.wav is at {sr_y} Hz, rec{source} at {sr} Hz")
        t = rsalazar_truth(base, rec)
        rows = []
        for i, (on, label) in enumerate(t):
            key = build.clean(label)
            if key not in patterns:
                a, b = build.beat_cut(y, sr, t, i)
                patterns[key] = y[a:b].copy()
                lo = max(0, int((on - 0.02) * sr))
                y[lo:b] = 10 ** (-60 / 20) * rng.standard_normal(b - lo)
                continue
            rows.append((on, key, "", 1.0))
        seqs.append((y, rows))
    folder = out / name
    build.save_set(folder, patterns, {k: "impulse" for k in patterns},
                   seqs, sr, about=f"rsalazar beats: templates from rec{source} (labels the beat lacks from their "
                                   f"first rec6 onset, blanked); seqs " + ", ".join(f"rec{r}" for r in tested))
    return folder


def check_is_dev_set(folder, make):
    """A set made here that is the dev set's own choice must be that set, file by file, as build.py makes it."""
    with tempfile.TemporaryDirectory() as tmp:
        make(pathlib.Path(tmp))
        theirs = pathlib.Path(tmp) / folder.name
        names = sorted(p.relative_to(folder) for p in folder.rglob("*") if p.is_file() and p.name != "set.json")
        their_names = sorted(p.relative_to(theirs) for p in theirs.rglob("*") if p.is_file() and p.name != "set.json")
        if names != their_names or not all(filecmp.cmp(folder / n, theirs / n, shallow=False) for n in names):
            sys.exit(f"other-loops.py: {folder} is not {folder.name} as build.py makes it")


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: other-loops.py OUT_DIR")
    out = pathlib.Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    try:
        for start in range(len(build.agh_loops())):
            folder = agh_from(out, start)
            if start == 0:
                check_is_dev_set(folder, build.d2_agh)
        for source in (2, 3, 4):
            folder = rsalazar_from(out, source)
            if source == 2:
                check_is_dev_set(folder, build.d2_rsalazar)
    except build.BuildError as e:
        sys.exit(f"other-loops.py: {e}")
    print(f"other-loops.py: sets in {out}")


if __name__ == "__main__":
    main()
