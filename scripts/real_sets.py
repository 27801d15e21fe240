"""The development sets' generator (../shared/devsets/build.py) and the builders of its
sets of real takes, for the scripts that build those sets enrolled otherwise
(`other-takes.py`, `more-takes.py`), which replace `build.enrol` and `build.save_set`
([`build_all`])."""

import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent.parent / "shared" / "devsets"))
import build  # noqa: E402  (the development sets' generator)

# D1 (isolated hits of four speakers, and zingerbox in noise), D2_beats_agh_isolated
# (loops, enrolled from the isolated sounds), D6_knocks and N_speech_real (real speech
# with zingerbox's sounds enrolled): the sets that enrol a take of several.
BUILDERS = [
    build.d1_zingerbox,
    lambda out: build.d1_mitrank(out, "a"),
    lambda out: build.d1_mitrank(out, "b"),
    build.d1_agh,
    build.d1_noise,
    build.d2_agh_isolated,
    build.d6_knocks,
    build.n_speech_real,
]


def build_all(out, enrol, save_set):
    """Builds every set of BUILDERS into `out`, with `enrol` and `save_set` in place of
    the generator's (each builder looks them up in its module at call time)."""
    build.enrol = enrol
    build.save_set = save_set
    for builder in BUILDERS:
        builder(out)


def arguments(least, usage):
    """The command line `NUMBER DIR` (NUMBER at least `least`; else exit with `usage`):
    the number and the folder, made if missing."""
    if len(sys.argv) != 3 or not sys.argv[1].isdigit() or int(sys.argv[1]) < least:
        sys.exit(usage)
    out = pathlib.Path(sys.argv[2])
    out.mkdir(parents=True, exist_ok=True)
    return int(sys.argv[1]), out
