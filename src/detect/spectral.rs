//! The feature-domain matcher (`method = "spectral"`): short-time log-mel frames, onset
//! detection, and a decision a few tens of milliseconds after each onset.
//!
//! Frames and features come from the features stage ([`super::features`]), onsets
//! from the onset stage ([`super::onset`]) on the same frames' band powers. A few
//! frames later the placement stage ([`super::place`]) puts an onset on the samples
//! (the first 1.5 ms window, sliding a sample at a time, within 12 dB of the loudest: a
//! signal a few samples later gives an onset as many samples later and the same
//! strength, wherever the frames fall), whatever became of the onsets before it. The
//! gates ([`super::gates`]) then decide what becomes of it from the evidence gathered
//! here: it must stand 10 dB out of the 40-5 ms before it (a consonant inside speech
//! follows a vowel) unless that sound is an impulse that fired and it is clearly an
//! impulse pattern's (a rhythm's words overlap; `GateParams::over_fired_score`), or
//! one of its takes added to that word's tail explains its first two decision windows
//! (`GateParams::over_tail_share`; it is then named by that take, its features,
//! mostly the tail's, are not judged, and it is that word's own later sound only where
//! the fired take's later windows explain it as well), and so on. The levels they
//! compare are the sound in a frame as the bands hear it (the rumble under them cut,
//! [`LowCut`]), its power less twice the room's noise (the
//! level stage, [`super::levels`]), so that noise just under a sound neither hides it
//! nor passes for speech around it; for the rise out of the quiet before, the noise of
//! whole periods of mains hum.
//! An enrolled take's onset is placed by the same stages, run on the take after noise:
//! once in a room as loud as the take allows and once in a quiet one, where a soft
//! first consonant (the "p" of "pew") is found; an impulse whose two placements differ
//! is enrolled from both ([`super::enrol`]).
//! A held sound that swells (a breathy "h" before its vowel) is placed where the stream
//! finds it when loud, on its soft start, and when soft, on its vowel: such a take is
//! enrolled from both (`first_block_within`, `SOFT_ONSET_RANGE_DB`).
//!
//! Classification: the frames of the first `decision_seconds` from the onset (the
//! first one centred on it) are pooled into features ([`super::features`]) over the
//! bands that the input's rate, the takes and the stream so far all carry
//! ([`super::passband`]; made again in place when the stream shows less), and
//! compared by cosine with the same of every enrolment take (an impulse pattern's
//! takes drawn two thirds of the way towards their mean, `TAKE_SHRINK`), each take as
//! heard in the onset's room, its noise added ([`super::classify`]), allowing a shift
//! of ±1 frame. Each impulse pattern also has a tracked template that follows
//! the voice as it drifts from the takes, and keeps its latest clear instances as they
//! were ([`super::classify::Tracked`]); what an instance taught is taken back if talk
//! follows it (`SpectralMatcher::teach_due`). The best pattern wins if its score passes
//! its threshold; below, the sound is none of the patterns and nothing fires. Two patterns that one window cannot tell apart and that part later
//! (a spoken "pop" and "pew", the same "p" for 40 ms) are decided between over more
//! windows, up to `max_decision_seconds` (`Separating` in [`super::enrol`],
//! `SpectralMatcher::scores_over`), and so, over two, is an instance that its first
//! window leaves between two impulse patterns whose takes differ there
//! (`BETWEEN_TWO_GAP`); every gate still judges the first window.
//! Each onset is decided once, so a sound never gives two events. A sound whose
//! strength (its amplitude against the take's over the decision window, both in the
//! bands compared, so that a take that carries more than the input is not louder by
//! what the input cannot carry) is below `min_strength` is not the user's (a voice
//! across the room, a breath) and does not fire either. Nor does an onset inside the
//! last impulse's take that the take itself has at that time, at that level, and that
//! resembles it as well as its best pattern does or nearly as well as a take resembles
//! itself (the closing "p" of a "pop"): see `SpectralMatcher::continues_last_impulse`;
//! nor, when the last impulse fired on a soft start, the attack that rose out of it,
//! named by the same pattern within the 40 ms the quiet-before gate looks back over
//! (`SpectralMatcher::attack_after_soft_start`).
//!
//! Exact copies: an onset that did not fire (but by the speech guard) is checked once
//! 0.25 s of its sound is in, by its waveform against each impulse take; a copy of a
//! take fires its pattern then ([`super::copies`]; outcome `copy`).
//!
//! A second look: an impulse that the background took for speech, heard clear of talk
//! and not over a fired word, is heard again three decision windows on; where its
//! sound fell away unvoiced, as a hit's does and a syllable's does not, it fires then
//! ([`super::syllable`]; outcome `fell_away`).
//!
//! Speech guard: an onset is ignored when the `speech_guard_seconds` before it held
//! 200 ms of sound within 10 dB of its peak that no pattern recognised (a consonant
//! inside a sentence follows its words; a missed hit is shorter): the context stage
//! ([`super::context`]) keeps the recognised sounds' spans and judges it.
//!
//! Continuous patterns: after an onset classified as one, the held stage
//! ([`super::held`]) follows the sound frame by frame (while it still resembles the
//! pattern's sustained spectrum, its mean frame after the takes' onsets) and says when
//! it ended. A voiced held sound also reports its pitch ([`super::pitch`]).
//!
//! Runs on the detector thread. FFT plan, mel bank, rings and templates are made in
//! [`SpectralMatcher::new`]; `push` allocates nothing.

use std::ops::RangeInclusive;
use std::sync::Arc;

use super::ablation::Ablation;
use super::background::BackgroundModel;
use super::classify::{
    default_noise_over_floor, share_explained_over_tail, FiredInstance, Room, TrackParams, Tracked,
};
use super::context::{Before, Context, ContextParams, Guard, SPAN_STRETCH};
use super::copies::Copies;
use super::enrol::{
    first_block_within, shrink_takes_towards_their_mean, take_features, take_placements,
    takes_agreement, takes_carry_under_hz, window_power, Separating, TakeFeatures, TakePlacements,
    TakesAgree, Template, SOFT_ONSET_GAP_SECONDS, SOFT_ONSET_RANGE_DB,
};
use super::explain::{HeldEndRecord, MatchedBy, OnsetRecord, SoundSpan, Taught, Wait};
use super::features::{
    features_of_power, normalise, pool_power, present_bands, share_in_bands, similarity,
    sum_of_squares, top_hz, Analyzer, Cepstrum, LowCut, BANDS, FEATURES, HOP_SECONDS,
    WINDOW_SECONDS,
};
use super::fifo::Fifo;
use super::gates::{after_background, decide, Evidence, GateParams, Outcome};
use super::held::{Held, HeldParams, HeldStage};
use super::levels::{sound_level_db, LevelInput, Levels, StreamStart, SILENT_DB};
use super::onset::{holds_sound, Onset, OnsetDetector, OnsetParams};
use super::passband::Passband;
use super::pitch::PitchEstimator;
use super::place::{Placer, PLACE_AFTER_FRAMES};
use super::syllable::{Afterwards, SecondLooks, SyllableParams, Waiting};
use super::talk::HeardTalk;
use super::Event;
use crate::config::{DetectorSettings, PatternKind, DEFAULT_SPEECH_GUARD_SECONDS};
use crate::pattern::Pattern;

/// The frames between these times before an onset are the quiet it must rise out of
/// (`GateParams::pre_quiet_db`); the speech guard's span and a recognised sound's start
/// end where this one does. The placement puts an onset on the first 1.5 ms block
/// within 12 dB of its sound's loudest, so what lies a few blocks before it is the
/// sound before, not its attack. The end was swept from 0 to 20 ms over every dev set
/// (`docs/quiet-before.md`): 3.75 to 7.5 ms a plateau; 5 ms keeps the most of a voice's
/// own speech out, 10 ms (as it was) let a consonant 5-10 ms after a vowel through.
const PRE_QUIET_FROM_SECONDS: f64 = 0.040;
const PRE_QUIET_TO_SECONDS: f64 = 0.005;

/// The frames the quiet before an onset reaches back over (`PRE_QUIET_FROM_SECONDS`).
fn quiet_before_frames() -> u64 {
    (PRE_QUIET_FROM_SECONDS / HOP_SECONDS).ceil() as u64
}
/// Shift tolerance when comparing frames with a template.
pub(super) const MAX_SHIFT: usize = 1;
/// Frames of features and samples kept: the longest speech guard and a decision.
const HISTORY_SECONDS: f64 = crate::config::MAX_SPEECH_GUARD_SECONDS + 0.25;

struct PatternInfo {
    name: Arc<str>,
    kind: PatternKind,
    threshold: f32,
    continuous_threshold: f32,
    /// Continuous patterns: the takes' mean frame after the onset (dB per band)...
    mean_frame: Vec<f32>,
    /// ...centred and unit-norm over the bands compared.
    sustain: Vec<f32>,
    /// Mean power per sample of the takes.
    power: f64,
    /// The longest gap between attacks over those of its takes that are one sound
    /// repeated ([`repeats_every`]), frames: each take is said at its own pace, and the
    /// takes show how far the pace strays.
    repeats_every: Option<usize>,
}

/// What an onset's first window showed ([`SpectralMatcher::first_look`]): its best
/// pattern, the evidence that does not depend on the pattern, the energy of its
/// decision window in the bands compared, and its peak level by two measures. Kept
/// while its decision waits for more windows, so that every gate judges the first
/// window once.
#[derive(Clone, Copy)]
struct FirstLook {
    best: usize,
    context: Evidence,
    early: f64,
    /// Its peak level, dB of sound, as the speech guard judges it...
    peak: f32,
    /// ...and by the quiet-before rise's measure (where its span starts to follow its
    /// sound).
    rise_peak: f32,
    /// The speech guard's judgement of the sound before it...
    guard: Guard,
    /// ...and whether it was heard clear of talk ([`Context::guard`]).
    clear_of_talk: bool,
}

/// What was decided of one onset ([`SpectralMatcher::classify`]), for the steps that
/// act on it: the record, the guard's cover of a stopped sound, the firing.
struct Decision {
    time_sample: u64,
    onset_frame: u64,
    /// Its pattern, and the evidence the gates judged it on.
    pattern: usize,
    evidence: Evidence,
    outcome: Outcome,
    guard: Guard,
    /// Heard clear of talk: what fires may teach tracking ([`Context::guard`]).
    clear_of_talk: bool,
    /// Its peak level by the guard's measure and by the quiet-before rise's.
    peak: f32,
    rise_peak: f32,
    /// It was named by what a take adds to a fired word's tail.
    judged_over_tail: bool,
    /// Decision windows its choice heard, and why more than one.
    heard_windows: usize,
    waited_for: Option<Wait>,
    /// Samples before its onset that an impulse that fires is dated: where its take's
    /// earlier placement falls, when its soft start was lost ([`SpectralMatcher::dated_back`]).
    dated_back: u64,
}

/// A placed onset waiting for its decision.
#[derive(Clone, Copy)]
struct PendingOnset {
    /// The onset sample.
    time_sample: u64,
    /// The frame centred on it.
    frame: u64,
    /// Decision windows its decision waits for: more than one once its two best
    /// patterns are a pair that one window cannot tell apart (`separating`).
    windows: usize,
}

/// Onset times (seconds, each at the centre of the frame where the onset function
/// peaked) that the onset stage with `params` finds in `samples` at `rate` Hz, through
/// the matcher's own frames: for measuring the stage alone (`examples/onset_sweep.rs`).
pub fn onset_times(samples: &[f32], rate: f64, params: OnsetParams) -> Vec<f64> {
    let mut frames = Vec::new();
    let (win, hop) = run_onset_stage(samples, rate, params, 0, |step| {
        frames.extend(step.onset.map(|o| o.frame));
    });
    frames
        .iter()
        .map(|&f| (f as usize * hop + win / 2) as f64 / rate)
        .collect()
}

/// One frame of [`run_onset_stage`].
pub(super) struct OnsetStep<'a> {
    /// Frames made so far, this one included.
    pub(super) frames: u64,
    /// Samples consumed: this frame's window ends here.
    pub(super) consumed: u64,
    /// The onset the stage found at this frame.
    pub(super) onset: Option<Onset>,
    /// The frame's band powers (linear) and the onset stage's band floors after it.
    pub(super) power: &'a [f32],
    pub(super) floors: &'a [f32],
}

/// Runs the features and onset stages (with `params`) over `samples` at `rate`, offline,
/// on a stream's schedule (a frame every hop once a window's samples have arrived), and
/// on through `tail_frames` frames of silence after them, calling `each` after every
/// frame. Returns the frames' window and hop, in samples.
pub(super) fn run_onset_stage(
    samples: &[f32],
    rate: f64,
    params: OnsetParams,
    tail_frames: usize,
    mut each: impl FnMut(OnsetStep),
) -> (usize, usize) {
    let mut analyzer = Analyzer::new(rate);
    let (win, hop) = (analyzer.win, analyzer.hop);
    let mut onsets = OnsetDetector::new(params, &analyzer.band_bins(), win, hop, rate);
    let mut window = vec![0.0f32; win];
    let mut frame = vec![0.0f32; BANDS];
    let mut frames = 0u64;
    let mut consumed = hop;
    while consumed <= samples.len() + tail_frames * hop {
        if consumed >= win {
            for (k, w) in window.iter_mut().enumerate() {
                *w = samples.get(consumed - win + k).copied().unwrap_or(0.0);
            }
            analyzer.frame(&window, &mut frame);
            frames += 1;
            let onset = onsets.push(&analyzer.power);
            each(OnsetStep {
                frames,
                consumed: consumed as u64,
                onset,
                power: &analyzer.power,
                floors: onsets.band_floors(),
            });
        }
        consumed += hop;
    }
    (win, hop)
}

/// The features of every onset in `samples` (at `settings.sample_rate`) that stands out
/// of its quiet, as the matcher with `settings` pools them: a background model
/// (`examples/background_model.rs`).
pub fn background_model(samples: &[f32], settings: &DetectorSettings) -> BackgroundModel {
    let mut matcher = SpectralMatcher::new(Vec::new(), settings, settings.sample_rate);
    matcher.collected = Some(Vec::new());
    let mut out = Vec::new();
    matcher.push(samples, &mut out);
    matcher.finish(&mut out);
    let templates = matcher.collected.take().unwrap_or_default();
    BackgroundModel::new(FEATURES, matcher.decision_frames, templates)
}

/// The highest frequency (Hz) that an input at `input_rate` and every take of
/// `patterns` carry: where the resampler's passband ends at the lowest of their rates,
/// or lower where the takes fall off a filter's edge ([`takes_carry_under_hz`]). Only
/// the bands under it are compared.
fn carried_top_hz(
    analyzer: &mut Analyzer,
    patterns: &[Pattern],
    settings: &DetectorSettings,
    input_rate: u32,
) -> f64 {
    let lowest_rate = patterns
        .iter()
        .flat_map(|p| p.takes.iter().map(|t| t.recorded_rate))
        .chain([input_rate, settings.sample_rate])
        .min()
        .unwrap_or(settings.sample_rate);
    let takes = patterns
        .iter()
        .flat_map(|p| &p.takes)
        .map(|t| &t.samples[..]);
    let rate = f64::from(settings.sample_rate);
    top_hz(f64::from(lowest_rate)).min(takes_carry_under_hz(analyzer, takes, rate))
}

/// The top of the highest band a matcher of `patterns` heard through an input at
/// `input_rate` compares (Hz), when it compares fewer than every band; `None` when it
/// compares every one. What [`SpectralMatcher::compared_top_hz`] says of a matcher
/// built, without building one.
pub fn compared_top_hz(
    patterns: &[Pattern],
    settings: &DetectorSettings,
    input_rate: u32,
) -> Option<f64> {
    let rate = f64::from(settings.sample_rate);
    let mut analyzer = Analyzer::new(rate);
    let top = carried_top_hz(&mut analyzer, patterns, settings, input_rate);
    analyzer.compare_under(rate, top);
    analyzer.cepstrum.top_hz(rate)
}

/// Which of the matcher's held stages: the one whose sounds fired, or the one that
/// follows a held sound the speech guard stopped.
#[derive(Clone, Copy)]
enum Stage {
    Fired,
    Stopped,
}

/// Where stream sample `n` lies in the sample ring. The ring is a power of two long:
/// a mask, not a division, per sample.
fn ring_slot(ring: &[f32], n: u64) -> usize {
    (n & (ring.len() as u64 - 1)) as usize
}

/// The `len` samples from stream position `start` on in `ring`, in order, as two
/// slices (the second empty unless the ring wraps there).
fn ring_slices(ring: &[f32], start: u64, len: usize) -> (&[f32], &[f32]) {
    let first = ring_slot(ring, start);
    let head = len.min(ring.len() - first);
    (&ring[first..first + head], &ring[..len - head])
}

/// Streaming spectral matcher.
pub struct SpectralMatcher {
    rate: f64,
    analyzer: Analyzer,
    decision_frames: usize,
    templates: Vec<Template>,
    patterns: Vec<PatternInfo>,
    /// Ring of the last samples (a power of two long).
    samples: Vec<f32>,
    low_cut: LowCut,
    /// The same samples through `low_cut`, in a ring as long.
    heard_samples: Vec<f32>,
    /// Samples received, and of them those the stages have consumed: all once it is
    /// known how the stream begins ([`Self::read_ahead`]).
    received: u64,
    consumed: u64,
    stream_start: StreamStart,
    primed: bool,
    /// Of the frames read ahead: their band powers and what the level stage takes.
    prime_powers: Vec<f32>,
    prime_levels: Vec<LevelInput>,
    /// Samples since the last frame.
    since_frame: usize,
    /// Ring of log-mel frames, `BANDS` each.
    frames: Vec<f32>,
    /// Per frame: the sound in it over the room's noise
    /// ([`super::levels::FrameLevels::sound`]), for the speech guard and for how long a
    /// held sound lasts.
    levels: Vec<f32>,
    /// Per frame: the same over the noise of whole periods of mains hum
    /// ([`super::levels::FrameLevels::rise`]), for the quiet-before rise and the spans of
    /// recognised sounds, which end where a new sound rises by that measure.
    rise_levels: Vec<f32>,
    /// Per frame: its power as the bands hear it, dB ([`super::levels::FrameLevels::heard`]).
    heard_levels: Vec<f32>,
    /// Per frame: its sound as a held sound is followed by it
    /// ([`super::levels::FrameLevels::held`]).
    held_levels: Vec<f32>,
    frame_capacity: usize,
    /// Frames computed.
    frame_count: u64,
    onsets: OnsetDetector,
    /// The sound of each frame over the room's noise ([`super::levels`]).
    level_stage: Levels,
    placer: Placer,
    pending: Vec<PendingOnset>,
    /// Placed onsets that found `pending` full.
    pending_dropped: u64,
    held: HeldStage,
    /// The span in the context stage of the held sound `held` follows, and where it
    /// began.
    held_span: Option<(usize, u64)>,
    /// A held sound the guard stopped, followed only to know how long it covers
    /// (`SpectralMatcher::follow_stopped_held`), and its span in the context stage.
    stopped_held: HeldStage,
    stopped_held_span: Option<(usize, u64)>,
    /// The room each held sound (`held`, `stopped_held`) is heard over, when it began
    /// right after digital silence ([`Levels::room_before_silence`]).
    held_room: [Option<f32>; 2],
    frame_buf: Vec<f32>,
    window_buf: Vec<f32>,
    instance: Vec<f32>,
    /// The pooled power spectrum `instance` was made from.
    instance_power: Vec<f32>,
    /// Per template, for an onset over a fired word's tail that did not rise out of it:
    /// the share of its sound that the take explains over the tail
    /// ([`share_explained_over_tail`]; over its first decision window, then the least
    /// of its first two; 0 for a held pattern's, and for any other onset).
    over_tail_shares: Vec<f32>,
    /// Whether a decision may wait for a second window (`max_decision_seconds` allows
    /// it): without, an onset over a tail is not asked the share, and an instance
    /// between two patterns is decided on its first window.
    waits_a_window: bool,
    /// The onset's room, and a take's features as heard in it.
    room: Room,
    heard_take: Vec<f32>,
    pitch: PitchEstimator,
    finished: bool,
    /// The recognised sounds before an onset, and the speech guard.
    context: Context,
    /// The first look at the onset whose decision waits for more windows.
    waiting: Option<FirstLook>,
    gates: GateParams,
    /// Mechanisms a measurement build turned off (none in any other build).
    off: Ablation,
    /// The last onset that fired (sample), and how near an onset may be placed to it:
    /// the onset stage's `min_gap_seconds`.
    last_fired: Option<u64>,
    min_gap_samples: u64,
    /// The last impulse fired, whose take may still be going on.
    last_impulse: Option<FiredImpulse>,
    /// The impulse of each pattern as its user has lately made it, scored as its takes
    /// are ([`Tracked`]).
    tracked: Tracked,
    /// How near each pattern's takes lie to one another ([`takes_agreement`]), which
    /// an instance must reach to teach tracking.
    takes_agree: Vec<TakesAgree>,
    /// Per pattern, the scores of the onset being classified.
    pattern_scores: Vec<PatternScore>,
    /// The instance's features at the shift that scored best.
    best_instance: Vec<f32>,
    /// Every onset decided and what became of it, when asked for (offline).
    explain: Option<Vec<OnsetRecord>>,
    /// Every held sound that fired and ended, and why, when asked for with `explain`.
    held_ends: Option<Vec<HeldEndRecord>>,
    /// The sounds of speech, the room... that must never fire, as compared: the
    /// built-in model and the user's own ([`Self::add_background`]) through the
    /// cepstrum...
    background: BackgroundModel,
    /// ...from their features over every band.
    background_full: BackgroundModel,
    /// The onset being classified: its best similarity with the background.
    background_score: f32,
    /// The user's own talk, as the onsets the guard stopped amid it sounded
    /// ([`HeardTalk`]).
    talk: HeardTalk,
    /// The onset being classified: the talk heard lately that lies nearest it, its
    /// similarity and the sample it was heard at.
    talk_nearest: Option<(f32, u64)>,
    /// Onsets the guard stopped, waiting for their sound to show whether it went on
    /// as a syllable's...
    talk_heard: Fifo<TalkWaiting, LESSONS>,
    /// ...and those that did, waiting to be known as talk once the sound after them
    /// is in (as long a wait as a lesson's, so as many; one that finds a queue full
    /// is not kept).
    talk_waiting: Fifo<TalkWaiting, LESSONS>,
    /// Per ordered pair of patterns (row-major): over how many decision windows the
    /// choice between them is made ([`Separating`]).
    separating: Vec<u8>,
    /// The most windows any pair waits for, over any bands compared (1: none waits).
    max_windows: usize,
    separating_scratch: Separating,
    /// A take's pooled power over several windows (scratch).
    take_power: Vec<f32>,
    /// The features of every onset that stands out of its quiet, when building a
    /// background model ([`background_model`]).
    collected: Option<Vec<f32>>,
    /// Per pattern, its kind.
    kinds: Vec<PatternKind>,
    /// The highest frequency that the input's rate and the takes carry (Hz), and how
    /// far up the stream's own loudest frames carry sound: the bands compared are those
    /// under both.
    carried_top_hz: f64,
    passband: Passband,
    /// Onsets that did not fire, checked for an exact copy of a take once its sound is
    /// in ([`Copies`]).
    copies: Copies,
    /// The impulses the background took for speech, waiting to be heard again once it is
    /// known whether their sound went on as a syllable's.
    second_looks: SecondLooks,
    /// What the impulses that fired taught tracking, until the sound after them is in.
    lessons: Fifo<Lesson, LESSONS>,
    /// What tracking has learnt from the impulses whose after-span was clear of talk.
    confirmed: Tracked,
}

/// Two patterns whose takes look alike over the decision window
/// ([`SpectralMatcher::look_alike_patterns`]).
#[derive(Debug, Clone, PartialEq)]
pub struct AlikePair {
    pub first: Arc<str>,
    pub second: Arc<str>,
    /// The best similarity of their takes, 1 for the same.
    pub similarity: f32,
    /// When they part later: how much of a sound a choice between them waits for,
    /// seconds from its onset.
    pub decided_after_seconds: Option<f64>,
}

/// One pattern's score for an onset: the best of its takes, its tracked template and
/// its kept instances; and which take scored best, and how well.
#[derive(Clone, Copy)]
struct PatternScore {
    score: f32,
    /// What gave `score`.
    matched_by: MatchedBy,
    take: usize,
    take_score: f32,
}

impl PatternScore {
    const NONE: Self = Self {
        score: f32::NEG_INFINITY,
        matched_by: MatchedBy::Take,
        take: usize::MAX,
        take_score: f32::NEG_INFINITY,
    };
}

/// An onset the guard stopped, waiting until the guard's span after its take's sound
/// is in to be known as talk ([`SpectralMatcher::learn_talk_due`]).
#[derive(Clone, Copy, Default)]
struct TalkWaiting {
    time_sample: u64,
    end_sample: u64,
    peak: f32,
    features: [f32; FEATURES],
}

/// What an impulse that fired taught tracking, waiting to be kept until the speech
/// guard's span after its take's sound is in ([`SpectralMatcher::teach_due`]).
#[derive(Clone, Copy, Default)]
struct Lesson {
    pattern: usize,
    time_sample: u64,
    /// Where its take's sound ends, and its peak (dB) as the guard judges sound by.
    end_sample: u64,
    peak: f32,
    /// Where the span it covers for the speech guard begins ([`Context::fired_impulse`]).
    covered_from: u64,
    features: [f32; FEATURES],
    score: f32,
    take_score: f32,
    other: f32,
    over_fired_impulse: bool,
    /// Heard amid talk before it.
    amid_talk: bool,
}

impl Lesson {
    /// The instance as tracking is told of it.
    fn instance<'a>(
        &'a self,
        patterns: &[PatternInfo],
        takes_agree: &[TakesAgree],
    ) -> FiredInstance<'a> {
        FiredInstance {
            features: &self.features,
            score: self.score,
            take_score: self.take_score,
            other: self.other,
            threshold: patterns[self.pattern].threshold,
            takes_agree: takes_agree[self.pattern].score,
            over_fired_impulse: self.over_fired_impulse,
            amid_talk: self.amid_talk,
        }
    }
}

/// Lessons waiting, at most this many: a second and a half of impulses 20 ms apart
/// (the onset stage's shortest gap) for a take of 0.85 s. One that finds the queue full
/// is taught at once but never kept.
const LESSONS: usize = 64;

#[derive(Clone, Copy)]
struct FiredImpulse {
    template: usize,
    /// Its event's onset (where it was dated) to its take's end, samples.
    span: (u64, u64),
    onset_frame: u64,
    strength: f64,
    /// The frame of the last onset taken for its own later sound (its own onset's until
    /// one is): a sound of one sound repeated goes on, past its take's end too, while
    /// its attacks keep coming at its takes' pace ([`SpectralMatcher::continuation_lags`]).
    last_attack_frame: u64,
    /// Its own first window: its features and its energy in the bands compared. A sound
    /// repeated repeats this instance's attack, which may lie further from the take's
    /// than its attacks lie from one another ([`SpectralMatcher::continues_last_impulse`]).
    first_attack: [f32; FEATURES],
    first_attack_energy: f64,
}

/// The later sound of the last fired impulse that an onset may be
/// ([`SpectralMatcher::continuation_lags`]).
struct ContinuationLags {
    last: FiredImpulse,
    /// Frames after its take's onset whose windows the onset is compared with.
    lags: RangeInclusive<usize>,
    /// Every later window of a take that is one sound repeated.
    repeated: bool,
}

/// See [`SpectralMatcher::continues_last_impulse`].
const CONTINUATION_SLACK_SECONDS: f64 = 0.02;
const CONTINUATION_SIMILARITY: f32 = 0.8;
const CONTINUATION_DB: f64 = 6.0;

/// Two patterns whose takes are this alike over a decision window cannot be told
/// apart there; a choice between them waits for the windows that part them
/// ([`Separating`]). Swept over every dev set (`docs/classify.md`): 0.6 and 0.7
/// score alike, 0.8 and 0.9 lose the beats' "B" and "Pf", 0.5 and less wait for pairs
/// that longer windows do not part.
const ALIKE_SIMILARITY: f32 = 0.7;

/// Decision windows an onset over a fired word's tail is judged over by what a take adds
/// to the tail ([`share_explained_over_tail`]): the consonant a word begins with and
/// the sound it goes on into. Over its first alone, a word's own closing consonant
/// said quicker than its take (the closing "p" of a "pop" at 300 words a minute) is
/// explained as well, and fired as a new word.
const OVER_TAIL_WINDOWS: usize = 2;

/// An instance whose runner-up, an impulse pattern, scores within this much of its
/// best (an impulse too) lies between the two over its first decision window, however
/// unlike their takes are there: a performer's kick whose take is brighter than the
/// kicks he then makes scores 0.63 for it and 0.70 for his "Pf". The choice between the
/// two is then made over `BETWEEN_TWO_WINDOWS` windows, as for a pair alike at first
/// ([`Separating`]). Swept over every dev set (`docs/classify.md`, "An instance between
/// two patterns"): from 0.05 to 0.3 the mean F1 lies within 0.0016, 0.1 at its top.
const BETWEEN_TWO_GAP: f32 = 0.1;
/// One window more than the first: the least more of the sound that can part the two.
const BETWEEN_TWO_WINDOWS: usize = 2;

/// A take whose sound is one sound repeated has at least this many attacks: the first
/// and two more, so that it repeats at a pace (a word's first and closing consonants
/// are two).
const REPEATED_ATTACKS: usize = 3;

/// For a take placed at sample `start` whose attacks lie at `attacks` (samples from its
/// start, [`TakePlacements::attacks`]), with the pooled power of its first decision
/// window and of each later frame's (`later_power`): when it has `REPEATED_ATTACKS`
/// attacks from `start` on, each as alike its first window as a continuation must be
/// (`CONTINUATION_SIMILARITY`), the longest time between two successive ones, frames.
/// A sound said with more of its attacks than its take has goes on at that pace.
fn repeats_every(
    attacks: &[usize],
    start: usize,
    hop: usize,
    pooled_power: &[f32],
    later_power: &[f32],
    cepstrum: &Cepstrum,
) -> Option<usize> {
    // Each attack that lies where the take still has a whole window, as frames after
    // this placement.
    let windows = later_power.len() / BANDS;
    let lags: Vec<usize> = attacks
        .iter()
        .filter(|&&at| at + hop > start)
        .map(|&at| (at.saturating_sub(start) + hop / 2) / hop)
        .filter(|&lag| lag <= windows)
        .collect();
    if lags.len() < REPEATED_ATTACKS {
        return None;
    }
    let mut first = [0.0f32; FEATURES];
    features_of_power(pooled_power, cepstrum, &mut first);
    let mut later = [0.0f32; FEATURES];
    for &lag in &lags[1..] {
        let power = &later_power[(lag.max(1) - 1) * BANDS..lag.max(1) * BANDS];
        features_of_power(power, cepstrum, &mut later);
        if similarity(&first, &later) < CONTINUATION_SIMILARITY {
            return None;
        }
    }
    lags.windows(2).map(|w| w[1] - w[0]).max()
}

/// Mean power of `samples[from..to]` (clipped to its length; 0 when empty).
fn mean_power(samples: &[f32], from: usize, to: usize) -> f64 {
    let span = &samples[from.min(samples.len())..to.min(samples.len())];
    span.iter().map(|&x| f64::from(x).powi(2)).sum::<f64>() / span.len().max(1) as f64
}

/// Pools `count` frames from frame `first` of the ring `frames` (`capacity` frames of
/// `BANDS` dB values) into one mean power spectrum, `out` ([`pool_power`]).
fn pool_ring(frames: &[f32], capacity: usize, first: u64, count: usize, out: &mut [f32]) {
    let cap = capacity as u64;
    pool_power(
        count,
        |k| {
            let slot = ((first + k as u64) % cap) as usize;
            &frames[slot * BANDS..(slot + 1) * BANDS]
        },
        out,
    );
}

impl SpectralMatcher {
    /// A matcher of `patterns` for input recorded at `input_rate` (resampled to
    /// `settings.sample_rate` before it arrives).
    pub fn new(patterns: Vec<Pattern>, settings: &DetectorSettings, input_rate: u32) -> Self {
        let off = Ablation::from_env();
        let rate = f64::from(settings.sample_rate);
        let mut analyzer = Analyzer::new(rate);
        let carried = carried_top_hz(&mut analyzer, &patterns, settings, input_rate);
        analyzer.compare_under(rate, carried);
        let onset_params = OnsetParams::default();
        // The decision waits for the frames whose windows reach `decision_seconds` past
        // the onset (the onset frame is centred on it), shift tolerance included.
        let frames_reaching = |seconds: f64| {
            (((seconds - WINDOW_SECONDS / 2.0) / HOP_SECONDS).floor() as usize)
                .saturating_sub(MAX_SHIFT)
        };
        let decision_frames = frames_reaching(settings.decision_seconds).max(2);
        // As many whole windows as reach no further than `max_decision_seconds`.
        let allowed_windows =
            (frames_reaching(settings.max_decision_seconds) / decision_frames).max(1);
        let mut templates = Vec::new();
        let mut infos = Vec::new();
        // Impulse takes and their onsets, for the copies stage.
        let mut copy_takes = Vec::new();
        let mut takes_so_far = 0;
        for (pi, p) in patterns.iter().enumerate() {
            let mut sustain = vec![0.0f32; BANDS];
            let mut sustain_frames = 0usize;
            let mut power = 0.0f64;
            for take in &p.takes {
                let TakePlacements {
                    first: onset,
                    quiet_room: quiet_room_onset,
                    attacks,
                } = take_placements(&take.samples, settings, analyzer.hop);
                if p.kind == PatternKind::Impulse {
                    // Compared from the earlier placement: a copy loud enough to be
                    // checked is placed there at the latest.
                    let first = quiet_room_onset.map_or(onset, |q| q.min(onset));
                    copy_takes.push((pi, take.samples.as_slice(), first));
                }
                // A held sound swells: a stream places its onset on its soft start when
                // it stands out of the noise, later when it does not. Both are enrolled.
                let soft = first_block_within(&take.samples, analyzer.hop, SOFT_ONSET_RANGE_DB);
                let soft_first = p.kind == PatternKind::Continuous
                    && (onset.saturating_sub(soft) as f64) > SOFT_ONSET_GAP_SECONDS * rate
                    && !off.second_placement;
                let quiet_room_onset = quiet_room_onset.filter(|_| !off.second_placement);
                // An impulse is enrolled from where a quiet room places it too.
                let starts: &[(usize, bool)] = match (soft_first, quiet_room_onset) {
                    (true, _) => &[(soft, true), (onset, false)],
                    (false, Some(early)) if p.kind == PatternKind::Impulse => {
                        &[(early, true), (onset, false)]
                    }
                    _ => &[(onset, false)],
                };
                let mut sustained = None;
                for &(start, second_placement) in starts {
                    let TakeFeatures {
                        features,
                        pooled_power,
                        early_energy,
                        mean_frame,
                        mean_frames,
                        later_power,
                        later_energy,
                    } = take_features(&mut analyzer, &take.samples, decision_frames, start);
                    let repeats_every = (p.kind == PatternKind::Impulse)
                        .then(|| {
                            repeats_every(
                                &attacks,
                                start,
                                analyzer.hop,
                                &pooled_power,
                                &later_power,
                                &analyzer.cepstrum,
                            )
                        })
                        .flatten();
                    let (after_earlier, soft_start_share) =
                        match (second_placement, quiet_room_onset) {
                            (false, Some(early))
                                if p.kind == PatternKind::Impulse
                                    && start >= early + decision_frames * analyzer.hop =>
                            {
                                let decision_len = decision_frames * analyzer.hop;
                                let soft = mean_power(&take.samples, early, start);
                                let after = mean_power(&take.samples, start, start + decision_len);
                                ((start - early) as u64, soft / after.max(1e-20))
                            }
                            _ => (0, 0.0),
                        };
                    templates.push(Template {
                        pattern: pi,
                        take: takes_so_far,
                        second_placement,
                        features,
                        pooled_power,
                        drawn_towards: None,
                        early_energy,
                        length_after_onset: (take.samples.len() - start) as u64,
                        after_earlier,
                        soft_start_share,
                        later_power,
                        later_energy,
                        repeats_every,
                    });
                    // The held spectrum is taken from the later start.
                    sustained = Some((mean_frame, mean_frames));
                }
                takes_so_far += 1;
                let (mean_frame, n) = sustained.unwrap_or_default();
                for (s, m) in sustain.iter_mut().zip(&mean_frame) {
                    *s += m * n as f32;
                }
                sustain_frames += n;
                power += take.energy() / take.samples.len() as f64;
            }
            for s in &mut sustain {
                *s /= sustain_frames.max(1) as f32;
            }
            infos.push(PatternInfo {
                name: p.name.clone(),
                kind: p.kind,
                threshold: p.threshold as f32,
                continuous_threshold: p.continuous_threshold as f32,
                sustain: sustain.clone(),
                mean_frame: sustain,
                power: power / p.takes.len().max(1) as f64,
                repeats_every: templates
                    .iter()
                    .filter(|t| t.pattern == pi)
                    .filter_map(|t| t.repeats_every)
                    .max(),
            });
        }
        let frame_capacity =
            ((HISTORY_SECONDS / HOP_SECONDS) as usize).max(decision_frames + 4 * MAX_SHIFT + 16);
        let sample_capacity = ((HISTORY_SECONDS * rate) as usize).next_power_of_two();
        let (win, hop_seconds) = (analyzer.win, analyzer.hop as f64 / rate);
        let n_patterns = infos.len();
        let kinds: Vec<PatternKind> = infos.iter().map(|i| i.kind).collect();
        // Nothing is compared without templates (enrolment's probe of a take).
        let noise_over_floor = if templates.is_empty() {
            vec![1.0; BANDS]
        } else {
            default_noise_over_floor(rate)
        };
        let background_full = BackgroundModel::builtin().for_matcher(FEATURES, decision_frames);
        let gates = GateParams {
            min_strength: if off.min_strength {
                0.0
            } else {
                settings.min_strength
            },
            over_fired_score: if off.over_fired {
                f32::INFINITY
            } else {
                GateParams::default().over_fired_score
            },
            background_margin: if off.background {
                f32::INFINITY
            } else {
                GateParams::default().background_margin
            },
            ..GateParams::default()
        };
        let templates_len = templates.len();
        let copies = Copies::new(copy_takes.into_iter(), rate);
        let second_looks =
            SecondLooks::new(SyllableParams::default(), rate, settings.decision_seconds);
        let tracked = Tracked::new(TrackParams::default(), n_patterns, FEATURES);
        let mut matcher = Self {
            rate,
            decision_frames,
            templates,
            patterns: infos,
            samples: vec![0.0; sample_capacity],
            low_cut: LowCut::new(rate),
            heard_samples: vec![0.0; sample_capacity],
            received: 0,
            consumed: 0,
            stream_start: StreamStart::new(0.0, 0, 1, 0),
            primed: false,
            prime_powers: Vec::new(),
            prime_levels: Vec::new(),
            since_frame: 0,
            frames: vec![0.0; frame_capacity * BANDS],
            levels: vec![SILENT_DB; frame_capacity],
            rise_levels: vec![SILENT_DB; frame_capacity],
            heard_levels: vec![SILENT_DB; frame_capacity],
            held_levels: vec![SILENT_DB; frame_capacity],
            frame_capacity,
            frame_count: 0,
            onsets: OnsetDetector::new(
                onset_params,
                &analyzer.band_bins(),
                win,
                analyzer.hop,
                rate,
            ),
            level_stage: Levels::new(win, analyzer.hop, &onset_params),
            placer: Placer::new(analyzer.hop),
            pending: Vec::with_capacity(16),
            pending_dropped: 0,
            held: HeldStage::new(HeldParams::default(), HOP_SECONDS),
            stopped_held: HeldStage::new(HeldParams::default(), HOP_SECONDS),
            held_span: None,
            stopped_held_span: None,
            held_room: [None; 2],
            frame_buf: vec![0.0; BANDS],
            window_buf: vec![0.0; win],
            instance: vec![0.0; FEATURES],
            instance_power: vec![0.0; BANDS],
            over_tail_shares: vec![0.0; templates_len],
            waits_a_window: allowed_windows >= 2,
            room: Room::new(noise_over_floor),
            heard_take: vec![0.0; FEATURES],
            pitch: PitchEstimator::new(rate),
            analyzer,
            finished: false,
            context: Context::new(
                ContextParams::new(settings.speech_guard_seconds, gates.pre_quiet_db),
                hop_seconds,
            ),
            waiting: None,
            gates,
            off,
            last_fired: None,
            min_gap_samples: (onset_params.min_gap_seconds * rate) as u64,
            last_impulse: None,
            confirmed: tracked.clone(),
            tracked,
            takes_agree: vec![TakesAgree::NONE; n_patterns],
            pattern_scores: vec![PatternScore::NONE; n_patterns],
            best_instance: vec![0.0; FEATURES],
            explain: None,
            held_ends: None,
            background: background_full.own_copy(),
            background_full,
            background_score: f32::NEG_INFINITY,
            talk: HeardTalk::new(FEATURES, rate),
            talk_nearest: None,
            talk_heard: Fifo::new(),
            talk_waiting: Fifo::new(),
            separating: vec![1; n_patterns * n_patterns],
            separating_scratch: Separating::new(
                templates_len,
                n_patterns,
                decision_frames,
                ALIKE_SIMILARITY,
                allowed_windows,
            ),
            max_windows: 1,
            take_power: vec![0.0; BANDS],
            collected: None,
            kinds,
            carried_top_hz: carried,
            passband: Passband::new(rate),
            copies,
            second_looks,
            lessons: Fifo::new(),
        };
        let bands = matcher.analyzer.cepstrum.bands();
        // Whatever bands the stream leaves compared, no pair waits longer than this.
        let mut fewer = Cepstrum::new(bands);
        for b in 2..=bands {
            fewer.set_bands(b);
            matcher.separating_scratch.waits(
                &matcher.templates,
                &matcher.kinds,
                &fewer,
                &mut matcher.separating,
            );
            let most = matcher.separating.iter().copied().max().unwrap_or(1);
            matcher.max_windows = matcher.max_windows.max(usize::from(most));
        }
        if matcher.waits_a_window {
            matcher.max_windows = matcher
                .max_windows
                .max(OVER_TAIL_WINDOWS)
                .max(BETWEEN_TWO_WINDOWS);
        }
        matcher.compare_bands(bands);
        let read_ahead_frames = matcher.onsets.read_ahead_frames();
        matcher.stream_start = StreamStart::new(
            matcher.gates.pre_quiet_db,
            read_ahead_frames,
            matcher.analyzer.win.div_ceil(matcher.hop()),
            quiet_before_frames() as usize,
        );
        matcher.prime_powers = Vec::with_capacity(read_ahead_frames * BANDS);
        matcher.prime_levels = Vec::with_capacity(read_ahead_frames);
        matcher
    }

    /// Makes everything that depends on the bands compared again for the first
    /// `bands`: the cepstrum, the takes' features, how near they lie to one another and
    /// their shrink, the held patterns'
    /// spectra, the pairs' waits, the background's features; the tracked templates
    /// and kept instances start again. Allocates nothing: called while a stream runs,
    /// when it turns out to carry fewer bands than the takes ([`Passband`]).
    fn compare_bands(&mut self, bands: usize) {
        let cepstrum = &mut self.analyzer.cepstrum;
        cepstrum.set_bands(bands);
        let bands = cepstrum.bands();
        for t in &mut self.templates {
            features_of_power(&t.pooled_power, cepstrum, &mut t.features);
        }
        takes_agreement(&self.templates, &self.kinds, &mut self.takes_agree);
        shrink_takes_towards_their_mean(&mut self.templates, &self.kinds);
        for info in &mut self.patterns {
            info.sustain.copy_from_slice(&info.mean_frame);
            info.sustain[bands..].fill(0.0);
            normalise(&mut info.sustain[..bands]);
        }
        self.separating_scratch
            .waits(&self.templates, &self.kinds, cepstrum, &mut self.separating);
        self.background.compare_on(&self.background_full, cepstrum);
        self.talk.forget();
        self.tracked.forget();
        self.confirmed.forget();
        while self.lessons.pop().is_some() {}
    }

    /// Adds `own` (made by [`background_model`] with this matcher's settings, from a
    /// recording of sounds that must never fire: the user talking, the room) to the
    /// sounds an onset is compared with besides the patterns. Called while the
    /// detector is built, never per block.
    pub fn add_background(&mut self, own: &BackgroundModel) {
        self.background_full = self.background_full.joined(own);
        self.background = self.background_full.own_copy();
        self.background
            .compare_on(&self.background_full, &self.analyzer.cepstrum);
    }

    /// Keeps a record of every onset, and of every held sound's end, from now on (grows
    /// with the stream: offline).
    pub fn enable_explain(&mut self) {
        self.explain.get_or_insert_with(Vec::new);
        self.held_ends.get_or_insert_with(Vec::new);
    }

    /// Hands over the records kept since [`Self::enable_explain`].
    pub fn take_explain(&mut self) -> Option<Vec<OnsetRecord>> {
        self.explain.as_mut().map(std::mem::take)
    }

    /// Hands over the held sounds' ends kept since [`Self::enable_explain`].
    pub fn take_held_ends(&mut self) -> Option<Vec<HeldEndRecord>> {
        self.held_ends.as_mut().map(std::mem::take)
    }

    /// The top of the highest band compared, in Hz, when the input or the takes carry
    /// less than every band (`features::Analyzer::compare_under`); `None` when every band is.
    pub fn compared_top_hz(&self) -> Option<f64> {
        self.analyzer.cepstrum.top_hz(self.rate)
    }

    /// How near each pattern's takes lie to one another, by pattern
    /// ([`takes_agreement`]): `None` for a held pattern and one of a single take.
    pub fn takes_agreement(&self) -> Vec<Option<TakesAgree>> {
        self.takes_agree
            .iter()
            .map(|a| a.score.is_finite().then_some(*a))
            .collect()
    }

    /// By pattern, for an impulse pattern whose takes are one sound repeated (a teeth
    /// chatter, a trill: [`repeats_every`]), the longest gap between their attacks,
    /// seconds: an instance goes on, however many attacks it has, while they keep that
    /// pace ([`Self::continuation_lags`]). `None` for any other pattern.
    pub fn repeats_every_seconds(&self) -> Vec<Option<f64>> {
        self.patterns
            .iter()
            .map(|p| p.repeats_every.map(|frames| frames as f64 * HOP_SECONDS))
            .collect()
    }

    /// Pairs of patterns whose takes resemble each other over the decision window at
    /// least as much as `min_similarity` (the score an instance of one would give the
    /// other's take): pattern names and the best similarity of their takes, most alike
    /// first. Such patterns are easily taken for each other.
    ///
    /// With each pair that parts later ([`Separating`]), how much of a sound
    /// (seconds from its onset) a choice between the two hears.
    pub fn look_alike_patterns(&self, min_similarity: f32) -> Vec<AlikePair> {
        let mut pairs: Vec<(usize, usize, f32)> = Vec::new();
        for (i, a) in self.templates.iter().enumerate() {
            for b in &self.templates[i + 1..] {
                if a.pattern == b.pattern {
                    continue;
                }
                let (first, second) = (a.pattern.min(b.pattern), a.pattern.max(b.pattern));
                let similarity = similarity(&a.features, &b.features);
                match pairs.iter_mut().find(|p| (p.0, p.1) == (first, second)) {
                    Some(pair) => pair.2 = pair.2.max(similarity),
                    None => pairs.push((first, second, similarity)),
                }
            }
        }
        pairs.retain(|p| p.2 >= min_similarity);
        pairs.sort_by(|x, y| y.2.total_cmp(&x.2));
        pairs
            .into_iter()
            .map(|(a, b, s)| {
                let windows = self.separating[a * self.patterns.len() + b] as usize;
                AlikePair {
                    first: self.patterns[a].name.clone(),
                    second: self.patterns[b].name.clone(),
                    similarity: s,
                    decided_after_seconds: (windows > 1).then(|| self.heard_seconds(windows)),
                }
            })
            .collect()
    }

    /// Longest time from an impulse's onset to its decision, seconds: the decision
    /// frames (as many windows as the most alike pair of patterns waits for) and their
    /// shift, the frames the onset may be placed before its detection (the rise is
    /// looked for over 6 frames), and one window. An exact copy that only its waveform
    /// finds ([`Copies`]) is decided later, once its take's span is in, and an impulse
    /// dated back to its take's earlier placement (its soft start lost) by that much
    /// more.
    pub fn decision_delay_bound(&self) -> f64 {
        let frames =
            self.max_windows * self.decision_frames + MAX_SHIFT + PLACE_AFTER_FRAMES as usize + 6;
        (frames * self.hop() + self.analyzer.win) as f64 / self.rate
    }

    /// The sound a decision over `windows` decision windows waits for, seconds from
    /// the onset: to the end of the last frame that it pools, shift included (the
    /// onset's frame is centred on it).
    fn heard_seconds(&self, windows: usize) -> f64 {
        (windows * self.decision_frames + MAX_SHIFT) as f64 * HOP_SECONDS + WINDOW_SECONDS / 2.0
    }

    /// Samples per frame hop.
    fn hop(&self) -> usize {
        self.analyzer.hop
    }

    /// First sample of frame `f`'s window: frame 0 is computed once `win` samples
    /// have arrived, and each later one a hop after.
    fn frame_start(&self, f: u64) -> i64 {
        f as i64 * self.hop() as i64
    }

    fn sample(&self, n: u64) -> f32 {
        self.samples[ring_slot(&self.samples, n)]
    }

    pub fn push(&mut self, samples: &[f32], out: &mut Vec<Event>) {
        if self.finished {
            return;
        }
        for &x in samples {
            let slot = ring_slot(&self.samples, self.received);
            self.samples[slot] = x;
            self.heard_samples[slot] = self.low_cut.run(x);
            self.received += 1;
            if self.primed {
                self.advance(out);
            } else {
                self.read_ahead(out);
            }
        }
    }

    /// The stages take the next sample received: a frame every hop once a window's
    /// samples have come.
    fn advance(&mut self, out: &mut Vec<Event>) {
        self.consumed += 1;
        self.since_frame += 1;
        if self.since_frame == self.hop() {
            self.since_frame = 0;
            if self.consumed >= self.analyzer.win as u64 {
                self.compute_frame(out);
            }
        }
    }

    /// Reads the frame whose window ends at the sample just received ahead, until it is
    /// known how the stream begins ([`StreamStart`]); then primes the floors of the
    /// onset and level stages if it began with a sound ([`OnsetDetector::prime`]), and
    /// lets the stages take the samples read. Their decisions come once they have been
    /// read (`emitted_at`): this once, at most the onset stage's read-ahead (0.5 s) after
    /// the stream's start.
    fn read_ahead(&mut self, out: &mut Vec<Event>) {
        let (win, hop) = (self.analyzer.win as u64, self.hop() as u64);
        let end = self.received;
        if end < win || end % hop != 0 {
            return;
        }
        let frame = self.analyse_frame(end);
        self.prime_powers.extend_from_slice(&self.analyzer.power);
        self.prime_levels.push(frame);
        if let Some(frames) = self
            .stream_start
            .read(self.level_stage.heard_db(frame.heard))
        {
            self.prime(frames, out);
        }
    }

    /// Primes the floors with the first `frames` frames read ahead if the stream began
    /// with a sound ([`Levels::prime`] tells), and lets the stages take every sample
    /// received.
    fn prime(&mut self, frames: usize, out: &mut Vec<Event>) {
        let frames = frames.min(self.prime_levels.len());
        if frames > 0
            && self
                .level_stage
                .prime(&self.prime_levels[..frames], self.gates.pre_quiet_db)
        {
            self.onsets.prime(&self.prime_powers[..frames * BANDS]);
        }
        self.primed = true;
        while self.consumed < self.received {
            self.advance(out);
        }
    }

    /// Analyses the frame whose window ends at sample `end`: its log-mel frame into
    /// `frame_buf`, its band powers into the analyser's, and what the level stage takes
    /// of it (its energy as the bands hear it, and its newest hop's).
    fn analyse_frame(&mut self, end: u64) -> LevelInput {
        let win = self.analyzer.win;
        let start = end - win as u64;
        let (first, second) = ring_slices(&self.samples, start, win);
        self.window_buf[..first.len()].copy_from_slice(first);
        self.window_buf[first.len()..win].copy_from_slice(second);
        let frame_db = self.analyzer.frame(&self.window_buf, &mut self.frame_buf);
        let newest = end - self.hop() as u64;
        let (first, second) = ring_slices(&self.heard_samples, start, win);
        let heard = sum_of_squares(first) + sum_of_squares(second);
        let (first, second) = ring_slices(&self.heard_samples, newest, (end - newest) as usize);
        let newest_hop = sum_of_squares(first) + sum_of_squares(second);
        LevelInput {
            frame_db,
            heard,
            newest_hop,
            sound: holds_sound(&self.analyzer.power),
        }
    }

    /// Onsets detected but never classified because a bounded queue was full (onsets
    /// are at least 20 ms apart and wait at most `max_decision_seconds`, so none on
    /// any input so far).
    pub fn dropped_onsets(&self) -> u64 {
        self.placer.dropped()
            + self.pending_dropped
            + self.copies.dropped()
            + self.second_looks.dropped()
    }

    pub fn finish(&mut self, out: &mut Vec<Event>) {
        if self.finished {
            return;
        }
        // Enough silence for pending decisions and a held sound's end (and, after a
        // stream shorter than the read-ahead, its room: the samples end there).
        let pad =
            (self.max_windows * self.decision_frames + MAX_SHIFT + PLACE_AFTER_FRAMES as usize + 4)
                * self.hop()
                + self.analyzer.win
                + (self.held.params().gap_seconds * self.rate) as usize
                + self.copies.reach().max(self.second_looks.reach()) as usize;
        let end = self.received;
        const ZEROS: [f32; 256] = [0.0; 256];
        let mut left = pad;
        while left > 0 {
            let n = left.min(ZEROS.len());
            self.push(&ZEROS[..n], out);
            left -= n;
        }
        if !self.primed {
            self.prime(self.prime_levels.len(), out);
        }
        if let Some(h) = self.held.end() {
            self.close_held(h, out);
        }
        self.end_stopped_held();
        if self.dropped_onsets() > 0 {
            tracing::warn!(
                dropped = self.dropped_onsets(),
                "onsets came faster than they were decided and some were never classified"
            );
        }
        self.finished = true;
        let end_s = end as f64 / self.rate;
        super::keep_within(out, end_s);
        if let Some(records) = &mut self.explain {
            records.retain(|r| r.time < end_s);
        }
    }

    fn compute_frame(&mut self, out: &mut Vec<Event>) {
        let level_input = self.analyse_frame(self.consumed);
        self.passband.push(&self.analyzer.power);
        let f = self.frame_count;
        let slot = (f % self.frame_capacity as u64) as usize;
        self.frames[slot * BANDS..(slot + 1) * BANDS].copy_from_slice(&self.frame_buf);
        self.frame_count += 1;
        let frame_levels = self.level_stage.push(level_input);
        self.levels[slot] = frame_levels.sound;
        self.rise_levels[slot] = frame_levels.rise;
        self.heard_levels[slot] = frame_levels.heard;
        self.held_levels[slot] = frame_levels.held;

        let centre = self.analyzer.frame_centre(f);
        self.context.follow(
            centre,
            centre + self.hop() as u64 / 2,
            self.rise_levels[slot],
        );
        if let Some(onset) = self.onsets.push(&self.analyzer.power) {
            self.placer.detected(onset.frame);
        }
        let oldest = self.consumed.saturating_sub(self.samples.len() as u64);
        let samples = &self.samples;
        // The room's noise for placement: the level of its quietest frames.
        let noise_power = self.level_stage.noise_power();
        while let Some(time_sample) =
            self.placer
                .next(self.frame_count, self.consumed, oldest, noise_power, |n| {
                    samples[ring_slot(samples, n)]
                })
        {
            let frame = self.analyzer.frame_centred_on(time_sample);
            if self.pending.len() < self.pending.capacity() {
                self.pending.push(PendingOnset {
                    time_sample,
                    frame,
                    windows: 1,
                });
            } else {
                self.pending_dropped += 1;
            }
        }
        self.decide_pending(out);
        self.check_copies(out);
        self.check_second_looks(out);
        self.teach_due();
        self.learn_talk_due();
        self.follow_held(f, out);
        self.follow_stopped_held(f);
    }

    fn decide_pending(&mut self, out: &mut Vec<Event>) {
        while let Some(&PendingOnset {
            time_sample,
            frame,
            windows,
        }) = self.pending.first()
        {
            // Two detections 20 ms apart can be placed on the same attack, the first
            // late in its search and the second early in its own: once the first has
            // fired, the second is that sound again.
            if windows == 1
                && !self.off.same_onset
                && self
                    .last_fired
                    .is_some_and(|last| time_sample < last + self.min_gap_samples)
            {
                self.pending.remove(0);
                let fired = self.last_fired.map(|t| (t, t));
                self.explain_unscored(time_sample, Outcome::SameOnset, fired);
                continue;
            }
            if self.frame_count <= frame + (windows * self.decision_frames + MAX_SHIFT) as u64 {
                break;
            }
            match self.classify(time_sample, frame, windows, out) {
                Some(more) => self.pending[0].windows = more,
                None => {
                    self.pending.remove(0);
                }
            }
        }
    }

    /// Records an onset that was not scored, for `--explain`, and the samples of the
    /// sound held against it ([`OnsetRecord::because_of`]).
    fn explain_unscored(
        &mut self,
        time_sample: u64,
        outcome: Outcome,
        because_of: Option<(u64, u64)>,
    ) {
        let (time, decided_at) = (
            time_sample as f64 / self.rate,
            self.received as f64 / self.rate,
        );
        let because_of = because_of.map(|span| self.sound_span(span));
        if let Some(records) = &mut self.explain {
            records.push(OnsetRecord {
                because_of,
                ..OnsetRecord::unscored(time, decided_at, outcome)
            });
        }
    }

    /// Samples `from..=to` as seconds of stream.
    fn sound_span(&self, (from, to): (u64, u64)) -> SoundSpan {
        SoundSpan {
            from: from as f64 / self.rate,
            to: to as f64 / self.rate,
        }
    }

    /// The samples of the sound that the stage which decided `d` held against its onset
    /// ([`OnsetRecord::because_of`]); its peak and guard as its first look found them.
    fn because_of(&self, d: &Decision) -> Option<(u64, u64)> {
        match d.outcome {
            Outcome::SpeechGuard => self.guard_sound(d.time_sample, d.peak, d.guard),
            // A repeated sound goes on past its take's end: up to this onset.
            Outcome::Continuation => self
                .last_impulse
                .map(|last| (last.span.0, last.span.1.max(d.time_sample))),
            Outcome::HeldContinues => self.held.current().map(|h| (h.begin_sample, self.received)),
            Outcome::SameOnset => self.last_fired.map(|t| (t, t)),
            Outcome::Background => self
                .talk_nearest
                .filter(|_| d.evidence.by_own_talk())
                .map(|(_, at)| (at, at)),
            _ => None,
        }
    }

    /// Decides the onset at `time_sample` (frame `onset_frame`) with `windows` decision
    /// windows of its sound at hand; returns how many it needs when that is more.
    fn classify(
        &mut self,
        time_sample: u64,
        onset_frame: u64,
        windows: usize,
        out: &mut Vec<Event>,
    ) -> Option<usize> {
        // An onset back for more windows was looked at once already: its scores (still
        // in `pattern_scores`, as no other onset is classified before it is decided)
        // and its evidence are those of its first window.
        let first_look = match self.waiting.take() {
            Some(look) if windows > 1 => look,
            _ => self.first_look(time_sample, onset_frame)?,
        };
        let FirstLook {
            best: mut pi,
            mut context,
            early,
            peak,
            rise_peak,
            guard,
            clear_of_talk,
        } = first_look;
        // Over a fired word's tail, the onset's features are mostly the tail's: it is
        // named by what its takes add to the tail instead, where one explains enough.
        let judged_over_tail =
            self.judged_over_tail(context.over_fired_impulse, context.rise_db, pi);
        // Decision windows the choice of its pattern heard.
        let mut heard_windows = 1;
        if judged_over_tail && self.best_over_tail().is_some() {
            // A word's own closing consonant, said quicker than its take, is a burst
            // over the tail too; a new word goes on into its own sound. Both windows
            // must be explained.
            if windows < OVER_TAIL_WINDOWS {
                self.waiting = Some(first_look);
                return Some(OVER_TAIL_WINDOWS);
            }
            self.hear_over_tail(time_sample, onset_frame, OVER_TAIL_WINDOWS);
            heard_windows = OVER_TAIL_WINDOWS;
            if let Some(over_tail) = self.best_over_tail() {
                pi = over_tail;
                let share = self.over_tail_share(pi);
                context.continues_last_impulse =
                    self.continues_over_tail(time_sample, onset_frame, share);
            }
        }
        let mut evidence = self.as_instance_of(pi, &context, early);
        let mut outcome = decide(&evidence, &self.gates);
        // An onset that fires, whose runner-up is a pattern one window cannot tell from
        // its best, is decided between the two over as many windows as part them.
        let mut parted_over = 1;
        let mut waited_for = (heard_windows > 1).then_some(Wait::OverTail);
        if let Some(q) = self.runner_up(pi) {
            let n = self.patterns.len();
            let mut needed = if self.off.pair_waits {
                1
            } else {
                self.separating[pi * n + q] as usize
            };
            let mut why = Wait::PairAlikeAtFirst;
            // Named by its features, not over a tail, where the features are the tail's.
            if needed < BETWEEN_TWO_WINDOWS && heard_windows == 1 && self.between_two(pi, q) {
                needed = BETWEEN_TWO_WINDOWS;
                why = Wait::BetweenTwo;
            }
            if outcome == Outcome::Fired
                && needed > 1
                && self.pattern_scores[q].score >= self.patterns[q].threshold
            {
                if windows < needed {
                    self.waiting = Some(first_look);
                    return Some(needed);
                }
                parted_over = needed;
                waited_for = Some(why);
                let [over_p, over_q] = self.scores_over(needed, onset_frame, [pi, q]);
                if over_q > over_p {
                    pi = q;
                    evidence = self.as_instance_of(pi, &context, early);
                    outcome = decide(&evidence, &self.gates);
                }
            }
        }
        let dated_back = if outcome == Outcome::Fired {
            self.dated_back(pi, time_sample, judged_over_tail)
        } else {
            0
        };
        // Dated back onto the attack of the last sound that fired (a word found on its
        // vowel, whose consonant an onset of its own had found), it is that sound again.
        if dated_back > 0
            && !self.off.same_onset
            && self.last_fired.is_some_and(|last| {
                time_sample.saturating_sub(dated_back).abs_diff(last) < self.min_gap_samples
            })
        {
            outcome = Outcome::SameOnset;
        }
        let decision = Decision {
            time_sample,
            onset_frame,
            pattern: pi,
            evidence,
            outcome,
            guard,
            clear_of_talk,
            peak,
            rise_peak,
            judged_over_tail,
            heard_windows: parted_over.max(heard_windows),
            waited_for,
            dated_back,
        };
        if self.explain.is_some() {
            self.record(&decision);
        }
        self.cover_stopped(&decision);
        if outcome == Outcome::SpeechGuard
            && !self.off.heard_talk
            && self.patterns[decision.pattern].kind == PatternKind::Impulse
        {
            let take = self.pattern_scores[decision.pattern].take;
            let mut features = [0.0f32; FEATURES];
            features.copy_from_slice(&self.best_instance[..FEATURES]);
            self.talk_heard.push(TalkWaiting {
                time_sample,
                end_sample: time_sample + self.templates[take].length_after_onset,
                peak: decision.peak,
                features,
            });
        }
        // A second look fires what the background took, so it must pass the gates after
        // the background (a sound too faint to be the user's is not, however it falls
        // away). Over a fired word's tail the sound after the onset is partly that
        // word's; after talk, a word's last consonant falls away unvoiced too. What
        // counts as talk is what the speech guard counts over its usual span, whatever
        // it is set to: the user who turns it off wants hits right after talking found,
        // not talk.
        if outcome == Outcome::Background
            && !self.off.second_look
            && after_background(&decision.evidence, &self.gates) == Outcome::Fired
            && self.patterns[decision.pattern].kind == PatternKind::Impulse
            && !decision.evidence.over_fired_impulse
            && self.clear_of_talk_as_usual(time_sample, decision.peak)
        {
            self.second_looks.wait(Waiting {
                time_sample,
                pattern: decision.pattern,
                strength: decision.evidence.strength,
                score: decision.evidence.best_score,
            });
        }
        // The last impulse's sound going on, whatever stopped it first (the quiet before
        // a fast repetition holds the attack before it): a repeated sound goes on from it.
        if decision.evidence.continues_last_impulse {
            if let Some(last) = &mut self.last_impulse {
                last.last_attack_frame = onset_frame;
            }
        }
        if outcome != Outcome::Fired {
            // What its first window looked like may have misled the gates; what came
            // before it is the guard's to judge, and a user who plays a take back while
            // talking turns the guard off.
            if !matches!(outcome, Outcome::SpeechGuard | Outcome::SameOnset) && !self.off.copies {
                self.copies.wait(time_sample);
            }
            return None;
        }
        let taught = self.fire(&decision, out);
        if let Some(record) = self.explain.as_mut().and_then(|r| r.last_mut()) {
            record.taught = taught;
        }
        None
    }

    /// Records what became of an onset, for `--explain`.
    fn record(&mut self, d: &Decision) {
        let pi = d.pattern;
        let evidence = &d.evidence;
        let second = self
            .runner_up(pi)
            .map(|p| (p, self.pattern_scores[p].score));
        let name = |i: usize| self.patterns[i].name.clone();
        let record = OnsetRecord {
            time: d.time_sample as f64 / self.rate,
            decided_at: self.received as f64 / self.rate,
            best: Some(name(pi)),
            best_score: Some(f64::from(evidence.best_score)),
            second: second.map(|s| name(s.0)),
            second_score: second.map(|s| f64::from(s.1)),
            strength: Some(evidence.strength),
            background_score: (!self.background.is_empty())
                .then_some(f64::from(self.background_score)),
            talk_score: self.talk_nearest.map(|(score, _)| f64::from(score)),
            rise_db: evidence
                .rise_db
                .is_finite()
                .then_some(f64::from(evidence.rise_db)),
            over_fired_impulse: evidence.over_fired_impulse,
            explained_over_tail: d
                .judged_over_tail
                .then_some(f64::from(evidence.explained_over_tail)),
            guard_by_stopped_speech: d.outcome == Outcome::SpeechGuard
                && d.guard == Guard::ClosedByStopped,
            window_seconds: Some(self.heard_seconds(d.heard_windows)),
            waited_for: d.waited_for,
            matched_by: Some(self.pattern_scores[pi].matched_by),
            outcome: d.outcome,
            // Known once it has fired.
            taught: None,
            because_of: self.because_of(d).map(|span| self.sound_span(span)),
        };
        if let Some(records) = &mut self.explain {
            records.push(record);
        }
    }

    /// A sound the guard stopped, but that the threshold and the background would have
    /// let through, is a pattern's sound too: it covers its span as a fired one does, so
    /// the guard does not feed on its own decisions (only sounds that are none of the
    /// patterns keep it closed). So is one that only `min_strength` stopped: too faint
    /// to be the user's, but no talk, so that a performer quieter than the takes is not
    /// stopped by their own fainter sounds. One that lies as near speech as to its
    /// pattern (within the background's margin either way) and that the guard stopped
    /// on unrecognised sound is that talk going on: it counts as unrecognised sound, but
    /// what it alone closes the guard on covers again, so a stop passes on once at most
    /// (`docs/speech-guard.md`).
    fn cover_stopped(&mut self, d: &Decision) {
        let evidence = &d.evidence;
        if self.off.cover_stopped
            || !matches!(d.outcome, Outcome::SpeechGuard | Outcome::MinStrength)
            || evidence.below_threshold()
            || evidence.like_speech(&self.gates)
        {
            return;
        }
        let pi = d.pattern;
        let covered_from = self.covered_from(d.time_sample);
        let near_speech = d.guard == Guard::Closed
            && evidence.best_score - evidence.speech_score() < self.gates.background_margin;
        if self.patterns[pi].kind == PatternKind::Continuous {
            // A held sound covers as long as the held stage hears it go on.
            self.end_stopped_held();
            self.held_room[Stage::Stopped as usize] = self.room_under(d.onset_frame);
            let loudest = self.held_loudest_since(Stage::Stopped, d.onset_frame);
            let slot = self.context.held_began(covered_from, near_speech);
            self.stopped_held_span = Some((slot, covered_from));
            self.stopped_held.begin(
                pi,
                d.time_sample,
                evidence.best_score,
                loudest,
                self.frame_count - 1,
            );
        } else {
            let take = self.pattern_scores[pi].take;
            let to = d.time_sample + self.templates[take].length_after_onset;
            self.context
                .stopped_impulse(covered_from, to, near_speech, d.rise_peak);
        }
    }

    /// Fires the onset's pattern: its event (an impulse, or the begin of a held sound,
    /// which the held stage then follows), and what the context, tracking and the copies
    /// stage keep of it; for an impulse, what it taught tracking.
    fn fire(&mut self, d: &Decision, out: &mut Vec<Event>) -> Option<Taught> {
        let (pi, time_sample, onset_frame) = (d.pattern, d.time_sample, d.onset_frame);
        let Evidence {
            best_score,
            strength,
            ..
        } = d.evidence;
        let best_template = self.pattern_scores[pi].take;
        let covered_from = self.covered_from(time_sample);
        self.last_fired = Some(time_sample);
        let take_length = self.templates[best_template].length_after_onset;
        // The impulse, or the begin marker of a held sound (the daemon sends it at
        // once; the detector keeps it only for callers that asked for begins).
        let began = time_sample.saturating_sub(d.dated_back);
        let decided = self.decided(pi, began, strength, best_score);
        let kind = self.patterns[pi].kind;
        if kind == PatternKind::Continuous {
            // A held sound it replaces ends first (a stopped one that was followed as
            // well), so that its end does not close the new one's span.
            self.end_stopped_held();
            self.held_room[Stage::Fired as usize] = self.room_under(onset_frame);
            let loudest = self.held_loudest_since(Stage::Fired, onset_frame);
            let newest = self.frame_count - 1;
            if let Some(h) = self
                .held
                .begin(pi, time_sample, best_score, loudest, newest)
            {
                self.close_held(h, out);
            }
            let slot = self.context.held_began(covered_from, false);
            self.held_span = Some((slot, covered_from));
        } else {
            self.context.fired_impulse(
                covered_from,
                time_sample + take_length,
                d.rise_peak,
                time_sample + SPAN_STRETCH * take_length,
            );
        }
        let mut first_attack = [0.0f32; FEATURES];
        let mut first_attack_energy = 0.0;
        if kind == PatternKind::Impulse && self.patterns[pi].repeats_every.is_some() {
            self.pool_instance(onset_frame);
            first_attack.copy_from_slice(&self.instance[..FEATURES]);
            first_attack_energy = self.in_compared_bands(
                self.decision_window_energy(time_sample),
                &self.instance_power,
            );
        }
        self.last_impulse = (kind == PatternKind::Impulse).then_some(FiredImpulse {
            template: best_template,
            span: (began, time_sample + take_length),
            onset_frame,
            strength,
            last_attack_frame: onset_frame,
            first_attack,
            first_attack_energy,
        });
        let taught = if kind == PatternKind::Impulse {
            self.copies.fired(time_sample, pi);
            // Taught at once, for the next onsets; kept once the sound after it shows
            // it was not talk ([`Self::teach_due`]).
            let lesson = self.lesson(pi, covered_from, time_sample + take_length, d);
            (!self.off.tracking).then(|| {
                let taught = self
                    .tracked
                    .follow(pi, &lesson.instance(&self.patterns, &self.takes_agree));
                if taught.learnt() {
                    self.lessons.push(lesson);
                }
                taught
            })
        } else {
            None
        };
        out.push(decided);
        taught
    }

    /// The event of pattern `pi` whose onset is at `time_sample`, decided now.
    fn decided(&self, pi: usize, time_sample: u64, strength: f64, score: f32) -> Event {
        let info = &self.patterns[pi];
        Event {
            id: 0,
            pattern: info.name.clone(),
            kind: info.kind,
            time: time_sample as f64 / self.rate,
            end: None,
            strength,
            score: f64::from(score),
            emitted_at: self.received as f64 / self.rate,
            pitch: None,
        }
    }

    /// Checks each onset that did not fire, once its sound is in, for an exact copy of
    /// a take ([`Copies`]), and fires the copies found.
    fn check_copies(&mut self, out: &mut Vec<Event>) {
        while let Some(onset) = self.copies.due(self.consumed) {
            let samples = &self.samples;
            let noise_power = self.level_stage.noise_power();
            let Some(found) = self
                .copies
                .check(onset, noise_power, |n| samples[ring_slot(samples, n)])
            else {
                continue;
            };
            if found.strength < self.gates.min_strength {
                continue;
            }
            // What the copy spans is recognised sound, for the speech guard.
            self.context
                .stopped(found.time_sample, found.time_sample + found.len, false);
            let event = self.decided(
                found.pattern,
                found.time_sample,
                found.strength,
                found.similarity,
            );
            if let Some(records) = &mut self.explain {
                records.push(OnsetRecord {
                    best: Some(event.pattern.clone()),
                    best_score: Some(event.score),
                    strength: Some(event.strength),
                    window_seconds: Some(found.len as f64 / self.rate),
                    ..OnsetRecord::unscored(event.time, event.emitted_at, Outcome::Copy)
                });
            }
            out.push(event);
        }
    }

    /// Whether the onset at `time_sample` (its sound's peak `peak`, dB) was heard clear
    /// of talk over the speech guard's default span ([`Context::guard`]).
    fn clear_of_talk_as_usual(&self, time_sample: u64, peak: f32) -> bool {
        let span = (DEFAULT_SPEECH_GUARD_SECONDS * self.rate) as u64;
        self.context
            .guard(self.frames_before(time_sample, span), peak)
            .clear_of_talk
    }

    /// Fires each impulse the background took for speech whose sound has since fallen
    /// away unvoiced ([`super::syllable`]), dated at its onset.
    fn check_second_looks(&mut self, out: &mut Vec<Event>) {
        loop {
            let samples = &self.samples;
            let Some((onset, afterwards)) =
                self.second_looks.due(self.consumed, &mut self.pitch, |n| {
                    samples[ring_slot(samples, n)]
                })
            else {
                return;
            };
            if !afterwards.fell_away(self.second_looks.params()) {
                continue;
            }
            let Waiting {
                time_sample,
                pattern,
                strength,
                score,
            } = onset;
            // What it spans is recognised sound, for the speech guard, and a copy of a
            // take there has fired.
            let after = self.second_looks.reach();
            self.context
                .stopped(time_sample, time_sample + after, false);
            self.copies.fired(time_sample, pattern);
            let event = self.decided(pattern, time_sample, strength, score);
            if let Some(records) = &mut self.explain {
                records.push(OnsetRecord {
                    best: Some(event.pattern.clone()),
                    best_score: Some(event.score),
                    strength: Some(event.strength),
                    window_seconds: Some(after as f64 / self.rate),
                    ..OnsetRecord::unscored(event.time, event.emitted_at, Outcome::FellAway)
                });
            }
            out.push(event);
        }
    }

    /// Scores the onset at `time_sample` (frame `onset_frame`) over its first window and
    /// gathers the evidence that does not depend on the pattern; `None` without patterns
    /// (a matcher that only collects onsets' features for a background model).
    fn first_look(&mut self, time_sample: u64, onset_frame: u64) -> Option<FirstLook> {
        let peak = self.loudest_since(&self.levels, onset_frame);
        let rise_peak = self.loudest_since(&self.rise_levels, onset_frame);
        let rise_db = rise_peak - self.loudest_before(time_sample);
        if self.collected.is_some() && rise_db >= self.gates.pre_quiet_db {
            self.pool_instance(onset_frame);
            if let Some(collected) = &mut self.collected {
                collected.extend_from_slice(&self.instance);
            }
        }
        if self.templates.is_empty() {
            return None;
        }
        let rise_db = if self.off.quiet_before {
            f32::INFINITY
        } else {
            rise_db
        };
        // Only the bands that the stream, as its loudest frames so far show it, carries
        // too are compared.
        let stream_top = self
            .passband
            .top_hz_over_noise(self.onsets.band_floors(), self.onsets.room_over_floor());
        let bands = present_bands(self.rate, self.carried_top_hz.min(stream_top));
        if bands != self.analyzer.cepstrum.bands() {
            self.compare_bands(bands);
        }
        // The decision window's energy in the bands compared, once per onset (its power
        // pooled anew: scoring leaves the last shift's).
        let early = {
            let mut power = [0.0f32; BANDS];
            let (cap, k) = (self.frame_capacity, self.decision_frames);
            pool_ring(&self.frames, cap, onset_frame, k, &mut power);
            self.in_compared_bands(self.decision_window_energy(time_sample), &power)
        };
        self.score_patterns(time_sample, onset_frame);
        let mut best = 0;
        for (p, s) in self.pattern_scores.iter().enumerate() {
            if s.score > self.pattern_scores[best].score {
                best = p;
            }
        }
        let Before {
            guard,
            clear_of_talk,
        } = self.guard(time_sample, peak);
        let over_fired_impulse = self.over_fired_impulse(time_sample);
        self.over_tail_shares.fill(0.0);
        if self.judged_over_tail(over_fired_impulse, rise_db, best) {
            self.hear_over_tail(time_sample, onset_frame, 1);
        }
        let context = Evidence {
            rise_db,
            over_fired_impulse,
            follows_unrecognised_sound: guard != Guard::Open && !self.off.speech_guard,
            continues_last_impulse: (!self.off.continuation
                && self.continues_last_impulse(
                    time_sample,
                    onset_frame,
                    self.pattern_scores[best].score,
                ))
                || (!self.off.soft_start_attack && self.attack_after_soft_start(onset_frame, best)),
            background_score: self.background_score,
            talk_score: self
                .talk_nearest
                .map_or(f32::NEG_INFINITY, |(score, _)| score),
            best_score: f32::NEG_INFINITY,
            best_is_impulse: false,
            explained_over_tail: 0.0,
            threshold: 0.0,
            held_by_best_pattern: false,
            strength: 0.0,
        };
        Some(FirstLook {
            best,
            context,
            early,
            peak,
            rise_peak,
            guard,
            clear_of_talk,
        })
    }

    /// Sets `over_tail_shares` for the onset at `time_sample` (frame `onset_frame`),
    /// which lies over a fired word's tail: the share of its decision window
    /// `window` (1 or 2) that each impulse take's window as far after its onset
    /// explains over the mean power of the onset's quiet-before span, in the room's
    /// noise (as `score_patterns` set it for this onset); over the second window, the
    /// lesser of that and the first's.
    fn hear_over_tail(&mut self, time_sample: u64, onset_frame: u64, window: usize) {
        let k = self.decision_frames;
        let onset = self.window_power(onset_frame, window);
        let before = self.tail_before(time_sample);
        let bands = self.analyzer.cepstrum.bands();
        for (t, share) in self.templates.iter().zip(self.over_tail_shares.iter_mut()) {
            if self.patterns[t.pattern].kind != PatternKind::Impulse {
                continue;
            }
            // The take's window as far after its onset (none when the take is shorter).
            let explained = t.window_at((window - 1) * k).map_or(0.0, |take| {
                share_explained_over_tail(&onset, &before, self.room.noise(), take, bands)
            });
            *share = if window == 1 {
                explained
            } else {
                share.min(explained)
            };
        }
    }

    /// The pooled power spectrum of decision window `window` (1, 2, ...) of the onset at
    /// frame `onset_frame`.
    fn window_power(&mut self, onset_frame: u64, window: usize) -> [f32; BANDS] {
        let k = self.decision_frames;
        self.pool_frames(onset_frame + ((window - 1) * k) as u64, k);
        let mut power = [0.0f32; BANDS];
        power.copy_from_slice(&self.instance_power);
        power
    }

    /// The mean power spectrum of the quiet-before span of the onset at `time_sample`:
    /// the tail it began over.
    fn tail_before(&self, time_sample: u64) -> [f32; BANDS] {
        let (from, to) = self.quiet_before_span(time_sample);
        let (first, end) = self
            .frames_inside(from, to)
            .fold((u64::MAX, 0), |(a, b), f| (a.min(f), b.max(f + 1)));
        let mut before = [0.0f32; BANDS];
        pool_ring(
            &self.frames,
            self.frame_capacity,
            first,
            end.saturating_sub(first) as usize,
            &mut before,
        );
        before
    }

    /// Whether the onset at `time_sample` (frame `onset_frame`), named over a fired
    /// word's tail by a take explaining `new_share` of it, is that word's own later
    /// sound instead: the fired take's own windows as many frames after its onset
    /// (give or take `CONTINUATION_SLACK_SECONDS`), added to the tail, explain at least
    /// as much of each of the onset's `OVER_TAIL_WINDOWS` windows. Asked in the terms
    /// the new word was, because the similarity [`Self::continues_last_impulse`] asks
    /// hears the tail in the onset's features, which the fired word's later sound
    /// always resembles.
    fn continues_over_tail(&mut self, time_sample: u64, onset_frame: u64, new_share: f32) -> bool {
        let Some(ContinuationLags { last, lags, .. }) = self.continuation_lags(onset_frame) else {
            return false;
        };
        let windows: [[f32; BANDS]; OVER_TAIL_WINDOWS] =
            std::array::from_fn(|w| self.window_power(onset_frame, w + 1));
        let before = self.tail_before(time_sample);
        let (k, bands) = (self.decision_frames, self.analyzer.cepstrum.bands());
        let take = &self.templates[last.template];
        lags.into_iter().any(|lag| {
            windows.iter().enumerate().all(|(w, onset)| {
                take.window_at(lag + w * k).is_some_and(|later| {
                    share_explained_over_tail(onset, &before, self.room.noise(), later, bands)
                        >= new_share
                })
            })
        })
    }

    /// The share of the onset's sound over a fired word's tail that pattern `pi`'s
    /// takes explain: its best take's.
    fn over_tail_share(&self, pi: usize) -> f32 {
        self.templates
            .iter()
            .zip(&self.over_tail_shares)
            .filter(|(t, _)| t.pattern == pi)
            .map(|(_, &s)| s)
            .fold(0.0, f32::max)
    }

    /// The impulse pattern whose takes explain most of the onset's sound over a fired
    /// word's tail, when that share reaches `GateParams::over_tail_share`.
    fn best_over_tail(&self) -> Option<usize> {
        let (pi, share) = (0..self.patterns.len())
            .map(|pi| (pi, self.over_tail_share(pi)))
            .max_by(|a, b| a.1.total_cmp(&b.1))?;
        (share >= self.gates.over_tail_share).then_some(pi)
    }

    /// Whether the onset, whose best pattern over its first window is `best`, is judged
    /// by what a take adds to a fired word's tail (`over_tail_shares`): it lies over
    /// one (`over_fired_impulse`), did not rise out of it (`rise_db`), and is no clear
    /// instance of an impulse pattern (`GateParams::over_fired_score`), which is
    /// excused the rise as it is.
    fn judged_over_tail(&self, over_fired_impulse: bool, rise_db: f32, best: usize) -> bool {
        let clear_instance = self.patterns[best].kind == PatternKind::Impulse
            && self.pattern_scores[best].score >= self.gates.over_fired_score;
        self.waits_a_window
            && !self.off.over_tail
            && over_fired_impulse
            && rise_db < self.gates.pre_quiet_db
            && !clear_instance
    }

    /// The evidence about the onset being classified as an instance of pattern `pi`:
    /// `context` with the pattern's own score, threshold, held sound and strength
    /// (`early`, the energy of the onset's decision window, against its best take's, both
    /// in the bands compared).
    fn as_instance_of(&self, pi: usize, context: &Evidence, early: f64) -> Evidence {
        let PatternScore { score, take, .. } = self.pattern_scores[pi];
        Evidence {
            best_score: score,
            best_is_impulse: self.patterns[pi].kind == PatternKind::Impulse,
            explained_over_tail: self.over_tail_share(pi),
            threshold: self.patterns[pi].threshold,
            held_by_best_pattern: self.held.current().is_some_and(|h| h.pattern == pi),
            strength: (early / self.take_energy(take).max(1e-12)).sqrt(),
            ..*context
        }
    }

    /// The pattern that scored best after `pi` on the onset being classified.
    fn runner_up(&self, pi: usize) -> Option<usize> {
        self.pattern_scores
            .iter()
            .enumerate()
            .filter(|&(p, s)| p != pi && s.take != usize::MAX)
            .max_by(|a, b| a.1.score.total_cmp(&b.1.score))
            .map(|(p, _)| p)
    }

    /// Whether the onset's first window lies between impulse patterns `pi` (its best)
    /// and `q` (its runner-up): `q` scores within `BETWEEN_TWO_GAP` of `pi`, and a
    /// decision may wait for more of the sound.
    fn between_two(&self, pi: usize, q: usize) -> bool {
        let impulse = |p: usize| self.patterns[p].kind == PatternKind::Impulse;
        self.waits_a_window
            && !self.off.between_two
            && impulse(pi)
            && impulse(q)
            && self.pattern_scores[q].score >= self.pattern_scores[pi].score - BETWEEN_TWO_GAP
    }

    /// The best score of each of `pair`'s takes over `windows` decision windows from
    /// the onset at frame `onset_frame`, each take heard in the onset's room and
    /// allowing the same shift as one window's scoring.
    fn scores_over(&mut self, windows: usize, onset_frame: u64, pair: [usize; 2]) -> [f32; 2] {
        let mut best = [f32::NEG_INFINITY; 2];
        for shift in 0..=2 * MAX_SHIFT {
            let first = (onset_frame + shift as u64).saturating_sub(MAX_SHIFT as u64);
            self.pool_frames(first, windows * self.decision_frames);
            self.room
                .hear(&self.instance_power, self.analyzer.cepstrum.bands());
            for t in &self.templates {
                let Some(i) = pair.iter().position(|&p| p == t.pattern) else {
                    continue;
                };
                window_power(t, windows, self.decision_frames, &mut self.take_power);
                self.room.take(
                    &self.take_power,
                    None,
                    &self.analyzer.cepstrum,
                    &mut self.heard_take,
                );
                best[i] = best[i].max(similarity(&self.heard_take, &self.instance));
            }
        }
        best
    }

    /// The loudest of the frames before the onset at `time_sample` whose whole window
    /// lies in its quiet-before span, over the noise of whole periods of hum
    /// (`rise_levels`, dB of sound). How far an onset's sound rises over it is the
    /// quiet-before rise: a vocal hit stands out of relative quiet; a consonant inside
    /// speech follows a vowel, so an onset whose last tens of milliseconds were nearly
    /// as loud is rejected.
    fn loudest_before(&self, time_sample: u64) -> f32 {
        let cap = self.frame_capacity as u64;
        let (quiet_from, quiet_to) = self.quiet_before_span(time_sample);
        self.frames_inside(quiet_from, quiet_to)
            .map(|f| self.rise_levels[(f % cap) as usize])
            .fold(f32::NEG_INFINITY, f32::max)
    }

    /// Whether a frame of the quiet-before span of the onset at `time_sample` lies in
    /// an impulse that fired: the onset then begins over that word's tail, not inside
    /// sound that no pattern recognised (judged by the sample at a frame's centre). A
    /// held sound that fired does not count: a voice's vowel in speech can start one,
    /// and the syllables after it would then be excused.
    fn over_fired_impulse(&self, time_sample: u64) -> bool {
        let (quiet_from, quiet_to) = self.quiet_before_span(time_sample);
        self.frames_inside(quiet_from, quiet_to)
            .any(|f| self.context.fired_at(self.analyzer.frame_centre(f)))
    }

    /// Where a recognised sound that begins at `time_sample` is covered from, for the
    /// speech guard: where the guard's look ends before it.
    fn covered_from(&self, time_sample: u64) -> u64 {
        self.quiet_before_span(time_sample).1
    }

    /// The samples `[from, to)` before the onset at `time_sample` that its sound must
    /// rise out of (`PRE_QUIET_FROM_SECONDS` to `PRE_QUIET_TO_SECONDS` before it).
    fn quiet_before_span(&self, time_sample: u64) -> (u64, u64) {
        let before = |seconds: f64| time_sample.saturating_sub((seconds * self.rate) as u64);
        (before(PRE_QUIET_FROM_SECONDS), before(PRE_QUIET_TO_SECONDS))
    }

    /// Scores the onset at frame `onset_frame` against every pattern's takes and
    /// tracked template and kept instances, at each shift, into `pattern_scores`; keeps
    /// the features that scored best in `best_instance`.
    fn score_patterns(&mut self, time_sample: u64, onset_frame: u64) {
        self.pattern_scores.fill(PatternScore::NONE);
        self.background_score = f32::NEG_INFINITY;
        self.talk_nearest = None;
        let mut best = f32::NEG_INFINITY;
        self.room.set(self.onsets.band_floors());
        for shift in 0..=2 * MAX_SHIFT {
            self.pool_instance((onset_frame + shift as u64).saturating_sub(MAX_SHIFT as u64));
            self.room
                .hear(&self.instance_power, self.analyzer.cepstrum.bands());
            for (ti, t) in self.templates.iter().enumerate() {
                self.room.take(
                    &t.pooled_power,
                    t.drawn_towards.as_deref(),
                    &self.analyzer.cepstrum,
                    &mut self.heard_take,
                );
                let score = similarity(&self.heard_take, &self.instance);
                let s = &mut self.pattern_scores[t.pattern];
                if score > s.take_score {
                    s.take_score = score;
                    s.take = ti;
                }
                if score > s.score {
                    s.score = score;
                    s.matched_by = MatchedBy::Take;
                }
                if score > best {
                    best = score;
                    self.best_instance.copy_from_slice(&self.instance);
                }
            }
            self.background_score = self
                .background_score
                .max(self.background.nearest(&self.instance));
            if let Some(talk) = self.talk.nearest(&self.instance, time_sample) {
                if self.talk_nearest.is_none_or(|(best, _)| talk.0 > best) {
                    self.talk_nearest = Some(talk);
                }
            }
            for (pi, s) in self.pattern_scores.iter_mut().enumerate() {
                let tracked = self.tracked.template(pi).map(|t| (MatchedBy::Tracked, t));
                let kept = self.tracked.kept(pi).map(|t| (MatchedBy::Kept, t));
                for (by, template) in tracked.into_iter().chain(kept) {
                    let score = similarity(template, &self.instance);
                    if score > s.score {
                        s.score = score;
                        s.matched_by = by;
                    }
                    if score > best {
                        best = score;
                        self.best_instance.copy_from_slice(&self.instance);
                    }
                }
            }
        }
    }

    /// What the impulse of pattern `pi` that fires as decided in `d`, its span for the
    /// speech guard beginning at `covered_from` and its take's sound ending at
    /// `end_sample`, teaches tracking ([`Tracked::follow`]):
    /// this instance as it scored, whether it began over a fired word's tail, and
    /// whether it was heard amid talk ([`Context::guard`]).
    fn lesson(&self, pi: usize, covered_from: u64, end_sample: u64, d: &Decision) -> Lesson {
        let other = self
            .pattern_scores
            .iter()
            .enumerate()
            .filter(|&(p, _)| p != pi)
            .map(|(_, s)| s.score)
            .fold(f32::NEG_INFINITY, f32::max);
        let mut features = [0.0f32; FEATURES];
        features.copy_from_slice(&self.best_instance[..FEATURES]);
        Lesson {
            pattern: pi,
            time_sample: d.time_sample,
            end_sample,
            peak: d.peak,
            covered_from,
            features,
            score: self.pattern_scores[pi].score,
            take_score: self.pattern_scores[pi].take_score,
            other,
            over_fired_impulse: d.evidence.over_fired_impulse,
            amid_talk: !d.clear_of_talk,
        }
    }

    /// Settles what each impulse that fired taught tracking once the speech guard's span
    /// after its take's sound is in. Tracking learnt from it at once; heard clear of
    /// talk after it as well as before, the lesson is kept (`confirmed`); otherwise
    /// tracking becomes what the kept lessons and those still waiting taught. A
    /// syllable that fires at the start of an utterance follows silence, as a hit does,
    /// but the rest of its word follows it; a template moved to it finds the next
    /// syllables, and those moved it further (`docs/classify.md`, "Tracking kept only
    /// when no talk follows").
    fn teach_due(&mut self) {
        let span = self.guard_samples();
        while let Some(lesson) = self.lessons.front() {
            let due = lesson.end_sample + span;
            if self.consumed < due {
                return;
            }
            self.lessons.pop();
            // Judged without its own span, which grows over whatever sound goes on
            // after it: talk after a syllable taken for a word would confirm it.
            let after =
                self.context
                    .guard_after(self.guard_frames(due), lesson.peak, lesson.covered_from);
            if after.clear_of_talk {
                let instance = lesson.instance(&self.patterns, &self.takes_agree);
                self.confirmed.follow(lesson.pattern, &instance);
                continue;
            }
            self.tracked.copy_from(&self.confirmed);
            for waiting in self.lessons.iter() {
                let instance = waiting.instance(&self.patterns, &self.takes_agree);
                self.tracked.follow(waiting.pattern, &instance);
            }
            if let Some(records) = &mut self.explain {
                let time = lesson.time_sample as f64 / self.rate;
                let fired = records
                    .iter_mut()
                    .rev()
                    .find(|r| r.outcome == Outcome::Fired && r.time == time);
                if let Some(record) = fired {
                    record.taught = Some(Taught::NothingTalkAfter);
                }
            }
        }
    }

    /// Learns the onsets the guard stopped that were inside talk ([`HeardTalk`]). First,
    /// once a second look's stretch of its sound is in, whether it went on as a
    /// syllable does ([`Afterwards::went_on_as_a_syllable`]; a hit falls away, and most
    /// of a beatbox kit's sounds are unvoiced); then, once the guard's span after its
    /// take's length is in, whether talk followed it (as much as keeps an impulse that
    /// fired from teaching tracking). Its own sound is talk only where the guard counts
    /// it so: a pattern's sound that only the guard stopped covers its span
    /// ([`Self::cover_stopped`]), so a word said straight after talking, and then clear
    /// of it, teaches nothing.
    fn learn_talk_due(&mut self) {
        let (window, after) = (self.second_looks.window(), self.second_looks.reach());
        while let Some(heard) = self.talk_heard.front() {
            if self.consumed < heard.time_sample + after {
                break;
            }
            self.talk_heard.pop();
            let samples = &self.samples;
            let afterwards =
                Afterwards::measure(heard.time_sample, window, after, &mut self.pitch, |n| {
                    samples[ring_slot(samples, n)]
                });
            if afterwards.went_on_as_a_syllable() {
                self.talk_waiting.push(heard);
            }
        }
        let span = self.guard_samples();
        while let Some(waiting) = self.talk_waiting.front() {
            let due = waiting.end_sample + span;
            if self.consumed < due {
                return;
            }
            self.talk_waiting.pop();
            if !self.guard(due, waiting.peak).clear_of_talk {
                self.talk.learn(&waiting.features, waiting.time_sample);
            }
        }
    }

    /// Energy of the samples (received so far) of the decision window from
    /// `time_sample`.
    fn decision_window_energy(&self, time_sample: u64) -> f64 {
        let decision_len = (self.decision_frames * self.hop()) as u64;
        (time_sample..time_sample + decision_len)
            .filter(|&n| n < self.consumed)
            .map(|n| f64::from(self.sample(n)).powi(2))
            .sum()
    }

    /// Samples before its onset at `time_sample` that a sound of pattern `pi`, about to
    /// fire, is dated. One found by the later placement of a take that a quiet room
    /// places earlier began that much before where it was placed when its soft start
    /// was lost under the room or the last sound's tail. It is dated there, as a copy
    /// is, when both say so: its own features chose that placement (over a fired word's
    /// tail they are mostly the tail's, and the take that scored best says nothing of
    /// where the sound began), and the sound there is at least as loud, against the
    /// instance's first window, as the take's soft start is against its own (quieter,
    /// nothing hid a soft start: the onset was placed on it, or it has none).
    fn dated_back(&self, pi: usize, time_sample: u64, judged_over_tail: bool) -> u64 {
        let template = &self.templates[self.pattern_scores[pi].take];
        if !self.off.dated_back
            && template.after_earlier > 0
            && !judged_over_tail
            && self.hides_a_soft_start(
                time_sample,
                template.after_earlier,
                template.soft_start_share,
            )
        {
            template.after_earlier
        } else {
            0
        }
    }

    /// Whether the `span` samples before `time_sample` hold a sound whose mean power is
    /// at least `share` of the decision window's from `time_sample`.
    fn hides_a_soft_start(&self, time_sample: u64, span: u64, share: f64) -> bool {
        let decision_len = (self.decision_frames * self.hop()) as u64;
        self.mean_power_between(time_sample.saturating_sub(span), time_sample)
            >= share * self.mean_power_between(time_sample, time_sample + decision_len)
    }

    /// Mean power of the stream's samples `[from, to)`, of those the ring still holds
    /// and has received (0 when none).
    fn mean_power_between(&self, from: u64, to: u64) -> f64 {
        let lo = from.max(self.consumed.saturating_sub(self.samples.len() as u64));
        let hi = to.min(self.consumed);
        let energy: f64 = (lo..hi).map(|n| f64::from(self.sample(n)).powi(2)).sum();
        energy / hi.saturating_sub(lo).max(1) as f64
    }

    /// `energy`, of a window whose mean power spectrum is `power`, in the bands compared
    /// ([`share_in_bands`]).
    fn in_compared_bands(&self, energy: f64, power: &[f32]) -> f64 {
        energy * share_in_bands(power, self.analyzer.cepstrum.bands())
    }

    /// The share in the bands compared ([`share_in_bands`]) of the power of a mean frame
    /// (dB per band).
    fn share_of_mean_frame(&self, mean_db: &[f32]) -> f64 {
        let mut power = [0.0f32; BANDS];
        for (p, db) in power.iter_mut().zip(mean_db) {
            *p = 10f32.powf(db / 10.0);
        }
        share_in_bands(&power, self.analyzer.cepstrum.bands())
    }

    /// The mean frame (dB per band) of the frames still in the ring centred in samples
    /// `lo..hi` (the one nearest `lo` when none is).
    fn mean_frame_between(&self, lo: u64, hi: u64) -> [f32; BANDS] {
        let cap = self.frame_capacity as u64;
        let newest = self.frame_count.saturating_sub(1);
        let oldest = self.frame_count.saturating_sub(cap);
        let first = self.analyzer.frame_centred_on(lo).clamp(oldest, newest);
        let last = self
            .analyzer
            .frame_centred_on(hi.saturating_sub(1))
            .clamp(first, newest);
        let mut mean = [0.0f32; BANDS];
        for f in first..=last {
            let slot = (f % cap) as usize;
            for (m, x) in mean
                .iter_mut()
                .zip(&self.frames[slot * BANDS..(slot + 1) * BANDS])
            {
                *m += x;
            }
        }
        let count = (last - first + 1) as f32;
        mean.iter_mut().for_each(|m| *m /= count);
        mean
    }

    /// The energy of take `take`'s decision window in the bands compared.
    fn take_energy(&self, take: usize) -> f64 {
        let t = &self.templates[take];
        self.in_compared_bands(t.early_energy, &t.pooled_power)
    }

    /// Pools the decision frames from frame `first` (still in the ring) into
    /// `self.instance`.
    fn pool_instance(&mut self, first: u64) {
        self.pool_frames(first, self.decision_frames);
    }

    /// Pools `count` frames from frame `first` (still in the ring) into
    /// `self.instance_power` and `self.instance`.
    fn pool_frames(&mut self, first: u64, count: usize) {
        pool_ring(
            &self.frames,
            self.frame_capacity,
            first,
            count,
            &mut self.instance_power,
        );
        features_of_power(
            &self.instance_power,
            &self.analyzer.cepstrum,
            &mut self.instance,
        );
    }

    /// The last fired impulse and the frames after its take's onset (each a window of
    /// its `later_power`) that the onset at frame `onset_frame` may be the later sound
    /// of: as many as lie between the two, give or take `CONTINUATION_SLACK_SECONDS`.
    /// A take that is one sound repeated (a teeth chatter, a trill: [`repeats_every`])
    /// is said at another pace and with more of its attacks than it was enrolled with:
    /// while they keep coming at about its pace (each no further from the last taken
    /// for its own than the longest gap between attacks of its pattern's takes, and
    /// `CONTINUATION_SLACK_SECONDS`, and the onset stage's hold, within which attacks
    /// that came before the last had fallen back were no onsets) and for as long as its
    /// sound may stretch
    /// (`SPAN_STRETCH` times its take), any of its take's later frames. None without
    /// such an impulse, or when the onset lies past its take's end otherwise.
    fn continuation_lags(&self, onset_frame: u64) -> Option<ContinuationLags> {
        let last = self.last_impulse?;
        let after = onset_frame.saturating_sub(last.onset_frame) as usize;
        let slack = (CONTINUATION_SLACK_SECONDS / HOP_SECONDS).round() as usize;
        let template = &self.templates[last.template];
        let count = template.later_energy.len();
        if after == 0 || count == 0 {
            return None;
        }
        if let (Some(_), Some(gap), false) = (
            template.repeats_every,
            self.patterns[template.pattern].repeats_every,
            self.off.repeated,
        ) {
            // The attacks the onset stage held back (as loud, before the last had
            // fallen back) were no onsets: the last of them may lie up to its hold
            // after the last one taken for the sound's own.
            let since_attack = onset_frame.saturating_sub(last.last_attack_frame) as usize;
            let unseen = self.onsets.hold_frames() as usize;
            if after <= SPAN_STRETCH as usize * count && since_attack <= gap + slack + unseen {
                return Some(ContinuationLags {
                    last,
                    lags: 1..=count,
                    repeated: true,
                });
            }
        }
        (after <= count + slack).then(|| ContinuationLags {
            last,
            lags: after.saturating_sub(slack).max(1)..=(after + slack).min(count),
            repeated: false,
        })
    }

    /// Whether the onset at frame `onset_frame`, whose best pattern is `best`, is the
    /// attack of the last impulse, which fired on its soft start (a hiss that swells
    /// before its attack): it lies so soon after that impulse's onset that the quiet it
    /// rose out of (`PRE_QUIET_FROM_SECONDS` before it) is that impulse's own sound, and
    /// the same pattern names it. The take, placed on its own attack, has no such attack
    /// in its later windows to tell it by. Another pattern's sound there is judged as
    /// any other onset: the first to fire is not always the one that names the sound
    /// (`docs/classify.md`, "A sound's attack after its soft start fired").
    fn attack_after_soft_start(&self, onset_frame: u64, best: usize) -> bool {
        self.last_impulse.is_some_and(|last| {
            let after = onset_frame.saturating_sub(last.onset_frame);
            after > 0
                && after <= quiet_before_frames()
                && self.templates[last.template].pattern == best
        })
    }

    /// Whether the onset at `time_sample` (frame `onset_frame`), whose best pattern
    /// scored `best_score`, is the last impulse's own later sound (the closing "p" of a
    /// "pop"): its take, as many frames after its onset (give or take
    /// `CONTINUATION_SLACK_SECONDS`) and heard in the onset's room, sounds alike at the
    /// level the impulse's strength predicts (within `CONTINUATION_DB`). Alike: a
    /// similarity of `CONTINUATION_SIMILARITY`, or at least the best pattern's score,
    /// so that the onset is no likelier a new sound than the last one going on (against
    /// any window of a repeated sound's take, the former alone; or, for a repeated
    /// sound, as alike the instance's own first window, within as many dB of it). The
    /// second is what tells a take whose own first window scores low (a soft "f" that
    /// the room's noise half hides) from its louder later sound: an exact copy of a
    /// "fish" fired at 0.82, and the "sh" 28 ms on, 11 dB over the "f", fired again at
    /// 0.59 where the take's later window scored 0.79.
    fn continues_last_impulse(
        &mut self,
        time_sample: u64,
        onset_frame: u64,
        best_score: f32,
    ) -> bool {
        let Some(ContinuationLags {
            last,
            lags,
            repeated,
        }) = self.continuation_lags(onset_frame)
        else {
            return false;
        };
        // Against any window of a repeated sound's take, only a sound as alike as a
        // continuation must be: some window of it is likelier to match a new sound's
        // low score.
        let needed = if repeated {
            CONTINUATION_SIMILARITY
        } else {
            CONTINUATION_SIMILARITY.min(best_score)
        };
        self.pool_instance(onset_frame);
        self.room.set(self.onsets.band_floors());
        self.room
            .hear(&self.instance_power, self.analyzer.cepstrum.bands());
        let energy = self.in_compared_bands(
            self.decision_window_energy(time_sample),
            &self.instance_power,
        );
        // A sound repeated: an attack like its own first, as loud give or take as much.
        if repeated {
            let db = 10.0 * (energy.max(1e-20) / last.first_attack_energy.max(1e-20)).log10();
            if similarity(&self.instance, &last.first_attack) >= CONTINUATION_SIMILARITY
                && db.abs() <= CONTINUATION_DB
            {
                return true;
            }
        }
        let template = &self.templates[last.template];
        for k in lags {
            let Some(later) = template.window_at(k) else {
                continue;
            };
            self.room
                .take(later, None, &self.analyzer.cepstrum, &mut self.heard_take);
            let similarity = similarity(&self.heard_take, &self.instance);
            let expected = self.in_compared_bands(template.later_energy[k - 1], later)
                * last.strength
                * last.strength;
            let db = 10.0 * (energy.max(1e-20) / expected.max(1e-20)).log10();
            let alike = similarity >= needed;
            if alike && db.abs() <= CONTINUATION_DB {
                return true;
            }
        }
        false
    }

    /// The frames still in the ring whose whole window lies in samples `[from, to)`.
    fn frames_inside(&self, from: u64, to: u64) -> impl Iterator<Item = u64> + '_ {
        let (hop, win) = (self.hop() as u64, self.analyzer.win as u64);
        let cap = self.frame_capacity as u64;
        let first = from.div_ceil(hop);
        // No frame fits when the span is shorter than a window.
        let end = to
            .checked_sub(win)
            .map_or(0, |last_start| last_start / hop + 1);
        (first..end.max(first)).filter(move |&f| f < self.frame_count && f + cap > self.frame_count)
    }

    /// How far back the speech guard looks, samples.
    fn guard_samples(&self) -> u64 {
        (self.context.params().guard_seconds * self.rate) as u64
    }

    /// The speech guard's judgement ([`Context::guard`]) of the `speech_guard_seconds`
    /// before an onset (up to 5 ms before it), near the new sound's `peak` (dB): whether
    /// the onset is part of a longer unrecognised sound, such as a consonant inside
    /// speech; and whether it was heard clear of talk.
    fn guard(&self, time_sample: u64, peak: f32) -> Before {
        self.context.guard(self.guard_frames(time_sample), peak)
    }

    /// The frames the speech guard judges before the onset at `time_sample`, as (centre
    /// sample, level dB): those whose whole window lies in the `speech_guard_seconds`
    /// before it, up to 5 ms before it.
    fn guard_frames(&self, time_sample: u64) -> impl Iterator<Item = (u64, f32)> + '_ {
        self.frames_before(time_sample, self.guard_samples())
    }

    /// The frames whose whole window lies in the `span` samples before the onset at
    /// `time_sample`, up to 5 ms before it, as (centre sample, level dB).
    fn frames_before(&self, time_sample: u64, span: u64) -> impl Iterator<Item = (u64, f32)> + '_ {
        let cap = self.frame_capacity as u64;
        let from = time_sample.saturating_sub(span);
        let to = self.quiet_before_span(time_sample).1;
        self.frames_inside(from, to).map(move |f| {
            (
                self.analyzer.frame_centre(f),
                self.levels[(f % cap) as usize],
            )
        })
    }

    /// The first and last samples (frame centres) of the sound that closed the speech
    /// guard before the onset at `time_sample`, which judged it `guard`
    /// ([`Context::guard_sound`]).
    fn guard_sound(&self, time_sample: u64, peak: f32, guard: Guard) -> Option<(u64, u64)> {
        self.context
            .guard_sound(self.guard_frames(time_sample), peak, guard)
    }

    /// Feeds frame `f` to the stage that follows a held sound the guard stopped; its
    /// span ends where the sound does.
    fn follow_stopped_held(&mut self, f: u64) {
        if let Some(h) = self.follow_stage(Stage::Stopped, f) {
            self.close_stopped_held(h);
        }
    }

    /// Feeds frame `f` to one of the two held stages; the sound it ends, if any.
    fn follow_stage(&mut self, stage: Stage, f: u64) -> Option<Held> {
        let held = match stage {
            Stage::Fired => &mut self.held,
            Stage::Stopped => &mut self.stopped_held,
        };
        let info = &self.patterns[held.current()?.pattern];
        let slot = (f % self.frame_capacity as u64) as usize;
        let bands = self.analyzer.cepstrum.bands();
        let level = match self.held_room[stage as usize] {
            Some(room) => sound_level_db(self.heard_levels[slot], room),
            None => self.held_levels[slot],
        };
        held.follow(
            f,
            &self.frames[slot * BANDS..slot * BANDS + bands],
            level,
            &info.sustain[..bands],
            info.continuous_threshold,
        )
    }

    /// The room a held sound whose onset is at frame `onset_frame` is heard over, when
    /// it began right after digital silence (the silence within its quiet-before span):
    /// the room as last heard before the silence. After digital silence the floors rise
    /// to the first sound as to a room coming back (`docs/rooms.md`, "Digital
    /// silence"), and a held sound (a "hoo" a noise gate opens on) would sink under
    /// them and end in pieces.
    fn room_under(&self, onset_frame: u64) -> Option<f32> {
        self.level_stage
            .room_before_silence(onset_frame.saturating_sub(quiet_before_frames()))
    }

    /// The loudest level since `first` of the held sound `stage` follows, as it is
    /// heard ([`Self::follow_stage`]).
    fn held_loudest_since(&self, stage: Stage, first: u64) -> f32 {
        match self.held_room[stage as usize] {
            Some(room) => sound_level_db(self.loudest_since(&self.heard_levels, first), room),
            None => self.loudest_since(&self.held_levels, first),
        }
    }

    /// Ends the held sound the guard stopped, if one is going on.
    fn end_stopped_held(&mut self) {
        if let Some(h) = self.stopped_held.end() {
            self.close_stopped_held(h);
        }
    }

    fn close_stopped_held(&mut self, h: Held) {
        let span = self.stopped_held_span.take();
        self.end_held_span(span, self.held_end_sample(&h));
    }

    /// Ends the context stage's `span` (slot, and where it began) of a held sound that
    /// ended at `end_sample`. Its sound dying away is still its own, for as long as the
    /// guard looks back.
    fn end_held_span(&mut self, span: Option<(usize, u64)>, end_sample: u64) {
        if let Some((slot, from)) = span {
            let newest = self.newest_rise_level();
            let limit = end_sample + self.guard_samples();
            self.context.end_held(slot, from, end_sample, newest, limit);
        }
    }

    /// The loudest of the per-frame `levels` (`self.levels` or `self.rise_levels`, dB of
    /// sound) of the frames from `first` to the newest.
    fn loudest_since(&self, levels: &[f32], first: u64) -> f32 {
        (first..self.frame_count)
            .map(|f| levels[(f % self.frame_capacity as u64) as usize])
            .fold(f32::NEG_INFINITY, f32::max)
    }

    /// The newest frame's `rise_levels` (dB of sound).
    fn newest_rise_level(&self) -> f32 {
        self.rise_levels[((self.frame_count.max(1) - 1) % self.frame_capacity as u64) as usize]
    }

    /// Where a held sound ends: at the end of its last matching frame's centre hop.
    fn held_end_sample(&self, h: &Held) -> u64 {
        (self.frame_start(h.last_good_frame())
            + self.analyzer.win as i64 / 2
            + self.hop() as i64 / 2)
            .max(h.begin_sample as i64 + 1) as u64
    }

    /// Feeds frame `f` to the held stage; turns the held sound it ends into an event.
    fn follow_held(&mut self, f: u64, out: &mut Vec<Event>) {
        if let Some(h) = self.follow_stage(Stage::Fired, f) {
            self.close_held(h, out);
        }
    }

    fn close_held(&mut self, h: Held, out: &mut Vec<Event>) {
        let end_sample = self.held_end_sample(&h);
        let span = self.held_span.take();
        self.end_held_span(span, end_sample);
        let lo = h
            .begin_sample
            .max(self.consumed.saturating_sub(self.samples.len() as u64));
        let hi = end_sample.min(self.consumed);
        // Mean power over the held sound (its most recent half second when longer).
        let power = self.mean_power_between(lo, hi);
        // Both powers in the bands compared, as an impulse's strength is: each by its
        // share there in its mean frame (the sound's over the same span, the takes' after
        // their onsets).
        let power = power * self.share_of_mean_frame(&self.mean_frame_between(lo, hi));
        let info = &self.patterns[h.pattern];
        let pattern_power = info.power * self.share_of_mean_frame(info.mean_frame.as_slice());
        let samples = &self.samples;
        let pitch = self
            .pitch
            .estimate(lo, hi, |n| samples[ring_slot(samples, n)]);
        if let (Some(records), Some(ended_by)) = (&mut self.held_ends, h.ended_by()) {
            records.push(HeldEndRecord {
                pattern: info.name.clone(),
                time: h.begin_sample as f64 / self.rate,
                end: end_sample as f64 / self.rate,
                decided_at: self.received as f64 / self.rate,
                ended_by,
            });
        }
        out.push(Event {
            id: 0,
            pattern: info.name.clone(),
            kind: PatternKind::Continuous,
            time: h.begin_sample as f64 / self.rate,
            end: Some(end_sample as f64 / self.rate),
            strength: (power / pattern_power.max(1e-12)).sqrt(),
            score: f64::from(h.score),
            emitted_at: self.received as f64 / self.rate,
            pitch,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Method;
    use crate::detect::white_noise;

    /// The rate the matcher runs at; a detector resamples its input to it.
    fn rate() -> f64 {
        f64::from(DetectorSettings::default().sample_rate)
    }

    /// 40 ms of noise `gain` under full scale, then 0.2 s of a 140 Hz buzz: a word
    /// whose soft start a loud room hides.
    fn soft_then_buzz(gain: f32) -> Vec<f32> {
        let mut x = white_noise((0.04 * rate()) as usize, gain, 3);
        x.extend((0..(0.2 * rate()) as usize).map(|i| {
            let t = i as f64 / rate();
            let buzz: f64 = (1..28)
                .map(|k| (2.0 * std::f64::consts::PI * 140.0 * k as f64 * t).sin() / k as f64)
                .sum();
            (0.25 * buzz) as f32
        }));
        x
    }

    /// A teeth chatter's take: one click (noise dying away over 1 ms) six times, 45 ms
    /// apart, over noise 60 dB down.
    fn chatter_take() -> Vec<f32> {
        let mut x = white_noise((0.35 * rate()) as usize, 0.001, 11);
        for k in 0u32..6 {
            let at = (0.05 + 0.045 * f64::from(k)) * rate();
            let click = white_noise((0.006 * rate()) as usize, 0.5, 20);
            for (i, c) in click.iter().enumerate() {
                x[at as usize + i] += c * (-(i as f64) / (0.001 * rate())).exp() as f32;
            }
        }
        x
    }

    /// A sound of one sound repeated goes on while its attacks come at its pace; the
    /// onset stage takes none of them that come before the last has fallen back until
    /// its hold has passed, so the next attack it gives may lie that much further from
    /// the last one taken for the sound's own, and still continue it. One frame further
    /// it does not.
    #[test]
    fn a_repeated_sound_goes_on_past_the_attacks_the_onset_stage_held_back() {
        let settings = DetectorSettings {
            method: Method::Spectral,
            ..DetectorSettings::default()
        };
        let pattern = Pattern::from_samples(
            "chatter",
            PatternKind::Impulse,
            vec![chatter_take()],
            &settings,
        )
        .unwrap();
        let mut matcher = SpectralMatcher::new(vec![pattern], &settings, settings.sample_rate);
        let template = matcher
            .templates
            .iter()
            .position(|t| t.repeats_every.is_some())
            .expect("the take is one sound repeated");
        let gap = matcher.patterns[0].repeats_every.unwrap() as u64;
        let slack = (CONTINUATION_SLACK_SECONDS / HOP_SECONDS).round() as u64;
        let hold = matcher.onsets.hold_frames();
        let fired = 1000;
        matcher.last_impulse = Some(FiredImpulse {
            template,
            span: (0, 0),
            onset_frame: fired,
            strength: 1.0,
            last_attack_frame: fired,
            first_attack: [0.0; FEATURES],
            first_attack_energy: 1.0,
        });
        let repeated = |frame: u64| matcher.continuation_lags(frame).is_some_and(|c| c.repeated);
        assert!(repeated(fired + gap + slack));
        assert!(repeated(fired + gap + slack + hold));
        assert!(!repeated(fired + gap + slack + hold + 1));
    }

    fn events_with(off: Ablation, rec: &[f32]) -> Vec<Event> {
        let settings = DetectorSettings {
            method: Method::Spectral,
            ..DetectorSettings::default()
        };
        let take = soft_then_buzz(0.02);
        let pattern =
            Pattern::from_samples("soft", PatternKind::Impulse, vec![take], &settings).unwrap();
        let mut matcher = SpectralMatcher::new(vec![pattern], &settings, settings.sample_rate);
        matcher.off = off;
        let mut out = Vec::new();
        for block in rec.chunks(256) {
            matcher.push(block, &mut out);
        }
        matcher.finish(&mut out);
        out
    }

    /// In a quiet room the soft start of each instance is an onset and fires; the buzz
    /// 40 ms on, far louder, is an onset too, found by the take's later placement and
    /// dated back where that placement's soft start falls: on the onset that fired.
    /// With the two gates off that take the buzz for the soft start's own later sound
    /// (the continuation, and the attack after a soft start), it is that sound again
    /// all the same, not a second event there; with the same-onset rule off as well,
    /// instances fire twice at their start.
    #[test]
    fn a_sound_dated_back_onto_the_onset_that_fired_is_that_sound_again() {
        let instance = soft_then_buzz(0.02);
        let mut rec = white_noise((5.5 * rate()) as usize, 0.001, 9);
        let starts: Vec<f64> = (0..8).map(|k| 0.5 + 0.6 * f64::from(k)).collect();
        for &t in &starts {
            let at = (t * rate()) as usize;
            for (r, x) in rec[at..].iter_mut().zip(&instance) {
                *r += x;
            }
        }
        let dated_at_start = |events: &[Event]| -> Vec<usize> {
            starts
                .iter()
                .map(|t| {
                    events
                        .iter()
                        .filter(|e| (e.time - t).abs() <= 0.015)
                        .count()
                })
                .collect()
        };
        let own_later_sound_off = Ablation {
            continuation: true,
            soft_start_attack: true,
            ..Ablation::default()
        };
        let events = events_with(own_later_sound_off, &rec);
        assert_eq!(dated_at_start(&events), vec![1; 8], "{events:#?}");
        let same_onset_off_too = Ablation {
            same_onset: true,
            ..own_later_sound_off
        };
        let twice = dated_at_start(&events_with(same_onset_off_too, &rec));
        assert!(twice.contains(&2), "{twice:?}");
    }
}
