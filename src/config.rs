//! The configuration: TOML parsed into raw serde structs (`deny_unknown_fields`), then
//! validated into [`Config`], the one place where settings become domain types. Also the
//! `--pattern NAME=FILE.wav[:continuous]` command-line form.
//!
//! Runs on the main thread at start-up (and, later, on reload); never on the audio path.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// Errors in a configuration. Each names the file or key, what was expected and what was found.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    #[error("cannot read config '{}': {cause}", path.display())]
    Read {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("config '{}' is not valid: {message}", path.display())]
    Parse { path: PathBuf, message: String },
    #[error("{origin}: {message}")]
    Invalid { origin: String, message: String },
    #[error("--pattern '{spec}': {message}")]
    PatternArg { spec: String, message: String },
}

/// How a pattern behaves in time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum PatternKind {
    /// One instant ("tick", "pop"): one time.
    #[default]
    Impulse,
    /// A held sound ("chhh", "hooo"): a begin and an end.
    Continuous,
}

impl PatternKind {
    pub fn as_str(self) -> &'static str {
        match self {
            PatternKind::Impulse => "impulse",
            PatternKind::Continuous => "continuous",
        }
    }
}

/// Which matcher runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// The paper's normalised cross-correlation of raw waveforms.
    Waveform,
    /// Log-mel frames matched a few tens of milliseconds after each onset.
    #[default]
    Spectral,
}

impl Method {
    /// Match threshold of patterns when none is configured: the paper's 0.5 for its
    /// correlation of waveforms; 0.3 for the spectral method, whose weighted cepstral
    /// similarity runs lower (see the README's accuracy table for how it trades misses
    /// for false triggers).
    pub fn default_threshold(self) -> f64 {
        match self {
            Method::Waveform => 0.5,
            Method::Spectral => 0.3,
        }
    }

    /// The name a config and the command line use.
    pub fn name(self) -> &'static str {
        match self {
            Method::Waveform => "waveform",
            Method::Spectral => "spectral",
        }
    }
}

/// Bounce style of a contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactStyle {
    Hard,
    Soft,
    Slide,
}

/// What `onomato render` draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Scene {
    /// A ball bouncing on the floor: it lands on every hard bounce, squashes on soft
    /// ones by their strength and slides along the floor through held sounds.
    Ball,
    /// Every event on a strip over time, with its label and strength, and a playhead.
    Timeline,
    /// The paper's rain: each impulse drops a drop at a place of its own (the same on
    /// every run), landing at its time, as large as it is strong.
    Rain,
    /// The paper's spaceship: each impulse throws a dart as large as it is strong; held
    /// sounds move the ship up or down for exactly their spans.
    Darts,
    /// The paper's laser scene: shots fired low or high, a runner who jumps or slides
    /// under them (two soundtracks: one shoots, one moves).
    Laser,
}

impl Scene {
    pub fn name(self) -> &'static str {
        match self {
            Scene::Ball => "ball",
            Scene::Timeline => "timeline",
            Scene::Rain => "rain",
            Scene::Darts => "darts",
            Scene::Laser => "laser",
        }
    }
}

/// What a pattern does in the darts scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DartsAction {
    /// Throw a dart (an impulse).
    Throw,
    /// Move the ship up while it lasts (a held sound).
    Up,
    /// Move the ship down while it lasts (a held sound).
    Down,
}

/// What a pattern does in the laser scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LaserAction {
    /// Fire a shot at the runner's feet (an impulse).
    ShootLow,
    /// Fire a shot at the runner's head (an impulse).
    ShootHigh,
    /// The runner jumps (an impulse).
    Jump,
    /// The runner slides under, while it lasts (a held sound).
    Slide,
}

/// The kind of pattern an action is made by.
pub trait SceneAction: Copy {
    fn kind(self) -> PatternKind;
    fn name(self) -> &'static str;
}

impl SceneAction for DartsAction {
    fn kind(self) -> PatternKind {
        match self {
            DartsAction::Throw => PatternKind::Impulse,
            DartsAction::Up | DartsAction::Down => PatternKind::Continuous,
        }
    }
    fn name(self) -> &'static str {
        match self {
            DartsAction::Throw => "throw",
            DartsAction::Up => "up",
            DartsAction::Down => "down",
        }
    }
}

impl SceneAction for LaserAction {
    fn kind(self) -> PatternKind {
        match self {
            LaserAction::Slide => PatternKind::Continuous,
            _ => PatternKind::Impulse,
        }
    }
    fn name(self) -> &'static str {
        match self {
            LaserAction::ShootLow => "shoot_low",
            LaserAction::ShootHigh => "shoot_high",
            LaserAction::Jump => "jump",
            LaserAction::Slide => "slide",
        }
    }
}

// ---------------------------------------------------------------- raw (as written)

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    #[serde(default)]
    detector: RawDetector,
    #[serde(default)]
    pattern: Vec<RawPattern>,
    bounce: Option<RawBounce>,
    #[serde(default)]
    input: RawInput,
    osc: Option<RawOsc>,
    midi: Option<RawMidi>,
    render: Option<RawRender>,
    preview: Option<RawPreview>,
    #[serde(default)]
    performer: Vec<RawPerformer>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPerformer {
    name: String,
    channel: Option<u16>,
    osc_prefix: Option<String>,
    midi_channel: Option<u8>,
    #[serde(default)]
    pattern: Vec<RawPattern>,
    bounce: Option<RawBounce>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPreview {
    address: Option<String>,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawInput {
    device: Option<String>,
    sample_rate: Option<u32>,
    buffer_frames: Option<u32>,
    ring_seconds: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawOsc {
    #[serde(default)]
    targets: Vec<String>,
    prefix: Option<String>,
    bundle: Option<bool>,
    heartbeat_seconds: Option<f64>,
    bounce_state_rate: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMidi {
    connect: Option<String>,
    virtual_port: Option<String>,
    channel: Option<u8>,
    gate_seconds: Option<f64>,
    velocity_min: Option<u8>,
    velocity_max: Option<u8>,
    full_strength: Option<f64>,
    velocity_curve: Option<f64>,
    strength_cc: Option<u8>,
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawDetector {
    method: Option<Method>,
    sample_rate: Option<u32>,
    threshold: Option<f64>,
    continuous_threshold: Option<f64>,
    max_pattern_seconds: Option<f64>,
    channel: Option<u16>,
    spectral: Option<RawSpectral>,
    waveform: Option<RawWaveform>,
    // Keys of one method, once in [detector]: refused with where they now live.
    suppression_seconds: Option<toml::Value>,
    decision_seconds: Option<toml::Value>,
    max_decision_seconds: Option<toml::Value>,
    speech_guard_seconds: Option<toml::Value>,
    min_strength: Option<toml::Value>,
}

/// `[detector.spectral]`: settings only the spectral method has.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawSpectral {
    decision_seconds: Option<f64>,
    max_decision_seconds: Option<f64>,
    speech_guard_seconds: Option<f64>,
    min_strength: Option<f64>,
    #[serde(default)]
    background: Vec<PathBuf>,
}

/// `[detector.waveform]`: settings only the waveform method has.
#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawWaveform {
    suppression_seconds: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPattern {
    name: String,
    #[serde(default)]
    kind: PatternKind,
    takes: Vec<PathBuf>,
    threshold: Option<f64>,
    continuous_threshold: Option<f64>,
    note: Option<u8>,
    channel: Option<u8>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBounce {
    gravity: Option<f64>,
    default_interval_seconds: Option<f64>,
    state_delay_seconds: Option<f64>,
    #[serde(default)]
    hard: Vec<String>,
    #[serde(default)]
    soft: Vec<String>,
    #[serde(default)]
    slide: Vec<String>,
    max_squash: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRender {
    scene: Option<Scene>,
    darts: Option<BTreeMap<String, DartsAction>>,
    laser: Option<BTreeMap<String, LaserAction>>,
    rain: Option<Vec<String>>,
    #[serde(default)]
    track: Vec<RawTrack>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTrack {
    patterns: Vec<String>,
}

// ---------------------------------------------------------------- validated

/// Detector settings, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectorSettings {
    pub method: Method,
    /// Working sample rate: every input is resampled to it.
    pub sample_rate: u32,
    /// Match threshold for patterns that do not set their own; `None`: the method's
    /// default ([`Method::default_threshold`]). Read it with [`Self::threshold`].
    pub threshold: Option<f64>,
    /// Lower threshold that holds a continuous event (on the smoothed match score).
    pub continuous_threshold: f64,
    /// Half-width of the window in which a greater match suppresses an instance.
    /// `None`: half the pattern's length, as in the paper.
    pub suppression_seconds: Option<f64>,
    /// Longest pattern take accepted.
    pub max_pattern_seconds: f64,
    /// Spectral method: how long after an onset the sound is classified. The built-in
    /// background of speech is pooled over the default; at another value it is not used.
    pub decision_seconds: f64,
    /// Spectral method: the longest a decision waits, seconds from the onset, to tell
    /// apart two patterns that sound alike over `decision_seconds` (a spoken "pop" and
    /// "pew" share their "p") and part later, or that an instance lies between over
    /// `decision_seconds`. `decision_seconds` never waits.
    pub max_decision_seconds: f64,
    /// Spectral method: an onset is ignored when, this long before it, a sound that no
    /// pattern recognised (speech, music) held 200 ms within 10 dB of the new sound's
    /// peak. 0 turns the guard off.
    pub speech_guard_seconds: f64,
    /// Spectral method: a sound whose strength (amplitude against the enrolled take,
    /// over the first `decision_seconds`) is below this is not the user's: a voice
    /// across the room, a breath, the hum of a fan. 0 accepts any level.
    pub min_strength: f64,
    /// Channel of multi-channel inputs (`None`: mix all channels). Mono files are used
    /// as they are.
    pub channel: Option<u16>,
    /// Spectral method: recordings (WAV) of sounds that must never fire, such as the
    /// user talking or the room: every onset in them that stands out of its quiet joins
    /// the built-in background of speech (`docs/background.md`).
    pub background: Vec<PathBuf>,
}

impl Default for DetectorSettings {
    fn default() -> Self {
        Self {
            method: Method::Spectral,
            sample_rate: 22_050,
            threshold: None,
            continuous_threshold: 0.3,
            suppression_seconds: None,
            max_pattern_seconds: 5.0,
            channel: None,
            decision_seconds: 0.025,
            max_decision_seconds: 0.055,
            speech_guard_seconds: DEFAULT_SPEECH_GUARD_SECONDS,
            min_strength: 0.06,
            background: Vec::new(),
        }
    }
}

/// One pattern as configured (its takes not yet loaded).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PatternSpec {
    pub name: String,
    pub kind: PatternKind,
    pub takes: Vec<PathBuf>,
    pub threshold: Option<f64>,
    pub continuous_threshold: Option<f64>,
    /// MIDI note (0-127); `None`: 36 plus the pattern's position.
    pub note: Option<u8>,
    /// MIDI channel (1-16); `None`: the `[midi]` channel.
    pub midi_channel: Option<u8>,
}

/// Audio capture settings of `listen`, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct InputSettings {
    /// Input device: its name or a part of it; `None`: the system's default input.
    pub device: Option<String>,
    /// Capture rate, Hz; `None`: the device's default rate.
    pub sample_rate: Option<u32>,
    /// Frames per capture callback (the device's buffer size).
    pub buffer_frames: u32,
    /// Length of the ring between the capture callback and the detector, seconds.
    pub ring_seconds: f64,
}

impl Default for InputSettings {
    fn default() -> Self {
        Self {
            device: None,
            sample_rate: None,
            buffer_frames: 256,
            ring_seconds: 2.0,
        }
    }
}

/// OSC output, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct OscSettings {
    /// UDP targets as `HOST:PORT`; resolved when the daemon starts.
    pub targets: Vec<String>,
    /// Address prefix, such as `/onomato`: starts with '/', does not end with one.
    pub prefix: String,
    /// Wrap each message in a bundle whose timetag is the sound's onset.
    pub bundle: bool,
    /// Period of the `/status` message, seconds; `None`: no status.
    pub heartbeat_seconds: Option<f64>,
    /// Rate of `/bounce/state` messages, Hz; `None`: hits only.
    pub bounce_state_rate: Option<f64>,
}

impl OscSettings {
    pub fn with_targets(targets: Vec<String>) -> Self {
        Self {
            targets,
            prefix: DEFAULT_OSC_PREFIX.to_string(),
            bundle: false,
            heartbeat_seconds: None,
            bounce_state_rate: None,
        }
    }
}

pub const DEFAULT_OSC_PREFIX: &str = "/onomato";

/// Where MIDI goes.
#[derive(Debug, Clone, PartialEq)]
pub enum MidiPortChoice {
    /// Connect to the first output port whose name contains this text.
    Connect(String),
    /// Open a virtual port of this name, for other programs to connect to.
    Virtual(String),
}

/// MIDI output, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct MidiSettings {
    pub port: MidiPortChoice,
    /// Channel (1-16) of patterns that do not set their own.
    pub channel: u8,
    /// How long an impulse's note is held, seconds.
    pub gate_seconds: f64,
    pub velocity_min: u8,
    pub velocity_max: u8,
    /// Strength that gives `velocity_max`.
    pub full_strength: f64,
    /// Exponent of the strength-to-velocity curve (1: linear).
    pub velocity_curve: f64,
    /// Control change number that carries a continuous sound's strength.
    pub strength_cc: Option<u8>,
}

impl MidiSettings {
    pub fn with_port(port: MidiPortChoice) -> Self {
        Self {
            port,
            channel: 10,
            gate_seconds: 0.05,
            velocity_min: 1,
            velocity_max: 127,
            full_strength: 1.5,
            velocity_curve: 1.0,
            strength_cc: None,
        }
    }

    /// Velocity (1-127) of a sound of this strength.
    pub fn velocity(&self, strength: f64) -> u8 {
        let x = if strength.is_finite() {
            (strength / self.full_strength).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let lo = f64::from(self.velocity_min);
        let hi = f64::from(self.velocity_max);
        (lo + (hi - lo) * x.powf(self.velocity_curve))
            .round()
            .clamp(1.0, 127.0) as u8
    }
}

/// Bounce solver settings, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct BounceSettings {
    /// m/s², positive.
    pub gravity: f64,
    /// Pattern name to contact style.
    pub styles: BTreeMap<String, ContactStyle>,
    /// Squash of a soft bounce at strength 1 (fraction of the ball's height).
    pub max_squash: f64,
    /// Live solver: the interval predicted before two hits have been seen, seconds.
    pub default_interval_seconds: f64,
    /// Live solver: how far the state stream runs behind the input, so that it knows
    /// each hit before drawing it, seconds. `None`: the detector's decision delay.
    pub state_delay_seconds: Option<f64>,
}

impl BounceSettings {
    /// Every impulse pattern a hard bounce, every continuous pattern a slide.
    pub fn default_for(patterns: &[PatternSpec]) -> Self {
        let styles = patterns
            .iter()
            .map(|p| {
                let style = match p.kind {
                    PatternKind::Impulse => ContactStyle::Hard,
                    PatternKind::Continuous => ContactStyle::Slide,
                };
                (p.name.clone(), style)
            })
            .collect();
        Self {
            gravity: DEFAULT_GRAVITY,
            styles,
            max_squash: DEFAULT_MAX_SQUASH,
            default_interval_seconds: DEFAULT_INTERVAL_SECONDS,
            state_delay_seconds: None,
        }
    }
}

/// `onomato render` settings, validated: which pattern does what in each scene (`None`:
/// the scene's defaults from the patterns' kinds), and which patterns each soundtrack
/// is searched for.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RenderSettings {
    /// The scene drawn when the command line names none.
    pub scene: Option<Scene>,
    pub darts: Option<BTreeMap<String, DartsAction>>,
    pub laser: Option<BTreeMap<String, LaserAction>>,
    /// The patterns whose events drop a drop.
    pub rain: Option<Vec<String>>,
    /// The patterns of each soundtrack, in the order of the command line (the recording
    /// first, then each `--track`). Empty: every soundtrack is searched for every pattern.
    pub tracks: Vec<Vec<String>>,
}

pub const DEFAULT_GRAVITY: f64 = 9.81;
pub const DEFAULT_MAX_SQUASH: f64 = 0.4;
pub const DEFAULT_INTERVAL_SECONDS: f64 = 0.5;

/// A validated configuration.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Config {
    pub detector: DetectorSettings,
    pub patterns: Vec<PatternSpec>,
    /// `None` when the file has no `[bounce]` section.
    pub bounce: Option<BounceSettings>,
    pub input: InputSettings,
    /// `None`: no OSC.
    pub osc: Option<OscSettings>,
    /// `None`: no MIDI.
    pub midi: Option<MidiSettings>,
    pub render: RenderSettings,
    /// `None`: no preview page.
    pub preview: Option<PreviewSettings>,
    /// `[[performer]]` sections: each an input channel with its own patterns and
    /// outputs. Empty: one performer, the file's `[[pattern]]`s on `[detector] channel`.
    pub performers: Vec<Performer>,
}

/// A performer (`[[performer]]`), validated: one input channel of the device, with its
/// own patterns, OSC prefix, MIDI channel and bounce solver.
#[derive(Debug, Clone, PartialEq)]
pub struct Performer {
    pub name: String,
    /// Input channel, from 0; `None`: the channels mixed.
    pub channel: Option<u16>,
    /// OSC address prefix (default: the `[osc]` prefix, then `/` and the name).
    pub osc_prefix: String,
    /// MIDI channel, 1-16 (default: the `[midi]` channel); a pattern's own wins.
    pub midi_channel: Option<u8>,
    pub patterns: Vec<PatternSpec>,
    /// `None`: the bounce solver's defaults from the patterns' kinds, when it runs.
    pub bounce: Option<BounceSettings>,
}

/// The live preview page (`listen --preview`), validated.
#[derive(Debug, Clone, PartialEq)]
pub struct PreviewSettings {
    /// Where its HTTP server listens.
    pub address: std::net::SocketAddr,
}

/// Loopback only unless the user names another address.
pub const DEFAULT_PREVIEW_ADDRESS: &str = "127.0.0.1:8765";

/// A preview address: an IP address and a port, such as `127.0.0.1:8765`.
pub fn parse_preview_address(text: &str) -> Result<std::net::SocketAddr, String> {
    text.trim().parse().map_err(|_| {
        format!("address must be an IP address and a port, such as '{DEFAULT_PREVIEW_ADDRESS}', found '{text}'")
    })
}

impl Config {
    /// Reads and validates a config file. Relative take paths are resolved against the
    /// file's folder.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|cause| ConfigError::Read {
            path: path.to_path_buf(),
            cause,
        })?;
        let base = path.parent().unwrap_or(Path::new("."));
        Self::parse(&text, base, &format!("config '{}'", path.display())).map_err(|e| match e {
            ConfigError::Parse { message, .. } => ConfigError::Parse {
                path: path.to_path_buf(),
                message,
            },
            other => other,
        })
    }

    /// Parses and validates TOML text; `base` resolves relative paths, `origin` names the
    /// source in messages.
    pub fn parse(text: &str, base: &Path, origin: &str) -> Result<Self, ConfigError> {
        let raw: RawConfig = toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: PathBuf::from(origin),
            message: e.to_string().trim_end().to_string(),
        })?;
        raw.validate(base, origin)
    }

    /// Adds patterns given on the command line. A name already in the config is an error.
    pub fn add_cli_patterns(&mut self, specs: Vec<PatternSpec>) -> Result<(), ConfigError> {
        for spec in specs {
            if self.patterns.iter().any(|p| p.name == spec.name) {
                return Err(ConfigError::Invalid {
                    origin: "--pattern".into(),
                    message: format!(
                        "pattern '{}' is already defined in the config; give it another name",
                        spec.name
                    ),
                });
            }
            self.patterns.push(spec);
        }
        Ok(())
    }

    /// Checks every continuous pattern's lower threshold against its threshold, after
    /// command-line overrides.
    pub fn check_pattern_thresholds(&self, origin: &str) -> Result<(), ConfigError> {
        for (name, c) in self.lanes() {
            let who = name
                .map(|n| format!(", performer '{n}'"))
                .unwrap_or_default();
            for p in &c.patterns {
                check_thresholds(
                    &format!("{origin}{who}, pattern '{}'", p.name),
                    p,
                    &self.detector,
                )?;
            }
        }
        Ok(())
    }

    /// What each performer runs on: one config per performer, holding only that
    /// performer's patterns, channel, OSC prefix, MIDI channel and bounce settings, with
    /// its name; without `[[performer]]` sections, this config, unnamed.
    pub fn lanes(&self) -> Vec<(Option<String>, Config)> {
        if self.performers.is_empty() {
            return vec![(None, self.clone())];
        }
        self.performers
            .iter()
            .map(|p| (Some(p.name.clone()), self.for_performer(p)))
            .collect()
    }

    /// The config of the performer named `name` alone (see [`Config::lanes`]); `None`
    /// keeps a config without performers as it is. An error names what was asked and
    /// what there is.
    pub fn select_performer(&self, name: Option<&str>) -> Result<Config, String> {
        let names = || {
            self.performers
                .iter()
                .map(|p| format!("'{}'", p.name))
                .collect::<Vec<_>>()
                .join(", ")
        };
        match (name, self.performers.is_empty()) {
            (None, true) => Ok(self.clone()),
            (None, false) => Err(format!(
                "the config has performers ({}); name one with --performer",
                names()
            )),
            (Some(n), true) => Err(format!(
                "--performer '{n}': the config has no [[performer]] sections"
            )),
            (Some(n), false) => self
                .performers
                .iter()
                .find(|p| p.name == n)
                .map(|p| self.for_performer(p))
                .ok_or_else(|| {
                    format!(
                        "--performer '{n}': no such performer; the config has {}",
                        names()
                    )
                }),
        }
    }

    fn for_performer(&self, p: &Performer) -> Config {
        let mut c = self.clone();
        c.performers = Vec::new();
        c.patterns = p.patterns.clone();
        c.bounce = p.bounce.clone();
        c.detector.channel = p.channel;
        if let Some(o) = c.osc.as_mut() {
            o.prefix = p.osc_prefix.clone();
        }
        if let (Some(m), Some(ch)) = (c.midi.as_mut(), p.midi_channel) {
            m.channel = ch;
        }
        c
    }

    /// The bounce settings to use: the config's, or defaults for its patterns.
    pub fn bounce_or_default(&self) -> BounceSettings {
        self.bounce
            .clone()
            .unwrap_or_else(|| BounceSettings::default_for(&self.patterns))
    }
}

fn invalid(origin: &str, message: String) -> ConfigError {
    ConfigError::Invalid {
        origin: origin.to_string(),
        message,
    }
}

fn check_unit_interval(origin: &str, key: &str, value: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value > 0.0 && value <= 1.0 {
        Ok(())
    } else {
        Err(invalid(
            origin,
            format!("{key} must be greater than 0 and at most 1, found {value}"),
        ))
    }
}

/// Pattern names become OSC address parts and CSV fields: keep them plain.
pub fn check_pattern_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
    if ok {
        Ok(())
    } else {
        Err(format!(
            "pattern name must be 1-64 characters of letters, digits, '_' or '-', found '{name}'"
        ))
    }
}

impl RawConfig {
    fn validate(self, base: &Path, origin: &str) -> Result<Config, ConfigError> {
        let defaults = DetectorSettings::default();
        let d = self.detector;
        let item = format!("{origin}, [detector]");
        for (key, value, table) in [
            ("suppression_seconds", &d.suppression_seconds, "waveform"),
            ("decision_seconds", &d.decision_seconds, "spectral"),
            ("max_decision_seconds", &d.max_decision_seconds, "spectral"),
            ("speech_guard_seconds", &d.speech_guard_seconds, "spectral"),
            ("min_strength", &d.min_strength, "spectral"),
        ] {
            if value.is_some() {
                return Err(invalid(
                    &item,
                    format!(
                        "{key} is a setting of the {table} method: put it in [detector.{table}]"
                    ),
                ));
            }
        }
        let method = d.method.unwrap_or(defaults.method);
        let (other, other_name) = match method {
            Method::Spectral => (d.waveform.is_some(), "waveform"),
            Method::Waveform => (d.spectral.is_some(), "spectral"),
        };
        if other {
            return Err(invalid(
                &item,
                format!(
                    "[detector.{other_name}] is for method = \"{other_name}\", but this config's method is \"{}\"",
                    method.name()
                ),
            ));
        }
        let spectral = d.spectral.unwrap_or_default();
        let waveform = d.waveform.unwrap_or_default();
        let detector = DetectorSettings {
            method,
            sample_rate: d.sample_rate.unwrap_or(defaults.sample_rate),
            threshold: d.threshold,
            continuous_threshold: d
                .continuous_threshold
                .unwrap_or(defaults.continuous_threshold),
            suppression_seconds: waveform.suppression_seconds,
            max_pattern_seconds: d
                .max_pattern_seconds
                .unwrap_or(defaults.max_pattern_seconds),
            channel: d.channel,
            decision_seconds: spectral
                .decision_seconds
                .unwrap_or(defaults.decision_seconds),
            max_decision_seconds: spectral
                .max_decision_seconds
                .unwrap_or(defaults.max_decision_seconds),
            speech_guard_seconds: spectral
                .speech_guard_seconds
                .unwrap_or(defaults.speech_guard_seconds),
            min_strength: spectral.min_strength.unwrap_or(defaults.min_strength),
            background: spectral.background.iter().map(|p| base.join(p)).collect(),
        };
        detector.validate(origin)?;

        let patterns = validate_patterns(self.pattern, base, origin, &detector)?;

        let bounce = match self.bounce {
            None => None,
            Some(b) => Some(b.validate(&patterns, &format!("{origin}, [bounce]"))?),
        };
        let input = self.input.validate(&format!("{origin}, [input]"))?;
        let osc = match self.osc {
            None => None,
            Some(o) => Some(o.validate(&format!("{origin}, [osc]"))?),
        };
        let midi = match self.midi {
            None => None,
            Some(m) => Some(m.validate(&format!("{origin}, [midi]"))?),
        };
        let render = match self.render {
            None => RenderSettings::default(),
            Some(r) => r.validate(&patterns, &format!("{origin}, [render]"))?,
        };
        let preview = match self.preview {
            None => None,
            Some(p) => Some(PreviewSettings {
                address: parse_preview_address(
                    p.address.as_deref().unwrap_or(DEFAULT_PREVIEW_ADDRESS),
                )
                .map_err(|m| invalid(&format!("{origin}, [preview]"), m))?,
            }),
        };
        let performers =
            validate_performers(self.performer, base, origin, &detector, osc.as_ref())?;
        if !performers.is_empty() {
            let item = format!("{origin}, [[performer]]");
            if !patterns.is_empty() {
                return Err(invalid(&item, "[[pattern]] sections cannot be used with [[performer]]; each performer's patterns are its own [[performer.pattern]] sections".into()));
            }
            if bounce.is_some() {
                return Err(invalid(&item, "[bounce] cannot be used with [[performer]]; give a performer its own [performer.bounce]".into()));
            }
            if detector.channel.is_some() {
                return Err(invalid(&item, "[detector] channel cannot be used with [[performer]]; each performer names its own channel".into()));
            }
        }
        Ok(Config {
            detector,
            patterns,
            bounce,
            input,
            osc,
            midi,
            render,
            preview,
            performers,
        })
    }
}

fn validate_performers(
    raw: Vec<RawPerformer>,
    base: &Path,
    origin: &str,
    detector: &DetectorSettings,
    osc: Option<&OscSettings>,
) -> Result<Vec<Performer>, ConfigError> {
    if raw.len() > crate::status::MAX_LANES {
        return Err(invalid(
            &format!("{origin}, [[performer]]"),
            format!(
                "at most {} performers, found {}",
                crate::status::MAX_LANES,
                raw.len()
            ),
        ));
    }
    let mut performers: Vec<Performer> = Vec::with_capacity(raw.len());
    for (i, p) in raw.into_iter().enumerate() {
        let item = format!("{origin}, performer #{} ('{}')", i + 1, p.name);
        check_pattern_name(&p.name)
            .map_err(|m| invalid(&item, m.replace("pattern name", "performer name")))?;
        if performers.iter().any(|q| q.name == p.name) {
            return Err(invalid(
                &item,
                format!(
                    "performer name '{}' is used twice; names must be unique",
                    p.name
                ),
            ));
        }
        let osc_prefix = p.osc_prefix.unwrap_or_else(|| {
            let base = osc.map_or(DEFAULT_OSC_PREFIX, |o| o.prefix.as_str());
            format!("{base}/{}", p.name)
        });
        check_osc_prefix(&osc_prefix).map_err(|m| invalid(&item, format!("osc_prefix: {m}")))?;
        if let Some(c) = p.midi_channel {
            check_channel(&item, c).map_err(|_| {
                invalid(
                    &item,
                    format!("midi_channel must be a MIDI channel from 1 to 16, found {c}"),
                )
            })?;
        }
        if p.pattern.is_empty() {
            return Err(invalid(
                &item,
                "no [[performer.pattern]]; a performer needs at least one pattern".into(),
            ));
        }
        let patterns = validate_patterns(p.pattern, base, &item, detector)?;
        let bounce = match p.bounce {
            None => None,
            Some(b) => Some(b.validate(&patterns, &format!("{item}, [performer.bounce]"))?),
        };
        performers.push(Performer {
            name: p.name,
            channel: p.channel,
            osc_prefix,
            midi_channel: p.midi_channel,
            patterns,
            bounce,
        });
    }
    Ok(performers)
}

/// Validates `[[pattern]]` sections (of the file, or of one performer; `origin` names
/// where they are).
fn validate_patterns(
    raw: Vec<RawPattern>,
    base: &Path,
    origin: &str,
    detector: &DetectorSettings,
) -> Result<Vec<PatternSpec>, ConfigError> {
    let mut patterns: Vec<PatternSpec> = Vec::with_capacity(raw.len());
    for (i, p) in raw.into_iter().enumerate() {
        let item = format!("{origin}, pattern #{} ('{}')", i + 1, p.name);
        check_pattern_name(&p.name).map_err(|m| invalid(&item, m))?;
        if patterns.iter().any(|q| q.name == p.name) {
            return Err(invalid(
                &item,
                format!(
                    "pattern name '{}' is used twice; names must be unique",
                    p.name
                ),
            ));
        }
        if p.takes.is_empty() {
            return Err(invalid(
                &item,
                "takes is empty; expected at least one WAV file".into(),
            ));
        }
        if let Some(t) = p.threshold {
            check_unit_interval(&item, "threshold", t)?;
        }
        if let Some(t) = p.continuous_threshold {
            check_unit_interval(&item, "continuous_threshold", t)?;
            if p.kind == PatternKind::Impulse {
                return Err(invalid(
                    &item,
                    "continuous_threshold is only for kind = \"continuous\", found kind = \"impulse\"".into(),
                ));
            }
        }
        let spec = PatternSpec {
            name: p.name,
            kind: p.kind,
            takes: p.takes.into_iter().map(|t| base.join(t)).collect(),
            threshold: p.threshold,
            continuous_threshold: p.continuous_threshold,
            note: p.note,
            midi_channel: p.channel,
        };
        if let Some(n) = spec.note {
            check_note(&item, "note", n)?;
        }
        if let Some(c) = spec.midi_channel {
            check_channel(&item, c)?;
        }
        check_thresholds(&item, &spec, detector)?;
        patterns.push(spec);
    }
    Ok(patterns)
}

fn check_note(item: &str, key: &str, value: u8) -> Result<(), ConfigError> {
    if value <= 127 {
        Ok(())
    } else {
        Err(invalid(
            item,
            format!("{key} must be a MIDI number from 0 to 127, found {value}"),
        ))
    }
}

fn check_channel(item: &str, channel: u8) -> Result<(), ConfigError> {
    if (1..=16).contains(&channel) {
        Ok(())
    } else {
        Err(invalid(
            item,
            format!("channel must be a MIDI channel from 1 to 16, found {channel}"),
        ))
    }
}

fn check_seconds(item: &str, key: &str, value: f64, lo: f64, hi: f64) -> Result<(), ConfigError> {
    if value.is_finite() && (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(invalid(
            item,
            format!("{key} must be between {lo} and {hi} seconds, found {value}"),
        ))
    }
}

/// Checks `HOST:PORT` (the host is resolved later, when the daemon starts).
pub fn check_osc_target(target: &str) -> Result<(), String> {
    let Some((host, port)) = target.rsplit_once(':') else {
        return Err(format!(
            "expected HOST:PORT such as 127.0.0.1:9000, found '{target}'"
        ));
    };
    if host.is_empty() || host.contains(char::is_whitespace) {
        return Err(format!(
            "expected a host name or address before ':', found '{target}'"
        ));
    }
    match port.parse::<u16>() {
        Ok(p) if p > 0 => Ok(()),
        _ => Err(format!(
            "expected a UDP port from 1 to 65535 after ':', found '{port}' in '{target}'"
        )),
    }
}

/// An OSC address prefix: '/' then parts without OSC's special characters.
fn check_osc_prefix(prefix: &str) -> Result<(), String> {
    let ok = prefix.starts_with('/')
        && !prefix.ends_with('/')
        && !prefix.contains("//")
        && prefix
            .chars()
            .all(|c| c.is_ascii_graphic() && !"#*,?[]{}".contains(c));
    if ok {
        Ok(())
    } else {
        Err(format!(
            "prefix must start with '/', not end with '/', and hold no spaces or any of #*,?[]{{}}, found '{prefix}'"
        ))
    }
}

impl RawInput {
    fn validate(self, item: &str) -> Result<InputSettings, ConfigError> {
        let d = InputSettings::default();
        if let Some(name) = &self.device {
            if name.trim().is_empty() {
                return Err(invalid(
                    item,
                    "device is empty; give a device name (see `onomato devices`) or leave it out for the default input".into(),
                ));
            }
        }
        if let Some(rate) = self.sample_rate {
            if !(8_000..=192_000).contains(&rate) {
                return Err(invalid(
                    item,
                    format!("sample_rate must be between 8000 and 192000 Hz, found {rate}"),
                ));
            }
        }
        let buffer_frames = self.buffer_frames.unwrap_or(d.buffer_frames);
        if !(16..=8192).contains(&buffer_frames) {
            return Err(invalid(
                item,
                format!("buffer_frames must be between 16 and 8192, found {buffer_frames}"),
            ));
        }
        let ring_seconds = self.ring_seconds.unwrap_or(d.ring_seconds);
        check_seconds(item, "ring_seconds", ring_seconds, 0.1, 30.0)?;
        Ok(InputSettings {
            device: self.device,
            sample_rate: self.sample_rate,
            buffer_frames,
            ring_seconds,
        })
    }
}

impl RawOsc {
    fn validate(self, item: &str) -> Result<OscSettings, ConfigError> {
        for t in &self.targets {
            check_osc_target(t).map_err(|m| invalid(item, format!("targets: {m}")))?;
        }
        let prefix = self
            .prefix
            .unwrap_or_else(|| DEFAULT_OSC_PREFIX.to_string());
        check_osc_prefix(&prefix).map_err(|m| invalid(item, m))?;
        if let Some(h) = self.heartbeat_seconds {
            check_seconds(item, "heartbeat_seconds", h, 0.1, 3600.0)?;
        }
        if let Some(r) = self.bounce_state_rate {
            if !(r.is_finite() && (1.0..=1000.0).contains(&r)) {
                return Err(invalid(
                    item,
                    format!("bounce_state_rate must be between 1 and 1000 Hz, found {r}"),
                ));
            }
        }
        Ok(OscSettings {
            targets: self.targets,
            prefix,
            bundle: self.bundle.unwrap_or(false),
            heartbeat_seconds: self.heartbeat_seconds,
            bounce_state_rate: self.bounce_state_rate,
        })
    }
}

impl RawMidi {
    fn validate(self, item: &str) -> Result<MidiSettings, ConfigError> {
        let port =
            match (self.connect, self.virtual_port) {
                (Some(_), Some(_)) => return Err(invalid(
                    item,
                    "give connect (an existing port) or virtual_port (a port of our own), not both"
                        .into(),
                )),
                (Some(c), None) if !c.trim().is_empty() => MidiPortChoice::Connect(c),
                (None, Some(v)) if !v.trim().is_empty() => MidiPortChoice::Virtual(v),
                (None, None) => MidiPortChoice::Virtual("onomato".into()),
                _ => return Err(invalid(item, "the MIDI port name is empty".into())),
            };
        let mut m = MidiSettings::with_port(port);
        if let Some(c) = self.channel {
            check_channel(item, c)?;
            m.channel = c;
        }
        if let Some(g) = self.gate_seconds {
            check_seconds(item, "gate_seconds", g, 0.001, 10.0)?;
            m.gate_seconds = g;
        }
        for (key, value, slot) in [
            ("velocity_min", self.velocity_min, &mut m.velocity_min),
            ("velocity_max", self.velocity_max, &mut m.velocity_max),
        ] {
            if let Some(v) = value {
                if !(1..=127).contains(&v) {
                    return Err(invalid(
                        item,
                        format!("{key} must be from 1 to 127, found {v}"),
                    ));
                }
                *slot = v;
            }
        }
        if m.velocity_min > m.velocity_max {
            return Err(invalid(
                item,
                format!(
                    "velocity_min ({}) must not be above velocity_max ({})",
                    m.velocity_min, m.velocity_max
                ),
            ));
        }
        if let Some(f) = self.full_strength {
            if !(f.is_finite() && f > 0.0) {
                return Err(invalid(
                    item,
                    format!("full_strength must be a positive number, found {f}"),
                ));
            }
            m.full_strength = f;
        }
        if let Some(c) = self.velocity_curve {
            if !(c.is_finite() && (0.1..=10.0).contains(&c)) {
                return Err(invalid(
                    item,
                    format!("velocity_curve must be between 0.1 and 10, found {c}"),
                ));
            }
            m.velocity_curve = c;
        }
        if let Some(cc) = self.strength_cc {
            check_note(item, "strength_cc", cc)?;
            m.strength_cc = Some(cc);
        }
        Ok(m)
    }
}

fn check_thresholds(
    item: &str,
    spec: &PatternSpec,
    detector: &DetectorSettings,
) -> Result<(), ConfigError> {
    // The waveform method holds a continuous event with hysteresis on one score; the
    // spectral method's continuous threshold is a frame's likeness to the held
    // spectrum, another quantity, so either may be the higher there.
    if spec.kind != PatternKind::Continuous || detector.method != Method::Waveform {
        return Ok(());
    }
    let high = spec.threshold.unwrap_or(detector.threshold());
    let low = spec
        .continuous_threshold
        .unwrap_or(detector.continuous_threshold);
    if low > high {
        return Err(invalid(
            item,
            format!("continuous_threshold ({low}) must not be above threshold ({high})"),
        ));
    }
    Ok(())
}

/// Longest `speech_guard_seconds`: the detector keeps this much history.
pub const MAX_SPEECH_GUARD_SECONDS: f64 = 1.0;
/// The speech guard's span when the config does not set it (`speech_guard_seconds`).
pub const DEFAULT_SPEECH_GUARD_SECONDS: f64 = 0.65;

impl DetectorSettings {
    /// Match threshold for patterns that do not set their own.
    pub fn threshold(&self) -> f64 {
        self.threshold
            .unwrap_or_else(|| self.method.default_threshold())
    }

    /// Checks every field; `origin` names the source in messages.
    pub fn validate(&self, origin: &str) -> Result<(), ConfigError> {
        // Each key is named with the table it is written in.
        let item = format!("{origin}, [detector]");
        let spectral = format!("{origin}, [detector.spectral]");
        let waveform = format!("{origin}, [detector.waveform]");
        if !(8_000..=192_000).contains(&self.sample_rate) {
            return Err(invalid(
                &item,
                format!(
                    "sample_rate must be between 8000 and 192000 Hz, found {}",
                    self.sample_rate
                ),
            ));
        }
        if let Some(t) = self.threshold {
            check_unit_interval(&item, "threshold", t)?;
        }
        check_unit_interval(&item, "continuous_threshold", self.continuous_threshold)?;
        if let Some(s) = self.suppression_seconds {
            if !(s.is_finite() && (0.0..=5.0).contains(&s)) {
                return Err(invalid(
                    &waveform,
                    format!("suppression_seconds must be between 0 and 5, found {s}"),
                ));
            }
        }
        if self.method != Method::Spectral && !self.background.is_empty() {
            return Err(invalid(
                &spectral,
                format!(
                    "background is a setting of the spectral method (the built-in background of speech that it joins belongs to it); the method here is \"{}\"",
                    self.method.name()
                ),
            ));
        }
        let d = self.decision_seconds;
        if !(d.is_finite() && (0.015..=0.2).contains(&d)) {
            return Err(invalid(
                &spectral,
                format!("decision_seconds must be between 0.015 and 0.2, found {d}"),
            ));
        }
        let m = self.max_decision_seconds;
        if !(m.is_finite() && (d..=0.2).contains(&m)) {
            return Err(invalid(
                &spectral,
                format!(
                    "max_decision_seconds must be between decision_seconds ({d}) and 0.2, found {m}"
                ),
            ));
        }
        let g = self.speech_guard_seconds;
        if !(g.is_finite() && (0.0..=MAX_SPEECH_GUARD_SECONDS).contains(&g)) {
            return Err(invalid(
                &spectral,
                format!(
                    "speech_guard_seconds must be between 0 (off) and {MAX_SPEECH_GUARD_SECONDS}, found {g}"
                ),
            ));
        }
        let s = self.min_strength;
        if !(s.is_finite() && (0.0..=1.0).contains(&s)) {
            return Err(invalid(
                &spectral,
                format!("min_strength must be between 0 (any level) and 1, found {s}"),
            ));
        }
        let m = self.max_pattern_seconds;
        if !(m.is_finite() && (0.05..=60.0).contains(&m)) {
            return Err(invalid(
                &item,
                format!("max_pattern_seconds must be between 0.05 and 60, found {m}"),
            ));
        }
        Ok(())
    }
}

/// The pattern `key` of section `item` names, or an error saying it is not defined.
fn find_pattern<'a>(
    patterns: &'a [PatternSpec],
    item: &str,
    key: &str,
    name: &str,
) -> Result<&'a PatternSpec, ConfigError> {
    patterns.iter().find(|p| p.name == name).ok_or_else(|| {
        invalid(
            item,
            format!("{key} names pattern '{name}', which is not defined"),
        )
    })
}

impl RawBounce {
    fn validate(self, patterns: &[PatternSpec], item: &str) -> Result<BounceSettings, ConfigError> {
        let gravity = self.gravity.unwrap_or(DEFAULT_GRAVITY);
        if !(gravity.is_finite() && gravity > 0.0) {
            return Err(invalid(
                item,
                format!("gravity must be a positive number (m/s²), found {gravity}"),
            ));
        }
        let max_squash = self.max_squash.unwrap_or(DEFAULT_MAX_SQUASH);
        if !(max_squash.is_finite() && (0.0..1.0).contains(&max_squash)) {
            return Err(invalid(
                item,
                format!("max_squash must be at least 0 and below 1, found {max_squash}"),
            ));
        }
        let default_interval_seconds = self
            .default_interval_seconds
            .unwrap_or(DEFAULT_INTERVAL_SECONDS);
        check_seconds(
            item,
            "default_interval_seconds",
            default_interval_seconds,
            0.05,
            10.0,
        )?;
        let state_delay_seconds = self.state_delay_seconds;
        if let Some(d) = state_delay_seconds {
            check_seconds(item, "state_delay_seconds", d, 0.0, 5.0)?;
        }
        let mut styles = BTreeMap::new();
        for (key, names, style, kind) in [
            ("hard", self.hard, ContactStyle::Hard, PatternKind::Impulse),
            ("soft", self.soft, ContactStyle::Soft, PatternKind::Impulse),
            (
                "slide",
                self.slide,
                ContactStyle::Slide,
                PatternKind::Continuous,
            ),
        ] {
            for name in names {
                let p = find_pattern(patterns, item, key, &name)?;
                if p.kind != kind {
                    return Err(invalid(
                        item,
                        format!(
                            "{key} expects {} patterns, but '{name}' is {}",
                            kind.as_str(),
                            p.kind.as_str()
                        ),
                    ));
                }
                if styles.insert(name.clone(), style).is_some() {
                    return Err(invalid(
                        item,
                        format!("pattern '{name}' is given more than one contact style"),
                    ));
                }
            }
        }
        Ok(BounceSettings {
            gravity,
            styles,
            max_squash,
            default_interval_seconds,
            state_delay_seconds,
        })
    }
}

impl RawRender {
    fn validate(self, patterns: &[PatternSpec], item: &str) -> Result<RenderSettings, ConfigError> {
        fn check_actions<A: SceneAction>(
            key: &str,
            actions: &Option<BTreeMap<String, A>>,
            patterns: &[PatternSpec],
            item: &str,
        ) -> Result<(), ConfigError> {
            for (name, action) in actions.iter().flatten() {
                let p = find_pattern(patterns, item, key, name)?;
                if p.kind != action.kind() {
                    return Err(invalid(
                        item,
                        format!(
                            "{key}: '{name}' cannot {}: that action is made by {} patterns, and '{name}' is {}",
                            action.name(),
                            action.kind().as_str(),
                            p.kind.as_str()
                        ),
                    ));
                }
            }
            Ok(())
        }
        check_actions("darts", &self.darts, patterns, item)?;
        check_actions("laser", &self.laser, patterns, item)?;
        for name in self.rain.iter().flatten() {
            if find_pattern(patterns, item, "rain", name)?.kind != PatternKind::Impulse {
                return Err(invalid(
                    item,
                    format!("rain: '{name}' cannot drop a drop: drops are made by impulse patterns, and '{name}' is continuous"),
                ));
            }
        }
        let mut tracks = Vec::with_capacity(self.track.len());
        for (i, t) in self.track.into_iter().enumerate() {
            let key = format!("track #{}", i + 1);
            if t.patterns.is_empty() {
                return Err(invalid(
                    item,
                    format!("{key}: patterns is empty; expected the names of the patterns its soundtrack is searched for"),
                ));
            }
            for name in &t.patterns {
                find_pattern(patterns, item, &key, name)?;
            }
            tracks.push(t.patterns);
        }
        Ok(RenderSettings {
            scene: self.scene,
            darts: self.darts,
            laser: self.laser,
            rain: self.rain,
            tracks,
        })
    }
}

/// Parses `NAME=FILE.wav` or `NAME=FILE.wav:continuous` (or `:impulse`). Repeating a
/// name adds a take to it.
pub fn parse_pattern_args(args: &[String]) -> Result<Vec<PatternSpec>, ConfigError> {
    let mut specs: Vec<PatternSpec> = Vec::new();
    for arg in args {
        let fail = |message: String| ConfigError::PatternArg {
            spec: arg.clone(),
            message,
        };
        let Some((name, rest)) = arg.split_once('=') else {
            return Err(fail(
                "expected NAME=FILE.wav or NAME=FILE.wav:continuous, found no '='".into(),
            ));
        };
        check_pattern_name(name).map_err(fail)?;
        let (file, kind) = if let Some(f) = rest.strip_suffix(":continuous") {
            (f, PatternKind::Continuous)
        } else if let Some(f) = rest.strip_suffix(":impulse") {
            (f, PatternKind::Impulse)
        } else {
            (rest, PatternKind::Impulse)
        };
        if file.is_empty() {
            return Err(fail("the file name after '=' is empty".into()));
        }
        match specs.iter_mut().find(|s| s.name == name) {
            Some(existing) if existing.kind != kind => {
                return Err(fail(format!(
                    "pattern '{name}' was given as {} before, and as {} here",
                    existing.kind.as_str(),
                    kind.as_str()
                )))
            }
            Some(existing) => existing.takes.push(PathBuf::from(file)),
            None => specs.push(PatternSpec {
                name: name.to_string(),
                kind,
                takes: vec![PathBuf::from(file)],
                ..PatternSpec::default()
            }),
        }
    }
    Ok(specs)
}
