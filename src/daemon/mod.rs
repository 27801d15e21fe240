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

/// How channels of the ring's frames become the detector's mono input.
#[derive(Debug, Clone, Copy)]
pub struct FrameLayout {
    pub channels: usize,
    pub select: ChannelSelect,
}

/// The detector thread's work: read what the ring holds, mix it down, detect, hand the
/// events over. Every buffer is made in [`DetectorStage::new`]; [`DetectorStage::poll`]
/// allocates nothing (a test checks it).
pub struct DetectorStage {
    detector: Detector,
    consumer: Consumer<f32>,
    layout: FrameLayout,
    block_frames: usize,
    interleaved: Vec<f32>,
    mono: Vec<f32>,
    events: Vec<Event>,
    sender: SyncSender<OutputMessage>,
    /// Messages the output thread could not take yet, in order: a reconfiguration or
    /// cut-off waits here instead of blocking detection, and the events after it wait
    /// behind it (at most `BACKLOG` of them; more are dropped and counted).
    backlog: VecDeque<OutputMessage>,
    /// Bad samples counted by detectors that were replaced (reload, new input).
    bad_samples_before: u64,
    status: Arc<Status>,
}

/// Events that may wait behind a control message the output thread has not taken.
const BACKLOG: usize = 64;

impl DetectorStage {
    pub fn new(
        mut detector: Detector,
        consumer: Consumer<f32>,
        layout: FrameLayout,
        block_frames: usize,
        sender: SyncSender<OutputMessage>,
        status: Arc<Status>,
    ) -> Self {
        detector.report_begins(true);
        status
            .input_rate
            .store(detector.input_rate(), Ordering::Relaxed);
        status
            .level_db_bits
            .store((-120.0f32).to_bits(), Ordering::Relaxed);
        let channels = layout.channels.max(1);
        Self {
            detector,
            consumer,
            layout: FrameLayout { channels, ..layout },
            block_frames,
            interleaved: vec![0.0; block_frames * channels],
            mono: Vec::with_capacity(block_frames),
            events: Vec::with_capacity(256),
            sender,
            backlog: VecDeque::with_capacity(BACKLOG + 2),
            bad_samples_before: 0,
            status,
        }
    }

    /// Processes at most one block of what the ring holds; returns the frames read (0
    /// when the ring had less than a block, unless `drain` is set: then any remainder).
    pub fn poll(&mut self, drain: bool) -> usize {
        let channels = self.layout.channels;
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
        self.mono.clear();
        let mut peak = 0.0f32;
        for frame in self.interleaved[..samples].chunks_exact(channels) {
            let x = match self.layout.select {
                ChannelSelect::Index(i) if usize::from(i) < channels => frame[usize::from(i)],
                _ => frame.iter().sum::<f32>() / channels as f32,
            };
            peak = peak.max(x.abs());
            self.mono.push(x);
        }
        let db = 20.0 * peak.max(1e-6).log10();
        self.status
            .level_db_bits
            .store(db.to_bits(), Ordering::Relaxed);
        self.detector.process(&self.mono, &mut self.events);
        self.status.bad_samples.store(
            self.bad_samples_before + self.detector.bad_samples(),
            Ordering::Relaxed,
        );
        self.status.stream_samples.store(
            (self.detector.stream_seconds() * f64::from(self.detector.input_rate())).round() as u64,
            Ordering::Relaxed,
        );
        self.hand_over();
        frames
    }

    /// Hands the pending events to the output thread, after anything still waiting;
    /// what does not fit is counted. Never waits.
    fn hand_over(&mut self) {
        self.flush_backlog();
        for e in self.events.drain(..) {
            if !self.backlog.is_empty() {
                if self.backlog.len() < BACKLOG {
                    self.backlog.push_back(OutputMessage::Event(e));
                } else {
                    self.status.dropped_events.fetch_add(1, Ordering::Relaxed);
                }
                continue;
            }
            // Full or gone, the event is lost: counted.
            if self.sender.try_send(OutputMessage::Event(e)).is_err() {
                self.status.dropped_events.fetch_add(1, Ordering::Relaxed);
            }
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
            .filter(|m| matches!(m, OutputMessage::Event(_)))
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
        self.detector.finish(&mut self.events);
        self.hand_over();
    }

    /// Swaps in a new detector (reload): it continues the stream's time and numbering.
    pub fn replace_detector(&mut self, mut detector: Detector) {
        detector.report_begins(true);
        detector.continue_after(&self.detector);
        self.bad_samples_before += self.detector.bad_samples();
        self.status
            .input_rate
            .store(detector.input_rate(), Ordering::Relaxed);
        self.detector = detector;
    }

    /// Reads a new ring from now on (the capture was opened again), with a detector
    /// for its rate. Stream time counts the audio received: the outage is not in it.
    pub fn replace_input(
        &mut self,
        consumer: Consumer<f32>,
        layout: FrameLayout,
        detector: Detector,
    ) {
        let channels = layout.channels.max(1);
        self.consumer = consumer;
        self.layout = FrameLayout { channels, ..layout };
        self.interleaved = vec![0.0; self.block_frames * channels];
        self.replace_detector(detector);
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
    /// A reloaded configuration: a new detector when its patterns or settings changed,
    /// and the output settings (the output thread rebuilds what changed).
    Reload(Option<Box<Detector>>, Box<OutputSettings>),
    /// The capture was opened again: a new ring (and layout) and a detector for its rate.
    NewInput(Consumer<f32>, FrameLayout, Box<Detector>),
}

fn log_bad_samples(new: u64, total: u64) {
    tracing::warn!(
        new,
        total,
        "input samples that were not numbers (taken as 0) or beyond full scale (clamped) were replaced"
    );
}

/// Replaced input samples are logged at most this often.
const BAD_SAMPLES_LOG_EVERY: Duration = Duration::from_secs(60);

/// How long the capture may deliver nothing before it is opened again.
const STALL_SECONDS: f64 = 3.0;
/// Pause between two attempts to open a lost capture.
const REOPEN_EVERY: Duration = Duration::from_secs(2);

/// The microphone, watched: opened again when it fails or stalls.
struct Microphone {
    capture: Option<input::Capture>,
    select: ChannelSelect,
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
    ) -> Result<(u32, FrameLayout, Consumer<f32>), input::CaptureError> {
        let tx = self.control.clone();
        let (c, consumer) = input::open_capture(&config.input, self.status.clone(), move |f| {
            let _ = tx.send(Control::CaptureFault(f));
        })?;
        tracing::info!(device = %c.device, rate = c.rate, channels = c.channels, "capturing");
        let layout = FrameLayout {
            channels: usize::from(c.channels),
            select: self.select,
        };
        let rate = c.rate;
        self.capture = Some(c);
        self.last_progress = std::time::Instant::now();
        Ok((rate, layout, consumer))
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
    fn reopen(&mut self, config: &Config) -> Option<(u32, FrameLayout, Consumer<f32>)> {
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
    let patterns = pattern::load_patterns(&config.patterns, &config.detector)?;
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
    let select = config
        .detector
        .channel
        .map_or(ChannelSelect::Mix, ChannelSelect::Index);
    let block_frames = config.input.buffer_frames as usize;

    // The source: a replayed file or the microphone.
    let mut microphone = None;
    let mut replay = None;
    let (mut rate, layout, consumer) = match &options.input_file {
        Some(path) => {
            let (r, consumer) = input::spawn_replay(
                path,
                select,
                block_frames,
                options.speed,
                options.repeat,
                stop.clone(),
                input_done.clone(),
            )?;
            let rate = r.rate;
            tracing::info!(file = %path.display(), rate, speed = options.speed, "replaying");
            replay = Some(r);
            let layout = FrameLayout {
                channels: 1,
                select: ChannelSelect::Mix,
            };
            (rate, layout, consumer)
        }
        None => {
            let now = std::time::Instant::now();
            let mut mic = Microphone {
                capture: None,
                select,
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

    let mut running_patterns = patterns.clone();
    let detector = Detector::new(patterns, &config.detector, rate)?;
    let mut running_delay = detector.decision_delay_bound();
    let (out_tx, out_rx) = mpsc::sync_channel::<OutputMessage>(output::OUTPUT_QUEUE);
    let origin = SystemTime::now();
    // Bound before anything runs, so that a port in use is an error at start.
    let preview = match &config.preview {
        Some(p) => Some(PreviewServer::start(p.address)?),
        None => None,
    };
    let output_thread = {
        let settings = OutputSettings::from_config(&config, running_delay, options.print);
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
            detector,
            consumer,
            layout,
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

    tracing::info!(patterns = config.patterns.len(), rate, "listening");
    let mut failure: Option<&str> = None;
    let mut bad_logged = 0u64;
    let mut last_bad_log = std::time::Instant::now() - BAD_SAMPLES_LOG_EVERY;
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
                    running_delay,
                    rate,
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
                        let detector = reload.detector.map(|(detector, patterns)| {
                            running_patterns = patterns;
                            running_delay = detector.decision_delay_bound();
                            detector
                        });
                        let _ = command_tx.send(DetectorCommand::Reload(detector, reload.settings));
                        let changed = if reload.changed.is_empty() {
                            "nothing".to_string()
                        } else {
                            reload.changed.join(", ")
                        };
                        tracing::info!(patterns = new.patterns.len(), %changed, "configuration reloaded");
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
        let bad = status.bad_samples();
        if bad > bad_logged && last_bad_log.elapsed() >= BAD_SAMPLES_LOG_EVERY {
            log_bad_samples(bad - bad_logged, bad);
            bad_logged = bad;
            last_bad_log = std::time::Instant::now();
        }
        if let Some(mic) = microphone.as_mut() {
            mic.check(None);
            if let Some((new_rate, layout, consumer)) = mic.reopen(&config) {
                match pattern::load_patterns(&config.patterns, &config.detector)
                    .map_err(anyhow::Error::from)
                    .and_then(|p| Ok(Detector::new(p, &config.detector, new_rate)?))
                {
                    Ok(detector) => {
                        rate = new_rate;
                        let _ = command_tx.send(DetectorCommand::NewInput(
                            consumer,
                            layout,
                            Box::new(detector),
                        ));
                    }
                    Err(e) => tracing::error!("cannot restart detection on the new input: {e:#}"),
                }
            }
        }
    }
    stop.store(true, Ordering::Release);
    let _ = detector_thread.join();
    if status.bad_samples() > bad_logged {
        log_bad_samples(status.bad_samples() - bad_logged, status.bad_samples());
    }
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
            Ok(DetectorCommand::Reload(detector, settings)) => {
                if let Some(detector) = detector {
                    stage.replace_detector(*detector);
                    // The new detector does not know the old one's held sounds: they
                    // end here, after the old detector's events, before the new one's.
                    stage.send_control(OutputMessage::CutOff);
                }
                stage.send_control(OutputMessage::Reconfigure(settings));
            }
            Ok(DetectorCommand::NewInput(consumer, layout, detector)) => {
                stage.replace_input(consumer, layout, *detector);
                stage.send_control(OutputMessage::CutOff);
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
    /// A new detector and its patterns, when the patterns (their takes' sound
    /// included) or the detector's settings changed.
    detector: Option<(Box<Detector>, Vec<Pattern>)>,
    settings: Box<OutputSettings>,
    changed: Vec<&'static str>,
}

/// Loads and validates the configuration again and compares it with the running one:
/// only the parts that differ are rebuilt.
fn prepare_reload(
    load: &dyn Fn() -> anyhow::Result<Config>,
    running: &Config,
    running_patterns: &[Pattern],
    running_delay: f64,
    rate: u32,
    print: PrintMode,
) -> anyhow::Result<Reload> {
    let config = load()?;
    let patterns = pattern::load_patterns(&config.patterns, &config.detector)?;
    let mut changed = Vec::new();
    let detector = if patterns != running_patterns || config.detector != running.detector {
        changed.push("detector");
        Some(Detector::new(patterns.clone(), &config.detector, rate)?)
    } else {
        None
    };
    let delay = detector
        .as_ref()
        .map_or(running_delay, Detector::decision_delay_bound);
    let settings = OutputSettings::from_config(&config, delay, print);
    let running_settings = OutputSettings::from_config(running, running_delay, print);
    if settings.osc != running_settings.osc {
        changed.push("osc");
    }
    if settings.midi != running_settings.midi {
        changed.push("midi");
    }
    if settings.bounce != running_settings.bounce {
        changed.push("bounce");
    }
    Ok(Reload {
        config,
        detector: detector.map(|d| (Box::new(d), patterns)),
        settings: Box::new(settings),
        changed,
    })
}
