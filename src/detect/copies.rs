//! The copies stage: a sound that is one of the enrolled takes, sample for sample (a
//! take played back, a sample triggered, a recording made of the takes), is that take's
//! pattern, even where its first decision window, soft in the room's noise, is not
//! (the "f" of a "flick" 11 dB under its take, in noise 50 dB down). Owns each impulse
//! take's first `SPAN_SECONDS` from its onset, and the onsets that did not fire, each
//! waiting until the stream holds that much sound after it. Then the waveform decides:
//! the normalised cross-correlation of each take with the stream, at every lag within
//! `MAX_LAG_SECONDS` of the onset; the best take at `COPY_SIMILARITY` or more, and
//! within `COPY_SLACK` of what the room's noise lets a copy reach, fires its pattern,
//! dated where the take's onset falls in the stream. An instance that the
//! spectral decision fired is never checked, nor one the speech guard stopped (what
//! came before a sound is the guard's to judge; `speech_guard_seconds = 0` to play
//! takes back while talking), and a copy whose pattern fired within it is not fired
//! again.
//!
//! A waveform is proof only when unrelated sounds cannot match it by chance: a take that
//! is nearly a tone (a kick's low boom) correlates with any sound at its pitch. A take
//! takes part when its span holds at least `(3 / COPY_SIMILARITY)^2` independent
//! samples (its length over the sum of its squared autocorrelation), so that a chance
//! correlation, whose spread is one over their square root, lies three spreads under
//! the similarity asked.
//!
//! Runs on the detector thread, inside the spectral matcher ([`super::spectral`]). The
//! FFT plans, the takes' spectra and every buffer are made in [`Copies::new`]; checking
//! allocates nothing.

use std::sync::Arc;

use realfft::num_complex::Complex32;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};

use super::waveform::{correlate, prefix_squares, template_spectrum};

/// How much of a take, from its onset, the comparison holds: long enough that a copy's
/// soft start is outweighed by its louder later sound, and that a word said again by
/// the same voice, even a synthetic one, parts from the take. On the development sets'
/// speech no onset comes within 0.8 of a take over 0.25 s (0.85 over 0.1 s), while
/// exact copies 12 dB down in noise 50 dB down reach 0.94 or more
/// (`scripts/copy-similarity.py`, `docs/classify.md`).
pub(super) const SPAN_SECONDS: f64 = 0.25;
/// How far from the onset the take's onset may lie in the stream: the two were placed
/// by the same stages, but on a soft start in noise the stream's placement comes later.
pub(super) const MAX_LAG_SECONDS: f64 = 0.025;
/// A take and its copy in noise 6 dB under it correlate at sqrt(4/5) = 0.89: the copy
/// must stand at least that far out of its room.
pub(super) const COPY_SIMILARITY: f32 = 0.9;
/// A copy correlates with its take as well as the room's noise lets it: sqrt(1 - N/W),
/// N the noise's energy over the span and W the window's. It may fall this far short
/// of that: the stream and the take are resampled at different fractions of a sample,
/// and the noise is read from the room's quietest frames, a dB or so under its mean. A
/// word said again, loud over the noise, correlates 0.85-0.89 at most (an unheard
/// synthetic voice's speech, `docs/classify.md`): it falls short by 0.1 or more.
pub(super) const COPY_SLACK: f32 = 0.05;
/// Onsets waiting (at least 20 ms apart, for at most `SPAN_SECONDS` and two lags).
const WAITING: usize = 32;
/// Recent impulses fired, to tell a copy already found.
const RECENT: usize = 32;

/// One take as the stage compares it.
struct CopyTake {
    pattern: usize,
    /// Samples compared, from the take's onset.
    len: usize,
    /// Energy of those samples.
    energy: f64,
    /// Its [`template_spectrum`], for [`correlate`].
    spectrum: Vec<Complex32>,
}

/// A copy found ([`Copies::check`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Found {
    pub pattern: usize,
    /// Where the take's onset falls in the stream (sample).
    pub time_sample: u64,
    /// The normalised cross-correlation.
    pub similarity: f32,
    /// Amplitude against the take over the span.
    pub strength: f64,
    /// Samples the copy spans from its onset.
    pub len: u64,
}

pub(super) struct Copies {
    takes: Vec<CopyTake>,
    max_lag: usize,
    /// The longest span of any take.
    longest: usize,
    forward: Arc<dyn RealToComplex<f32>>,
    inverse: Arc<dyn ComplexToReal<f32>>,
    segment: Vec<f32>,
    segment_spectrum: Vec<Complex32>,
    product: Vec<Complex32>,
    correlation: Vec<f32>,
    /// Prefix sums of the segment's squares.
    prefix: Vec<f64>,
    forward_scratch: Vec<Complex32>,
    inverse_scratch: Vec<Complex32>,
    /// Onsets waiting for their span (samples, oldest first).
    waiting: Vec<u64>,
    dropped: u64,
    /// Impulses fired lately (onset sample, pattern), a ring.
    recent: [(u64, usize); RECENT],
    recent_next: usize,
}

/// Independent samples in `x`: its length over the sum of its squared normalised
/// autocorrelation (every lag, both signs). A white sound has as many as its length, a
/// tone a few.
fn independent_samples(x: &[f32], planner: &mut RealFftPlanner<f32>) -> f64 {
    let n = x.len();
    if n == 0 {
        return 0.0;
    }
    let len = (2 * n).next_power_of_two();
    let forward = planner.plan_fft_forward(len);
    let inverse = planner.plan_fft_inverse(len);
    let mut padded = vec![0.0f32; len];
    padded[..n].copy_from_slice(x);
    let mut spectrum = forward.make_output_vec();
    if forward.process(&mut padded, &mut spectrum).is_err() {
        return 0.0;
    }
    for c in spectrum.iter_mut() {
        *c = Complex32::new(c.norm_sqr(), 0.0);
    }
    let mut acf = vec![0.0f32; len];
    if inverse.process(&mut spectrum, &mut acf).is_err() || acf[0] <= 0.0 {
        return 0.0;
    }
    let zero = f64::from(acf[0]);
    let squares: f64 = acf[1..n]
        .iter()
        .map(|&a| (f64::from(a) / zero).powi(2))
        .sum();
    n as f64 / (1.0 + 2.0 * squares)
}

impl Copies {
    /// The stage for impulse takes given as (pattern, samples at the working `rate`,
    /// onset sample); takes that are nearly tones are left out (see the module comment).
    pub(super) fn new<'a>(
        takes: impl Iterator<Item = (usize, &'a [f32], usize)>,
        rate: f64,
    ) -> Self {
        let span = (SPAN_SECONDS * rate) as usize;
        let max_lag = (MAX_LAG_SECONDS * rate) as usize;
        let mut planner = RealFftPlanner::<f32>::new();
        let enough = (3.0 / f64::from(COPY_SIMILARITY)).powi(2);
        // A silent span has no independent sample: every take kept has energy.
        let spans: Vec<(usize, &[f32])> = takes
            .filter_map(|(pattern, samples, onset)| {
                let s = &samples[onset.min(samples.len())..];
                let s = &s[..s.len().min(span)];
                (independent_samples(s, &mut planner) >= enough).then_some((pattern, s))
            })
            .collect();
        let longest = spans.iter().map(|(_, s)| s.len()).max().unwrap_or(0);
        let fft_len = (longest + 2 * max_lag).max(2).next_power_of_two();
        let forward = planner.plan_fft_forward(fft_len);
        let inverse = planner.plan_fft_inverse(fft_len);
        let mut padded = forward.make_input_vec();
        let takes = spans
            .into_iter()
            .map(|(pattern, s)| {
                let energy: f64 = s.iter().map(|&x| f64::from(x).powi(2)).sum();
                CopyTake {
                    pattern,
                    len: s.len(),
                    energy,
                    spectrum: template_spectrum(forward.as_ref(), s, energy, &mut padded),
                }
            })
            .collect();
        Self {
            takes,
            max_lag,
            longest,
            segment: vec![0.0; fft_len],
            segment_spectrum: forward.make_output_vec(),
            product: forward.make_output_vec(),
            correlation: vec![0.0; fft_len],
            prefix: vec![0.0; fft_len + 1],
            forward_scratch: forward.make_scratch_vec(),
            inverse_scratch: inverse.make_scratch_vec(),
            forward,
            inverse,
            waiting: Vec::with_capacity(WAITING),
            dropped: 0,
            recent: [(u64::MAX, usize::MAX); RECENT],
            recent_next: 0,
        }
    }

    /// Whether any take takes part.
    pub(super) fn is_empty(&self) -> bool {
        self.takes.is_empty()
    }

    /// Samples of stream a check needs after an onset (and kept before it: `max_lag`).
    pub(super) fn reach(&self) -> u64 {
        (self.longest + self.max_lag) as u64
    }

    /// The onset at sample `onset` did not fire: it is checked once its span is in.
    pub(super) fn wait(&mut self, onset: u64) {
        if self.is_empty() {
            return;
        }
        if self.waiting.len() < self.waiting.capacity() {
            self.waiting.push(onset);
        } else {
            self.dropped += 1;
        }
    }

    /// Onsets that found the queue full and were never checked.
    pub(super) fn dropped(&self) -> u64 {
        self.dropped
    }

    /// An impulse of `pattern` fired at sample `onset` (by any stage).
    pub(super) fn fired(&mut self, onset: u64, pattern: usize) {
        self.recent[self.recent_next] = (onset, pattern);
        self.recent_next = (self.recent_next + 1) % RECENT;
    }

    /// The oldest waiting onset whose span the stream holds once `consumed` samples are
    /// in, taken from the queue.
    pub(super) fn due(&mut self, consumed: u64) -> Option<u64> {
        let &onset = self.waiting.first()?;
        (onset + self.reach() <= consumed).then(|| self.waiting.remove(0))
    }

    /// Checks the onset at sample `onset` against every take, the stream read through
    /// `sample` (which holds `onset - max_lag` to `onset + reach()`) in a room whose
    /// noise has `noise_power` (mean square per sample); a copy found that no impulse of
    /// its pattern already fired within.
    pub(super) fn check(
        &mut self,
        onset: u64,
        noise_power: f64,
        sample: impl Fn(u64) -> f32,
    ) -> Option<Found> {
        let lag = self.max_lag as u64;
        let start = onset.checked_sub(lag)?;
        let filled = self.longest + 2 * self.max_lag;
        self.segment.fill(0.0);
        for (i, s) in self.segment[..filled].iter_mut().enumerate() {
            *s = sample(start + i as u64);
        }
        prefix_squares(&self.segment, &mut self.prefix);
        self.forward
            .process_with_scratch(
                &mut self.segment,
                &mut self.segment_spectrum,
                &mut self.forward_scratch,
            )
            .ok()?;
        let mut best: Option<Found> = None;
        for take in &self.takes {
            correlate(
                self.inverse.as_ref(),
                &self.segment_spectrum,
                &take.spectrum,
                &mut self.product,
                &mut self.correlation,
                &mut self.inverse_scratch,
            );
            for j in 0..=2 * self.max_lag {
                let window = self.prefix[j + take.len] - self.prefix[j];
                if window <= 0.0 {
                    continue;
                }
                let similarity = (f64::from(self.correlation[j]) / window.sqrt()) as f32;
                let allowed = (1.0 - noise_power * take.len as f64 / window)
                    .max(0.0)
                    .sqrt();
                if similarity < COPY_SIMILARITY.max(allowed as f32 - COPY_SLACK) {
                    continue;
                }
                if best.is_none_or(|b| similarity > b.similarity) {
                    best = Some(Found {
                        pattern: take.pattern,
                        time_sample: start + j as u64,
                        similarity,
                        strength: (window / take.energy).sqrt(),
                        len: take.len as u64,
                    });
                }
            }
        }
        let copy = best?;
        let found = self.recent.iter().any(|&(at, pattern)| {
            pattern == copy.pattern
                && at + lag >= copy.time_sample
                && at < copy.time_sample + copy.len
        });
        if found {
            return None;
        }
        // Later onsets inside the copy are its own sound.
        self.waiting.retain(|&w| w >= copy.time_sample + copy.len);
        self.fired(copy.time_sample, copy.pattern);
        Some(copy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATE: f64 = 22_050.0;
    /// The streams' noise: white noise in [-1, 1) times 0.0125 has a mean square of
    /// 0.0125^2 / 3.
    const NOISE_POWER: f64 = 0.0125 * 0.0125 / 3.0;

    /// Deterministic white noise in [-1, 1): the pitch tests' generator, seeded apart
    /// and doubled (the same samples, bit for bit, as this test's own generator gave).
    fn noise(n: usize, seed: u64) -> Vec<f32> {
        let seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        super::super::pitch::tests::noise(n, seed)
            .iter()
            .map(|x| 2.0 * x)
            .collect()
    }

    fn check_at(copies: &mut Copies, stream: &[f32], onset: u64) -> Option<Found> {
        copies.check(onset, NOISE_POWER, |n| {
            stream.get(n as usize).copied().unwrap_or(0.0)
        })
    }

    #[test]
    fn a_take_in_noise_is_found_where_it_begins_and_at_its_level() {
        let take: Vec<f32> = noise(3000, 1).iter().map(|x| 0.5 * x).collect();
        let mut copies = Copies::new([(0, take.as_slice(), 0)].into_iter(), RATE);
        assert!(!copies.is_empty());
        // The copy at a quarter of the take's level, 6 ms after where the onset was
        // placed, in noise 20 dB under it.
        let mut stream: Vec<f32> = noise(20_000, 2).iter().map(|x| 0.0125 * x).collect();
        let at = 5_000;
        for (i, &x) in take.iter().enumerate() {
            stream[at + i] += 0.25 * x;
        }
        let placed = (at - 132) as u64;
        let copy = check_at(&mut copies, &stream, placed).expect("the copy is found");
        assert_eq!(copy.time_sample, at as u64);
        assert!(copy.similarity > 0.98, "{copy:?}");
        assert!((copy.strength - 0.25).abs() < 0.02, "{copy:?}");
    }

    #[test]
    fn another_sound_with_the_same_spectrum_is_no_copy() {
        let take = noise(3000, 1);
        let mut copies = Copies::new([(0, take.as_slice(), 0)].into_iter(), RATE);
        let stream = noise(20_000, 7);
        assert_eq!(check_at(&mut copies, &stream, 5_000), None);
    }

    #[test]
    fn a_sound_alike_but_loud_over_the_room_is_no_copy_while_a_copy_as_alike_in_noise_is() {
        let take = noise(3000, 1);
        let mut copies = Copies::new([(0, take.as_slice(), 0)].into_iter(), RATE);
        // Correlated 0.92 with the take: by the room's noise (the take at 8 dB over
        // it), or by another sound over a quiet room.
        let place = |other: f32, noise_amp: f32| {
            let mut stream: Vec<f32> = noise(20_000, 2).iter().map(|x| noise_amp * x).collect();
            let others = noise(3000, 5);
            for (i, (&x, &o)) in take.iter().zip(&others).enumerate() {
                stream[5_000 + i] += 0.25 * x + other * o;
            }
            stream
        };
        let as_loud = 0.25 * (1.0f32 / 0.92 / 0.92 - 1.0).sqrt();
        let in_noise = place(0.0, as_loud);
        let noise_power = f64::from(as_loud * as_loud) / 3.0;
        let found = copies
            .check(5_000, noise_power, |n| in_noise[n as usize])
            .expect("a copy in noise");
        assert!((0.9..0.95).contains(&found.similarity), "{found:?}");
        let alike = place(as_loud, 0.0125);
        assert_eq!(check_at(&mut copies, &alike, 5_000), None);
    }

    #[test]
    fn a_take_that_is_nearly_a_tone_takes_no_part() {
        let tone: Vec<f32> = (0..3000)
            .map(|i| (2.0 * std::f64::consts::PI * 56.0 * i as f64 / RATE).sin() as f32)
            .collect();
        assert!(independent_samples(&tone, &mut RealFftPlanner::new()) < 11.0);
        assert!(independent_samples(&noise(3000, 3), &mut RealFftPlanner::new()) > 1000.0);
        let copies = Copies::new([(0, tone.as_slice(), 0)].into_iter(), RATE);
        assert!(copies.is_empty());
    }

    #[test]
    fn a_copy_already_fired_or_found_is_not_fired_again() {
        let take = noise(3000, 1);
        let mut copies = Copies::new([(0, take.as_slice(), 0)].into_iter(), RATE);
        let mut stream = vec![0.0f32; 20_000];
        stream[5_000..8_000].copy_from_slice(&take);
        copies.fired(5_010, 0);
        assert_eq!(check_at(&mut copies, &stream, 5_000), None);
        let mut copies = Copies::new([(0, take.as_slice(), 0)].into_iter(), RATE);
        copies.wait(5_000);
        copies.wait(5_400);
        copies.wait(9_000);
        assert_eq!(copies.due(5_000), None, "its span is not in yet");
        let first = copies.due(20_000).unwrap();
        assert!(check_at(&mut copies, &stream, first).is_some());
        assert_eq!(
            copies.due(20_000),
            Some(9_000),
            "the onset inside the copy is dropped"
        );
    }
}
