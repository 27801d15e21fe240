//! The pitch stage: the fundamental frequency of a held voiced sound, by normalised
//! autocorrelation over the middle of its samples, and how voiced a stretch of sound is
//! (for the syllable stage, [`super::syllable`]). Runs on the detector thread when a
//! held sound ends; its buffers (the samples correlated, a correlation per lag) are made
//! once, so it allocates nothing.

const PITCH_MIN_HZ: f64 = 60.0;
const PITCH_MAX_HZ: f64 = 500.0;
/// The longest stretch of the sound that is correlated.
const PITCH_WINDOW_SECONDS: f64 = 0.1;
/// A held sound is voiced when its autocorrelation reaches this at some lag.
pub(super) const VOICED_CORRELATION: f64 = 0.6;

pub(super) struct PitchEstimator {
    rate: f64,
    /// Correlation per lag (lags `min - 1 ..= max + 1`).
    by_lag: Vec<f64>,
    /// The samples correlated, copied out of the caller's ring once.
    window: Vec<f64>,
}

impl PitchEstimator {
    pub(super) fn new(rate: f64) -> Self {
        let lags = ((rate / PITCH_MIN_HZ).ceil() - (rate / PITCH_MAX_HZ).floor()) as usize + 3;
        let longest =
            (PITCH_WINDOW_SECONDS * rate) as usize + (rate / PITCH_MIN_HZ).ceil() as usize + 2;
        Self {
            rate,
            by_lag: vec![0.0; lags],
            window: vec![0.0; longest],
        }
    }

    /// Fundamental frequency (60-500 Hz) over the middle of samples [lo, hi)
    /// (`sample(n)` reads sample `n`), by normalised autocorrelation: the shortest lag
    /// whose correlation is within 10% of the best. `None` when the best correlation is
    /// below `VOICED_CORRELATION` (unvoiced, noisy) or the span is too short.
    pub(super) fn estimate(
        &mut self,
        lo: u64,
        hi: u64,
        sample: impl Fn(u64) -> f32,
    ) -> Option<f64> {
        let min_lag = self.correlate(lo, hi, 2, sample)?;
        pitch_from_correlations(&self.by_lag, min_lag, self.rate)
    }

    /// How voiced samples [lo, hi) are: their best normalised correlation at a lag of one
    /// period of 60-500 Hz, over the middle of the span (0 when it holds less than two of
    /// the longest periods). A voice's vowel reaches [`VOICED_CORRELATION`]; a hiss, a
    /// click's decay and a room's noise stay far under it.
    pub(super) fn voicing(&mut self, lo: u64, hi: u64, sample: impl Fn(u64) -> f32) -> f64 {
        match self.correlate(lo, hi, 1, sample) {
            Some(_) => self.by_lag[1..self.by_lag.len() - 1]
                .iter()
                .fold(0.0, |best, &c| best.max(c)),
            None => 0.0,
        }
    }

    /// Fills `by_lag` with the normalised correlation of the middle of samples [lo, hi)
    /// at every lag of `min_lag - 1 ..= max_lag + 1`, over a stretch of at least
    /// `periods` of the longest period (at most `PITCH_WINDOW_SECONDS`); returns
    /// `min_lag`, or `None` when the span is too short.
    fn correlate(
        &mut self,
        lo: u64,
        hi: u64,
        periods: u64,
        sample: impl Fn(u64) -> f32,
    ) -> Option<u64> {
        let min_lag = (self.rate / PITCH_MAX_HZ).floor() as u64;
        let max_lag = (self.rate / PITCH_MIN_HZ).ceil() as u64;
        let span = hi.saturating_sub(lo);
        let len = ((PITCH_WINDOW_SECONDS * self.rate) as u64).min(span.saturating_sub(max_lag + 1));
        if len < periods * max_lag {
            return None;
        }
        let start = lo + (span - len - max_lag) / 2;
        let (len, max_lag) = (len as usize, max_lag as usize);
        let window = &mut self.window[..len + max_lag + 1];
        for (w, n) in window.iter_mut().zip(start..) {
            *w = f64::from(sample(n));
        }
        let window = &*window;
        let correlation = |lag: u64| {
            let (mut xy, mut xx, mut yy) = (0.0f64, 0.0f64, 0.0f64);
            let lag = lag as usize;
            for (&x, &y) in window[..len].iter().zip(&window[lag..lag + len]) {
                xy += x * y;
                xx += x * x;
                yy += y * y;
            }
            if xx > 0.0 && yy > 0.0 {
                xy / (xx * yy).sqrt()
            } else {
                0.0
            }
        };
        for (slot, lag) in self.by_lag.iter_mut().zip(min_lag - 1..=max_lag as u64 + 1) {
            *slot = correlation(lag);
        }
        Some(min_lag)
    }
}

/// Pitch from the correlations of lags `min_lag - 1 ..= max_lag + 1` (`by_lag[0]` is
/// lag `min_lag - 1`): the shortest lag within 10% of the best, walked up to its local
/// peak and refined with a parabola through 3 points.
fn pitch_from_correlations(by_lag: &[f64], min_lag: u64, rate: f64) -> Option<f64> {
    let corr = |lag: u64| by_lag[(lag + 1 - min_lag) as usize];
    let max_lag = min_lag + by_lag.len() as u64 - 3;
    let best = (min_lag..=max_lag)
        .map(corr)
        .fold(f64::NEG_INFINITY, f64::max);
    if best < VOICED_CORRELATION {
        return None;
    }
    let lag = (min_lag..=max_lag).find(|&l| corr(l) >= 0.9 * best)?;
    // Walk up to the local peak, then refine it with a parabola through 3 points.
    let mut lag = lag;
    while lag < max_lag && corr(lag + 1) > corr(lag) {
        lag += 1;
    }
    let (a, b, c) = (corr(lag - 1), corr(lag), corr(lag + 1));
    let denom = a - 2.0 * b + c;
    let shift = if denom.abs() > 1e-12 {
        0.5 * (a - c) / denom
    } else {
        0.0
    };
    Some(rate / (lag as f64 + shift.clamp(-0.5, 0.5)))
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    const RATE: f64 = 22_050.0;

    /// A voiced buzz at `f0`: its first five harmonics, falling by 6 dB each.
    fn buzz(f0: f64, seconds: f64) -> Vec<f32> {
        (0..(seconds * RATE) as usize)
            .map(|i| {
                let t = i as f64 / RATE;
                (1..=5)
                    .map(|k| (2.0 * std::f64::consts::PI * f0 * k as f64 * t).sin() / k as f64)
                    .sum::<f64>() as f32
                    * 0.3
            })
            .collect()
    }

    /// `n` samples of uniform white noise (a linear congruential generator from `seed`).
    pub(in crate::detect) fn noise(n: usize, seed: u64) -> Vec<f32> {
        let mut state = seed;
        (0..n)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 40) as f32 / (1u64 << 24) as f32) - 0.5
            })
            .collect()
    }

    fn estimate(x: &[f32]) -> Option<f64> {
        PitchEstimator::new(RATE).estimate(0, x.len() as u64, |n| x[n as usize])
    }

    #[test]
    fn a_buzz_gives_its_fundamental() {
        for f0 in [80.0, 150.0, 220.0, 440.0] {
            let pitch = estimate(&buzz(f0, 0.3)).expect("voiced");
            assert!((pitch / f0 - 1.0).abs() < 0.01, "{f0} Hz: {pitch}");
        }
    }

    #[test]
    fn a_buzz_is_voiced_and_noise_is_not() {
        let mut pitch = PitchEstimator::new(RATE);
        // 50 ms: the span the syllable stage asks about.
        let n = (0.05 * RATE) as usize;
        for f0 in [80.0, 150.0, 300.0] {
            let x = buzz(f0, 0.05);
            let v = pitch.voicing(0, n as u64, |k| x[k as usize]);
            assert!(v >= VOICED_CORRELATION, "{f0} Hz: {v}");
        }
        let noise = noise(n, 7);
        let v = pitch.voicing(0, n as u64, |k| noise[k as usize]);
        assert!(v < 0.3, "noise: {v}");
        // Shorter than one of the longest periods (60 Hz) and the lag itself.
        assert_eq!(pitch.voicing(0, 400, |k| noise[k as usize]), 0.0);
    }

    #[test]
    fn noise_and_a_short_span_give_none() {
        let noise = noise((0.3 * RATE) as usize, 1);
        assert_eq!(estimate(&noise), None);
        // Shorter than two of the longest periods (60 Hz).
        assert_eq!(estimate(&buzz(150.0, 0.02)), None);
    }
}
