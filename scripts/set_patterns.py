"""The `--pattern` arguments of a set in the dev sets' format (../shared/devsets/README.md),
for the scripts that run `onomato analyze` on its sequences themselves (run from the
set's folder: the paths are relative to it)."""

import json
import os


def pattern_args(folder):
    """The set's kinds ({label: "impulse" or "continuous"}) and the `--pattern
    LABEL=patterns/LABEL.wav[:continuous]` arguments that enrol them."""
    kinds = json.load(open(os.path.join(folder, "set.json")))["kinds"]
    args = []
    for label, kind in kinds.items():
        suffix = ":continuous" if kind == "continuous" else ""
        args += ["--pattern", f"{label}=patterns/{label}.wav{suffix}"]
    return kinds, args
