#!/usr/bin/env bash
# Quick start: installs the libraries onomato builds against (Debian packages), builds
# it, and runs the daemon on the bundled example: examples/beat.wav is replayed in real
# time through the same pipeline as the microphone, and each event is printed as it is
# sent (OSC to 127.0.0.1:9000, as config/onomato.toml says).
#   bash scripts/example.sh
set -euo pipefail
cd "$(dirname "$0")/.."

packages=()
command -v pkg-config >/dev/null 2>&1 || packages+=(pkg-config)
dpkg -s libasound2-dev >/dev/null 2>&1 || packages+=(libasound2-dev)
if [ "${#packages[@]}" -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  echo "installing ${packages[*]}" >&2
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
fi

cargo run --release --locked -- listen --config config/onomato.toml \
  --input examples/beat.wav --print text "$@"
