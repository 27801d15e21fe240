#!/usr/bin/env python3
"""Synthetic knocks on three surfaces, in the development sets' knock protocol (D6_knocks): a
set no recording is needed for, of surfaces unlike the one table the real knocks come from.

Each surface is a plate struck by a knuckle (modal synthesis): its modes at
f_mn = f11 (m^2 + a^2 n^2) / (1 + a^2) for a plate of aspect a, simply supported; each mode
excited by the knuckle's force (a half-sine pulse of the contact's length, whose spectrum
falls off above 1/contact) and by where the plate is struck (sin(m pi x) sin(n pi y)), and
dying away at 1 / (pi f eta) for the material's loss factor eta. Each knock is struck at
another point within 4 % of the plate's size of the surface's spot, 0-9 dB softer (a softer
knock's contact lasts longer, as a Hertzian contact's does: its length goes as the speed to
the -1/5), over the contact's own 0.3 ms click.

| surface | f11 (Hz) | aspect | loss factor | contact (ms) | falls 20 dB in |
|---|---|---|---|---|---|
| wood    | 110 | 1.6 | 0.020 | 1.0  | 0.05 s: a table top's dull thud |
| marble  | 260 | 1.3 | 0.008 | 0.5  | 0.2 s: a stone slab's bright knock |
| ceramic | 900 | 1.1 | 0.002 | 0.35 | 0.4 s: a tile's or a mug's ring |

A plate small against the wavelength radiates its low modes poorly (the modes' amplitudes
times f^2 / (f^2 + 400^2)); every mode starts from rest when struck, so that a knock begins
with its attack.

Ten knocks a surface; the first enrols, the others are placed as D6_knocks places its takes
(`../shared/devsets/build.py`: two 25 s sequences 0.12-0.7 s apart, gains -9..0 dB, noise -60
dB; one of close-by knocks 0.03-0.12 s apart, -6..0 dB, noise -40 dB; a melody's rhythm at
150 bpm; straight eighths at 200 bpm, 0.15 s apart), with the same generator.

    ~/.cache/onomato-devsets-venv/bin/python scripts/knock-sounds.py OUT_DIR
    bash ../shared/devsets/run.sh target/release/onomato OUT_DIR

Writes OUT_DIR/D6_knocks_synth. Needs numpy and soundfile (build.sh's venv); deterministic.
"""

import pathlib
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent / "shared" / "devsets"))
import build  # noqa: E402  (the development sets' generator)

RATE = 44100
SECONDS = 1.5
# surface: (f11 Hz, aspect, loss factor, contact s, struck at (x, y) as a share of the plate)
SURFACES = {
    "wood": (110.0, 1.6, 0.020, 0.0010, (0.31, 0.42)),
    "marble": (260.0, 1.3, 0.008, 0.0005, (0.23, 0.37)),
    "ceramic": (900.0, 1.1, 0.002, 0.00035, (0.41, 0.28)),
}
KNOCKS = 10
TOP_HZ = 12000.0
RADIATES_HZ = 400.0


def half_sine_spectrum(f, contact):
    """Magnitude of a half-sine force pulse's spectrum (unit peak force), at f Hz."""
    u = 2.0 * f * contact
    with np.errstate(divide="ignore", invalid="ignore"):
        p = (2.0 * contact / np.pi) * np.abs(np.cos(np.pi * f * contact) / (1.0 - u * u))
    return np.where(np.abs(1.0 - u * u) < 1e-9, contact / 2.0, p)


def knock(surface, x0, y0, softer_db, rng):
    f11, aspect, eta, contact, _ = SURFACES[surface]
    # A softer knock strikes slower: a Hertzian contact lasts as the speed to the -1/5.
    contact = contact * (10 ** (-softer_db / 20)) ** (-0.2)
    t = np.arange(int(SECONDS * RATE)) / RATE
    y = np.zeros_like(t)
    for m in range(1, 40):
        for n in range(1, 40):
            f = f11 * (m * m + aspect * aspect * n * n) / (1 + aspect * aspect)
            if f > TOP_HZ:
                break
            shape = np.sin(m * np.pi * x0) * np.sin(n * np.pi * y0)
            # Heard at a fixed point of the plate (where the sound radiates from most).
            heard = np.sin(m * np.pi * 0.5) * np.sin(n * np.pi * 0.5) + 0.5
            # A plate small against the wavelength radiates its low modes poorly.
            radiated = f * f / (f * f + RADIATES_HZ * RADIATES_HZ)
            a = half_sine_spectrum(f, contact) * shape * heard * radiated
            decay = 1.0 / (np.pi * f * eta)
            # Struck, every mode starts from rest: a sine, its sign the mode shape's.
            y += a * np.sin(2 * np.pi * f * t) * np.exp(-t / decay)
    click = rng.normal(0, 1, int(0.0003 * RATE)) * np.hanning(int(0.0003 * RATE))
    y /= np.max(np.abs(y))
    y[: len(click)] += 0.3 * click
    # Every knock at its surface's peak, softer ones under it.
    return 0.5 * y / np.max(np.abs(y)) * 10 ** (-softer_db / 20)


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: knock-sounds.py OUT_DIR")
    out = pathlib.Path(sys.argv[1])
    name = "D6_knocks_synth"
    rng = build.rng_for(name)
    classes = {}
    for surface, (*_, spot) in SURFACES.items():
        classes[surface] = [
            (
                knock(surface, spot[0] + rng.uniform(-0.04, 0.04), spot[1] + rng.uniform(-0.04, 0.04),
                      0.0 if k == 0 else rng.uniform(0, 9), rng),
                RATE,
            )
            for k in range(KNOCKS)
        ]
    patterns, takes, kinds, sr = build.enrol(classes)
    seqs = [build.compose(rng, takes, sr, 25, (0.12, 0.7), (-9, 0), -60) for _ in range(2)]
    seqs.append(build.compose(rng, takes, sr, 20, (0.03, 0.12), (-6, 0), -40))
    times = build.rhythm_times(build.MELODY, 150)
    seqs.append(build.compose(rng, takes, sr, float(times[-1] + 1.5), None, (-6, 0), -60, rhythm=times))
    times = build.rhythm_times([0.5] * 32, 200, repeats=1)
    seqs.append(build.compose(rng, takes, sr, float(times[-1] + 1.0), None, (-6, 0), -60, rhythm=times))
    build.save_set(out / name, patterns, kinds, seqs, sr,
                   about="synthetic knocks on wood, marble and ceramic (modal plates); the protocol of D6_knocks")


if __name__ == "__main__":
    main()
