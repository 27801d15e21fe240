#!/usr/bin/env bash
# Installs what the tests need (Debian packages) and runs the whole test suite in
# release mode (the detector is signal processing: debug builds are needlessly slow).
#   bash scripts/test.sh
#
# The daemon's tests use real parts, each started by the test itself in a folder of its
# own: a PulseAudio server with a null sink (captured through ALSA's default device), a
# JACK server with the dummy driver and jack_midi_dump, and oscdump as OSC receiver.
# MIDI goes through JACK there (this machine has no ALSA sequencer), so the tests are
# built with the `jack` feature.
set -euo pipefail
cd "$(dirname "$0")/.."

# command -> Debian package
need=(
  "espeak-ng espeak-ng"                 # a test rebuilds the bundled example
  "sox sox"
  "pkg-config pkg-config"               # building: ALSA and JACK libraries
  "pulseaudio pulseaudio"               # the microphone: a null sink's monitor
  "paplay pulseaudio-utils"
  "oscdump liblo-tools"                 # an independent OSC receiver
  "jackd jackd2"                        # MIDI through JACK
  "jack_midi_dump jack-tools"
  "stdbuf coreutils"
)
packages=()
for pair in "${need[@]}"; do
  read -r cmd pkg <<<"$pair"
  command -v "$cmd" >/dev/null 2>&1 || packages+=("$pkg")
done
# Libraries (no command to look for).
for pkg in libasound2-dev libjack-jackd2-dev libasound2-plugins; do
  dpkg -s "$pkg" >/dev/null 2>&1 || packages+=("$pkg")
done
if [ "${#packages[@]}" -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  echo "installing ${packages[*]}" >&2
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
fi

cargo test --release --locked --features jack
