//! Onset stage: where a new sound starts, found causally one frame after the peak of
//! an onset function over band powers. Owns the per-band noise floors and the recent
//! onset function; knows nothing of patterns, so no later decision can feed back on it.
//!
//! The onset function is a spectral flux on a noise-floored log spectrum (after Böck
//! and Widmer's SuperFlux, with the per-band floor of Stowell and Plumbley's adaptive
//! whitening). Each band's power gets `floor_weight` times its own noise floor added
//! before the log, so a band at the room's noise level barely moves while a band that
//! rises out of it moves by its signal-to-noise ratio; the rise is taken over the
//! same band one window earlier (SuperFlux's maximum over neighbouring bins spans a
//! quarter-tone on its fine filterbank, but several semitones to an octave on these 32
//! mel bands, where it hides a hiss that rises in its own bands only); the function is
//! the mean rise over bands, each weighed by how little its noise wanders
//! ([`band_weights`]), in dB. An onset is a local maximum of it that stands
//! `threshold_db` over its mean of the last `mean_seconds`, at least `min_gap_seconds`
//! after the previous one, once the previous sound has fallen back (`rearm_fall`) or
//! when it is a new sound: far louder than the previous one (`new_sound_db`) or rising
//! far more steeply (`new_sound_rise_ratio`).
//!
//! After digital silence the floors catch up with the room as fast as they fall
//! (`docs/rooms.md`, "Digital silence"). A stream's first frames are heard in the room
//! that follows them ([`OnsetDetector::prime`]; `docs/rooms.md`, "A stream that begins
//! with a sound").
//!
//! Because the function is a log ratio, its statistics on steady noise do not depend on
//! the noise's level or colour: `floor_weight` and `threshold_db` are the pair that
//! gives no false onset in a minute of steady white or red noise at any level, and a
//! quiet room and a loud one behave alike. The sweeps are in `docs/onset-stage.md`.
//!
//! Runs on the detector thread, inside the spectral matcher; allocates only in `new`.

/// Settings of the onset stage.
#[derive(Debug, Clone, Copy)]
pub struct OnsetParams {
    /// Each band's noise floor, times this, is added to its power before the log.
    pub floor_weight: f32,
    /// Margin of the onset function over its recent mean, dB of mean band rise.
    pub threshold_db: f32,
    /// The recent mean is taken over this long.
    pub mean_seconds: f64,
    /// Two onsets are at least this far apart: about the shortest gap at which the
    /// order of two sounds can be told (Hirsh, 1959).
    pub min_gap_seconds: f64,
    /// A band's noise floor rises at most this fast, dB per second: a room's noise
    /// changes over seconds, a sound's tail falls faster, and a burst of any loudness
    /// cannot lift it...
    pub floor_rise_db_per_s: f32,
    /// ...and falls at most this fast: a few dB over a dropout of 10 ms of silence
    /// (or of samples that were not numbers), which must not leave the floor far under
    /// the room for seconds afterwards.
    pub floor_fall_db_per_s: f32,
    /// After an onset that rose by `v` dB (mean band rise), the next needs the sound to
    /// have fallen back, as a mean over bands from each band's peak since, by this
    /// fraction of `v`, or by `rearm_fall_max_db` (a sound at a hundredth of its peak
    /// power has ended, however loud it rose in a quiet room), or to be back within
    /// `threshold_db` of the room's noise...
    pub rearm_fall: f32,
    pub rearm_fall_max_db: f32,
    /// ...or this long to have passed: no longer than the notes of a quick rhythm
    /// (eighths at 200 bpm, 0.15 s), whose strikes on a surface that rings, or words
    /// over the last one's vowel, come before the last has fallen back. Until then, an
    /// onset is only a new sound if it rises `new_sound_db` (mean over bands) over the
    /// loudest that each band has been since the last sound began. From 0.15 to 0.25 s
    /// the development sets score alike, and under 0.15 s more speech passes
    /// (`docs/onset-stage.md`, "How long an onset that has not faded holds the stage,
    /// again").
    pub rearm_after_seconds: f64,
    pub new_sound_db: f32,
    /// ...or its onset function is this many times the last onset's: a knock 15 ms
    /// after the faint click of a finger landing, whose sound has not fallen back yet
    /// (2-5 score alike on the development sets: `docs/onset-stage.md`).
    pub new_sound_rise_ratio: f32,
    /// A second onset function takes each band's rise over this many windows: a sound
    /// that swells (a hiss in loud noise) rises too little within one window to stand
    /// out, but by as much as an attack over a few. Its peaks are picked as the first
    /// function's, and only where that one found nothing within this span, so it adds
    /// onsets and never delays one (0: off; `docs/onset-stage.md`, "Slow rises").
    pub slow_rise_windows: usize,
    /// A stream's first frames are read this long at most to learn whether it begins
    /// with a sound ([`OnsetDetector::prime`]): a word or a hit the stream opens on,
    /// and the room after it (`docs/rooms.md`, "A stream that begins with a sound":
    /// 0.25 s did not see a word end).
    pub stream_start_read_seconds: f64,
}

impl Default for OnsetParams {
    fn default() -> Self {
        Self {
            floor_weight: 8.0,
            threshold_db: 1.0,
            mean_seconds: 0.1,
            min_gap_seconds: 0.02,
            floor_rise_db_per_s: 3.0,
            floor_fall_db_per_s: 100.0,
            rearm_fall: 1.0,
            rearm_fall_max_db: 20.0,
            new_sound_db: 15.0,
            rearm_after_seconds: 0.15,
            new_sound_rise_ratio: 4.0,
            slow_rise_windows: 3,
            stream_start_read_seconds: 0.5,
        }
    }
}

/// Band power below which a band is taken to hold nothing (-100 dB: below the noise
/// of 16-bit audio).
const MIN_BAND_POWER: f32 = 1e-10;

/// How far under a frame's loudest band a band can hold anything, dB: 16-bit audio
/// spans 96 dB. Under about 120 dB a band holds the rounding of the f32 analysis
/// (resampling, window, transform) of what is in the loudest one, which wanders with
/// the phase of a pure tone and, where no input noise covers it (a tone synthesised at
/// a float sample format), rises by more than the onset threshold a few times a second.
const ANALYSIS_RANGE_DB: f32 = 100.0;

/// The least power a band of a frame whose loudest band holds `loudest` is taken to
/// hold: `MIN_BAND_POWER`, or `ANALYSIS_RANGE_DB` under the loudest.
fn least_band_power(loudest: f32) -> f32 {
    MIN_BAND_POWER.max(loudest * 10f32.powf(-ANALYSIS_RANGE_DB / 10.0))
}

/// A band's power as the onset stage takes it: at least [`least_band_power`] of its
/// frame's loudest band (`least`); a value that is not a number holds nothing.
fn band_power(p: f32, least: f32) -> f32 {
    if p.is_finite() {
        p.max(least)
    } else {
        MIN_BAND_POWER
    }
}

/// The loudest finite band power of a frame.
fn loudest_band(power: &[f32]) -> f32 {
    power
        .iter()
        .filter(|p| p.is_finite())
        .fold(0.0f32, |m, &p| m.max(p))
}

/// Whether a frame's band powers hold any sound at all. A frame that holds none is
/// digital silence (samples that are all zero, or were not numbers, made zero): no
/// room is that quiet.
pub(super) fn holds_sound(power: &[f32]) -> bool {
    power.iter().any(|&p| p > MIN_BAND_POWER)
}

/// Each band's weight in the onset function: the square root of the number of
/// spectral values it sums (`band_bins`, the effective count of its filter's bins),
/// over the mean of those roots. On steady noise a band's log level wanders by about
/// 4.3 dB over the root of that count (the log of a mean of that many exponential
/// powers), so a narrow low band that covers one bin wanders several times as far as a
/// wide high one. Weighed so, every band's rise counts in units of its own noise's
/// spread, and a hiss that lifts only the wide high bands is not averaged away by the
/// wandering of the narrow low ones.
pub fn band_weights(band_bins: &[f32]) -> Vec<f32> {
    let roots: Vec<f32> = band_bins.iter().map(|&n| n.max(1.0).sqrt()).collect();
    let mean = roots.iter().sum::<f32>() / roots.len().max(1) as f32;
    roots.iter().map(|r| r / mean).collect()
}

/// An onset found by [`OnsetDetector::push`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Onset {
    /// Frame at which the onset function peaked.
    pub frame: u64,
    /// The onset function there, dB of mean band rise.
    pub flux_db: f32,
}

/// Causal onset detector over band powers, one frame at a time.
pub struct OnsetDetector {
    params: OnsetParams,
    bands: usize,
    /// Frames between the compared frames: one window, so that an attack's whole rise
    /// lies in one difference.
    lag: usize,
    mean_frames: usize,
    min_gap_frames: u64,
    /// Per band: the weight of its rise in the onset function (see [`band_weights`]).
    weight: Vec<f32>,
    floor_rise: f32,
    floor_fall: f32,
    /// Per band: the noise floor (linear power).
    floor: Vec<f32>,
    /// How far a band at its noise floor stands over the floor's own log, dB.
    room_over_floor_db: f32,
    /// Ring of floored log spectra, two frames more than the longer lag, of `bands`.
    history: Vec<f32>,
    /// Ring of onset-function values, `mean_frames + 2`.
    odf: Vec<f32>,
    /// Frames between the compared frames of the slow-rise function (`lag` times
    /// `slow_rise_windows`; 0 when off), and its values, as `odf`.
    slow_lag: usize,
    slow_odf: Vec<f32>,
    frames: u64,
    last_onset: Option<u64>,
    rearm_after_frames: u64,
    /// Per band: the loudest floored log level since the last onset.
    peak: Vec<f32>,
    /// The onset function at the last onset (where the current sound began); `None`
    /// once its sound has faded.
    unarmed_rise: Option<f32>,
    /// Per band: the floor lies under the sound after digital silence, and rises to it
    /// as fast as a floor falls, until a frame meets it.
    catching_up: Vec<bool>,
    /// The last frame was digital silence.
    after_silence: bool,
    /// Per band: its floored log level before the stream, once [`Self::prime`] has
    /// read the stream's first frames.
    before_stream: Vec<f32>,
    primed: bool,
    read_ahead_frames: usize,
}

impl OnsetDetector {
    /// For frames of `bands` band powers, `win` samples long every `hop` samples, at
    /// `rate` Hz.
    pub fn new(params: OnsetParams, band_bins: &[f32], win: usize, hop: usize, rate: f64) -> Self {
        let bands = band_bins.len();
        let hop_seconds = hop as f64 / rate;
        let lag = win.div_ceil(hop).max(1);
        let mean_frames = ((params.mean_seconds / hop_seconds) as usize).max(1);
        let slow_lag = lag * params.slow_rise_windows;
        Self {
            bands,
            lag,
            mean_frames,
            min_gap_frames: (params.min_gap_seconds / hop_seconds) as u64,
            weight: band_weights(band_bins),
            floor_rise: 10f32.powf(params.floor_rise_db_per_s * hop_seconds as f32 / 10.0),
            floor_fall: 10f32.powf(-params.floor_fall_db_per_s * hop_seconds as f32 / 10.0),
            floor: vec![0.0; bands],
            room_over_floor_db: 10.0 * (1.0 + params.floor_weight).log10(),
            history: vec![0.0; (lag.max(slow_lag) + 2) * bands],
            odf: vec![0.0; mean_frames + 2],
            slow_lag,
            slow_odf: vec![0.0; mean_frames + 2],
            frames: 0,
            last_onset: None,
            rearm_after_frames: (params.rearm_after_seconds / hop_seconds) as u64,
            peak: vec![0.0; bands],
            unarmed_rise: None,
            catching_up: vec![false; bands],
            after_silence: false,
            before_stream: vec![0.0; bands],
            primed: false,
            read_ahead_frames: Self::read_ahead_frames_at(&params, hop, rate),
            params,
        }
    }

    /// How many frames a stream's start is read ahead for [`Self::prime`].
    fn read_ahead_frames_at(params: &OnsetParams, hop: usize, rate: f64) -> usize {
        (params.stream_start_read_seconds * rate / hop as f64).ceil() as usize
    }

    /// How many frames [`Self::prime`] reads.
    pub fn read_ahead_frames(&self) -> usize {
        self.read_ahead_frames
    }

    /// Frames after an onset during which a sound that has not fallen back gives no
    /// other onset as loud (`rearm_after_seconds`).
    pub fn hold_frames(&self) -> u64 {
        self.rearm_after_frames
    }

    /// Sets the floors from the first frames of a stream that begins with a sound
    /// (`powers`: their band powers, `bands` values a frame, in time order; at most
    /// [`Self::read_ahead_frames`]), before the first is pushed. A floor that starts from
    /// the first frame takes the sound for the room, and the sound never rises out of
    /// it. Read from the last frame back to the first, by the rule that makes a floor
    /// follow the room forwards, the floors reach the stream's start at the room that
    /// follows the sound; before the stream each band was at its floor, and the onset
    /// function 0 (`docs/rooms.md`, "A stream that begins with a sound").
    pub fn prime(&mut self, powers: &[f32]) {
        let bands = self.bands;
        let frames = (powers.len() / bands.max(1)).min(self.read_ahead_frames);
        if frames == 0 {
            return;
        }
        for f in (0..frames).rev() {
            let frame = &powers[f * bands..(f + 1) * bands];
            let least = least_band_power(loudest_band(frame));
            for (fl, &p) in self.floor.iter_mut().zip(frame) {
                let p = band_power(p, least);
                *fl = if f == frames - 1 {
                    p
                } else {
                    (*fl * self.floor_rise).min(p.max(*fl * self.floor_fall))
                };
            }
        }
        for (before, &fl) in self.before_stream.iter_mut().zip(&self.floor) {
            *before = 10.0 * ((1.0 + self.params.floor_weight) * fl).log10();
        }
        self.primed = true;
    }

    /// Per band: the noise floor (linear power, as the frames fed).
    pub fn band_floors(&self) -> &[f32] {
        &self.floor
    }

    /// How far the room's noise stands over a band's floor (a power ratio): the weight
    /// that makes a band at the room's level barely move the onset function.
    pub fn room_over_floor(&self) -> f32 {
        1.0 + self.params.floor_weight
    }

    /// Feeds the next frame's band powers (linear); returns the onset whose peak was
    /// the frame before, if there is one.
    pub fn push(&mut self, power: &[f32]) -> Option<Onset> {
        let f = self.frames;
        self.frames += 1;
        let (bands, lag) = (self.bands, self.lag as u64);
        let slots = (self.history.len() / bands.max(1)) as u64;
        let row = |g: u64| ((g % slots) as usize) * bands;
        let now = row(f);
        // Over digital silence the floors fall as over any quieter frame (a gated
        // input's room is that silence). After it, a floor under the first frame with
        // sound starts from that frame (its window holds some of the silence still),
        // and rises on to the sound as fast as it would fall, until the first frame at
        // or under it: a room that begins (or comes back) after digital silence is
        // reached within a fraction of a second instead of at the slow rise's pace,
        // while a sound that begins there still rises out of the silence.
        let sound = holds_sound(&power[..bands.min(power.len())]);
        let resumed = std::mem::replace(&mut self.after_silence, !sound) && sound;
        let catch_up = 1.0 / self.floor_fall;
        let least = least_band_power(loudest_band(&power[..bands.min(power.len())]));
        for (b, &p) in power.iter().enumerate().take(bands) {
            let p = band_power(p, least);
            let fl = &mut self.floor[b];
            let catching = &mut self.catching_up[b];
            if f == 0 && !self.primed {
                *fl = p;
                *catching = !sound;
            } else {
                if resumed {
                    *fl = fl.max(p);
                }
                *catching |= !sound;
                let rise = if *catching && sound {
                    catch_up
                } else {
                    self.floor_rise
                };
                if sound && !resumed && p <= *fl * rise {
                    *catching = false;
                }
                *fl = (*fl * rise).min(p.max(*fl * self.floor_fall));
            }
            self.history[now + b] = p + self.params.floor_weight * *fl;
        }
        // In dB in a loop of its own, which runs in vector registers.
        for h in &mut self.history[now..now + bands] {
            *h = super::features::fast_db(*h);
        }
        // The mean over bands of each band's rise since `lag` frames ago, weighed.
        // Before the stream, the bands' level there (once primed).
        let rise_since = |lag: u64| {
            let before = match (lag == 0, f < lag, self.primed) {
                (true, _, _) | (false, true, false) => return 0.0,
                (false, true, true) => self.before_stream.as_slice(),
                (false, false, _) => &self.history[row(f - lag)..row(f - lag) + bands],
            };
            let mut rise = 0.0f32;
            for (b, before) in before.iter().enumerate() {
                rise += self.weight[b] * (self.history[now + b] - before).max(0.0);
            }
            rise / bands as f32
        };
        let odf = rise_since(lag);
        let slow_odf = rise_since(self.slow_lag as u64);
        let n = self.odf.len() as u64;
        self.odf[(f % n) as usize] = odf;
        self.slow_odf[(f % n) as usize] = slow_odf;
        // The candidate is the frame before: a peak once the function falls again (the
        // first frame too when the stream was primed: before it, the function was 0).
        if f < 2 && !(f == 1 && self.primed) {
            return None;
        }
        let c = f - 1;
        if let (Some(rise), Some(start)) = (self.unarmed_rise, self.last_onset) {
            // The frame a window before the candidate: where an attack rises from.
            let g = c.saturating_sub(lag);
            let mut fall = 0.0f32;
            let mut above_room = f32::INFINITY;
            if g > start {
                let trough = row(g);
                above_room = 0.0;
                for (b, peak) in self.peak.iter_mut().enumerate() {
                    let level = self.history[trough + b];
                    *peak = peak.max(level);
                    fall += *peak - level;
                    above_room += level - self.room_over_floor_db - 10.0 * self.floor[b].log10();
                }
            }
            // A sound back within the onset threshold of the room's noise has ended,
            // whatever it rose by: in loud noise a quiet hit's rise (noise's upward
            // wander included) can be more than it has to fall back by.
            if fall / bands as f32
                >= (self.params.rearm_fall * rise).min(self.params.rearm_fall_max_db)
                || above_room / (bands as f32) <= self.params.threshold_db
                || c - start >= self.rearm_after_frames
            {
                self.unarmed_rise = None;
            }
        }
        // A peak of either function at `c`, standing out of its recent mean; the slow
        // one only where no onset was found within its span.
        let value = match self.peak_at(&self.odf, c) {
            Some(v) => v,
            None if self.slow_lag > 0
                && self
                    .last_onset
                    .is_none_or(|last| c - last > self.slow_lag as u64) =>
            {
                self.peak_at(&self.slow_odf, c)?
            }
            None => return None,
        };
        if self
            .last_onset
            .is_some_and(|last| c - last < self.min_gap_frames)
        {
            return None;
        }
        if self.unarmed_rise.is_some() {
            // Before the last sound has faded, only a far louder or far steeper one is
            // new (the faint click of the lips before a hit does not hide the hit).
            let now = row(c);
            let mut over = 0.0f32;
            for b in 0..bands {
                let lo = b.saturating_sub(1);
                let hi = (b + 1).min(bands - 1);
                let loudest = self.peak[lo..=hi]
                    .iter()
                    .fold(f32::NEG_INFINITY, |m, &x| m.max(x));
                over += (self.history[now + b] - loudest).max(0.0);
            }
            let steeper = self
                .unarmed_rise
                .is_some_and(|v| value >= self.params.new_sound_rise_ratio * v);
            if over / (bands as f32) < self.params.new_sound_db && !steeper {
                return None;
            }
            self.unarmed_rise = None;
        }
        self.last_onset = Some(c);
        self.unarmed_rise = Some(value);
        let at_onset = row(c);
        self.peak
            .copy_from_slice(&self.history[at_onset..at_onset + bands]);
        Some(Onset {
            frame: c,
            flux_db: value,
        })
    }

    /// The value of the onset function in ring `odf` at frame `c` (the newest frame is
    /// `c + 1`) if it peaks there at least `threshold_db` over its mean of the
    /// `mean_frames` before.
    fn peak_at(&self, odf: &[f32], c: u64) -> Option<f32> {
        let n = odf.len() as u64;
        let at = |g: u64| odf[(g % n) as usize];
        let value = at(c);
        let previous = if c == 0 { 0.0 } else { at(c - 1) };
        if value <= at(c + 1) || value < previous {
            return None;
        }
        // Before a primed stream the function was 0: the room, no rise.
        let older = (self.mean_frames as u64).min(c);
        let over = if self.primed {
            self.mean_frames as u64
        } else {
            older
        };
        let mean = (1..=older).map(|d| at(c - d)).sum::<f32>() / over.max(1) as f32;
        (value >= mean + self.params.threshold_db).then_some(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATE: f64 = 22_050.0;
    const WIN: usize = 256;
    const HOP: usize = 64;
    const BANDS: usize = 16;

    /// Band powers of a frame: the mean square of `frame` split into `BANDS` equal
    /// stretches of its spectrum would need an FFT; for the stage alone a crude
    /// filterbank of sample-difference orders is enough (white noise is flat in it, a
    /// burst rises in every band).
    fn powers(frame: &[f32]) -> [f32; BANDS] {
        let mut out = [0.0f32; BANDS];
        for (b, o) in out.iter_mut().enumerate() {
            let k = b + 1;
            *o = frame
                .windows(k + 1)
                .map(|w| (w[k] - w[0]).powi(2))
                .sum::<f32>()
                / frame.len() as f32;
        }
        out
    }

    fn onsets(signal: &[f32]) -> Vec<f64> {
        onsets_with(OnsetParams::default(), signal)
    }

    fn onsets_with(params: OnsetParams, signal: &[f32]) -> Vec<f64> {
        let mut d = OnsetDetector::new(params, &[1.0; BANDS], WIN, HOP, RATE);
        let mut found = Vec::new();
        let mut start = 0;
        while start + WIN <= signal.len() {
            if let Some(o) = d.push(&powers(&signal[start..start + WIN])) {
                found.push((o.frame as usize * HOP + WIN) as f64 / RATE);
            }
            start += HOP;
        }
        found
    }

    use crate::detect::white_noise as noise;

    /// Decaying noise bursts 30 ms long at `times` (s), each `burst` in amplitude, over
    /// noise of amplitude `floor`, `seconds` long.
    fn bursts(times: &[f64], burst: f32, floor: f32, seconds: f64) -> Vec<f32> {
        let mut s = noise((seconds * RATE) as usize, floor, 7);
        for (i, &t) in times.iter().enumerate() {
            let at = (t * RATE) as usize;
            for (k, x) in noise(660, burst, 100 + i as u64).iter().enumerate() {
                s[at + k] += x * (-(k as f32) / 200.0).exp();
            }
        }
        s
    }

    /// A hit at the stream's first sample, over a room 30 dB under it: the floors that
    /// start from the first frame take the hit for the room and find no onset there;
    /// primed with the frames that follow (where the room is), the stage finds it in
    /// the first window, and no other onset.
    #[test]
    fn a_hit_the_stream_begins_with_is_an_onset_once_primed() {
        let signal = bursts(&[0.0], 0.3, 0.01, 1.0);
        let frames: Vec<[f32; BANDS]> = signal.windows(WIN).step_by(HOP).map(powers).collect();
        let run = |prime: bool| {
            let mut d = OnsetDetector::new(OnsetParams::default(), &[1.0; BANDS], WIN, HOP, RATE);
            if prime {
                let read: Vec<f32> = frames[..d.read_ahead_frames()].concat();
                d.prime(&read);
            }
            frames
                .iter()
                .filter_map(|p| d.push(p))
                .map(|o| o.frame)
                .collect::<Vec<_>>()
        };
        let first_window = (WIN / HOP) as u64;
        assert!(
            run(false).iter().all(|&f| f > first_window),
            "{:?}",
            run(false)
        );
        let primed = run(true);
        assert_eq!(primed.len(), 1, "{primed:?}");
        assert!(primed[0] < first_window, "{primed:?}");
    }

    #[test]
    fn steady_noise_of_any_level_has_no_onset() {
        for amplitude in [1e-4, 1e-2, 0.5] {
            let found = onsets(&noise(10 * RATE as usize, amplitude, 3));
            assert!(found.len() <= 1, "{amplitude}: {found:?}");
        }
    }

    /// The band floors after each frame of `signal`.
    fn floors(signal: &[f32]) -> Vec<Vec<f32>> {
        let mut d = OnsetDetector::new(OnsetParams::default(), &[1.0; BANDS], WIN, HOP, RATE);
        signal
            .windows(WIN)
            .step_by(HOP)
            .map(|frame| {
                d.push(&powers(frame));
                d.band_floors().to_vec()
            })
            .collect()
    }

    #[test]
    fn the_floors_catch_up_with_the_room_after_digital_silence() {
        // Noise at -30 dB after 0.5 s of zeros, with hits; muted for 0.5 s.
        let lead = (0.5 * RATE) as usize;
        let times = [1.0, 1.5, 2.6];
        let room = bursts(&times, 0.25, 0.03, 3.0);
        let mut signal = vec![0.0; lead];
        signal.extend_from_slice(&room);
        let muted = lead + (2.0 * RATE) as usize..lead + (2.5 * RATE) as usize;
        signal[muted].fill(0.0);
        // Each hit is an onset, where it is; so may the room's beginning and its coming
        // back after the mute be (to the stage, a sound rising out of silence), but
        // nothing else.
        let found = onsets(&signal);
        for t in times {
            assert!(
                found.iter().any(|f| (f - 0.5 - t).abs() < 0.015),
                "no onset for {t} + 0.5: {found:?}"
            );
        }
        let room_back = [0.5, 3.0];
        assert!(
            found
                .iter()
                .all(|f| times.iter().any(|t| (f - 0.5 - t).abs() < 0.015)
                    || room_back.iter().any(|b| (f - b).abs() < 0.03)),
            "{found:?}"
        );
        // Within 0.2 s of the room's beginning, and 0.4 s of its coming back, the
        // floors are those of the room heard from the start (within 2 dB: a floor's
        // wander).
        let (with, without) = (floors(&signal), floors(&room));
        let hops = |s: f64| (s * RATE) as usize / HOP;
        for at in [0.2, 0.9, 1.9, 2.9] {
            let (a, b) = (&with[hops(at + 0.5)], &without[hops(at)]);
            for (x, y) in a.iter().zip(b) {
                let db = 10.0 * (x / y).log10();
                assert!(
                    db.abs() < 2.0,
                    "at {at} s: {db:.1} dB ({a:?} against {b:?})"
                );
            }
        }
    }

    #[test]
    fn hits_30_ms_apart_are_each_an_onset_in_quiet_and_in_noise() {
        // 30 ms bursts with 30 ms between them.
        let times = [0.2, 0.26, 0.32, 0.5, 0.56, 0.8];
        // Bursts at -12 dB over noise at -60 and at -30 dB.
        for floor in [0.001, 0.03] {
            let found = onsets(&bursts(&times, 0.25, floor, 1.0));
            assert_eq!(found.len(), times.len(), "noise {floor}: {found:?}");
            for (f, t) in found.iter().zip(times) {
                assert!((f - t).abs() < 0.015, "noise {floor}: onset {f} for {t}");
            }
        }
    }

    /// A plate struck at each of `times` (s), alike each time: its modes from 900 Hz
    /// up, each dying away at 1 / (pi f eta) for a loss factor of 0.002 (a ceramic
    /// tile's or a mug's ring, 0.18 s at the first mode), over noise 80 dB down.
    fn strikes(times: &[f64], seconds: f64) -> Vec<f32> {
        let mut s = noise((seconds * RATE) as usize, 1e-4, 5);
        let (f11, aspect, eta) = (900.0f64, 1.1f64, 0.002f64);
        for &t in times {
            let at = (t * RATE) as usize;
            for m in 1..12 {
                for n in 1..12 {
                    let f = f11 * (m * m) as f64 + f11 * aspect * aspect * (n * n) as f64;
                    let f = f / (1.0 + aspect * aspect);
                    if f > RATE / 2.0 {
                        break;
                    }
                    let shape = (m as f64 * 0.41 * std::f64::consts::PI).sin()
                        * (n as f64 * 0.28 * std::f64::consts::PI).sin();
                    let decay = 1.0 / (std::f64::consts::PI * f * eta);
                    for (k, x) in s[at..].iter_mut().enumerate() {
                        let u = k as f64 / RATE;
                        *x += (0.05
                            * shape
                            * (2.0 * std::f64::consts::PI * f * u).sin()
                            * (-u / decay).exp()) as f32;
                    }
                }
            }
        }
        s
    }

    /// Eighth notes at 200 bpm on a surface that rings: each strike comes while the
    /// last one still sounds a few dB under it, so it never falls back by what it rose
    /// and is no far louder sound; the stage re-arms once `rearm_after_seconds` have
    /// passed, no longer than the rhythm's notes.
    #[test]
    fn strikes_on_a_ringing_surface_0_15_s_apart_are_each_an_onset() {
        let times = [0.2, 0.35, 0.5, 0.65, 0.8];
        let found = onsets(&strikes(&times, 1.2));
        assert_eq!(found.len(), times.len(), "{found:?}");
        for (f, t) in found.iter().zip(times) {
            assert!((f - t).abs() < 0.015, "onset {f} for {t}");
        }
    }

    #[test]
    fn a_faint_click_does_not_hide_the_hit_right_after_it() {
        // A click 40 dB under the hit, 20 ms before it: the click has not faded, but
        // the hit is far louder.
        let mut s = bursts(&[0.3], 0.005, 0.0001, 1.0);
        for (k, x) in noise(660, 0.5, 9).iter().enumerate() {
            s[(0.32 * RATE) as usize + k] += x * (-(k as f32) / 200.0).exp();
        }
        let found = onsets(&s);
        assert!(found.iter().any(|t| (t - 0.32).abs() < 0.015), "{found:?}");
    }

    #[test]
    fn a_hiss_that_swells_out_of_loud_noise_is_an_onset() {
        // Noise at -30 dB; at 0.4 s a hiss swells over 40 ms to twice the noise's
        // amplitude, holds 60 ms and fades over 100 ms: within any one window it rises
        // by a few dB only.
        let mut s = noise(RATE as usize, 0.03, 11);
        let hiss = noise(4_410, 0.06, 12);
        let (swell, hold) = (0.04 * RATE, 0.1 * RATE);
        for (k, x) in hiss.iter().enumerate() {
            let k = k as f64;
            let gain = if k < swell {
                k / swell
            } else if k < hold {
                1.0
            } else {
                (1.0 - (k - hold) / (0.2 * RATE - hold)).max(0.0)
            };
            s[(0.4 * RATE) as usize + k as usize] += x * gain as f32;
        }
        let found = onsets(&s);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!((found[0] - 0.42).abs() < 0.03, "{found:?}");
        // Rises over one window alone do not stand out of the noise.
        let one_window = OnsetParams {
            slow_rise_windows: 0,
            ..OnsetParams::default()
        };
        assert_eq!(onsets_with(one_window, &s), Vec::<f64>::new());
    }

    #[test]
    fn a_burst_of_any_loudness_does_not_lift_the_floor() {
        let mut s = bursts(&[0.6], 0.05, 0.001, 1.0);
        for x in &mut s[4_000..4_220] {
            *x = 1e6;
        }
        let found = onsets(&s);
        assert_eq!(found.len(), 2, "{found:?}");
        assert!((found[1] - 0.6).abs() < 0.015, "{found:?}");
    }
}
