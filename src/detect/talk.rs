//! The talk stage: what the user's own talking has sounded like lately. Owns the
//! features of the onsets heard inside talk: ones the speech guard stopped (sound that
//! no pattern recognised filled its span before them) and that talk followed too (the
//! same count over the guard's span after their take's length), each kept for
//! `TALK_KEPT_SECONDS`. The built-in background knows other voices' speech; a voice's
//! own syllable that begins like one of its words lies nearer that word's take, and
//! fires wherever the talk before it is too quiet or too short to close the guard (a
//! stressed syllable after a pause). It lies nearer still to the same voice's
//! syllables heard inside its talk a little earlier: an onset nearer one of them than to
//! its pattern, by the background's margin, is talk ([`super::gates`]).
//!
//! What is learnt is bounded both ways: only sound inside talk (a word said straight
//! after talking, then clear of it, teaches nothing), and each for a fixed time, so
//! nothing it stops keeps it going once the talk has ended.
//!
//! Runs on the detector thread, inside the spectral matcher; fixed size, allocates
//! nothing after `new`.

use super::features::similarity;

/// How long a sound heard inside talk counts, seconds. Swept over the speech sets of
/// the development sets and the twelve unheard voices, with one and three takes
/// (`docs/speech-guard.md`, "The user's own talk, heard as it goes"): every length
/// from 60 s on keeps out as much, 30 s lets one voice's speech over its floor again.
pub(super) const TALK_KEPT_SECONDS: f64 = 60.0;

/// Speech runs at 4-5 syllables a second, and an onset the guard stops inside talk
/// begins at most one of them: room for `TALK_KEPT_SECONDS` of talk at 4 a second
/// (with 128 or more, the sweep above finds the same).
pub(super) const TALK_ONSETS_PER_SECOND: f64 = 4.0;

/// The features of the onsets heard inside talk, newest overwriting oldest.
#[derive(Debug, Clone)]
pub(super) struct HeardTalk {
    features: usize,
    /// `capacity` vectors of `features` values (unit norm, as the instances are).
    values: Vec<f32>,
    /// The sample each was heard at; `u64::MAX` for an empty slot.
    heard_at: Vec<u64>,
    /// The slot the next one goes into.
    next: usize,
    /// How long each counts, samples.
    kept_samples: u64,
}

impl HeardTalk {
    /// Room for `TALK_KEPT_SECONDS` of talk at `rate` samples a second, of `features`
    /// values each.
    pub fn new(features: usize, rate: f64) -> Self {
        let capacity = (TALK_KEPT_SECONDS * TALK_ONSETS_PER_SECOND).ceil() as usize;
        Self::with_capacity(capacity, features, (TALK_KEPT_SECONDS * rate) as u64)
    }

    /// Room for `capacity` onsets of `features` values, each counting for
    /// `kept_samples` after it was heard.
    fn with_capacity(capacity: usize, features: usize, kept_samples: u64) -> Self {
        Self {
            features,
            values: vec![0.0; capacity * features],
            heard_at: vec![u64::MAX; capacity],
            next: 0,
            kept_samples,
        }
    }

    /// Keeps `instance` (its first `features` values), the onset at sample `at`.
    pub fn learn(&mut self, instance: &[f32], at: u64) {
        let capacity = self.heard_at.len();
        if capacity == 0 {
            return;
        }
        let slot = self.next;
        self.values[slot * self.features..(slot + 1) * self.features]
            .copy_from_slice(&instance[..self.features]);
        self.heard_at[slot] = at;
        self.next = (slot + 1) % capacity;
    }

    /// The talk heard before sample `now`, and not longer than the kept time before
    /// it, that lies nearest `instance`: its similarity (cosine) and the sample it was
    /// heard at. None when there is none.
    pub fn nearest(&self, instance: &[f32], now: u64) -> Option<(f32, u64)> {
        self.values
            .chunks_exact(self.features)
            .zip(&self.heard_at)
            .filter(|&(_, &at)| at < now && now - at <= self.kept_samples)
            .map(|(talk, &at)| (similarity(talk, instance), at))
            .fold(None, |best: Option<(f32, u64)>, (score, at)| match best {
                Some((b, _)) if b >= score => best,
                _ => Some((score, at)),
            })
    }

    /// Forgets everything heard (the features are compared anew).
    pub fn forget(&mut self) {
        self.heard_at.fill(u64::MAX);
        self.next = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(i: usize) -> [f32; 3] {
        let mut v = [0.0; 3];
        v[i] = 1.0;
        v
    }

    #[test]
    fn what_was_heard_counts_for_its_kept_time_and_no_longer() {
        let mut talk = HeardTalk::with_capacity(2, 3, 100);
        assert_eq!(talk.nearest(&unit(0), 10), None);
        talk.learn(&unit(0), 10);
        assert_eq!(talk.nearest(&unit(0), 10), None, "not before it was heard");
        assert_eq!(talk.nearest(&unit(0), 110), Some((1.0, 10)));
        assert_eq!(talk.nearest(&unit(1), 110), Some((0.0, 10)));
        assert_eq!(talk.nearest(&unit(0), 111), None);
    }

    #[test]
    fn the_newest_overwrites_the_oldest_and_the_nearest_is_named() {
        let mut talk = HeardTalk::with_capacity(2, 3, 1000);
        talk.learn(&unit(0), 1);
        talk.learn(&unit(1), 2);
        talk.learn(&unit(2), 3);
        assert_eq!(talk.nearest(&unit(0), 10), Some((0.0, 3)));
        assert_eq!(talk.nearest(&unit(1), 10), Some((1.0, 2)));
        assert_eq!(talk.nearest(&unit(2), 10), Some((1.0, 3)));
        talk.forget();
        assert_eq!(talk.nearest(&unit(2), 10), None);
    }

    #[test]
    fn a_minute_of_talk_at_four_onsets_a_second_is_kept() {
        let rate = 48_000.0;
        let mut talk = HeardTalk::new(3, rate);
        let every = (rate / TALK_ONSETS_PER_SECOND) as u64;
        let n = (TALK_KEPT_SECONDS * TALK_ONSETS_PER_SECOND) as u64;
        talk.learn(&unit(0), 0);
        for i in 1..n {
            talk.learn(&unit(1), i * every);
        }
        assert_eq!(talk.nearest(&unit(0), n * every), Some((1.0, 0)));
        talk.learn(&unit(1), n * every);
        assert_eq!(
            talk.nearest(&unit(0), n * every + 1),
            Some((0.0, n * every))
        );
    }
}
