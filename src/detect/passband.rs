//! Passband stage: how far up in frequency a sound carries, from the loudest power
//! each mel band has had. A converter's anti-aliasing filter or a resampler leaves a
//! cliff there that no sound makes: a band-limited source (a 16 kHz headset resampled
//! to 48 kHz by a sound server, a file converted from a narrow one) says nothing of its
//! band by its rate, but its loudest frames fall off the filter's edge. Enrolment feeds
//! it the takes' frames ([`super::enrol::takes_carry_under_hz`]); the spectral matcher
//! feeds it every frame of the stream, so that it compares only the bands the stream
//! carries too.
//!
//! Runs on the detector thread (and where a detector is built); allocates only in `new`.

use super::features::{band_centres, band_top_hz, BANDS};

/// A fall of this much (dB) over [`CLIFF_BANDS`] bands of the loudest frames is a
/// filter's edge, not a sound's: three of the top mel bands span about a third of an
/// octave, and 20 dB over it is over 50 dB an octave, steeper than a voice, a knock or
/// a microphone's own roll-off, but what a converter's anti-aliasing filter or a
/// resampler does. Over the takes of every dev set, unheard voice and room the steepest
/// fall above `CLIFF_LOWEST_HZ` is 16 dB (synthetic words, knocks); low-passed at
/// 6.3 kHz, 25 to 77 dB (`docs/classify.md`, "An input that carries fewer bands").
const CLIFF_DB: f32 = 20.0;
const CLIFF_BANDS: usize = 3;
/// Falls under this are the sound's own: a "boom" may have nothing over a few hundred
/// hertz. It is where an 8 kHz input's band ends, the narrowest one compared.
const CLIFF_LOWEST_HZ: f64 = 3_000.0;

/// Each band's loudest power (linear) over the frames pushed, and where its first
/// cliff lies.
pub(super) struct Passband {
    loudest: [f32; BANDS],
    /// The first band whose centre is at least `CLIFF_LOWEST_HZ`.
    first_band: usize,
    /// Each band's top edge (Hz).
    band_top: [f64; BANDS],
    /// Bit `b`: the noise confirmed a cliff of the loudest frames ending at band `b`.
    confirmed: u32,
    /// The band that ends the stream's edge ([`Self::top_hz_over_noise`]).
    stream_edge: Option<usize>,
}

impl Passband {
    /// For frames of the mel bands at the working `rate`.
    pub(super) fn new(rate: f64) -> Self {
        let centres = band_centres(rate);
        let first_band = (CLIFF_BANDS..BANDS)
            .find(|&b| centres[b] >= CLIFF_LOWEST_HZ)
            .unwrap_or(BANDS);
        Self {
            loudest: [0.0; BANDS],
            first_band,
            band_top: std::array::from_fn(|b| band_top_hz(rate, b)),
            confirmed: 0,
            stream_edge: None,
        }
    }

    /// One frame's band powers (linear, [`super::features::Analyzer::power`]).
    pub(super) fn push(&mut self, power: &[f32]) {
        for (l, &p) in self.loudest.iter_mut().zip(power) {
            // A power that is not a number leaves the band as it was.
            if p > *l {
                *l = p;
            }
        }
    }

    /// The highest frequency (Hz) carried: the top edge of the band where the first
    /// cliff of the loudest frames begins (the bands on the cliff are the filter's
    /// transition); infinite when there is none.
    pub(super) fn top_hz(&self) -> f64 {
        self.top_under(self.edge(|_| true))
    }

    /// The same, of a stream whose bands' noise floors are `floors` (linear) and whose
    /// room's noise stands up to `room_over_floor` times its floors: the first cliff
    /// that the noise shows too. In its first seconds a stream's loudest frames hold
    /// few sounds, and a dip between them is a cliff until other sounds fill it (the
    /// first second of a sentence of vowels falls 20 dB at 4 kHz, a table's first
    /// knocks at 2.6 kHz); but the room's noise goes on under the dip, and over the dip
    /// there is still sound. Over a filter's edge, the noise that passed the filter
    /// falls off it too (its floors fall as far, within as many bands again), or, where
    /// noise was added after the filter (a converter's own, dither), no band's loudest
    /// frame ever rose out of it. A cliff confirmed so stays confirmed while the loudest
    /// frames keep it: the floors wander from frame to frame, a filter does not. Nor
    /// does its transition: as louder sounds come, the band where the loudest frames
    /// have fallen 20 dB moves a band down or up; a band once found beyond the edge stays
    /// beyond while the edge found next lies within the cliff's width of it.
    pub(super) fn top_hz_over_noise(&mut self, floors: &[f32], room_over_floor: f32) -> f64 {
        let (loudest, mut confirmed) = (self.loudest, self.confirmed);
        let edge = self.edge(|b| {
            let noise_falls = || {
                let quietest_after = floors[b..(b + CLIFF_BANDS).min(BANDS)]
                    .iter()
                    .copied()
                    .fold(f32::INFINITY, f32::min);
                below_by_cliff(quietest_after, floors[b - CLIFF_BANDS])
            };
            let only_noise = || (b..BANDS).all(|c| loudest[c] <= floors[c] * room_over_floor);
            if confirmed & (1 << b) == 0 && (noise_falls() || only_noise()) {
                confirmed |= 1 << b;
            }
            confirmed & (1 << b) != 0
        });
        self.confirmed = confirmed;
        self.stream_edge = match (self.stream_edge, edge) {
            (Some(was), Some(now)) if now > was && now - was <= CLIFF_BANDS => Some(was),
            _ => edge,
        };
        self.top_under(self.stream_edge)
    }

    /// The first band (from `first_band`) that ends a cliff of the loudest frames and
    /// satisfies `also`.
    fn edge(&self, mut also: impl FnMut(usize) -> bool) -> Option<usize> {
        (self.first_band..BANDS).find(|&b| falls(&self.loudest, b) && also(b))
    }

    /// The highest frequency carried under the cliff ending at band `edge`.
    fn top_under(&self, edge: Option<usize>) -> f64 {
        edge.map_or(f64::INFINITY, |b| self.band_top[b - CLIFF_BANDS])
    }
}

/// Whether `power` (linear, per band) falls by `CLIFF_DB` from band `b - CLIFF_BANDS`
/// to band `b`.
fn falls(power: &[f32], b: usize) -> bool {
    below_by_cliff(power[b], power[b - CLIFF_BANDS])
}

/// Whether power `low` lies `CLIFF_DB` under power `high` (linear).
fn below_by_cliff(low: f32, high: f32) -> bool {
    // 1e-20: bands that never held anything (-200 dB) are alike.
    low + 1e-20 < (high + 1e-20) * 10f32.powf(-CLIFF_DB / 10.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::features::Analyzer;

    const RATE: f64 = 22_050.0;

    /// White noise, and the same low-passed by a steep filter at `cut_hz` (an FFT's
    /// bins over it zeroed), through the analyzer's frames.
    fn loudest_top_hz(cut_hz: Option<f64>) -> f64 {
        let mut analyzer = Analyzer::new(RATE);
        let mut passband = Passband::new(RATE);
        let mut seed = 12345u32;
        let mut noise = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
        };
        let n = 8192;
        let mut x: Vec<f32> = (0..n).map(|_| noise()).collect();
        if let Some(cut) = cut_hz {
            let mut planner = realfft::RealFftPlanner::<f32>::new();
            let fft = planner.plan_fft_forward(n);
            let ifft = planner.plan_fft_inverse(n);
            let mut spectrum = fft.make_output_vec();
            fft.process(&mut x, &mut spectrum).unwrap();
            for (k, s) in spectrum.iter_mut().enumerate() {
                if k as f64 * RATE / n as f64 > cut {
                    *s = realfft::num_complex::Complex32::new(0.0, 0.0);
                }
            }
            ifft.process(&mut spectrum, &mut x).unwrap();
            x.iter_mut().for_each(|v| *v /= n as f32);
        }
        let mut frame = vec![0.0f32; BANDS];
        let mut start = 0;
        while start + analyzer.win <= x.len() {
            analyzer.frame(&x[start..start + analyzer.win], &mut frame);
            passband.push(&analyzer.power);
            start += analyzer.hop;
        }
        passband.top_hz()
    }

    #[test]
    fn a_full_band_sound_has_no_edge() {
        assert_eq!(loudest_top_hz(None), f64::INFINITY);
    }

    #[test]
    fn a_low_passed_sound_carries_up_to_its_filter_edge() {
        for cut in [4_000.0, 6_300.0] {
            let top = loudest_top_hz(Some(cut));
            assert!(
                top <= cut && top > cut * 0.75,
                "low-passed at {cut} Hz: carries up to {top} Hz"
            );
        }
    }

    #[test]
    fn nothing_pushed_or_silence_has_no_edge() {
        let mut passband = Passband::new(RATE);
        assert_eq!(passband.top_hz(), f64::INFINITY);
        passband.push(&[0.0; BANDS]);
        assert_eq!(passband.top_hz(), f64::INFINITY);
    }
}
