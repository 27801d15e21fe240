//! [`MidiSink`]: plays events as MIDI notes through midir (ALSA sequencer by default,
//! JACK with the `jack` cargo feature). Each pattern has a note and a channel; the
//! velocity follows the strength through the configured curve. An impulse is a note-on
//! and a note-off after the gate; a continuous event holds its note from begin to end
//! (with an optional control change carrying its strength). Every note that is on is
//! known, so all are released on stop, on reload and when a held sound is cut off.
//!
//! Owned by the output thread: sending MIDI is not real-time safe in most backends. A
//! port that cannot be opened is logged and retried; it never stops the daemon.

use std::time::{Duration, Instant};

use midir::{MidiOutput, MidiOutputConnection};

use crate::config::{MidiPortChoice, MidiSettings, PatternKind, PatternSpec};
use crate::detect::Event;

/// What MIDI needs on this build, for error messages.
#[cfg(feature = "jack")]
const BACKEND_HINT: &str = "this build sends MIDI through JACK: is a JACK server running?";
#[cfg(not(feature = "jack"))]
const BACKEND_HINT: &str =
    "this build sends MIDI through the ALSA sequencer (/dev/snd/seq); build with --features jack for JACK";

/// Client name the port is opened under.
pub const CLIENT_NAME: &str = "onomato";
const RETRY: Duration = Duration::from_secs(5);

/// Where a pattern's notes go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NoteMapping {
    pub pattern: String,
    pub note: u8,
    /// 1-16.
    pub channel: u8,
}

/// The note of each pattern: its own, or 36 plus its position (General MIDI drums from
/// the bass drum up); its channel, or the `[midi]` channel.
pub fn note_mappings(patterns: &[PatternSpec], midi: &MidiSettings) -> Vec<NoteMapping> {
    patterns
        .iter()
        .enumerate()
        .map(|(i, p)| NoteMapping {
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
    /// Event that started it.
    event: u64,
    /// When an impulse's gate closes; `None` for a held note.
    off_at: Option<Instant>,
}

/// Counters of what was sent.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct MidiCounters {
    pub note_ons: u64,
    pub note_offs: u64,
    pub send_errors: u64,
}

/// The MIDI sender.
pub struct MidiSink {
    settings: MidiSettings,
    mappings: Vec<NoteMapping>,
    connection: Option<MidiOutputConnection>,
    next_connect: Instant,
    sounding: Vec<SoundingNote>,
    /// Held sounds whose note a reload released: their end plays nothing.
    released_held: Vec<u64>,
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
            counters: MidiCounters::default(),
            last_sent: None,
            open_failures: 0,
        };
        sink.connect(Instant::now());
        sink
    }

    pub fn counters(&self) -> MidiCounters {
        self.counters
    }

    fn connect(&mut self, now: Instant) {
        if self.connection.is_some() || now < self.next_connect {
            return;
        }
        self.next_connect = now + RETRY;
        match open_port(&self.settings.port) {
            Ok(c) => {
                tracing::info!(port = %describe(&self.settings.port), "MIDI output open");
                self.connection = Some(c);
                self.open_failures = 0;
            }
            Err(e) => {
                // The first failure, then one a minute: a port that is away for hours
                // must not flood the log.
                self.open_failures += 1;
                if self.open_failures % 12 == 1 {
                    tracing::warn!(port = %describe(&self.settings.port), error = %e, attempts = self.open_failures, "cannot open MIDI output; retrying every 5 s");
                }
            }
        }
    }

    fn send(&mut self, bytes: &[u8]) -> bool {
        self.connect(Instant::now());
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

    fn note_on(&mut self, note: u8, channel: u8, velocity: u8) {
        if self.send(&[0x90 | (channel - 1), note, velocity.clamp(1, 127)]) {
            self.counters.note_ons += 1;
        }
    }

    fn note_off(&mut self, note: u8, channel: u8) {
        if self.send(&[0x80 | (channel - 1), note, 0]) {
            self.counters.note_offs += 1;
        }
    }

    /// Plays one event (impulse, begin marker or complete continuous event).
    pub fn play(&mut self, e: &Event, now: Instant) {
        let Some(m) = self.mappings.iter().find(|m| *m.pattern == *e.pattern) else {
            return;
        };
        let (note, channel) = (m.note, m.channel);
        let velocity = self.settings.velocity(e.strength);
        let gate = Some(now + Duration::from_secs_f64(self.settings.gate_seconds));
        match (e.kind, e.end) {
            (PatternKind::Impulse, _) => {
                self.start_note(note, channel, velocity, e.id, gate, false)
            }
            (PatternKind::Continuous, None) => {
                self.start_note(note, channel, velocity, e.id, None, true)
            }
            (PatternKind::Continuous, Some(_)) => {
                let id = e.id;
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
        event: u64,
        off_at: Option<Instant>,
        held: bool,
    ) {
        self.release_matching(|s| s.note == note && s.channel == channel);
        if let (true, Some(cc)) = (held, self.settings.strength_cc) {
            self.send(&[0xB0 | (channel - 1), cc, velocity.min(127)]);
        }
        self.note_on(note, channel, velocity);
        self.sounding.push(SoundingNote {
            note,
            channel,
            event,
            off_at,
        });
    }

    fn release_matching(&mut self, hit: impl Fn(&SoundingNote) -> bool) {
        let mut i = 0;
        while i < self.sounding.len() {
            if hit(&self.sounding[i]) {
                let s = self.sounding.swap_remove(i);
                self.note_off(s.note, s.channel);
            } else {
                i += 1;
            }
        }
    }

    /// Sends the note-offs whose gate has closed.
    pub fn release_due(&mut self, now: Instant) {
        self.release_matching(|s| s.off_at.is_some_and(|t| t <= now));
        if self.connection.is_none() {
            self.connect(now);
        }
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

    /// Releases the held note of one continuous event, if it is on.
    pub fn release_event(&mut self, id: u64) {
        self.release_matching(|s| s.event == id);
    }
}

impl Drop for MidiSink {
    /// Releases every note and gives the backend time to deliver the note-offs: JACK
    /// sends them in its next process cycles, after `send` has returned.
    fn drop(&mut self) {
        self.release_all();
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

/// Opens the configured port.
fn open_port(choice: &MidiPortChoice) -> Result<MidiOutputConnection, String> {
    let output = MidiOutput::new(CLIENT_NAME)
        .map_err(|e| format!("MIDI is not available: {e} ({BACKEND_HINT})"))?;
    match choice {
        MidiPortChoice::Connect(wanted) => {
            let ports = output.ports();
            let names: Vec<String> = ports
                .iter()
                .map(|p| output.port_name(p).unwrap_or_default())
                .collect();
            let needle = wanted.to_lowercase();
            let Some(i) = names
                .iter()
                .position(|n| n.to_lowercase().contains(&needle))
            else {
                return Err(format!(
                    "no MIDI output port name contains '{wanted}'; ports: {}",
                    if names.is_empty() {
                        "none".to_string()
                    } else {
                        names.join(", ")
                    }
                ));
            };
            output
                .connect(&ports[i], "out")
                .map_err(|e| format!("cannot connect to '{}': {e}", names[i]))
        }
        MidiPortChoice::Virtual(name) => open_virtual(output, name),
    }
}

#[cfg(unix)]
fn open_virtual(output: MidiOutput, name: &str) -> Result<MidiOutputConnection, String> {
    use midir::os::unix::VirtualOutput;
    output
        .create_virtual(name)
        .map_err(|e| format!("cannot open virtual port '{name}': {e}"))
}

#[cfg(not(unix))]
fn open_virtual(_output: MidiOutput, name: &str) -> Result<MidiOutputConnection, String> {
    Err(format!(
        "virtual MIDI ports are not available on this system; set [midi] connect to an existing port instead of virtual_port '{name}'"
    ))
}

/// Names of the MIDI output ports that can be connected to.
pub fn list_ports() -> Result<Vec<String>, String> {
    let output = MidiOutput::new(CLIENT_NAME).map_err(|e| format!("MIDI is not available: {e}"))?;
    Ok(output
        .ports()
        .iter()
        .map(|p| {
            output
                .port_name(p)
                .unwrap_or_else(|e| format!("(unnamed: {e})"))
        })
        .collect())
}
