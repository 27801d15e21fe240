#!/usr/bin/env bash
# Quick start: installs the libraries onomato builds against (Debian packages), builds
# it, and runs the daemon on the bundled example: examples/beat.wav is replayed in real
# time through the same pipeline as the microphone, and each event is printed as it is
# sent (OSC to 127.0.0.1:9000, as config/onomato.toml says).
#   bash scripts/example.sh
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-packages.sh pkg-config libasound2-dev

cargo run --release --locked -- listen --config config/onomato.toml \
  --input examples/beat.wav --print text "$@"
