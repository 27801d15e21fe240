//! The syllable stage: a second look at an impulse the background stage took for speech,
//! once the sound after its onset shows whether it went on as a syllable does. A
//! consonant of speech runs into its vowel: within a few tens of milliseconds the sound
//! is voiced, and as loud as its consonant or louder. A hit (a hi-hat, a snare, a
//! click) is no syllable: its sound falls away, unvoiced. So an onset that its pattern
//! named but that lay nearer the background's speech than its take, and whose sound
//! `after_windows` decision windows on has fallen `fall_db` under its first window
//! without turning voiced, fires its pattern then, dated at its onset (outcome
//! `fell_away`). Owns the onsets waiting for that look; the measure is [`Afterwards`],
//! a pure function of the samples. Runs on the detector thread, inside the spectral
//! matcher ([`super::spectral`]); allocates nothing after `new`.

use super::fifo::Fifo;
use super::pitch::{PitchEstimator, VOICED_CORRELATION};

/// The stage's settings (`docs/background.md`, "A second look, once the sound has gone
/// on").
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SyllableParams {
    /// How many decision windows after its onset a sound is looked at again (75 ms at
    /// the default 25 ms), by when a syllable's consonant has run into its vowel. Swept
    /// 2-4 windows over every dev set: from 3 on alike; after 2 a hit has not yet fallen
    /// away.
    pub after_windows: u64,
    /// How far (dB) its last decision window's power must lie under its first: swept
    /// 8-18 dB, the hits found alike from 8 to 12, the speech passing less the more is
    /// asked; 12 dB, a sixteenth of the power.
    pub fall_db: f64,
}

impl Default for SyllableParams {
    fn default() -> Self {
        Self {
            after_windows: 3,
            fall_db: 12.0,
        }
    }
}

/// What the sound did after its onset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Afterwards {
    /// The power of the last decision window before the look against the first one's,
    /// dB.
    pub fall_db: f64,
    /// How voiced the sound between the two windows is ([`PitchEstimator::voicing`]).
    pub voicing: f64,
}

impl Afterwards {
    /// What samples `onset ..` did over `after` samples, with decision windows of `window`
    /// samples (`sample(n)` reads sample `n`).
    pub(super) fn measure(
        onset: u64,
        window: u64,
        after: u64,
        pitch: &mut PitchEstimator,
        sample: impl Fn(u64) -> f32,
    ) -> Self {
        let power = |from: u64, to: u64| {
            (from..to)
                .map(|n| f64::from(sample(n)).powi(2))
                .sum::<f64>()
                / (to - from).max(1) as f64
        };
        let first = power(onset, onset + window);
        let last = power(onset + after - window, onset + after);
        Self {
            fall_db: 10.0 * (last.max(1e-20) / first.max(1e-20)).log10(),
            voicing: pitch.voicing(onset + window, onset + after, &sample),
        }
    }

    /// It fell away, unvoiced: no syllable.
    pub(super) fn fell_away(&self, params: &SyllableParams) -> bool {
        self.fall_db <= -params.fall_db && self.voicing < VOICED_CORRELATION
    }

    /// It went on as a syllable of talk does: voiced, and as loud as its first window
    /// or louder (its consonant ran into its vowel).
    pub(super) fn went_on_as_a_syllable(&self) -> bool {
        self.voicing >= VOICED_CORRELATION && self.fall_db >= 0.0
    }
}

/// An onset waiting for its second look: its pattern as its first window named it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(super) struct Waiting {
    pub time_sample: u64,
    pub pattern: usize,
    pub strength: f64,
    pub score: f32,
}

/// Onsets waiting (at least 20 ms apart, for `after_windows` windows): a handful would
/// do.
const WAITING: usize = 16;

/// The onsets waiting for their second look, oldest first.
pub(super) struct SecondLooks {
    params: SyllableParams,
    /// How long after its onset a sound is looked at again, and a decision window,
    /// samples.
    after: u64,
    window: u64,
    waiting: Fifo<Waiting, WAITING>,
}

impl SecondLooks {
    pub(super) fn new(params: SyllableParams, rate: f64, window_seconds: f64) -> Self {
        let window = (window_seconds * rate).round() as u64;
        Self {
            params,
            after: params.after_windows * window,
            window,
            waiting: Fifo::new(),
        }
    }

    /// How far after an onset its second look needs the stream, samples.
    pub(super) fn reach(&self) -> u64 {
        self.after
    }

    /// A decision window, samples.
    pub(super) fn window(&self) -> u64 {
        self.window
    }

    /// The background took `onset` for speech.
    pub(super) fn wait(&mut self, onset: Waiting) {
        self.waiting.push(onset);
    }

    /// Onsets that found the queue full.
    pub(super) fn dropped(&self) -> u64 {
        self.waiting.dropped()
    }

    /// The oldest onset whose look is due once `consumed` samples are in, with what its
    /// sound did; `None` when none is due.
    pub(super) fn due(
        &mut self,
        consumed: u64,
        pitch: &mut PitchEstimator,
        sample: impl Fn(u64) -> f32,
    ) -> Option<(Waiting, Afterwards)> {
        let onset = self.waiting.front()?;
        if consumed < onset.time_sample + self.after {
            return None;
        }
        self.waiting.pop();
        let afterwards =
            Afterwards::measure(onset.time_sample, self.window, self.after, pitch, sample);
        Some((onset, afterwards))
    }

    pub(super) fn params(&self) -> &SyllableParams {
        &self.params
    }
}

#[cfg(test)]
mod tests {
    use super::super::pitch::tests::noise;
    use super::*;

    const RATE: f64 = 22_050.0;

    fn measure(x: &[f32]) -> Afterwards {
        let mut pitch = PitchEstimator::new(RATE);
        let sample = |n: u64| x.get(n as usize).copied().unwrap_or(0.0);
        Afterwards::measure(
            0,
            (0.025 * RATE) as u64,
            (0.075 * RATE) as u64,
            &mut pitch,
            sample,
        )
    }

    /// A hiss under a 15 ms decay (a hi-hat) falls away unvoiced; the same hiss running
    /// into a buzz as loud (a consonant into its vowel) does not; nor does a hiss that
    /// goes on (a held "sss").
    #[test]
    fn a_decaying_hiss_fell_away_and_a_syllable_or_a_held_hiss_did_not() {
        let params = SyllableParams::default();
        let n = (0.2 * RATE) as usize;
        let hiss = noise(n, 3);
        let hat: Vec<f32> = hiss
            .iter()
            .enumerate()
            .map(|(i, v)| v * (-(i as f64) / RATE / 0.015).exp() as f32)
            .collect();
        let a = measure(&hat);
        assert!(a.fell_away(&params), "{a:?}");

        let mut syllable: Vec<f32> = hiss[..(0.03 * RATE) as usize].to_vec();
        syllable.extend((0..n).map(|i| {
            let t = i as f64 / RATE;
            (1..=5)
                .map(|k| (2.0 * std::f64::consts::PI * 140.0 * k as f64 * t).sin() / k as f64)
                .sum::<f64>() as f32
                * 0.3
        }));
        let s = measure(&syllable);
        assert!(
            !s.fell_away(&params) && s.voicing >= VOICED_CORRELATION,
            "{s:?}"
        );

        let held = measure(&hiss);
        assert!(
            !held.fell_away(&params) && held.fall_db.abs() < 3.0,
            "{held:?}"
        );
    }

    #[test]
    fn each_waiting_onset_is_looked_at_once_its_sound_is_in() {
        let mut looks = SecondLooks::new(SyllableParams::default(), RATE, 0.025);
        let mut pitch = PitchEstimator::new(RATE);
        let x = noise((0.5 * RATE) as usize, 5);
        let sample = |n: u64| x.get(n as usize).copied().unwrap_or(0.0);
        let onset = |t: u64| Waiting {
            time_sample: t,
            pattern: 1,
            strength: 0.5,
            score: 0.7,
        };
        looks.wait(onset(100));
        looks.wait(onset(2000));
        let reach = looks.reach();
        assert!(looks.due(100 + reach - 1, &mut pitch, sample).is_none());
        let (first, _) = looks.due(100 + reach, &mut pitch, sample).unwrap();
        assert_eq!(first.time_sample, 100);
        assert!(looks.due(2000 + reach - 1, &mut pitch, sample).is_none());
        assert_eq!(
            looks
                .due(2000 + reach, &mut pitch, sample)
                .unwrap()
                .0
                .time_sample,
            2000
        );
        assert!(looks.due(u64::MAX / 2, &mut pitch, sample).is_none());
        for k in 0..WAITING as u64 + 2 {
            looks.wait(onset(k));
        }
        assert_eq!(looks.dropped(), 2);
    }
}
