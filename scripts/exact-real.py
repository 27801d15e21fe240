#!/usr/bin/env python3
"""The exact-copies protocol (D5_exact) on the real sets' own takes: for each set of
real recordings among the development sets, a set whose sequences are exact copies of
its enrolled takes (its `patterns/*.wav` as they are, room noise, hum and all) at
-12..0 dB, gaps 80-500 ms, in white noise 50 dB down, written as 32-bit float at the
takes' own rate. D5_exact itself copies three espeak-ng words; the takes of real
performers open on a room, a click or a beat's bleed instead, and the copies must be
found all the same. Uses the generator of ../shared/devsets (its venv, with numpy and
soundfile, as build.sh makes it).

    ~/.cache/onomato-devsets-venv/bin/python scripts/exact-real.py /tmp/devsets /tmp/exact-real
    bash ../shared/devsets/run.sh target/release/onomato /tmp/exact-real

A copy's onset is where its take's sound begins: every such take is cut 5 ms before
its annotated onset (../shared/devsets/build.py, `cut` and `beat_cut`). Held sounds
(continuous patterns) are left out, as in D5_exact. A set of more than five takes
gets a sequence of 15 s per five takes, so that each take is copied as often.
"""

import json
import pathlib
import sys

import soundfile as sf

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "shared" / "devsets"))
sys.path.insert(0, str(HERE))  # exact_copies.py, also when loaded from another folder
import build  # noqa: E402  (the development sets' generator)
from exact_copies import sequences as copies_sequences  # noqa: E402

# The real sets whose takes are copied.
REAL_SETS = [
    "D1_isolated_zingerbox",
    "D1_isolated_mitrank_a",
    "D1_isolated_mitrank_b",
    "D1_isolated_agh",
    "D2_beats_rsalazar",
    "D2_beats_agh",
    "D3_dictionary_marcin",
    "D6_knocks",
]
# Where a take's sound begins in its file (build.py cuts every take so).
ONSET_IN_TAKE_S = 0.005
TAKES_PER_SEQ = 5


def read_takes(folder):
    """{label: samples} of the set's impulse patterns, and their common rate."""
    kinds = json.loads((folder / "set.json").read_text())["kinds"]
    takes, rate = {}, None
    for label, kind in sorted(kinds.items()):
        if kind != "impulse":
            continue
        path = folder / "patterns" / f"{label}.wav"
        try:
            x, sr = sf.read(str(path), dtype="float64", always_2d=True)
        except (OSError, RuntimeError) as e:  # soundfile raises LibsndfileError, a RuntimeError
            raise build.BuildError(f"cannot read {path}: {e}") from e
        if rate is not None and sr != rate:
            raise build.BuildError(f"{path} is at {sr} Hz, the set's other takes at {rate} Hz")
        rate = sr
        takes[label] = x.mean(axis=1)
    if not takes:
        raise build.BuildError(f"{folder} has no impulse pattern to copy")
    return takes, rate


def exact_copies(folder, out):
    """A D5_exact-like set of exact copies of `folder`'s takes, in `out`."""
    takes, sr = read_takes(folder)
    name = "D5_exact_" + folder.name.split("_", 1)[1]
    rng = build.rng_for(name)
    seqs = copies_sequences(rng, takes, sr, max(2, -(-len(takes) // TAKES_PER_SEQ)), ONSET_IN_TAKE_S)
    build.save_set(out / name, takes, {k: "impulse" for k in takes}, seqs, sr, subtype="FLOAT",
                   digits=6, about=f"exact copies of the takes of {folder.name}; onset 5 ms into each copy")


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sets, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    missing = [s for s in REAL_SETS if not (sets / s / "set.json").is_file()]
    if missing:
        sys.exit(f"exact-real.py: {sets} lacks {', '.join(missing)} (bash ../shared/devsets/build.sh {sets})")
    out.mkdir(parents=True, exist_ok=True)
    for s in REAL_SETS:
        try:
            exact_copies(sets / s, out)
        except (build.BuildError, KeyError, ValueError) as e:
            sys.exit(f"exact-real.py: {sets / s}: {e}")


if __name__ == "__main__":
    main()
