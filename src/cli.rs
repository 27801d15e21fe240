//! The command line (clap): raw arguments are parsed here and turned into a validated
//! [`Config`] in one place, then handed to the commands. Errors are printed with their
//! whole chain; the exit code says what happened.
//!
//! Runs on the main thread.

// The arguments' doc comments are their `--help` texts, which name config tables as
// the config file writes them (`[render]`, `[[performer]]`), not as links.
#![allow(rustdoc::broken_intra_doc_links)]

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};

use crate::analyze;
use crate::config::{self, Config, Method, MidiPortChoice, MidiSettings, OscSettings};
use crate::daemon::{self, ListenOptions};
use crate::eval;
use crate::output::PrintMode;
use crate::pattern;

/// Turns short vocal sounds ("tick", "pop", "chhh") into timed events for animation and
/// game engines.
#[derive(Debug, Parser)]
#[command(name = "onomato", version)]
pub struct Cli {
    /// More log output on stderr (-v info, -vv debug). RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Detect the patterns in a recording and print the events on stdout.
    Analyze(AnalyzeArgs),
    /// Validate a configuration and load its pattern files; exit 1 if anything is wrong.
    Check(PatternSource),
    /// Analyse a recording and score the events against an annotation CSV.
    Eval(EvalArgs),
    /// The daemon: listen to the microphone (or replay a file) and send each detected
    /// sound as OSC and MIDI as it happens. SIGHUP reloads the config, SIGTERM stops.
    Listen(ListenArgs),
    /// List audio inputs and MIDI output ports.
    Devices,
    /// Enrol a pattern: record takes of it (from the microphone, or a file), cut each to
    /// the sound, save them beside the config and add the pattern to the config. With
    /// --background: record what must never fire (you talking) instead.
    Record(RecordArgs),
    /// Draw an animation whose timing is a recording's (a ball bouncing on every hit,
    /// rain, darts, a laser duel, or a timeline of the events), as an MP4 video with the
    /// sound, or one HTML page that plays it.
    Render(RenderArgs),
}

#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// The soundtrack (WAV): analysed for its events, and played with the picture.
    pub recording: PathBuf,
    /// Another soundtrack (WAV) driving its own actor, aligned with the first at its
    /// start; repeat for more. The config's [[render.track]] sections say which
    /// patterns each soundtrack is searched for.
    #[arg(long = "track", value_name = "FILE.wav")]
    pub tracks: Vec<PathBuf>,
    #[command(flatten)]
    pub source: PatternSource,
    /// Take the events from this file (the JSON `analyze` writes, perhaps edited by
    /// hand) instead of analysing the recording; with --track, once per soundtrack, in
    /// the same order.
    #[arg(long, value_name = "FILE.json")]
    pub events: Vec<PathBuf>,
    /// What to draw [default: the config's [render] scene, or ball].
    #[arg(long, value_enum)]
    pub scene: Option<crate::render::Scene>,
    /// Where to write the animation: an .mp4 video (H.264 and AAC, by ffmpeg) or an
    /// .html page (self-contained: sound and script inside, plays offline in any
    /// browser).
    #[arg(long, short = 'o', value_name = "OUT.mp4|OUT.html")]
    pub output: PathBuf,
    /// Frames per second.
    #[arg(long, default_value_t = 60)]
    pub fps: u32,
    /// Frame size in pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_name = "WxH")]
    pub size: String,
}

#[derive(Debug, clap::Args)]
pub struct RecordArgs {
    /// The pattern's name (letters, digits, '_' or '-').
    pub name: String,
    /// How many takes to record.
    #[arg(long, default_value_t = 3)]
    pub takes: usize,
    /// The config to add the pattern to; the takes are saved beside it.
    #[arg(long, short = 'c', value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// A held sound ("chhh", "hooo") rather than an impulse.
    #[arg(long)]
    pub continuous: bool,
    /// Take the takes from this WAV file (its sounds, separated by silence) instead of
    /// the microphone.
    #[arg(long, value_name = "FILE.wav")]
    pub input: Option<PathBuf>,
    /// Audio input device: its name or part of it (overrides the config).
    #[arg(long, value_name = "NAME")]
    pub device: Option<String>,
    /// Where to save the takes without --config.
    #[arg(long, default_value = ".", value_name = "DIR")]
    pub dir: PathBuf,
    /// Enrol for this [[performer]] of the config: its channel is recorded and the
    /// pattern goes into its [[performer.pattern]] sections.
    #[arg(long, value_name = "NAME", requires = "config")]
    pub performer: Option<String>,
    /// Record what must never fire instead of a pattern: you talking as you do between
    /// your sounds (spectral method). Saved as NAME.wav and added to the config's
    /// `background` list; from --input, the whole file.
    #[arg(long, conflicts_with_all = ["continuous", "takes"])]
    pub background: bool,
    /// With --background: how long to record from the microphone, seconds.
    #[arg(
        long,
        default_value_t = 60.0,
        value_name = "SECONDS",
        requires = "background"
    )]
    pub seconds: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LogFormat {
    Human,
    Json,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PrintChoice {
    /// Text when stdout is a terminal, nothing otherwise.
    Auto,
    Text,
    Json,
    None,
}

#[derive(Debug, clap::Args)]
pub struct ListenArgs {
    #[command(flatten)]
    pub source: PatternSource,
    /// Replay this WAV file in real time instead of capturing the microphone.
    #[arg(long, value_name = "FILE.wav")]
    pub input: Option<PathBuf>,
    /// Replay speed: 1 is real time, 10 ten times faster (with --input).
    #[arg(long, default_value_t = 1.0, requires = "input")]
    pub speed: f64,
    /// Replay the file this many times (with --input).
    #[arg(long, default_value_t = 1, requires = "input")]
    pub repeat: u32,
    /// Audio input device: its name or part of it (overrides the config).
    #[arg(long, value_name = "NAME")]
    pub device: Option<String>,
    /// Send OSC to HOST:PORT (repeatable; adds to the config's targets).
    #[arg(long, value_name = "HOST:PORT")]
    pub osc: Vec<String>,
    /// Send MIDI to the first output port whose name contains PORT (overrides the config).
    #[arg(long, value_name = "PORT", conflicts_with = "midi_virtual")]
    pub midi: Option<String>,
    /// Send MIDI through a virtual port of this name (overrides the config).
    #[arg(long, value_name = "NAME")]
    pub midi_virtual: Option<String>,
    /// Run the live bounce solver (with the config's bounce settings, or defaults).
    #[arg(long)]
    pub bounce: bool,
    /// Serve a live preview page (the bounce ball, each sound as it fires, the input
    /// level and counters) at http://ADDR/ (default 127.0.0.1:8765; overrides the
    /// config's [preview]).
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = config::DEFAULT_PREVIEW_ADDRESS)]
    pub preview: Option<String>,
    /// How each event is printed on stdout as it is sent.
    #[arg(long, value_enum, default_value_t = PrintChoice::Auto)]
    pub print: PrintChoice,
    /// Log format on stderr.
    #[arg(long, value_enum, default_value_t = LogFormat::Human)]
    pub log_format: LogFormat,
}

impl ListenArgs {
    /// The validated configuration: the file and patterns, then the overrides.
    pub fn to_config(&self) -> anyhow::Result<Config> {
        let mut config = self.source.to_daemon_config()?;
        if let Some(d) = &self.device {
            if d.trim().is_empty() {
                anyhow::bail!("--device is empty; give a device name (see `onomato devices`)");
            }
            config.input.device = Some(d.clone());
        }
        if !self.osc.is_empty() {
            for t in &self.osc {
                config::check_osc_target(t).map_err(|m| anyhow::anyhow!("--osc: {m}"))?;
            }
            match config.osc.as_mut() {
                Some(o) => o.targets.extend(self.osc.iter().cloned()),
                None => config.osc = Some(OscSettings::with_targets(self.osc.clone())),
            }
        }
        let port = match (&self.midi, &self.midi_virtual) {
            (Some(p), _) => Some(MidiPortChoice::Connect(p.clone())),
            (None, Some(v)) => Some(MidiPortChoice::Virtual(v.clone())),
            (None, None) => None,
        };
        if let Some(port) = port {
            match config.midi.as_mut() {
                Some(m) => m.port = port,
                None => config.midi = Some(MidiSettings::with_port(port)),
            }
        }
        if self.bounce && config.bounce.is_none() {
            config.bounce = Some(config.bounce_or_default());
        }
        if let Some(address) = &self.preview {
            let address = config::parse_preview_address(address)
                .map_err(|m| anyhow::anyhow!("--preview: {m}"))?;
            config.preview = Some(config::PreviewSettings { address });
        }
        Ok(config)
    }
}

/// Where the patterns come from: a config file, `--pattern` arguments, or both.
#[derive(Debug, clap::Args)]
pub struct PatternSource {
    /// TOML configuration (see config/onomato.toml).
    #[arg(long, short = 'c', value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// A pattern to detect, repeatable; the same NAME again adds a take.
    #[arg(
        long = "pattern",
        short = 'p',
        value_name = "NAME=FILE.wav[:continuous]"
    )]
    pub patterns: Vec<String>,
    /// Matching method (overrides the config).
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// Match threshold for every pattern without its own, 0 to 1 (overrides the config).
    #[arg(long)]
    pub threshold: Option<f64>,
    /// Use this channel of multi-channel files (from 0) instead of mixing them.
    #[arg(long)]
    pub channel: Option<u16>,
    /// Spectral method: ignore onsets this soon after a sound that is none of the
    /// patterns, such as speech; 0 turns the guard off (overrides the config).
    #[arg(long, value_name = "SECONDS")]
    pub speech_guard: Option<f64>,
    /// Spectral method: a recording of sounds that must never fire (you talking, the
    /// room), repeatable; added to the config's `background` list.
    #[arg(long, value_name = "FILE.wav")]
    pub background: Vec<PathBuf>,
    /// With a config of [[performer]]s: this performer's patterns and channel alone
    /// (`listen` runs every performer without it).
    #[arg(long, value_name = "NAME")]
    pub performer: Option<String>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    Json,
    Csv,
}

#[derive(Debug, clap::Args)]
pub struct AnalyzeArgs {
    /// The recording to analyse (WAV).
    pub recording: PathBuf,
    #[command(flatten)]
    pub source: PatternSource,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Json)]
    pub format: Format,
    /// Add the bounce solver's contacts ("bounce" array, JSON only).
    #[arg(long)]
    pub bounce: bool,
    /// Gravity for --bounce, m/s² (overrides the config).
    #[arg(long)]
    pub gravity: Option<f64>,
    /// Also draw the waveform, each pattern's match score and the events as an SVG.
    #[arg(long, value_name = "OUT.svg")]
    pub plot: Option<PathBuf>,
    /// Spectral method: list every onset the detector considered, with the two patterns
    /// it resembled most, their scores, how much of its sound the choice heard, and what
    /// became of it and which stage decided (fired, quiet_before, speech_guard,
    /// continuation, below_threshold, background, held_continues, min_strength,
    /// same_onset; and a later record for an onset that fired later: copy, fell_away): a
    /// table on stderr, and an "onsets" array in the JSON output.
    #[arg(long)]
    pub explain: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ScoreFormat {
    Text,
    Json,
}

#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// The recording to analyse (WAV).
    pub recording: PathBuf,
    /// Annotation CSV with a header: onset_s,label and optionally end_s (other columns are ignored).
    #[arg(long, value_name = "CSV")]
    pub truth: PathBuf,
    #[command(flatten)]
    pub source: PatternSource,
    /// A detection is correct when its label matches and its onset is this close, seconds.
    #[arg(long, default_value_t = 0.05)]
    pub tolerance: f64,
    /// Output format.
    #[arg(long, value_enum, default_value_t = ScoreFormat::Text)]
    pub format: ScoreFormat,
}

impl PatternSource {
    /// The validated configuration these arguments describe, for one performer: a
    /// config of `[[performer]]`s needs `--performer`.
    pub fn to_config(&self) -> anyhow::Result<Config> {
        self.load(false)
    }

    /// As [`PatternSource::to_config`], keeping every performer unless `--performer`
    /// names one (the daemon).
    pub fn to_daemon_config(&self) -> anyhow::Result<Config> {
        self.load(true)
    }

    fn load(&self, every_performer: bool) -> anyhow::Result<Config> {
        let mut config = match &self.config {
            Some(path) => Config::load(path)?,
            None => Config::default(),
        };
        let from = || {
            self.config
                .as_ref()
                .map_or("the command line".to_string(), |p| {
                    format!("config '{}'", p.display())
                })
        };
        if self.performer.is_some() || !(every_performer || config.performers.is_empty()) {
            config = config
                .select_performer(self.performer.as_deref())
                .map_err(|m| anyhow::anyhow!("{}: {m}", from()))?;
        } else if !config.performers.is_empty() {
            if !self.patterns.is_empty() {
                anyhow::bail!(
                    "--pattern cannot be added to every performer of {}; name one with --performer",
                    from()
                );
            }
            if self.channel.is_some() {
                anyhow::bail!("--channel: each performer of {} has its own channel; name one with --performer", from());
            }
        }
        config.add_cli_patterns(config::parse_pattern_args(&self.patterns)?)?;
        if let Some(method) = self.method {
            config.detector.method = method;
        }
        if let Some(threshold) = self.threshold {
            config.detector.threshold = Some(threshold);
        }
        if let Some(channel) = self.channel {
            config.detector.channel = Some(channel);
        }
        if let Some(guard) = self.speech_guard {
            if config.detector.method != config::Method::Spectral {
                anyhow::bail!(
                    "--speech-guard is a setting of the spectral method; the method here is \"{}\"",
                    config.detector.method.name()
                );
            }
            config.detector.speech_guard_seconds = guard;
        }
        config
            .detector
            .background
            .extend(self.background.iter().cloned());
        config.detector.validate("command line")?;
        config.check_pattern_thresholds("command line")?;
        if config.patterns.is_empty() && config.performers.is_empty() {
            anyhow::bail!(
                "no patterns to detect: give --pattern NAME=FILE.wav (repeatable) or --config FILE with [[pattern]] entries"
            );
        }
        Ok(config)
    }
}

fn run_analyze(args: &AnalyzeArgs) -> anyhow::Result<()> {
    if args.bounce && args.format != Format::Json {
        anyhow::bail!("--bounce adds a \"bounce\" array to the JSON output; it cannot be used with --format csv");
    }
    let mut config = args.source.to_config()?;
    if let Some(g) = args.gravity {
        if !(g.is_finite() && g > 0.0) {
            anyhow::bail!("--gravity must be a positive number (m/s²), found {g}");
        }
        let mut bounce = config.bounce_or_default();
        bounce.gravity = g;
        config.bounce = Some(bounce);
    }
    // A progress bar on stderr, for long files in a terminal only (indicatif hides it
    // when stderr is not a terminal).
    let bar = indicatif::ProgressBar::with_draw_target(
        Some(1000),
        indicatif::ProgressDrawTarget::stderr(),
    );
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "analysing {bar:40} {percent:>3}%  {elapsed} (about {eta} left)",
    ) {
        bar.set_style(style);
    }
    let started = std::time::Instant::now();
    let keep = analyze::Keep {
        scores: args.plot.is_some(),
        // The plot draws the onsets that did not fire.
        onsets: args.explain || args.plot.is_some(),
    };
    let analysis = analyze::analyze_file_with(&args.recording, &config, keep, &mut |done| {
        // Short analyses finish before a bar would help.
        if started.elapsed() > std::time::Duration::from_millis(300) {
            bar.set_position((done * 1000.0) as u64);
        }
    });
    bar.finish_and_clear();
    let analysis = analysis?;
    if let Some(path) = &args.plot {
        let select = config.detector.channel.map_or(
            crate::audio::ChannelSelect::Mix,
            crate::audio::ChannelSelect::Index,
        );
        let samples = crate::audio::WavSource::open(&args.recording, select)
            .and_then(|mut s| s.read_all())
            .map_err(analyze::AnalyzeError::Recording)?;
        crate::plot::write_svg(path, &samples, &analysis)?;
    }
    if args.explain {
        if let Some(top_hz) = analysis.compared_top_hz {
            let _ = writeln!(
                std::io::stderr().lock(),
                "only the bands under {:.1} kHz are compared: the recording or the takes carry no more",
                top_hz / 1000.0
            );
        }
        match &analysis.onsets {
            Some(onsets) => {
                let mut err = std::io::stderr().lock();
                analyze::write_explain(&mut err, onsets)
                    .and_then(|()| {
                        analyze::write_held_ends(
                            &mut err,
                            analysis.held_ends.as_deref().unwrap_or_default(),
                        )
                    })
                    .context("cannot write to stderr")?
            }
            None => tracing::warn!(
                "--explain lists the onsets of the spectral method; the waveform method has none"
            ),
        }
    }
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match args.format {
        Format::Json => {
            let contacts = args
                .bounce
                .then(|| analyze::bounce(&analysis.events, &config));
            let explained = match (&analysis.onsets, &analysis.held_ends) {
                (Some(onsets), Some(held_ends)) if args.explain => {
                    Some(analyze::Explained { onsets, held_ends })
                }
                _ => None,
            };
            analyze::write_json(&mut out, &analysis.events, contacts.as_deref(), explained)
        }
        Format::Csv => analyze::write_csv(&mut out, &analysis.events),
    }
    .and_then(|()| out.flush())
    .context("cannot write to stdout")
}

fn run_eval(args: &EvalArgs) -> anyhow::Result<()> {
    if !(args.tolerance.is_finite() && args.tolerance > 0.0) {
        anyhow::bail!(
            "--tolerance must be a positive number of seconds, found {}",
            args.tolerance
        );
    }
    let truth = eval::load_truth(&args.truth)?;
    let config = args.source.to_config()?;
    let analysis = analyze::analyze_file(&args.recording, &config)?;
    let score = eval::score(&analysis.events, &truth, args.tolerance);
    let text = match args.format {
        ScoreFormat::Text => eval::render_text(&score),
        ScoreFormat::Json => serde_json::to_string(&score)? + "\n",
    };
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .context("cannot write to stdout")
}

/// Checks every performer (or the one `--performer` names).
fn run_check(source: &PatternSource) -> anyhow::Result<()> {
    let config = source.to_daemon_config()?;
    let mut err = std::io::stderr().lock();
    for (name, lane) in config.lanes() {
        let who = name
            .map(|n| format!("performer '{n}', "))
            .unwrap_or_default();
        let patterns = pattern::load_patterns(&lane.patterns, &lane.detector)
            .with_context(|| who.trim_end_matches(", ").to_string())?;
        for p in &patterns {
            let _ = writeln!(
                err,
                "{who}pattern '{}' ({}): {} take(s), {:.0} ms longest, threshold {}",
                p.name,
                p.kind.as_str(),
                p.takes.len(),
                p.max_len() as f64 * 1000.0 / f64::from(lane.detector.sample_rate),
                p.threshold
            );
        }
        let report = pattern::takes_report(&patterns, &lane.detector)?;
        for spread in &report.spread {
            let _ = writeln!(err, "{who}{spread}");
        }
        for repeated in &report.repeated {
            let _ = writeln!(err, "{who}{repeated}");
        }
        for (path, model) in crate::detect::own_background(&lane.detector)? {
            let _ = writeln!(
                err,
                "{who}background '{}': {} sounds that must never fire",
                path.display(),
                model.len()
            );
        }
        if let Some(top_hz) = pattern::takes_carry_under_hz(&patterns, &lane.detector) {
            let _ = writeln!(
                err,
                "{who}the takes carry sound up to {:.1} kHz (recorded at a low rate, or band-limited on their way in): the spectral method compares only the bands under it",
                top_hz / 1000.0
            );
        }
        for warning in &report.look_alike {
            let _ = writeln!(err, "warning: {who}{warning}");
        }
    }
    let _ = writeln!(err, "configuration is valid");
    Ok(())
}

fn run_listen(args: &ListenArgs) -> anyhow::Result<()> {
    if !(args.speed.is_finite() && args.speed > 0.0 && args.speed <= 1000.0) {
        anyhow::bail!(
            "--speed must be above 0 and at most 1000, found {}",
            args.speed
        );
    }
    if args.repeat == 0 {
        anyhow::bail!("--repeat must be at least 1, found 0");
    }
    let print = match args.print {
        PrintChoice::Auto => {
            use std::io::IsTerminal;
            if std::io::stdout().is_terminal() {
                PrintMode::Text
            } else {
                PrintMode::None
            }
        }
        PrintChoice::Text => PrintMode::Text,
        PrintChoice::Json => PrintMode::Json,
        PrintChoice::None => PrintMode::None,
    };
    let options = ListenOptions {
        input_file: args.input.clone(),
        speed: args.speed,
        repeat: args.repeat,
        print,
    };
    daemon::listen(&|| args.to_config(), &options)?;
    Ok(())
}

fn run_record(args: &RecordArgs) -> anyhow::Result<()> {
    if !(1..=20).contains(&args.takes) {
        anyhow::bail!("--takes must be from 1 to 20, found {}", args.takes);
    }
    let longest = crate::detect::MAX_BACKGROUND_SECONDS;
    if !(args.seconds.is_finite() && (5.0..=longest).contains(&args.seconds)) {
        anyhow::bail!(
            "--seconds must be from 5 to {longest}, found {}",
            args.seconds
        );
    }
    let config = match &args.config {
        Some(path) => Config::load(path)?,
        None => Config::default(),
    };
    let mut input_settings = config.input.clone();
    if let Some(d) = &args.device {
        input_settings.device = Some(d.clone());
    }
    // The performer's channel; a config with performers needs one named.
    let channel = config
        .select_performer(args.performer.as_deref())
        .map_err(|m| anyhow::anyhow!(m))?
        .detector
        .channel;
    let options = crate::record::RecordOptions {
        name: args.name.clone(),
        performer: args.performer.clone(),
        channel: channel.map_or(
            crate::audio::ChannelSelect::Mix,
            crate::audio::ChannelSelect::Index,
        ),
        kind: if args.continuous {
            config::PatternKind::Continuous
        } else {
            config::PatternKind::Impulse
        },
        takes: args.takes,
        config: args.config.clone(),
        dir: args.dir.clone(),
        input: args.input.clone(),
        detector: config.detector.clone(),
        input_settings,
        background_seconds: args.background.then_some(args.seconds),
    };
    let mut err = std::io::stderr().lock();
    crate::record::record(&options, &mut err)?;
    Ok(())
}

fn run_devices() -> anyhow::Result<()> {
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    writeln!(out, "audio inputs:")?;
    match crate::input::list_inputs() {
        Ok(inputs) if inputs.is_empty() => writeln!(out, "  (none)")?,
        Ok(inputs) => {
            for i in inputs {
                writeln!(out, "  {i}")?;
            }
        }
        Err(e) => writeln!(out, "  (cannot list: {e})")?,
    }
    writeln!(out, "MIDI output ports:")?;
    match crate::output::midi::list_ports() {
        Ok(ports) if ports.is_empty() => writeln!(out, "  (none)")?,
        Ok(ports) => {
            for p in ports {
                writeln!(out, "  {p}")?;
            }
        }
        Err(e) => writeln!(out, "  (cannot list: {e})")?,
    }
    out.flush().context("cannot write to stdout")
}

fn init_logging(verbose: u8, format: LogFormat, daemon: bool) {
    use tracing_subscriber::EnvFilter;
    let default = match (verbose, daemon) {
        (0, false) => "warn",
        (0, true) | (1, _) => "info",
        _ => "debug",
    };
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default));
    use std::io::IsTerminal;
    let builder = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(std::io::stderr().is_terminal())
        .with_writer(std::io::stderr);
    let _ = match format {
        LogFormat::Human => builder.try_init(),
        LogFormat::Json => builder.json().try_init(),
    };
}

fn run_render(args: &RenderArgs) -> anyhow::Result<()> {
    let extension = args
        .output
        .extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    let video = match extension.as_str() {
        "mp4" => true,
        "html" | "htm" => false,
        _ => anyhow::bail!(
            "cannot write {}: render writes an MP4 video or an HTML page; name the output OUT.mp4 or OUT.html",
            args.output.display()
        ),
    };
    let (width, height) = parse_size(&args.size)?;
    if !(1..=240).contains(&args.fps) {
        anyhow::bail!("--fps must be from 1 to 240, found {}", args.fps);
    }
    let soundtracks: Vec<PathBuf> = std::iter::once(args.recording.clone())
        .chain(args.tracks.iter().cloned())
        .collect();
    let mut duration = 0.0_f64;
    for path in &soundtracks {
        let source = crate::audio::WavSource::open(path, crate::audio::ChannelSelect::Mix)
            .map_err(analyze::AnalyzeError::Recording)?;
        duration = duration.max(source.frames_total() as f64 / f64::from(source.sample_rate()));
    }
    if !args.events.is_empty() && args.events.len() != soundtracks.len() {
        anyhow::bail!(
            "--events given {} times for {} soundtracks: give one events file per soundtrack (the recording, then each --track), or none to analyse them",
            args.events.len(),
            soundtracks.len()
        );
    }
    let given_patterns = args.source.config.is_some() || !args.source.patterns.is_empty();
    let config = if given_patterns || args.events.is_empty() {
        args.source.to_config()?
    } else {
        Config::default()
    };
    let origin = args
        .source
        .config
        .as_ref()
        .map_or("the command line".to_string(), |c| {
            format!("config '{}'", c.display())
        });
    let track_patterns = &config.render.tracks;
    if !track_patterns.is_empty() && track_patterns.len() != soundtracks.len() {
        anyhow::bail!(
            "{origin} has {} [[render.track]] sections for {} soundtracks (the recording and {} --track): give one per soundtrack, or none to search every soundtrack for every pattern",
            track_patterns.len(),
            soundtracks.len(),
            args.tracks.len()
        );
    }
    let mut tracks: Vec<Vec<crate::detect::Event>> = Vec::with_capacity(soundtracks.len());
    for (i, path) in soundtracks.iter().enumerate() {
        let events = match args.events.get(i) {
            Some(file) => crate::render::read_events(file)?,
            None => {
                let mut own = config.clone();
                if let Some(names) = track_patterns.get(i) {
                    own.patterns.retain(|p| names.contains(&p.name));
                }
                analyze::analyze_file_with(path, &own, analyze::Keep::default(), &mut |_| {})?
                    .events
            }
        };
        tracks.push(events);
    }
    let patterns: Vec<(String, crate::config::PatternKind)> = if given_patterns {
        config
            .patterns
            .iter()
            .map(|p| (p.name.clone(), p.kind))
            .collect()
    } else {
        crate::render::patterns_of_events(&tracks)
    };
    let actions = crate::render::Actions::new(&config.render, config.bounce.clone(), &patterns);
    let scene = args
        .scene
        .or(config.render.scene)
        .unwrap_or(crate::render::Scene::Ball);
    let frames = crate::render::FrameSettings {
        fps: args.fps,
        width,
        height,
    };
    let animation = crate::render::animate(scene, &tracks, &actions, frames, duration);
    let sound = crate::render::soundtrack(&soundtracks)?;
    let title = format!(
        "{} — onomato",
        args.recording
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
    );
    if video {
        let bar = indicatif::ProgressBar::with_draw_target(
            Some(animation.frames.len() as u64),
            indicatif::ProgressDrawTarget::stderr(),
        );
        if let Ok(style) = indicatif::ProgressStyle::with_template(
            "rendering {bar:40} {pos}/{len} frames  {elapsed} (about {eta} left)",
        ) {
            bar.set_style(style);
        }
        let written = crate::render::write_video(&animation, &sound, &args.output, &mut |k| {
            bar.set_position(k as u64)
        });
        bar.finish_and_clear();
        written?;
    } else {
        crate::render::write_atomically(&args.output, |out| {
            crate::render::write_html(&animation, &sound, &title, out)
        })?;
    }
    eprintln!(
        "{}: {} scene, {} events, {} frames at {} fps, {}x{}",
        args.output.display(),
        scene.name(),
        tracks.iter().map(Vec::len).sum::<usize>(),
        animation.frames.len(),
        args.fps,
        width,
        height
    );
    Ok(())
}

/// "WIDTHxHEIGHT" in pixels, each 16 to 7680.
fn parse_size(text: &str) -> anyhow::Result<(u32, u32)> {
    let parsed = text
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((w, h)) if (16..=7680).contains(&w) && (16..=7680).contains(&h) => Ok((w, h)),
        _ => anyhow::bail!(
            "--size must be WIDTHxHEIGHT in pixels, each 16 to 7680 (such as 1280x720), found '{text}'"
        ),
    }
}

/// Entry point of the binary: parses arguments, runs the command, prints errors.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match &cli.command {
        Command::Listen(args) => init_logging(cli.verbose, args.log_format, true),
        _ => init_logging(cli.verbose, LogFormat::Human, false),
    }
    let result = match &cli.command {
        Command::Analyze(args) => run_analyze(args),
        Command::Check(source) => run_check(source),
        Command::Eval(args) => run_eval(args),
        Command::Listen(args) => run_listen(args),
        Command::Devices => run_devices(),
        Command::Record(args) => run_record(args),
        Command::Render(args) => run_render(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
