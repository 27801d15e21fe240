//! The context stage: what lay before an onset. Owns the spans of the last sounds the
//! patterns recognised and the speech guard's judgement of the sound before a new
//! onset: whether it follows unrecognised sound (a consonant inside speech follows its
//! words), and whether it begins over an impulse that fired (a rhythm's word over the
//! tail of the word before; the quiet-before gate excuses it, [`super::gates`]).
//!
//! A recognised impulse covers its take's length from its onset, longer while its sound
//! goes on and then while it dies away, until a new sound rises out of it
//! ([`Context::follow`]); a held sound covers up to its end, then its sound dying away
//! the same way for as long as the guard looks back; a pattern's sound that only the
//! guard or `min_strength` stopped covers its take's length too, or less where a new
//! sound rises out of it (a held one, up to the end the held stage finds for it, then
//! as it dies away), so that only sounds that are none of the patterns keep the guard
//! closed.
//! The one exception passes a stop on once at most: a sound the guard stopped on such
//! sound, and that lies as near speech as to its pattern, is the same talk going on and
//! counts as unrecognised (`near_speech`, in [`Context::stopped`] and
//! [`Context::held_began`]), but what it alone closes the guard on covers again
//! ([`Guard::ClosedByStopped`]). The guard judges only the frames of
//! its span before an onset, so it opens within two of its spans and a stopped sound's
//! length of the last sound no pattern recognised, whatever follows. The talk after an
//! impulse that fired (whether what it taught tracking is kept) is judged without that
//! impulse's own span ([`Context::guard_after`]).
//!
//! A stage of the spectral matcher ([`super::spectral`]), which gives it the frames of
//! that span as (centre sample, level dB); runs on the detector thread, fixed size,
//! allocates nothing.

use super::held::SOUND_DROP_DB;
use super::levels::SILENT_DB;

/// The context stage's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ContextParams {
    /// How far back before an onset the speech guard looks, seconds
    /// (`speech_guard_seconds`; 0 turns it off).
    pub guard_seconds: f64,
    /// The unrecognised sound that closes the guard: this long in all...
    pub guard_sound_seconds: f64,
    /// ...within this many dB of the new sound's peak.
    pub guard_db: f32,
    /// A recognised sound dying away (an impulse `SOUND_DROP_DB` under its peak, a held
    /// sound after its end) still covers what follows until the level rises this far
    /// (dB) over the lowest it fell to since: the rise the quiet-before gate asks of a
    /// new sound (`GateParams::pre_quiet_db`).
    pub new_sound_db: f32,
}

/// Speech fills most of the guard's span with sound; a hit that no pattern recognised
/// (a miss, a cough) holds its level for well under 200 ms, so it does not stop the
/// hits after it. Chosen with the guard's span by a sweep over the development sets
/// (`docs/speech-guard.md`): with 60 ms, a guard long enough to keep a voice's own
/// speech out stopped the hits after every miss. The speech guard's unrecognised
/// sound: this long in all...
const GUARD_SOUND_SECONDS: f64 = 0.2;
/// ...within this many dB of the new sound's peak. On the 48 s of synthetic speech of
/// `scripts/eval-speech.sh` with a guard of 0.5 s (threshold 0.3): 104 false events
/// without the guard, 2 with it; on the real beatbox sets (`examples/eval_beatbox.rs`)
/// it costs the isolated set 0.008 of F1 and leaves the others as they are.
const GUARD_DB: f32 = 10.0;

impl ContextParams {
    /// The guard looking `guard_seconds` back, with the sound it asks for as swept, and
    /// a new sound rising `new_sound_db`.
    pub fn new(guard_seconds: f64, new_sound_db: f32) -> Self {
        Self {
            guard_seconds,
            guard_sound_seconds: GUARD_SOUND_SECONDS,
            guard_db: GUARD_DB,
            new_sound_db,
        }
    }
}

/// A recognised impulse covers its take's length from its onset, and longer while its
/// sound goes on (said more slowly than enrolled) or dies away, up to this many times
/// the take's length. Swept over every dev set (`docs/speech-guard.md`): 4 to 10 score
/// alike; 2 loses words of the rhythms at 150 bpm.
pub(super) const SPAN_STRETCH: u64 = 4;

/// Recognised sounds remembered; the oldest is forgotten first.
const SPANS: usize = 8;

/// A recognised sound's span, first and last sample.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Span {
    from: u64,
    /// `u64::MAX` while a held sound goes on.
    to: u64,
    /// An impulse that fired (rather than a held sound, or a pattern's sound that only
    /// the guard stopped).
    fired: bool,
    /// A sound the guard stopped on unrecognised sound that lies as near speech as to
    /// its pattern: unrecognised sound for the guard, but one it does not pass on
    /// ([`Context::guard`]).
    near_speech: bool,
}

impl Span {
    const NONE: Self = Self {
        from: u64::MAX,
        to: u64::MAX,
        fired: false,
        near_speech: false,
    };

    /// Whether the span holds sample `n`.
    fn holds(&self, n: u64) -> bool {
        self.from != u64::MAX && n >= self.from && n <= self.to
    }
}

/// A recognised sound's level since its onset: it goes on while within `SOUND_DROP_DB`
/// of its peak, then dies away until a new sound rises out of it.
#[derive(Debug, Clone, Copy)]
struct Fading {
    peak_db: f32,
    /// Once the sound has fallen `SOUND_DROP_DB` under its peak: the lowest level since.
    lowest_db: Option<f32>,
}

impl Fading {
    /// Takes the next frame's level; whether a new sound rose `new_sound_db` over the
    /// lowest the sound fell to.
    fn new_sound(&mut self, level_db: f32, new_sound_db: f32) -> bool {
        if self.lowest_db.is_some() || level_db < self.peak_db - SOUND_DROP_DB {
            let lowest = self.lowest_db.unwrap_or(level_db);
            if level_db > lowest + new_sound_db {
                return true;
            }
            self.lowest_db = Some(lowest.min(level_db));
        }
        self.peak_db = self.peak_db.max(level_db);
        false
    }
}

/// The newest recognised impulse (or held sound that has ended), whose span grows while
/// its sound goes on or dies away.
#[derive(Debug, Clone, Copy)]
struct Growing {
    slot: usize,
    level: Fading,
    /// Last sample the span may reach.
    limit: u64,
}

/// The newest impulse the guard stopped, whose span ends early where a new sound rises
/// out of it.
#[derive(Debug, Clone, Copy)]
struct Stopped {
    slot: usize,
    /// The span's first sample: whether its slot still holds it.
    from: u64,
    level: Fading,
}

/// See the module comment.
#[derive(Debug, Clone)]
pub(super) struct Context {
    params: ContextParams,
    /// Frames of unrecognised sound that close the guard.
    guard_frames: usize,
    spans: [Span; SPANS],
    next: usize,
    growing: Option<Growing>,
    stopped: Option<Stopped>,
}

impl Context {
    /// A context for frames `hop_seconds` apart.
    pub(super) fn new(params: ContextParams, hop_seconds: f64) -> Self {
        Self {
            params,
            guard_frames: (params.guard_sound_seconds / hop_seconds).ceil() as usize,
            spans: [Span::NONE; SPANS],
            next: 0,
            growing: None,
            stopped: None,
        }
    }

    pub(super) fn params(&self) -> &ContextParams {
        &self.params
    }

    /// A pattern's sound that only the guard stopped covers samples `from..=to`; one
    /// `near_speech` (as near speech as to its pattern, stopped on sound no pattern
    /// recognised) as unrecognised sound ([`Context::guard`]); returns its span's slot.
    pub(super) fn stopped(&mut self, from: u64, to: u64, near_speech: bool) -> usize {
        self.push(Span {
            from,
            to,
            fired: false,
            near_speech,
        })
    }

    /// An impulse that only the guard stopped, whose sound peaked at `peak_db` (dB),
    /// covers samples `from..=to` as [`Context::stopped`], but ends where a new sound
    /// rises out of it ([`Context::follow`]): in speech its take's length holds the
    /// syllables after it, which are not its sound.
    pub(super) fn stopped_impulse(&mut self, from: u64, to: u64, near_speech: bool, peak_db: f32) {
        let slot = self.stopped(from, to, near_speech);
        self.stopped = Some(Stopped {
            slot,
            from,
            level: Fading {
                peak_db,
                lowest_db: None,
            },
        });
    }

    /// An impulse that fired, whose sound peaked at `peak_db` (dB), covers samples
    /// `from..=to`, and longer while its sound goes on or dies away, up to sample
    /// `limit` ([`Context::follow`]).
    pub(super) fn fired_impulse(&mut self, from: u64, to: u64, peak_db: f32, limit: u64) {
        let slot = self.push(Span {
            from,
            to,
            fired: true,
            near_speech: false,
        });
        self.growing = Some(Growing {
            slot,
            level: Fading {
                peak_db,
                lowest_db: None,
            },
            limit,
        });
    }

    /// The held sound of [`Context::held_began`] whose span is in `slot`, from sample
    /// `from`, ended at sample `end`, the newest frame at `level_db`: its span ends
    /// there, then covers the sound as it dies away (as an impulse's does,
    /// [`Context::follow`]) up to sample `limit`. Each held sound ends its own span: one
    /// the guard stopped, followed while a held sound that fired goes on, outlasts it
    /// or not by its own sound. A span forgotten since (newer spans took its slot) is
    /// left alone.
    pub(super) fn end_held(&mut self, slot: usize, from: u64, end: u64, level_db: f32, limit: u64) {
        let span = self.spans[slot];
        if span.from == from && span.to == u64::MAX {
            self.spans[slot].to = end;
            self.growing = Some(Growing {
                slot,
                level: Fading {
                    peak_db: level_db,
                    lowest_db: Some(level_db),
                },
                limit,
            });
        }
    }

    /// A held sound (one that fired, or one that only the guard stopped) covers from
    /// sample `from` until it ends ([`Context::end_held`]), as unrecognised sound if
    /// `near_speech` ([`Context::stopped`]); returns its span's slot.
    pub(super) fn held_began(&mut self, from: u64, near_speech: bool) -> usize {
        self.growing = None;
        self.push(Span {
            from,
            to: u64::MAX,
            fired: false,
            near_speech,
        })
    }

    fn push(&mut self, span: Span) -> usize {
        let slot = self.next;
        self.spans[slot] = span;
        self.next = (slot + 1) % SPANS;
        slot
    }

    /// A new frame, centred on sample `centre` and reaching `end`, at `level_db`: the
    /// newest impulse's span grows over it while its sound goes on (within
    /// `SOUND_DROP_DB` of its peak) and, once it has fallen further, while it dies away:
    /// until the level rises `new_sound_db` over the lowest it fell to, a new sound by
    /// the quiet-before gate's measure. A word's tail in a room, or under the next word
    /// of a quick rhythm, is still that word's sound, not unrecognised sound before the
    /// next onset (`docs/speech-guard.md`, "A recognised sound as it dies away").
    /// The newest impulse the guard stopped, by the same measure, ends before a new
    /// sound that rises out of it within its take's length ("A sound the guard stopped,
    /// ended where a new sound rises out of it").
    pub(super) fn follow(&mut self, centre: u64, end: u64, level_db: f32) {
        let new_sound_db = self.params.new_sound_db;
        if let Some(mut s) = self.stopped.take() {
            let span = &mut self.spans[s.slot];
            if span.from == s.from && centre <= span.to {
                if s.level.new_sound(level_db, new_sound_db) {
                    span.to = centre.saturating_sub(1).max(span.from);
                } else {
                    self.stopped = Some(s);
                }
            }
        }
        let Some(mut g) = self.growing.take() else {
            return;
        };
        if centre > g.limit || g.level.new_sound(level_db, new_sound_db) {
            return;
        }
        let span = &mut self.spans[g.slot];
        span.to = span.to.max(end);
        self.growing = Some(g);
    }

    /// Whether an impulse that fired holds sample `n`.
    pub(super) fn fired_at(&self, n: u64) -> bool {
        self.spans.iter().any(|s| s.fired && s.holds(n))
    }

    /// Whether some recognised sound holds sample `n`.
    #[cfg(test)]
    fn recognised_at(&self, n: u64) -> bool {
        self.recognised_except(n, None)
    }

    /// Whether some recognised sound holds sample `n`, the impulse that fired from
    /// sample `except` (if any) left out.
    fn recognised_except(&self, n: u64, except: Option<u64>) -> bool {
        self.spans
            .iter()
            .any(|s| !s.near_speech && s.holds(n) && !(s.fired && except == Some(s.from)))
    }

    /// Whether a stopped sound near speech holds sample `n`.
    fn near_speech_at(&self, n: u64) -> bool {
        self.spans.iter().any(|s| s.near_speech && s.holds(n))
    }

    /// The speech guard: whether `frames` (centre sample, level dB; the guard's span
    /// before an onset) hold `guard_sound_seconds` of frames within `guard_db` of the new
    /// sound's `peak_db` that no recognised sound covers. A frame is judged by the
    /// sample at its centre. Stopped sounds near speech count ([`Context::stopped`]), but
    /// when the guard closes only with them it says so, and what it stops then covers
    /// its span again: a stop passes on once at most. A frame with no sound over the room
    /// (`SILENT_DB`: digital silence, a closed noise gate) is no sound, however little
    /// the new one stands over its own floor. The same count says whether the onset was
    /// heard clear of talk: at most half of what closes the guard, so that what fires
    /// there may teach tracking ([`super::classify::Tracked`]).
    pub(super) fn guard(&self, frames: impl Iterator<Item = (u64, f32)>, peak_db: f32) -> Before {
        self.judge(frames, peak_db, None)
    }

    /// [`Context::guard`] of the frames after an impulse that fired, its own span (the
    /// one that begins at sample `own_from`) covering none of them: that span grows
    /// over whatever sound goes on after it, talk after a syllable taken for a word
    /// too, and what came after an event is not judged by the event.
    pub(super) fn guard_after(
        &self,
        frames: impl Iterator<Item = (u64, f32)>,
        peak_db: f32,
        own_from: u64,
    ) -> Before {
        self.judge(frames, peak_db, Some(own_from))
    }

    /// The guard's count, the fired span beginning at `except` (if any) covering
    /// nothing.
    fn judge(
        &self,
        frames: impl Iterator<Item = (u64, f32)>,
        peak_db: f32,
        except: Option<u64>,
    ) -> Before {
        let (mut unrecognised, mut near_speech) = (0, 0);
        for (centre, level) in frames {
            match self.counted(centre, level, peak_db, except) {
                Some(Counted::Unrecognised) => unrecognised += 1,
                Some(Counted::NearSpeech) => near_speech += 1,
                None => {}
            }
        }
        let guard = if unrecognised >= self.guard_frames {
            Guard::Closed
        } else if unrecognised + near_speech >= self.guard_frames {
            Guard::ClosedByStopped
        } else {
            Guard::Open
        };
        Before {
            guard,
            clear_of_talk: 2 * (unrecognised + near_speech) <= self.guard_frames,
        }
    }

    /// What closed the guard (`guard`, its judgement of the same `frames`): the centres
    /// of the first and last frames of sound it counted, the stopped sounds near speech
    /// among them only when it closed by them. None when it did not close.
    pub(super) fn guard_sound(
        &self,
        frames: impl Iterator<Item = (u64, f32)>,
        peak_db: f32,
        guard: Guard,
    ) -> Option<(u64, u64)> {
        let mut span: Option<(u64, u64)> = None;
        for (centre, level) in frames {
            let counts = match self.counted(centre, level, peak_db, None) {
                Some(Counted::Unrecognised) => guard != Guard::Open,
                Some(Counted::NearSpeech) => guard == Guard::ClosedByStopped,
                None => false,
            };
            if counts {
                span = Some(span.map_or((centre, centre), |(from, _)| (from, centre)));
            }
        }
        span
    }

    /// How the guard counts a frame centred on sample `centre` at `level` (dB), before
    /// a new sound that peaks at `peak_db`: none when it holds no sound over the room,
    /// lies `guard_db` under the new sound or a recognised sound covers it.
    fn counted(
        &self,
        centre: u64,
        level: f32,
        peak_db: f32,
        except: Option<u64>,
    ) -> Option<Counted> {
        if level <= SILENT_DB
            || level < peak_db - self.params.guard_db
            || self.recognised_except(centre, except)
        {
            None
        } else if self.near_speech_at(centre) {
            Some(Counted::NearSpeech)
        } else {
            Some(Counted::Unrecognised)
        }
    }
}

/// A frame of sound the guard counts.
enum Counted {
    Unrecognised,
    /// Covered by a stopped sound near speech ([`Context::stopped`]).
    NearSpeech,
}

/// What the sound before an onset showed ([`Context::guard`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Before {
    /// The speech guard's judgement.
    pub guard: Guard,
    /// It held at most half the unrecognised sound that closes the guard.
    pub clear_of_talk: bool,
}

/// The speech guard's judgement of the sound before an onset.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Guard {
    /// Too little unrecognised sound.
    Open,
    /// Enough sound that no pattern recognised.
    Closed,
    /// Enough only with the stopped sounds near speech counted.
    ClosedByStopped,
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOP: f64 = 0.001;

    fn context() -> Context {
        Context::new(ContextParams::new(0.65, 10.0), HOP)
    }

    fn closed(c: &Context, frames: impl Iterator<Item = (u64, f32)>, peak_db: f32) -> bool {
        c.guard(frames, peak_db).guard != Guard::Open
    }

    /// Frames 1 ms apart (centres in samples of 1 kHz) from `from` for `count` frames,
    /// at `level` dB.
    fn frames(from: u64, count: u64, level: f32) -> impl Iterator<Item = (u64, f32)> {
        (from..from + count).map(move |c| (c, level))
    }

    #[test]
    fn two_hundred_ms_of_unrecognised_sound_near_the_peak_close_the_guard() {
        let c = context();
        assert!(closed(&c, frames(0, 200, -25.0), -20.0));
        assert!(!closed(&c, frames(0, 199, -25.0), -20.0));
    }

    /// Digital silence before a sound that stands next to nothing over its room (the
    /// level stage has just caught up with it) is no sound, though it lies within
    /// `guard_db` of that sound's peak.
    #[test]
    fn digital_silence_is_no_sound_to_the_guard() {
        let c = context();
        assert!(!closed(&c, frames(0, 650, SILENT_DB), SILENT_DB));
        assert!(!closed(&c, frames(0, 650, SILENT_DB), SILENT_DB + 5.0));
        assert!(closed(&c, frames(0, 200, SILENT_DB + 1.0), SILENT_DB + 5.0));
    }

    /// What closed the guard is the sound it counted: here 250 ms of it, of which
    /// the 100 ms a recognised sound covers and the frames 10 dB under the new sound do
    /// not count.
    #[test]
    fn the_sound_that_closed_the_guard_spans_the_frames_it_counted() {
        let mut c = context();
        c.fired_impulse(0, 99, -20.0, 99);
        let before = || frames(0, 300, -25.0).chain(frames(300, 50, -31.0));
        assert_eq!(c.guard(before(), -20.0).guard, Guard::Closed);
        assert_eq!(
            c.guard_sound(before(), -20.0, Guard::Closed),
            Some((100, 299))
        );
        assert_eq!(
            c.guard_sound(frames(0, 100, -25.0), -20.0, Guard::Open),
            None
        );
    }

    /// Talk that goes on after an impulse that fired (a syllable taken for a word) keeps
    /// within `SOUND_DROP_DB` of its peak: its span grows over it, and to the guard of
    /// the next onsets it is that impulse's sound. What came after the impulse itself
    /// is judged without that span: talk after it.
    #[test]
    fn talk_after_an_impulse_is_not_its_own_sound_to_what_follows_it() {
        let mut c = context();
        c.fired_impulse(0, 99, -20.0, 4_000);
        for centre in 100..1_000 {
            c.follow(centre, centre, -22.0);
        }
        let after = || frames(100, 650, -22.0);
        assert_eq!(c.guard(after(), -20.0).guard, Guard::Open);
        assert!(c.guard(after(), -20.0).clear_of_talk);
        let own = c.guard_after(after(), -20.0, 0);
        assert_eq!(own.guard, Guard::Closed);
        assert!(!own.clear_of_talk);
        // Another impulse's span is left as it is.
        assert!(c.guard_after(after(), -20.0, 50).clear_of_talk);
    }

    #[test]
    fn sound_more_than_10_db_under_the_peak_does_not_count() {
        let c = context();
        assert!(closed(&c, frames(0, 300, -30.0), -20.0));
        assert!(!closed(&c, frames(0, 300, -30.1), -20.0));
    }

    #[test]
    fn recognised_sound_does_not_count_whether_it_fired_or_only_the_guard_stopped_it() {
        for fired in [true, false] {
            let mut c = context();
            if fired {
                c.fired_impulse(50, 149, -20.0, 149);
            } else {
                c.stopped(50, 149, false);
            }
            assert!(!closed(&c, frames(0, 250, -25.0), -20.0));
            assert!(closed(&c, frames(0, 300, -25.0), -20.0));
            assert_eq!(c.fired_at(100), fired);
            assert!(c.recognised_at(100) && !c.recognised_at(150));
        }
    }

    #[test]
    fn a_stopped_sound_near_speech_is_unrecognised_sound_that_passes_a_stop_on_once() {
        // An impulse's span, and a held sound's until it ends.
        for held in [false, true] {
            let mut c = context();
            if held {
                let slot = c.held_began(100, true);
                c.end_held(slot, 100, 249, -60.0, 249);
            } else {
                c.stopped(100, 249, true);
            }
            assert!(!c.recognised_at(100));
            // 150 ms of it and 100 ms of other unrecognised sound: closed by it alone.
            let before = || frames(0, 100, -25.0).chain(frames(100, 150, -25.0));
            assert_eq!(c.guard(before(), -20.0).guard, Guard::ClosedByStopped);
            // With 200 ms of other unrecognised sound the guard is closed as it was.
            assert_eq!(c.guard(frames(300, 200, -25.0), -20.0).guard, Guard::Closed);
            assert_eq!(c.guard(frames(0, 100, -25.0), -20.0).guard, Guard::Open);
            // A recognised sound over it covers it.
            c.stopped(100, 249, false);
            assert_eq!(c.guard(before(), -20.0).guard, Guard::Open);
        }
    }

    #[test]
    fn a_held_sound_the_guard_stopped_covers_until_it_ends_then_as_it_dies_away() {
        let mut c = context();
        let slot = c.held_began(50, false);
        assert!(c.recognised_at(50) && c.recognised_at(5000) && !c.fired_at(100));
        c.end_held(slot, 50, 900, -20.0, 2000);
        assert!(c.recognised_at(900) && !c.recognised_at(901));
        // Its sound dying away is still its own, until a new sound rises 10 dB.
        for centre in 901..1000 {
            c.follow(centre, centre, -40.0);
        }
        c.follow(1000, 1000, -29.0);
        assert!(c.recognised_at(999) && !c.recognised_at(1000));
        // A span whose slot newer spans took is left alone.
        let mut c = context();
        let slot = c.held_began(50, false);
        for k in 0..SPANS as u64 {
            c.stopped(100 + 10 * k, 105 + 10 * k, false);
        }
        c.end_held(slot, 50, 900, -20.0, 2000);
        assert!(!c.recognised_at(900) && !c.recognised_at(60));
    }

    #[test]
    fn each_held_sound_ends_its_own_span() {
        // A held sound that fired, and one the guard stopped while it went on.
        let mut c = context();
        let fired = c.held_began(0, false);
        let stopped = c.held_began(300, false);
        c.end_held(fired, 0, 500, -60.0, 500);
        assert!(
            c.recognised_at(5000),
            "the stopped held sound goes on after the fired one ends"
        );
        c.end_held(stopped, 300, 900, -60.0, 900);
        assert!(c.recognised_at(900) && !c.recognised_at(901));
        // Ended in the other order, each span keeps its own end.
        let mut c = context();
        let fired = c.held_began(0, false);
        let stopped = c.held_began(300, false);
        c.end_held(stopped, 300, 400, -60.0, 400);
        assert!(c.recognised_at(5000), "the fired held sound goes on");
        c.end_held(fired, 0, 900, -60.0, 900);
        assert!(c.recognised_at(900) && !c.recognised_at(901));
    }

    #[test]
    fn a_fired_impulse_covers_more_while_its_sound_goes_on_up_to_its_limit() {
        let mut c = context();
        c.fired_impulse(0, 100, -10.0, 1000);
        // Louder, then down to 20 dB under the new peak: still its sound.
        for centre in 90..200 {
            c.follow(centre, centre, if centre < 150 { -5.0 } else { -25.0 });
        }
        assert!(c.recognised_at(199));
        // The limit holds however long the sound goes on.
        let mut c = context();
        c.fired_impulse(0, 100, -10.0, 300);
        for centre in 90..400 {
            c.follow(centre, centre, -10.0);
        }
        assert!(c.recognised_at(300) && !c.recognised_at(301));
    }

    #[test]
    fn a_fired_impulse_covers_its_sound_dying_away_until_a_new_sound_rises_10_db() {
        let mut c = context();
        c.fired_impulse(0, 100, 0.0, 1000);
        // A tail falling from 20 to 60 dB under the peak, wavering by 1 dB.
        for centre in 100..300 {
            let falling = -20.0 - 40.0 * (centre - 100) as f32 / 199.0;
            c.follow(
                centre,
                centre,
                falling + if centre % 2 == 0 { 1.0 } else { 0.0 },
            );
        }
        assert!(
            c.recognised_at(299),
            "the tail is still the impulse's sound"
        );
        // The next sound rises 9 dB over the tail: under a new sound's rise, still
        // covered; then 10.5 dB over the lowest the tail fell to: a new sound.
        c.follow(300, 300, -60.0 + 9.0);
        assert!(c.recognised_at(300));
        c.follow(301, 301, -60.0 + 10.5);
        assert!(!c.recognised_at(301));
        c.follow(302, 302, -70.0);
        assert!(
            !c.recognised_at(302),
            "once ended, the span does not grow again"
        );
    }

    #[test]
    fn a_stopped_impulse_covers_its_take_unless_a_new_sound_rises_out_of_it() {
        // A syllable the guard stopped, its take 200 frames long: it falls 25 dB and
        // the next syllable rises 15 dB out of the dip at frame 150.
        let mut c = context();
        c.stopped_impulse(0, 199, false, -10.0);
        for centre in 0..200 {
            let level = match centre {
                0..=99 => -10.0 - 25.0 * centre as f32 / 99.0,
                100..=149 => -35.0,
                _ => -20.0,
            };
            c.follow(centre, centre, level);
        }
        assert!(c.recognised_at(149) && !c.recognised_at(150));
        assert!(!c.fired_at(100), "a stopped sound is recognised, not fired");
        // Its own sound going on, or dying away without a new sound, is covered to the
        // take's end, and no further.
        let mut c = context();
        c.stopped_impulse(0, 199, false, -10.0);
        for centre in 0..300 {
            c.follow(centre, centre, -10.0 - 40.0 * centre as f32 / 299.0);
        }
        assert!(c.recognised_at(199) && !c.recognised_at(200));
        // A newer span in its slot is left alone.
        let mut c = context();
        c.stopped_impulse(0, 199, false, -10.0);
        for k in 1..SPANS as u64 {
            c.stopped(1000 * k, 1000 * k + 10, false);
        }
        c.stopped(5000, 6000, false);
        c.follow(100, 100, -40.0);
        c.follow(5100, 5100, -20.0);
        assert!(c.recognised_at(5100) && c.recognised_at(6000));
    }

    #[test]
    fn a_held_sound_covers_its_sound_dying_away_after_its_end_up_to_a_limit() {
        let mut c = context();
        let slot = c.held_began(0, false);
        c.end_held(slot, 0, 500, -30.0, 700);
        for centre in 501..600 {
            c.follow(centre, centre, -30.0 - 0.2 * (centre - 500) as f32);
        }
        assert!(c.recognised_at(599), "the tail is still the held sound's");
        c.follow(600, 600, -30.0);
        assert!(
            !c.recognised_at(600),
            "a sound rising 10 dB out of the tail is new"
        );
        let mut c = context();
        let slot = c.held_began(0, false);
        c.end_held(slot, 0, 500, -30.0, 700);
        for centre in 501..800 {
            c.follow(centre, centre, -40.0);
        }
        assert!(c.recognised_at(700) && !c.recognised_at(701));
    }

    #[test]
    fn a_held_sound_covers_until_it_ends_and_the_oldest_span_is_forgotten() {
        let mut c = context();
        let slot = c.held_began(0, false);
        assert!(c.recognised_at(1_000_000));
        c.end_held(slot, 0, 500, -60.0, 500);
        assert!(c.recognised_at(500) && !c.recognised_at(501));
        for k in 1..=SPANS as u64 {
            c.stopped(1000 * k, 1000 * k + 10, false);
        }
        assert!(!c.recognised_at(0), "the held sound's span was the oldest");
        assert!(c.recognised_at(1000));
    }
}
