//! Offline analysis: a recording is read block by block and fed to the same streaming
//! [`Detector`] the daemon uses, as fast as it goes; the events (and, on request, the
//! bounce solution) are written as JSON or CSV.
//!
//! Runs on the main thread of `onomato analyze`.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::audio::{AudioError, ChannelSelect, WavSource};
use crate::config::Config;
use crate::detect::waveform::TakeTrace;
use crate::detect::{DetectError, Detector, Event, HeldEndRecord, MatchedBy, OnsetRecord, Taught};
use crate::pattern::{self, PatternError};
use crate::solver::{self, Contact};

/// Frames read from the file per block.
pub const READ_BLOCK_FRAMES: usize = 4096;

#[derive(Debug, thiserror::Error)]
pub enum AnalyzeError {
    #[error("recording: {0}")]
    Recording(AudioError),
    #[error("recording '{}' holds no audio (0 samples)", .0.display())]
    EmptyRecording(PathBuf),
    #[error(transparent)]
    Pattern(#[from] PatternError),
    #[error(transparent)]
    Detect(#[from] DetectError),
}

/// What an analysis found.
#[derive(Debug, Clone)]
pub struct Analysis {
    pub events: Vec<Event>,
    /// Length of the recording, seconds.
    pub duration: f64,
    pub sample_rate: u32,
    /// Each take's match score over time, when asked for (waveform method).
    pub score_traces: Option<Vec<TakeTrace>>,
    /// The match threshold of each pattern, by name.
    pub thresholds: Vec<(std::sync::Arc<str>, f64)>,
    /// The detector's working rate (of the score traces).
    pub working_rate: u32,
    /// Spectral method, when asked for: every onset considered and what became of it...
    pub onsets: Option<Vec<OnsetRecord>>,
    /// ...and how each held sound that fired ended.
    pub held_ends: Option<Vec<HeldEndRecord>>,
    /// Spectral method: the top of the bands compared (Hz) when the recording or the
    /// takes carry less than the full band.
    pub compared_top_hz: Option<f64>,
}

/// What an analysis keeps besides the events.
#[derive(Debug, Clone, Copy, Default)]
pub struct Keep {
    /// Match scores over time, for a plot (waveform method).
    pub scores: bool,
    /// Every onset considered (spectral method).
    pub onsets: bool,
}

/// Detects `config`'s patterns in the WAV file `recording`.
pub fn analyze_file(recording: &Path, config: &Config) -> Result<Analysis, AnalyzeError> {
    analyze_file_with(recording, config, Keep::default(), &mut |_| {})
}

/// [`analyze_file`], keeping what `keep` asks for; `progress` is called with the
/// fraction of the file read so far.
pub fn analyze_file_with(
    recording: &Path,
    config: &Config,
    keep: Keep,
    progress: &mut dyn FnMut(f64),
) -> Result<Analysis, AnalyzeError> {
    let patterns = pattern::load_patterns(&config.patterns, &config.detector)?;
    let thresholds = patterns
        .iter()
        .map(|p| (p.name.clone(), p.threshold))
        .collect();
    let select = config
        .detector
        .channel
        .map_or(ChannelSelect::Mix, ChannelSelect::Index);
    let mut source = WavSource::open(recording, select).map_err(AnalyzeError::Recording)?;
    let mut detector = Detector::new(patterns, &config.detector, source.sample_rate())?;
    let takes_top_hz = detector.compared_top_hz();
    if let Some(top_hz) = takes_top_hz {
        tracing::info!(
            recording = %recording.display(),
            rate = source.sample_rate(),
            top_hz = top_hz.round(),
            "the recording's rate or the takes carry less than the full band: only the bands under top_hz are compared"
        );
    }
    if keep.scores {
        detector.enable_score_trace();
    }
    if keep.onsets {
        detector.enable_explain();
    }
    let total = source.frames_total().max(1);
    let mut events = Vec::new();
    let mut block = Vec::with_capacity(READ_BLOCK_FRAMES);
    let mut frames = 0u64;
    loop {
        let n = source
            .read_block(READ_BLOCK_FRAMES, &mut block)
            .map_err(AnalyzeError::Recording)?;
        if n == 0 {
            break;
        }
        frames += n as u64;
        detector.process(&block, &mut events);
        progress(frames as f64 / total as f64);
    }
    if frames == 0 {
        return Err(AnalyzeError::EmptyRecording(recording.to_path_buf()));
    }
    detector.finish(&mut events);
    if detector.compared_top_hz() != takes_top_hz {
        if let Some(top_hz) = detector.compared_top_hz() {
            tracing::info!(
                recording = %recording.display(),
                top_hz = top_hz.round(),
                "the recording carries sound up to top_hz only (its loudest sounds fall off a filter's edge into noise): from where it showed it, only the bands under it were compared"
            );
        }
    }
    if detector.bad_samples() > 0 {
        tracing::warn!(
            recording = %recording.display(),
            samples = detector.bad_samples(),
            "samples that were not numbers (taken as 0) or beyond full scale (clamped) were replaced"
        );
    }
    if detector.clipped_samples() > 0 {
        tracing::warn!(
            recording = %recording.display(),
            samples = detector.clipped_samples(),
            "the recording clips: samples reached full scale, and a clipped sound's spectrum is not its take's; record with less gain"
        );
    }
    tracing::info!(
        recording = %recording.display(),
        seconds = frames as f64 / f64::from(source.sample_rate()),
        events = events.len(),
        "analysis done"
    );
    Ok(Analysis {
        events,
        duration: frames as f64 / f64::from(source.sample_rate()),
        sample_rate: source.sample_rate(),
        score_traces: detector.take_score_trace(),
        onsets: detector.take_explain(),
        held_ends: detector.take_held_ends(),
        compared_top_hz: detector.compared_top_hz(),
        thresholds,
        working_rate: config.detector.sample_rate,
    })
}

/// Runs a whole in-memory signal through a detector in blocks of `block` samples
/// (tests, benchmarks, evaluation).
pub fn detect_in_blocks(detector: &mut Detector, signal: &[f32], block: usize) -> Vec<Event> {
    let mut events = Vec::new();
    for chunk in signal.chunks(block.max(1)) {
        detector.process(chunk, &mut events);
    }
    detector.finish(&mut events);
    events
}

#[derive(Serialize)]
struct JsonOutput<'a> {
    events: &'a [Event],
    #[serde(skip_serializing_if = "Option::is_none")]
    bounce: Option<&'a [Contact]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    onsets: Option<&'a [OnsetRecord]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    held_ends: Option<&'a [HeldEndRecord]>,
}

/// What `--explain` adds to the JSON output: every onset considered, and how each held
/// sound ended.
#[derive(Debug, Clone, Copy)]
pub struct Explained<'a> {
    pub onsets: &'a [OnsetRecord],
    pub held_ends: &'a [HeldEndRecord],
}

/// Writes `{"events":[...]}` (and `"bounce":[...]`, `"onsets":[...]` and
/// `"held_ends":[...]` when given) and a newline.
pub fn write_json(
    out: &mut dyn Write,
    events: &[Event],
    bounce: Option<&[Contact]>,
    explained: Option<Explained>,
) -> std::io::Result<()> {
    serde_json::to_writer(
        &mut *out,
        &JsonOutput {
            events,
            bounce,
            onsets: explained.map(|e| e.onsets),
            held_ends: explained.map(|e| e.held_ends),
        },
    )?;
    writeln!(out)
}

/// Writes one line per held sound that fired: its pattern, begin and end, and why it
/// ended (`--explain`, on stderr, after the onsets).
pub fn write_held_ends(out: &mut dyn Write, ends: &[HeldEndRecord]) -> std::io::Result<()> {
    if ends.is_empty() {
        return Ok(());
    }
    writeln!(
        out,
        "{:<12} {:>9}  {:>9}  ended",
        "held sound", "begin s", "end s"
    )?;
    for r in ends {
        writeln!(
            out,
            "{:<12} {:>9.4}  {:>9.4}  {}",
            r.pattern,
            r.time,
            r.end,
            r.ended_by.as_str()
        )?;
    }
    Ok(())
}

/// Writes one line per onset considered: its time, the two patterns it resembled most
/// with their scores, its strength, the nearest background sound's score, its rise
/// (marked `*` when it began over an impulse that fired), over such a word's tail the
/// share of its sound its pattern's takes explain there (`new`), how much of its sound
/// the choice of its pattern heard, what of its best pattern it resembled most (a take,
/// the tracked template or a kept instance), for an impulse that fired what it taught
/// tracking, and what became of it, with the sound held against it when there is one
/// (`--explain`, on stderr).
pub fn write_explain(out: &mut dyn Write, onsets: &[OnsetRecord]) -> std::io::Result<()> {
    writeln!(
        out,
        "{:>9}  {:<12} {:>5}  {:<12} {:>5}  {:>8}  {:>6}  {:>7}  {:>4}  {:>8}  {:<7}  {:<9}  outcome",
        "onset s",
        "best",
        "score",
        "second",
        "score",
        "strength",
        "speech",
        "rise dB",
        "new",
        "heard ms",
        "by",
        "taught"
    )?;
    for r in onsets {
        let name = |n: &Option<std::sync::Arc<str>>| n.as_deref().unwrap_or("-").to_string();
        let num = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{v:.2}"));
        let because_of = r.because_of.map_or(String::new(), |s| {
            if s.to > s.from {
                format!(" ({:.4}-{:.4} s)", s.from, s.to)
            } else {
                format!(" ({:.4} s)", s.from)
            }
        });
        writeln!(
            out,
            "{:>9.4}  {:<12} {:>5}  {:<12} {:>5}  {:>8}  {:>6}  {:>7}  {:>4}  {:>8}  {:<7}  {:<9}  {}{}{}",
            r.time,
            name(&r.best),
            num(r.best_score),
            name(&r.second),
            num(r.second_score),
            num(r.strength),
            num(r.background_score),
            r.rise_db.map_or("-".to_string(), |v| {
                let over_a_word = if r.over_fired_impulse { "*" } else { "" };
                format!("{v:.1}{over_a_word}")
            }),
            num(r.explained_over_tail),
            r.window_seconds
                .map_or("-".to_string(), |v| format!("{:.0}", 1000.0 * v)),
            r.matched_by.map_or("-", MatchedBy::as_str),
            r.taught.map_or("-", Taught::as_str),
            r.outcome.as_str(),
            if r.guard_by_stopped_speech { "*" } else { "" },
            because_of,
        )?;
    }
    Ok(())
}

/// Header of the CSV output.
pub const CSV_HEADER: &str = "id,pattern,kind,time,end,strength,score,emitted_at,pitch";

/// Writes a header and one row per event. Pattern names cannot hold commas or quotes
/// (see [`crate::config::check_pattern_name`]), so no quoting is needed.
pub fn write_csv(out: &mut dyn Write, events: &[Event]) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")?;
    for e in events {
        let end = e.end.map(|x| format!("{x:.5}")).unwrap_or_default();
        let pitch = e.pitch.map(|x| format!("{x:.1}")).unwrap_or_default();
        writeln!(
            out,
            "{},{},{},{:.5},{},{:.4},{:.4},{:.5},{}",
            e.id,
            e.pattern,
            e.kind.as_str(),
            e.time,
            end,
            e.strength,
            e.score,
            e.emitted_at,
            pitch
        )?;
    }
    Ok(())
}

/// Bounce contacts for an analysis.
pub fn bounce(events: &[Event], config: &Config) -> Vec<Contact> {
    solver::solve(events, &config.bounce_or_default())
}
