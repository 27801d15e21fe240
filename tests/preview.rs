//! `listen --preview` with real parts: the daemon binary replays the example in real
//! time, `oscdump` (liblo) receives its OSC, and a real headless Chromium (Debian's
//! `chromium`, driven by `tests/browser/preview.mjs` through playwright-core) opens the
//! preview page. The page keeps what it received and drew when opened with `?trace`.
//!
//! `bash scripts/test.sh` installs chromium, liblo-tools and the driver's package.

use std::fs;
use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::procs::{read, signal, unix_now, wait_exit, Guard, OscDump, OscLine};
use common::root;

const BIN: &str = env!("CARGO_BIN_EXE_onomato");

/// Silence before the example in the replayed file: the page connects in it.
const LEAD_SECONDS: f64 = 3.0;

/// The example with `LEAD_SECONDS` of silence before it.
fn example_after_silence(dir: &Path) -> PathBuf {
    let (beat, rate) = common::read_wav_16(&root().join("examples/beat.wav"));
    let mut samples = vec![0.0f32; (LEAD_SECONDS * f64::from(rate)) as usize];
    samples.extend(beat);
    let path = dir.join("lead-and-beat.wav");
    common::write_wav_f32(&path, &samples, rate);
    path
}

fn free_tcp_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn wait_connectable(address: &str) {
    let start = Instant::now();
    while TcpStream::connect(address).is_err() {
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "nothing listens on {address}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The browser, driven one command per line.
struct Browser {
    _child: Guard,
    stdin: ChildStdin,
    lines: std::sync::mpsc::Receiver<String>,
}

impl Browser {
    fn open(url: &str) -> Self {
        let driver = root().join("tests/browser/preview.mjs");
        let mut child = Command::new("node")
            .arg(&driver)
            .arg(url)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("node must be installed (bash scripts/test.sh)");
        let stdin = child.stdin.take().unwrap();
        let stdout = BufReader::new(child.stdout.take().unwrap());
        let (tx, lines) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in stdout.lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut b = Self {
            _child: Guard(child),
            stdin,
            lines,
        };
        assert_eq!(
            b.line(),
            "ready",
            "the browser did not open the page (bash scripts/test.sh installs chromium and tests/browser's package)"
        );
        b
    }

    fn line(&mut self) -> String {
        self.lines
            .recv_timeout(Duration::from_secs(60))
            .map(|l| l.trim().to_string())
            .unwrap_or_default()
    }

    fn ask(&mut self, command: &str) -> String {
        writeln!(self.stdin, "{command}").unwrap();
        self.line()
    }

    fn trace(&mut self) -> serde_json::Value {
        let answer = self.ask("trace");
        serde_json::from_str(&answer).unwrap_or_else(|e| panic!("{e}: {answer}"))
    }
}

fn listen(dir: &Path, tag: &str, args: &[&str]) -> (Child, PathBuf) {
    let err = dir.join(format!("listen-{tag}.err"));
    let child = Command::new(BIN)
        .arg("listen")
        .args(args)
        .current_dir(root())
        .env("RUST_LOG", "info")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(fs::File::create(&err).unwrap())
        .spawn()
        .expect("cannot start onomato");
    (child, err)
}

/// `listen` replaying `wav` with the example's config, and `extra` arguments.
fn replay(dir: &Path, tag: &str, wav: &str, extra: &[&str]) -> (Child, PathBuf) {
    let mut args = vec!["-c", "config/onomato.toml", "--input", wav];
    args.extend_from_slice(extra);
    listen(dir, tag, &args)
}

/// The `/event` messages as (pattern, kind, id, arrival).
fn osc_sounds(messages: &[OscLine]) -> Vec<(String, String, i64, f64)> {
    messages
        .iter()
        .filter(|m| m.addr == "/onomato/event")
        .map(|m| {
            (
                m.s(0).to_string(),
                m.s(1).to_string(),
                m.f(5) as i64,
                m.arrival,
            )
        })
        .collect()
}

/// The index of the `hello` of the daemon started at `started` (Unix seconds).
fn hello_of(trace: &serde_json::Value, started: f64) -> usize {
    let hellos = trace["hellos"].as_array().unwrap();
    hellos
        .iter()
        .position(|h| (h["data"]["origin_unix_seconds"].as_f64().unwrap() - started).abs() < 1.0)
        .unwrap_or_else(|| {
            panic!("the page never connected to the daemon started at {started}: {hellos:?}")
        })
}

/// The page's `sound` messages received after its `run`th `hello` (until the next), as
/// (pattern, kind, id, arrival).
fn page_sounds(trace: &serde_json::Value, run: usize) -> Vec<(String, String, i64, f64)> {
    let hellos = trace["hellos"].as_array().unwrap();
    let from = hellos[run]["at"].as_f64().unwrap();
    let to = hellos
        .get(run + 1)
        .map_or(f64::INFINITY, |h| h["at"].as_f64().unwrap());
    trace["sounds"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| (from..to).contains(&s["at"].as_f64().unwrap()))
        .map(|s| {
            let kind = match (s["kind"].as_str().unwrap(), s["end"].is_null()) {
                ("continuous", true) => "begin",
                ("continuous", false) => "end",
                _ => "impulse",
            };
            (
                s["pattern"].as_str().unwrap().to_string(),
                kind.to_string(),
                s["id"].as_i64().unwrap(),
                s["at"].as_f64().unwrap() / 1000.0,
            )
        })
        .collect()
}

/// The page showed what OSC received, in order, each within 50 ms of it.
fn check_same_sounds(osc: &[(String, String, i64, f64)], page: &[(String, String, i64, f64)]) {
    let key = |v: &[(String, String, i64, f64)]| -> Vec<(String, String, i64)> {
        v.iter().map(|s| (s.0.clone(), s.1.clone(), s.2)).collect()
    };
    assert_eq!(key(page), key(osc), "the page's sounds and OSC's, in order");
    for (o, p) in osc.iter().zip(page) {
        let lag = p.3 - o.3;
        assert!(
            lag < 0.050,
            "{o:?}: the page received it {:.1} ms after the OSC receiver",
            lag * 1e3
        );
    }
}

/// At every bounce hit, the drawn ball (read back from the canvas) touches the floor;
/// between two hits it leaves it.
fn check_ball(trace: &serde_json::Value) {
    let frames = trace["frames"].as_array().unwrap();
    let hits = trace["hits"].as_array().unwrap();
    assert!(hits.len() >= 10, "{} bounce hits", hits.len());
    let mut touched = 0;
    for hit in hits {
        let t = hit["time"].as_f64().unwrap();
        // Frames of both runs are in the trace; this run's frame at the hit is the one
        // drawn after the hit arrived.
        let at = hit["at"].as_f64().unwrap();
        let frame = frames
            .iter()
            .find(|f| {
                f["performer"] == hit["performer"]
                    && f["time"].as_f64().unwrap() == t
                    && f["at"].as_f64().unwrap() >= at
            })
            .unwrap_or_else(|| panic!("no frame drawn at the hit {hit}"));
        let bottom = frame["bottom"]
            .as_f64()
            .expect("the ball was not found on the canvas");
        let floor = frame["floor"].as_f64().unwrap();
        assert!(
            (bottom - floor).abs() <= 1.0,
            "at the hit {t:.3} s the ball's bottom is at row {bottom}, the floor at {floor}"
        );
        touched += 1;
        let land = hit["predicted_landing"].as_f64().unwrap();
        let top = frames
            .iter()
            .filter(|f| {
                let ft = f["time"].as_f64().unwrap();
                f["performer"] == hit["performer"]
                    && f["at"].as_f64().unwrap() >= at
                    && ft > t
                    && ft < land.min(t + 2.0)
            })
            .filter_map(|f| f["bottom"].as_f64())
            .fold(f64::INFINITY, f64::min);
        if land - t > 0.2 && top.is_finite() {
            assert!(
                top < floor - 20.0,
                "after the hit at {t:.3} s the ball never left the floor ({top} vs {floor})"
            );
        }
    }
    assert_eq!(touched, hits.len());
}

#[test]
fn the_preview_shows_every_event_osc_gets_and_comes_back_after_a_restart() {
    let dir = common::temp_dir("preview-page");
    let wav = example_after_silence(&dir);
    let wav = wav.to_string_lossy().to_string();
    let port = free_tcp_port();
    let address = format!("127.0.0.1:{port}");
    // A daemon hearing silence serves the page to open; killed, the page waits for the
    // next one.
    let silence = dir.join("silence.wav");
    common::write_wav_f32(&silence, &vec![0.0; 22_050 * 60], 22_050);
    let silence = silence.to_string_lossy().to_string();
    let (mut opener, _) = replay(&dir, "opener", &silence, &["--preview", &address]);
    wait_connectable(&address);
    let mut browser = Browser::open(&format!("http://{address}/?trace"));
    opener.kill().unwrap();
    opener.wait().unwrap();

    // First run: played twice; killed in the silence before the second play.
    let osc1 = OscDump::start(&dir);
    let (mut first, first_err) = replay(
        &dir,
        "first",
        &wav,
        &[
            "--repeat",
            "2",
            "--osc",
            &osc1.target(),
            "--preview",
            &address,
        ],
    );
    let started = Instant::now();
    let first_start = unix_now();
    osc1.wait_count(|m| m.addr == "/onomato/event", 15, Duration::from_secs(40));
    let pass = LEAD_SECONDS + 10.0;
    std::thread::sleep(Duration::from_secs_f64(pass + 1.0).saturating_sub(started.elapsed()));
    assert!(
        first.try_wait().unwrap().is_none(),
        "the first daemon ended early: {}",
        read(&first_err)
    );
    first.kill().unwrap();
    first.wait().unwrap();

    // Second run, on the same address: the page reconnects by itself.
    let osc2 = OscDump::start(&dir);
    let (mut second, second_err) = replay(
        &dir,
        "second",
        &wav,
        &["--osc", &osc2.target(), "--preview", &address],
    );
    let second_started = Instant::now();
    let second_start = unix_now();
    // A still of the page in the middle of the example, for the README.
    std::thread::sleep(Duration::from_secs_f64(LEAD_SECONDS + 6.1));
    let still = root().join("target/preview.png");
    assert_eq!(
        browser.ask(&format!("screenshot {}", still.display())),
        "ok"
    );
    let live = browser.trace();
    assert_eq!(live["connection"], "live", "{live}");
    let status = wait_exit(&mut second, Duration::from_secs(40));
    assert!(status.success(), "{}", read(&second_err));
    assert!(second_started.elapsed() >= Duration::from_secs(12));
    osc2.wait_count(|m| m.addr == "/onomato/event", 15, Duration::from_secs(5));
    std::thread::sleep(Duration::from_millis(300));

    let all = browser.trace();
    let trace = &all["trace"];
    // Chromium notes each failed connection of the stream in the console (refused while
    // no daemon runs; reset or not connected, depending on timing, when a daemon is
    // killed): those are the browser's own network log, about /events only. Nothing else
    // may be there.
    let events_url = format!("http://{address}/events");
    let errors = all["errors"].as_array().unwrap();
    let (network, others): (Vec<_>, Vec<_>) = errors.iter().partition(|e| {
        e["url"] == events_url.as_str()
            && e["text"]
                .as_str()
                .is_some_and(|t| t.starts_with("Failed to load resource: net::ERR_"))
    });
    assert!(others.is_empty(), "the page logged errors: {others:?}");
    // Two restarts, each of a few half-second retries.
    assert!(network.len() < 20, "{network:?}");
    let hellos = trace["hellos"].as_array().unwrap();
    let mut origins: Vec<f64> = hellos
        .iter()
        .map(|h| h["data"]["origin_unix_seconds"].as_f64().unwrap())
        .collect();
    origins.dedup();
    assert_eq!(
        origins.len(),
        hellos.len(),
        "one connection per daemon (a second hello within a run would be a lost stream): {hellos:?}"
    );
    let (first_run, second_run) = (hello_of(trace, first_start), hello_of(trace, second_start));
    let osc_first = osc_sounds(&osc1.messages());
    assert_eq!(osc_first.len(), 15, "{osc_first:?}");
    check_same_sounds(&osc_first, &page_sounds(trace, first_run));
    let osc_second = osc_sounds(&osc2.messages());
    assert_eq!(osc_second.len(), 15, "{osc_second:?}");
    check_same_sounds(&osc_second, &page_sounds(trace, second_run));
    check_ball(trace);
    // The page reconnected within a second of the second daemon's start.
    let reconnected = hellos[second_run]["at"].as_f64().unwrap() / 1000.0;
    assert!(
        reconnected - second_start < 1.0,
        "the page reconnected {:.2} s after the daemon started",
        reconnected - second_start
    );
    let _ = writeln!(browser.stdin, "quit");
}

/// A client of the stream whose receive buffer is as small as the system allows.
fn stalled_client(port: u16) -> std::os::fd::OwnedFd {
    use std::os::fd::{FromRawFd, OwnedFd};
    // SAFETY: socket(2), setsockopt(2) and connect(2) on a descriptor this function
    // creates and hands to an OwnedFd; the structures are initialised before use.
    unsafe {
        let fd = libc::socket(libc::AF_INET, libc::SOCK_STREAM, 0);
        assert!(fd >= 0, "socket");
        let owned = OwnedFd::from_raw_fd(fd);
        let size: libc::c_int = 1024;
        libc::setsockopt(
            fd,
            libc::SOL_SOCKET,
            libc::SO_RCVBUF,
            (&size as *const libc::c_int).cast(),
            std::mem::size_of::<libc::c_int>() as libc::socklen_t,
        );
        let address = libc::sockaddr_in {
            sin_family: libc::AF_INET as libc::sa_family_t,
            sin_port: port.to_be(),
            sin_addr: libc::in_addr {
                s_addr: u32::from_be_bytes([127, 0, 0, 1]).to_be(),
            },
            sin_zero: [0; 8],
        };
        let start = Instant::now();
        while libc::connect(
            fd,
            (&address as *const libc::sockaddr_in).cast(),
            std::mem::size_of::<libc::sockaddr_in>() as libc::socklen_t,
        ) != 0
        {
            assert!(
                start.elapsed() < Duration::from_secs(5),
                "cannot connect to the preview"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        owned
    }
}

/// A browser that connects to the stream and never reads: OSC goes on as without it,
/// and the daemon closes that stream once its queue is full.
#[test]
fn a_stalled_preview_client_never_delays_osc() {
    let dir = common::temp_dir("preview-stalled");
    let wav = example_after_silence(&dir);
    let wav = wav.to_string_lossy().to_string();
    let port = free_tcp_port();
    let address = format!("127.0.0.1:{port}");
    let osc = OscDump::start(&dir);
    let speed = 2.0;
    let started = unix_now();
    let (mut d, err) = replay(
        &dir,
        "stalled",
        &wav,
        &[
            "--speed",
            "2",
            "--repeat",
            "2",
            "--osc",
            &osc.target(),
            "--preview",
            &address,
        ],
    );
    let stalled = TcpStream::from(stalled_client(port));
    (&stalled)
        .write_all(b"GET /events HTTP/1.1\r\nHost: localhost\r\n\r\n")
        .unwrap();
    let status = wait_exit(&mut d, Duration::from_secs(60));
    assert!(status.success(), "{}", read(&err));
    osc.wait_count(|m| m.addr == "/onomato/event", 30, Duration::from_secs(5));
    // Every sound reached OSC as it does with no preview: within 0.5 s of where the
    // replay put it (a write that waited on the stalled socket would wait up to 5 s).
    for m in osc.messages().iter().filter(|m| m.addr == "/onomato/event") {
        let delay = m.arrival - (started + m.f(3) / speed);
        assert!(
            delay < 0.5,
            "{m:?} arrived {delay:.3} s after its onset was played, with a stalled preview client"
        );
    }
    let log = read(&err);
    assert!(
        log.contains("a preview page stopped reading its stream"),
        "the stalled stream was not closed:\n{log}"
    );
    assert!(log.contains("preview_streams_closed=1"), "{log}");
    drop(stalled);
}

#[test]
fn the_preview_serves_nothing_but_its_page_and_stream() {
    let dir = common::temp_dir("preview-paths");
    let port = free_tcp_port();
    let address = format!("127.0.0.1:{port}");
    let (mut d, err) = replay(&dir, "paths", "examples/beat.wav", &["--preview", &address]);
    let get = |request: &str| -> String {
        wait_connectable(&address);
        let mut s = TcpStream::connect(&address).unwrap();
        s.write_all(request.as_bytes()).unwrap();
        let mut out = String::new();
        let _ = std::io::Read::read_to_string(&mut s, &mut out);
        out
    };
    let page = get("GET / HTTP/1.1\r\nHost: localhost\r\n\r\n");
    assert!(page.starts_with("HTTP/1.1 200 OK"), "{page}");
    assert!(page.contains("<canvas"), "{page}");
    for path in [
        "/index.htm",
        "/events/1",
        "/status",
        "/favicon.ico",
        "/../config/onomato.toml",
    ] {
        let r = get(&format!("GET {path} HTTP/1.1\r\nHost: localhost\r\n\r\n"));
        assert!(r.starts_with("HTTP/1.1 404 Not Found"), "{path}: {r}");
    }
    let r = get("POST /events HTTP/1.1\r\nHost: localhost\r\nContent-Length: 4\r\n\r\nstop");
    assert!(r.starts_with("HTTP/1.1 405"), "{r}");
    // A page of another site that reaches this port through a name of its own.
    let r = get("GET /events HTTP/1.1\r\nHost: rebound.example:8765\r\n\r\n");
    assert!(r.starts_with("HTTP/1.1 421"), "{r}");
    signal(&d, "TERM");
    let status = wait_exit(&mut d, Duration::from_secs(10));
    assert!(status.success(), "{}", read(&err));

    // An address in use is refused at start, naming it.
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let taken_address = taken.local_addr().unwrap().to_string();
    let out = Command::new(BIN)
        .args([
            "listen",
            "-c",
            "config/onomato.toml",
            "--input",
            "examples/beat.wav",
            "--preview",
            &taken_address,
        ])
        .current_dir(root())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(
        message.contains(&format!("preview: cannot listen on {taken_address}")),
        "{message}"
    );
    // And an address that is not one is refused by name.
    let out = Command::new(BIN)
        .args([
            "listen",
            "-c",
            "config/onomato.toml",
            "--preview",
            "localhost",
        ])
        .current_dir(root())
        .output()
        .unwrap();
    assert!(!out.status.success());
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(
        message.contains("--preview: address must be an IP address and a port"),
        "{message}"
    );
}

/// config/duo.toml with its takes' paths made absolute, and no OSC or MIDI.
fn duo_config(dir: &Path) -> PathBuf {
    let examples = root().join("examples");
    let text = read(&root().join("config/duo.toml"))
        .replace("\"../examples", &format!("\"{}", examples.display()))
        .replace("[osc]\ntargets = [\"127.0.0.1:9000\"]\n", "[osc]\n")
        .replace("[midi]\nvirtual_port = \"onomato\"\n", "");
    let path = dir.join("duo.toml");
    fs::write(&path, text).unwrap();
    path
}

#[test]
fn the_preview_draws_a_ball_per_performer() {
    let dir = common::temp_dir("preview-duo");
    let stereo = common::duel_in_stereo(&dir).to_string_lossy().to_string();
    let config = duo_config(&dir).to_string_lossy().to_string();
    let port = free_tcp_port();
    let address = format!("127.0.0.1:{port}");
    let (mut d, err) = listen(
        &dir,
        "duo",
        &[
            "-c",
            &config,
            "--input",
            &stereo,
            "--repeat",
            "2",
            "--preview",
            &address,
        ],
    );
    wait_connectable(&address);
    let mut browser = Browser::open(&format!("http://{address}/?trace"));
    // Into the second play, where both have sounded.
    std::thread::sleep(Duration::from_secs_f64(8.0 + 3.75));
    let still = root().join("target/preview-duo.png");
    assert_eq!(
        browser.ask(&format!("screenshot {}", still.display())),
        "ok"
    );
    let status = wait_exit(&mut d, Duration::from_secs(30));
    assert!(status.success(), "{}", read(&err));
    let all = browser.trace();
    let _ = writeln!(browser.stdin, "quit");
    let trace = &all["trace"];
    let performers = &trace["hellos"][0]["data"]["performers"];
    let names: Vec<&str> = performers
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["shooter", "runner"]);
    // Each performer's sounds reached the page tagged with it.
    let sounds = trace["sounds"].as_array().unwrap();
    for (index, own) in [(0, ["pew", "boom"]), (1, ["hup", "whoo"])] {
        let theirs: Vec<&str> = sounds
            .iter()
            .filter(|s| s["performer"] == index)
            .map(|s| s["pattern"].as_str().unwrap())
            .collect();
        assert!(theirs.len() >= 7, "performer {index}: {theirs:?}");
        assert!(
            theirs.iter().all(|p| own.contains(p)),
            "performer {index}: {theirs:?}"
        );
    }
    // A ball each, each on the floor at its own hits.
    for index in 0..2 {
        let frames = trace["frames"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|f| f["performer"] == index)
            .count();
        assert!(frames > 100, "performer {index}: {frames} frames drawn");
    }
    check_ball(trace);
    let errors = all["errors"].as_array().unwrap();
    let events_url = format!("http://{address}/events");
    assert!(
        errors.iter().all(|e| e["url"] == events_url.as_str()),
        "the page logged errors: {errors:?}"
    );
}
