//! `onomato listen` with real parts: the daemon binary, a real PulseAudio server with a
//! null sink (cpal captures its monitor through ALSA's default device while `paplay`
//! plays into it), a real JACK server with the dummy driver and `jack_midi_dump` for
//! MIDI (built with the `jack` feature), and `oscdump` (liblo) as an independent OSC
//! receiver. Each test starts its own servers in its own folder and stops them.
//!
//! `bash scripts/test.sh` installs the programs (pulseaudio, pulseaudio-utils,
//! libasound2-plugins, liblo-tools, jackd2, jack-tools) and runs these tests.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod common;
#[cfg(feature = "jack")]
use common::procs::spawn_child;
use common::procs::{
    free_udp_port, read, signal, spawn, unix_now, wait_exit, wait_for_text, Guard, OscDump, OscLine,
};
use common::root;

const BIN: &str = env!("CARGO_BIN_EXE_onomato");

/// The PulseAudio and JACK tests run servers and replay in real time: one at a time, so
/// that they do not starve each other of the machine's cores (a starved player inserts
/// silence; a capture started under load has lost the first second of a play).
static REAL_TIME_AUDIO: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// How long after a play has ended its last events may take to reach OSC: PulseAudio's
/// null sink can hand a capture its audio in blocks of up to 2 s, and a loaded machine
/// delays it further. What each test measures of delays it asserts by itself.
const CAPTURE_CATCH_UP: Duration = Duration::from_secs(15);

/// A server stopped with SIGTERM (then killed if it does not stop): jackd removes its
/// entry from JACK's shared registry only then, and the registry holds few servers.
#[cfg(feature = "jack")]
struct Server(Child);

#[cfg(feature = "jack")]
impl Drop for Server {
    fn drop(&mut self) {
        if let Ok(Some(_)) = self.0.try_wait() {
            return;
        }
        // SAFETY: kill(2) on our own child's pid.
        unsafe { libc::kill(self.0.id() as libc::pid_t, libc::SIGTERM) };
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(3) {
            if let Ok(Some(_)) = self.0.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Sends SIGTERM and expects a clean exit (code 0) within 10 s; returns the log.
fn stop_cleanly(mut d: Daemon) -> String {
    signal(&d.child, "TERM");
    let status = wait_exit(&mut d.child, Duration::from_secs(10));
    let log = read(&d.stderr);
    assert!(status.success(), "exit {status:?}: {log}");
    log
}

// ---------------------------------------------------------------- servers

/// A PulseAudio server of our own with a null sink, default sink and source.
struct Pulse {
    server: Option<Guard>,
    keepalive: Option<Guard>,
    dir: PathBuf,
    runtime: PathBuf,
    home: PathBuf,
}

impl Pulse {
    fn start(dir: &Path) -> Self {
        let runtime = dir.join("xdg");
        let home = dir.join("home");
        fs::create_dir_all(&runtime).unwrap();
        fs::create_dir_all(&home).unwrap();
        use std::os::unix::fs::PermissionsExt;
        fs::set_permissions(&runtime, fs::Permissions::from_mode(0o700)).unwrap();
        let mut pulse = Self {
            server: None,
            keepalive: None,
            dir: dir.to_path_buf(),
            runtime,
            home,
        };
        pulse.run();
        pulse
    }

    fn run(&mut self) {
        let log = self.dir.join("pulseaudio.log");
        self.server = Some(spawn(
            self.env(&mut Command::new("pulseaudio"))
                .args([
                    "-n",
                    "--daemonize=no",
                    "--exit-idle-time=-1",
                    "--disallow-exit",
                    "--load=module-null-sink sink_name=onomato_null",
                    "--load=module-native-protocol-unix",
                    "--log-target=stderr",
                ])
                .stdout(Stdio::null())
                .stderr(fs::File::create(&log).unwrap()),
            "pulseaudio",
        ));
        let start = Instant::now();
        while !self.pactl(&["info"]) {
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "PulseAudio did not start: {}",
                read(&log)
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        // The null sink starts in 2-second blocks: a playing stream and a suspend and
        // resume make data flow at once.
        self.keepalive = Some(spawn(
            self.env(&mut Command::new("pacat"))
                .args(["--playback", "--latency-msec=20"])
                .stdin(fs::File::open("/dev/zero").unwrap())
                .stdout(Stdio::null())
                .stderr(Stdio::null()),
            "pacat",
        ));
        std::thread::sleep(Duration::from_millis(300));
        assert!(self.pactl(&["suspend-sink", "onomato_null", "1"]));
        assert!(self.pactl(&["suspend-sink", "onomato_null", "0"]));
    }

    /// Kills the server (as a crash would) and starts a new one in its place.
    fn crash_and_restart(&mut self, down_for: Duration) {
        self.keepalive = None;
        self.server = None;
        std::thread::sleep(down_for);
        self.run();
    }

    fn env<'a>(&self, cmd: &'a mut Command) -> &'a mut Command {
        cmd.env("XDG_RUNTIME_DIR", &self.runtime)
            .env("HOME", &self.home)
            .env_remove("PULSE_SERVER")
    }

    fn pactl(&self, args: &[&str]) -> bool {
        self.env(&mut Command::new("pactl"))
            .args(args)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    }

    fn play(&self, file: &str) {
        let ok = self
            .env(&mut Command::new("paplay"))
            .args(["--latency-msec=50", file])
            .current_dir(root())
            .status()
            .unwrap()
            .success();
        assert!(ok, "paplay {file} failed");
    }
}

/// A JACK server of our own (dummy driver) and `jack_midi_dump` listening on it.
#[cfg(feature = "jack")]
struct Jack {
    // Dropped in this order: the receiver, then the server.
    _dump: Guard,
    _server: Server,
    name: String,
    dump: PathBuf,
}

#[cfg(feature = "jack")]
impl Jack {
    fn start(dir: &Path, tag: &str) -> Self {
        // A fixed name per test: JACK's registry holds 8 servers, and an entry left by
        // a server that died is reused only by a server of the same name.
        let name = format!("onomato_{tag}");
        let server = Server(spawn_child(
            Command::new("jackd")
                .env("JACK_NO_AUDIO_RESERVATION", "1")
                .args([
                    "-n",
                    &name,
                    "--no-realtime",
                    "-d",
                    "dummy",
                    "-r",
                    "48000",
                    "-p",
                    // 21 ms cycles: without real-time priority on a loaded machine,
                    // shorter ones come late now and then, and a client late in a
                    // cycle misses its messages (the daemon logs the late cycles).
                    "1024",
                ])
                .stdout(Stdio::null())
                .stderr(fs::File::create(dir.join("jackd.log")).unwrap()),
            "jackd (jackd2)",
        ));
        let start = Instant::now();
        loop {
            let up = Command::new("jack_lsp")
                .env("JACK_DEFAULT_SERVER", &name)
                .env("JACK_NO_START_SERVER", "1")
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .status()
                .is_ok_and(|s| s.success());
            if up {
                break;
            }
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "jackd did not start: {}",
                read(&dir.join("jackd.log"))
            );
            std::thread::sleep(Duration::from_millis(100));
        }
        let dump = dir.join("midi.txt");
        let dumper = spawn(
            Command::new("stdbuf")
                .args(["-oL", "jack_midi_dump"])
                .env("JACK_DEFAULT_SERVER", &name)
                .env("JACK_NO_START_SERVER", "1")
                .stdout(fs::File::create(&dump).unwrap())
                .stderr(Stdio::null()),
            "jack_midi_dump (jack-tools)",
        );
        // The receiver's port must exist before the daemon looks for it.
        let start = Instant::now();
        loop {
            let ports = Command::new("jack_lsp")
                .env("JACK_DEFAULT_SERVER", &name)
                .env("JACK_NO_START_SERVER", "1")
                .output()
                .map(|o| String::from_utf8_lossy(&o.stdout).to_string())
                .unwrap_or_default();
            if ports.contains("midi-monitor:input") {
                break;
            }
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "jack_midi_dump did not start: {ports}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        Self {
            _dump: dumper,
            _server: server,
            name,
            dump,
        }
    }

    /// Kills the server as a crash would (SIGKILL), then its receiver: a receiver that
    /// outlived its server would share the restarted server's wake-ups with the new
    /// receiver of the same name (jack2 reuses the dead server's synchronisation files).
    fn crash(self) -> PathBuf {
        let Jack {
            _dump,
            mut _server,
            dump,
            ..
        } = self;
        let _ = _server.0.kill();
        let _ = _server.0.wait();
        drop(_dump);
        dump
    }

    /// (status byte, note, velocity) of every message received.
    fn messages(&self) -> Vec<(u8, u8, u8)> {
        midi_messages(&self.dump)
    }
}

/// (channel, note) of the notes still on after `messages`, in order; a note-off whose
/// note is not on fails the test.
#[cfg(feature = "jack")]
fn notes_left_on(messages: &[(u8, u8, u8)]) -> Vec<(u8, u8)> {
    let mut sounding: Vec<(u8, u8)> = Vec::new();
    for m in messages {
        match m.0 & 0xF0 {
            0x90 if m.2 > 0 => sounding.push((m.0 & 0x0F, m.1)),
            0x80 => {
                let i = sounding
                    .iter()
                    .position(|s| *s == (m.0 & 0x0F, m.1))
                    .unwrap_or_else(|| panic!("note-off without note-on {m:?} in {messages:?}"));
                sounding.remove(i);
            }
            _ => {}
        }
    }
    sounding
}

/// (status byte, note, velocity) of every message `jack_midi_dump` printed to `dump`.
#[cfg(feature = "jack")]
fn midi_messages(dump: &Path) -> Vec<(u8, u8, u8)> {
    read(dump)
        .lines()
        .filter_map(|l| {
            let (_, rest) = l.split_once(':')?;
            let b: Vec<u8> = rest
                .split_whitespace()
                .take(3)
                .map(|h| u8::from_str_radix(h, 16))
                .collect::<Result<_, _>>()
                .ok()?;
            (b.len() == 3).then(|| (b[0], b[1], b[2]))
        })
        .collect()
}

// ---------------------------------------------------------------- the daemon

struct Daemon {
    child: Child,
    stdout: PathBuf,
    stderr: PathBuf,
}

impl Drop for Daemon {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start_listen(
    dir: &Path,
    args: &[&str],
    env: impl FnOnce(&mut Command) -> &mut Command,
) -> Daemon {
    let stdout = dir.join("listen.out");
    let stderr = dir.join("listen.err");
    let mut cmd = Command::new(BIN);
    cmd.arg("listen")
        .args(args)
        .current_dir(root())
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(fs::File::create(&stdout).unwrap())
        .stderr(fs::File::create(&stderr).unwrap());
    env(&mut cmd);
    let child = cmd.spawn().expect("cannot start onomato");
    Daemon {
        child,
        stdout,
        stderr,
    }
}

/// The example's truth: (onset, label, gain).
fn example_truth() -> Vec<(f64, String, f64)> {
    read(&root().join("examples/beat.truth.csv"))
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (
                f[0].parse().unwrap(),
                f[1].to_string(),
                f[3].parse().unwrap(),
            )
        })
        .collect()
}

/// Every labelled sound of the example was sent once, with its label, in order; the
/// strengths of each label rank like the gains it was played at.
fn check_example_osc(messages: &[OscLine], time_shift: Option<f64>) {
    let truth = example_truth();
    let sounds: Vec<&OscLine> = messages
        .iter()
        .filter(|m| {
            let parts: Vec<&str> = m.addr.split('/').collect();
            // /onomato/<pattern> and /onomato/<pattern>/begin
            (parts.len() == 3 && !["event", "status"].contains(&parts[2]))
                || (parts.len() == 4 && parts[3] == "begin")
        })
        .collect();
    let labels: Vec<String> = sounds
        .iter()
        .map(|m| m.addr.split('/').nth(2).unwrap().to_string())
        .collect();
    let expected: Vec<String> = truth.iter().map(|t| t.1.clone()).collect();
    assert_eq!(labels, expected, "patterns sent, in order");
    if let Some(shift) = time_shift {
        for (m, t) in sounds.iter().zip(&truth) {
            let time = m.f(1) - shift;
            // The waveform method starts the held "hoo" late: its unvoiced "h" does not
            // correlate with the vowel (see the README).
            let tolerance = if t.1 == "hoo" { 0.08 } else { 0.02 };
            assert!(
                (time - t.0).abs() < tolerance,
                "{m:?} vs truth onset {}",
                t.0
            );
        }
    }
    for label in ["tick", "pop", "boom"] {
        let mut pairs: Vec<(f64, f64)> = sounds
            .iter()
            .zip(&truth)
            .filter(|(_, t)| t.1 == label)
            .map(|(m, t)| (t.2, m.f(0)))
            .collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert!(
            pairs.windows(2).all(|w| w[0].1 < w[1].1),
            "{label}: strengths do not rank like the gains: {pairs:?}"
        );
    }
    // Every /begin has its /end, and /event carries the same sounds.
    let begins = messages
        .iter()
        .filter(|m| m.addr.ends_with("/begin"))
        .count();
    let ends = messages.iter().filter(|m| m.addr.ends_with("/end")).count();
    assert_eq!(begins, ends);
    let generic = messages
        .iter()
        .filter(|m| m.addr == "/onomato/event" && m.s(1) != "end")
        .count();
    assert_eq!(generic, truth.len());
}

#[test]
fn replayed_example_reaches_an_independent_osc_receiver() {
    let dir = common::temp_dir("listen-replay");
    let osc = OscDump::start(&dir);
    let mut d = start_listen(
        &dir,
        &[
            "-c",
            "config/onomato.toml",
            "--input",
            "examples/beat.wav",
            "--speed",
            "4",
            "--osc",
            &osc.target(),
            "--print",
            "json",
        ],
        |c| c,
    );
    let status = wait_exit(&mut d.child, Duration::from_secs(30));
    assert!(status.success(), "{}", read(&d.stderr));
    osc.wait_count(|m| m.addr == "/onomato/event", 15, Duration::from_secs(5));
    let messages = osc.messages();
    check_example_osc(&messages, Some(0.0));
    // The daemon printed what it sent: the same records `analyze` prints.
    let printed: Vec<serde_json::Value> = read(&d.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let analyzed = Command::new(BIN)
        .args(["analyze", "examples/beat.wav", "-c", "config/onomato.toml"])
        .current_dir(root())
        .output()
        .unwrap();
    let analyzed: serde_json::Value = serde_json::from_slice(&analyzed.stdout).unwrap();
    let complete: Vec<&serde_json::Value> = printed
        .iter()
        .filter(|e| e["kind"] == "impulse" || e.get("end").is_some())
        .collect();
    let analyzed = analyzed["events"].as_array().unwrap();
    assert_eq!(complete.len(), analyzed.len());
    for (a, b) in complete.iter().zip(analyzed) {
        assert_eq!(a["pattern"], b["pattern"]);
        assert_eq!(a["time"], b["time"]);
        assert_eq!(a["strength"], b["strength"]);
        assert_eq!(a["emitted_at"], b["emitted_at"]);
    }
}

/// The example's impulses as sent (`/onomato/<pattern>`), in order.
fn impulse_messages(messages: &[OscLine]) -> Vec<&OscLine> {
    messages
        .iter()
        .filter(|m| m.addr.matches('/').count() == 2 && !m.addr.ends_with("/event"))
        .collect()
}

/// Each impulse message with its delay: its arrival less the moment its sound was
/// played (the file's start at `played_at`, Unix seconds, plus the sound's onset).
fn arrival_delays(messages: &[OscLine], played_at: f64) -> Vec<(&OscLine, f64)> {
    let truth = example_truth();
    impulse_messages(messages)
        .into_iter()
        .zip(truth.iter().filter(|t| t.1 != "hoo"))
        .map(|(m, t)| (m, m.arrival - (played_at + t.0)))
        .collect()
}

#[test]
fn microphone_capture_through_pulseaudio_sends_one_osc_message_per_sound() {
    let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
    let dir = common::temp_dir("listen-pulse");
    let pulse = Pulse::start(&dir);
    let osc = OscDump::start(&dir);
    let d = start_listen(
        &dir,
        &[
            "-c",
            "config/onomato.toml",
            "--osc",
            &osc.target(),
            "--print",
            "json",
        ],
        |c| pulse.env(c),
    );
    wait_for_text(&d.stderr, "listening", Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(500));
    let played_at = unix_now();
    pulse.play("examples/beat.wav");
    osc.wait_count(|m| m.addr == "/onomato/event", 15, CAPTURE_CATCH_UP);
    let log = stop_cleanly(d);
    assert!(log.contains("capturing"), "{log}");
    let messages = osc.messages();
    // The stream starts when capture starts: the sounds' times are shifted by the wait
    // before paplay. Their spacing is the file's.
    check_example_osc(&messages, None);
    let truth = example_truth();
    let impulses = impulse_messages(&messages);
    let first = impulses[0].f(1);
    for (m, t) in impulses.iter().zip(truth.iter().filter(|t| t.1 != "hoo")) {
        assert!(
            (m.f(1) - first - (t.0 - truth[0].0)).abs() < 0.05,
            "{m:?} is not where the file puts it ({} s after the first sound)",
            t.0 - truth[0].0
        );
    }
    // End-to-end delay: from the sound's onset in the played file to the arrival.
    let mut delays: Vec<f64> = arrival_delays(&messages, played_at)
        .into_iter()
        .map(|(_, d)| d)
        .collect();
    delays.sort_by(f64::total_cmp);
    eprintln!(
        "end-to-end delay (waveform method, paplay start to OSC arrival): median {:.0} ms, worst {:.0} ms",
        delays[delays.len() / 2] * 1000.0,
        delays[delays.len() - 1] * 1000.0
    );
    assert!(
        delays[0] > 0.0,
        "a message arrived before its sound was played: {delays:?}"
    );
}

#[test]
fn a_reader_of_printed_events_that_stops_for_10_s_costs_printed_lines_only() {
    use std::os::fd::AsRawFd;
    let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
    let dir = common::temp_dir("listen-stalled-stdout");
    let pulse = Pulse::start(&dir);
    let osc = OscDump::start(&dir);
    // stdout is a pipe filled to the brim before the daemon starts, and not read for
    // the first 10 s: the daemon's first printed line blocks.
    let (mut reader, mut writer) = std::io::pipe().unwrap();
    let fd = writer.as_raw_fd();
    // SAFETY: fcntl(2) on a descriptor this test owns.
    let flags = unsafe { libc::fcntl(fd, libc::F_GETFL) };
    unsafe { libc::fcntl(fd, libc::F_SETFL, flags | libc::O_NONBLOCK) };
    let mut filler = 0usize;
    loop {
        match std::io::Write::write(&mut writer, &[b'#'; 4096]) {
            Ok(n) => filler += n,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => break,
            Err(e) => panic!("filling the pipe: {e}"),
        }
    }
    unsafe { libc::fcntl(fd, libc::F_SETFL, flags) };
    let stderr = dir.join("listen.err");
    let mut cmd = Command::new(BIN);
    cmd.args([
        "listen",
        "-c",
        "config/onomato.toml",
        "--osc",
        &osc.target(),
    ])
    .args(["--print", "json"])
    .current_dir(root())
    .env("RUST_LOG", "info")
    .stdin(Stdio::null())
    .stdout(writer)
    .stderr(fs::File::create(&stderr).unwrap());
    pulse.env(&mut cmd);
    let stalled_at = Instant::now();
    let d = Daemon {
        child: cmd.spawn().expect("cannot start onomato"),
        stdout: dir.join("unused"),
        stderr: stderr.clone(),
    };
    // The command holds the pipe's other end: the reader would never see its end.
    drop(cmd);
    wait_for_text(&stderr, "listening", Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(500));
    let played_at = unix_now();
    pulse.play("examples/beat.wav");
    osc.wait_count(|m| m.addr == "/onomato/event", 15, CAPTURE_CATCH_UP);
    // Every sound reached OSC as soon as it would with a reader, while nobody read.
    let messages = osc.messages();
    check_example_osc(&messages, None);
    for (m, delay) in arrival_delays(&messages, played_at) {
        assert!(
            delay < 0.5,
            "{m:?} arrived {delay:.3} s after its sound while stdout was not read"
        );
    }
    std::thread::sleep(Duration::from_secs(10).saturating_sub(stalled_at.elapsed()));
    let log = read(&stderr);
    assert!(
        !log.contains("delivered nothing") && !log.contains("open again"),
        "the input was taken for dead while stdout was not read:\n{log}"
    );
    // The reader comes back: the printed lines were waiting, none was lost.
    let drain = std::thread::spawn(move || {
        let mut all = Vec::new();
        let _ = std::io::Read::read_to_end(&mut reader, &mut all);
        all
    });
    let log = stop_cleanly(d);
    let printed = String::from_utf8(drain.join().unwrap()).unwrap();
    let lines: Vec<&str> = printed[filler..].lines().collect();
    assert_eq!(lines.len(), 15, "{printed}");
    for l in &lines {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert!(v["pattern"].is_string(), "{l}");
    }
    assert!(log.contains("printed_lines_dropped=0"), "{log}");
}

#[test]
fn the_daemon_outlives_a_crash_of_the_sound_server_and_captures_again() {
    let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
    let dir = common::temp_dir("listen-pulse-crash");
    let mut pulse = Pulse::start(&dir);
    let osc = OscDump::start(&dir);
    let d = start_listen(
        &dir,
        &["-c", "config/onomato.toml", "--osc", &osc.target()],
        |c| pulse.env(c),
    );
    wait_for_text(&d.stderr, "listening", Duration::from_secs(10));
    std::thread::sleep(Duration::from_millis(300));
    pulse.play("examples/beat.wav");
    let event = |m: &OscLine| m.addr == "/onomato/event" && m.s(1) != "begin";
    osc.wait_count(event, 13, CAPTURE_CATCH_UP);

    pulse.crash_and_restart(Duration::from_secs(1));
    wait_for_text(&d.stderr, "audio input open again", Duration::from_secs(20));
    std::thread::sleep(Duration::from_millis(300));
    pulse.play("examples/beat.wav");
    osc.wait_count(event, 26, CAPTURE_CATCH_UP);
    let labels: Vec<String> = osc
        .messages()
        .iter()
        .filter(|m| event(m))
        .map(|m| m.s(0).to_string())
        .collect();
    assert_eq!(
        labels[..13],
        labels[13..],
        "the second play is found like the first"
    );

    let _ = stop_cleanly(d);
}

#[test]
fn record_takes_sounds_from_the_microphone_and_asks_again_after_a_clipped_one() {
    let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
    let dir = common::temp_dir("record-pulse");
    let pulse = Pulse::start(&dir);
    let rate = 44_100;
    let mut good = vec![0.0f32; common::samples_for(0.2, rate)];
    good.extend(common::buzz(rate, 0.3, 170.0).iter().map(|x| x * 0.5));
    good.extend(vec![0.0f32; common::samples_for(0.2, rate)]);
    let clipped: Vec<f32> = good.iter().map(|x| (x * 6.0).clamp(-1.0, 1.0)).collect();
    // Stereo, both channels alike: the sink is stereo, and a mono file would reach the
    // capture at another level.
    let stereo = |x: &[f32]| x.iter().map(|&v| vec![v, v]).collect::<Vec<_>>();
    let good_wav = dir.join("good.wav");
    let clipped_wav = dir.join("clipped.wav");
    common::write_wav_int(&good_wav, &stereo(&good), rate, 16);
    common::write_wav_int(&clipped_wav, &stereo(&clipped), rate, 16);
    let takes = dir.join("takes");
    fs::create_dir_all(&takes).unwrap();
    let log = dir.join("record.err");
    let mut cmd = Command::new(BIN);
    cmd.args(["record", "hum", "--takes", "2", "--dir"])
        .arg(&takes)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(fs::File::create(&log).unwrap());
    let mut child = pulse.env(&mut cmd).spawn().unwrap();
    let play = |wav: &Path| {
        pulse.play(&wav.to_string_lossy());
    };
    let wait_count = |text: &str, n: usize| {
        let start = Instant::now();
        while read(&log).matches(text).count() < n {
            assert!(
                start.elapsed() < Duration::from_secs(20),
                "no '{text}' ×{n}: {}",
                read(&log)
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    wait_count("take 1 of 2: now!", 1);
    play(&good_wav);
    wait_count("take 2 of 2: now!", 1);
    play(&clipped_wav);
    wait_count("refused: clipped", 1);
    wait_count("take 2 of 2: now!", 2);
    play(&good_wav);
    let status = wait_exit(&mut child, Duration::from_secs(20));
    let text = read(&log);
    assert!(status.success(), "{text}");
    assert!(text.contains("level"), "no live level: {text}");
    for k in 1..=2 {
        let path = takes.join(format!("hum-{k}.wav"));
        let r = hound::WavReader::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let seconds = r.duration() as f64 / f64::from(r.spec().sample_rate);
        assert!(
            (seconds - 0.32).abs() < 0.03,
            "take {k} is {seconds} s: {text}"
        );
    }
    assert!(!takes.join("hum-3.wav").exists());
    assert!(text.contains("--pattern hum="), "{text}");
}

#[test]
fn record_background_takes_seconds_of_the_microphone_and_finds_its_sounds() {
    let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
    let dir = common::temp_dir("record-background-pulse");
    let pulse = Pulse::start(&dir);
    let rate = 44_100;
    // Four syllable-like sounds 0.8 s apart, as talking gives them.
    let mut talking = vec![0.0f32; common::samples_for(3.6, rate)];
    for k in 0..4 {
        let at = common::samples_for(0.3 + 0.8 * k as f64, rate);
        common::place(
            &mut talking,
            &common::buzz(rate, 0.25, 120.0 + 30.0 * k as f64),
            at,
            0.4,
        );
    }
    let stereo: Vec<Vec<f32>> = talking.iter().map(|&v| vec![v, v]).collect();
    let talking_wav = dir.join("talking-play.wav");
    common::write_wav_int(&talking_wav, &stereo, rate, 16);
    let log = dir.join("record.err");
    let mut cmd = Command::new(BIN);
    cmd.args(["record", "me", "--background", "--seconds", "5", "--dir"])
        .arg(&dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(fs::File::create(&log).unwrap());
    let mut child = pulse.env(&mut cmd).spawn().unwrap();
    let start = Instant::now();
    while !read(&log).contains("background: now!") {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "no countdown: {}",
            read(&log)
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    pulse.play(&talking_wav.to_string_lossy());
    let status = wait_exit(&mut child, Duration::from_secs(20));
    let text = read(&log);
    assert!(status.success(), "{text}");
    let saved = dir.join("me.wav");
    let r = hound::WavReader::open(&saved).unwrap_or_else(|e| panic!("{}: {e}", saved.display()));
    let seconds = r.duration() as f64 / f64::from(r.spec().sample_rate);
    assert!((seconds - 5.0).abs() < 0.05, "{seconds} s: {text}");
    let sounds: usize = text
        .split(" sounds that must never fire")
        .next()
        .and_then(|head| head.rsplit(", ").next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no count of sounds: {text}"));
    assert!((4..=8).contains(&sounds), "{sounds} sounds: {text}");
    assert!(text.contains("use it with: --background "), "{text}");
}

#[test]
fn an_unreachable_osc_target_does_not_stop_the_daemon() {
    let dir = common::temp_dir("listen-unreachable");
    let osc = OscDump::start(&dir);
    let closed = free_udp_port();
    let mut d = start_listen(
        &dir,
        &[
            "-c",
            "config/onomato.toml",
            "--input",
            "examples/beat.wav",
            "--speed",
            "8",
            "--osc",
            &format!("127.0.0.1:{closed}"),
            "--osc",
            "no-such-host.invalid:9000",
            "--osc",
            &osc.target(),
        ],
        |c| c,
    );
    let status = wait_exit(&mut d.child, Duration::from_secs(30));
    assert!(status.success(), "{}", read(&d.stderr));
    let log = read(&d.stderr);
    assert!(
        log.contains("no-such-host.invalid"),
        "the bad host is not named: {log}"
    );
    osc.wait_count(|m| m.addr == "/onomato/event", 15, Duration::from_secs(5));
    check_example_osc(&osc.messages(), Some(0.0));
}

#[test]
fn an_osc_receiver_that_goes_away_and_comes_back_gets_the_later_events() {
    let dir = common::temp_dir("listen-receiver-back");
    let first = OscDump::start(&dir);
    let port = first.port;
    let mut d = start_listen(
        &dir,
        &[
            "-c",
            "config/onomato.toml",
            "--input",
            "examples/beat.wav",
            "--repeat",
            "4",
            "--speed",
            "4",
            "--osc",
            &first.target(),
        ],
        |c| c,
    );
    first.wait_count(|m| m.addr == "/onomato/event", 3, Duration::from_secs(10));
    // The receiver quits (its port is closed: sends fail with "connection refused")...
    drop(first);
    std::thread::sleep(Duration::from_millis(1500));
    // ...and a new one starts on the same port.
    let second = OscDump::start_on(&dir, port, "-again");
    let status = wait_exit(&mut d.child, Duration::from_secs(30));
    assert!(status.success(), "{}", read(&d.stderr));
    let times: Vec<f64> = second
        .messages()
        .iter()
        .filter(|m| m.addr == "/onomato/event")
        .map(|m| m.f(3))
        .collect();
    // The replay lasts 40 s of stream (10 s at 4x); the receiver was back after at most
    // 2.5 s of wall time: the last 25 s of stream, about 35 sounds, reached it.
    assert!(
        times.len() >= 30,
        "{} events after the receiver came back: {times:?}",
        times.len()
    );
    assert!(times.last().is_some_and(|&t| t > 38.0), "{times:?}");
}

/// A `[[pattern]]` of the example's patterns, with its take's absolute path and any
/// `extra` lines.
fn example_pattern(name: &str, extra: &str) -> String {
    let take = root().join("examples/patterns").join(format!("{name}.wav"));
    format!(
        "[[pattern]]\nname = \"{name}\"\ntakes = [\"{}\"]\n{extra}\n",
        take.display()
    )
}

/// The example's four patterns, as the example config has them.
fn all_example_patterns() -> String {
    ["tick", "pop", "boom"]
        .iter()
        .map(|n| example_pattern(n, ""))
        .chain([example_pattern("hoo", "kind = \"continuous\"")])
        .collect()
}

fn write_config(path: &Path, prefix: &str, threshold: &str, osc: &str) {
    let patterns: String = ["tick", "pop", "boom"]
        .iter()
        .map(|n| example_pattern(n, ""))
        .collect();
    let text = format!(
        "[detector]\nthreshold = {threshold}\n\n{patterns}\n[osc]\ntargets = [\"{osc}\"]\nprefix = \"{prefix}\"\n"
    );
    fs::write(path, text).unwrap();
}

/// config/duo.toml with its takes' paths made absolute, its OSC to `osc` and no MIDI,
/// and the runner's OSC prefix `runner_prefix`.
fn duo_config(osc: &str, runner_prefix: &str) -> String {
    let examples = root().join("examples");
    read(&root().join("config/duo.toml"))
        .replace("\"../examples", &format!("\"{}", examples.display()))
        .replace(
            "targets = [\"127.0.0.1:9000\"]",
            &format!("targets = [\"{osc}\"]"),
        )
        .replace("[midi]\nvirtual_port = \"onomato\"\n", "")
        .replace(
            "# osc_prefix = \"/runner\"",
            &format!("osc_prefix = \"{runner_prefix}\""),
        )
}

#[test]
fn sighup_reloads_one_performer_and_leaves_the_other_running() {
    let dir = common::temp_dir("listen-reload-performer");
    let osc = OscDump::start(&dir);
    let config = dir.join("duo.toml");
    fs::write(&config, duo_config(&osc.target(), "/before")).unwrap();
    let stereo = common::duel_in_stereo(&dir);
    let config_arg = config.to_string_lossy().to_string();
    let stereo_arg = stereo.to_string_lossy().to_string();
    let mut d = start_listen(&dir, &["-c", &config_arg, "--input", &stereo_arg], |c| c);
    wait_for_text(&d.stderr, "listening", Duration::from_secs(10));
    let started = Instant::now();
    // A channel the stereo input does not have: refused by name, the running
    // configuration kept.
    std::thread::sleep(Duration::from_millis(1000));
    let runner_on_3 =
        duo_config(&osc.target(), "/before").replace("channel = 1\n", "channel = 3\n");
    fs::write(&config, runner_on_3).unwrap();
    signal(&d.child, "HUP");
    wait_for_text(
        &d.stderr,
        "reload refused, keeping the running configuration: performer 'runner': channel 3 (counted from 0), but the input has 2 channels",
        Duration::from_secs(5),
    );
    // After the runner's second hup (2.8 s) and before its third (4.9 s), outside its
    // held sounds: its prefix changes, nothing else does.
    std::thread::sleep(Duration::from_millis(3200).saturating_sub(started.elapsed()));
    fs::write(&config, duo_config(&osc.target(), "/after")).unwrap();
    signal(&d.child, "HUP");
    let status = wait_exit(&mut d.child, Duration::from_secs(30));
    assert!(status.success(), "{}", read(&d.stderr));
    let log = read(&d.stderr);
    assert!(
        log.contains("configuration reloaded") && log.contains("changed=osc"),
        "{log}"
    );
    std::thread::sleep(Duration::from_millis(300));
    let m = osc.messages();
    let count = |prefix: &str| {
        m.iter()
            .filter(|m| m.addr.starts_with(prefix) && m.addr.ends_with("/event"))
            .count()
    };
    // All 7 shots on the shooter's prefix; the runner's 10 messages (4 hups, 3 held
    // whoos) split at the reload, none lost.
    assert_eq!(count("/onomato/shooter/"), 7, "{m:#?}");
    let (before, after) = (count("/before/"), count("/after/"));
    assert_eq!(before + after, 10, "{m:#?}");
    assert!(
        before >= 3 && after >= 3,
        "before {before}, after {after}: {m:#?}"
    );
    // The shooter's detector was not replaced: its numbering runs on unbroken.
    let ids: Vec<i64> = m
        .iter()
        .filter(|m| m.addr == "/onomato/shooter/event")
        .map(|m| m.f(5) as i64)
        .collect();
    assert_eq!(ids, (0..7).collect::<Vec<i64>>());
}

#[test]
fn sighup_reloads_a_good_config_and_keeps_the_old_one_when_the_new_one_is_broken() {
    let dir = common::temp_dir("listen-reload");
    let osc = OscDump::start(&dir);
    let config = dir.join("onomato.toml");
    write_config(&config, "/one", "0.5", &osc.target());
    let config_arg = config.to_string_lossy().to_string();
    let d = start_listen(
        &dir,
        &[
            "-c",
            &config_arg,
            "--input",
            "examples/beat.wav",
            "--repeat",
            "10",
            "--speed",
            "2",
        ],
        |c| c,
    );
    osc.wait_count(|m| m.addr.starts_with("/one/"), 2, Duration::from_secs(10));

    // Broken: refused, the old config keeps running.
    write_config(&config, "/two", "7", &osc.target());
    signal(&d.child, "HUP");
    wait_for_text(&d.stderr, "reload refused", Duration::from_secs(5));
    assert!(read(&d.stderr).contains("threshold must be greater than 0 and at most 1, found 7"));
    let before = osc
        .messages()
        .iter()
        .filter(|m| m.addr.starts_with("/one/"))
        .count();
    osc.wait_count(
        |m| m.addr.starts_with("/one/"),
        before + 2,
        Duration::from_secs(10),
    );

    // Good: taken, with its new prefix and threshold; only what changed is rebuilt.
    write_config(&config, "/two", "0.45", &osc.target());
    signal(&d.child, "HUP");
    wait_for_text(&d.stderr, "configuration reloaded", Duration::from_secs(5));
    assert!(
        read(&d.stderr).contains("changed=detector, osc"),
        "{}",
        read(&d.stderr)
    );
    osc.wait_count(|m| m.addr.starts_with("/two/"), 2, Duration::from_secs(10));
    let messages = osc.messages();
    let first_two = messages
        .iter()
        .position(|m| m.addr.starts_with("/two/"))
        .unwrap();
    assert!(
        messages[first_two..]
            .iter()
            .all(|m| !m.addr.starts_with("/one/")),
        "the old prefix was used after the reload"
    );
    // Stream time goes on across the reload.
    let times: Vec<f64> = messages
        .iter()
        .filter(|m| m.addr.ends_with("/event"))
        .map(|m| m.f(3))
        .collect();
    assert!(
        times.windows(2).all(|w| w[1] > w[0] - 0.5),
        "times went back: {times:?}"
    );

    let _ = stop_cleanly(d);
}

#[test]
fn bounce_hits_states_and_status_reach_osc() {
    let dir = common::temp_dir("listen-bounce");
    let osc = OscDump::start(&dir);
    let config = dir.join("bounce.toml");
    // All four of the example's sounds are enrolled: with the spectral method, a sound
    // that is none of the patterns (the held "hoo") would be taken for the nearest one.
    let patterns = all_example_patterns();
    fs::write(
        &config,
        format!(
            "{patterns}\n[osc]\ntargets = [\"{}\"]\nheartbeat_seconds = 0.5\nbounce_state_rate = 100\n\n[bounce]\nhard = [\"tick\", \"boom\"]\nsoft = [\"pop\"]\nslide = [\"hoo\"]\n",
            osc.target()
        ),
    )
    .unwrap();
    let config_arg = config.to_string_lossy().to_string();
    let mut d = start_listen(
        &dir,
        &[
            "-c",
            &config_arg,
            "--input",
            "examples/beat.wav",
            "--speed",
            "2",
        ],
        |c| c,
    );
    let status = wait_exit(&mut d.child, Duration::from_secs(30));
    assert!(status.success(), "{}", read(&d.stderr));
    std::thread::sleep(Duration::from_millis(300));
    let m = osc.messages();
    let hits: Vec<&OscLine> = m
        .iter()
        .filter(|m| m.addr == "/onomato/bounce/hit")
        .collect();
    // One launch per tick, boom and pop (11), and one at the end of each held "hoo"'s
    // slide (2).
    assert_eq!(hits.len(), 13, "{hits:?}");
    for h in &hits {
        // v0 = g·Δ/2 and apex = g·Δ²/8 for the predicted flight Δ.
        let flight = h.f(2) - h.f(1);
        assert!((h.f(0) - 9.81 * flight / 2.0).abs() < 1e-3, "{h:?}");
        assert!(
            (h.f(3) - 9.81 * flight * flight / 8.0).abs() < 1e-3,
            "{h:?}"
        );
    }
    let states: Vec<(f64, f64)> = m
        .iter()
        .filter(|m| m.addr == "/onomato/bounce/state")
        .map(|m| (m.f(2), m.f(0)))
        .collect();
    assert!(states.len() > 500, "{} states", states.len());
    assert!(states.iter().all(|s| s.1 >= 0.0), "below the floor");
    for h in &hits {
        let at = states
            .iter()
            .find(|s| (s.0 - h.f(1)).abs() < 1e-5)
            .unwrap_or_else(|| panic!("no state at the hit {h:?}"));
        assert_eq!(at.1, 0.0, "not on the floor at the hit {h:?}");
    }
    let heartbeats = m.iter().filter(|m| m.addr == "/onomato/status").count();
    assert!(
        heartbeats >= 5,
        "{heartbeats} status messages in 5 s at one per 0.5 s"
    );
}

#[test]
fn bundles_carry_the_onset_as_their_timetag() {
    let dir = common::temp_dir("listen-bundle");
    let osc = OscDump::start(&dir);
    let config = dir.join("bundle.toml");
    // All four sounds are enrolled: with the spectral method, a tick right after a
    // sound that is none of the patterns is taken for speech and ignored.
    fs::write(
        &config,
        format!(
            "{}\n[osc]\ntargets = [\"{}\"]\nbundle = true\n",
            all_example_patterns(),
            osc.target()
        ),
    )
    .unwrap();
    let config_arg = config.to_string_lossy().to_string();
    let mut d = start_listen(
        &dir,
        &["-c", &config_arg, "--input", "examples/beat.wav"],
        |c| c,
    );
    assert!(
        wait_exit(&mut d.child, Duration::from_secs(30)).success(),
        "{}",
        read(&d.stderr)
    );
    osc.wait_count(|m| m.addr == "/onomato/tick", 5, Duration::from_secs(5));
    // oscdump prints a bundle's timetag (for a lone message, the arrival): the
    // timetags are the onsets on the wall clock, though the messages left later.
    let ticks: Vec<OscLine> = osc
        .messages()
        .into_iter()
        .filter(|m| m.addr == "/onomato/tick")
        .collect();
    for pair in ticks.windows(2) {
        let tag_gap = pair[1].arrival - pair[0].arrival;
        let onset_gap = pair[1].f(1) - pair[0].f(1);
        assert!(
            (tag_gap - onset_gap).abs() < 0.002,
            "timetag gap {tag_gap} vs onset gap {onset_gap}"
        );
    }
    let wall_origin = ticks[0].arrival - ticks[0].f(1);
    assert!(wall_origin < unix_now() && unix_now() - wall_origin < 60.0);
}

/// A held tone that the spectral method follows from its begin.
fn held_tone_files(dir: &Path) -> (PathBuf, PathBuf) {
    let rate = 22_050;
    let tone = common::buzz(rate, 0.3, 180.0);
    let pattern = dir.join("hum.wav");
    common::write_wav_f32(&pattern, &tone, rate);
    let mut rec = vec![0.0f32; common::samples_for(6.0, rate)];
    let held = common::buzz(rate, 5.0, 180.0);
    common::place(&mut rec, &held, common::samples_for(0.5, rate), 0.8);
    common::add_noise(&mut rec, 0.0005, 3);
    let recording = dir.join("held.wav");
    common::write_wav_f32(&recording, &rec, rate);
    (pattern, recording)
}

/// Replays a 5 s held tone (from 0.5 s) with the spectral method, its first 0.3 s
/// enrolled as the continuous pattern "hum", events printed as JSON, and `extra`
/// arguments (the outputs).
fn listen_to_held_tone(
    dir: &Path,
    extra: &[&str],
    env: impl FnOnce(&mut Command) -> &mut Command,
) -> Daemon {
    let (pattern, recording) = held_tone_files(dir);
    let hum = format!("hum={}:continuous", pattern.display());
    let recording = recording.to_string_lossy().into_owned();
    let mut args = vec![
        "--pattern",
        &hum,
        "--method",
        "spectral",
        "--input",
        &recording,
    ];
    args.extend_from_slice(&["--print", "json"]);
    args.extend_from_slice(extra);
    start_listen(dir, &args, env)
}

#[test]
fn sigint_in_the_middle_of_a_held_sound_ends_it_on_osc() {
    let dir = common::temp_dir("listen-cutoff-osc");
    let osc = OscDump::start(&dir);
    let target = osc.target();
    let d = listen_to_held_tone(&dir, &["--osc", &target], |c| c);
    osc.wait_count(
        |m| m.addr == "/onomato/hum/begin",
        1,
        Duration::from_secs(10),
    );
    std::thread::sleep(Duration::from_millis(500));
    signal(&d.child, "INT");
    let mut d = d;
    let status = wait_exit(&mut d.child, Duration::from_secs(10));
    assert!(status.success(), "{}", read(&d.stderr));
    osc.wait_count(|m| m.addr == "/onomato/hum/end", 1, Duration::from_secs(5));
    let m = osc.messages();
    let begin = m.iter().find(|m| m.addr == "/onomato/hum/begin").unwrap();
    let end = m.iter().find(|m| m.addr == "/onomato/hum/end").unwrap();
    assert!((begin.f(1) - 0.5).abs() < 0.05, "{begin:?}");
    assert!(end.f(1) > 0.9 && end.f(1) < 5.5, "cut off at {end:?}");
    assert_eq!(
        begin.args[2], end.args[2],
        "begin and end carry the same id"
    );
}

#[cfg(feature = "jack")]
mod jack {
    use super::*;

    #[test]
    fn midi_notes_arrive_at_jack_with_the_configured_note_channel_and_velocity() {
        let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
        let dir = common::temp_dir("listen-jack");
        let jack = Jack::start(&dir, "notes");
        let config = dir.join("midi.toml");
        let patterns = [
            example_pattern("tick", "note = 42"),
            example_pattern("pop", "note = 38\nchannel = 3"),
            example_pattern("boom", "note = 36"),
            example_pattern("hoo", "kind = \"continuous\"\nnote = 60"),
        ]
        .concat();
        let midi = "[midi]\nconnect = \"midi-monitor\"\nchannel = 10\ngate_seconds = 0.03\nfull_strength = 1.25\nstrength_cc = 11\n";
        fs::write(&config, format!("{patterns}\n{midi}")).unwrap();
        let config_arg = config.to_string_lossy().to_string();
        let mut d = start_listen(
            &dir,
            &[
                "-c",
                &config_arg,
                "--input",
                "examples/beat.wav",
                "--speed",
                "4",
                "--print",
                "json",
            ],
            |c| {
                c.env("JACK_DEFAULT_SERVER", &jack.name)
                    .env("JACK_NO_START_SERVER", "1")
            },
        );
        let status = wait_exit(&mut d.child, Duration::from_secs(30));
        assert!(status.success(), "{}", read(&d.stderr));
        std::thread::sleep(Duration::from_millis(300));
        let midi = jack.messages();
        let ons: Vec<&(u8, u8, u8)> = midi
            .iter()
            .filter(|m| m.0 & 0xF0 == 0x90 && m.2 > 0)
            .collect();
        // A held sound's note-on follows a control change 11 with its velocity.
        for (i, m) in midi.iter().enumerate() {
            if m.0 == 0x99 && m.1 == 60 {
                assert!(
                    i > 0 && midi[i - 1] == (0xB9, 11, m.2),
                    "no CC 11 before {m:?}: {midi:?}"
                );
            }
        }
        assert_eq!(midi.iter().filter(|m| m.0 == 0xB9).count(), 2, "{midi:?}");
        let offs: Vec<&(u8, u8, u8)> = midi.iter().filter(|m| m.0 & 0xF0 == 0x80).collect();
        // The events the daemon printed, in order, give the expected notes.
        let events: Vec<serde_json::Value> = read(&d.stdout)
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            // A held sound's note-on leaves at its begin, with the begin's strength.
            .filter(|e: &serde_json::Value| e["kind"] == "impulse" || e.get("end").is_none())
            .collect();
        assert_eq!(events.len(), 13, "{}", read(&d.stdout));
        assert_eq!(
            ons.len(),
            events.len(),
            "one note-on per sound: {midi:?}\n{}",
            read(&d.stderr)
        );
        for (on, e) in ons.iter().zip(&events) {
            let (note, channel) = match e["pattern"].as_str().unwrap() {
                "tick" => (42, 10),
                "pop" => (38, 3),
                "boom" => (36, 10),
                "hoo" => (60, 10),
                other => panic!("unexpected pattern {other}"),
            };
            assert_eq!(on.1, note, "{e}");
            assert_eq!(on.0, 0x90 | (channel - 1), "{e}");
            let strength = e["strength"].as_f64().unwrap();
            let velocity = (1.0 + 126.0 * (strength / 1.25).clamp(0.0, 1.0)).round() as u8;
            assert!(
                (i16::from(on.2) - i16::from(velocity)).abs() <= 1,
                "velocity {} for {e}",
                on.2
            );
        }
        // Every note-on has its note-off, on the same channel and note.
        let sounding = notes_left_on(&midi);
        assert!(sounding.is_empty(), "notes left on: {sounding:?}");
        assert_eq!(offs.len(), ons.len());
    }

    #[test]
    fn reloads_that_change_the_osc_prefix_or_a_note_keep_the_jack_connection_and_the_held_sound() {
        let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
        let dir = common::temp_dir("listen-reload-difference");
        let jack = Jack::start(&dir, "reload");
        let osc = OscDump::start(&dir);
        let (pattern, recording) = held_tone_files(&dir);
        let config = dir.join("onomato.toml");
        let write = |prefix: &str, note: u8| {
            fs::write(
                &config,
                format!(
                    "[detector]\nmethod = \"spectral\"\n\n[[pattern]]\nname = \"hum\"\nkind = \"continuous\"\nnote = {note}\ntakes = [\"{}\"]\n\n[osc]\ntargets = [\"{}\"]\nprefix = \"{prefix}\"\n\n[midi]\nvirtual_port = \"drums\"\n",
                    pattern.display(),
                    osc.target()
                ),
            )
            .unwrap()
        };
        write("/one", 36);
        let config_arg = config.to_string_lossy().into_owned();
        let recording = recording.to_string_lossy().into_owned();
        fn on_jack<'a>(c: &'a mut Command, server: &str) -> &'a mut Command {
            c.env("JACK_DEFAULT_SERVER", server)
                .env("JACK_NO_START_SERVER", "1")
        }
        let server = jack.name.clone();
        let d = start_listen(
            &dir,
            &["-c", &config_arg, "--input", &recording, "--print", "json"],
            |c| on_jack(c, &server),
        );
        wait_for_text(&d.stderr, "MIDI output open", Duration::from_secs(10));
        let ports = String::from_utf8_lossy(
            &on_jack(&mut Command::new("jack_lsp"), &server)
                .output()
                .unwrap()
                .stdout,
        )
        .to_string();
        let ours = ports
            .lines()
            .find(|p| p.ends_with(":drums"))
            .unwrap_or_else(|| panic!("no port named drums: {ports}"))
            .to_string();
        let ok = on_jack(&mut Command::new("jack_connect"), &server)
            .args([ours.as_str(), "midi-monitor:input"])
            .status()
            .unwrap()
            .success();
        assert!(ok, "jack_connect {ours} failed");
        // The held sound begins at 0.5 s and lasts 5 s; the reload comes in its middle.
        osc.wait_count(|m| m.addr == "/one/hum/begin", 1, Duration::from_secs(10));
        std::thread::sleep(Duration::from_millis(500));
        let still_connected = || {
            let connections = String::from_utf8_lossy(
                &on_jack(&mut Command::new("jack_lsp"), &server)
                    .arg("-c")
                    .output()
                    .unwrap()
                    .stdout,
            )
            .to_string();
            let after_ours: Vec<&str> = connections
                .lines()
                .skip_while(|l| *l != ours)
                .skip(1)
                .take_while(|l| l.starts_with(' '))
                .collect();
            assert!(
                after_ours.iter().any(|l| l.trim() == "midi-monitor:input"),
                "the connection to the port did not survive the reload:\n{connections}"
            );
        };
        write("/two", 36);
        signal(&d.child, "HUP");
        wait_for_text(&d.stderr, "changed=osc", Duration::from_secs(5));
        still_connected();
        // A new note for the pattern: the note that is on is released, the port stays.
        std::thread::sleep(Duration::from_millis(500));
        write("/two", 40);
        signal(&d.child, "HUP");
        wait_for_text(&d.stderr, "changed=midi", Duration::from_secs(5));
        still_connected();
        osc.wait_count(|m| m.addr == "/two/hum/end", 1, Duration::from_secs(10));
        let log = stop_cleanly(d);
        assert!(!log.contains("changed=detector"), "{log}");
        let m = osc.messages();
        assert!(
            !m.iter().any(|m| m.addr == "/one/hum/end"),
            "the reload ended the held sound"
        );
        let begin = m.iter().find(|m| m.addr == "/one/hum/begin").unwrap();
        let end = m.iter().find(|m| m.addr == "/two/hum/end").unwrap();
        assert_eq!(begin.args[2], end.args[2], "one sound, one id");
        assert!(
            (end.f(1) - 5.5).abs() < 0.1,
            "ended at {end:?}, not where the tone ends"
        );
        // One note for the one sound, on at its begin and off once, at the reload that
        // changed its note: none at the reload of the prefix.
        let notes: Vec<(u8, u8, u8)> = jack.messages();
        let ons: Vec<u8> = notes
            .iter()
            .filter(|n| n.0 == 0x99 && n.2 > 0)
            .map(|n| n.1)
            .collect();
        let offs: Vec<u8> = notes
            .iter()
            .filter(|n| n.0 == 0x89 || (n.0 == 0x99 && n.2 == 0))
            .map(|n| n.1)
            .collect();
        assert_eq!((ons, offs), (vec![36], vec![36]), "{notes:?}");
    }

    #[test]
    fn a_virtual_port_can_be_connected_to_by_another_program() {
        let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
        let dir = common::temp_dir("listen-jack-virtual");
        let jack = Jack::start(&dir, "virtual");
        let d = start_listen(
            &dir,
            &[
                "-c",
                "config/onomato.toml",
                "--input",
                "examples/beat.wav",
                "--repeat",
                "3",
                "--speed",
                "4",
                "--midi-virtual",
                "drums",
                "--print",
                "json",
            ],
            |c| {
                c.env("JACK_DEFAULT_SERVER", &jack.name)
                    .env("JACK_NO_START_SERVER", "1")
            },
        );
        wait_for_text(&d.stderr, "MIDI output open", Duration::from_secs(10));
        // Another program connects the daemon's port to the receiver.
        let ports = Command::new("jack_lsp")
            .env("JACK_DEFAULT_SERVER", &jack.name)
            .output()
            .unwrap();
        let ports = String::from_utf8_lossy(&ports.stdout).to_string();
        let ours = ports
            .lines()
            .find(|p| p.ends_with(":drums"))
            .unwrap_or_else(|| panic!("no port named drums: {ports}"))
            .to_string();
        let ok = Command::new("jack_connect")
            .args([ours.as_str(), "midi-monitor:input"])
            .env("JACK_DEFAULT_SERVER", &jack.name)
            .status()
            .unwrap()
            .success();
        assert!(ok, "jack_connect {ours} failed");
        let start = Instant::now();
        while jack.messages().iter().filter(|m| m.0 == 0x99).count() < 3 {
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "no notes through the virtual port"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = stop_cleanly(d);
        // The example config's notes: tick 42, pop 38, boom 36, hoo 60.
        let notes: Vec<u8> = jack
            .messages()
            .iter()
            .filter(|m| m.0 == 0x99)
            .map(|m| m.1)
            .collect();
        assert!(
            notes.iter().all(|n| [42, 38, 36, 60].contains(n)),
            "{notes:?}"
        );
    }

    #[test]
    fn a_jack_server_killed_and_restarted_gets_the_notes_that_were_on_released_and_the_later_notes()
    {
        let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
        let dir = common::temp_dir("listen-jack-restart");
        let (before_dir, after_dir) = (dir.join("before"), dir.join("after"));
        fs::create_dir_all(&before_dir).unwrap();
        fs::create_dir_all(&after_dir).unwrap();
        let before = Jack::start(&before_dir, "restart");
        let server = before.name.clone();
        let config = dir.join("midi.toml");
        // A long gate, so that notes are on when the server dies.
        fs::write(
            &config,
            format!(
                "{}\n[midi]\nconnect = \"midi-monitor\"\ngate_seconds = 1.0\n",
                all_example_patterns()
            ),
        )
        .unwrap();
        let config_arg = config.to_string_lossy().into_owned();
        let mut d = start_listen(
            &dir,
            &[
                "-c",
                &config_arg,
                "--input",
                "examples/beat.wav",
                "--repeat",
                "3",
                "--speed",
                "2",
                "--print",
                "json",
            ],
            |c| {
                c.env("JACK_DEFAULT_SERVER", &server)
                    .env("JACK_NO_START_SERVER", "1")
            },
        );
        wait_for_text(&d.stderr, "MIDI output open", Duration::from_secs(10));
        // The third sound's note has left; the server dies while it is on.
        let start = Instant::now();
        while read(&d.stdout).lines().count() < 3 {
            assert!(start.elapsed() < Duration::from_secs(10), "no events");
            std::thread::sleep(Duration::from_millis(10));
        }
        std::thread::sleep(Duration::from_millis(100));
        let before_dump = before.crash();
        wait_for_text(&d.stderr, "MIDI output lost", Duration::from_secs(5));
        let after = Jack::start(&after_dir, "restart");
        let start = Instant::now();
        while read(&d.stderr).matches("MIDI output open").count() < 2 {
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "the port did not come back: {}",
                read(&d.stderr)
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        let status = wait_exit(&mut d.child, Duration::from_secs(30));
        assert!(status.success(), "{}", read(&d.stderr));
        std::thread::sleep(Duration::from_millis(300));
        let log = read(&d.stderr);
        assert!(log.contains("midi_ports_lost=1"), "{log}");

        // The notes the first server's receiver was left with.
        let first = midi_messages(&before_dump);
        let left_on = notes_left_on(&first);
        assert!(
            !left_on.is_empty(),
            "no note was on at the crash: {first:?}"
        );
        // The restarted server's receiver: the note-offs owed first, then whole notes.
        let second = after.messages();
        let owed: Vec<(u8, u8)> = second
            .iter()
            .take_while(|m| m.0 & 0xF0 == 0x80)
            .map(|m| (m.0 & 0x0F, m.1))
            .collect();
        for (channel, note) in &left_on {
            assert!(
                owed.contains(&(*channel, *note)),
                "note {note} on at the crash was not released on reconnect: {second:?}"
            );
        }
        let sounding = notes_left_on(&second[owed.len()..]);
        assert!(sounding.is_empty(), "notes left on: {sounding:?}");
        // The last play of the three (10-15 s of wall time) is wholly after the
        // restart: its 13 sounds at least.
        let later_ons = second.iter().filter(|m| m.0 & 0xF0 == 0x90).count();
        assert!(
            later_ons >= 13,
            "{later_ons} notes after the restart: {second:?}"
        );
    }

    #[test]
    fn sigterm_during_a_held_sound_releases_its_note() {
        let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
        let dir = common::temp_dir("listen-jack-cutoff");
        let jack = Jack::start(&dir, "cutoff");
        let d = listen_to_held_tone(&dir, &["--midi", "midi-monitor"], |c| {
            c.env("JACK_DEFAULT_SERVER", &jack.name)
                .env("JACK_NO_START_SERVER", "1")
        });
        wait_for_text(&d.stdout, "\"continuous\"", Duration::from_secs(10));
        std::thread::sleep(Duration::from_millis(500));
        let held: Vec<(u8, u8, u8)> = jack.messages();
        assert_eq!(
            held.iter().filter(|m| m.0 == 0x99).count(),
            1,
            "the held note is on before the stop: {held:?}"
        );
        assert_eq!(held.iter().filter(|m| m.0 == 0x89).count(), 0, "{held:?}");
        let _ = stop_cleanly(d);
        std::thread::sleep(Duration::from_millis(300));
        let midi = jack.messages();
        assert_eq!(midi.len(), 2, "{midi:?}");
        assert_eq!((midi[0].0, midi[0].1), (0x99, 36));
        assert_eq!(
            (midi[1].0, midi[1].1),
            (0x89, 36),
            "the held note was not released"
        );
    }

    /// The labels of a truth file of the duel example, in order.
    fn duel_truth(name: &str) -> Vec<String> {
        read(&root().join("examples/duel").join(name))
            .lines()
            .skip(1)
            .map(|l| l.split(',').nth(1).unwrap().to_string())
            .collect()
    }

    #[test]
    fn two_performers_on_the_channels_of_one_capture_each_send_their_own_sounds() {
        let _one_at_a_time = REAL_TIME_AUDIO.lock().unwrap_or_else(|e| e.into_inner());
        let dir = common::temp_dir("listen-performers");
        let stereo = common::duel_in_stereo(&dir);
        let pulse = Pulse::start(&dir);
        let jack = Jack::start(&dir, "duo");
        let osc = OscDump::start(&dir);
        let d = start_listen(
            &dir,
            &[
                "-c",
                "config/duo.toml",
                "--osc",
                &osc.target(),
                "--midi",
                "midi-monitor",
                "--print",
                "json",
            ],
            |c| {
                pulse
                    .env(c)
                    .env("JACK_DEFAULT_SERVER", &jack.name)
                    .env("JACK_NO_START_SERVER", "1")
            },
        );
        wait_for_text(&d.stderr, "listening", Duration::from_secs(10));
        std::thread::sleep(Duration::from_millis(500));
        pulse.play(&stereo.to_string_lossy());
        // 14 sounds: 7 shots, 4 hups and 3 held whoos (a begin and an end each).
        osc.wait_count(|m| m.addr.ends_with("/event"), 17, CAPTURE_CATCH_UP);
        std::thread::sleep(Duration::from_millis(300));
        let stdout = d.stdout.clone();
        let log = stop_cleanly(d);
        assert!(
            log.contains("capturing") && log.contains("channels=2"),
            "{log}"
        );
        // The printed records name their performer first.
        let printed = read(&stdout);
        assert_eq!(printed.lines().count(), 17, "{printed}");
        for line in printed.lines() {
            let shooter = ["\"pattern\":\"pew\"", "\"pattern\":\"boom\""]
                .iter()
                .any(|p| line.contains(p));
            let who = if shooter { "shooter" } else { "runner" };
            assert!(
                line.starts_with(&format!("{{\"performer\":\"{who}\",\"id\":")),
                "{line}"
            );
        }
        let messages = osc.messages();
        // Each prefix gets exactly its performer's sounds, in order.
        let sounds = |prefix: &str| -> Vec<String> {
            messages
                .iter()
                .filter_map(|m| {
                    let rest = m.addr.strip_prefix(prefix)?;
                    let parts: Vec<&str> = rest.split('/').collect();
                    match parts[..] {
                        ["", name] if !["event", "status", "bounce"].contains(&name) => {
                            Some(name.to_string())
                        }
                        ["", name, "begin"] => Some(name.to_string()),
                        _ => None,
                    }
                })
                .collect()
        };
        assert_eq!(
            sounds("/onomato/shooter"),
            duel_truth("shots.truth.csv"),
            "{messages:#?}"
        );
        assert_eq!(
            sounds("/onomato/runner"),
            duel_truth("moves.truth.csv"),
            "{messages:#?}"
        );
        assert!(
            messages
                .iter()
                .all(|m| m.addr.starts_with("/onomato/shooter/")
                    || m.addr.starts_with("/onomato/runner/")),
            "a message outside both prefixes: {messages:#?}"
        );
        // The runner's bounce solver launches on its hups and at the end of its slides;
        // the shooter has none (no [performer.bounce], no states asked for).
        let runner_hits = messages
            .iter()
            .filter(|m| m.addr == "/onomato/runner/bounce/hit")
            .count();
        assert_eq!(runner_hits, 4 + 3, "{messages:#?}");
        // MIDI: one port, each performer's notes on its own channel, in the order of
        // its sounds; every note released.
        let midi = jack.messages();
        let ons = |status: u8| -> Vec<u8> {
            midi.iter()
                .filter(|m| m.0 == status && m.2 > 0)
                .map(|m| m.1)
                .collect()
        };
        let notes = |labels: Vec<String>, map: &[(&str, u8)]| -> Vec<u8> {
            labels
                .iter()
                .map(|l| map.iter().find(|(n, _)| n == l).unwrap().1)
                .collect()
        };
        assert_eq!(
            ons(0x90),
            notes(duel_truth("shots.truth.csv"), &[("pew", 38), ("boom", 36)]),
            "channel 1: {midi:?}"
        );
        assert_eq!(
            ons(0x91),
            notes(duel_truth("moves.truth.csv"), &[("hup", 42), ("whoo", 60)]),
            "channel 2: {midi:?}"
        );
        assert!(
            midi.iter().all(|m| matches!(m.0 & 0x0F, 0 | 1)),
            "a message on another channel: {midi:?}"
        );
        assert_eq!(notes_left_on(&midi), Vec::<(u8, u8)>::new());
    }
}
