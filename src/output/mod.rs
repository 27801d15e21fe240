//! The output thread of the daemon: it owns the OSC socket ([`osc::OscSink`]), the MIDI
//! port ([`midi::MidiSink`]) and the live bounce solver, and hands each event it sends
//! to the printing thread ([`print::Printer`]), which never holds it up. The detector thread hands it events through a bounded channel (`try_send`,
//! drops counted), and reconfigurations, cut-offs and the stop the same way, in order
//! and without waiting (`DetectorStage::send_control`).
//!
//! Sends never run on the detection path. On stop every held sound is cut off (its
//! `/end` sent, its note released) and every note is released; a reload rebuilds only
//! what changed ([`Sinks::reconfigure`]).

pub mod midi;
pub mod osc;
pub mod preview;
pub mod print;

use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime};

use crate::config::{BounceSettings, Config, MidiSettings, OscSettings, PatternKind};
use crate::detect::Event;
use crate::live_bounce::{BounceState, LiveBounce, LiveHit};
use crate::status::Status;
use midi::{MidiSink, NoteMapping};
use osc::OscSink;
use preview::PreviewHub;
use print::Printer;

/// Capacity of the channel from the detector thread.
pub const OUTPUT_QUEUE: usize = 256;

/// How events are printed on stdout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PrintMode {
    /// One readable line per event.
    Text,
    /// One JSON event record per line (a continuous event twice: at its begin without
    /// `end`, then complete).
    Json,
    /// Nothing (logs only).
    None,
}

/// What the output thread sends where.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputSettings {
    pub osc: Option<OscSettings>,
    pub midi: Option<(MidiSettings, Vec<NoteMapping>)>,
    /// The live bounce solver runs when set; its states are sent when OSC has a
    /// `bounce_state_rate`.
    pub bounce: Option<BounceSettings>,
    /// The detector's longest decision delay: the bounce states' default delay.
    pub decision_delay: f64,
    pub print: PrintMode,
    /// The patterns (for the preview page's `hello`).
    pub patterns: Vec<(String, PatternKind)>,
    /// Draw the bounce states for the preview page (at the OSC state rate, or 60 Hz).
    pub preview: bool,
}

/// Bounce states drawn per second for the preview when OSC does not set a rate.
const PREVIEW_STATE_RATE: f64 = 60.0;
/// Status messages to the preview page per second.
const PREVIEW_STATUS_PERIOD: Duration = Duration::from_millis(100);

impl OutputSettings {
    /// The output thread's settings from a config; `decision_delay`: the detector's
    /// [`crate::detect::Detector::decision_delay_bound`].
    pub fn from_config(config: &Config, decision_delay: f64, print: PrintMode) -> Self {
        Self {
            osc: config.osc.clone(),
            midi: config
                .midi
                .as_ref()
                .map(|m| (m.clone(), midi::note_mappings(&config.patterns, m))),
            bounce: (config.bounce.is_some()
                || config.preview.is_some()
                || config
                    .osc
                    .as_ref()
                    .is_some_and(|o| o.bounce_state_rate.is_some()))
            .then(|| config.bounce_or_default()),
            decision_delay,
            print,
            patterns: config
                .patterns
                .iter()
                .map(|p| (p.name.clone(), p.kind))
                .collect(),
            preview: config.preview.is_some(),
        }
    }
}

/// Messages to the output thread.
#[derive(Debug)]
pub enum OutputMessage {
    Event(Event),
    /// New settings (reload): only the sinks whose settings changed are made again.
    Reconfigure(Box<OutputSettings>),
    /// Cut off held sounds and release every note (the input changed).
    CutOff,
    /// Cut off held sounds, release every note, and end the thread.
    Stop,
}

/// What the output thread did, returned when it ends.
#[derive(Debug, Default, Clone, Copy)]
pub struct OutputReport {
    /// Sounds sent: impulses, and held sounds counted once (at their begin).
    pub events: u64,
    pub osc: osc::OscCounters,
    pub midi: midi::MidiCounters,
    pub late_bounce_hits: u64,
    /// Printed lines dropped because stdout was not read fast enough.
    pub print_dropped: u64,
    /// Preview streams closed because their browser stopped reading.
    pub preview_closed: u64,
}

struct Sinks {
    /// The settings the sinks were made from, to reload by difference.
    settings: OutputSettings,
    origin: SystemTime,
    osc: Option<OscSink>,
    midi: Option<MidiSink>,
    bounce: Option<LiveBounce>,
    state_delay: f64,
    heartbeat: Option<Duration>,
    /// Seconds between two drawn bounce states; `None`: no states are drawn.
    state_period: Option<f64>,
    /// Drawn states go to OSC (`bounce_state_rate` is set).
    osc_states: bool,
}

fn state_rate(s: &OutputSettings) -> Option<f64> {
    s.osc.as_ref().and_then(|o| o.bounce_state_rate)
}

/// The rate states are drawn at: OSC's, else the preview's; `None`: no states.
fn drawn_state_rate(s: &OutputSettings) -> Option<f64> {
    state_rate(s).or(s.preview.then_some(PREVIEW_STATE_RATE))
}

fn new_bounce(s: &OutputSettings) -> Option<LiveBounce> {
    s.bounce
        .as_ref()
        .map(|b| LiveBounce::new(b, drawn_state_rate(s).unwrap_or(PREVIEW_STATE_RATE)))
}

impl Sinks {
    fn new(s: &OutputSettings, origin: SystemTime) -> Self {
        let mut sinks = Self {
            settings: s.clone(),
            origin,
            osc: s.osc.as_ref().map(|o| OscSink::new(o, origin)),
            midi: s
                .midi
                .as_ref()
                .map(|(m, notes)| MidiSink::new(m.clone(), notes.clone())),
            bounce: new_bounce(s),
            state_delay: 0.0,
            heartbeat: None,
            state_period: None,
            osc_states: false,
        };
        sinks.derive_timing();
        sinks
    }

    fn derive_timing(&mut self) {
        let s = &self.settings;
        self.state_delay = s
            .bounce
            .as_ref()
            .and_then(|b| b.state_delay_seconds)
            .unwrap_or(s.decision_delay);
        self.heartbeat = s
            .osc
            .as_ref()
            .and_then(|o| o.heartbeat_seconds)
            .map(Duration::from_secs_f64);
        self.state_period = drawn_state_rate(s).map(|r| 1.0 / r);
        self.osc_states = state_rate(s).is_some();
    }

    /// Reload by difference: rebuilds only the sinks whose settings changed, so that a
    /// new OSC target keeps the MIDI port (and the connections a DAW made to it) and
    /// the held sounds, and new note mappings keep the port open. Returns what changed.
    /// The counters of a sink that is replaced go into `report`.
    fn reconfigure(
        &mut self,
        new: &OutputSettings,
        report: &mut OutputReport,
    ) -> Vec<&'static str> {
        let mut changed = Vec::new();
        let old = std::mem::replace(&mut self.settings, new.clone());
        if new.osc != old.osc {
            if let Some(o) = &self.osc {
                add_osc(report, o.counters());
            }
            self.osc = new.osc.as_ref().map(|o| OscSink::new(o, self.origin));
            changed.push("osc");
        }
        match (&new.midi, self.midi.as_mut(), &old.midi) {
            (Some((m, notes)), Some(sink), Some((old_m, old_notes)))
                if m.port == old_m.port && (m != old_m || notes != old_notes) =>
            {
                // The notes that are on were started under the old mapping.
                sink.update(m.clone(), notes.clone());
                changed.push("midi notes");
            }
            (Some((m, _)), Some(_), Some((old_m, _))) if m.port == old_m.port => {}
            _ if new.midi != old.midi => {
                if let Some(m) = &self.midi {
                    add_midi(report, m.counters());
                }
                // Dropping the old sink releases its notes.
                self.midi = new
                    .midi
                    .as_ref()
                    .map(|(m, notes)| MidiSink::new(m.clone(), notes.clone()));
                changed.push("midi port");
            }
            _ => {}
        }
        if new.bounce != old.bounce || drawn_state_rate(new) != drawn_state_rate(&old) {
            if let Some(b) = &self.bounce {
                report.late_bounce_hits += b.late_hits();
            }
            self.bounce = new_bounce(new);
            changed.push("bounce");
        }
        self.derive_timing();
        changed
    }

    /// States are drawn when OSC asks for them (`bounce_state_rate`, which only an
    /// `[osc]` section sets) or the preview shows them.
    fn states_wanted(&self) -> bool {
        self.bounce.is_some() && self.state_period.is_some()
    }

    /// Draws the bounce states up to stream time `until` and sends them where they go.
    fn draw_states(&mut self, until: f64, preview: Option<&PreviewHub>) {
        let Sinks {
            bounce,
            osc,
            osc_states,
            ..
        } = self;
        let Some(b) = bounce.as_mut() else {
            return;
        };
        let preview = preview.filter(|p| p.watched());
        b.draw_until(until, |s| {
            if *osc_states {
                if let Some(o) = osc.as_mut() {
                    o.send_bounce_state(&s);
                }
            }
            if let Some(p) = preview {
                p.publish("state", &state_json(&s));
            }
        });
    }
}

/// The preview's `hello`: the patterns, and the wall-clock time of stream time 0.
fn hello_json(s: &OutputSettings, origin: SystemTime) -> String {
    let patterns: Vec<serde_json::Value> = s
        .patterns
        .iter()
        .map(|(name, kind)| serde_json::json!({ "name": name, "kind": kind }))
        .collect();
    let origin = origin
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64());
    serde_json::json!({
        "patterns": patterns,
        "bounce": s.bounce.is_some(),
        "origin_unix_seconds": origin,
    })
    .to_string()
}

fn state_json(s: &BounceState) -> String {
    serde_json::json!({ "time": s.time, "height": s.height, "velocity": s.velocity }).to_string()
}

fn hit_json(h: &LiveHit) -> String {
    serde_json::json!({
        "event": h.event,
        "time": h.time,
        "launch_velocity": h.launch_velocity,
        "predicted_landing": h.predicted_landing,
        "apex": h.apex,
        "squash": h.squash,
    })
    .to_string()
}

fn publish_sound(preview: Option<&PreviewHub>, e: &Event) {
    if let Some(p) = preview.filter(|p| p.watched()) {
        if let Ok(json) = serde_json::to_string(e) {
            p.publish("sound", &json);
        }
    }
}

/// Runs the output thread's loop until [`OutputMessage::Stop`] (or every sender is
/// gone). `origin` is the wall-clock time of stream time 0; `preview`, the preview
/// page's hub when it is served.
pub fn run(
    settings: OutputSettings,
    rx: Receiver<OutputMessage>,
    status: Arc<Status>,
    origin: SystemTime,
    preview: Option<PreviewHub>,
) -> OutputReport {
    let mut sinks = Sinks::new(&settings, origin);
    let preview = preview.as_ref();
    if let Some(p) = preview {
        p.set_hello(&hello_json(&settings, origin));
    }
    let mut next_preview_status = Instant::now();
    let mut report = OutputReport::default();
    // Continuous events whose begin was sent and whose end was not.
    let mut open: Vec<Event> = Vec::with_capacity(16);
    let mut next_heartbeat = Instant::now();
    // In a terminal, a compact input level under the printed events.
    let meter = {
        use std::io::IsTerminal;
        settings.print == PrintMode::Text && std::io::stderr().is_terminal()
    };
    let mut printer = Printer::start(settings.print, meter, print::PRINT_QUEUE, std::io::stdout());
    let mut next_meter = Instant::now();
    loop {
        let now = Instant::now();
        let mut wake = now + Duration::from_millis(250);
        if meter {
            wake = wake.min(next_meter);
        }
        if let Some(t) = sinks.midi.as_ref().and_then(MidiSink::next_deadline) {
            wake = wake.min(t);
        }
        if sinks.heartbeat.is_some() {
            wake = wake.min(next_heartbeat);
        }
        if sinks.states_wanted() {
            let period = sinks.state_period.unwrap_or(0.25).min(0.25);
            wake = wake.min(now + Duration::from_secs_f64(period));
        }
        if preview.is_some() {
            wake = wake.min(next_preview_status);
        }
        let message = rx.recv_timeout(wake.saturating_duration_since(now));
        match message {
            Ok(OutputMessage::Event(e)) => {
                let ends_an_open_sound = e.kind == PatternKind::Continuous
                    && e.end.is_some()
                    && open.iter().any(|o| o.id == e.id);
                if !ends_an_open_sound {
                    report.events += 1;
                }
                let begin_sent = match (e.kind, e.end) {
                    (PatternKind::Continuous, None) => {
                        open.push(e.clone());
                        false
                    }
                    (PatternKind::Continuous, Some(_)) => {
                        let was = open.iter().position(|o| o.id == e.id);
                        if let Some(i) = was {
                            open.swap_remove(i);
                        }
                        was.is_some()
                    }
                    _ => false,
                };
                if let Some(o) = sinks.osc.as_mut() {
                    o.send_event(&e, begin_sent);
                }
                if let Some(m) = sinks.midi.as_mut() {
                    m.play(&e, Instant::now());
                }
                printer.event(&e, begin_sent);
                publish_sound(preview, &e);
                if let Some(b) = sinks.bounce.as_mut() {
                    let late = b.late_hits();
                    let hit = b.on_event(&e);
                    if b.late_hits() > late && late % 100 == 0 {
                        tracing::warn!(
                            late_hits = b.late_hits(),
                            delay = sinks.state_delay,
                            "a hit was decided after the bounce states had passed it; raise [bounce] state_delay_seconds"
                        );
                    }
                    if let Some(hit) = hit {
                        if let Some(o) = sinks.osc.as_mut() {
                            o.send_bounce_hit(&hit);
                        }
                        if let Some(p) = preview {
                            p.publish("hit", &hit_json(&hit));
                        }
                    }
                }
            }
            Ok(OutputMessage::Reconfigure(new)) => {
                let changed = sinks.reconfigure(&new, &mut report);
                if let Some(p) = preview {
                    p.set_hello(&hello_json(&new, origin));
                }
                if !changed.is_empty() {
                    tracing::info!(changed = %changed.join(", "), "outputs reloaded");
                }
            }
            Ok(OutputMessage::CutOff) => {
                cut_off(&mut sinks, &mut open, status.stream_seconds(), preview);
            }
            Ok(OutputMessage::Stop) | Err(RecvTimeoutError::Disconnected) => {
                // The states the delay held back, up to the end of the stream.
                if sinks.states_wanted() {
                    sinks.draw_states(status.stream_seconds(), preview);
                }
                cut_off(&mut sinks, &mut open, status.stream_seconds(), preview);
                collect(&sinks, &mut report);
                report.print_dropped = printer.finish();
                report.preview_closed = preview.map_or(0, PreviewHub::closed_slow);
                return report;
            }
            Err(RecvTimeoutError::Timeout) => {}
        }
        let now = Instant::now();
        if meter && now >= next_meter {
            next_meter = now + Duration::from_millis(100);
            printer.meter(status.level_db(), status.stream_seconds(), report.events);
        }
        if let Some(m) = sinks.midi.as_mut() {
            m.release_due(now);
        }
        if let Some(period) = sinks.heartbeat {
            if now >= next_heartbeat {
                next_heartbeat = now + period;
                if let Some(o) = sinks.osc.as_mut() {
                    o.send_status(
                        status.stream_seconds(),
                        report.events,
                        status.dropped_events(),
                        status.overrun_samples(),
                        status.level_db(),
                    );
                }
            }
        }
        if sinks.states_wanted() {
            sinks.draw_states(status.stream_seconds() - sinks.state_delay, preview);
        }
        if let Some(p) = preview {
            if now >= next_preview_status {
                next_preview_status = now + PREVIEW_STATUS_PERIOD;
                if p.watched() {
                    p.publish("status", &status_json(&status, &report, &sinks, p));
                }
            }
        }
    }
}

/// The counters of `/status`, and the others the daemon keeps, for the preview.
fn status_json(status: &Status, report: &OutputReport, sinks: &Sinks, p: &PreviewHub) -> String {
    serde_json::json!({
        "stream_seconds": status.stream_seconds(),
        "events": report.events,
        "dropped_events": status.dropped_events(),
        "overrun_samples": status.overrun_samples(),
        "level_db": status.level_db(),
        "bad_samples": status.bad_samples(),
        "xruns": status.xruns(),
        "late_bounce_hits": report.late_bounce_hits + sinks.bounce.as_ref().map_or(0, LiveBounce::late_hits),
        "preview_closed": p.closed_slow(),
    })
    .to_string()
}

/// Ends every open continuous event at stream time `at` and releases every note.
fn cut_off(sinks: &mut Sinks, open: &mut Vec<Event>, at: f64, preview: Option<&PreviewHub>) {
    for mut e in open.drain(..) {
        tracing::info!(pattern = %e.pattern, id = e.id, "held sound cut off");
        // Its end, sent as the `/end` of the begin that was sent.
        e.end = Some(at.max(e.time));
        if let Some(o) = sinks.osc.as_mut() {
            o.send_event(&e, true);
        }
        publish_sound(preview, &e);
        if let Some(m) = sinks.midi.as_mut() {
            m.release_event(e.id);
        }
    }
    if let Some(m) = sinks.midi.as_mut() {
        m.release_all();
    }
}

fn add_osc(report: &mut OutputReport, c: osc::OscCounters) {
    report.osc.packets_sent += c.packets_sent;
    report.osc.send_errors += c.send_errors;
}

fn add_midi(report: &mut OutputReport, c: midi::MidiCounters) {
    report.midi.note_ons += c.note_ons;
    report.midi.note_offs += c.note_offs;
    report.midi.send_errors += c.send_errors;
    report.midi.ports_lost += c.ports_lost;
    report.midi.server_xruns += c.server_xruns;
}

fn collect(sinks: &Sinks, report: &mut OutputReport) {
    if let Some(o) = &sinks.osc {
        add_osc(report, o.counters());
    }
    if let Some(m) = &sinks.midi {
        add_midi(report, m.counters());
    }
    if let Some(b) = &sinks.bounce {
        report.late_bounce_hits += b.late_hits();
    }
}
