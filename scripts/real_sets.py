"""The development sets' generator (../shared/devsets/build.py) and the builders of its
sets of real takes, for the scripts that build those sets enrolled otherwise
(`other-takes.py`, `more-takes.py`). They patch `build.enrol` and `build.save_set`,
which the builders look up in their module at call time."""

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
