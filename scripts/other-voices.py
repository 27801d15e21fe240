#!/usr/bin/env python3
"""Sets of the development sets' voice protocol (D4_voice_*, N_speech_espeak_*) for
espeak-ng voices that no development set uses: a check that a change carries over to
voices it was not chosen on. Uses the generator of ../shared/devsets (its venv, with
numpy and soundfile, as build.sh makes it), espeak-ng and sox.

    ~/.cache/onomato-devsets-venv/bin/python scripts/other-voices.py /tmp/other-voices
    bash ../shared/devsets/run.sh target/release/onomato /tmp/other-voices

Keep it a check: a setting chosen on these voices is fitted to them as well.
"""

import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "shared" / "devsets"))
import build  # noqa: E402  (the development sets' generator)

# (espeak-ng voice, set suffix, impulse words): voices whose variant no development set,
# no test and no speech of the built-in background model (scripts/background-speech.sh:
# f2 f4 f5 m3 m5 m6 klatt3 Andy Annie grandma Storm) uses, so that their own speech is
# heard for the first time too.
VOICES = [
    ("en+m8", "m8", ["tick", "pop", "pew", "boom"]),
    ("en+klatt", "klatt", ["tick", "pop", "pew", "boom"]),
    ("en-us+linda", "uslinda", ["tack", "zap", "pom", "knock"]),
    ("en-gb-x-gbclan+edward", "gbedward", ["tick", "pop", "pew", "boom"]),
    ("en-us-nyc+david", "nycdavid", ["tick", "pop", "pew", "boom"]),
    ("en-gb-x-gbcwmd+steph", "cwmdsteph", ["tick", "pop", "pew", "boom"]),
]


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = pathlib.Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    for voice, short, words in VOICES:
        build.d4_voice(out, voice, short, words)
        build.n_speech_espeak(out, voice, short)


if __name__ == "__main__":
    main()
