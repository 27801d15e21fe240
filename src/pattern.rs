//! Enrolled patterns: each configured take is read, mixed to mono, resampled to the
//! working rate, checked (empty, silent, too short, too long) and trimmed of the silence
//! around the sound.
//!
//! Runs on the main thread when a detector is built; never on the audio path.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::audio::{self, AudioError, ChannelSelect, WavSource};
use crate::config::{DetectorSettings, Method, PatternKind, PatternSpec};

/// A take quieter than this (peak, dBFS) is refused as silent...
pub const SILENT_PEAK_DBFS: f64 = -60.0;
/// ...or, over this (16-bit audio's step is -90 dBFS), as too quiet, with the remedy.
const NOTHING_PEAK_DBFS: f64 = -80.0;
/// Leading and trailing samples quieter than this, relative to the take's peak, are cut.
pub const TRIM_BELOW_PEAK_DB: f64 = -50.0;
/// A take shorter than this after trimming is refused: a spike of a few samples (a
/// glitch of the interface) rather than a sound. The shortest sounds a mouth makes,
/// tongue and lip clicks, last a few milliseconds, and a click of 4 ms is a take like
/// any other (`tests/spectral.rs`, `a_click_of_4_ms_enrols_and_each_one_is_found`).
pub const MIN_TAKE_SECONDS: f64 = 0.002;

#[derive(Debug, thiserror::Error)]
pub enum PatternError {
    #[error("pattern '{pattern}': {cause}")]
    Audio { pattern: String, cause: AudioError },
    #[error("pattern '{pattern}': take '{}' {problem}", path.display())]
    BadTake {
        pattern: String,
        path: PathBuf,
        problem: String,
    },
}

/// One enrolment take at the working rate.
#[derive(Debug, Clone, PartialEq)]
pub struct Take {
    pub source: PathBuf,
    /// Mono samples at the working rate, DC removed, trimmed.
    pub samples: Vec<f32>,
    /// The rate it was recorded at: nothing above its Nyquist frequency is in it.
    pub recorded_rate: u32,
}

impl Take {
    /// Sum of squares of the samples.
    pub fn energy(&self) -> f64 {
        self.samples
            .iter()
            .map(|&x| f64::from(x) * f64::from(x))
            .sum()
    }
}

/// A pattern with its takes loaded.
#[derive(Debug, Clone, PartialEq)]
pub struct Pattern {
    pub name: Arc<str>,
    pub kind: PatternKind,
    pub takes: Vec<Take>,
    pub threshold: f64,
    pub continuous_threshold: f64,
}

impl Pattern {
    /// Loads every take of `spec` for the detector settings `settings`.
    pub fn load(spec: &PatternSpec, settings: &DetectorSettings) -> Result<Self, PatternError> {
        let takes = spec
            .takes
            .iter()
            .map(|path| load_take(&spec.name, path, settings))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            name: Arc::from(spec.name.as_str()),
            kind: spec.kind,
            takes,
            threshold: spec.threshold.unwrap_or(settings.threshold()),
            continuous_threshold: spec
                .continuous_threshold
                .unwrap_or(settings.continuous_threshold),
        })
    }

    /// Builds a pattern from samples already at the working rate (tests, benchmarks,
    /// recordings made in memory). The samples get the same DC removal and trimming as a
    /// file, and the same checks.
    pub fn from_samples(
        name: &str,
        kind: PatternKind,
        takes: Vec<Vec<f32>>,
        settings: &DetectorSettings,
    ) -> Result<Self, PatternError> {
        let takes = takes
            .into_iter()
            .enumerate()
            .map(|(i, samples)| {
                let source = PathBuf::from(format!("<take {}>", i + 1));
                prepare_take(name, &source, samples, settings.sample_rate, settings)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self {
            name: Arc::from(name),
            kind,
            takes,
            threshold: settings.threshold(),
            continuous_threshold: settings.continuous_threshold,
        })
    }

    /// Length of the longest take, in working-rate samples.
    pub fn max_len(&self) -> usize {
        self.takes
            .iter()
            .map(|t| t.samples.len())
            .max()
            .unwrap_or(0)
    }
}

/// Loads all patterns of a config.
pub fn load_patterns(
    specs: &[PatternSpec],
    settings: &DetectorSettings,
) -> Result<Vec<Pattern>, PatternError> {
    specs.iter().map(|s| Pattern::load(s, settings)).collect()
}

fn load_take(
    pattern: &str,
    path: &Path,
    settings: &DetectorSettings,
) -> Result<Take, PatternError> {
    let bad = |problem: String| PatternError::BadTake {
        pattern: pattern.to_string(),
        path: path.to_path_buf(),
        problem,
    };
    let audio_err = |cause| PatternError::Audio {
        pattern: pattern.to_string(),
        cause,
    };
    let select = settings
        .channel
        .map_or(ChannelSelect::Mix, ChannelSelect::Index);
    let mut source = WavSource::open(path, select).map_err(audio_err)?;
    let rate = source.sample_rate();
    if rate == 0 {
        return Err(bad("declares a sample rate of 0 Hz".into()));
    }
    let seconds = source.frames_total() as f64 / f64::from(rate);
    if seconds > settings.max_pattern_seconds {
        return Err(bad(format!(
            "is {seconds:.1} s long; a pattern take must be at most {} s (max_pattern_seconds): cut it to the sound",
            settings.max_pattern_seconds
        )));
    }
    let samples = source.read_all().map_err(audio_err)?;
    if samples.is_empty() {
        return Err(bad("holds no audio (0 samples)".into()));
    }
    let samples = audio::resample_clip(&samples, rate, settings.sample_rate).map_err(audio_err)?;
    prepare_take(pattern, path, samples, rate, settings)
}

fn prepare_take(
    pattern: &str,
    path: &Path,
    mut samples: Vec<f32>,
    recorded_rate: u32,
    settings: &DetectorSettings,
) -> Result<Take, PatternError> {
    let bad = |problem: String| PatternError::BadTake {
        pattern: pattern.to_string(),
        path: path.to_path_buf(),
        problem,
    };
    if samples.is_empty() {
        return Err(bad("holds no audio (0 samples)".into()));
    }
    if let Some(i) = samples.iter().position(|x| !x.is_finite()) {
        return Err(bad(format!("holds a non-finite sample at index {i}")));
    }
    let mean = samples.iter().map(|&x| f64::from(x)).sum::<f64>() / samples.len() as f64;
    for x in &mut samples {
        *x -= mean as f32;
    }
    let peak = samples.iter().fold(0.0f32, |m, &x| m.max(x.abs()));
    let peak_db = 20.0 * f64::from(peak).log10();
    if peak_db < SILENT_PEAK_DBFS {
        // Under a few steps of 16-bit audio there is nothing to record louder.
        return Err(bad(if peak_db < NOTHING_PEAK_DBFS {
            format!(
                "is silent (peak {}); a pattern needs a sound louder than {SILENT_PEAK_DBFS} dBFS",
                if peak > 0.0 {
                    format!("{peak_db:.1} dBFS")
                } else {
                    "-inf dBFS".to_string()
                }
            )
        } else {
            format!(
                "is too quiet (peak {peak_db:.1} dBFS); a pattern needs a sound louder than \
                 {SILENT_PEAK_DBFS} dBFS: record it again with more input gain (the stream \
                 is heard through the same gain)"
            )
        }));
    }
    let floor = peak * 10f32.powf((TRIM_BELOW_PEAK_DB / 20.0) as f32);
    let first = samples.iter().position(|x| x.abs() > floor).unwrap_or(0);
    let last = samples.iter().rposition(|x| x.abs() > floor).unwrap_or(0);
    let samples = samples[first..=last].to_vec();
    let seconds = samples.len() as f64 / f64::from(settings.sample_rate);
    if seconds < MIN_TAKE_SECONDS {
        return Err(bad(format!(
            "is only {:.1} ms long after trimming silence; a pattern take must last at least {} ms",
            seconds * 1000.0,
            MIN_TAKE_SECONDS * 1000.0
        )));
    }
    if seconds > settings.max_pattern_seconds {
        return Err(bad(format!(
            "is {seconds:.1} s long; a pattern take must be at most {} s (max_pattern_seconds): cut it to the sound",
            settings.max_pattern_seconds
        )));
    }
    Ok(Take {
        source: path.to_path_buf(),
        samples,
        recorded_rate,
    })
}

/// Two patterns whose takes are this alike over the decision window are warned of.
/// On the real recordings of `examples/eval_beatbox.rs` (`--verbose` prints every
/// pair), every pair at 0.47 or more but four was taken one for the other at times (tom
/// and cymbal 0.68, closed and open hi-hat 0.62, two snares 0.61 and 0.56, kick and lip
/// buzz 0.47); the four (0.50-0.61) were not. Below 0.45, one sound was: a tom taken
/// once for a hi-hat (0.06).
const LOOK_ALIKE_SIMILARITY: f32 = 0.45;

/// Two patterns whose takes look alike over the spectral method's decision window.
#[derive(Debug, Clone, PartialEq)]
pub struct LookAlike {
    pub first: Arc<str>,
    pub second: Arc<str>,
    /// Best similarity of their takes, 1 for the same.
    pub similarity: f32,
    /// The decision window, seconds.
    pub window_seconds: f64,
    /// When they part later: how much of a sound a choice between them hears, seconds
    /// from its onset (the decision waits for it).
    pub decided_after_seconds: Option<f64>,
}

impl LookAlike {
    /// Whether `name` is one of the two.
    pub fn involves(&self, name: &str) -> bool {
        &*self.first == name || &*self.second == name
    }
}

impl std::fmt::Display for LookAlike {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "patterns '{}' and '{}' look alike over their first {:.0} ms (similarity {:.2} \
             of 1)",
            self.first,
            self.second,
            self.window_seconds * 1000.0,
            self.similarity
        )?;
        // A pair that parts later is decided later: the wait is the user's to know.
        if let Some(after) = self.decided_after_seconds {
            write!(
                f,
                " and part later: the spectral method waits {:.0} ms after such a sound's \
                 onset to tell which it is (max_decision_seconds); sounds that differ from \
                 their start are decided sooner",
                after * 1000.0
            )
        } else {
            write!(
                f,
                ": the spectral method may take one for the other; make the sounds more \
                 different, or enrol more takes of each"
            )
        }
    }
}

/// With the spectral method, the top of the highest band compared (Hz) when `patterns`'
/// takes carry less than the full band (recorded at a low rate, or band-limited on their
/// way in); `None` when they carry every band, and with the waveform method.
pub fn takes_carry_under_hz(patterns: &[Pattern], settings: &DetectorSettings) -> Option<f64> {
    if settings.method != Method::Spectral {
        return None;
    }
    // An input at the working rate carries every band: the takes alone decide.
    crate::detect::spectral::compared_top_hz(patterns, settings, settings.sample_rate)
}

/// How near one another an impulse pattern's takes lie (`check` and `record` say so).
#[derive(Debug, Clone, PartialEq)]
pub struct TakesSpread {
    pub pattern: Arc<str>,
    pub takes: usize,
    /// The least over its takes of each one's score, left out, against the others.
    pub agree: f32,
    /// The take that scored it: the least typical.
    pub least_typical: PathBuf,
}

impl std::fmt::Display for TakesSpread {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "pattern '{}': its {} takes agree at {:.2}, the least typical '{}'; tracking learns only from sounds as near them",
            self.pattern,
            self.takes,
            self.agree,
            self.least_typical.display()
        )
    }
}

/// An impulse pattern whose takes are one sound repeated (`check` and `record` say so).
#[derive(Debug, Clone, PartialEq)]
pub struct Repeated {
    pub pattern: Arc<str>,
    /// The longest gap between the takes' attacks, seconds.
    pub every_seconds: f64,
}

impl std::fmt::Display for Repeated {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "pattern '{}': one sound repeated, its attacks at most {:.0} ms apart; an instance is one event however many attacks it has, while they come about as close",
            self.pattern,
            self.every_seconds * 1000.0
        )
    }
}

/// What the spectral method makes of `patterns`' takes, for `check` and `record`.
#[derive(Debug, Default)]
pub struct TakesReport {
    /// The pairs of patterns whose takes look alike over the decision window (most
    /// alike first), which the method may take for each other.
    pub look_alike: Vec<LookAlike>,
    /// How near one another the takes of each impulse pattern with several lie.
    pub spread: Vec<TakesSpread>,
    /// The impulse patterns whose takes are one sound repeated.
    pub repeated: Vec<Repeated>,
}

/// With the spectral method, what it makes of `patterns`' takes ([`TakesReport`]), from
/// one detector built on them; nothing with the waveform method.
pub fn takes_report(
    patterns: &[Pattern],
    settings: &DetectorSettings,
) -> Result<TakesReport, crate::detect::DetectError> {
    if settings.method != Method::Spectral {
        return Ok(TakesReport::default());
    }
    // How alike the takes are does not depend on the background recordings: they are
    // not read and pooled again here.
    let takes_only = DetectorSettings {
        background: Vec::new(),
        ..settings.clone()
    };
    let detector = crate::Detector::new(patterns.to_vec(), &takes_only, settings.sample_rate)?;
    let look_alike = detector
        .look_alike_patterns(LOOK_ALIKE_SIMILARITY)
        .into_iter()
        .map(|pair| LookAlike {
            first: pair.first,
            second: pair.second,
            similarity: pair.similarity,
            window_seconds: settings.decision_seconds,
            decided_after_seconds: pair.decided_after_seconds,
        })
        .collect();
    let spread = detector
        .takes_agreement()
        .into_iter()
        .zip(patterns)
        .filter_map(|(agree, p)| {
            let agree = agree?;
            Some(TakesSpread {
                pattern: p.name.clone(),
                takes: p.takes.len(),
                agree: agree.score,
                least_typical: p.takes.get(agree.least_typical)?.source.clone(),
            })
        })
        .collect();
    let repeated = detector
        .repeats_every_seconds()
        .into_iter()
        .zip(patterns)
        .filter_map(|(every, p)| {
            Some(Repeated {
                pattern: p.name.clone(),
                every_seconds: every?,
            })
        })
        .collect();
    Ok(TakesReport {
        look_alike,
        spread,
        repeated,
    })
}
