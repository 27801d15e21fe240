#!/usr/bin/env python3
"""The development sets of real recordings enrolled from another take: each label's
take number SHIFT + 1 enrols (take 2 with SHIFT 1, take 3 with SHIFT 2; the count
wraps round a label with fewer takes) and every other take, the first among them,
is an instance. The sequences are composed as the sets compose them (the same
generator and seeds), so what changes is which recording of each sound the detector
was given and which it must find. A check that a change does not hold only for the
takes that happen to enrol the development sets. Uses the generator of
../shared/devsets (its venv, with numpy and soundfile, as build.sh makes it).

    ~/.cache/onomato-devsets-venv/bin/python scripts/other-takes.py 1 /tmp/takes1
    bash ../shared/devsets/run.sh target/release/onomato /tmp/takes1

The sets: D1 (isolated hits of four speakers, and zingerbox in noise), D2_beats_agh_isolated
(loops, enrolled from the isolated sounds), D6_knocks and N_speech_real (real speech with
zingerbox's sounds enrolled). D3, D4 and D5 enrol from their only take or from
synthesis, and D2's other sets from the loops themselves.

Keep it a check: a setting chosen on these sets is fitted to them as well.
"""

import inspect

from real_sets import arguments, build, build_all


def main():
    shift, out = arguments(1, __doc__)
    enrol = build.enrol

    def enrol_other_take(classes, *args, **kwargs):
        rotated = {}
        for label, items in classes.items():
            k = shift % len(items)
            rotated[label] = list(items[k:]) + list(items[:k])
        return enrol(rotated, *args, **kwargs)

    save_set = build.save_set

    def save_set_saying_so(*args, **kwargs):
        bound = inspect.signature(save_set).bind(*args, **kwargs)
        bound.arguments["about"] += f" (here each label's take {shift + 1} enrols instead: scripts/other-takes.py)"
        return save_set(*bound.args, **bound.kwargs)

    build_all(out, enrol_other_take, save_set_saying_so)


if __name__ == "__main__":
    main()
