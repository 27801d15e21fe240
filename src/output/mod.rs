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

/// What the output thread sends where: one lane per performer, and the MIDI port they
/// share.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputSettings {
    pub lanes: Vec<LaneSettings>,
    /// The port's settings, and every lane's note mappings.
    pub midi: Option<(MidiSettings, Vec<NoteMapping>)>,
    pub print: PrintMode,
    /// Draw the bounce states for the preview page (at the OSC state rate, or 60 Hz).
    pub preview: bool,
}

/// One performer's outputs.
#[derive(Debug, Clone, PartialEq)]
pub struct LaneSettings {
    /// The performer's name; `None` without `[[performer]]` sections.
    pub name: Option<String>,
    /// With the performer's own prefix.
    pub osc: Option<OscSettings>,
    /// The live bounce solver runs when set; its states are sent when OSC has a
    /// `bounce_state_rate`.
    pub bounce: Option<BounceSettings>,
    /// The detector's longest decision delay: the bounce states' default delay.
    pub decision_delay: f64,
    /// The patterns (for the preview page's `hello`).
    pub patterns: Vec<(String, PatternKind)>,
}

/// Bounce states drawn per second for the preview when OSC does not set a rate.
const PREVIEW_STATE_RATE: f64 = 60.0;
/// Status messages to the preview page per second.
const PREVIEW_STATUS_PERIOD: Duration = Duration::from_millis(100);

impl OutputSettings {
    /// The output thread's settings from a config; `decision_delays`: each performer's
    /// detector's [`crate::detect::Detector::decision_delay_bound`], in the order of
    /// [`Config::lanes`].
    pub fn from_config(config: &Config, decision_delays: &[f64], print: PrintMode) -> Self {
        let lanes = config.lanes();
        let lane_settings = lanes
            .iter()
            .zip(decision_delays)
            .map(|((name, c), &decision_delay)| LaneSettings {
                name: name.clone(),
                osc: c.osc.clone(),
                bounce: (c.bounce.is_some()
                    || c.preview.is_some()
                    || c.osc
                        .as_ref()
                        .is_some_and(|o| o.bounce_state_rate.is_some()))
                .then(|| c.bounce_or_default()),
                decision_delay,
                patterns: c
                    .patterns
                    .iter()
                    .map(|p| (p.name.clone(), p.kind))
                    .collect(),
            })
            .collect();
        let midi = config.midi.as_ref().map(|m| {
            let notes = lanes
                .iter()
                .enumerate()
                .flat_map(|(lane, (_, c))| {
                    midi::note_mappings(lane, &c.patterns, c.midi.as_ref().unwrap_or(m))
                })
                .collect();
            (m.clone(), notes)
        });
        Self {
            lanes: lane_settings,
            midi,
            print,
            preview: config.preview.is_some(),
        }
    }
}

/// Messages to the output thread.
#[derive(Debug)]
pub enum OutputMessage {
    /// An event of the performer (lane) with this index.
    Event(usize, Event),
    /// New settings (reload): only the sinks whose settings changed are made again.
    Reconfigure(Box<OutputSettings>),
    /// Cut off every held sound and release every note (the input changed).
    CutOff,
    /// Cut off the held sounds and notes of one performer (its detector was replaced).
    CutOffLane(usize),
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

/// One performer's sinks.
struct Lane {
    /// The settings the sinks were made from, to reload by difference.
    settings: LaneSettings,
    osc: Option<OscSink>,
    bounce: Option<LiveBounce>,
    state_delay: f64,
    heartbeat: Option<Duration>,
    /// Seconds between two drawn bounce states; `None`: no states are drawn.
    state_period: Option<f64>,
    /// Continuous events whose begin was sent and whose end was not.
    open: Vec<Event>,
    /// Sounds sent (impulses, held sounds once).
    events: u64,
}

fn state_rate(s: &LaneSettings) -> Option<f64> {
    s.osc.as_ref().and_then(|o| o.bounce_state_rate)
}

/// The rate states are drawn at: OSC's, else the preview's; `None`: no states.
fn drawn_state_rate(s: &LaneSettings, preview: bool) -> Option<f64> {
    state_rate(s).or(preview.then_some(PREVIEW_STATE_RATE))
}

impl Lane {
    fn new(s: &LaneSettings, origin: SystemTime, preview: bool) -> Self {
        let mut lane = Self {
            settings: s.clone(),
            osc: s.osc.as_ref().map(|o| OscSink::new(o, origin)),
            bounce: None,
            state_delay: 0.0,
            heartbeat: None,
            state_period: None,
            open: Vec::with_capacity(16),
            events: 0,
        };
        lane.bounce = lane.new_bounce(preview);
        lane.derive_timing(preview);
        lane
    }

    fn new_bounce(&self, preview: bool) -> Option<LiveBounce> {
        let s = &self.settings;
        s.bounce.as_ref().map(|b| {
            LiveBounce::new(
                b,
                drawn_state_rate(s, preview).unwrap_or(PREVIEW_STATE_RATE),
            )
        })
    }

    fn derive_timing(&mut self, preview: bool) {
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
        self.state_period = drawn_state_rate(s, preview).map(|r| 1.0 / r);
    }

    /// Reload by difference: a new OSC target keeps the bounce solver and the held
    /// sounds; the counters of a sink that is replaced go into `report`.
    fn reconfigure(
        &mut self,
        new: &LaneSettings,
        preview: bool,
        report: &mut OutputReport,
        origin: SystemTime,
        changed: &mut Vec<&'static str>,
    ) {
        let old = std::mem::replace(&mut self.settings, new.clone());
        if new.osc != old.osc {
            if let Some(o) = &self.osc {
                add_osc(report, o.counters());
            }
            self.osc = new.osc.as_ref().map(|o| OscSink::new(o, origin));
            changed.push("osc");
        }
        if new.bounce != old.bounce
            || drawn_state_rate(new, preview) != drawn_state_rate(&old, preview)
        {
            if let Some(b) = &self.bounce {
                report.late_bounce_hits += b.late_hits();
            }
            self.bounce = self.new_bounce(preview);
            changed.push("bounce");
        }
        self.derive_timing(preview);
    }

    /// States are drawn when OSC asks for them (`bounce_state_rate`, which only an
    /// `[osc]` section sets) or the preview shows them.
    fn states_wanted(&self) -> bool {
        self.bounce.is_some() && self.state_period.is_some()
    }

    /// Draws the bounce states up to stream time `until` and sends them where they go.
    fn draw_states(&mut self, until: f64, lane: usize, preview: Option<&PreviewHub>) {
        // They go to OSC when it sets a `bounce_state_rate`.
        let osc_states = state_rate(&self.settings).is_some();
        let Lane { bounce, osc, .. } = self;
        let Some(b) = bounce.as_mut() else {
            return;
        };
        let preview = preview.filter(|p| p.watched());
        b.draw_until(until, |s| {
            if osc_states {
                if let Some(o) = osc.as_mut() {
                    o.send_bounce_state(&s);
                }
            }
            if let Some(p) = preview {
                p.publish("state", &state_json(lane, &s));
            }
        });
    }
}

struct Sinks {
    lanes: Vec<Lane>,
    /// The port all performers share; each lane's notes on its own channel.
    midi: Option<MidiSink>,
    midi_settings: Option<(MidiSettings, Vec<NoteMapping>)>,
    origin: SystemTime,
}

impl Sinks {
    fn new(s: &OutputSettings, origin: SystemTime) -> Self {
        Self {
            lanes: s
                .lanes
                .iter()
                .map(|l| Lane::new(l, origin, s.preview))
                .collect(),
            midi: s
                .midi
                .as_ref()
                .map(|(m, notes)| MidiSink::new(m.clone(), notes.clone())),
            midi_settings: s.midi.clone(),
            origin,
        }
    }

    /// Reload by difference: rebuilds only the sinks whose settings changed, so that a
    /// new OSC target keeps the MIDI port (and the connections a DAW made to it) and
    /// the held sounds, and new note mappings keep the port open. A different set of
    /// performers makes every lane again (their held sounds were cut off before).
    /// Returns what changed. The counters of a sink that is replaced go into `report`.
    fn reconfigure(
        &mut self,
        new: &OutputSettings,
        report: &mut OutputReport,
    ) -> Vec<&'static str> {
        let mut changed = Vec::new();
        let names = |l: &[LaneSettings]| l.iter().map(|l| l.name.clone()).collect::<Vec<_>>();
        let old_names: Vec<Option<String>> =
            self.lanes.iter().map(|l| l.settings.name.clone()).collect();
        if names(&new.lanes) == old_names {
            for (lane, s) in self.lanes.iter_mut().zip(&new.lanes) {
                lane.reconfigure(s, new.preview, report, self.origin, &mut changed);
            }
        } else {
            for lane in &self.lanes {
                collect_lane(lane, report);
            }
            self.lanes = new
                .lanes
                .iter()
                .map(|l| Lane::new(l, self.origin, new.preview))
                .collect();
            changed.push("performers");
        }
        match (&new.midi, self.midi.as_mut(), &self.midi_settings) {
            (Some((m, notes)), Some(sink), Some((old_m, old_notes)))
                if m.port == old_m.port && (m != old_m || notes != old_notes) =>
            {
                // The notes that are on were started under the old mapping.
                sink.update(m.clone(), notes.clone());
                changed.push("midi notes");
            }
            (Some((m, _)), Some(_), Some((old_m, _))) if m.port == old_m.port => {}
            _ if new.midi != self.midi_settings => {
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
        self.midi_settings = new.midi.clone();
        changed.sort_unstable();
        changed.dedup();
        changed
    }
}

/// The preview's `hello`: the performers and their patterns, and the wall-clock time of
/// stream time 0.
fn hello_json(s: &OutputSettings, origin: SystemTime) -> String {
    let performers: Vec<serde_json::Value> = s
        .lanes
        .iter()
        .map(|l| {
            let patterns: Vec<serde_json::Value> = l
                .patterns
                .iter()
                .map(|(name, kind)| serde_json::json!({ "name": name, "kind": kind }))
                .collect();
            serde_json::json!({
                "name": l.name,
                "patterns": patterns,
                "bounce": l.bounce.is_some(),
                "osc_prefix": l.osc.as_ref().map(|o| o.prefix.clone()),
            })
        })
        .collect();
    let origin = origin
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64());
    serde_json::json!({
        "performers": performers,
        "origin_unix_seconds": origin,
    })
    .to_string()
}

fn state_json(lane: usize, s: &BounceState) -> String {
    serde_json::json!({
        "performer": lane,
        "time": s.time,
        "height": s.height,
        "velocity": s.velocity,
    })
    .to_string()
}

fn hit_json(lane: usize, h: &LiveHit) -> String {
    serde_json::json!({
        "performer": lane,
        "event": h.event,
        "time": h.time,
        "launch_velocity": h.launch_velocity,
        "predicted_landing": h.predicted_landing,
        "apex": h.apex,
        "squash": h.squash,
    })
    .to_string()
}

/// The event record, with the index of its performer.
fn publish_sound(preview: Option<&PreviewHub>, lane: usize, e: &Event) {
    if let Some(p) = preview.filter(|p| p.watched()) {
        let record = print::PerformerEvent {
            performer: lane,
            event: e,
        };
        if let Ok(json) = serde_json::to_string(&record) {
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
        if sinks.lanes.iter().any(|l| l.heartbeat.is_some()) {
            wake = wake.min(next_heartbeat);
        }
        for lane in sinks.lanes.iter().filter(|l| l.states_wanted()) {
            let period = lane.state_period.unwrap_or(0.25).min(0.25);
            wake = wake.min(now + Duration::from_secs_f64(period));
        }
        if preview.is_some() {
            wake = wake.min(next_preview_status);
        }
        let message = rx.recv_timeout(wake.saturating_duration_since(now));
        match message {
            Ok(OutputMessage::Event(index, e)) => {
                let Some(lane) = sinks.lanes.get_mut(index) else {
                    continue;
                };
                let ends_an_open_sound = e.kind == PatternKind::Continuous
                    && e.end.is_some()
                    && lane.open.iter().any(|o| o.id == e.id);
                if !ends_an_open_sound {
                    report.events += 1;
                    lane.events += 1;
                }
                let begin_sent = match (e.kind, e.end) {
                    (PatternKind::Continuous, None) => {
                        lane.open.push(e.clone());
                        false
                    }
                    (PatternKind::Continuous, Some(_)) => {
                        let was = lane.open.iter().position(|o| o.id == e.id);
                        if let Some(i) = was {
                            lane.open.swap_remove(i);
                        }
                        was.is_some()
                    }
                    _ => false,
                };
                if let Some(o) = lane.osc.as_mut() {
                    o.send_event(&e, begin_sent);
                }
                if let Some(m) = sinks.midi.as_mut() {
                    m.play(index, &e, Instant::now());
                }
                printer.event(lane.settings.name.as_deref(), &e, begin_sent);
                publish_sound(preview, index, &e);
                if let Some(b) = lane.bounce.as_mut() {
                    let late = b.late_hits();
                    let hit = b.on_event(&e);
                    if b.late_hits() > late && late % 100 == 0 {
                        tracing::warn!(
                            late_hits = b.late_hits(),
                            delay = lane.state_delay,
                            "a hit was decided after the bounce states had passed it; raise [bounce] state_delay_seconds"
                        );
                    }
                    if let Some(hit) = hit {
                        if let Some(o) = lane.osc.as_mut() {
                            o.send_bounce_hit(&hit);
                        }
                        if let Some(p) = preview {
                            p.publish("hit", &hit_json(index, &hit));
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
                for lane in 0..sinks.lanes.len() {
                    cut_off(&mut sinks, lane, status.stream_seconds(), preview);
                }
                if let Some(m) = sinks.midi.as_mut() {
                    m.release_all();
                }
            }
            Ok(OutputMessage::CutOffLane(lane)) => {
                cut_off(&mut sinks, lane, status.stream_seconds(), preview);
            }
            Ok(OutputMessage::Stop) | Err(RecvTimeoutError::Disconnected) => {
                let end = status.stream_seconds();
                for index in 0..sinks.lanes.len() {
                    // The states the delay held back, up to the end of the stream.
                    let lane = &mut sinks.lanes[index];
                    if lane.states_wanted() {
                        lane.draw_states(end, index, preview);
                    }
                    cut_off(&mut sinks, index, end, preview);
                }
                if let Some(m) = sinks.midi.as_mut() {
                    m.release_all();
                }
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
        if now >= next_heartbeat {
            // Every lane's own period, which a reload may change: the shortest rules.
            if let Some(period) = sinks.lanes.iter().filter_map(|l| l.heartbeat).min() {
                next_heartbeat = now + period;
                for lane in &mut sinks.lanes {
                    if let (Some(o), Some(_)) = (lane.osc.as_mut(), lane.heartbeat) {
                        o.send_status(
                            status.stream_seconds(),
                            lane.events,
                            status.dropped_events(),
                            status.overrun_samples(),
                            status.level_db(),
                        );
                    }
                }
            }
        }
        for (index, lane) in sinks.lanes.iter_mut().enumerate() {
            if lane.states_wanted() {
                let until = status.stream_seconds() - lane.state_delay;
                lane.draw_states(until, index, preview);
            }
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

/// The counters of `/status`, and the others the daemon keeps, for the preview; the
/// events of each performer, and each one's input level.
fn status_json(status: &Status, report: &OutputReport, sinks: &Sinks, p: &PreviewHub) -> String {
    let late: u64 = report.late_bounce_hits
        + sinks
            .lanes
            .iter()
            .filter_map(|l| l.bounce.as_ref())
            .map(LiveBounce::late_hits)
            .sum::<u64>();
    let lanes: Vec<serde_json::Value> = sinks
        .lanes
        .iter()
        .enumerate()
        .map(
            |(i, l)| serde_json::json!({ "events": l.events, "level_db": status.lane_level_db(i) }),
        )
        .collect();
    serde_json::json!({
        "stream_seconds": status.stream_seconds(),
        "events": report.events,
        "dropped_events": status.dropped_events(),
        "overrun_samples": status.overrun_samples(),
        "level_db": status.level_db(),
        "bad_samples": status.bad_samples(),
        "clipped_samples": status.clipped_samples(),
        "xruns": status.xruns(),
        "late_bounce_hits": late,
        "preview_closed": p.closed_slow(),
        "performers": lanes,
    })
    .to_string()
}

/// Ends every open continuous event of performer `index` at stream time `at` and
/// releases its notes.
fn cut_off(sinks: &mut Sinks, index: usize, at: f64, preview: Option<&PreviewHub>) {
    let Some(lane) = sinks.lanes.get_mut(index) else {
        return;
    };
    for mut e in lane.open.drain(..) {
        tracing::info!(performer = lane.settings.name.as_deref().unwrap_or(""), pattern = %e.pattern, id = e.id, "held sound cut off");
        // Its end, sent as the `/end` of the begin that was sent.
        e.end = Some(at.max(e.time));
        if let Some(o) = lane.osc.as_mut() {
            o.send_event(&e, true);
        }
        publish_sound(preview, index, &e);
        if let Some(m) = sinks.midi.as_mut() {
            m.release_event(index, e.id);
        }
    }
    if let Some(m) = sinks.midi.as_mut() {
        m.release_lane(index);
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

fn collect_lane(lane: &Lane, report: &mut OutputReport) {
    if let Some(o) = &lane.osc {
        add_osc(report, o.counters());
    }
    if let Some(b) = &lane.bounce {
        report.late_bounce_hits += b.late_hits();
    }
}

fn collect(sinks: &Sinks, report: &mut OutputReport) {
    for lane in &sinks.lanes {
        collect_lane(lane, report);
    }
    if let Some(m) = &sinks.midi {
        add_midi(report, m.counters());
    }
}
