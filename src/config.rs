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
    #[default]
    Waveform,
    /// Log-mel frames matched a few tens of milliseconds after each onset.
    Spectral,
}

/// Bounce style of a contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactStyle {
    Hard,
    Soft,
    Slide,
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
}

#[derive(Debug, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct RawDetector {
    method: Option<Method>,
    sample_rate: Option<u32>,
    threshold: Option<f64>,
    continuous_threshold: Option<f64>,
    suppression_seconds: Option<f64>,
    max_pattern_seconds: Option<f64>,
    channel: Option<u16>,
    decision_seconds: Option<f64>,
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
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBounce {
    gravity: Option<f64>,
    #[serde(default)]
    hard: Vec<String>,
    #[serde(default)]
    soft: Vec<String>,
    #[serde(default)]
    slide: Vec<String>,
    max_squash: Option<f64>,
}

// ---------------------------------------------------------------- validated

/// Detector settings, validated.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectorSettings {
    pub method: Method,
    /// Working sample rate: every input is resampled to it.
    pub sample_rate: u32,
    /// Match threshold for patterns that do not set their own (paper: 0.5).
    pub threshold: f64,
    /// Lower threshold that holds a continuous event (on the smoothed match score).
    pub continuous_threshold: f64,
    /// Half-width of the window in which a greater match suppresses an instance.
    /// `None`: half the pattern's length, as in the paper.
    pub suppression_seconds: Option<f64>,
    /// Longest pattern take accepted.
    pub max_pattern_seconds: f64,
    /// Spectral method: how long after an onset the sound is classified.
    pub decision_seconds: f64,
    /// Channel of multi-channel inputs (`None`: mix all channels). Mono files are used
    /// as they are.
    pub channel: Option<u16>,
}

impl Default for DetectorSettings {
    fn default() -> Self {
        Self {
            method: Method::Waveform,
            sample_rate: 22_050,
            threshold: 0.5,
            continuous_threshold: 0.3,
            suppression_seconds: None,
            max_pattern_seconds: 5.0,
            channel: None,
            decision_seconds: 0.025,
        }
    }
}

/// One pattern as configured (its takes not yet loaded).
#[derive(Debug, Clone, PartialEq)]
pub struct PatternSpec {
    pub name: String,
    pub kind: PatternKind,
    pub takes: Vec<PathBuf>,
    pub threshold: Option<f64>,
    pub continuous_threshold: Option<f64>,
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
        }
    }
}

pub const DEFAULT_GRAVITY: f64 = 9.81;
pub const DEFAULT_MAX_SQUASH: f64 = 0.4;

/// A validated configuration.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Config {
    pub detector: DetectorSettings,
    pub patterns: Vec<PatternSpec>,
    /// `None` when the file has no `[bounce]` section.
    pub bounce: Option<BounceSettings>,
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
        for p in &self.patterns {
            check_thresholds(
                &format!("{origin}, pattern '{}'", p.name),
                p,
                &self.detector,
            )?;
        }
        Ok(())
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
        let detector = DetectorSettings {
            method: d.method.unwrap_or(defaults.method),
            sample_rate: d.sample_rate.unwrap_or(defaults.sample_rate),
            threshold: d.threshold.unwrap_or(defaults.threshold),
            continuous_threshold: d
                .continuous_threshold
                .unwrap_or(defaults.continuous_threshold),
            suppression_seconds: d.suppression_seconds,
            max_pattern_seconds: d
                .max_pattern_seconds
                .unwrap_or(defaults.max_pattern_seconds),
            channel: d.channel,
            decision_seconds: d.decision_seconds.unwrap_or(defaults.decision_seconds),
        };
        detector.validate(origin)?;

        let mut patterns: Vec<PatternSpec> = Vec::with_capacity(self.pattern.len());
        for (i, p) in self.pattern.into_iter().enumerate() {
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
            };
            check_thresholds(&item, &spec, &detector)?;
            patterns.push(spec);
        }

        let bounce = match self.bounce {
            None => None,
            Some(b) => Some(b.validate(&patterns, &format!("{origin}, [bounce]"))?),
        };
        Ok(Config {
            detector,
            patterns,
            bounce,
        })
    }
}

fn check_thresholds(
    item: &str,
    spec: &PatternSpec,
    detector: &DetectorSettings,
) -> Result<(), ConfigError> {
    if spec.kind != PatternKind::Continuous {
        return Ok(());
    }
    let high = spec.threshold.unwrap_or(detector.threshold);
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

impl DetectorSettings {
    /// Checks every field; `origin` names the source in messages.
    pub fn validate(&self, origin: &str) -> Result<(), ConfigError> {
        let item = format!("{origin}, [detector]");
        if !(8_000..=192_000).contains(&self.sample_rate) {
            return Err(invalid(
                &item,
                format!(
                    "sample_rate must be between 8000 and 192000 Hz, found {}",
                    self.sample_rate
                ),
            ));
        }
        check_unit_interval(&item, "threshold", self.threshold)?;
        check_unit_interval(&item, "continuous_threshold", self.continuous_threshold)?;
        if let Some(s) = self.suppression_seconds {
            if !(s.is_finite() && (0.0..=5.0).contains(&s)) {
                return Err(invalid(
                    &item,
                    format!("suppression_seconds must be between 0 and 5, found {s}"),
                ));
            }
        }
        let d = self.decision_seconds;
        if !(d.is_finite() && (0.015..=0.2).contains(&d)) {
            return Err(invalid(
                &item,
                format!("decision_seconds must be between 0.015 and 0.2, found {d}"),
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
                let Some(p) = patterns.iter().find(|p| p.name == name) else {
                    return Err(invalid(
                        item,
                        format!("{key} names pattern '{name}', which is not defined"),
                    ));
                };
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
                threshold: None,
                continuous_threshold: None,
            }),
        }
    }
    Ok(specs)
}
