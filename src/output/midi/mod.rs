//! [`MidiSink`]: plays events as MIDI notes on a port of the ALSA sequencer (midir) or,
//! with the `jack` cargo feature, of a JACK server. Each pattern has a note and a
//! channel; the velocity follows the strength through the configured curve. An impulse
//! is a note-on and a note-off after the gate; a continuous event holds its note from
//! begin to end (with an optional control change carrying its strength). Every note that
//! is on is known, so all are released on stop, on reload and when a held sound is cut
//! off; a note-off that cannot be sent (the port is away, the server died) is owed and
//! sent as soon as a port is open again.
//!
//! Owned by the output thread: sending MIDI is not real-time safe in most backends. A
//! port that cannot be opened, or whose server goes away, is logged and retried; it
//! never stops the daemon.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::config::{MidiPortChoice, MidiSettings, PatternKind, PatternSpec};
use crate::detect::Event;

#[cfg(not(feature = "jack"))]
mod alsa;
#[cfg(not(feature = "jack"))]
use alsa as backend;
#[cfg(feature = "jack")]
mod jack;
#[cfg(feature = "jack")]
use jack as backend;

use backend::Connection;

/// Client name the port is opened under.
pub const CLIENT_NAME: &str = "onomato";
/// How often a port that cannot be opened is tried again: a restarted server is
/// found within this.
const RETRY: Duration = Duration::from_secs(2);
/// Failed attempts between two warnings in the log: one a minute.
const WARN_EVERY: u64 = 30;
/// How far back note-offs are remembered: longer than a server's cycle and than the
/// output thread takes to notice a lost port.
const RECENT_OFFS: Duration = Duration::from_secs(2);

/// Where a pattern's notes go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NoteMapping {
    /// The performer (lane) whose pattern it is.
    pub lane: usize,
    pub pattern: String,
    pub note: u8,
    /// 1-16.
    pub channel: u8,
}

/// The note of each pattern of performer `lane`: its own, or 36 plus its position
/// (General MIDI drums from the bass drum up); its channel, or the `[midi]` channel
/// (the performer's).
pub fn note_mappings(
    lane: usize,
    patterns: &[PatternSpec],
    midi: &MidiSettings,
) -> Vec<NoteMapping> {
    patterns
        .iter()
        .enumerate()
        .map(|(i, p)| NoteMapping {
            lane,
            pattern: p.name.clone(),
            note: p.note.unwrap_or((36 + i).min(127) as u8),
            channel: p.midi_channel.unwrap_or(midi.channel),
        })
        .collect()
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct SoundingNote {
    note: u8,
    channel: u8,
    /// Performer (lane) and event that started it.
    event: (usize, u64),
    /// When an impulse's gate closes; `None` for a held note.
    off_at: Option<Instant>,
    /// Whether its note-on left (no port, no note-off).
    on_sent: bool,
}

/// Counters of what was sent.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct MidiCounters {
    pub note_ons: u64,
    pub note_offs: u64,
    pub send_errors: u64,
    /// Ports lost under the daemon (their server stopped or died).
    pub ports_lost: u64,
    /// Late cycles (xruns) a JACK server reported: its receivers may have missed the
    /// messages of those cycles.
    pub server_xruns: u64,
}

/// The MIDI sender.
pub struct MidiSink {
    settings: MidiSettings,
    mappings: Vec<NoteMapping>,
    connection: Option<Connection>,
    next_connect: Instant,
    sounding: Vec<SoundingNote>,
    /// Held sounds (performer, event) whose note a reload released: their end plays
    /// nothing.
    released_held: Vec<(usize, u64)>,
    /// Note-offs (note, channel) of notes that went on and could not be released:
    /// sent first when a port is open again.
    owed_offs: Vec<(u8, u8)>,
    /// The note-offs sent in the last [`RECENT_OFFS`], with when: those the port may
    /// not have delivered when its server died are sent again.
    recent_offs: VecDeque<(u8, u8, Instant)>,
    counters: MidiCounters,
    last_sent: Option<Instant>,
    open_failures: u64,
}

impl MidiSink {
    pub fn new(settings: MidiSettings, mappings: Vec<NoteMapping>) -> Self {
        let mut sink = Self {
            settings,
            mappings,
            connection: None,
            next_connect: Instant::now(),
            sounding: Vec::with_capacity(64),
            released_held: Vec::new(),
            owed_offs: Vec::with_capacity(64),
            recent_offs: VecDeque::with_capacity(64),
            counters: MidiCounters::default(),
            last_sent: None,
            open_failures: 0,
        };
        sink.connect(Instant::now());
        sink
    }

    pub fn counters(&self) -> MidiCounters {
        let mut c = self.counters;
        c.server_xruns += self.connection.as_ref().map_or(0, Connection::server_xruns);
        c
    }

    fn connect(&mut self, now: Instant) {
        if self.connection.is_some() || now < self.next_connect {
            return;
        }
        self.next_connect = now + RETRY;
        match Connection::open(CLIENT_NAME, &self.settings.port) {
            Ok(c) => {
                tracing::info!(port = %describe(&self.settings.port), owed_note_offs = self.owed_offs.len(), "MIDI output open");
                self.connection = Some(c);
                self.open_failures = 0;
                for (note, channel) in std::mem::take(&mut self.owed_offs) {
                    self.note_off(note, channel);
                }
            }
            Err(e) => {
                // The first failure, then one a minute: a port that is away for hours
                // must not flood the log.
                self.open_failures += 1;
                if self.open_failures % WARN_EVERY == 1 {
                    tracing::warn!(port = %describe(&self.settings.port), error = %e, attempts = self.open_failures, "cannot open MIDI output; retrying every {} s", RETRY.as_secs());
                }
            }
        }
    }

    /// Drops a connection whose server went away. The notes it had on went with the
    /// server: their note-offs are owed to the next port, and the held sounds among
    /// them play nothing at their end.
    fn check_lost(&mut self, now: Instant) {
        let Some(why) = self.connection.as_ref().and_then(Connection::lost) else {
            return;
        };
        let undelivered = self
            .connection
            .as_ref()
            .and_then(Connection::undelivered_since);
        self.counters.server_xruns += self.connection.as_ref().map_or(0, Connection::server_xruns);
        self.connection = None;
        self.counters.ports_lost += 1;
        if let Some(since) = undelivered {
            for &(note, channel, at) in &self.recent_offs {
                if at >= since && !self.owed_offs.contains(&(note, channel)) {
                    self.owed_offs.push((note, channel));
                }
            }
        }
        self.recent_offs.clear();
        for s in self.sounding.drain(..) {
            if s.off_at.is_none() {
                self.released_held.push(s.event);
            }
            if s.on_sent && !self.owed_offs.contains(&(s.note, s.channel)) {
                self.owed_offs.push((s.note, s.channel));
            }
        }
        tracing::warn!(port = %describe(&self.settings.port), reason = %why, owed_note_offs = self.owed_offs.len(), "MIDI output lost; reopening every {} s", RETRY.as_secs());
        self.next_connect = now;
        self.connect(now);
    }

    fn send(&mut self, bytes: &[u8]) -> bool {
        let now = Instant::now();
        self.check_lost(now);
        self.connect(now);
        let Some(c) = self.connection.as_mut() else {
            self.counters.send_errors += 1;
            return false;
        };
        match c.send(bytes) {
            Ok(()) => {
                self.last_sent = Some(Instant::now());
                true
            }
            Err(e) => {
                self.counters.send_errors += 1;
                if self.counters.send_errors % 1000 == 1 {
                    tracing::warn!(error = %e, "cannot send MIDI; going on");
                }
                false
            }
        }
    }

    fn note_on(&mut self, note: u8, channel: u8, velocity: u8) -> bool {
        let sent = self.send(&[0x90 | (channel - 1), note, velocity.clamp(1, 127)]);
        if sent {
            self.counters.note_ons += 1;
        }
        sent
    }

    fn note_off(&mut self, note: u8, channel: u8) {
        if self.send(&[0x80 | (channel - 1), note, 0]) {
            self.counters.note_offs += 1;
            let now = Instant::now();
            while self
                .recent_offs
                .front()
                .is_some_and(|&(_, _, at)| now.duration_since(at) > RECENT_OFFS)
                || self.recent_offs.len() >= 64
            {
                self.recent_offs.pop_front();
            }
            self.recent_offs.push_back((note, channel, now));
        } else if !self.owed_offs.contains(&(note, channel)) {
            self.owed_offs.push((note, channel));
        }
    }

    /// Plays one event (impulse, begin marker or complete continuous event).
    /// Plays an event of performer `lane`.
    pub fn play(&mut self, lane: usize, e: &Event, now: Instant) {
        let Some(m) = self
            .mappings
            .iter()
            .find(|m| m.lane == lane && *m.pattern == *e.pattern)
        else {
            return;
        };
        let (note, channel) = (m.note, m.channel);
        let velocity = self.settings.velocity(e.strength);
        let gate = Some(now + Duration::from_secs_f64(self.settings.gate_seconds));
        match (e.kind, e.end) {
            (PatternKind::Impulse, _) => {
                self.start_note(note, channel, velocity, (lane, e.id), gate, false)
            }
            (PatternKind::Continuous, None) => {
                self.start_note(note, channel, velocity, (lane, e.id), None, true)
            }
            (PatternKind::Continuous, Some(_)) => {
                let id = (lane, e.id);
                if let Some(i) = self.released_held.iter().position(|&r| r == id) {
                    self.released_held.swap_remove(i);
                } else if self.sounding.iter().any(|s| s.event == id) {
                    self.release_matching(|s| s.event == id);
                } else {
                    // Begin and end decided together (waveform method): play it gated.
                    self.start_note(note, channel, velocity, id, gate, true);
                }
            }
        }
    }

    /// Plays a note for `event`, releasing first the same note if it still sounds; held
    /// sounds send the strength control change first. `off_at`: when the gate closes
    /// (`None`: held until its end).
    fn start_note(
        &mut self,
        note: u8,
        channel: u8,
        velocity: u8,
        event: (usize, u64),
        off_at: Option<Instant>,
        held: bool,
    ) {
        self.release_matching(|s| s.note == note && s.channel == channel);
        if let (true, Some(cc)) = (held, self.settings.strength_cc) {
            self.send(&[0xB0 | (channel - 1), cc, velocity.min(127)]);
        }
        let on_sent = self.note_on(note, channel, velocity);
        self.sounding.push(SoundingNote {
            note,
            channel,
            event,
            off_at,
            on_sent,
        });
    }

    fn release_matching(&mut self, hit: impl Fn(&SoundingNote) -> bool) {
        let mut i = 0;
        while i < self.sounding.len() {
            if hit(&self.sounding[i]) {
                let s = self.sounding.swap_remove(i);
                if s.on_sent {
                    self.note_off(s.note, s.channel);
                }
            } else {
                i += 1;
            }
        }
    }

    /// Sends the note-offs whose gate has closed.
    pub fn release_due(&mut self, now: Instant) {
        self.check_lost(now);
        self.release_matching(|s| s.off_at.is_some_and(|t| t <= now));
        self.connect(now);
    }

    /// When the next gate closes.
    pub fn next_deadline(&self) -> Option<Instant> {
        self.sounding.iter().filter_map(|s| s.off_at).min()
    }

    /// New settings and note mappings on the same port (reload): the notes that are on
    /// are released first, the connection stays.
    pub fn update(&mut self, settings: MidiSettings, mappings: Vec<NoteMapping>) {
        self.released_held = self
            .sounding
            .iter()
            .filter(|s| s.off_at.is_none())
            .map(|s| s.event)
            .collect();
        self.release_all();
        debug_assert!(settings.port == self.settings.port);
        self.settings = settings;
        self.mappings = mappings;
    }

    /// Releases every note that is on (stop, reload, cut-off).
    pub fn release_all(&mut self) {
        self.release_matching(|_| true);
    }

    /// Releases the held note of one continuous event of performer `lane`, if it is on.
    pub fn release_event(&mut self, lane: usize, id: u64) {
        self.release_matching(|s| s.event == (lane, id));
    }

    /// Releases every note of performer `lane` (its detector was replaced).
    pub fn release_lane(&mut self, lane: usize) {
        self.release_matching(|s| s.event.0 == lane);
    }
}

impl Drop for MidiSink {
    /// Releases every note and gives the backend time to deliver the note-offs: JACK
    /// sends them in its next process cycles, after `send` has returned.
    fn drop(&mut self) {
        self.check_lost(Instant::now());
        self.release_all();
        if !self.owed_offs.is_empty() {
            tracing::warn!(port = %describe(&self.settings.port), owed_note_offs = self.owed_offs.len(), "MIDI output closed with notes it could not release: no port is open");
        }
        if let Some(sent) = self.last_sent {
            let since = sent.elapsed();
            if since < DELIVERY_GRACE {
                std::thread::sleep(DELIVERY_GRACE - since);
            }
        }
    }
}

/// How long a closing port waits for its last messages to leave.
const DELIVERY_GRACE: Duration = Duration::from_millis(100);

fn describe(port: &MidiPortChoice) -> String {
    match port {
        MidiPortChoice::Connect(name) => format!("connect to '{name}'"),
        MidiPortChoice::Virtual(name) => format!("virtual port '{name}'"),
    }
}

/// Index of the first port whose name contains `wanted` (case-insensitive).
fn find_port(names: &[String], wanted: &str) -> Result<usize, String> {
    let needle = wanted.to_lowercase();
    names
        .iter()
        .position(|n| n.to_lowercase().contains(&needle))
        .ok_or_else(|| {
            format!(
                "no MIDI port name contains '{wanted}'; ports: {}",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            )
        })
}

/// Names of the MIDI ports that `[midi] connect` can name.
pub fn list_ports() -> Result<Vec<String>, String> {
    backend::list_ports(CLIENT_NAME)
}
