//! The features stage: short-time log-mel frames of the samples, and the pooled
//! cepstral features an onset is classified by. Pure functions of their input; the
//! analyser owns its FFT plan and buffers, made once, so `frame` allocates nothing.
//! Runs on the detector thread (and at enrolment, on the thread that builds the
//! detector).
//!
//! Frames: 256-sample Hann windows every 64 samples (at 22.05 kHz: 11.6 ms every
//! 2.9 ms), 32 mel bands from 80 Hz to 8.7 kHz, in dB, floored 60 dB below the loudest
//! band. Features: the frames of a decision window pooled into one mean power
//! spectrum, in dB, floored 50 dB below its loudest band, turned into cepstral
//! coefficients weighted towards the finer shape of the spectrum, of unit norm; two
//! sounds are compared by the cosine of their features. Only the bands that the input
//! and every take carry are compared ([`Cepstrum`]).

use std::sync::Arc;

use biquad::{Biquad, Coefficients, DirectForm2Transposed, ToHertz, Type};
use realfft::num_complex::Complex32;
use realfft::{RealFftPlanner, RealToComplex};

pub(super) const WINDOW_SECONDS: f64 = 256.0 / 22_050.0;
pub(super) const HOP_SECONDS: f64 = 64.0 / 22_050.0;
pub(super) const BANDS: usize = 32;
const LOW_HZ: f64 = 80.0;
/// Top of the mel bands at the working `rate`: where the resampler's passband ends
/// (8.7 kHz at 22.05 kHz). Above it, a band's level depends on the anti-aliasing
/// filter rather than on the sound. The bands used to stop at 7 kHz; over every dev
/// set the mean F1 rises from 0.818 to 0.834 at the passband's end and stays within
/// 0.828-0.838 from there to the Nyquist frequency (`docs/classify.md`).
pub(super) fn top_hz(rate: f64) -> f64 {
    crate::audio::resampler_passband() * rate / 2.0
}
/// Cutoff of [`LowCut`]: far enough under the bands' low edge (`LOW_HZ`) that what the
/// bands hear passes within 0.4 dB (24 dB an octave: (80/60)^8 = 10, -0.41 dB), so a
/// kick's fundamental counts in the level as it does in the bands.
const LOW_CUT_HZ: f64 = 60.0;
/// The samples as the bands hear them, for the level of the sound in a frame: a
/// 4th-order Butterworth high-pass under the bands (`LOW_CUT_HZ`). Rumble under the
/// bands (traffic, air conditioning, a microphone handled, a DC offset) is nothing the
/// bands or the features see, so it is no sound for the gates either; in the samples'
/// plain power it would be most of a quiet room's level, and wander with it. Runs
/// wherever the samples arrive; one sample at a time, allocating nothing.
#[derive(Clone)]
pub(super) struct LowCut {
    stages: [DirectForm2Transposed<f32>; 2],
}

impl LowCut {
    pub(super) fn new(rate: f64) -> Self {
        // The two sections of a 4th-order Butterworth filter: Q = 1 / (2 cos(k pi / 8)),
        // k = 1 and 3.
        let section = |q: f64| {
            let coefficients = Coefficients::<f32>::from_params(
                Type::HighPass,
                (rate as f32).hz(),
                (LOW_CUT_HZ as f32).hz(),
                q as f32,
            )
            // A rate under twice the cutoff (no rate the program accepts) passes all.
            .unwrap_or(Coefficients {
                a1: 0.0,
                a2: 0.0,
                b0: 1.0,
                b1: 0.0,
                b2: 0.0,
            });
            DirectForm2Transposed::<f32>::new(coefficients)
        };
        let q = |k: f64| 1.0 / (2.0 * (k * std::f64::consts::PI / 8.0).cos());
        Self {
            stages: [section(q(1.0)), section(q(3.0))],
        }
    }

    pub(super) fn run(&mut self, x: f32) -> f32 {
        self.stages.iter_mut().fold(x, |y, s| s.run(y))
    }
}

/// Cutoff of [`DcBlock`]: far enough under the bands' low edge (`LOW_HZ`) that they hear
/// no difference (0.02 dB at 80 Hz), and under the 20 Hz where hearing ends.
const DC_BLOCK_HZ: f64 = 5.0;

/// A DC blocker (one pole, one zero at DC; `DC_BLOCK_HZ`): a microphone's or a
/// converter's offset is no sound, but a window's leakage puts it in the lowest band,
/// its power in every strength and level, and a stream that stops (the zeros after
/// its end) steps out of it. The takes have their mean taken away when they are
/// enrolled; the stream has this. Starts from silence, so a stream without an offset
/// is its own samples from the first; one sample at a time, allocating nothing.
#[derive(Clone)]
pub(super) struct DcBlock {
    pole: f32,
    last_in: f32,
    last_out: f32,
}

impl DcBlock {
    pub(super) fn new(rate: f64) -> Self {
        Self {
            pole: (-2.0 * std::f64::consts::PI * DC_BLOCK_HZ / rate).exp() as f32,
            last_in: 0.0,
            last_out: 0.0,
        }
    }

    pub(super) fn run(&mut self, x: f32) -> f32 {
        let y = x - self.last_in + self.pole * self.last_out;
        self.last_in = x;
        self.last_out = y;
        y
    }
}

/// Bands are floored this far below the frame's loudest band.
const BAND_RANGE_DB: f32 = 60.0;

struct MelBand {
    first_bin: usize,
    weights: Vec<f32>,
}

/// The edges of the mel bands at `rate` (`BANDS + 2` of them, in Hz): band `b` rises
/// from edge `b` to `b + 1` and falls to `b + 2`. Allocates nothing: the bands compared
/// are found again while a stream runs.
fn band_edges(rate: f64) -> [f64; BANDS + 2] {
    let mel = |hz: f64| 2595.0 * (1.0 + hz / 700.0).log10();
    let hz = |m: f64| 700.0 * (10f64.powf(m / 2595.0) - 1.0);
    let (m0, m1) = (mel(LOW_HZ), mel(top_hz(rate)));
    std::array::from_fn(|i| hz(m0 + (m1 - m0) * i as f64 / (BANDS + 1) as f64))
}

/// The centre of each mel band at `rate`, in Hz.
pub(super) fn band_centres(rate: f64) -> Vec<f64> {
    band_edges(rate)[1..=BANDS].to_vec()
}

/// The top edge of band `b` at `rate`, in Hz.
pub(super) fn band_top_hz(rate: f64, b: usize) -> f64 {
    band_edges(rate)[b.min(BANDS - 1) + 2]
}

/// Log-mel analysis shared by the matcher and the templates.
pub(super) struct Analyzer {
    pub(super) win: usize,
    pub(super) hop: usize,
    fft: Arc<dyn RealToComplex<f32>>,
    window: Vec<f32>,
    fft_in: Vec<f32>,
    spectrum: Vec<Complex32>,
    /// The last frame's power per spectral bin, |X|², each read by the two bands over it.
    bin_power: Vec<f32>,
    scratch: Vec<Complex32>,
    bands: Vec<MelBand>,
    /// The bands compared, every one until [`Analyzer::compare_under`] says otherwise.
    pub(super) cepstrum: Cepstrum,
    /// The last frame's band powers (linear), for the onset stage.
    pub(super) power: Vec<f32>,
}

impl Analyzer {
    pub(super) fn new(rate: f64) -> Self {
        let win = Self::win_at(rate);
        let hop = Self::hop_at(rate);
        let fft = RealFftPlanner::<f32>::new().plan_fft_forward(win);
        let window = (0..win)
            .map(|i| {
                let x = std::f64::consts::PI * 2.0 * i as f64 / win as f64;
                (0.5 - 0.5 * x.cos()) as f32
            })
            .collect();
        let bins = win / 2 + 1;
        let edges = band_edges(rate);
        let bin_hz = rate / win as f64;
        let bands = (0..BANDS)
            .map(|b| {
                let (lo, mid, hi) = (edges[b], edges[b + 1], edges[b + 2]);
                let first = ((lo / bin_hz).floor() as usize).min(bins - 1);
                let last = ((hi / bin_hz).ceil() as usize).min(bins - 1);
                let mut weights: Vec<f32> = (first..=last)
                    .map(|k| {
                        let f = k as f64 * bin_hz;
                        let w = if f <= mid {
                            (f - lo) / (mid - lo)
                        } else {
                            (hi - f) / (hi - mid)
                        };
                        w.max(0.0) as f32
                    })
                    .collect();
                // Narrow low bands may fall between bins: give them their nearest bin.
                if weights.iter().all(|&w| w == 0.0) {
                    let nearest = ((mid / bin_hz).round() as usize).clamp(first, last);
                    weights[nearest - first] = 1.0;
                }
                MelBand {
                    first_bin: first,
                    weights,
                }
            })
            .collect();
        Self {
            win,
            hop,
            fft_in: fft.make_input_vec(),
            spectrum: fft.make_output_vec(),
            bin_power: vec![0.0; bins],
            scratch: fft.make_scratch_vec(),
            fft,
            window,
            bands,
            cepstrum: Cepstrum::full(),
            power: vec![0.0; BANDS],
        }
    }

    /// Compares only the bands wholly under `content_top_hz`, the highest frequency
    /// the input (and every take) carries.
    pub(super) fn compare_under(&mut self, rate: f64, content_top_hz: f64) {
        self.cepstrum = Cepstrum::new(present_bands(rate, content_top_hz));
    }

    /// Samples in a frame's window at `rate`.
    pub(super) fn win_at(rate: f64) -> usize {
        ((WINDOW_SECONDS * rate).round() as usize).max(32)
    }

    /// Samples between frames at `rate`.
    pub(super) fn hop_at(rate: f64) -> usize {
        ((HOP_SECONDS * rate).round() as usize).max(1)
    }

    /// The sample at the centre of frame `f`'s window (frame 0's window starts at
    /// sample 0).
    pub(super) fn frame_centre(&self, f: u64) -> u64 {
        f * self.hop as u64 + self.win as u64 / 2
    }

    /// The frame whose window is centred nearest `sample`: where an onset's features
    /// start, in a stream and in a take alike.
    pub(super) fn frame_centred_on(&self, sample: u64) -> u64 {
        (sample.saturating_sub(self.win as u64 / 2) as f64 / self.hop as f64).round() as u64
    }

    /// Per band: the effective number of spectral bins its filter sums, (sum w)^2 /
    /// sum w^2 for its weights w.
    pub(super) fn band_bins(&self) -> Vec<f32> {
        self.bands
            .iter()
            .map(|b| {
                let sum: f32 = b.weights.iter().sum();
                let squares: f32 = b.weights.iter().map(|w| w * w).sum();
                sum * sum / squares.max(1e-12)
            })
            .collect()
    }

    /// Log-mel frame (dB) of `samples` (`win` long) into `out`; returns the frame's
    /// level in dB (mean power).
    pub(super) fn frame(&mut self, samples: &[f32], out: &mut [f32]) -> f32 {
        for ((d, &x), &w) in self.fft_in.iter_mut().zip(samples).zip(&self.window) {
            *d = x * w;
        }
        let power = sum_of_squares(samples);
        let _ =
            self.fft
                .process_with_scratch(&mut self.fft_in, &mut self.spectrum, &mut self.scratch);
        for (p, c) in self.bin_power.iter_mut().zip(&self.spectrum) {
            *p = c.norm_sqr();
        }
        for (band, p) in self.bands.iter().zip(&mut self.power) {
            let e: f32 = band
                .weights
                .iter()
                .zip(&self.bin_power[band.first_bin..])
                .map(|(w, p)| w * p)
                .sum();
            *p = e;
        }
        // In dB in a loop of its own, which runs in vector registers.
        for (o, p) in out.iter_mut().zip(&self.power) {
            *o = fast_db(p + 1e-12);
        }
        let loudest = out.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b));
        for o in out.iter_mut() {
            *o = o.max(loudest - BAND_RANGE_DB);
        }
        10.0 * ((power / samples.len() as f64) + 1e-12).log10() as f32
    }
}

/// 10 log10(x) for a positive normal `x`, to within 1e-4 dB: the exponent from the
/// float's bits, the natural log of the mantissa (scaled into [0.71, 1.41)) by the
/// series of 2 atanh((m - 1) / (m + 1)) to its fourth term (the next is under 1e-8).
/// The library's log is a call per value; this is arithmetic a loop over the bands
/// runs in vector registers (each frame's bands in [`Analyzer::frame`] and the onset
/// stage, and the fits of [`super::classify::share_explained_over_tail`]).
pub(super) fn fast_db(x: f32) -> f32 {
    const DB_PER_NEPER: f32 = 10.0 / std::f32::consts::LN_10;
    let bits = x.to_bits();
    let mantissa = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let over = mantissa > std::f32::consts::SQRT_2;
    let exponent = ((bits >> 23) & 0xff) as i32 - 127 + i32::from(over);
    let mantissa = if over { mantissa * 0.5 } else { mantissa };
    let s = (mantissa - 1.0) / (mantissa + 1.0);
    let s2 = s * s;
    let ln_mantissa = 2.0 * s * (1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0))));
    DB_PER_NEPER * (exponent as f32 * std::f32::consts::LN_2 + ln_mantissa)
}

/// The sum of the squares of `samples`, in f64, kept in four partial sums: one running
/// sum is a chain of dependent additions that the processor cannot overlap, and this
/// runs once or twice over every frame's window.
pub(super) fn sum_of_squares(samples: &[f32]) -> f64 {
    let mut sums = [0.0f64; 4];
    let mut quads = samples.chunks_exact(4);
    for q in &mut quads {
        for (s, &x) in sums.iter_mut().zip(q) {
            *s += f64::from(x) * f64::from(x);
        }
    }
    let rest: f64 = quads
        .remainder()
        .iter()
        .map(|&x| f64::from(x) * f64::from(x))
        .sum();
    (sums[0] + sums[1]) + (sums[2] + sums[3]) + rest
}

/// Pooled bands are floored this far below the loudest pooled band: the quiet bands'
/// fine shape, which varies from one hit to the next, counts no further down. Swept
/// from 30 to 60 dB over every dev set (`docs/classify.md`): 50 and 60 a plateau,
/// narrower ranges lose the real hits.
pub(super) const POOLED_RANGE_DB: f32 = 50.0;
/// Length of a feature vector: the cepstral coefficients of the pooled spectrum (the
/// first, its mean level, always 0).
pub(super) const FEATURES: usize = BANDS;
/// Cepstral coefficient k is weighted by k to this power before the comparison. At 0
/// the similarity is the Pearson correlation of the pooled dB spectra, which the broad
/// tilt of a spectrum (more bass or more hiss) dominates; a higher power weighs the
/// finer shape (where the resonances of the mouth lie), which tells look-alike hits
/// apart, up to a point: the mean F1 over every dev set peaks at 0.5 and falls on
/// either side (`docs/classify.md`). Scores are lower than plain correlations: hence
/// the method's threshold.
const LIFTER_POWER: f32 = 0.5;

/// The comparison's view of a pooled spectrum: the weighted cepstral coefficients of
/// its first `bands` mel bands, those the input carries (see [`present_bands`]). A
/// band above what the input can carry holds only the resampler's leakage, 60 dB or
/// more under the rest: every sound would share that cliff, look alike, and unlike a
/// full-band take or the background's speech (a 16 kHz input, or one band-limited to
/// 6.3 kHz: `docs/classify.md`, "An input that carries fewer bands").
pub(super) struct Cepstrum {
    /// `FEATURES` rows of `BANDS` (row 0, the mean level, and the rows from `bands` on
    /// are zero; columns from `bands` on are zero).
    basis: Vec<f32>,
    bands: usize,
}

impl Cepstrum {
    /// The DCT-II rows over the first `bands` bands (at least 2, at most `BANDS`).
    pub(super) fn new(bands: usize) -> Self {
        let mut cepstrum = Self {
            basis: vec![0.0f32; FEATURES * BANDS],
            bands: 0,
        };
        cepstrum.set_bands(bands);
        cepstrum
    }

    /// The rows over the first `bands` bands instead, made in place.
    pub(super) fn set_bands(&mut self, bands: usize) {
        let bands = bands.clamp(2, BANDS);
        self.basis.fill(0.0);
        for k in 1..bands {
            let weight = (k as f32).powf(LIFTER_POWER);
            for i in 0..bands {
                let angle = std::f64::consts::PI * k as f64 * (i as f64 + 0.5) / bands as f64;
                self.basis[k * BANDS + i] = weight * angle.cos() as f32;
            }
        }
        self.bands = bands;
    }

    /// Every band.
    pub(super) fn full() -> Self {
        Self::new(BANDS)
    }

    /// The bands compared.
    pub(super) fn bands(&self) -> usize {
        self.bands
    }

    /// The top of the highest band compared at the working `rate` (Hz) when fewer than
    /// every band are; `None` when every band is.
    pub(super) fn top_hz(&self, rate: f64) -> Option<f64> {
        (self.bands < BANDS).then(|| band_top_hz(rate, self.bands - 1))
    }

    /// [`Self::refeature_into`], into a new vector.
    #[cfg(test)]
    pub(super) fn refeature(&self, full: &[f32]) -> Vec<f32> {
        let mut out = vec![0.0f32; full.len()];
        self.refeature_into(full, &mut out);
        out
    }

    /// The features (unit norm) that `full`, feature vectors one after the other of
    /// spectra pooled over every band, become when only this cepstrum's bands are
    /// compared, into `out`, as long as `full`: each spectrum is recovered from them (up
    /// to its level and scale, which no feature keeps) and taken through this cepstrum.
    /// The same features when every band is compared. For models pooled over every band
    /// (the built-in background).
    pub(super) fn refeature_into(&self, full: &[f32], out: &mut [f32]) {
        if self.bands == BANDS {
            out.copy_from_slice(full);
            return;
        }
        // The inverse of the full DCT-II rows 1.. (orthogonal, each of squared norm
        // weight^2 BANDS / 2) gives the spectrum less its mean; through this cepstrum's
        // rows: one matrix, `FEATURES` by `FEATURES`, made once for every vector.
        let mut through = [0.0f32; FEATURES * FEATURES];
        for k in 1..FEATURES {
            let weight = (k as f32).powf(LIFTER_POWER);
            for i in 0..BANDS {
                let angle = std::f64::consts::PI * k as f64 * (i as f64 + 0.5) / BANDS as f64;
                let inverse = angle.cos() as f32 * 2.0 / (weight * BANDS as f32);
                for (t, row) in through
                    .chunks_exact_mut(FEATURES)
                    .zip(self.basis.chunks_exact(BANDS))
                {
                    t[k] += row[i] * inverse;
                }
            }
        }
        for (o, f) in out
            .chunks_exact_mut(FEATURES)
            .zip(full.chunks_exact(FEATURES))
        {
            for (x, t) in o.iter_mut().zip(through.chunks_exact(FEATURES)) {
                *x = t.iter().zip(f).map(|(a, b)| a * b).sum();
            }
            scale_to_unit(o);
        }
    }
}

/// How many of the mel bands at the working `rate` lie wholly under `content_top_hz`,
/// the highest frequency the input carries (at least 2).
pub(super) fn present_bands(rate: f64, content_top_hz: f64) -> usize {
    let edges = band_edges(rate);
    // A band is present when its top edge is; the rounding of the edges aside.
    (0..BANDS)
        .take_while(|&b| edges[b + 2] <= content_top_hz * (1.0 + 1e-9))
        .count()
        .max(2)
}

/// The share of a mean power spectrum (linear, as [`pool_power`] gives it) that lies
/// in its first `bands` bands; 1 for a silent one. An energy measured over every
/// frequency, times this, is the energy in the bands: a sound's strength compares an
/// instance and a take in the bands both carry, so that a take recorded at a full rate
/// is not louder than its instance by what the input cannot carry (a 16 kHz headset
/// carries 6.3 kHz).
pub(super) fn share_in_bands(power: &[f32], bands: usize) -> f64 {
    let all: f64 = power.iter().map(|&p| f64::from(p)).sum();
    let under: f64 = power[..bands.min(power.len())]
        .iter()
        .map(|&p| f64::from(p))
        .sum();
    if all > 0.0 {
        under / all
    } else {
        1.0
    }
}

/// The mean power spectrum (linear) of `k` consecutive frames (each `BANDS` dB values,
/// from `frame(i)`), into `out`: what [`features_of_power`] turns into features.
/// Averaging powers rather than dB lets the loud frames of the attack lead: on the
/// real recordings of `examples/eval_beatbox.rs` (with plain correlations, before
/// `LIFTER_POWER`) it raised the F1 of rec6 from 0.39 to 0.43 and of the repeated set
/// from 0.66 to 0.71 (isolated, rec3 unchanged). One spectrum over the whole window
/// scored best: finer time detail (2 or 3 sub-windows) follows the articulation of one
/// take too closely. Over every dev set too: the whole window's features and its later
/// half's, scored together, gave a mean F1 of 0.813 against 0.834 (the background model
/// made again with them), losing most on real hits (D1_isolated_agh 0.861 to 0.717).
pub(super) fn pool_power<'a>(k: usize, frame: impl Fn(usize) -> &'a [f32], out: &mut [f32]) {
    out.fill(0.0);
    for i in 0..k {
        for (d, x) in out.iter_mut().zip(frame(i)) {
            *d += 10f32.powf(x / 10.0);
        }
    }
    for d in out.iter_mut() {
        *d /= k.max(1) as f32;
    }
}

/// The features of a pooled power spectrum (from [`pool_power`]): in dB, floored
/// `POOLED_RANGE_DB` under its loudest band, turned into weighted cepstral coefficients
/// of unit norm over the bands `cepstrum` compares, into `out`.
pub(super) fn features_of_power(power: &[f32], cepstrum: &Cepstrum, out: &mut [f32]) {
    let bands = cepstrum.bands;
    let mut pooled = [0.0f32; BANDS];
    for (d, p) in pooled.iter_mut().zip(power).take(bands) {
        *d = 10.0 * (p + 1e-12).log10();
    }
    let loudest = pooled[..bands]
        .iter()
        .cloned()
        .fold(f32::NEG_INFINITY, f32::max);
    for x in pooled[..bands].iter_mut() {
        *x = x.max(loudest - POOLED_RANGE_DB);
    }
    for (c, row) in out.iter_mut().zip(cepstrum.basis.chunks_exact(BANDS)) {
        *c = row.iter().zip(&pooled).map(|(w, x)| w * x).sum();
    }
    scale_to_unit(out);
}

/// Scales `v` to unit norm (in place); a zero vector stays zero.
pub(super) fn scale_to_unit(v: &mut [f32]) {
    let norm = v.iter().map(|x| x * x).sum::<f32>().sqrt();
    for x in v.iter_mut() {
        *x = if norm > 1e-9 { *x / norm } else { 0.0 };
    }
}

/// Similarity of two unit-norm feature vectors (the cosine of their angle).
pub(super) fn similarity(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Centres `v` and scales it to unit norm (in place); a flat vector becomes zeros.
pub(super) fn normalise(v: &mut [f32]) {
    let mean = v.iter().sum::<f32>() / v.len().max(1) as f32;
    v.iter_mut().for_each(|x| *x -= mean);
    scale_to_unit(v);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_db_is_the_librarys_to_a_ten_thousandth_of_a_db() {
        let mut x = 1e-13f32;
        while x < 1e6 {
            let exact = 10.0 * f64::from(x).log10();
            assert!(
                (f64::from(fast_db(x)) - exact).abs() < 1e-4,
                "{x}: {}",
                fast_db(x)
            );
            x *= 1.37;
        }
    }

    /// Gain in dB of the filter `run` (a fresh one, one sample at a time) on a steady
    /// sine of `hz` at `rate`, after a second to settle.
    fn steady_gain_db(rate: f64, hz: f64, mut run: impl FnMut(f32) -> f32) -> f64 {
        let (mut input, mut output) = (0.0f64, 0.0f64);
        for n in 0..(2.0 * rate) as usize {
            let x = (2.0 * std::f64::consts::PI * hz * n as f64 / rate).sin() as f32;
            let y = run(x);
            if n as f64 >= rate {
                input += f64::from(x).powi(2);
                output += f64::from(y).powi(2);
            }
        }
        10.0 * (output / input).log10()
    }

    #[test]
    fn the_low_cut_removes_rumble_under_the_bands_and_passes_what_they_hear() {
        let rate = 22_050.0;
        let gain_db = |hz: f64| {
            let mut low_cut = LowCut::new(rate);
            steady_gain_db(rate, hz, |x| low_cut.run(x))
        };
        // A 4th-order Butterworth high-pass: -3 dB at its cutoff, 24 dB per octave under
        // it, the bands' lowest frequency passed within 0.4 dB.
        assert!(
            (gain_db(LOW_CUT_HZ) + 3.0).abs() < 0.3,
            "{}",
            gain_db(LOW_CUT_HZ)
        );
        assert!(gain_db(LOW_HZ) > -0.45, "{}", gain_db(LOW_HZ));
        assert!(gain_db(15.0) < -45.0, "{}", gain_db(15.0));
        assert!(gain_db(1000.0).abs() < 0.1, "{}", gain_db(1000.0));
        // A DC offset goes.
        let mut low_cut = LowCut::new(rate);
        let last = (0..rate as usize).fold(0.0, |_, _| low_cut.run(0.5));
        assert!(last.abs() < 1e-4, "{last}");
    }

    #[test]
    fn the_dc_blocker_takes_an_offset_away_and_leaves_what_the_bands_hear() {
        let rate = 22_050.0;
        let gain_db = |hz: f64| {
            let mut dc = DcBlock::new(rate);
            steady_gain_db(rate, hz, |x| dc.run(x))
        };
        // One pole: -3 dB at its cutoff, the bands' lowest frequency within 0.02 dB.
        assert!(
            (gain_db(DC_BLOCK_HZ) + 3.0).abs() < 0.1,
            "{}",
            gain_db(DC_BLOCK_HZ)
        );
        assert!(gain_db(LOW_HZ) > -0.02, "{}", gain_db(LOW_HZ));
        // An offset is gone within a fifth of a second, and silence stays silence.
        let mut dc = DcBlock::new(rate);
        let settled = (0..(0.2 * rate) as usize).fold(0.0, |_, _| dc.run(0.05));
        assert!(settled.abs() < 0.05 * 0.01, "{settled}");
        let mut dc = DcBlock::new(rate);
        assert!((0..1000).all(|_| dc.run(0.0) == 0.0));
    }

    /// The features of `k` frames.
    fn pool_features<'a>(
        k: usize,
        frame: impl Fn(usize) -> &'a [f32],
        cepstrum: &Cepstrum,
        out: &mut [f32],
    ) {
        let mut pooled = [0.0f32; BANDS];
        pool_power(k, frame, &mut pooled);
        features_of_power(&pooled, cepstrum, out);
    }

    const RATE: f64 = 22_050.0;

    fn sine(hz: f64, amplitude: f32, n: usize) -> Vec<f32> {
        (0..n)
            .map(|i| amplitude * (2.0 * std::f64::consts::PI * hz * i as f64 / RATE).sin() as f32)
            .collect()
    }

    /// The band whose centre lies nearest `hz` (the mel bank's own edges).
    fn band_of(hz: f64) -> usize {
        let mel = |hz: f64| 2595.0 * (1.0 + hz / 700.0).log10();
        let (m0, m1) = (mel(LOW_HZ), mel(top_hz(RATE)));
        let position = (mel(hz) - m0) / (m1 - m0) * (BANDS + 1) as f64 - 1.0;
        position.round() as usize
    }

    #[test]
    fn a_tone_is_loudest_in_its_band_and_its_level_is_its_power() {
        let mut analyzer = Analyzer::new(RATE);
        let mut frame = vec![0.0f32; BANDS];
        for hz in [300.0, 1000.0, 4000.0] {
            let x = sine(hz, 0.5, analyzer.win);
            let level = analyzer.frame(&x, &mut frame);
            let loudest = (0..BANDS)
                .max_by(|&a, &b| frame[a].total_cmp(&frame[b]))
                .unwrap();
            assert!(
                loudest.abs_diff(band_of(hz)) <= 1,
                "{hz} Hz: band {loudest}"
            );
            // A sine of amplitude 0.5 has a mean power of 0.125: -9.0 dB.
            assert!((level - (-9.03)).abs() < 0.2, "{hz} Hz: {level} dB");
            // Floored 60 dB below the loudest band.
            assert!(frame
                .iter()
                .all(|&b| b >= frame[loudest] - BAND_RANGE_DB - 1e-3));
        }
    }

    #[test]
    fn features_have_unit_norm_and_ignore_the_level() {
        let mut analyzer = Analyzer::new(RATE);
        let x: Vec<f32> = sine(500.0, 0.3, 4096)
            .iter()
            .zip(sine(2500.0, 0.1, 4096))
            .map(|(a, b)| a + b)
            .collect();
        let features_of = |analyzer: &mut Analyzer, gain: f32| {
            let (win, hop) = (analyzer.win, analyzer.hop);
            let frames: Vec<Vec<f32>> = (0..6)
                .map(|k| {
                    let mut f = vec![0.0f32; BANDS];
                    let w: Vec<f32> = x[k * hop..k * hop + win].iter().map(|v| v * gain).collect();
                    analyzer.frame(&w, &mut f);
                    f
                })
                .collect();
            let mut out = vec![0.0f32; FEATURES];
            pool_features(6, |k| &frames[k], &analyzer.cepstrum, &mut out);
            out
        };
        let loud = features_of(&mut analyzer, 1.0);
        let quiet = features_of(&mut analyzer, 0.01);
        let norm: f32 = loud.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!((norm - 1.0).abs() < 1e-4, "{norm}");
        assert!(similarity(&loud, &loud) > 0.9999);
        // 40 dB down, the same sound: the mean level is not a feature.
        assert!(
            similarity(&loud, &quiet) > 0.999,
            "{}",
            similarity(&loud, &quiet)
        );
    }

    #[test]
    fn the_bands_compared_are_those_wholly_under_what_the_input_carries() {
        // At the working rate itself every band is carried.
        assert_eq!(present_bands(RATE, top_hz(RATE)), BANDS);
        assert_eq!(present_bands(RATE, top_hz(48_000.0)), BANDS);
        // A 16 kHz input carries up to 6.3 kHz, an 8 kHz one up to 3.2 kHz.
        for (input_rate, top) in [(16_000.0, 6_310.0), (8_000.0, 3_155.0)] {
            let bands = present_bands(RATE, top_hz(input_rate));
            assert!((top_hz(input_rate) - top).abs() < 10.0);
            let edges = band_edges(RATE);
            assert!(
                edges[bands + 1] <= top && edges[bands + 2] > top,
                "{input_rate}: {bands}"
            );
        }
        assert_eq!(present_bands(RATE, 0.0), 2);
    }

    #[test]
    fn features_over_every_band_give_those_over_fewer_bands() {
        // A pooled spectrum with a shape over every band (its loudest within the first
        // bands, nothing under the floor), its features over every band taken through
        // the narrower cepstrum, equal the features of its first bands.
        let power: Vec<f32> = (0..BANDS)
            .map(|b| 10f32.powf((-0.8 * b as f32 + 6.0 * (b as f32 * 0.7).sin()) / 10.0))
            .collect();
        let full = Cepstrum::full();
        let mut every = vec![0.0f32; FEATURES];
        features_of_power(&power, &full, &mut every);
        assert_eq!(full.refeature(&every), every);
        for bands in [28, 20, 5] {
            let narrow = Cepstrum::new(bands);
            let mut direct = vec![0.0f32; FEATURES];
            features_of_power(&power, &narrow, &mut direct);
            let refeatured = narrow.refeature(&every);
            assert!(
                similarity(&direct, &refeatured) > 0.9999,
                "{bands} bands: {direct:?} against {refeatured:?}"
            );
            // What lies above the compared bands makes no difference.
            let mut other = power.clone();
            other[bands..].iter_mut().for_each(|p| *p *= 1e-4);
            let mut without_top = vec![0.0f32; FEATURES];
            features_of_power(&other, &narrow, &mut without_top);
            assert_eq!(without_top, direct);
        }
    }

    #[test]
    fn other_sounds_score_lower_than_the_same_sound() {
        let mut analyzer = Analyzer::new(RATE);
        let pooled = |analyzer: &mut Analyzer, hz: f64| {
            let x = sine(hz, 0.5, analyzer.win);
            let mut f = vec![0.0f32; BANDS];
            analyzer.frame(&x, &mut f);
            let mut out = vec![0.0f32; FEATURES];
            pool_features(1, |_| &f, &analyzer.cepstrum, &mut out);
            out
        };
        let low = pooled(&mut analyzer, 400.0);
        let low_again = pooled(&mut analyzer, 410.0);
        let high = pooled(&mut analyzer, 3000.0);
        assert!(similarity(&low, &low_again) > similarity(&low, &high) + 0.3);
    }

    #[test]
    fn the_share_in_the_lower_bands_of_a_tone_is_all_under_it_and_none_over_it() {
        let mut analyzer = Analyzer::new(RATE);
        let x = sine(1000.0, 0.5, analyzer.win);
        let mut frame = vec![0.0f32; BANDS];
        analyzer.frame(&x, &mut frame);
        let mut power = vec![0.0f32; BANDS];
        pool_power(1, |_| &frame, &mut power);
        // The bands that lie wholly under 1 kHz hold none of it but the window's
        // leakage (its sidelobes, 31 dB down and falling); those up to 1.5 kHz all of it.
        assert!(share_in_bands(&power, present_bands(RATE, 700.0)) < 1e-2);
        assert!(share_in_bands(&power, present_bands(RATE, 1500.0)) > 0.99);
        assert_eq!(share_in_bands(&power, BANDS), 1.0);
        assert_eq!(share_in_bands(&[0.0; BANDS], 4), 1.0);
    }

    #[test]
    fn normalise_centres_and_scales_and_a_flat_vector_becomes_zeros() {
        let mut v = vec![1.0f32, 2.0, 3.0, 4.0];
        normalise(&mut v);
        assert!(v.iter().sum::<f32>().abs() < 1e-6);
        assert!((v.iter().map(|x| x * x).sum::<f32>() - 1.0).abs() < 1e-6);
        let mut flat = vec![2.0f32; 4];
        normalise(&mut flat);
        assert!(flat.iter().all(|&x| x == 0.0));
    }
}
