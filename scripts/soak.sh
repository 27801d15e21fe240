#!/usr/bin/env bash
# A day in a few minutes: replays 24 hours of audio through `onomato listen` with OSC
# and MIDI (JACK) out, faster than real time, and reports
#   - the daemon's resident memory (VmRSS) after 1 minute, 12 hours and 24 hours of
#     stream (the stream time is read from the daemon's own /status heartbeat);
#   - every sound received by an independent OSC receiver (oscdump), against the count
#     `onomato analyze` gives on one copy of the material, times the copies;
#   - how far the received event times (the exact i + f pair) drift from analyze's
#     times of the same sound in its copy;
#   - notes left on at the end (note-ons without a note-off, from jack_midi_dump);
#   - samples lost to a full ring and events dropped (the daemon's log line at exit).
# The material: the bundled example at 12 gains from -12 to -1 dB, each over white noise
# of its own level and followed by 2 s of silence (about 2.4 minutes), looped.
#   bash scripts/soak.sh [HOURS] [SPEED]      (default 24 hours at 300x: about 5 minutes)
# Needs what scripts/test.sh installs.
set -euo pipefail
hours=${1:-24}
speed=${2:-300}
cd "$(dirname "$0")/.."
root=$(pwd)
cargo build --release --locked --features jack >/dev/null 2>&1 || cargo build --release --locked --features jack
bin="$root/target/release/onomato"
work=$(mktemp -d)
jack_name="onomato_soak_$$"
cleanup() {
  [ -n "${daemon_pid:-}" ] && kill "$daemon_pid" 2>/dev/null || true
  [ -n "${dump_pid:-}" ] && kill "$dump_pid" 2>/dev/null || true
  [ -n "${midi_pid:-}" ] && kill "$midi_pid" 2>/dev/null || true
  [ -n "${jack_pid:-}" ] && kill "$jack_pid" 2>/dev/null || true
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

# The material.
parts=()
for i in $(seq 0 11); do
  gain=$((i - 12))
  noise=$(awk -v i="$i" 'BEGIN { printf "%.5f", 0.0005 * (1 + i % 4) }')
  sox -R -n -r 22050 -c 1 -b 16 "$work/noise$i.wav" synth 10 whitenoise vol "$noise"
  sox -m -v 1 "$root/examples/beat.wav" "$work/noise$i.wav" "$work/mix$i.wav" vol "${gain}dB"
  sox "$work/mix$i.wav" "$work/part$i.wav" pad 0 2
  parts+=("$work/part$i.wav")
done
sox "${parts[@]}" -b 16 "$work/material.wav"
duration=$(soxi -D "$work/material.wav")
repeat=$(awk -v h="$hours" -v d="$duration" 'BEGIN { printf "%d", h * 3600 / d + 0.5 }')
echo "material: $(printf '%.1f' "$duration") s, played $repeat times = $(awk -v r="$repeat" -v d="$duration" 'BEGIN { printf "%.2f", r * d / 3600 }') h of stream at ${speed}x"

# What analyze finds in two copies: the first as the stream's first, the second as
# every later one (it follows a copy, as they do).
sox "$work/material.wav" "$work/material.wav" "$work/two.wav"
"$bin" analyze "$work/two.wav" -c config/onomato.toml --format json > "$work/analyze.json"

# The receivers: oscdump, and a JACK server (dummy driver) with jack_midi_dump.
port=$(python3 -c 'import socket; s=socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
stdbuf -oL oscdump -L "$port" > "$work/osc.txt" 2>/dev/null &
dump_pid=$!
jackd -n "$jack_name" -d dummy -r 48000 -p 256 >/dev/null 2>&1 &
jack_pid=$!
export JACK_DEFAULT_SERVER="$jack_name" JACK_NO_START_SERVER=1
for _ in $(seq 50); do jack_lsp >/dev/null 2>&1 && break; sleep 0.1; done
stdbuf -oL jack_midi_dump > "$work/midi.txt" 2>/dev/null &
midi_pid=$!
sleep 0.5

# The example config with its OSC target replaced by the receiver, a heartbeat, and
# MIDI connected to jack_midi_dump's port from the start (a virtual port would be
# connected only once it exists, after the first notes at this speed).
sed -e "s#\.\./examples#$root/examples#" \
    -e "s#^targets = .*#targets = [\"127.0.0.1:$port\"]\nheartbeat_seconds = 0.5#" \
    config/onomato.toml > "$work/soak.toml"
cat >> "$work/soak.toml" <<EOF

[midi]
connect = "midi-monitor:input"
EOF

RUST_LOG=info "$bin" listen -c "$work/soak.toml" --input "$work/material.wav" \
  --repeat "$repeat" --speed "$speed" --print none 2> "$work/listen.log" &
daemon_pid=$!
# Resident memory after 1 minute, half of the stream, and its last two copies of the
# material (the heartbeat comes every 0.5 s of wall time: 150 s of stream at 300x,
# longer than one copy of the bundled example, so the last copy alone can pass
# between two heartbeats).
marks=(60 $(awk -v h="$hours" 'BEGIN { printf "%d", h * 1800 }') $(awk -v h="$hours" -v d="$duration" 'BEGIN { printf "%d", h * 3600 - 2 * d }'))
names=("1 min" "half" "last two copies")
next=0
rss=()
while kill -0 "$daemon_pid" 2>/dev/null; do
  stream=$( (grep '/onomato/status' "$work/osc.txt" || true) | tail -1 | awk '{print $4}')
  if [ -n "$stream" ] && [ "$next" -lt 3 ] && awk -v s="$stream" -v m="${marks[$next]}" 'BEGIN { exit !(s >= m) }'; then
    kb=$(awk '/VmRSS/ {print $2}' "/proc/$daemon_pid/status" 2>/dev/null || echo 0)
    rss+=("${names[$next]} of stream ($(printf '%.0f' "$stream") s): $kb kB")
    next=$((next + 1))
  fi
  sleep 0.2
done
wait "$daemon_pid" || { echo "listen failed:"; tail -5 "$work/listen.log"; exit 1; }
daemon_pid=""
sleep 1
kill "$midi_pid" 2>/dev/null || true

echo "resident memory:"
for line in "${rss[@]}"; do echo "  $line"; done
grep -o 'stopped .*' "$work/listen.log" | sed 's/^/daemon: /'
python3 - "$work" "$repeat" "$duration" <<'PY'
import json, sys, collections
work, repeat, duration = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
events = json.load(open(f"{work}/analyze.json"))["events"]
first = [e for e in events if e["time"] < duration]
later = [dict(e, time=e["time"] - duration) for e in events if e["time"] >= duration]
expected = len(first) + (repeat - 1) * len(later)
received = []
for line in open(f"{work}/osc.txt"):
    p = line.split()
    if len(p) > 2 and p[1] == "/onomato/event" and p[4] != '"begin"':
        # s pattern, s kind, f strength, f time, f end, i id, f pitch, i time_s, f time_frac
        pattern = p[3].strip('"')
        received.append((pattern, int(p[10]) + float(p[11])))
print(f"sounds: analyze {len(first)} in the first copy and {len(later)} in a later one: "
      f"{expected} expected; received {len(received)}")
worst = 0.0
unmatched = 0
per_copy_worst = {}
for pattern, t in received:
    k = int(t // duration)
    local = t - k * duration
    near = [abs(e["time"] - local) for e in (first if k == 0 else later) if e["pattern"] == pattern]
    d = min(near) if near else float("inf")
    if d > 0.05:
        unmatched += 1
    else:
        worst = max(worst, d)
    per_copy_worst[k] = max(per_copy_worst.get(k, 0.0), d if d <= 0.05 else 0.0)
copies = sorted(per_copy_worst)
tenths = [copies[i * len(copies) // 10:(i + 1) * len(copies) // 10] for i in range(10)]
print(f"event times against analyze's in each copy: largest difference {worst * 1000:.3f} ms; "
      f"sounds not at an analyzed time: {unmatched}")
print("  largest difference in each tenth of the stream (ms): "
      + " ".join(f"{max(per_copy_worst[k] for k in t) * 1000:.3f}" for t in tenths if t))
on = collections.Counter()
for line in open(f"{work}/midi.txt"):
    if ":" not in line:
        continue
    b = line.split(":", 1)[1].split()
    if len(b) < 3:
        continue
    status, note, vel = int(b[0], 16), int(b[1], 16), int(b[2], 16)
    if status & 0xF0 == 0x90 and vel > 0:
        on[(status & 0x0F, note)] += 1
    elif status & 0xF0 == 0x80 or (status & 0xF0 == 0x90 and vel == 0):
        on[(status & 0x0F, note)] -= 1
ons = sum(1 for _ in open(f"{work}/midi.txt"))
print(f"MIDI: {ons} messages; notes left on at the end: {sum(v for v in on.values() if v > 0)}")
PY
