//! Child processes of the tests (killed when a test ends, signalled, waited for) and
//! `oscdump` (liblo) as an independent OSC receiver: shared by the daemon's tests.

use std::fs;
use std::io::Read;
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// A child process killed when the test ends, whatever happens.
pub struct Guard(pub Child);

impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

pub fn spawn_child(cmd: &mut Command, what: &str) -> Child {
    cmd.spawn().unwrap_or_else(|e| {
        panic!("cannot start {what}: {e} (bash scripts/test.sh installs what these tests need)")
    })
}

pub fn spawn(cmd: &mut Command, what: &str) -> Guard {
    Guard(spawn_child(cmd, what))
}

pub fn signal(child: &Child, name: &str) {
    let number = match name {
        "HUP" => libc::SIGHUP,
        "TERM" => libc::SIGTERM,
        "INT" => libc::SIGINT,
        other => panic!("unknown signal {other}"),
    };
    // SAFETY: kill(2) with a pid of our own child; no memory is involved.
    let rc = unsafe { libc::kill(child.id() as libc::pid_t, number) };
    assert_eq!(rc, 0, "cannot send SIG{name}");
}

pub fn wait_exit(child: &mut Child, timeout: Duration) -> ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(s) = child.try_wait().expect("wait") {
            return s;
        }
        assert!(
            start.elapsed() < timeout,
            "the process did not exit within {timeout:?}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

pub fn read(path: &Path) -> String {
    let mut s = String::new();
    if let Ok(mut f) = fs::File::open(path) {
        let _ = f.read_to_string(&mut s);
    }
    s
}

/// Waits until `path` holds `text`.
pub fn wait_for_text(path: &Path, text: &str, timeout: Duration) {
    let start = Instant::now();
    while !read(path).contains(text) {
        assert!(
            start.elapsed() < timeout,
            "'{text}' did not appear in {} within {timeout:?}; it holds:\n{}",
            path.display(),
            read(path)
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

pub fn unix_now() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_secs_f64()
}

pub fn free_udp_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Waits until some process has bound UDP `port` (IPv4 or IPv6), as the kernel lists
/// it in /proc/net/udp and /proc/net/udp6.
pub fn wait_udp_bound(port: u16, timeout: Duration) {
    let hex = format!(":{port:04X}");
    let bound = || {
        ["/proc/net/udp", "/proc/net/udp6"].iter().any(|table| {
            fs::read_to_string(table).is_ok_and(|text| {
                text.lines()
                    .skip(1)
                    .filter_map(|line| line.split_whitespace().nth(1))
                    .any(|local| local.ends_with(&hex))
            })
        })
    };
    let start = Instant::now();
    while !bound() {
        assert!(
            start.elapsed() < timeout,
            "no process bound UDP port {port} within {timeout:?}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// One message as oscdump printed it.
#[derive(Debug, Clone)]
pub struct OscLine {
    /// Arrival, Unix seconds (oscdump stamps messages that are not in a bundle with
    /// their arrival time).
    pub arrival: f64,
    pub addr: String,
    pub args: Vec<String>,
}

impl OscLine {
    pub fn f(&self, i: usize) -> f64 {
        self.args[i]
            .parse()
            .unwrap_or_else(|_| panic!("argument {i} of {self:?}"))
    }
    pub fn s(&self, i: usize) -> &str {
        self.args[i].trim_matches('"')
    }
}

pub struct OscDump {
    pub _child: Guard,
    pub out: PathBuf,
    pub port: u16,
}

impl OscDump {
    pub fn start(dir: &Path) -> Self {
        Self::start_on(dir, free_udp_port(), "")
    }

    /// A receiver on `port`, writing to its own file (`tag` tells two apart).
    pub fn start_on(dir: &Path, port: u16, tag: &str) -> Self {
        let out = dir.join(format!("oscdump-{port}{tag}.txt"));
        let child = spawn(
            Command::new("stdbuf")
                .args(["-oL", "oscdump", "-L", &port.to_string()])
                .stdout(fs::File::create(&out).unwrap())
                .stderr(Stdio::null()),
            "oscdump (liblo-tools)",
        );
        // A datagram sent before the receiver has bound its port is lost: wait until
        // it has, however long a busy machine takes to start it.
        wait_udp_bound(port, Duration::from_secs(10));
        Self {
            _child: child,
            out,
            port,
        }
    }

    pub fn target(&self) -> String {
        format!("127.0.0.1:{}", self.port)
    }

    pub fn messages(&self) -> Vec<OscLine> {
        read(&self.out)
            .lines()
            .filter_map(|line| {
                let mut parts = line.split_whitespace();
                let tag = parts.next()?;
                let (secs, frac) = tag.split_once('.')?;
                let secs = u64::from_str_radix(secs, 16).ok()?;
                let frac = u64::from_str_radix(frac, 16).ok()?;
                let arrival = secs as f64 - 2_208_988_800.0 + frac as f64 / 4_294_967_296.0;
                let addr = parts.next()?.to_string();
                let _types = parts.next();
                Some(OscLine {
                    arrival,
                    addr,
                    args: parts.map(str::to_string).collect(),
                })
            })
            .collect()
    }

    pub fn wait_count(&self, pred: impl Fn(&OscLine) -> bool, n: usize, timeout: Duration) {
        let start = Instant::now();
        while self.messages().iter().filter(|m| pred(m)).count() < n {
            assert!(
                start.elapsed() < timeout,
                "fewer than {n} matching OSC messages within {timeout:?}; got:\n{}",
                read(&self.out)
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}
