//! The classification stage's comparison: a take heard in the room of the onset it is
//! compared with, the templates that follow each impulse pattern as its user makes it
//! lately ([`Tracked`]), and how much of an onset's sound over the tail of a word that
//! fired a take explains ([`share_explained_over_tail`]). The matcher calls them on the
//! detector thread, with buffers made when it is built; nothing here allocates per
//! onset.
//!
//! A take is enrolled in one room and an onset is heard in another. Where the onset's
//! room is noisy, the bands its sound leaves quiet hold the room's noise, while the
//! take's hold its own quiet: the features differ for the room alone, and a hit in a
//! loud room resembles the patterns whose spectra happen to be flat in those bands.
//! So each take is scored as it would sound in the onset's room (the noise model of
//! Gales and Young's parallel model combination, in the power domain): its pooled
//! power spectrum, scaled to the onset's sound, plus the room's noise. In a quiet room
//! that is the take as enrolled.

use super::explain::Taught;
use super::features::{
    fast_db, features_of_power, scale_to_unit, Analyzer, Cepstrum, BANDS, POOLED_RANGE_DB,
};
use super::onset::OnsetParams;
use super::spectral::run_onset_stage;
use super::{white_noise, NOISE_SEED};
use std::sync::Mutex;

/// Steady noise this long, after as long again to settle, measures how far the onset
/// stage's floors lie under the noise's mean power ([`noise_over_floor`]).
const CALIBRATION_SECONDS: f64 = 2.0;

/// Per band: the mean power of steady noise over the onset stage's floor for it. The
/// floor follows a band's quietest frames (it falls at once and rises slowly), so it
/// lies under the noise's mean, the further the fewer spectral bins the band sums (the
/// more its power wanders). The floor follows levels in dB, so the ratio does not
/// depend on the noise's level, and within a band little on its colour: it is
/// measured once, on seeded white noise through the same analysis and onset stage as
/// the stream.
pub(super) fn noise_over_floor(params: OnsetParams, rate: f64) -> Vec<f32> {
    let win = Analyzer::win_at(rate);
    let settle = (CALIBRATION_SECONDS * rate) as usize;
    let noise = white_noise(2 * settle + win, 0.5, NOISE_SEED);
    let (mut mean, mut floor) = (vec![0.0f64; BANDS], vec![0.0f64; BANDS]);
    run_onset_stage(&noise, rate, params, 0, |step| {
        // Frames whose window starts once the floors have settled.
        if step.consumed as usize >= settle + win {
            for b in 0..BANDS {
                mean[b] += f64::from(step.power[b]);
                floor[b] += f64::from(step.floors[b]);
            }
        }
    });
    mean.iter()
        .zip(&floor)
        .map(|(m, f)| if *f > 0.0 { (m / f) as f32 } else { 1.0 })
        .collect()
}

/// [`noise_over_floor`] of the default onset stage at `rate`, measured once per rate in a
/// process: every detector built after the first (a reload, each take that `record`
/// checks) reuses it.
pub(super) fn default_noise_over_floor(rate: f64) -> Vec<f32> {
    static MEASURED: Mutex<Vec<(u64, Vec<f32>)>> = Mutex::new(Vec::new());
    // A panic while measuring leaves nothing half-written: the list is only pushed to.
    let mut measured = MEASURED
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some((_, ratio)) = measured.iter().find(|(r, _)| *r == rate.to_bits()) {
        return ratio.clone();
    }
    let ratio = noise_over_floor(OnsetParams::default(), rate);
    measured.push((rate.to_bits(), ratio.clone()));
    ratio
}

/// The room an onset is heard in, set per onset ([`Room::set`]) and per pooled window
/// of it ([`Room::hear`]); made once per matcher.
pub(super) struct Room {
    /// Per band: see [`noise_over_floor`].
    noise_over_floor: Vec<f32>,
    /// Per band: the room's noise power.
    noise: Vec<f32>,
    /// The onset's pooled power above the noise, over all bands.
    onset_above_noise: f32,
    /// Scratch: a take's power spectrum as heard in the room.
    heard: Vec<f32>,
}

impl Room {
    pub(super) fn new(noise_over_floor: Vec<f32>) -> Self {
        let bands = noise_over_floor.len();
        Self {
            noise_over_floor,
            noise: vec![0.0; bands],
            onset_above_noise: 0.0,
            heard: vec![0.0; bands],
        }
    }

    /// Per band: the room's noise power, as last set.
    pub(super) fn noise(&self) -> &[f32] {
        &self.noise
    }

    /// The room's noise from the onset stage's per-band floors.
    pub(super) fn set(&mut self, floors: &[f32]) {
        for ((n, f), k) in self
            .noise
            .iter_mut()
            .zip(floors)
            .zip(&self.noise_over_floor)
        {
            *n = k * f;
        }
    }

    /// The onset's sound: its pooled power spectrum (linear), over the first `bands`
    /// bands (those compared).
    pub(super) fn hear(&mut self, onset_power: &[f32], bands: usize) {
        self.onset_above_noise = onset_power
            .iter()
            .zip(&self.noise)
            .take(bands)
            .map(|(p, n)| (p - n).max(0.0))
            .sum();
    }

    /// The features of a take (its pooled power spectrum `take_power`, and what the
    /// enrolment shrink added to its features, `drawn_towards`) heard in this room at
    /// the onset's level, into `out`: the take scaled so that it and the noise hold
    /// the onset's power, plus the noise.
    pub(super) fn take(
        &mut self,
        take_power: &[f32],
        drawn_towards: Option<&[f32]>,
        cepstrum: &Cepstrum,
        out: &mut [f32],
    ) {
        let take: f32 = take_power.iter().take(cepstrum.bands()).sum();
        let gain = if take > 0.0 {
            self.onset_above_noise / take
        } else {
            0.0
        };
        for ((h, t), n) in self.heard.iter_mut().zip(take_power).zip(&self.noise) {
            *h = gain * t + n;
        }
        features_of_power(&self.heard, cepstrum, out);
        if let Some(drawn) = drawn_towards {
            for (x, d) in out.iter_mut().zip(drawn) {
                *x += d;
            }
            scale_to_unit(out);
        }
    }
}

/// How the tracked templates follow ([`Tracked`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct TrackParams {
    /// How far each confident instance moves its pattern's tracked template.
    pub(super) rate: f32,
    /// Confident: at least this far over its pattern's threshold, and its pattern the
    /// best of all.
    pub(super) confidence: f32,
    /// How many of a pattern's latest clear instances are kept as templates too.
    pub(super) recent: usize,
}

impl Default for TrackParams {
    /// Swept over every dev set in `docs/classify.md` ("The matching's own settings";
    /// without tracking the mean F1 falls by 0.034, most of it on real hits; "The
    /// latest clear instances as templates" for `recent`).
    fn default() -> Self {
        Self {
            rate: 0.5,
            confidence: 0.15,
            recent: 4,
        }
    }
}

/// An instance that fired, as tracking is told of it.
pub(super) struct FiredInstance<'a> {
    /// Its features (unit norm) where its pattern scored best.
    pub(super) features: &'a [f32],
    /// Its pattern's score, over takes and tracked templates alike...
    pub(super) score: f32,
    /// ...and over the enrolled takes alone.
    pub(super) take_score: f32,
    /// The best score of any other pattern.
    pub(super) other: f32,
    /// Its pattern's threshold.
    pub(super) threshold: f32,
    /// How near its pattern's takes lie to one another ([`super::enrol::takes_agreement`];
    /// minus infinity for one take).
    pub(super) takes_agree: f32,
    /// Whether it began over the tail of an impulse that fired.
    pub(super) over_fired_impulse: bool,
    /// Whether the speech guard's span before it held more than half the unrecognised
    /// sound that closes the guard ([`super::context::Context::guard`]).
    pub(super) amid_talk: bool,
}

/// Follows a voice that drifts: a performer's "k" an hour in is not the "k" of the
/// take. Each impulse pattern has a tracked template besides its takes, scored as they
/// are. An instance recognised with confidence (`TrackParams::confidence` over its
/// pattern's threshold, its pattern the best over the first window, whose features
/// are what is tracked) becomes it the first time, and then moves it by
/// `TrackParams::rate` towards itself. The takes stay as enrolled, and every pattern
/// has one tracked template however many takes it has, so no pattern gains weight by
/// being heard more. Asking the instance also to stand a margin over every other
/// pattern kept hits alike from following their voice (`docs/classify.md`).
///
/// An average blurs a sound its user makes two ways, so a pattern also keeps its
/// latest `TrackParams::recent` clear instances as they were. Clear is asked of the
/// enrolled takes alone, so that no kept instance lets in the next one (a rule that
/// fed on its own decisions would carry one confusion on for good): the takes score
/// it `confidence` over its threshold and over every other pattern. And it began out
/// of quiet, since over a fired word's tail its features are partly that tail's.
///
/// Where a pattern was enrolled from several takes, they show how far its user's sound
/// varies, and neither learns from an instance further from them than they lie from
/// one another ([`super::enrol::takes_agreement`]): its score must reach theirs, over
/// takes and tracked template for the template, over the takes alone to be kept. An
/// instance further out is not clearly the sound; a syllable of speech that fired was
/// one, and the syllables after it followed the template it taught
/// (`docs/classify.md`, "How near its takes an instance must lie to teach
/// tracking"). One take shows no spread, and the confidence alone is asked.
///
/// Neither learns from an instance amid talk (more than half the unrecognised sound
/// that closes the speech guard in the span before it): a syllable that passed the
/// gates would move the template to speech, and the syllables after it would match the
/// template and move it further, a rule feeding on its own decisions. Half the guard's
/// sound is the middle of the plateau swept in `docs/classify.md` ("Tracking that
/// learns only in the clear").
#[derive(Clone)]
pub(super) struct Tracked {
    params: TrackParams,
    features: usize,
    /// Per pattern, `features` values each: the impulse as its user has lately made it.
    templates: Vec<f32>,
    /// Per pattern: whether a confident instance has been heard yet.
    set: Vec<bool>,
    /// Per pattern, `params.recent` slots of `features` values: its latest clear
    /// instances.
    recent: Vec<f32>,
    /// Per pattern: how many of its slots hold an instance, and the slot written next.
    recent_held: Vec<usize>,
    recent_next: Vec<usize>,
}

impl Tracked {
    pub(super) fn new(params: TrackParams, patterns: usize, features: usize) -> Self {
        Self {
            params,
            features,
            templates: vec![0.0; patterns * features],
            set: vec![false; patterns],
            recent: vec![0.0; patterns * params.recent * features],
            recent_held: vec![0; patterns],
            recent_next: vec![0; patterns],
        }
    }

    /// Becomes a copy of `other` (made for as many patterns and features), allocating
    /// nothing.
    pub(super) fn copy_from(&mut self, other: &Tracked) {
        self.templates.copy_from_slice(&other.templates);
        self.set.copy_from_slice(&other.set);
        self.recent.copy_from_slice(&other.recent);
        self.recent_held.copy_from_slice(&other.recent_held);
        self.recent_next.copy_from_slice(&other.recent_next);
    }

    /// Forgets every tracked template and kept instance (the features they were made
    /// of are no longer those compared).
    pub(super) fn forget(&mut self) {
        self.set.fill(false);
        self.recent_held.fill(0);
        self.recent_next.fill(0);
    }

    /// Pattern `pattern`'s tracked template, once a confident instance has set it.
    pub(super) fn template(&self, pattern: usize) -> Option<&[f32]> {
        let n = self.features;
        self.set[pattern].then(|| &self.templates[pattern * n..(pattern + 1) * n])
    }

    /// Pattern `pattern`'s kept instances, each scored as a take is.
    pub(super) fn kept(&self, pattern: usize) -> impl Iterator<Item = &[f32]> {
        let n = self.features;
        let first = pattern * self.params.recent;
        (first..first + self.recent_held[pattern])
            .map(move |slot| &self.recent[slot * n..(slot + 1) * n])
    }

    /// An instance that fired as `pattern`: what it taught.
    pub(super) fn follow(&mut self, pattern: usize, instance: &FiredInstance) -> Taught {
        if instance.amid_talk {
            return Taught::NothingAmidTalk;
        }
        let (n, confident) = (self.features, self.params.confidence);
        if instance.score < instance.threshold + confident || instance.score < instance.other {
            return Taught::NothingUnsure;
        }
        if instance.score < instance.takes_agree {
            return Taught::NothingFurtherThanTakes;
        }
        // Its score is over its takes and the template alike, so what its takes alone
        // find clear the template does too.
        let clear = !instance.over_fired_impulse
            && instance.take_score >= instance.threshold + confident
            && instance.take_score >= instance.other + confident
            && instance.take_score >= instance.takes_agree
            && self.params.recent > 0;
        if clear {
            let slot = pattern * self.params.recent + self.recent_next[pattern];
            self.recent[slot * n..(slot + 1) * n].copy_from_slice(instance.features);
            self.recent_next[pattern] = (self.recent_next[pattern] + 1) % self.params.recent;
            self.recent_held[pattern] = (self.recent_held[pattern] + 1).min(self.params.recent);
        }
        let template = &mut self.templates[pattern * n..(pattern + 1) * n];
        if self.set[pattern] {
            for (t, x) in template.iter_mut().zip(instance.features) {
                *t += self.params.rate * (x - *t);
            }
            scale_to_unit(template);
        } else {
            template.copy_from_slice(instance.features);
            self.set[pattern] = true;
        }
        if clear {
            Taught::TemplateAndKept
        } else {
            Taught::Template
        }
    }
}

/// The tail of the word before is tried at levels this many dB apart...
const OVER_TAIL_STEP_DB: f32 = 2.0;
/// ...within this many dB of its mean over the quiet-before span (a vowel's level moves
/// about as much over a decision window)...
const OVER_TAIL_TAIL_DB: f32 = 10.0;
/// ...and a take from this far under the onset's power (absent)...
const OVER_TAIL_TAKE_UNDER_DB: f32 = 40.0;
/// ...to this far over it.
const OVER_TAIL_TAKE_OVER_DB: f32 = 20.0;

/// How much of what is new in an onset's sound, over the word before it, a take
/// explains. A word said while the last one is still sounding begins over its tail:
/// the onset's window holds both, and the tail is most of its power, so the onset's
/// features resemble the tail whatever began (`docs/quiet-before.md`). Here the
/// onset's pooled power spectrum `onset`, in dB floored as features are, is fitted
/// once by the room's `noise` plus the sound before it (`before`, its mean power over
/// the quiet-before span) at some level, and once with the take's pooled power `take`
/// added at some level; the result is the share of the first fit's mean squared error
/// (dB²) that the take removes. Near 1, the onset is that take begun over the tail;
/// near 0, the tail alone explains the onset as well (a word's own later sound), or the
/// take adds nothing like what is new. Levels are tried on a grid of
/// `OVER_TAIL_STEP_DB` (the fit is of floored dB, so the take's best level may lie over
/// its share of the power); over the first `bands` bands. Allocates nothing.
pub(super) fn share_explained_over_tail(
    onset: &[f32],
    before: &[f32],
    noise: &[f32],
    take: &[f32],
    bands: usize,
) -> f32 {
    let bands = bands.min(BANDS);
    let mut heard = [0.0f32; BANDS];
    for (h, p) in heard.iter_mut().zip(onset).take(bands) {
        *h = fast_db(p + 1e-12);
    }
    let loudest = heard[..bands]
        .iter()
        .cloned()
        .fold(f32::NEG_INFINITY, f32::max);
    let lowest = loudest - POOLED_RANGE_DB;
    // Bands not compared stand at the floor, as the models' (left at 0) do.
    for (b, h) in heard.iter_mut().enumerate() {
        *h = if b < bands { h.max(lowest) } else { lowest };
    }
    // Mean squared error (dB²) of a model's power spectrum against the onset's, summed
    // eight bands abreast.
    let error = |model: &[f32; BANDS]| {
        let mut sums = [0.0f32; 8];
        for (h, m) in heard.chunks_exact(8).zip(model.chunks_exact(8)) {
            for i in 0..8 {
                let d = h[i] - fast_db(m[i] + 1e-12).max(lowest);
                sums[i] += d * d;
            }
        }
        sums.iter().sum::<f32>() / bands.max(1) as f32
    };
    let gain = |db: f32| 10f32.powf(db / 10.0);
    let onset_total: f32 = onset.iter().take(bands).sum();
    let take_total: f32 = take.iter().take(bands).sum();
    if take_total <= 0.0 || onset_total <= 0.0 {
        return 0.0;
    }
    let take_at_onset = onset_total / take_total;
    let steps = |from: f32, to: f32| {
        let n = ((to - from) / OVER_TAIL_STEP_DB).round() as usize;
        (0..=n).map(move |i| from + i as f32 * OVER_TAIL_STEP_DB)
    };
    let (mut tail_alone, mut with_take) = (f32::INFINITY, f32::INFINITY);
    let (mut base, mut model) = ([0.0f32; BANDS], [0.0f32; BANDS]);
    for tail_db in steps(-OVER_TAIL_TAIL_DB, OVER_TAIL_TAIL_DB) {
        let a = gain(tail_db);
        for b in 0..bands {
            base[b] = noise[b] + a * before[b];
        }
        tail_alone = tail_alone.min(error(&base));
        for take_db in steps(-OVER_TAIL_TAKE_UNDER_DB, OVER_TAIL_TAKE_OVER_DB) {
            let g = take_at_onset * gain(take_db);
            for b in 0..bands {
                model[b] = base[b] + g * take[b];
            }
            with_take = with_take.min(error(&model));
        }
    }
    if tail_alone <= 0.0 {
        return 0.0;
    }
    ((tail_alone - with_take) / tail_alone).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::super::features::{pool_power, similarity, Cepstrum, FEATURES};
    use super::super::onset::OnsetDetector;
    use super::*;

    const RATE: f64 = 22_050.0;

    #[test]
    fn the_floor_lies_under_the_noise_the_more_the_narrower_the_band() {
        let analyzer = Analyzer::new(RATE);
        let ratio = noise_over_floor(OnsetParams::default(), RATE);
        let bins = analyzer.band_bins();
        assert!(ratio.iter().all(|&r| r > 1.5), "{ratio:?}");
        // A one-bin band wanders most: its floor lies furthest under its mean.
        let (narrow, wide) = (
            (0..BANDS)
                .min_by(|&a, &b| bins[a].total_cmp(&bins[b]))
                .unwrap(),
            (0..BANDS)
                .max_by(|&a, &b| bins[a].total_cmp(&bins[b]))
                .unwrap(),
        );
        assert!(ratio[narrow] > 2.0 * ratio[wide], "{ratio:?}");
    }

    /// Spectra on the mel bands: a vowel's (its power in the low bands), a burst's (in
    /// the high ones) and the room's.
    fn vowel() -> Vec<f32> {
        (0..BANDS)
            .map(|b| if b < 10 { 1.0 } else { 1e-4 })
            .collect()
    }
    fn burst() -> Vec<f32> {
        (0..BANDS)
            .map(|b| if b >= 16 { 0.5 + 0.02 * b as f32 } else { 1e-5 })
            .collect()
    }
    fn mix(parts: &[(f32, &[f32])]) -> Vec<f32> {
        (0..BANDS)
            .map(|b| 1e-6 + parts.iter().map(|(g, p)| g * p[b]).sum::<f32>())
            .collect()
    }

    #[test]
    fn a_take_begun_over_a_tail_explains_what_the_tail_does_not_and_nothing_more() {
        let (vowel, burst, noise) = (vowel(), burst(), vec![1e-6; BANDS]);
        let share = |onset: &[f32], take: &[f32]| {
            share_explained_over_tail(onset, &vowel, &noise, take, BANDS)
        };
        // A burst 10 dB under the vowel begun over it, the vowel 1 dB down since.
        let burst_over_tail = mix(&[(0.8, &vowel), (0.1, &burst)]);
        assert!(
            share(&burst_over_tail, &burst) > 0.9,
            "{}",
            share(&burst_over_tail, &burst)
        );
        // The vowel's own take adds nothing the tail does not explain.
        assert!(
            share(&burst_over_tail, &vowel) < 0.1,
            "{}",
            share(&burst_over_tail, &vowel)
        );
        // The tail alone, fading: no take explains anything more.
        let tail = mix(&[(0.5, &vowel)]);
        assert!(share(&tail, &burst) < 0.05, "{}", share(&tail, &burst));
        // Nothing to compare: no share.
        assert_eq!(share(&burst_over_tail, &[0.0; BANDS]), 0.0);
    }

    /// The pooled power spectrum of `frames` frames of `x` from sample `from`.
    fn pooled(analyzer: &mut Analyzer, x: &[f32], from: usize, frames: usize) -> Vec<f32> {
        let (win, hop) = (analyzer.win, analyzer.hop);
        let db: Vec<Vec<f32>> = (0..frames)
            .map(|k| {
                let mut f = vec![0.0f32; BANDS];
                analyzer.frame(&x[from + k * hop..from + k * hop + win], &mut f);
                f
            })
            .collect();
        let mut power = vec![0.0f32; BANDS];
        pool_power(frames, |k| &db[k], &mut power);
        power
    }

    /// A low vowel-like buzz: harmonics of 150 Hz up to 1.5 kHz, nothing above.
    fn buzz(n: usize) -> Vec<f32> {
        (0..n)
            .map(|i| {
                let t = i as f64 / RATE;
                (1..=10)
                    .map(|h| (2.0 * std::f64::consts::PI * 150.0 * h as f64 * t).sin() / h as f64)
                    .sum::<f64>() as f32
                    * 0.1
            })
            .collect()
    }

    #[test]
    fn a_take_heard_in_the_onsets_room_matches_its_copy_in_noise() {
        let mut analyzer = Analyzer::new(RATE);
        let basis = Cepstrum::full();
        let ratio = noise_over_floor(OnsetParams::default(), RATE);
        let n = 4096;
        let take = buzz(n);
        // The same sound in a room whose hiss fills the bands it leaves empty.
        let hiss = white_noise(n, 0.025, 5);
        let copy: Vec<f32> = take.iter().zip(&hiss).map(|(a, b)| a + b).collect();
        let take_power = pooled(&mut analyzer, &take, 0, 8);
        let copy_power = pooled(&mut analyzer, &copy, 0, 8);
        // The room's floors, as the onset stage keeps them over a second of its noise.
        let before = white_noise(RATE as usize, 0.025, 6);
        let (win, hop) = (analyzer.win, analyzer.hop);
        let mut onsets = OnsetDetector::new(
            OnsetParams::default(),
            &analyzer.band_bins(),
            win,
            hop,
            RATE,
        );
        let mut frame = vec![0.0f32; BANDS];
        for start in (0..before.len() - win).step_by(hop) {
            analyzer.frame(&before[start..start + win], &mut frame);
            onsets.push(&analyzer.power);
        }
        let floors = onsets.band_floors().to_vec();
        let features = |power: &[f32]| {
            let mut out = vec![0.0f32; FEATURES];
            features_of_power(power, &basis, &mut out);
            out
        };
        let copy_features = features(&copy_power);
        let as_enrolled = similarity(&features(&take_power), &copy_features);
        let mut room = Room::new(ratio.clone());
        room.set(&floors);
        room.hear(&copy_power, BANDS);
        let mut heard = vec![0.0f32; FEATURES];
        room.take(&take_power, None, &basis, &mut heard);
        let in_room = similarity(&heard, &copy_features);
        assert!(in_room > 0.95, "{in_room} against {as_enrolled}");
        assert!(
            in_room > as_enrolled + 0.05,
            "{in_room} against {as_enrolled}"
        );

        // In a silent room the take is heard as enrolled.
        room.set(&[0.0; BANDS]);
        room.hear(&take_power, BANDS);
        room.take(&take_power, None, &basis, &mut heard);
        assert!(similarity(&heard, &features(&take_power)) > 0.9999);
    }

    fn unit(v: &[f32]) -> Vec<f32> {
        let mut v = v.to_vec();
        scale_to_unit(&mut v);
        v
    }

    /// An instance of pattern 0 that scored `score` over takes and tracked templates
    /// alike, `take_score` over its takes alone, `other` for the best other pattern,
    /// against a threshold of 0.3, out of quiet.
    fn fired(features: &[f32], score: f32, take_score: f32, other: f32) -> FiredInstance<'_> {
        FiredInstance {
            features,
            score,
            take_score,
            other,
            threshold: 0.3,
            takes_agree: f32::NEG_INFINITY,
            over_fired_impulse: false,
            amid_talk: false,
        }
    }

    /// Pattern 0's tracked template and kept instances, in order.
    fn templates_of(tracked: &Tracked) -> Vec<Vec<f32>> {
        let kept = tracked.kept(0);
        tracked
            .template(0)
            .into_iter()
            .chain(kept)
            .map(<[f32]>::to_vec)
            .collect()
    }

    #[test]
    fn a_confident_instance_sets_the_tracked_template_then_moves_it_halfway() {
        let params = TrackParams {
            recent: 0,
            ..TrackParams::default()
        };
        let mut tracked = Tracked::new(params, 2, 3);
        assert!(tracked.template(0).is_none());
        let (first, second) = (unit(&[1.0, 0.0, 0.0]), unit(&[0.0, 1.0, 0.0]));
        tracked.follow(0, &fired(&first, 0.9, 0.9, 0.5));
        assert_eq!(tracked.template(0), Some(&first[..]));
        assert!(tracked.template(1).is_none());
        tracked.follow(0, &fired(&second, 0.9, 0.9, 0.5));
        // Halfway between the two, scaled back to unit norm.
        let halfway = unit(&[1.0, 1.0, 0.0]);
        let now = tracked.template(0).unwrap();
        assert!(
            now.iter().zip(&halfway).all(|(a, b)| (a - b).abs() < 1e-6),
            "{now:?}"
        );
        assert_eq!(templates_of(&tracked), vec![now.to_vec()]);
    }

    #[test]
    fn an_instance_not_confidently_its_patterns_moves_nothing() {
        let mut tracked = Tracked::new(TrackParams::default(), 2, 3);
        let x = unit(&[1.0, 0.0, 0.0]);
        // Under the threshold plus the confidence.
        tracked.follow(0, &fired(&x, 0.44, 0.44, 0.1));
        // Another pattern scored more.
        tracked.follow(0, &fired(&x, 0.9, 0.9, 0.95));
        assert!(tracked.template(0).is_none());
        assert!(templates_of(&tracked).is_empty());
        tracked.follow(0, &fired(&x, 0.46, 0.46, 0.1));
        assert!(tracked.template(0).is_some());
    }

    #[test]
    fn an_instance_amid_talk_teaches_nothing() {
        let mut tracked = Tracked::new(TrackParams::default(), 2, 3);
        let x = unit(&[1.0, 0.0, 0.0]);
        let amid_talk = FiredInstance {
            amid_talk: true,
            ..fired(&x, 0.9, 0.9, 0.1)
        };
        assert_eq!(tracked.follow(0, &amid_talk), Taught::NothingAmidTalk);
        assert!(templates_of(&tracked).is_empty());
        assert_eq!(
            tracked.follow(0, &fired(&x, 0.9, 0.9, 0.1)),
            Taught::TemplateAndKept
        );
        assert_eq!(templates_of(&tracked).len(), 2);
    }

    #[test]
    fn an_instance_further_from_the_takes_than_they_lie_from_one_another_teaches_nothing() {
        let mut tracked = Tracked::new(TrackParams::default(), 2, 3);
        let x = unit(&[1.0, 0.0, 0.0]);
        // Confident by the threshold and the other pattern, but its takes agree at 0.8.
        let further = FiredInstance {
            takes_agree: 0.8,
            ..fired(&x, 0.75, 0.75, 0.1)
        };
        assert_eq!(tracked.follow(0, &further), Taught::NothingFurtherThanTakes);
        assert!(templates_of(&tracked).is_empty());
        // As near as they lie: it sets the template and is kept.
        let as_near = FiredInstance {
            takes_agree: 0.75,
            ..fired(&x, 0.75, 0.75, 0.1)
        };
        assert_eq!(tracked.follow(0, &as_near), Taught::TemplateAndKept);
        assert_eq!(templates_of(&tracked).len(), 2);
        // Near the template, not the takes: it moves the template, is not kept.
        let y = unit(&[1.0, 0.2, 0.0]);
        let by_template = FiredInstance {
            takes_agree: 0.8,
            ..fired(&y, 0.9, 0.7, 0.1)
        };
        assert_eq!(tracked.follow(0, &by_template), Taught::Template);
        assert_eq!(templates_of(&tracked).len(), 2);
        assert_ne!(tracked.template(0), Some(&x[..]));
    }

    #[test]
    fn the_latest_clear_instances_are_kept_as_they_were() {
        let params = TrackParams::default();
        let mut tracked = Tracked::new(params, 2, 3);
        let instances: Vec<Vec<f32>> = (0..params.recent + 2)
            .map(|i| unit(&[1.0, i as f32, 0.0]))
            .collect();
        for x in &instances {
            tracked.follow(0, &fired(x, 0.9, 0.9, 0.5));
        }
        let kept = templates_of(&tracked);
        // The tracked template, then the last `recent` instances (in the ring's order).
        assert_eq!(kept.len(), 1 + params.recent);
        let mut latest: Vec<Vec<f32>> = instances[2..].to_vec();
        latest.rotate_left(params.recent - 2);
        assert_eq!(kept[1..].to_vec(), latest);
        assert!(tracked.kept(1).next().is_none());
        tracked.forget();
        assert!(templates_of(&tracked).is_empty());
    }

    #[test]
    fn only_an_instance_its_takes_alone_find_clear_and_out_of_quiet_is_kept() {
        let mut tracked = Tracked::new(TrackParams::default(), 2, 3);
        let x = unit(&[1.0, 0.0, 0.0]);
        // Confident through a tracked template, but its takes alone score it under the
        // threshold plus the confidence: it moves the tracked template, is not kept.
        tracked.follow(0, &fired(&x, 0.9, 0.44, 0.5));
        assert_eq!(templates_of(&tracked).len(), 1);
        // Its takes find it over the threshold, but within the confidence of another
        // pattern: between the two, not kept.
        tracked.follow(0, &fired(&x, 0.9, 0.9, 0.8));
        assert_eq!(templates_of(&tracked).len(), 1);
        // Clear, but begun over a fired impulse's tail.
        let over_tail = FiredInstance {
            over_fired_impulse: true,
            ..fired(&x, 0.9, 0.9, 0.5)
        };
        tracked.follow(0, &over_tail);
        assert_eq!(templates_of(&tracked).len(), 1);
        tracked.follow(0, &fired(&x, 0.9, 0.9, 0.5));
        assert_eq!(templates_of(&tracked).len(), 2);
    }
}
