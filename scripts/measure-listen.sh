#!/usr/bin/env bash
# Measures the daemon, for the README's figures:
#   1. CPU: `onomato listen` with 8 patterns on a minute of audio replayed in real time
#      (user + system time over wall time, from bash's `time`).
#   2. Memory: resident size (VmRSS) sampled every second while an hour of audio is
#      replayed 60 times faster than real time.
#   3. End-to-end delay: a PulseAudio server with a null sink, `paplay` plays the bundled
#      example into it, `onomato listen` captures the sink's monitor through ALSA's
#      default device, and oscdump receives the OSC. Delay = arrival of the message -
#      (start of paplay + the sound's onset in the file). paplay's own start-up and
#      buffering are in it, so it is an upper bound.
# Each for the waveform and the spectral method. Needs what scripts/test.sh installs.
#   bash scripts/measure-listen.sh [cpu] [memory] [delay]   (all three: about 7 minutes)
set -euo pipefail
parts=" ${*:-cpu memory delay} "
cd "$(dirname "$0")/.."
root=$(pwd)

cargo build --release --locked >/dev/null 2>&1 || cargo build --release --locked
bin="$root/target/release/onomato"
work=$(mktemp -d)
cleanup() {
  jobs -p | xargs -r kill 2>/dev/null || true
  [ -n "${pulse_pid:-}" ] && kill "$pulse_pid" 2>/dev/null || true
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

# Eight patterns: the example's four and four variants of them (pitched, slowed), so
# that every pattern has a different sound.
p="$root/examples/patterns"
sox "$p/tick.wav" "$work/tick_high.wav" pitch 500
sox "$p/pop.wav" "$work/pop_low.wav" pitch -400
sox "$p/boom.wav" "$work/boom_slow.wav" tempo 0.8
sox "$p/hoo.wav" "$work/hoo_high.wav" pitch 300
cat > "$work/eight.toml" <<EOF
[[pattern]]
name = "tick"
takes = ["$p/tick.wav"]
[[pattern]]
name = "pop"
takes = ["$p/pop.wav"]
[[pattern]]
name = "boom"
takes = ["$p/boom.wav"]
[[pattern]]
name = "hoo"
kind = "continuous"
takes = ["$p/hoo.wav"]
[[pattern]]
name = "tick_high"
takes = ["$work/tick_high.wav"]
[[pattern]]
name = "pop_low"
takes = ["$work/pop_low.wav"]
[[pattern]]
name = "boom_slow"
takes = ["$work/boom_slow.wav"]
[[pattern]]
name = "hoo_high"
kind = "continuous"
takes = ["$work/hoo_high.wav"]

[osc]
targets = ["127.0.0.1:9"]
EOF

if [[ "$parts" == *" cpu "* ]]; then
echo "== CPU: 8 patterns, 60 s of audio replayed in real time (examples/beat.wav x 6)"
for method in waveform spectral; do
  TIMEFORMAT="%R %U %S"
  t=$( { time "$bin" listen -c "$work/eight.toml" --method "$method" \
          --input examples/beat.wav --repeat 6 --print none 2>/dev/null; } 2>&1 )
  read -r real user sys <<<"$t"
  awk -v m="$method" -v r="$real" -v u="$user" -v s="$sys" \
    'BEGIN { printf "  %-9s wall %.1f s, CPU %.2f s = %.2f%% of one core\n", m, r, u + s, 100 * (u + s) / r }'
done

fi

if [[ "$parts" == *" memory "* ]]; then
echo "== Memory: 8 patterns, 1 hour of audio replayed 60x (beat.wav x 360)"
for method in waveform spectral; do
  "$bin" listen -c "$work/eight.toml" --method "$method" --input examples/beat.wav \
    --repeat 360 --speed 60 --print none 2>"$work/mem-$method.log" &
  pid=$!
  : > "$work/rss-$method.txt"
  while kill -0 "$pid" 2>/dev/null; do
    awk '/VmRSS/ { print $2 }' "/proc/$pid/status" 2>/dev/null >> "$work/rss-$method.txt" || true
    sleep 1
  done
  wait "$pid"
  grep -o 'stream_seconds=[0-9.]*' "$work/mem-$method.log" | tail -1 | sed "s/^/  $method: /"
  awk -v m="$method" '
    NF { n++; v[n] = $1; if ($1 > max) max = $1 }
    END {
      if (n < 10) { print "  " m ": too few samples"; exit 1 }
      printf "  %-9s RSS after 5 s %d KiB, after half %d KiB, at the end %d KiB, peak %d KiB (%d samples)\n",
        m, v[5], v[int(n / 2)], v[n], max, n
    }' "$work/rss-$method.txt"
done

fi

if [[ "$parts" == *" delay "* ]]; then
echo "== End-to-end delay through PulseAudio (paplay -> null sink -> ALSA default -> onomato -> OSC -> oscdump)"
export XDG_RUNTIME_DIR="$work/xdg" HOME="$work/home"
mkdir -p "$XDG_RUNTIME_DIR" "$HOME"
chmod 700 "$XDG_RUNTIME_DIR"
pulseaudio -n --daemonize=no --exit-idle-time=-1 --disallow-exit \
  --load="module-null-sink sink_name=onomato_null" --load=module-native-protocol-unix \
  --log-target=stderr 2>"$work/pulse.log" &
pulse_pid=$!
for _ in $(seq 50); do pactl info >/dev/null 2>&1 && break; sleep 0.1; done
pacat --playback --latency-msec=20 </dev/zero >/dev/null 2>&1 &
sleep 0.3
pactl suspend-sink onomato_null 1
pactl suspend-sink onomato_null 0

for method in waveform spectral; do
  port=$((20000 + RANDOM % 20000))
  stdbuf -oL oscdump -L "$port" >"$work/osc-$method.txt" 2>/dev/null &
  dump=$!
  sleep 0.3
  "$bin" listen -c config/onomato.toml --method "$method" --osc "127.0.0.1:$port" \
    --print none 2>"$work/listen-$method.log" &
  listener=$!
  for _ in $(seq 100); do grep -q listening "$work/listen-$method.log" && break; sleep 0.1; done
  sleep 0.5
  start=$(date +%s.%N)
  paplay --latency-msec=20 examples/beat.wav
  sleep 2.5
  kill -TERM "$listener"; wait "$listener" || true
  kill "$dump"; wait "$dump" 2>/dev/null || true
  python3 - "$method" "$start" "$work/osc-$method.txt" examples/beat.truth.csv <<'PY'
import csv, statistics, sys
method, start, osc_path, truth_path = sys.argv[1], float(sys.argv[2]), sys.argv[3], sys.argv[4]
truth = [(float(r["onset_s"]), r["label"]) for r in csv.DictReader(open(truth_path))]
sent = []  # (arrival unix s, label, stream time)
for line in open(osc_path):
    f = line.split()
    if len(f) < 5:
        continue
    parts = f[1].split("/")
    if not (len(parts) == 3 and parts[2] not in ("event", "status")) and not (
        len(parts) == 4 and parts[3] == "begin"):
        continue
    secs, frac = f[0].split(".")
    arrival = int(secs, 16) - 2208988800 + int(frac, 16) / 2**32
    sent.append((arrival, parts[2], float(f[4])))
# The stream starts when capture starts: find the shift from stream time to file time
# that puts the most messages within 30 ms of a sound of their label.
def matches(shift):
    used, out = set(), []
    for arrival, label, t in sent:
        best = None
        for i, (onset, l) in enumerate(truth):
            if l == label and i not in used and abs(t - shift - onset) < 0.03:
                if best is None or abs(t - shift - onset) < abs(t - shift - truth[best][0]):
                    best = i
        if best is not None:
            used.add(best)
            out.append((arrival, truth[best][0]))
    return out
shifts = [t - onset for _, label, t in sent for onset, l in truth if l == label]
best = max(shifts, key=lambda s: len(matches(s))) if shifts else 0.0
found = matches(best)
delays = sorted(a - (start + onset) for a, onset in found)
if not delays:
    print(f"  {method:<9} no message matched a sound")
    sys.exit(1)
print(f"  {method:<9} {len(found)} of {len(truth)} sounds sent ({len(sent) - len(found)} other messages);"
      f" delay median {1000 * statistics.median(delays):.0f} ms, worst {1000 * delays[-1]:.0f} ms,"
      f" best {1000 * delays[0]:.0f} ms")
PY
done
fi
