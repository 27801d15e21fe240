#!/usr/bin/env python3
"""The development sets of real recordings, each label enrolled from its first N takes.

Take 1 of each label is saved as `patterns/LABEL.wav`, as the sets save it, and takes
2..N as `more_takes/LABEL-K.wav` beside it; takes N+1 on are the instances. The
sequences are composed as the sets compose them (the same generator and seeds), from
those instances only, so the same folder scores one take and N takes on the same truth:

    ~/.cache/onomato-devsets-venv/bin/python scripts/more-takes.py 3 /tmp/more3
    bash ../shared/devsets/run.sh target/release/onomato /tmp/more3          # take 1 alone
    TAG=all bash ../shared/devsets/run.sh scripts/with-more-takes.sh /tmp/more3  # takes 1..N

`scripts/with-more-takes.sh` runs onomato with every take of `more_takes/` added to its
pattern (`--pattern LABEL=FILE` again adds a take). The sets: D1 (isolated hits of four
speakers, and zingerbox in noise), D2_beats_agh_isolated (loops, enrolled from the
isolated sounds), D6_knocks and N_speech_real (real speech with zingerbox's sounds
enrolled). A label with N takes or fewer keeps one instance at least: fewer of its takes
enrol. Uses the generator of ../shared/devsets (its venv, with numpy and soundfile, as
build.sh makes it).
"""

from real_sets import arguments, build, build_all


def main():
    n, out = arguments(2, __doc__)
    enrol = build.enrol
    save_set = build.save_set
    # The takes 2..N of the set being built, cut as the first is: {label: [signal, ...]}.
    more = {}

    def enrol_first_takes(classes, rule=build.onset_end):
        more.clear()
        first_and_instances = {}
        for label, items in classes.items():
            k = max(1, min(n, len(items) - 1))
            extra = []
            for item in items[1:k]:
                x, sr = item if isinstance(item, tuple) else build.mono(item)
                x = build.pad(x, sr)
                extra.append(build.cut(x, sr, *rule(x, sr)))
            more[label] = extra
            first_and_instances[label] = [items[0]] + list(items[k:])
        return enrol(first_and_instances, rule)

    def save_set_with_more_takes(folder, patterns, kinds, seqs, sr, about, *args, **kwargs):
        about += f" (here takes 1-{n} of each label enrol, takes 2-{n} in more_takes/: scripts/more-takes.py)"
        save_set(folder, patterns, kinds, seqs, sr, about, *args, **kwargs)
        (folder / "more_takes").mkdir()
        for label, takes in more.items():
            for k, x in enumerate(takes, start=2):
                build.write(folder / "more_takes" / f"{label}-{k}.wav", x, sr)

    build_all(out, enrol_first_takes, save_set_with_more_takes)


if __name__ == "__main__":
    main()
