//! The one streaming detection core. [`Detector`] takes mono audio at the input rate in
//! blocks of any size, resamples it to the working rate, runs the configured matcher and
//! appends finished [`Event`]s to the caller's vector. `analyze` feeds it a file as fast
//! as it can; the daemon feeds it the microphone. The cut of the input into blocks does
//! not change any event, `emitted_at` included: every decision is taken at a fixed point
//! of the stream (a resampler chunk or a matcher segment), never at a block's end.
//!
//! Runs on the caller's thread (the detector thread in the daemon). After construction,
//! [`Detector::process`] allocates nothing, provided the caller's event vector has room.

mod envelope;
pub mod spectral;
pub mod waveform;

use std::sync::Arc;

use serde::{Serialize, Serializer};

use crate::audio::{AudioError, StreamResampler};
use crate::config::{DetectorSettings, Method, PatternKind};
use crate::pattern::Pattern;
pub use spectral::SpectralMatcher;
pub use waveform::WaveformMatcher;

/// The matcher a detector runs.
enum Matcher {
    Waveform(WaveformMatcher),
    Spectral(SpectralMatcher),
}

impl Matcher {
    fn push(&mut self, samples: &[f32], out: &mut Vec<Event>) {
        match self {
            Matcher::Waveform(m) => m.push(samples, out),
            Matcher::Spectral(m) => m.push(samples, out),
        }
    }

    fn finish(&mut self, out: &mut Vec<Event>) {
        match self {
            Matcher::Waveform(m) => m.finish(out),
            Matcher::Spectral(m) => m.finish(out),
        }
    }
}

/// One detected instance of a pattern. The same record is printed by `analyze`, sent by
/// the daemon and read by tools. Times are seconds from the start of the stream.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Event {
    /// Sequence number in the order of decision, from 0.
    pub id: u64,
    pub pattern: Arc<str>,
    pub kind: PatternKind,
    /// Onset of the instance.
    #[serde(serialize_with = "seconds")]
    pub time: f64,
    /// End of a continuous instance.
    #[serde(
        skip_serializing_if = "Option::is_none",
        serialize_with = "opt_seconds"
    )]
    pub end: Option<f64>,
    /// sqrt(energy(x) / energy(pattern)) over the instance (per sample for continuous
    /// instances): 1 for the pattern at its enrolled level.
    #[serde(serialize_with = "ratio")]
    pub strength: f64,
    /// Match score that led to the decision (1 is a perfect match).
    #[serde(serialize_with = "ratio")]
    pub score: f64,
    /// Stream time at which the detector decided.
    #[serde(serialize_with = "seconds")]
    pub emitted_at: f64,
    /// Fundamental frequency of a held voiced sound, Hz (spectral method; absent for
    /// impulses and unvoiced sounds).
    #[serde(skip_serializing_if = "Option::is_none", serialize_with = "opt_hertz")]
    pub pitch: Option<f64>,
}

fn round_to(x: f64, digits: i32) -> f64 {
    let scale = 10f64.powi(digits);
    (x * scale).round() / scale
}

pub(crate) fn seconds<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(round_to(*x, 5))
}

pub(crate) fn opt_seconds<S: Serializer>(x: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match x {
        Some(v) => s.serialize_f64(round_to(*v, 5)),
        None => s.serialize_none(),
    }
}

fn opt_hertz<S: Serializer>(x: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match x {
        Some(v) => s.serialize_f64(round_to(*v, 1)),
        None => s.serialize_none(),
    }
}

pub(crate) fn ratio<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(round_to(*x, 4))
}

#[derive(Debug, thiserror::Error)]
pub enum DetectError {
    #[error("no patterns are configured: give --pattern NAME=FILE.wav or a config with [[pattern]] entries")]
    NoPatterns,
    #[error("input sample rate {0} Hz is not usable; expected 1000 to 768000 Hz")]
    InputRate(u32),
    #[error(transparent)]
    Audio(#[from] AudioError),
}

/// The streaming detector: resampler, matcher, event numbering.
pub struct Detector {
    input_rate: u32,
    resampler: Option<StreamResampler>,
    matcher: Matcher,
    next_id: u64,
    input_consumed: u64,
}

impl Detector {
    /// Builds a detector for `patterns` (already at `settings.sample_rate`) that takes
    /// input at `input_rate`. FFT plans and every buffer are made here.
    pub fn new(
        patterns: Vec<Pattern>,
        settings: &DetectorSettings,
        input_rate: u32,
    ) -> Result<Self, DetectError> {
        if patterns.is_empty() {
            return Err(DetectError::NoPatterns);
        }
        if !(1_000..=768_000).contains(&input_rate) {
            return Err(DetectError::InputRate(input_rate));
        }
        let matcher = match settings.method {
            Method::Waveform => Matcher::Waveform(WaveformMatcher::new(patterns, settings)),
            Method::Spectral => Matcher::Spectral(SpectralMatcher::new(patterns, settings)),
        };
        let resampler = if input_rate == settings.sample_rate {
            None
        } else {
            Some(StreamResampler::new(input_rate, settings.sample_rate)?)
        };
        Ok(Self {
            input_rate,
            resampler,
            matcher,
            next_id: 0,
            input_consumed: 0,
        })
    }

    /// Input sample rate this detector was built for.
    pub fn input_rate(&self) -> u32 {
        self.input_rate
    }

    /// Stream time consumed so far, in seconds.
    pub fn stream_seconds(&self) -> f64 {
        self.input_consumed as f64 / f64::from(self.input_rate)
    }

    /// Keeps every match-score value (per pattern take) from now on, for plots and tests.
    /// Grows with the stream: for offline use only.
    /// (Waveform method only.)
    pub fn enable_score_trace(&mut self) {
        if let Matcher::Waveform(m) = &mut self.matcher {
            m.enable_score_trace();
        }
    }

    /// The recorded match scores: one curve per take, at the working rate.
    pub fn score_trace(&self) -> Option<&[waveform::TakeTrace]> {
        match &self.matcher {
            Matcher::Waveform(m) => m.score_trace(),
            Matcher::Spectral(_) => None,
        }
    }

    /// Consumes one block of mono input and appends the events decided meanwhile.
    pub fn process(&mut self, block: &[f32], out: &mut Vec<Event>) {
        let first = out.len();
        self.input_consumed += block.len() as u64;
        let input_rate = f64::from(self.input_rate);
        let Self {
            resampler, matcher, ..
        } = self;
        match resampler {
            None => matcher.push(block, out),
            Some(r) => r.push(block, &mut |piece, consumed| {
                push_resampled(matcher, out, piece, consumed as f64 / input_rate)
            }),
        }
        self.number(&mut out[first..]);
    }

    /// Ends the stream: flushes what is buffered and decides every pending instance.
    pub fn finish(&mut self, out: &mut Vec<Event>) {
        let first = out.len();
        let input_rate = f64::from(self.input_rate);
        let Self {
            resampler, matcher, ..
        } = self;
        if let Some(r) = resampler {
            r.finish(&mut |piece, consumed| {
                push_resampled(matcher, out, piece, consumed as f64 / input_rate)
            });
        }
        let start = out.len();
        matcher.finish(out);
        if self.resampler.is_some() {
            stamp(&mut out[start..], self.input_consumed as f64 / input_rate);
        }
        self.number(&mut out[first..]);
    }

    fn number(&mut self, events: &mut [Event]) {
        for e in events {
            e.id = self.next_id;
            self.next_id += 1;
        }
    }
}

/// At the end of a stream of `end_s` seconds (matchers pad it with silence to take
/// their last decisions): drops events that begin in the padding, and clamps ends and
/// decision times to the stream's end.
fn keep_within(events: &mut Vec<Event>, end_s: f64) {
    events.retain_mut(|e| {
        if let Some(end) = e.end.as_mut() {
            *end = end.min(end_s);
        }
        e.emitted_at = e.emitted_at.min(end_s);
        e.time < end_s
    });
}

/// Feeds a piece the resampler released: whatever the matcher decides on it was
/// decided when the input that completed the piece arrived (`emitted_at`, seconds).
fn push_resampled(matcher: &mut Matcher, out: &mut Vec<Event>, piece: &[f32], emitted_at: f64) {
    let start = out.len();
    matcher.push(piece, out);
    stamp(&mut out[start..], emitted_at);
}

fn stamp(events: &mut [Event], emitted_at: f64) {
    for e in events {
        e.emitted_at = emitted_at;
    }
}
