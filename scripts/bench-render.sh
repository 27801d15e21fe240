#!/usr/bin/env bash
# Times `onomato render` end to end (analysis, drawing, rasterising, ffmpeg's H.264 and
# AAC encoding, writing) for every scene on the bundled 10 s example at 1280x720, 60 fps,
# as an MP4 video and as an HTML page, and prints a Markdown table of wall-clock times
# and how many times faster than real time each is (the median of RUNS runs).
# Usage: scripts/bench-render.sh [RUNS]   (default 3; builds the release binary first)
set -euo pipefail
runs=${1:-3}
cd "$(dirname "$0")/.."
cargo build --release --locked --quiet
bin=target/release/onomato
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
length=$(soxi -D examples/beat.wav 2>/dev/null || echo 10)
echo "| scene | output | wall time, s (median of $runs) | × real time |"
echo "|---|---|---|---|"
for scene in ball timeline rain darts laser; do
  for ext in mp4 html; do
    times=()
    for _ in $(seq "$runs"); do
      start=$(date +%s.%N)
      "$bin" render examples/beat.wav -c config/onomato.toml --scene "$scene" \
        --fps 60 --size 1280x720 -o "$out/$scene.$ext" 2>/dev/null
      end=$(date +%s.%N)
      times+=("$(awk "BEGIN { print $end - $start }")")
    done
    median=$(printf '%s\n' "${times[@]}" | sort -g | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }')
    awk -v s="$scene" -v e="$ext" -v m="$median" -v l="$length" \
      'BEGIN { printf "| %s | %s | %.2f | %.1f |\n", s, e, m, l / m }'
  done
done
