#!/usr/bin/env python3
"""Synthetic mouth sounds in the development sets' format: a set no recording is needed for.

Four impulse patterns, one take each: a tongue click (a 2.6 kHz resonance dying within a few
milliseconds over a short burst), a cheek pop (a 700 Hz resonance of 20 ms), a lip smack (two
mid clicks 14 ms apart) and a teeth chatter (one click repeated six times, 45 ms apart). Three
20 s sequences of them, 0.25-0.7 s apart, each instance its resonances up to 7 % off the take's,
its decay 0.8-1.25 times, its level 0-12 dB under the takes', in white noise 55 dB down. With
--chatter-clicks-differ, each click of a chatter has its own resonances (a chatter that is not
one sound repeated by the enrolment's measure).

    python3 scripts/mouth-sounds.py OUT_DIR [--chatter-clicks-differ]
    bash ../shared/devsets/run.sh target/release/onomato OUT_DIR

Writes OUT_DIR/D1_mouth (set.json, patterns/*.wav, seq_NN.wav and seq_NN.csv). Needs numpy
(build.sh's venv has it); deterministic.
"""

import json
import os
import sys
import wave

import numpy as np

RATE = 44100


def resonance(hz, decay, n, seed, spread):
    """Five partials within `spread` of `hz`, random phases and weights, dying away at `decay` s."""
    r = np.random.default_rng(seed)
    t = np.arange(n) / RATE
    x = np.zeros(n)
    for _ in range(5):
        f = hz * (1 + spread * (r.random() - 0.5))
        x += np.sin(2 * np.pi * f * t + r.random() * 2 * np.pi) * r.random()
    return x * np.exp(-t / decay)


def click(shift, stretch, seed, _):
    x = resonance(2600 * shift, 0.0025 * stretch, int(0.03 * RATE), seed, 0.4)
    x[:40] += np.random.default_rng(seed).normal(0, 0.5, 40) * np.exp(-np.arange(40) / 10)
    return x


def pop(shift, stretch, seed, _):
    return resonance(700 * shift, 0.018 * stretch, int(0.08 * RATE), seed, 0.1)


def smack(shift, stretch, seed, _):
    n = int(0.06 * RATE)
    first = resonance(1500 * shift, 0.003 * stretch, n, seed, 0.5)
    later = np.zeros(n)
    gap = int(0.014 * RATE)
    later[gap:] = 0.6 * first[: n - gap]
    return first + later


def chatter(shift, stretch, seed, clicks_differ):
    x = np.zeros(int(0.3 * RATE))
    for i in range(6):
        c = resonance(3500 * shift, 0.002 * stretch, int(0.02 * RATE), seed + i * clicks_differ, 0.5)
        at = int(i * 0.045 * RATE)
        x[at : at + len(c)] += c * (0.7 + 0.3 * np.random.default_rng(seed + i).random())
    return x


SOUNDS = {"click": click, "pop": pop, "smack": smack, "chatter": chatter}


def at_peak(x, db):
    return x / np.max(np.abs(x)) * 10 ** (db / 20)


def write(path, x):
    x = np.clip(x, -1, 1)
    with wave.open(path, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(RATE)
        w.writeframes((x * 32767).astype(np.int16).tobytes())


def main():
    args = sys.argv[1:]
    differ = "--chatter-clicks-differ" in args
    args = [a for a in args if a != "--chatter-clicks-differ"]
    if len(args) != 1:
        sys.exit("usage: mouth-sounds.py OUT_DIR [--chatter-clicks-differ]")
    out = os.path.join(args[0], "D1_mouth")
    os.makedirs(os.path.join(out, "patterns"), exist_ok=True)
    rng = np.random.default_rng(7)
    about = "synthetic mouth sounds: click, pop, smack, chatter (impulse)"
    with open(os.path.join(out, "set.json"), "w") as f:
        json.dump({"kinds": {k: "impulse" for k in SOUNDS}, "sample_rate": RATE, "about": about}, f)
    room = 10 ** (-60 / 20)
    for i, (name, make) in enumerate(SOUNDS.items()):
        take = at_peak(make(1.0, 1.0, 100 + i, int(differ)), -6)
        pad = int(0.1 * RATE)
        x = np.concatenate([np.zeros(pad), take, np.zeros(pad)])
        write(os.path.join(out, "patterns", f"{name}.wav"), x + rng.normal(0, room, len(x)))
    for s in range(3):
        seconds = 20
        y = rng.normal(0, 10 ** (-55 / 20), seconds * RATE)
        t, rows = 0.5, []
        while t < seconds - 0.6:
            name = rng.choice(list(SOUNDS))
            shift, stretch, gain = rng.uniform(0.93, 1.07), rng.uniform(0.8, 1.25), rng.uniform(-12, 0)
            x = at_peak(SOUNDS[name](shift, stretch, int(rng.integers(1e6)), int(differ)), -3 + gain)
            at = int(t * RATE)
            y[at : at + len(x)] += x
            rows.append(f"{t:.4f},{name},,{10 ** (gain / 20):.4f}\n")
            t += rng.uniform(0.25, 0.7)
        write(os.path.join(out, f"seq_{s:02d}.wav"), y)
        with open(os.path.join(out, f"seq_{s:02d}.csv"), "w") as f:
            f.write("onset_s,label,end_s,gain\n" + "".join(rows))
    print(f"mouth-sounds.py: {out}")


if __name__ == "__main__":
    main()
