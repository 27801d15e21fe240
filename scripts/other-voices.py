#!/usr/bin/env python3
"""Sets of the development sets' voice protocol (D4_voice_*, N_speech_espeak_*) for
espeak-ng voices that no development set uses: a check that a change carries over to
voices it was not chosen on. Uses the generator of ../shared/devsets (its venv, with
numpy and soundfile, as build.sh makes it), espeak-ng and sox.

    ~/.cache/onomato-devsets-venv/bin/python scripts/other-voices.py /tmp/other-voices
    bash ../shared/devsets/run.sh target/release/onomato /tmp/other-voices

With --more, six further voices instead (none of them the first six's), for a second
check of a change the first six had a say in:

    ~/.cache/onomato-devsets-venv/bin/python scripts/other-voices.py --more /tmp/more-voices

With --exact, the exact-copies protocol (D5_exact: copies of the takes at -12..0 dB in
noise 50 dB down, gaps 80-500 ms) for words of those twelve voices, many of them opening
on a soft consonant ("fish", "sip", "thin", "hat"), in six sets of three:

    ~/.cache/onomato-devsets-venv/bin/python scripts/other-voices.py --exact /tmp/exact-more

Keep it a check: a setting chosen on these voices is fitted to them as well.
"""

import pathlib
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "shared" / "devsets"))
sys.path.insert(0, str(HERE))  # exact_copies.py, also when loaded from another folder
import build  # noqa: E402  (the development sets' generator)
from exact_copies import sequences as copies_sequences  # noqa: E402

# (espeak-ng voice, set suffix, impulse words): voices whose variant no development set,
# no test and no speech of the built-in background model (scripts/background-speech.sh)
# uses, so that their own speech is heard for the first time too.
VOICES = [
    ("en+m8", "m8", ["tick", "pop", "pew", "boom"]),
    ("en+klatt", "klatt", ["tick", "pop", "pew", "boom"]),
    ("en-us+linda", "uslinda", ["tack", "zap", "pom", "knock"]),
    ("en-gb-x-gbclan+edward", "gbedward", ["tick", "pop", "pew", "boom"]),
    ("en-us-nyc+david", "nycdavid", ["tick", "pop", "pew", "boom"]),
    ("en-gb-x-gbcwmd+steph", "cwmdsteph", ["tick", "pop", "pew", "boom"]),
]


MORE_VOICES = [
    ("en+Antonio", "antonio", ["tick", "pop", "pew", "boom"]),
    ("en-us+Auntie", "auntie", ["tack", "zap", "pom", "knock"]),
    ("en+Diogo", "diogo", ["tick", "pop", "pew", "boom"]),
    ("en-gb-scotland+Gustave", "gustave", ["tack", "zap", "pom", "knock"]),
    ("en+Jacky", "jacky", ["tick", "pop", "pew", "boom"]),
    ("en-029+Marco", "marco", ["tack", "zap", "pom", "knock"]),
]


# (set suffix, {word: espeak-ng voice}) for --exact: the voices above, other words.
EXACT_SETS = [
    ("a", {"fish": "en+m8", "tap": "en+klatt", "on": "en-us+linda"}),
    ("b", {"sip": "en-gb-x-gbclan+edward", "kick": "en-us-nyc+david", "flick": "en-gb-x-gbcwmd+steph"}),
    ("c", {"shot": "en+Antonio", "dunk": "en-us+Auntie", "hat": "en+Diogo"}),
    ("d", {"thin": "en-gb-scotland+Gustave", "ping": "en+Jacky", "fuzz": "en-029+Marco"}),
    ("e", {"flick": "en+m8", "sip": "en-us+linda", "pop": "en+klatt"}),
    ("f", {"fish": "en-us-nyc+david", "shot": "en-gb-x-gbcwmd+steph", "tick": "en+Antonio"}),
]


def exact_copies(out, short, words):
    """The protocol of the dev sets' d5_exact for `words` (word: voice)."""
    name = f"D5_exact_{short}"
    rng = build.rng_for(name)
    sr = 48000
    takes = {}
    for word, voice in words.items():
        x = build.espeak(word, voice, sr)
        e = np.abs(x)
        idx = np.nonzero(e > 0.05 * e.max())[0]
        takes[word] = x[idx[0]:idx[-1] + 1]
    seqs = copies_sequences(rng, takes, sr, 2)
    about = "exact copies: " + ", ".join(f"{w} ({v})" for w, v in words.items()) + "; onset = first sample"
    build.save_set(out / name, takes, {k: "impulse" for k in takes}, seqs, sr, subtype="FLOAT", digits=6,
                   about=about)


def main():
    args = sys.argv[1:]
    more = "--more" in args
    exact = "--exact" in args
    args = [a for a in args if a not in ("--more", "--exact")]
    if len(args) != 1 or (more and exact):
        sys.exit(__doc__)
    out = pathlib.Path(args[0])
    out.mkdir(parents=True, exist_ok=True)
    if exact:
        for short, words in EXACT_SETS:
            exact_copies(out, short, words)
        return
    for voice, short, words in MORE_VOICES if more else VOICES:
        build.d4_voice(out, voice, short, words)
        build.n_speech_espeak(out, voice, short)


if __name__ == "__main__":
    main()
