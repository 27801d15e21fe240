#!/usr/bin/env bash
# Runs onomato ($ONOMATO, default this checkout's target/release/onomato) with every take of the set's
# more_takes/ folder (scripts/more-takes.py) added to its pattern: `onomato analyze
# SEQ.wav ARGS...` becomes `onomato analyze SEQ.wav ARGS... --pattern LABEL=FILE ...`, for
# each more_takes/LABEL-K.wav beside SEQ.wav. Given to ../shared/devsets/run.sh as its
# binary:
#
#   TAG=all bash ../shared/devsets/run.sh scripts/with-more-takes.sh /tmp/more3
set -euo pipefail
bin=${ONOMATO:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/target/release/onomato}
if [[ $# -lt 2 || $1 != analyze ]]; then
  exec "$bin" "$@"
fi
extra=()
for take in "$(dirname "$2")"/more_takes/*.wav; do
  [[ -f $take ]] || continue
  name=$(basename "$take" .wav)
  extra+=(--pattern "${name%-*}=$take")
done
exec "$bin" "$@" "${extra[@]}"
