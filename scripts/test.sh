#!/usr/bin/env bash
# Installs what the tests need (Debian packages) and runs the whole test suite in
# release mode (the detector is signal processing: debug builds are needlessly slow).
#   bash scripts/test.sh
#
# The daemon's tests use real parts, each started by the test itself in a folder of its
# own: a PulseAudio server with a null sink (captured through ALSA's default device), a
# JACK server with the dummy driver and jack_midi_dump, oscdump as OSC receiver, and
# Chromium for the pages.
# MIDI goes through JACK there (this machine has no ALSA sequencer), so the tests are
# built with the `jack` feature.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  espeak-ng sox                          # a test rebuilds the bundled example
  pkg-config libasound2-dev libjack-jackd2-dev   # building: ALSA and JACK
  pulseaudio pulseaudio-utils libasound2-plugins # the microphone: a null sink's monitor
  liblo-tools                            # oscdump, an independent OSC receiver
  jackd2 jack-tools                      # MIDI through JACK, jack_midi_dump
  coreutils                              # stdbuf
  puredata-core                          # the Pure Data recipe, run headless
  librsvg2-bin                           # rsvg-convert renders the plot in a test
  systemd                                # systemd-analyze rates and checks the unit
  chromium                               # a real browser opens render's pages and the preview
  ffmpeg fonts-dejavu-core               # render's MP4 (encoding, labels), and ffprobe
)
bash scripts/install-packages.sh "${packages[@]}"

# The preview's tests drive Chromium with playwright-core (tests/browser), at the
# version its lock file names; node and npm come with the machine, else from Debian.
command -v npm >/dev/null || bash scripts/install-packages.sh nodejs npm
npm ci --prefix tests/browser --no-audit --no-fund --loglevel=error

# --all-targets: the benchmarks and examples are built and run once too, so they
# cannot rot.
cargo test --release --locked --features jack --all-targets
