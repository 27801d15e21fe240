//! [`OscSink`]: sends events, bounce launches and states, and status as OSC over UDP
//! to one or more targets. Flat addresses under a prefix, only the OSC 1.0 types i, f
//! and s, and explicit time arguments (receivers ignore bundle timetags); bundles with
//! the onset as timetag on request.
//!
//! Each time goes out twice: as an `f` where the contract first put it, and, appended
//! after every other argument, exactly as an `i` of whole seconds and an `f` fraction
//! ([`exact_time`]). A 32-bit float keeps a millisecond only for the first 2^14 s of
//! stream; the pair keeps 0.1 µs for 68 years, in types every receiver reads.
//!
//! Owned by the output thread; names are looked up on a thread of their own
//! ([`spawn_resolver`]). A target that cannot be resolved or does not answer is logged
//! and retried; it never stops the daemon.

use std::net::{SocketAddr, ToSocketAddrs, UdpSocket};
use std::sync::mpsc;
use std::time::{Duration, SystemTime};

use rosc::{OscBundle, OscMessage, OscPacket, OscTime, OscType};

use crate::config::{OscSettings, PatternKind};
use crate::detect::Event;
use crate::live_bounce::{BounceState, LiveHit};

/// How long the sink's start waits for the first lookup of its names (a name in
/// `/etc/hosts` takes well under a millisecond; a slow name server does not hold up a
/// start or a reload longer than this, and its answer is used when it comes).
const FIRST_LOOKUP_WAIT: Duration = Duration::from_millis(200);
/// Sent by the lookup thread after its first pass over the names.
const FIRST_PASS_DONE: usize = usize::MAX;
/// How long a target whose name did not resolve waits before the next try...
const RESOLVE_RETRY: Duration = Duration::from_secs(5);
/// ...and how often a name that did is looked up again (a receiver whose address
/// changes, as on a network that hands addresses out, is followed).
const RESOLVE_REFRESH: Duration = Duration::from_secs(60);

struct Target {
    spec: String,
    addr: Option<SocketAddr>,
    failures: u64,
}

/// The address to send to among those a name resolves to: IPv4 first.
fn pick(addrs: impl Iterator<Item = SocketAddr>) -> Option<SocketAddr> {
    let all: Vec<SocketAddr> = addrs.collect();
    all.iter().find(|a| a.is_ipv4()).or(all.first()).copied()
}

/// Looks the targets given by name up on a thread of its own, at once and then on a
/// timer, so that a slow or absent name server never holds up a send. It ends when
/// the sink that started it is dropped.
fn spawn_resolver(
    names: Vec<(usize, String)>,
    found: mpsc::Sender<(usize, Option<SocketAddr>)>,
) -> Option<mpsc::Sender<()>> {
    let (stop_tx, stop_rx) = mpsc::channel::<()>();
    let spawned = std::thread::Builder::new()
        .name("onomato-resolve".into())
        .spawn(move || {
            let mut known: Vec<Option<SocketAddr>> = vec![None; names.len()];
            let mut first_pass = true;
            loop {
                for (k, (index, spec)) in names.iter().enumerate() {
                    let addr = match spec.to_socket_addrs() {
                        Ok(addrs) => pick(addrs),
                        Err(e) => {
                            tracing::warn!(target = %spec, error = %e, "cannot resolve OSC target; retrying in 5 s");
                            None
                        }
                    };
                    if addr.is_none() && known[k].is_some() {
                        // A lookup that fails now keeps the address that worked.
                        continue;
                    }
                    if addr != known[k] {
                        known[k] = addr;
                        if found.send((*index, addr)).is_err() {
                            return;
                        }
                    }
                }
                if std::mem::take(&mut first_pass) && found.send((FIRST_PASS_DONE, None)).is_err() {
                    return;
                }
                let wait = if known.iter().all(Option::is_some) {
                    RESOLVE_REFRESH
                } else {
                    RESOLVE_RETRY
                };
                match stop_rx.recv_timeout(wait) {
                    Err(mpsc::RecvTimeoutError::Timeout) => {}
                    _ => return,
                }
            }
        });
    match spawned {
        Ok(_) => Some(stop_tx),
        Err(e) => {
            tracing::warn!("cannot start the OSC name lookup; targets by name get nothing: {e}");
            None
        }
    }
}

/// Counters of what was sent.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct OscCounters {
    pub packets_sent: u64,
    pub send_errors: u64,
}

/// The OSC sender.
pub struct OscSink {
    socket_v4: Option<UdpSocket>,
    socket_v6: Option<UdpSocket>,
    targets: Vec<Target>,
    /// Addresses of targets given by name, as the lookup thread finds them.
    resolved: mpsc::Receiver<(usize, Option<SocketAddr>)>,
    /// Dropped with the sink: ends the lookup thread.
    _stop_resolver: Option<mpsc::Sender<()>>,
    prefix: String,
    bundle: bool,
    /// Wall-clock time of stream time 0, for bundle timetags.
    stream_origin: SystemTime,
    counters: OscCounters,
}

/// Opens a UDP socket to send from; `None` (logged) when the system refuses.
fn bind(addr: &str) -> Option<UdpSocket> {
    match UdpSocket::bind(addr) {
        Ok(s) => Some(s),
        Err(e) => {
            tracing::warn!(bind = addr, error = %e, "cannot open a UDP socket for OSC");
            None
        }
    }
}

impl OscSink {
    pub fn new(settings: &OscSettings, stream_origin: SystemTime) -> Self {
        // Targets written as addresses are used at once; names are looked up apart.
        let targets: Vec<Target> = settings
            .targets
            .iter()
            .map(|spec| Target {
                spec: spec.clone(),
                addr: spec.parse::<SocketAddr>().ok(),
                failures: 0,
            })
            .collect();
        let names: Vec<(usize, String)> = targets
            .iter()
            .enumerate()
            .filter(|(_, t)| t.addr.is_none())
            .map(|(i, t)| (i, t.spec.clone()))
            .collect();
        let (found_tx, resolved) = mpsc::channel();
        let stop_resolver = if names.is_empty() {
            None
        } else {
            spawn_resolver(names, found_tx)
        };
        let mut sink = Self {
            socket_v4: bind("0.0.0.0:0"),
            socket_v6: None,
            targets,
            resolved,
            _stop_resolver: stop_resolver,
            prefix: settings.prefix.clone(),
            bundle: settings.bundle,
            stream_origin,
            counters: OscCounters::default(),
        };
        if sink
            .targets
            .iter()
            .any(|t| t.addr.is_some_and(|a| a.is_ipv6()))
        {
            sink.socket_v6 = bind("[::]:0");
        }
        if sink._stop_resolver.is_some() {
            let until = std::time::Instant::now() + FIRST_LOOKUP_WAIT;
            while let Ok((index, addr)) = sink
                .resolved
                .recv_timeout(until.saturating_duration_since(std::time::Instant::now()))
            {
                if index == FIRST_PASS_DONE {
                    break;
                }
                sink.set_address(index, addr);
            }
        }
        sink
    }

    /// Takes the addresses the lookup thread found since the last send.
    fn take_resolved(&mut self) {
        while let Ok((index, addr)) = self.resolved.try_recv() {
            self.set_address(index, addr);
        }
    }

    fn set_address(&mut self, index: usize, addr: Option<SocketAddr>) {
        let Some(t) = self.targets.get_mut(index) else {
            return;
        };
        if let Some(a) = addr {
            tracing::info!(target = %t.spec, address = %a, "OSC target resolved");
            if a.is_ipv6() && self.socket_v6.is_none() {
                self.socket_v6 = bind("[::]:0");
            }
        }
        t.addr = addr;
    }

    pub fn counters(&self) -> OscCounters {
        self.counters
    }

    /// Sends one event: `/p` for an impulse, `/p/begin` for a begin marker, `/p/end`
    /// for a complete continuous event, and `/event` for each.
    pub fn send_event(&mut self, e: &Event, begin_sent: bool) {
        let pitch = e.pitch.unwrap_or(0.0) as f32;
        let id = e.id as i32;
        let (strength, time) = (e.strength as f32, e.time as f32);
        let pattern = &*e.pattern;
        match (e.kind, e.end) {
            (PatternKind::Impulse, _) => {
                self.send(
                    &format!("/{pattern}"),
                    with_exact_times(
                        vec![
                            OscType::Float(strength),
                            OscType::Float(time),
                            OscType::Int(id),
                        ],
                        &[e.time],
                    ),
                    e.time,
                );
                self.send_generic(e, "impulse", e.time, pitch);
            }
            (PatternKind::Continuous, None) => {
                self.send_begin(e);
            }
            (PatternKind::Continuous, Some(end)) => {
                if !begin_sent {
                    self.send_begin(e);
                }
                self.send(
                    &format!("/{pattern}/end"),
                    with_exact_times(
                        vec![
                            OscType::Float(strength),
                            OscType::Float(end as f32),
                            OscType::Int(id),
                            OscType::Float(time),
                            OscType::Float(pitch),
                        ],
                        &[end, e.time],
                    ),
                    end,
                );
                self.send_generic(e, "end", end, pitch);
            }
        }
    }

    fn send_begin(&mut self, e: &Event) {
        self.send(
            &format!("/{}/begin", e.pattern),
            with_exact_times(
                vec![
                    OscType::Float(e.strength as f32),
                    OscType::Float(e.time as f32),
                    OscType::Int(e.id as i32),
                ],
                &[e.time],
            ),
            e.time,
        );
        self.send_generic(e, "begin", -1.0, 0.0);
    }

    /// `/event`: `end` is an impulse's own time and −1 for a begin.
    fn send_generic(&mut self, e: &Event, kind: &str, end: f64, pitch: f32) {
        self.send(
            "/event",
            with_exact_times(
                vec![
                    OscType::String(e.pattern.to_string()),
                    OscType::String(kind.to_string()),
                    OscType::Float(e.strength as f32),
                    OscType::Float(e.time as f32),
                    OscType::Float(end as f32),
                    OscType::Int(e.id as i32),
                    OscType::Float(pitch),
                ],
                &[e.time, end],
            ),
            e.time,
        );
    }

    /// `/bounce/hit`: launch velocity, launch time, predicted landing, apex, squash, id.
    pub fn send_bounce_hit(&mut self, hit: &LiveHit) {
        self.send(
            "/bounce/hit",
            with_exact_times(
                vec![
                    OscType::Float(hit.launch_velocity as f32),
                    OscType::Float(hit.time as f32),
                    OscType::Float(hit.predicted_landing as f32),
                    OscType::Float(hit.apex as f32),
                    OscType::Float(hit.squash as f32),
                    OscType::Int(hit.event as i32),
                ],
                &[hit.time, hit.predicted_landing],
            ),
            hit.time,
        );
    }

    /// `/bounce/state`: height, vertical velocity, time.
    pub fn send_bounce_state(&mut self, s: &BounceState) {
        self.send(
            "/bounce/state",
            with_exact_times(
                vec![
                    OscType::Float(s.height as f32),
                    OscType::Float(s.velocity as f32),
                    OscType::Float(s.time as f32),
                ],
                &[s.time],
            ),
            s.time,
        );
    }

    /// `/status`: stream time, events sent, events dropped, samples lost to overruns,
    /// input level (dBFS).
    pub fn send_status(
        &mut self,
        stream_time: f64,
        events: u64,
        dropped: u64,
        overruns: u64,
        level_db: f32,
    ) {
        let clamp = |n: u64| n.min(i32::MAX as u64) as i32;
        self.send(
            "/status",
            with_exact_times(
                vec![
                    OscType::Float(stream_time as f32),
                    OscType::Int(clamp(events)),
                    OscType::Int(clamp(dropped)),
                    OscType::Int(clamp(overruns)),
                    OscType::Float(level_db),
                ],
                &[stream_time],
            ),
            stream_time,
        );
    }

    fn send(&mut self, suffix: &str, args: Vec<OscType>, stream_time: f64) {
        let message = OscPacket::Message(OscMessage {
            addr: format!("{}{suffix}", self.prefix),
            args,
        });
        let packet = if self.bundle {
            let at = self.stream_origin + Duration::from_secs_f64(stream_time.max(0.0));
            let timetag = OscTime::try_from(at).unwrap_or(OscTime {
                seconds: 0,
                fractional: 1,
            });
            OscPacket::Bundle(OscBundle {
                timetag,
                content: vec![message],
            })
        } else {
            message
        };
        let bytes = match rosc::encoder::encode(&packet) {
            Ok(b) => b,
            Err(e) => {
                tracing::warn!(error = %e, "cannot encode an OSC message");
                return;
            }
        };
        self.take_resolved();
        for t in &mut self.targets {
            let Some(addr) = t.addr else { continue };
            let socket = if addr.is_ipv4() {
                self.socket_v4.as_ref()
            } else {
                self.socket_v6.as_ref()
            };
            let Some(socket) = socket else { continue };
            match socket.send_to(&bytes, addr) {
                Ok(_) => self.counters.packets_sent += 1,
                Err(e) => {
                    self.counters.send_errors += 1;
                    t.failures += 1;
                    // The first failure, then one in a thousand: a target that is down
                    // must not flood the log.
                    if t.failures % 1000 == 1 {
                        tracing::warn!(target = %t.spec, error = %e, failures = t.failures, "cannot send OSC; going on");
                    }
                }
            }
        }
    }
}

/// A time in stream seconds as OSC 1.0 types: whole seconds (`i`, rounded down, so −1
/// stays −1 with fraction 0) and the fraction of a second in [0, 1) (`f`).
pub fn exact_time(seconds: f64) -> [OscType; 2] {
    let whole = seconds.floor();
    let fraction = (seconds - whole) as f32;
    // An f32 just under 1 can round up to 1.0; carry it so the pair stays canonical.
    let (whole, fraction) = if fraction >= 1.0 {
        (whole + 1.0, 0.0)
    } else {
        (whole, fraction)
    };
    [
        OscType::Int(whole.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32),
        OscType::Float(fraction),
    ]
}

/// `args` with the exact form of each of `times` appended, in order.
fn with_exact_times(mut args: Vec<OscType>, times: &[f64]) -> Vec<OscType> {
    for &t in times {
        args.extend(exact_time(t));
    }
    args
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seconds_of(pair: &[OscType]) -> f64 {
        match pair {
            [OscType::Int(whole), OscType::Float(fraction)] => {
                assert!((0.0..1.0).contains(fraction), "fraction {fraction}");
                f64::from(*whole) + f64::from(*fraction)
            }
            other => panic!("not an exact time: {other:?}"),
        }
    }

    #[test]
    fn exact_times_keep_a_microsecond_after_seven_days_where_f32_keeps_62_ms() {
        let week = 7.0 * 86_400.0;
        for t in [
            0.0,
            0.0005,
            1.25,
            16_384.001,
            week + 0.0123,
            week + 0.9999999999,
        ] {
            let back = seconds_of(&exact_time(t));
            assert!((back - t).abs() < 1e-6, "{t} came back as {back}");
        }
        // What the f32 argument alone keeps there: the reason for the pair.
        assert!(((week + 0.0123) as f32 as f64 - (week + 0.0123)).abs() > 0.01);
        // A begin's "no end yet" stays −1 exactly.
        assert_eq!(seconds_of(&exact_time(-1.0)), -1.0);
    }

    #[test]
    fn a_target_given_by_name_gets_the_first_event_and_an_unknown_name_does_not_stop_the_others() {
        let receiver = UdpSocket::bind("127.0.0.1:0").unwrap();
        receiver
            .set_read_timeout(Some(Duration::from_secs(2)))
            .unwrap();
        let port = receiver.local_addr().unwrap().port();
        let settings = OscSettings {
            targets: vec![
                "no-such-host.invalid:9000".into(),
                format!("localhost:{port}"),
            ],
            prefix: "/x".into(),
            bundle: false,
            heartbeat_seconds: None,
            bounce_state_rate: None,
        };
        let mut sink = OscSink::new(&settings, SystemTime::now());
        sink.send_status(1.5, 0, 0, 0, -20.0);
        let mut buf = [0u8; 512];
        let n = receiver.recv(&mut buf).expect("nothing reached localhost");
        match rosc::decoder::decode_udp(&buf[..n]).unwrap().1 {
            OscPacket::Message(m) => assert_eq!(m.addr, "/x/status"),
            other => panic!("{other:?}"),
        }
        assert_eq!(sink.counters().packets_sent, 1);
    }

    #[test]
    fn an_impulse_a_week_into_the_stream_arrives_with_its_time_to_the_millisecond() {
        let receiver = UdpSocket::bind("127.0.0.1:0").unwrap();
        receiver
            .set_read_timeout(Some(Duration::from_secs(2)))
            .unwrap();
        let settings = OscSettings {
            targets: vec![receiver.local_addr().unwrap().to_string()],
            prefix: "/onomato".into(),
            bundle: false,
            heartbeat_seconds: None,
            bounce_state_rate: None,
        };
        let mut sink = OscSink::new(&settings, SystemTime::now());
        let time = 7.0 * 86_400.0 + 1.2345;
        let event = Event {
            id: 3,
            pattern: "tick".into(),
            kind: PatternKind::Impulse,
            time,
            end: None,
            strength: 0.8,
            score: 0.9,
            emitted_at: time + 0.02,
            pitch: None,
        };
        sink.send_event(&event, false);
        let mut buf = [0u8; 1024];
        let mut received = Vec::new();
        for _ in 0..2 {
            let n = receiver.recv(&mut buf).unwrap();
            match rosc::decoder::decode_udp(&buf[..n]).unwrap().1 {
                OscPacket::Message(m) => received.push(m),
                other => panic!("expected a message, got {other:?}"),
            }
        }
        let impulse = received.iter().find(|m| m.addr == "/onomato/tick").unwrap();
        assert_eq!(impulse.args.len(), 5);
        assert_eq!(impulse.args[2], OscType::Int(3));
        assert!((seconds_of(&impulse.args[3..5]) - time).abs() < 1e-3);
        let generic = received
            .iter()
            .find(|m| m.addr == "/onomato/event")
            .unwrap();
        assert_eq!(generic.args.len(), 11);
        assert!((seconds_of(&generic.args[7..9]) - time).abs() < 1e-3);
        assert!((seconds_of(&generic.args[9..11]) - time).abs() < 1e-3);
    }
}
