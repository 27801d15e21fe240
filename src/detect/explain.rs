//! The explain records: what became of each onset the spectral matcher considered,
//! and how each held sound that fired ended (`analyze --explain`, `--plot`). Plain
//! data, filled by the matcher on the detector thread when explaining is on
//! ([`super::SpectralMatcher::enable_explain`]) and handed over by
//! [`super::Detector::take_explain`] and [`super::Detector::take_held_ends`]; the JSON
//! field names are part of the `--explain` output.

use std::sync::Arc;

use serde::Serialize;

use super::gates::Outcome;
use super::held::HeldEnd;

/// What became of one onset (`analyze --explain`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OnsetRecord {
    /// Onset, seconds of stream.
    #[serde(serialize_with = "super::seconds")]
    pub time: f64,
    /// When it was decided.
    #[serde(serialize_with = "super::seconds")]
    pub decided_at: f64,
    /// The pattern it resembled most, and how much.
    pub best: Option<Arc<str>>,
    #[serde(serialize_with = "super::opt_ratio")]
    pub best_score: Option<f64>,
    /// The runner-up.
    pub second: Option<Arc<str>>,
    #[serde(serialize_with = "super::opt_ratio")]
    pub second_score: Option<f64>,
    /// Amplitude against the best pattern's take over the decision window.
    #[serde(serialize_with = "super::opt_ratio")]
    pub strength: Option<f64>,
    /// The nearest background sound's score: the background of speech and the user's
    /// own background recordings (none when the model is not used).
    #[serde(serialize_with = "super::opt_ratio")]
    pub background_score: Option<f64>,
    /// The score of the user's talk heard lately that lies nearest (none before any
    /// was heard): sounds the guard stopped inside talk, kept for a minute. It judges
    /// an impulse pattern's onset alone.
    #[serde(serialize_with = "super::opt_ratio")]
    pub talk_score: Option<f64>,
    /// How far the sound's peak rose above the 5-40 ms before its onset, dB (the
    /// quiet-before gate asks for 10).
    #[serde(serialize_with = "super::opt_db")]
    pub rise_db: Option<f64>,
    /// Some of those 5-40 ms lie in an impulse that fired: the onset begins over a
    /// recognised word's tail, and an impulse pattern scoring `over_fired_score` there
    /// is not held to the rise.
    pub over_fired_impulse: bool,
    /// Over such a tail, when it did not rise out of it: the share of its sound that
    /// its pattern's takes, added to the tail, explain beyond the tail alone (an
    /// impulse explaining `over_tail_share` is excused the rise and named by it).
    #[serde(serialize_with = "super::opt_ratio")]
    pub explained_over_tail: Option<f64>,
    /// The speech guard stopped it on sounds it had stopped before near speech: the
    /// talk they belong to (their sound alone closed it; a sound stopped so covers its
    /// span again).
    pub guard_by_stopped_speech: bool,
    /// The sound the choice of its pattern was made on, seconds from the onset: one
    /// decision window, or more when its two best patterns are alike over one
    /// ([`Separating`](super::enrol::Separating)) or when it was judged over a fired word's tail by what a take
    /// adds to it (`OVER_TAIL_WINDOWS`).
    #[serde(serialize_with = "super::opt_seconds")]
    pub window_seconds: Option<f64>,
    /// Why the choice heard more than one decision window, when it did.
    pub waited_for: Option<Wait>,
    /// What of its best pattern its first window resembled most: a take, the tracked
    /// template or a kept instance.
    pub matched_by: Option<MatchedBy>,
    pub outcome: Outcome,
    /// An impulse that fired: what it taught its pattern's tracking, or why nothing.
    pub taught: Option<Taught>,
    /// The sound that the stage which decided held against it: for `speech_guard`, the
    /// sound no pattern recognised that closed the guard (the first and last of its
    /// frames counted); for `continuation`, the impulse whose own later sound it is
    /// (its onset to its take's end, or to this onset when a sound of one sound repeated
    /// goes on past it); for `held_continues`, the held sound going on
    /// (its begin to the decision); for `same_onset`, the onset that fired; for
    /// `background`, the onset of the talk heard lately that it lay nearest, when that
    /// was the nearest sound that must never fire.
    pub because_of: Option<SoundSpan>,
}

/// How a held sound that fired ended (`analyze --explain`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldEndRecord {
    pub pattern: Arc<str>,
    /// Its begin and end, seconds of stream, as its event has them.
    #[serde(serialize_with = "super::seconds")]
    pub time: f64,
    #[serde(serialize_with = "super::seconds")]
    pub end: f64,
    /// When its end was decided.
    #[serde(serialize_with = "super::seconds")]
    pub decided_at: f64,
    pub ended_by: HeldEnd,
}

impl OnsetRecord {
    /// The same record on a stream clock `seconds` later (a detector that continues
    /// another's stream).
    pub(super) fn shift(&mut self, seconds: f64) {
        self.time += seconds;
        self.decided_at += seconds;
        if let Some(span) = &mut self.because_of {
            span.from += seconds;
            span.to += seconds;
        }
    }
}

impl HeldEndRecord {
    /// As [`OnsetRecord::shift`].
    pub(super) fn shift(&mut self, seconds: f64) {
        self.time += seconds;
        self.end += seconds;
        self.decided_at += seconds;
    }
}

/// A stretch of the stream, seconds ([`OnsetRecord::because_of`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SoundSpan {
    #[serde(serialize_with = "super::seconds")]
    pub from: f64,
    #[serde(serialize_with = "super::seconds")]
    pub to: f64,
}

/// Why the choice of an onset's pattern waited for more of its sound
/// ([`OnsetRecord::window_seconds`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Wait {
    /// Its two best patterns' takes are alike over one window and part later
    /// ([`Separating`](super::enrol::Separating)).
    PairAlikeAtFirst,
    /// Its first window lay between its two best patterns (`BETWEEN_TWO_GAP` in [`super::spectral`]).
    BetweenTwo,
    /// It was judged over a fired word's tail by what a take adds to it
    /// (`OVER_TAIL_WINDOWS`).
    OverTail,
}

/// What of its best pattern an onset's first window resembled most
/// ([`OnsetRecord::matched_by`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MatchedBy {
    /// One of the pattern's enrolled takes.
    Take,
    /// The template that follows the voice as it drifts ([`Tracked`](super::classify::Tracked)).
    Tracked,
    /// One of the pattern's latest clear instances, kept as it was ([`Tracked`](super::classify::Tracked)).
    Kept,
}

impl MatchedBy {
    /// The name `--explain` prints.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Take => "take",
            Self::Tracked => "tracked",
            Self::Kept => "kept",
        }
    }
}

/// What a fired impulse taught its pattern's tracking ([`OnsetRecord::taught`];
/// [`Tracked`](super::classify::Tracked)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Taught {
    /// It moved (or set) the tracked template and is kept as it was.
    TemplateAndKept,
    /// It moved the tracked template; it is not kept (it began over a fired word's
    /// tail, or its takes alone do not find it clearly).
    Template,
    /// Nothing: it was heard amid talk.
    NothingAmidTalk,
    /// Nothing in the end: talk followed it, and what it taught was taken back.
    NothingTalkAfter,
    /// Nothing: it is not confident (its pattern's threshold plus the confidence, or
    /// another pattern, is as high).
    NothingUnsure,
    /// Nothing: it lies further from its pattern's takes than they lie from one another.
    NothingFurtherThanTakes,
}

impl Taught {
    /// Whether it moved the tracked template.
    pub fn learnt(self) -> bool {
        matches!(self, Self::TemplateAndKept | Self::Template)
    }

    /// The name `--explain` prints.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::TemplateAndKept => "both",
            Self::Template => "template",
            Self::NothingAmidTalk => "no:talk",
            Self::NothingTalkAfter => "no:talk-after",
            Self::NothingUnsure => "no:unsure",
            Self::NothingFurtherThanTakes => "no:takes",
        }
    }
}

impl OnsetRecord {
    /// An onset at `time`, decided at `decided_at`, with nothing scored.
    pub(super) fn unscored(time: f64, decided_at: f64, outcome: Outcome) -> Self {
        Self {
            time,
            decided_at,
            best: None,
            best_score: None,
            second: None,
            second_score: None,
            strength: None,
            background_score: None,
            talk_score: None,
            rise_db: None,
            over_fired_impulse: false,
            explained_over_tail: None,
            guard_by_stopped_speech: false,
            window_seconds: None,
            waited_for: None,
            matched_by: None,
            outcome,
            taught: None,
            because_of: None,
        }
    }
}
