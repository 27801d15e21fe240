//! The one streaming detection core. [`Detector`] takes mono audio at the input rate in
//! blocks of any size, resamples it to the working rate, runs the configured matcher and
//! appends finished [`Event`]s to the caller's vector. `analyze` feeds it a file as fast
//! as it can; the daemon feeds it the microphone. The cut of the input into blocks does
//! not change any event, `emitted_at` included: every decision is taken at a fixed point
//! of the stream (a resampler chunk or a matcher segment), never at a block's end.
//!
//! Runs on the caller's thread (the detector thread in the daemon). After construction,
//! [`Detector::process`] allocates nothing, provided the caller's event vector has room.

mod ablation;
pub mod background;
mod classify;
mod context;
mod copies;
mod enrol;
mod envelope;
mod explain;
mod features;
mod fifo;
pub mod gates;
mod held;
mod levels;
pub mod onset;
mod passband;
mod pitch;
mod place;
mod recent_min;
pub mod spectral;
mod syllable;
mod talk;
pub mod waveform;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Serialize, Serializer};

use crate::audio::{resample_clip, AudioError, ChannelSelect, StreamResampler, WavSource};
use crate::config::{DetectorSettings, Method, PatternKind};
use crate::pattern::Pattern;
use background::BackgroundModel;
pub use enrol::TakesAgree;
pub use explain::{HeldEndRecord, MatchedBy, OnsetRecord, SoundSpan, Taught, Wait};
pub use gates::Outcome;
pub use held::HeldEnd;
pub use spectral::{AlikePair, SpectralMatcher};
pub use waveform::WaveformMatcher;

/// The seed of the stages' own noise ([`white_noise`]).
pub(crate) const NOISE_SEED: u64 = 0x9E37_79B9_7F4A_7C15;

/// `n` samples of white noise, uniform in ±`amplitude` (power amplitude² / 3), from a
/// xorshift generator seeded with `seed`: the same every run. For the stages' own
/// probes (a take's onset after noise, the onset floors' calibration) and their tests.
pub(crate) fn white_noise(n: usize, amplitude: f32, seed: u64) -> Vec<f32> {
    let mut state = seed | 1;
    (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0) * amplitude
        })
        .collect()
}

/// The matcher a detector runs.
enum Matcher {
    Waveform(Box<WaveformMatcher>),
    Spectral(Box<SpectralMatcher>),
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
    /// Sequence number in the order of recognition, from 0. A continuous event keeps
    /// the number it was given at its begin.
    pub id: u64,
    pub pattern: Arc<str>,
    pub kind: PatternKind,
    /// Onset of the instance.
    #[serde(serialize_with = "seconds")]
    pub time: f64,
    /// End of a continuous instance. A continuous event without an end is a begin
    /// marker: the sound was recognised and goes on (see [`Detector::report_begins`]).
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

pub(crate) fn opt_ratio<S: Serializer>(x: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match x {
        Some(v) => s.serialize_f64(round_to(*v, 4)),
        None => s.serialize_none(),
    }
}

pub(crate) fn opt_db<S: Serializer>(x: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match x {
        Some(v) => s.serialize_f64(round_to(*v, 2)),
        None => s.serialize_none(),
    }
}

#[derive(Debug, thiserror::Error)]
pub enum DetectError {
    #[error("no patterns are configured: give --pattern NAME=FILE.wav or a config with [[pattern]] entries")]
    NoPatterns,
    #[error("input sample rate {0} Hz is not usable; expected 1000 to 768000 Hz")]
    InputRate(u32),
    #[error(transparent)]
    Audio(#[from] AudioError),
    #[error("background recording: {0}")]
    BackgroundAudio(AudioError),
    #[error("background recording '{}' has no sound that stands out of its quiet; expected a recording of what must never fire (you talking, the room), at least a few seconds of it", .0.display())]
    EmptyBackground(PathBuf),
    #[error("background recording '{}' is {seconds:.0} s long; expected at most {MAX_BACKGROUND_SECONDS:.0} s (a minute of talking is plenty): cut it", path.display())]
    LongBackground { path: PathBuf, seconds: f64 },
    #[error("background recording '{}' holds a sample that is not a number at frame {frame}; expected samples between -1 and 1", path.display())]
    BadBackgroundSample { path: PathBuf, frame: usize },
}

/// The longest background recording read: it is read whole and pooled while the
/// detector is built (a minute takes about 60 ms), and a minute of a voice's talking
/// already covers its syllables (`docs/background.md`).
pub const MAX_BACKGROUND_SECONDS: f64 = 300.0;

/// The samples (channel `select`, or the mix) and sample rate of the background
/// recording `path`; one longer than [`MAX_BACKGROUND_SECONDS`] is refused before it is
/// read, one that holds a sample that is not a number (a float file) once read.
pub fn read_background(path: &Path, select: ChannelSelect) -> Result<(Vec<f32>, u32), DetectError> {
    let mut source = WavSource::open(path, select).map_err(DetectError::BackgroundAudio)?;
    let rate = source.sample_rate();
    let seconds = source.frames_total() as f64 / f64::from(rate.max(1));
    if seconds > MAX_BACKGROUND_SECONDS {
        return Err(DetectError::LongBackground {
            path: path.to_path_buf(),
            seconds,
        });
    }
    let samples = source.read_all().map_err(DetectError::BackgroundAudio)?;
    if let Some(frame) = samples.iter().position(|x| !x.is_finite()) {
        return Err(DetectError::BadBackgroundSample {
            path: path.to_path_buf(),
            frame,
        });
    }
    Ok((samples, rate))
}

/// The background recordings of `settings` (spectral method), each pooled as a matcher
/// with `settings` pools onsets ([`spectral::background_model`]), with its path. An
/// error names the file.
pub fn own_background(
    settings: &DetectorSettings,
) -> Result<Vec<(PathBuf, BackgroundModel)>, DetectError> {
    let select = settings
        .channel
        .map_or(ChannelSelect::Mix, ChannelSelect::Index);
    settings
        .background
        .iter()
        .map(|path| {
            let (samples, rate) = read_background(path, select)?;
            let mut samples = resample_clip(&samples, rate, settings.sample_rate)
                .map_err(DetectError::BackgroundAudio)?;
            // Heard as the stream is: its offset taken away.
            let mut dc_block = features::DcBlock::new(f64::from(settings.sample_rate));
            samples.iter_mut().for_each(|x| *x = dc_block.run(*x));
            let model = spectral::background_model(&samples, settings);
            if model.is_empty() {
                return Err(DetectError::EmptyBackground(path.clone()));
            }
            Ok((path.clone(), model))
        })
        .collect()
}

/// The streaming detector: resampler, matcher, event numbering.
pub struct Detector {
    input_rate: u32,
    resampler: Option<StreamResampler>,
    matcher: Matcher,
    next_id: u64,
    input_consumed: u64,
    /// Keep begin markers of continuous events in the output.
    report_begins: bool,
    /// Stream time at which this detector started (a reload continues the stream).
    time_offset: f64,
    /// Per pattern name: the id of its continuous event that has begun and not ended.
    /// Made with one slot per pattern, so updating it does not allocate.
    open_ids: Vec<(Arc<str>, Option<u64>)>,
    /// Input samples after sanitising (see [`Detector::process`]), a block at a time.
    clean: Vec<f32>,
    /// Samples that were not finite or beyond full scale.
    bad_samples: u64,
    /// Samples at full scale, or clamped to it ([`crate::audio::CLIP_LEVEL`]).
    clipped_samples: u64,
    /// The spectral method's: the input's offset taken away ([`features::DcBlock`]), at
    /// the input rate, before the resampler and the stream's end pad it with silence.
    /// The waveform method correlates the samples as they are, as the paper does.
    dc_block: Option<features::DcBlock>,
}

/// Samples are taken in pieces of this many to be sanitised.
const CLEAN_BLOCK: usize = 1024;

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
        let open_ids = patterns.iter().map(|p| (p.name.clone(), None)).collect();
        let matcher = match settings.method {
            Method::Waveform => {
                Matcher::Waveform(Box::new(WaveformMatcher::new(patterns, settings)))
            }
            Method::Spectral => {
                let mut matcher = SpectralMatcher::new(patterns, settings, input_rate);
                for (_, own) in own_background(settings)? {
                    matcher.add_background(&own);
                }
                Matcher::Spectral(Box::new(matcher))
            }
        };
        let dc_block = (settings.method == Method::Spectral)
            .then(|| features::DcBlock::new(f64::from(input_rate)));
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
            report_begins: false,
            time_offset: 0.0,
            open_ids,
            clean: vec![0.0; CLEAN_BLOCK],
            bad_samples: 0,
            clipped_samples: 0,
            dc_block,
        })
    }

    /// Also reports the begin of a continuous event as soon as it is recognised: an
    /// [`Event`] of kind continuous with no `end`, followed later by the complete event
    /// with the same id. The daemon uses it to send `/begin` at once; `analyze` does
    /// not. (The spectral method recognises held sounds at their start; the waveform
    /// method only when they end, so its begin and end come together.)
    pub fn report_begins(&mut self, report: bool) {
        self.report_begins = report;
    }

    /// Spectral method: how near each pattern's takes lie to one another, by pattern
    /// (`None` for a held pattern and one of a single take); empty for the waveform
    /// method.
    pub fn takes_agreement(&self) -> Vec<Option<TakesAgree>> {
        match &self.matcher {
            Matcher::Waveform(_) => Vec::new(),
            Matcher::Spectral(m) => m.takes_agreement(),
        }
    }

    /// Spectral method: by pattern, for one whose takes are one sound repeated (a teeth
    /// chatter, a trill), the longest gap between their attacks, seconds, within which
    /// an instance's next attack continues it; `None` for any other. Empty for the
    /// waveform method.
    pub fn repeats_every_seconds(&self) -> Vec<Option<f64>> {
        match &self.matcher {
            Matcher::Waveform(_) => Vec::new(),
            Matcher::Spectral(m) => m.repeats_every_seconds(),
        }
    }

    /// Spectral method: pairs of patterns whose takes look alike over the decision
    /// window (similarity at least `min_similarity`, 1 for the same), most alike first,
    /// and for a pair that parts later, how much of a sound a choice between them hears
    /// (seconds from the onset). Empty for the waveform method.
    pub fn look_alike_patterns(&self, min_similarity: f32) -> Vec<AlikePair> {
        match &self.matcher {
            Matcher::Waveform(_) => Vec::new(),
            Matcher::Spectral(m) => m.look_alike_patterns(min_similarity),
        }
    }

    /// Spectral method: the top of the highest band compared, in Hz, when the input or
    /// the takes carry less than every band (a 16 kHz input; takes band-limited on their
    /// way in); `None` when every band is, and for the waveform method.
    pub fn compared_top_hz(&self) -> Option<f64> {
        match &self.matcher {
            Matcher::Waveform(_) => None,
            Matcher::Spectral(m) => m.compared_top_hz(),
        }
    }

    /// Longest time from an impulse's onset to its decision (`emitted_at - time`),
    /// seconds, resampling included. Held sounds end later: by the gap that ends them.
    pub fn decision_delay_bound(&self) -> f64 {
        let matcher = match &self.matcher {
            Matcher::Waveform(m) => m.decision_delay_bound(),
            Matcher::Spectral(m) => m.decision_delay_bound(),
        };
        // The resampler hands over fixed chunks, behind a filter of half its length.
        let resampling = if self.resampler.is_some() {
            (crate::audio::RESAMPLER_CHUNK as f64 + crate::audio::RESAMPLER_SINC_LEN as f64)
                / f64::from(self.input_rate)
        } else {
            0.0
        };
        matcher + resampling
    }

    /// Input sample rate this detector was built for.
    pub fn input_rate(&self) -> u32 {
        self.input_rate
    }

    /// Stream time consumed so far, in seconds.
    pub fn stream_seconds(&self) -> f64 {
        self.time_offset + self.input_consumed as f64 / f64::from(self.input_rate)
    }

    /// Makes this detector continue the stream of `previous` (a reload): its events'
    /// times follow on from where `previous` stopped, and their ids too.
    pub fn continue_after(&mut self, previous: &Detector) {
        self.time_offset = previous.stream_seconds();
        self.next_id = previous.next_id;
    }

    /// Keeps every match-score value (per pattern take) from now on, for plots and tests.
    /// Grows with the stream: for offline use only.
    /// (Waveform method only.)
    pub fn enable_score_trace(&mut self) {
        if let Matcher::Waveform(m) = &mut self.matcher {
            m.enable_score_trace();
        }
    }

    /// Spectral method: keeps a record of every onset the detector considers and what
    /// became of it, and of how every held sound that fired ended, from now on (grows
    /// with the stream: for offline use only).
    pub fn enable_explain(&mut self) {
        if let Matcher::Spectral(m) = &mut self.matcher {
            m.enable_explain();
        }
    }

    /// Hands over the onset records (see [`Detector::enable_explain`]), their times on
    /// the stream's clock.
    pub fn take_explain(&mut self) -> Option<Vec<OnsetRecord>> {
        self.take_records(SpectralMatcher::take_explain, OnsetRecord::shift)
    }

    /// Hands over the held sounds' ends and why each ended (see
    /// [`Detector::enable_explain`]), their times on the stream's clock.
    pub fn take_held_ends(&mut self) -> Option<Vec<HeldEndRecord>> {
        self.take_records(SpectralMatcher::take_held_ends, HeldEndRecord::shift)
    }

    /// The spectral matcher's records that `take` hands over, each moved onto the
    /// stream's clock by `shift`.
    fn take_records<R>(
        &mut self,
        take: fn(&mut SpectralMatcher) -> Option<Vec<R>>,
        shift: fn(&mut R, f64),
    ) -> Option<Vec<R>> {
        let Matcher::Spectral(m) = &mut self.matcher else {
            return None;
        };
        let mut records = take(m)?;
        for r in &mut records {
            shift(r, self.time_offset);
        }
        Some(records)
    }

    /// Hands over the recorded match scores (see [`Detector::score_trace`]).
    pub fn take_score_trace(&mut self) -> Option<Vec<waveform::TakeTrace>> {
        match &mut self.matcher {
            Matcher::Waveform(m) => m.take_score_trace(),
            Matcher::Spectral(_) => None,
        }
    }

    /// The recorded match scores: one curve per take, at the working rate.
    pub fn score_trace(&self) -> Option<&[waveform::TakeTrace]> {
        match &self.matcher {
            Matcher::Waveform(m) => m.score_trace(),
            Matcher::Spectral(_) => None,
        }
    }

    /// Samples replaced so far because they were not finite (NaN, infinite: counted
    /// as 0) or beyond full scale (clamped to ±1).
    pub fn bad_samples(&self) -> u64 {
        self.bad_samples
    }

    /// Samples that reached full scale so far (clipped, or clamped to it): the input's
    /// gain is too high for its loudest sounds.
    pub fn clipped_samples(&self) -> u64 {
        self.clipped_samples
    }

    /// Consumes one block of mono input and appends the events decided meanwhile.
    /// Samples that are not finite become 0 and samples beyond full scale are clamped
    /// to ±1 before anything else sees them: no state of the detector (resampler,
    /// noise floors, onset function) can be captured by a corrupt burst. Then the
    /// spectral method takes the input's offset away.
    pub fn process(&mut self, block: &[f32], out: &mut Vec<Event>) {
        let first = out.len();
        self.input_consumed += block.len() as u64;
        let input_rate = f64::from(self.input_rate);
        let Self {
            resampler,
            matcher,
            clean,
            bad_samples,
            clipped_samples,
            dc_block,
            ..
        } = self;
        for piece in block.chunks(CLEAN_BLOCK) {
            let clean = &mut clean[..piece.len()];
            for (c, &x) in clean.iter_mut().zip(piece) {
                *c = if x.is_finite() {
                    x.clamp(-1.0, 1.0)
                } else {
                    0.0
                };
                if *c != x {
                    *bad_samples += 1;
                }
                if c.abs() >= crate::audio::CLIP_LEVEL {
                    *clipped_samples += 1;
                }
                if let Some(dc) = dc_block {
                    *c = dc.run(*c);
                }
            }
            match resampler {
                None => matcher.push(clean, out),
                Some(r) => r.push(clean, &mut |piece, consumed| {
                    push_resampled(matcher, out, piece, consumed as f64 / input_rate)
                }),
            }
        }
        self.number(out, first);
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
        self.number(out, first);
    }

    /// Numbers the events appended from `first` on, and drops begin markers unless
    /// they were asked for (in place: no allocation).
    fn number(&mut self, out: &mut Vec<Event>, first: usize) {
        let mut kept = first;
        for i in first..out.len() {
            let e = &mut out[i];
            let slot = (e.kind == PatternKind::Continuous)
                .then(|| self.open_ids.iter_mut().find(|(n, _)| **n == *e.pattern))
                .flatten();
            let begin_marker = e.kind == PatternKind::Continuous && e.end.is_none();
            e.id = match (slot, begin_marker) {
                (Some((_, open)), true) => {
                    let id = self.next_id;
                    self.next_id += 1;
                    *open = Some(id);
                    id
                }
                (Some((_, open)), false) => open.take().unwrap_or_else(|| {
                    let id = self.next_id;
                    self.next_id += 1;
                    id
                }),
                (None, _) => {
                    let id = self.next_id;
                    self.next_id += 1;
                    id
                }
            };
            if begin_marker && !self.report_begins {
                continue;
            }
            if self.time_offset != 0.0 {
                e.time += self.time_offset;
                e.emitted_at += self.time_offset;
                if let Some(end) = e.end.as_mut() {
                    *end += self.time_offset;
                }
            }
            out.swap(kept, i);
            kept += 1;
        }
        out.truncate(kept);
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
