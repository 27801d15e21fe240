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

Keep it a check: a setting chosen on these voices is fitted to them as well.
"""

import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "shared" / "devsets"))
import build  # noqa: E402  (the development sets' generator)

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


def main():
    args = sys.argv[1:]
    more = "--more" in args
    args = [a for a in args if a != "--more"]
    if len(args) != 1:
        sys.exit(__doc__)
    out = pathlib.Path(args[0])
    out.mkdir(parents=True, exist_ok=True)
    for voice, short, words in MORE_VOICES if more else VOICES:
        build.d4_voice(out, voice, short, words)
        build.n_speech_espeak(out, voice, short)


if __name__ == "__main__":
    main()
