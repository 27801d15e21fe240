#!/usr/bin/env bash
# Installs what the tests need (Debian packages) and runs the whole test suite in
# release mode (the detector is signal processing: debug builds are needlessly slow).
#   bash scripts/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."

# espeak-ng and sox: a test rebuilds the bundled example from scratch.
packages=()
command -v espeak-ng >/dev/null 2>&1 || packages+=(espeak-ng)
command -v sox >/dev/null 2>&1 || packages+=(sox)
if [ "${#packages[@]}" -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -eq 0 ] || sudo="sudo"
  echo "installing ${packages[*]}" >&2
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
fi

cargo test --release --locked
