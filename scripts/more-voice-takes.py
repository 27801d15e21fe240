#!/usr/bin/env python3
"""The voice protocol enrolled from three takes of each word: every D4_voice_* set of
SETS_DIR (../shared/devsets, or scripts/other-voices.py's folders) and the
N_speech_espeak_* set of the same voice, copied into OUT_DIR (the sequences, truth and
patterns linked, not copied) with each impulse word's take said twice more by the same
voice in `more_takes/`: slower and lower (145 words a minute, pitch 44) and quicker and
higher (175, 56) than the take the sets enrol (160, 50), inside the range its instances
are said at (135-190, 38-62), cut by the sets' own rule. A held sound keeps its one take.

    ~/.cache/onomato-devsets-venv/bin/python scripts/more-voice-takes.py /tmp/devsets /tmp/voice3
    bash ../shared/devsets/run.sh target/release/onomato /tmp/voice3          # one take
    TAG=all bash ../shared/devsets/run.sh scripts/with-more-takes.sh /tmp/voice3  # three

Uses the generator of ../shared/devsets (its venv, with numpy and soundfile, as build.sh
makes it) and espeak-ng.
"""

import json
import pathlib
import re
import sys

from real_sets import build

# (words a minute, pitch) of the two further takes.
FURTHER_TAKES = [(145, 44), (175, 56)]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    sets, out = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    voices = sorted(sets.glob("D4_voice_*/set.json"))
    if not voices:
        sys.exit(f"more-voice-takes.py: no D4_voice_* set in {sets}")
    for meta in voices:
        short = meta.parent.name.removeprefix("D4_voice_")
        about = json.loads(meta.read_text())
        found = re.search(r"espeak-ng (\S+):", about["about"])
        if not found:
            sys.exit(f"more-voice-takes.py: {meta}: no espeak-ng voice named in its 'about'")
        voice, sr = found.group(1), about["sample_rate"]
        takes = {}
        for label, kind in about["kinds"].items():
            if kind == "impulse":
                takes[label] = [build.cut_pattern(build.espeak(label, voice, sr, wpm, pitch), sr)
                                for wpm, pitch in FURTHER_TAKES]
        for name in (f"D4_voice_{short}", f"N_speech_espeak_{short}"):
            src, dst = sets / name, out / name
            if not (src / "set.json").is_file():
                continue
            (dst / "patterns").mkdir(parents=True, exist_ok=True)
            (dst / "more_takes").mkdir(exist_ok=True)
            for f in [*src.glob("seq_*.wav"), *src.glob("seq_*.csv"), *src.glob("patterns/*.wav")]:
                link = dst / f.relative_to(src)
                link.unlink(missing_ok=True)
                link.symlink_to(f.resolve())
            about_here = dict(about if name.startswith("D4") else json.loads((src / "set.json").read_text()))
            about_here["about"] += f" (here each impulse word also enrols said at {FURTHER_TAKES} (wpm, pitch): scripts/more-voice-takes.py)"
            (dst / "set.json").write_text(json.dumps(about_here, indent=1))
            for label, xs in takes.items():
                for k, x in enumerate(xs, start=2):
                    build.write(dst / "more_takes" / f"{label}-{k}.wav", x, sr)
        print(f"{short}: {voice}, {len(takes)} words with {len(FURTHER_TAKES)} more takes each")


if __name__ == "__main__":
    main()
