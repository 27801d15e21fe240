//! The live preview (`listen --preview`): an HTTP server that serves one page
//! (`preview.html`) at `/` and a stream of Server-Sent Events at `/events`, and nothing
//! else: any other path is a 404, any other method a 405, and nothing a browser sends
//! is read beyond the request line and headers (it takes no commands). Bound to
//! loopback, it answers only requests addressed to this machine by name (`Host:
//! localhost`, `127.0.0.1`, `[::1]`), so that a web page elsewhere cannot reach it
//! through a host name of its own that points here (DNS rebinding).
//!
//! Threads: an accept thread (`onomato-preview`) and one thread per open connection, at
//! most [`MAX_CONNECTIONS`]. The output thread publishes through [`PreviewHub`], which
//! never waits: each stream has its own bounded queue, and a stream whose queue is full
//! (a browser that stopped reading) is closed and counted, so a stalled browser costs
//! its own stream and never delays OSC or MIDI. The page reconnects by itself and starts
//! again from a fresh `hello`. Nothing here touches the detector thread.
//!
//! The stream's events, each one JSON object: `hello` (the patterns, sent first on every
//! connection and again after a reload), `sound` (the event record, as `--print json`
//! prints it: a held sound at its begin, then complete), `hit` and `state` (the live
//! bounce solver's launches and drawn states, as `/bounce/hit` and `/bounce/state`),
//! and `status` (the counters of `/status`, ten times a second).

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::Context;

/// The page, served at `/`.
const PAGE: &str = include_str!("preview.html");
/// Open connections served at once; more are answered 503.
pub const MAX_CONNECTIONS: usize = 16;
/// Messages a stream may have waiting (about 6 s of states, sounds and status at 60 Hz
/// states): a browser tab that is briefly busy keeps its stream, one that stopped
/// reading loses it.
pub const STREAM_QUEUE: usize = 512;
/// How often the accept thread looks for a connection or the stop.
const ACCEPT_POLL: Duration = Duration::from_millis(20);
/// A request head must arrive, and a write must complete, within this.
const IO_TIMEOUT: Duration = Duration::from_secs(5);
/// A comment line on a quiet stream, so that proxies and the browser keep it open.
const KEEP_ALIVE: Duration = Duration::from_secs(15);
/// Largest request head read.
const MAX_HEAD: usize = 8192;
/// What the system may hold of a stream for a browser that does not read (left to
/// itself, Linux grows it past a megabyte: minutes of states). With it, a stalled
/// browser fills its queue within seconds and loses its stream.
const STREAM_SEND_BUFFER: libc::c_int = 64 * 1024;

/// The output thread's side: publishes to every open stream without waiting.
#[derive(Clone)]
pub struct PreviewHub {
    shared: Arc<Shared>,
}

struct Shared {
    streams: Mutex<Vec<SyncSender<Arc<str>>>>,
    /// The `hello` message every new stream starts with.
    hello: Mutex<Arc<str>>,
    /// Streams closed because their browser did not keep up.
    closed_slow: AtomicU64,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic elsewhere while holding the list leaves it usable.
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn sse(kind: &str, data: &str) -> Arc<str> {
    format!("event: {kind}\ndata: {data}\n\n").into()
}

impl PreviewHub {
    fn new() -> Self {
        Self {
            shared: Arc::new(Shared {
                streams: Mutex::new(Vec::with_capacity(MAX_CONNECTIONS)),
                hello: Mutex::new(sse("hello", "{}")),
                closed_slow: AtomicU64::new(0),
            }),
        }
    }

    /// Whether any browser is watching (nothing needs formatting otherwise).
    pub fn watched(&self) -> bool {
        !lock(&self.shared.streams).is_empty()
    }

    /// Sets the `hello` that new streams start with, and sends it to the open ones.
    pub fn set_hello(&self, data: &str) {
        let message = sse("hello", data);
        *lock(&self.shared.hello) = message.clone();
        self.send(|| message);
    }

    /// Sends one event (`kind`, JSON `data`) to every open stream.
    pub fn publish(&self, kind: &str, data: &str) {
        self.send(|| sse(kind, data));
    }

    /// Sends a message to every open stream; it is made only when there is one.
    fn send(&self, message: impl FnOnce() -> Arc<str>) {
        let mut streams = lock(&self.shared.streams);
        if streams.is_empty() {
            return;
        }
        let message = message();
        streams.retain(|s| match s.try_send(message.clone()) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) => {
                let n = self.shared.closed_slow.fetch_add(1, Ordering::Relaxed) + 1;
                tracing::warn!(
                    closed = n,
                    "a preview page stopped reading its stream; closed it (it reconnects when it reads again)"
                );
                false
            }
            Err(TrySendError::Disconnected(_)) => false,
        });
    }

    /// Streams closed because their browser did not keep up.
    pub fn closed_slow(&self) -> u64 {
        self.shared.closed_slow.load(Ordering::Relaxed)
    }

    /// A new stream: its queue, registered, and the `hello` to start with.
    fn subscribe(&self) -> (mpsc::Receiver<Arc<str>>, Arc<str>) {
        let (tx, rx) = mpsc::sync_channel(STREAM_QUEUE);
        let mut streams = lock(&self.shared.streams);
        streams.push(tx);
        // Taken under the same lock as publishing: nothing is lost between the two.
        let hello = lock(&self.shared.hello).clone();
        (rx, hello)
    }

    fn close_all(&self) {
        lock(&self.shared.streams).clear();
    }
}

/// The HTTP server; stops when dropped (open streams end with it).
pub struct PreviewServer {
    hub: PreviewHub,
    address: SocketAddr,
    stop: Arc<AtomicBool>,
    accept: Option<JoinHandle<()>>,
}

impl PreviewServer {
    /// Binds `address` and starts serving. A port in use or an address that is not this
    /// machine's is an error naming the address.
    pub fn start(address: SocketAddr) -> anyhow::Result<Self> {
        let listener = TcpListener::bind(address)
            .with_context(|| format!("preview: cannot listen on {address}"))?;
        listener
            .set_nonblocking(true)
            .with_context(|| format!("preview: cannot listen on {address}"))?;
        let address = listener.local_addr().unwrap_or(address);
        let hub = PreviewHub::new();
        let stop = Arc::new(AtomicBool::new(false));
        let accept = {
            let hub = hub.clone();
            let stop = stop.clone();
            std::thread::Builder::new()
                .name("onomato-preview".into())
                .spawn(move || accept_loop(&listener, &hub, &stop, address.ip().is_loopback()))
                .context("cannot start the preview's thread")?
        };
        tracing::info!(url = %format!("http://{address}/"), "preview page");
        Ok(Self {
            hub,
            address,
            stop,
            accept: Some(accept),
        })
    }

    pub fn hub(&self) -> PreviewHub {
        self.hub.clone()
    }

    /// The address it listens on (the port the system chose for port 0).
    pub fn address(&self) -> SocketAddr {
        self.address
    }
}

impl Drop for PreviewServer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        self.hub.close_all();
        if let Some(t) = self.accept.take() {
            let _ = t.join();
        }
    }
}

fn accept_loop(listener: &TcpListener, hub: &PreviewHub, stop: &Arc<AtomicBool>, loopback: bool) {
    let open = Arc::new(AtomicUsize::new(0));
    while !stop.load(Ordering::Acquire) {
        match listener.accept() {
            Ok((socket, _)) => {
                if open.load(Ordering::Acquire) >= MAX_CONNECTIONS {
                    let mut socket = socket;
                    if prepare(&socket).is_ok() {
                        let _ = respond(
                            &mut socket,
                            "503 Service Unavailable",
                            "text/plain",
                            b"too many preview connections\n",
                            false,
                        );
                    }
                    continue;
                }
                open.fetch_add(1, Ordering::AcqRel);
                let (hub, stop, open_now) = (hub.clone(), stop.clone(), open.clone());
                let spawned = std::thread::Builder::new()
                    .name("onomato-preview-conn".into())
                    .spawn(move || {
                        if let Err(e) = serve(socket, &hub, &stop, loopback) {
                            tracing::debug!("preview connection ended: {e}");
                        }
                        open_now.fetch_sub(1, Ordering::AcqRel);
                    });
                if spawned.is_err() {
                    open.fetch_sub(1, Ordering::AcqRel);
                    tracing::warn!("cannot start a thread for a preview connection");
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => std::thread::sleep(ACCEPT_POLL),
            Err(e) => {
                tracing::warn!("preview: accepting a connection failed: {e}");
                std::thread::sleep(ACCEPT_POLL);
            }
        }
    }
}

fn prepare(socket: &TcpStream) -> std::io::Result<()> {
    socket.set_nonblocking(false)?;
    socket.set_read_timeout(Some(IO_TIMEOUT))?;
    socket.set_write_timeout(Some(IO_TIMEOUT))?;
    // Each event is written as it comes: do not hold it back to fill a segment.
    socket.set_nodelay(true)
}

/// What a request asks for.
#[derive(Debug, PartialEq, Eq)]
enum Route {
    Page,
    Events,
    NotFound,
    /// Not GET or HEAD.
    MethodNotAllowed,
    /// Addressed to another host name than this machine's (a loopback server only).
    WrongHost,
    BadRequest,
}

/// Whether a `Host` header names this machine: `localhost`, `127.0.0.1` or `[::1]`,
/// with or without a port.
fn is_local_host(host: &str) -> bool {
    let name = match host.strip_prefix('[') {
        Some(v6) => v6.split(']').next().unwrap_or(""),
        None => host.split(':').next().unwrap_or(""),
    };
    name.eq_ignore_ascii_case("localhost")
        || name
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// Parses a request head (everything up to the blank line); returns the route and
/// whether only the head is wanted. `loopback`: the server listens on loopback, and
/// answers requests for this machine only.
fn route(head: &[u8], loopback: bool) -> (Route, bool) {
    let mut headers = [httparse::EMPTY_HEADER; 32];
    let mut request = httparse::Request::new(&mut headers);
    match request.parse(head) {
        Ok(httparse::Status::Complete(_)) => {}
        _ => return (Route::BadRequest, false),
    }
    let head_only = request.method == Some("HEAD");
    if !matches!(request.method, Some("GET" | "HEAD")) {
        return (Route::MethodNotAllowed, false);
    }
    if loopback {
        let host = request
            .headers
            .iter()
            .find(|h| h.name.eq_ignore_ascii_case("host"))
            .map(|h| String::from_utf8_lossy(h.value).trim().to_string());
        // HTTP/1.0 clients may send none; a browser always does.
        if host.is_some_and(|h| !is_local_host(&h)) {
            return (Route::WrongHost, false);
        }
    }
    let path = request.path.unwrap_or("");
    let path = path.split(['?', '#']).next().unwrap_or("");
    let route = match path {
        "/" | "/index.html" => Route::Page,
        "/events" => Route::Events,
        _ => Route::NotFound,
    };
    (route, head_only)
}

/// Reads up to the end of the request head.
fn read_head(socket: &mut TcpStream) -> std::io::Result<Vec<u8>> {
    let mut head = Vec::with_capacity(1024);
    let mut buf = [0u8; 1024];
    loop {
        let n = socket.read(&mut buf)?;
        if n == 0 {
            return Err(std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                "closed before the request ended",
            ));
        }
        head.extend_from_slice(&buf[..n]);
        if head.windows(4).any(|w| w == b"\r\n\r\n") || head.len() >= MAX_HEAD {
            return Ok(head);
        }
    }
}

fn respond(
    socket: &mut TcpStream,
    status: &str,
    content_type: &str,
    body: &[u8],
    head_only: bool,
) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n",
        body.len()
    );
    socket.write_all(head.as_bytes())?;
    if !head_only {
        socket.write_all(body)?;
    }
    socket.flush()
}

fn serve(
    mut socket: TcpStream,
    hub: &PreviewHub,
    stop: &AtomicBool,
    loopback: bool,
) -> std::io::Result<()> {
    prepare(&socket)?;
    let head = read_head(&mut socket)?;
    match route(&head, loopback) {
        (Route::Page, head_only) => respond(
            &mut socket,
            "200 OK",
            "text/html; charset=utf-8",
            PAGE.as_bytes(),
            head_only,
        ),
        (Route::Events, true) => respond(&mut socket, "200 OK", "text/event-stream", b"", true),
        (Route::Events, false) => stream(socket, hub, stop),
        (Route::NotFound, head_only) => respond(
            &mut socket,
            "404 Not Found",
            "text/plain; charset=utf-8",
            b"not found: this server serves the preview page at / and its events at /events\n",
            head_only,
        ),
        (Route::MethodNotAllowed, _) => {
            socket.write_all(b"HTTP/1.1 405 Method Not Allowed\r\nAllow: GET, HEAD\r\nContent-Length: 0\r\nConnection: close\r\n\r\n")?;
            socket.flush()
        }
        (Route::WrongHost, _) => respond(
            &mut socket,
            "421 Misdirected Request",
            "text/plain; charset=utf-8",
            b"this preview answers requests for localhost only\n",
            false,
        ),
        (Route::BadRequest, _) => respond(
            &mut socket,
            "400 Bad Request",
            "text/plain; charset=utf-8",
            b"bad request\n",
            false,
        ),
    }
}

/// Sets the socket's send buffer (`SO_SNDBUF`).
fn set_send_buffer(socket: &TcpStream, bytes: libc::c_int) -> std::io::Result<()> {
    use std::os::fd::AsRawFd;
    // SAFETY: setsockopt(2) on a descriptor the stream owns, with a pointer to a c_int
    // that lives through the call and its size.
    let rc = unsafe {
        libc::setsockopt(
            socket.as_raw_fd(),
            libc::SOL_SOCKET,
            libc::SO_SNDBUF,
            (&bytes as *const libc::c_int).cast(),
            std::mem::size_of::<libc::c_int>() as libc::socklen_t,
        )
    };
    if rc == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

/// One browser's stream of events, until it goes, stops reading, or the server stops.
fn stream(mut socket: TcpStream, hub: &PreviewHub, stop: &AtomicBool) -> std::io::Result<()> {
    set_send_buffer(&socket, STREAM_SEND_BUFFER)?;
    socket.write_all(
        b"HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\n\r\nretry: 500\n\n",
    )?;
    let (rx, hello) = hub.subscribe();
    socket.write_all(hello.as_bytes())?;
    while !stop.load(Ordering::Acquire) {
        match rx.recv_timeout(KEEP_ALIVE) {
            Ok(message) => socket.write_all(message.as_bytes())?,
            Err(RecvTimeoutError::Timeout) => socket.write_all(b": keep-alive\n\n")?,
            // The hub dropped this stream (too slow) or the server stopped.
            Err(RecvTimeoutError::Disconnected) => break,
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::BufRead;

    fn get(address: SocketAddr, request: &str) -> String {
        let mut s = TcpStream::connect(address).unwrap();
        s.write_all(request.as_bytes()).unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        out
    }

    fn server() -> PreviewServer {
        PreviewServer::start("127.0.0.1:0".parse().unwrap()).unwrap()
    }

    #[test]
    fn routes_by_method_and_path() {
        let r = |h: &str| route(h.as_bytes(), true);
        assert_eq!(
            r("GET / HTTP/1.1\r\nHost: localhost\r\n\r\n"),
            (Route::Page, false)
        );
        assert_eq!(r("GET /?trace HTTP/1.1\r\n\r\n"), (Route::Page, false));
        assert_eq!(r("HEAD / HTTP/1.1\r\n\r\n"), (Route::Page, true));
        assert_eq!(r("GET /events HTTP/1.1\r\n\r\n"), (Route::Events, false));
        assert_eq!(
            r("GET /events/x HTTP/1.1\r\n\r\n"),
            (Route::NotFound, false)
        );
        assert_eq!(
            r("GET /../etc/passwd HTTP/1.1\r\n\r\n"),
            (Route::NotFound, false)
        );
        assert_eq!(
            r("POST / HTTP/1.1\r\n\r\n"),
            (Route::MethodNotAllowed, false)
        );
        assert_eq!(r("GET / HTTP/1.1\r\n"), (Route::BadRequest, false));
        assert_eq!(r("\u{1}\u{2} nonsense\r\n\r\n"), (Route::BadRequest, false));
    }

    #[test]
    fn a_loopback_server_answers_requests_for_this_machine_only() {
        for host in [
            "localhost",
            "LOCALHOST:8765",
            "127.0.0.1:8765",
            "127.0.0.2",
            "[::1]:8765",
            "[::1]",
        ] {
            let head = format!("GET / HTTP/1.1\r\nHost: {host}\r\n\r\n");
            assert_eq!(route(head.as_bytes(), true), (Route::Page, false), "{host}");
        }
        for host in [
            "evil.example:8765",
            "192.168.1.2:8765",
            "localhost.evil.example",
            "x",
        ] {
            let head = format!("GET /events HTTP/1.1\r\nHost: {host}\r\n\r\n");
            assert_eq!(
                route(head.as_bytes(), true),
                (Route::WrongHost, false),
                "{host}"
            );
            // Told to listen elsewhere, it answers whatever name it was reached by.
            assert_eq!(
                route(head.as_bytes(), false),
                (Route::Events, false),
                "{host}"
            );
        }
    }

    #[test]
    fn serves_the_page_and_a_404_for_anything_else() {
        let s = server();
        let page = get(s.address(), "GET / HTTP/1.1\r\nHost: localhost\r\n\r\n");
        assert!(page.starts_with("HTTP/1.1 200 OK\r\n"), "{page}");
        assert!(page.contains("text/html"), "{page}");
        assert!(page.contains("EventSource"), "the page is served whole");
        for path in ["/favicon.ico", "/status", "/events/", "/config"] {
            let r = get(s.address(), &format!("GET {path} HTTP/1.1\r\n\r\n"));
            assert!(r.starts_with("HTTP/1.1 404 Not Found\r\n"), "{path}: {r}");
        }
        let r = get(
            s.address(),
            "POST /events HTTP/1.1\r\nContent-Length: 0\r\n\r\n",
        );
        assert!(r.starts_with("HTTP/1.1 405"), "{r}");
    }

    #[test]
    fn a_port_in_use_is_refused_naming_the_address() {
        let s = server();
        let e = PreviewServer::start(s.address()).err().unwrap();
        assert!(format!("{e:#}").contains(&s.address().to_string()), "{e:#}");
    }

    /// Reads one SSE event (its `event:` and `data:` lines).
    fn next_event(r: &mut impl BufRead) -> (String, String) {
        let (mut kind, mut data) = (String::new(), String::new());
        loop {
            let mut line = String::new();
            assert!(r.read_line(&mut line).unwrap() > 0, "stream ended");
            let line = line.trim_end();
            if line.is_empty() && !kind.is_empty() {
                return (kind, data);
            }
            if let Some(k) = line.strip_prefix("event: ") {
                kind = k.to_string();
            } else if let Some(d) = line.strip_prefix("data: ") {
                data = d.to_string();
            }
        }
    }

    fn open_stream(s: &PreviewServer) -> std::io::BufReader<TcpStream> {
        let mut c = TcpStream::connect(s.address()).unwrap();
        c.write_all(b"GET /events HTTP/1.1\r\nAccept: text/event-stream\r\n\r\n")
            .unwrap();
        let mut r = std::io::BufReader::new(c);
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        assert_eq!(line, "HTTP/1.1 200 OK\r\n");
        r
    }

    fn wait_watched(hub: &PreviewHub, n: usize) {
        let start = std::time::Instant::now();
        while lock(&hub.shared.streams).len() < n {
            assert!(start.elapsed() < Duration::from_secs(5), "no stream opened");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    #[test]
    fn a_stream_starts_with_hello_and_gets_what_is_published_in_order() {
        let s = server();
        let hub = s.hub();
        hub.set_hello(r#"{"patterns":["tick"]}"#);
        let mut r = open_stream(&s);
        wait_watched(&hub, 1);
        for i in 0..100 {
            hub.publish("sound", &format!(r#"{{"id":{i}}}"#));
        }
        assert_eq!(
            next_event(&mut r),
            ("hello".into(), r#"{"patterns":["tick"]}"#.into())
        );
        for i in 0..100 {
            assert_eq!(
                next_event(&mut r),
                ("sound".into(), format!(r#"{{"id":{i}}}"#))
            );
        }
        hub.set_hello(r#"{"patterns":["pop"]}"#);
        assert_eq!(next_event(&mut r).1, r#"{"patterns":["pop"]}"#);
    }

    #[test]
    fn a_browser_that_stops_reading_loses_its_stream_and_never_holds_up_publishing() {
        let s = server();
        let hub = s.hub();
        // Connected, never read: once the socket's buffers are full, its queue fills.
        let _stalled = open_stream(&s);
        let mut reader = open_stream(&s);
        wait_watched(&hub, 2);
        let big = format!(r#"{{"pad":"{}"}}"#, "x".repeat(4000));
        let reader_thread = std::thread::spawn(move || {
            let mut n = 0;
            while n < 5000 {
                if next_event(&mut reader).0 == "sound" {
                    n += 1;
                }
            }
            n
        });
        for _ in 0..5000 {
            hub.publish("sound", &big);
            std::thread::sleep(Duration::from_micros(200));
        }
        assert_eq!(hub.closed_slow(), 1, "the stalled stream was closed, once");
        assert_eq!(
            reader_thread.join().unwrap(),
            5000,
            "the reading browser got everything"
        );
    }
}
