//! `onomato listen`, the daemon: capture (or replay) → ring → detector thread →
//! bounded channel → output thread, and the main thread that starts them, handles
//! signals (SIGHUP reloads a config that validates, SIGTERM/SIGINT stop cleanly) and
//! stops them.
//!
//! Threads: cpal's audio callback (or the replay thread) fills the ring; the detector
//! thread ([`DetectorStage`]) reads it and runs the one streaming [`Detector`]; the
//! output thread (`crate::output`) sends. The main thread only waits for signals and
//! control messages. [`Status`] is shared by all, through atomics.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::{Duration, SystemTime};

use anyhow::Context;
use rtrb::Consumer;

use crate::audio::ChannelSelect;
use crate::config::Config;
use crate::detect::{Detector, Event};
use crate::input;
use crate::output::preview::PreviewServer;
use crate::output::{self, OutputMessage, OutputReport, OutputSettings, PrintMode};
use crate::pattern::{self, Pattern};
pub use crate::status::Status;

/// One performer's detection: the channel of the ring's frames it hears and its
/// detector.
pub struct LaneDetector {
    pub detector: Detector,
    pub select: ChannelSelect,
}

struct Lane {
    detector: Detector,
    select: ChannelSelect,
    mono: Vec<f32>,
    events: Vec<Event>,
    /// The top of the bands its detector compares, as last logged.
    compared_top_hz: Option<f64>,
}

impl Lane {
    fn new(mut l: LaneDetector, block_frames: usize) -> Self {
        l.detector.report_begins(true);
        Self {
            compared_top_hz: l.detector.compared_top_hz(),
            detector: l.detector,
            select: l.select,
            mono: Vec::with_capacity(block_frames),
            events: Vec::with_capacity(256),
        }
    }
}

/// The detector thread's work: read what the ring holds, give each performer its
/// channel (or the mix), detect, hand the events over tagged with the performer. Every
/// buffer is made in [`DetectorStage::new`]; [`DetectorStage::poll`] allocates nothing
/// (a test checks it).
pub struct DetectorStage {
    lanes: Vec<Lane>,
    consumer: Consumer<f32>,
    /// Channels of each frame in the ring.
    channels: usize,
    block_frames: usize,
    interleaved: Vec<f32>,
    sender: SyncSender<OutputMessage>,
    /// Messages the output thread could not take yet, in order: a reconfiguration or
    /// cut-off waits here instead of blocking detection, and the events after it wait
    /// behind it (at most `BACKLOG` of them; more are dropped and counted).
    backlog: VecDeque<OutputMessage>,
    /// Bad and clipped samples counted by detectors that were replaced (reload, new
    /// input).
    bad_samples_before: u64,
    clipped_samples_before: u64,
    status: Arc<Status>,
}

/// Events that may wait behind a control message the output thread has not taken.
const BACKLOG: usize = 64;

fn peak_db(peak: f32) -> f32 {
    20.0 * peak.max(1e-6).log10()
}

impl DetectorStage {
    /// `lanes`: one per performer, in the order of [`Config::lanes`]; `channels`: of each
    /// frame in the ring.
    pub fn new(
        lanes: Vec<LaneDetector>,
        consumer: Consumer<f32>,
        channels: usize,
        block_frames: usize,
        sender: SyncSender<OutputMessage>,
        status: Arc<Status>,
    ) -> Self {
        assert!(!lanes.is_empty(), "at least one performer");
        let lanes: Vec<Lane> = lanes
            .into_iter()
            .map(|l| Lane::new(l, block_frames))
            .collect();
        status
            .input_rate
            .store(lanes[0].detector.input_rate(), Ordering::Relaxed);
        status
            .level_db_bits
            .store((-120.0f32).to_bits(), Ordering::Relaxed);
        let channels = channels.max(1);
        Self {
            lanes,
            consumer,
            channels,
            block_frames,
            interleaved: vec![0.0; block_frames * channels],
            sender,
            backlog: VecDeque::with_capacity(BACKLOG + 2),
            bad_samples_before: 0,
            clipped_samples_before: 0,
            status,
        }
    }

    /// Processes at most one block of what the ring holds; returns the frames read (0
    /// when the ring had less than a block, unless `drain` is set: then any remainder).
    pub fn poll(&mut self, drain: bool) -> usize {
        let channels = self.channels;
        let available = self.consumer.slots() / channels;
        let frames = available.min(self.block_frames);
        if frames == 0 || (frames < self.block_frames && !drain) {
            return 0;
        }
        let samples = frames * channels;
        let (first, _) = self
            .consumer
            .pop_partial_slice(&mut self.interleaved[..samples]);
        debug_assert_eq!(first.len(), samples);
        let mut loudest = 0.0f32;
        let mut bad = self.bad_samples_before;
        let mut clipped = self.clipped_samples_before;
        for (index, lane) in self.lanes.iter_mut().enumerate() {
            lane.mono.clear();
            let mut peak = 0.0f32;
            for frame in self.interleaved[..samples].chunks_exact(channels) {
                let x = match lane.select {
                    ChannelSelect::Index(i) if usize::from(i) < channels => frame[usize::from(i)],
                    _ => frame.iter().sum::<f32>() / channels as f32,
                };
                peak = peak.max(x.abs());
                lane.mono.push(x);
            }
            loudest = loudest.max(peak);
            if let Some(level) = self.status.lane_level_db_bits.get(index) {
                level.store(peak_db(peak).to_bits(), Ordering::Relaxed);
            }
            lane.detector.process(&lane.mono, &mut lane.events);
            let compared_top_hz = lane.detector.compared_top_hz();
            if compared_top_hz != lane.compared_top_hz {
                // Rare: when the input's loudest sounds first show a filter's edge.
                lane.compared_top_hz = compared_top_hz;
                log_compared_band(index, compared_top_hz);
            }
            bad += lane.detector.bad_samples();
            clipped += lane.detector.clipped_samples();
        }
        self.status
            .level_db_bits
            .store(peak_db(loudest).to_bits(), Ordering::Relaxed);
        self.status.bad_samples.store(bad, Ordering::Relaxed);
        self.status
            .clipped_samples
            .store(clipped, Ordering::Relaxed);
        let first = &self.lanes[0].detector;
        self.status.stream_samples.store(
            (first.stream_seconds() * f64::from(first.input_rate())).round() as u64,
            Ordering::Relaxed,
        );
        self.hand_over();
        frames
    }

    /// Hands the pending events to the output thread, after anything still waiting;
    /// what does not fit is counted. Never waits.
    fn hand_over(&mut self) {
        self.flush_backlog();
        for index in 0..self.lanes.len() {
            // Taken out and put back, capacity and all: nothing allocates.
            let mut events = std::mem::take(&mut self.lanes[index].events);
            for e in events.drain(..) {
                self.hand_over_event(index, e);
            }
            self.lanes[index].events = events;
        }
    }

    fn hand_over_event(&mut self, index: usize, e: Event) {
        if !self.backlog.is_empty() {
            if self.backlog.len() < BACKLOG {
                self.backlog.push_back(OutputMessage::Event(index, e));
            } else {
                self.status.dropped_events.fetch_add(1, Ordering::Relaxed);
            }
            return;
        }
        // Full or gone, the event is lost: counted.
        if self
            .sender
            .try_send(OutputMessage::Event(index, e))
            .is_err()
        {
            self.status.dropped_events.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Queues a control message for the output thread, after the events before it.
    /// Never waits; it is sent as soon as the output thread has room.
    pub fn send_control(&mut self, message: OutputMessage) {
        self.backlog.push_back(message);
        self.flush_backlog();
    }

    /// Sends what waits, in order, while the output thread takes it.
    fn flush_backlog(&mut self) {
        while let Some(message) = self.backlog.pop_front() {
            match self.sender.try_send(message) {
                Ok(()) => {}
                Err(TrySendError::Full(message)) => {
                    self.backlog.push_front(message);
                    return;
                }
                Err(TrySendError::Disconnected(_)) => {
                    self.backlog.clear();
                    return;
                }
            }
        }
    }

    /// At the end: waits for the output thread to take what is still waiting, `wait`
    /// at most (an output thread that is stuck cannot hold up the stop).
    fn drain_backlog(&mut self, wait: Duration) {
        let until = std::time::Instant::now() + wait;
        self.flush_backlog();
        while !self.backlog.is_empty() && std::time::Instant::now() < until {
            std::thread::sleep(Duration::from_millis(1));
            self.flush_backlog();
        }
        let lost = self
            .backlog
            .drain(..)
            .filter(|m| matches!(m, OutputMessage::Event(..)))
            .count();
        if lost > 0 {
            self.status
                .dropped_events
                .fetch_add(lost as u64, Ordering::Relaxed);
        }
    }

    /// The input ended: decide what is pending and hand it over.
    pub fn finish(&mut self) {
        while self.poll(true) > 0 {}
        for lane in &mut self.lanes {
            lane.detector.finish(&mut lane.events);
        }
        self.hand_over();
    }

    /// Swaps in new detectors (reload): `Some` for the performers whose detector
    /// changed, each continuing its stream's time and numbering, and their held sounds
    /// cut off; a different number of performers replaces them all (every one `Some`).
    pub fn replace_detectors(&mut self, new: Vec<Option<LaneDetector>>) {
        if new.len() == self.lanes.len() {
            for (index, replacement) in new.into_iter().enumerate() {
                if let Some(l) = replacement {
                    self.swap_lane(index, l);
                    // The new detector does not know the old one's held sounds: they end
                    // here, after the old detector's events, before the new one's.
                    self.send_control(OutputMessage::CutOffLane(index));
                }
            }
            return;
        }
        let old = std::mem::take(&mut self.lanes);
        for l in &old {
            self.bad_samples_before += l.detector.bad_samples();
            self.clipped_samples_before += l.detector.clipped_samples();
        }
        self.lanes = new
            .into_iter()
            .flatten()
            .map(|mut l| {
                l.detector.continue_after(&old[0].detector);
                Lane::new(l, self.block_frames)
            })
            .collect();
        self.send_control(OutputMessage::CutOff);
    }

    fn swap_lane(&mut self, index: usize, mut l: LaneDetector) {
        let old = &self.lanes[index];
        l.detector.continue_after(&old.detector);
        self.bad_samples_before += old.detector.bad_samples();
        self.clipped_samples_before += old.detector.clipped_samples();
        self.status
            .input_rate
            .store(l.detector.input_rate(), Ordering::Relaxed);
        self.lanes[index] = Lane::new(l, self.block_frames);
    }

    /// Reads a new ring from now on (the capture was opened again), with a detector per
    /// performer for its rate. Stream time counts the audio received: the outage is not
    /// in it.
    pub fn replace_input(
        &mut self,
        consumer: Consumer<f32>,
        channels: usize,
        detectors: Vec<LaneDetector>,
    ) {
        let channels = channels.max(1);
        self.consumer = consumer;
        self.channels = channels;
        self.interleaved = vec![0.0; self.block_frames * channels];
        for (index, l) in detectors.into_iter().enumerate().take(self.lanes.len()) {
            self.swap_lane(index, l);
        }
        self.send_control(OutputMessage::CutOff);
    }
}

/// Options of `listen` that are not in the config.
#[derive(Debug, Clone)]
pub struct ListenOptions {
    /// Replay this WAV file instead of capturing.
    pub input_file: Option<std::path::PathBuf>,
    /// Replay speed (1: real time).
    pub speed: f64,
    /// Replay the file this many times.
    pub repeat: u32,
    pub print: PrintMode,
}

/// What a `listen` run did.
#[derive(Debug, Clone, Copy)]
pub struct ListenReport {
    pub stream_seconds: f64,
    pub overrun_samples: u64,
    pub dropped_events: u64,
    pub output: OutputReport,
}

enum Control {
    Signal(i32),
    InputEnded,
    CaptureFault(input::StreamFault),
}

enum DetectorCommand {
    /// A reloaded configuration: a new detector for each performer whose patterns or
    /// settings changed, and the output settings (the output thread rebuilds what
    /// changed).
    Reload(Vec<Option<LaneDetector>>, Box<OutputSettings>),
    /// The capture was opened again: a new ring (its channels) and a detector per
    /// performer for its rate.
    NewInput(Consumer<f32>, usize, Vec<LaneDetector>),
}

/// Each performer's patterns, loaded (in the order of [`Config::lanes`]); an error
/// names the performer.
fn load_lane_patterns(config: &Config) -> anyhow::Result<Vec<Vec<Pattern>>> {
    config
        .lanes()
        .iter()
        .map(|(name, c)| {
            pattern::load_patterns(&c.patterns, &c.detector).with_context(|| match name {
                Some(n) => format!("performer '{n}'"),
                None => "patterns".to_string(),
            })
        })
        .collect()
}

/// Says which bands performer `lane`'s detector now compares, once the input has shown
/// that it carries fewer (or, after all, every one).
fn log_compared_band(lane: usize, top_hz: Option<f64>) {
    match top_hz {
        Some(top_hz) => tracing::info!(
            performer = lane,
            top_hz = top_hz.round(),
            "the input carries sound up to top_hz only (its loudest sounds fall off a filter's edge into noise): only the bands under it are compared"
        ),
        None => tracing::info!(
            performer = lane,
            "the input carries every band after all: every band is compared"
        ),
    }
}

/// One performer's detector at `rate` and the channel it hears; `lane`: its config
/// (see [`Config::lanes`]).
fn lane_detector(lane: &Config, patterns: &[Pattern], rate: u32) -> anyhow::Result<LaneDetector> {
    let detector = Detector::new(patterns.to_vec(), &lane.detector, rate)?;
    if let Some(top_hz) = detector.compared_top_hz() {
        tracing::info!(
            rate,
            top_hz = top_hz.round(),
            "the input or the takes carry less than the full band: only the bands under top_hz are compared"
        );
    }
    Ok(LaneDetector {
        detector,
        select: lane
            .detector
            .channel
            .map_or(ChannelSelect::Mix, ChannelSelect::Index),
    })
}

/// A detector per performer at `rate`, from the loaded patterns.
fn lane_detectors(
    config: &Config,
    patterns: &[Vec<Pattern>],
    rate: u32,
) -> anyhow::Result<Vec<LaneDetector>> {
    config
        .lanes()
        .iter()
        .zip(patterns)
        .map(|((_, c), p)| lane_detector(c, p, rate))
        .collect()
}

/// Every performer's channel is one the input has.
fn check_channels(config: &Config, channels: usize) -> anyhow::Result<()> {
    for (name, c) in config.lanes() {
        if let Some(ch) = c.detector.channel {
            if usize::from(ch) >= channels {
                let who = name.map_or("[detector] channel".to_string(), |n| {
                    format!("performer '{n}'")
                });
                anyhow::bail!(
                    "{who}: channel {ch} (counted from 0), but the input has {channels} channel{}",
                    if channels == 1 { "" } else { "s" }
                );
            }
        }
    }
    Ok(())
}

fn log_bad_samples(new: u64, total: u64) {
    tracing::warn!(
        new,
        total,
        "input samples that were not numbers (taken as 0) or beyond full scale (clamped) were replaced"
    );
}

fn log_clipped_samples(new: u64, total: u64) {
    tracing::warn!(
        new,
        total,
        "the input clips: samples reached full scale, and a clipped sound's spectrum is not its take's; lower the input gain"
    );
}

/// Replaced and clipped input samples are each logged at most this often.
const BAD_SAMPLES_LOG_EVERY: Duration = Duration::from_secs(60);

/// A running count of input samples (replaced, clipped) that `log` reports: what it
/// added since the last report, at most every `BAD_SAMPLES_LOG_EVERY`, and at exit.
struct SampleLog {
    log: fn(u64, u64),
    logged: u64,
    last: Option<std::time::Instant>,
}

impl SampleLog {
    fn new(log: fn(u64, u64)) -> Self {
        Self {
            log,
            logged: 0,
            last: None,
        }
    }

    /// Reports what `total` adds, when the last report is old enough or `at_exit`.
    fn report(&mut self, total: u64, at_exit: bool) {
        let due = at_exit
            || self
                .last
                .is_none_or(|t| t.elapsed() >= BAD_SAMPLES_LOG_EVERY);
        if total > self.logged && due {
            (self.log)(total - self.logged, total);
            self.logged = total;
            self.last = Some(std::time::Instant::now());
        }
    }
}

/// How long the capture may deliver nothing before it is opened again.
const STALL_SECONDS: f64 = 3.0;
/// Pause between two attempts to open a lost capture.
const REOPEN_EVERY: Duration = Duration::from_secs(2);

/// The microphone, watched: opened again when it fails or stalls.
struct Microphone {
    capture: Option<input::Capture>,
    control: mpsc::Sender<Control>,
    status: Arc<Status>,
    /// Frames captured at the last check, and when that count last moved. The capture
    /// callback counts them itself: a detector or output thread that falls behind does
    /// not make a healthy input look dead.
    last_position: u64,
    last_progress: std::time::Instant,
    next_attempt: std::time::Instant,
    failures: u64,
}

impl Microphone {
    fn open(
        &mut self,
        config: &Config,
    ) -> Result<(u32, usize, Consumer<f32>), input::CaptureError> {
        let tx = self.control.clone();
        let (c, consumer) = input::open_capture(&config.input, self.status.clone(), move |f| {
            let _ = tx.send(Control::CaptureFault(f));
        })?;
        tracing::info!(device = %c.device, rate = c.rate, channels = c.channels, "capturing");
        let (rate, channels) = (c.rate, usize::from(c.channels));
        self.capture = Some(c);
        self.last_progress = std::time::Instant::now();
        Ok((rate, channels, consumer))
    }

    /// Drops a capture that failed or stalled; returns whether it did.
    fn check(&mut self, fault: Option<&input::StreamFault>) -> bool {
        let now = std::time::Instant::now();
        let position = self.status.captured_frames();
        if position != self.last_position {
            self.last_position = position;
            self.last_progress = now;
        }
        let stalled = self.capture.is_some()
            && now.duration_since(self.last_progress).as_secs_f64() > STALL_SECONDS;
        let failed = fault.is_some_and(|f| f.fatal);
        if let Some(f) = fault {
            if f.fatal {
                tracing::error!("audio input lost: {}", f.message);
            } else {
                tracing::warn!("audio input: {}", f.message);
            }
        }
        if self.capture.is_some() && (stalled || failed) {
            if stalled {
                tracing::error!("audio input delivered nothing for {STALL_SECONDS} s");
            }
            if let Some(c) = self.capture.take() {
                release_capture(c);
            }
            self.next_attempt = now;
            return true;
        }
        false
    }

    /// Tries to open the capture again when it is lost and an attempt is due.
    fn reopen(&mut self, config: &Config) -> Option<(u32, usize, Consumer<f32>)> {
        let now = std::time::Instant::now();
        if self.capture.is_some() || now < self.next_attempt {
            return None;
        }
        self.next_attempt = now + REOPEN_EVERY;
        match self.open(config) {
            Ok(opened) => {
                tracing::info!("audio input open again");
                self.failures = 0;
                Some(opened)
            }
            Err(e) => {
                self.failures += 1;
                if self.failures == 1 || self.failures % 30 == 0 {
                    tracing::warn!(
                        attempts = self.failures,
                        "cannot open the audio input yet: {e}"
                    );
                }
                None
            }
        }
    }
}

/// Closes a capture without risking the caller: a stream whose sound server died can
/// hang in its backend when it is closed (ALSA's PulseAudio plugin does), so it is
/// closed on a thread of its own, waited for one second at most.
fn release_capture(capture: input::Capture) {
    let (done_tx, done_rx) = mpsc::channel::<()>();
    let spawned = std::thread::Builder::new()
        .name("onomato-close-input".into())
        .spawn(move || {
            drop(capture);
            let _ = done_tx.send(());
        });
    match spawned {
        Ok(_) => {
            if done_rx.recv_timeout(Duration::from_secs(1)).is_err() {
                tracing::warn!("the lost audio input does not close; leaving it behind");
            }
        }
        Err(e) => tracing::warn!("cannot close the audio input on its own thread: {e}"),
    }
}

/// Runs the daemon until SIGTERM/SIGINT, or until a replayed file ends. `load` reads
/// and validates the configuration (at start and on SIGHUP).
pub fn listen(
    load: &dyn Fn() -> anyhow::Result<Config>,
    options: &ListenOptions,
) -> anyhow::Result<ListenReport> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};

    let mut config = load()?;
    let mut running_patterns = load_lane_patterns(&config)?;
    let status = Arc::new(Status::default());
    let (control_tx, control_rx) = mpsc::channel::<Control>();

    // Signals first, so that a SIGTERM during start-up is not lost.
    let mut signals = signal_hook::iterator::Signals::new([SIGHUP, SIGINT, SIGTERM])
        .context("cannot install signal handlers")?;
    let signal_handle = signals.handle();
    {
        let tx = control_tx.clone();
        std::thread::Builder::new()
            .name("onomato-signals".into())
            .spawn(move || {
                for s in signals.forever() {
                    if tx.send(Control::Signal(s)).is_err() {
                        break;
                    }
                }
            })
            .context("cannot start the signal thread")?;
    }

    let stop = Arc::new(AtomicBool::new(false));
    let input_done = Arc::new(AtomicBool::new(false));
    let block_frames = config.input.buffer_frames as usize;

    // The source: a replayed file or the microphone.
    let mut microphone = None;
    let mut replay = None;
    let (mut rate, mut channels, consumer) = match &options.input_file {
        Some(path) => {
            let (r, consumer) = input::spawn_replay(
                path,
                block_frames,
                options.speed,
                options.repeat,
                stop.clone(),
                input_done.clone(),
            )?;
            let (rate, channels) = (r.rate, usize::from(r.channels));
            tracing::info!(file = %path.display(), rate, channels, speed = options.speed, "replaying");
            replay = Some(r);
            (rate, channels, consumer)
        }
        None => {
            let now = std::time::Instant::now();
            let mut mic = Microphone {
                capture: None,
                control: control_tx.clone(),
                status: status.clone(),
                last_position: 0,
                last_progress: now,
                next_attempt: now,
                failures: 0,
            };
            let opened = mic.open(&config)?;
            microphone = Some(mic);
            opened
        }
    };

    if let Err(e) = check_channels(&config, channels) {
        stop.store(true, Ordering::Release);
        return Err(e);
    }
    let detectors = lane_detectors(&config, &running_patterns, rate)?;
    let mut running_delays: Vec<f64> = detectors
        .iter()
        .map(|l| l.detector.decision_delay_bound())
        .collect();
    let (out_tx, out_rx) = mpsc::sync_channel::<OutputMessage>(output::OUTPUT_QUEUE);
    let origin = SystemTime::now();
    // Bound before anything runs, so that a port in use is an error at start.
    let preview = match &config.preview {
        Some(p) => Some(PreviewServer::start(p.address)?),
        None => None,
    };
    let output_thread = {
        let settings = OutputSettings::from_config(&config, &running_delays, options.print);
        let status = status.clone();
        let hub = preview.as_ref().map(PreviewServer::hub);
        std::thread::Builder::new()
            .name("onomato-output".into())
            .spawn(move || output::run(settings, out_rx, status, origin, hub))
            .context("cannot start the output thread")?
    };

    let (command_tx, command_rx) = mpsc::channel::<DetectorCommand>();
    let detector_thread = {
        let mut stage = DetectorStage::new(
            detectors,
            consumer,
            channels,
            block_frames,
            out_tx.clone(),
            status.clone(),
        );
        let stop = stop.clone();
        let input_done = input_done.clone();
        let control = control_tx.clone();
        // Poll at a quarter of a block's duration, within 1-5 ms.
        let nap = Duration::from_secs_f64(
            (block_frames as f64 / f64::from(rate) / 4.0).clamp(0.001, 0.005),
        );
        std::thread::Builder::new()
            .name("onomato-detector".into())
            .spawn(move || {
                detector_loop(&mut stage, &stop, &input_done, &command_rx, nap);
                if input_done.load(Ordering::Acquire) && !stop.load(Ordering::Acquire) {
                    let _ = control.send(Control::InputEnded);
                }
            })
            .context("cannot start the detector thread")?
    };
    drop(out_tx);
    drop(control_tx);

    tracing::info!(
        patterns = running_patterns.iter().map(Vec::len).sum::<usize>(),
        performers = config.performers.len(),
        rate,
        "listening"
    );
    let mut failure: Option<&str> = None;
    let mut bad_log = SampleLog::new(log_bad_samples);
    let mut clipped_log = SampleLog::new(log_clipped_samples);
    loop {
        let message = match control_rx.recv_timeout(Duration::from_secs(1)) {
            Ok(m) => Some(m),
            Err(mpsc::RecvTimeoutError::Timeout) => None,
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        };
        match message {
            Some(Control::Signal(SIGHUP)) => {
                tracing::info!("SIGHUP: reloading the configuration");
                match prepare_reload(
                    load,
                    &config,
                    &running_patterns,
                    &running_delays,
                    rate,
                    channels,
                    options.print,
                ) {
                    Ok(reload) => {
                        let new = reload.config;
                        if new.input != config.input && options.input_file.is_none() {
                            tracing::warn!("[input] changed: restart the daemon to use the new input settings; keeping the running capture");
                        }
                        if new.preview != config.preview {
                            tracing::warn!("[preview] changed: restart the daemon to serve the preview elsewhere; keeping the running one");
                        }
                        running_patterns = reload.patterns;
                        running_delays = reload.delays;
                        let _ = command_tx
                            .send(DetectorCommand::Reload(reload.detectors, reload.settings));
                        let changed = if reload.changed.is_empty() {
                            "nothing".to_string()
                        } else {
                            reload.changed.join(", ")
                        };
                        tracing::info!(
                            patterns = running_patterns.iter().map(Vec::len).sum::<usize>(),
                            %changed,
                            "configuration reloaded"
                        );
                        config = Config {
                            input: config.input.clone(),
                            preview: config.preview.clone(),
                            ..new
                        };
                    }
                    Err(e) => {
                        tracing::error!("reload refused, keeping the running configuration: {e:#}");
                    }
                }
            }
            Some(Control::Signal(s)) => {
                tracing::info!(signal = s, "stopping");
                break;
            }
            Some(Control::InputEnded) => {
                tracing::info!("input ended");
                break;
            }
            Some(Control::CaptureFault(fault)) => {
                if let Some(mic) = microphone.as_mut() {
                    mic.check(Some(&fault));
                }
            }
            None => {}
        }
        // A detector or output thread that ended on its own has failed (a bug): stop,
        // and exit with an error so that a service manager restarts the daemon.
        if !input_done.load(Ordering::Acquire)
            && (detector_thread.is_finished() || output_thread.is_finished())
        {
            failure = Some("the detector or output thread stopped unexpectedly");
            break;
        }
        bad_log.report(status.bad_samples(), false);
        clipped_log.report(status.clipped_samples(), false);
        if let Some(mic) = microphone.as_mut() {
            mic.check(None);
            if let Some((new_rate, new_channels, consumer)) = mic.reopen(&config) {
                match check_channels(&config, new_channels)
                    .and_then(|()| lane_detectors(&config, &running_patterns, new_rate))
                {
                    Ok(detectors) => {
                        (rate, channels) = (new_rate, new_channels);
                        let _ = command_tx
                            .send(DetectorCommand::NewInput(consumer, channels, detectors));
                    }
                    Err(e) => tracing::error!("cannot restart detection on the new input: {e:#}"),
                }
            }
        }
    }
    stop.store(true, Ordering::Release);
    let _ = detector_thread.join();
    bad_log.report(status.bad_samples(), true);
    clipped_log.report(status.clipped_samples(), true);
    drop(command_tx);
    // The detector thread sent Stop after its last event.
    let output = output_thread.join().unwrap_or_default();
    // The preview's streams end after the last event was published.
    drop(preview);
    if let Some(c) = microphone.and_then(|m| m.capture) {
        release_capture(c);
    }
    if let Some(r) = replay {
        match r.thread.join() {
            Ok(Err(e)) => tracing::error!("replay: {e}"),
            Err(_) => tracing::error!("the replay thread panicked"),
            Ok(Ok(())) => {}
        }
    }
    signal_handle.close();
    let report = ListenReport {
        stream_seconds: status.stream_seconds(),
        overrun_samples: status.overrun_samples(),
        dropped_events: status.dropped_events(),
        output,
    };
    tracing::info!(
        stream_seconds = report.stream_seconds,
        events = report.output.events,
        dropped_events = report.dropped_events,
        overrun_samples = report.overrun_samples,
        xruns = status.xruns(),
        osc_packets = report.output.osc.packets_sent,
        osc_errors = report.output.osc.send_errors,
        note_ons = report.output.midi.note_ons,
        note_offs = report.output.midi.note_offs,
        midi_ports_lost = report.output.midi.ports_lost,
        midi_server_xruns = report.output.midi.server_xruns,
        printed_lines_dropped = report.output.print_dropped,
        preview_streams_closed = report.output.preview_closed,
        bad_samples = status.bad_samples(),
        clipped_samples = status.clipped_samples(),
        "stopped"
    );
    if let Some(why) = failure {
        anyhow::bail!("{why}; see the log above");
    }
    Ok(report)
}

fn detector_loop(
    stage: &mut DetectorStage,
    stop: &AtomicBool,
    input_done: &AtomicBool,
    commands: &Receiver<DetectorCommand>,
    nap: Duration,
) {
    loop {
        if stop.load(Ordering::Acquire) {
            break;
        }
        match commands.try_recv() {
            Ok(DetectorCommand::Reload(detectors, settings)) => {
                stage.replace_detectors(detectors);
                stage.send_control(OutputMessage::Reconfigure(settings));
            }
            Ok(DetectorCommand::NewInput(consumer, channels, detectors)) => {
                stage.replace_input(consumer, channels, detectors);
            }
            Err(_) => {}
        }
        if stage.poll(false) > 0 {
            continue;
        }
        if input_done.load(Ordering::Acquire) {
            stage.finish();
            break;
        }
        // The output thread may have made room for what waits.
        stage.flush_backlog();
        std::thread::sleep(nap);
    }
    stage.send_control(OutputMessage::Stop);
    stage.drain_backlog(STOP_WAIT);
}

/// How long the stop waits for the output thread to take the last messages.
const STOP_WAIT: Duration = Duration::from_secs(2);

/// A validated configuration to reload: what changed, and what to run it with.
struct Reload {
    config: Config,
    /// Each performer's patterns (their takes' sound included) and decision delay.
    patterns: Vec<Vec<Pattern>>,
    delays: Vec<f64>,
    /// A new detector for each performer whose patterns or detector settings changed
    /// (every one, when the performers themselves changed).
    detectors: Vec<Option<LaneDetector>>,
    settings: Box<OutputSettings>,
    changed: Vec<&'static str>,
}

/// Loads and validates the configuration again and compares it with the running one:
/// only the parts that differ are rebuilt.
fn prepare_reload(
    load: &dyn Fn() -> anyhow::Result<Config>,
    running: &Config,
    running_patterns: &[Vec<Pattern>],
    running_delays: &[f64],
    rate: u32,
    channels: usize,
    print: PrintMode,
) -> anyhow::Result<Reload> {
    let config = load()?;
    check_channels(&config, channels)?;
    let patterns = load_lane_patterns(&config)?;
    let lanes = config.lanes();
    let running_lanes = running.lanes();
    let same_performers = lanes
        .iter()
        .map(|l| &l.0)
        .eq(running_lanes.iter().map(|l| &l.0));
    let mut changed = Vec::new();
    let mut detectors = Vec::with_capacity(lanes.len());
    let mut delays = Vec::with_capacity(lanes.len());
    for (i, ((_, c), p)) in lanes.iter().zip(&patterns).enumerate() {
        let unchanged = same_performers
            && running_patterns.get(i) == Some(p)
            && running_lanes[i].1.detector == c.detector;
        if unchanged {
            detectors.push(None);
            delays.push(running_delays[i]);
        } else {
            let l = lane_detector(c, p, rate)?;
            delays.push(l.detector.decision_delay_bound());
            detectors.push(Some(l));
        }
    }
    if !same_performers {
        changed.push("performers");
    } else if detectors.iter().any(Option::is_some) {
        changed.push("detector");
    }
    let settings = OutputSettings::from_config(&config, &delays, print);
    let running_settings = OutputSettings::from_config(running, running_delays, print);
    if settings
        .lanes
        .iter()
        .map(|l| &l.osc)
        .ne(running_settings.lanes.iter().map(|l| &l.osc))
    {
        changed.push("osc");
    }
    if settings.midi != running_settings.midi {
        changed.push("midi");
    }
    if settings
        .lanes
        .iter()
        .map(|l| &l.bounce)
        .ne(running_settings.lanes.iter().map(|l| &l.bounce))
    {
        changed.push("bounce");
    }
    Ok(Reload {
        config,
        patterns,
        delays,
        detectors,
        settings: Box::new(settings),
        changed,
    })
}
