//! The enrolment stage: turns a pattern's takes into the templates the matcher scores
//! onsets against. A take's onset is placed where a stream would place it (the
//! features, onset and placement stages run on the take after noise, as the matcher
//! runs them on a stream), and its features are those the features stage gives a
//! stream at that onset. The takes also tell how far up their input carries sound
//! ([`takes_carry_under_hz`]). Runs when a detector is built (on the thread that builds
//! it), never per block.

use super::features::{
    features_of_power, pool_power, scale_to_unit, similarity, Analyzer, Cepstrum, BANDS, FEATURES,
    HOP_SECONDS, WINDOW_SECONDS,
};
use super::onset::OnsetParams;
use super::passband::Passband;
use super::place::{first_window_within, Placer, ONSET_RANGE_DB, PLACE_AFTER_FRAMES};
use super::spectral::{run_onset_stage, MAX_SHIFT};
use super::{white_noise, NOISE_SEED};
use crate::config::{DetectorSettings, PatternKind};

pub(super) struct Template {
    pub(super) pattern: usize,
    /// Which take it was enrolled from (numbered over every pattern's takes): a take
    /// placed twice gives two templates of one take.
    pub(super) take: usize,
    /// Enrolled from a second placement of a take's onset (a quiet room's, or a held
    /// sound's soft start): left out of what compares different takes
    /// ([`Template::is_take_of`]).
    pub(super) second_placement: bool,
    /// Centred, unit-norm features of the first frames after the take's onset.
    pub(super) features: Vec<f32>,
    /// The mean power spectrum (linear) that `features` were made from, before the
    /// shrink: for hearing the take in another room ([`super::classify`]).
    pub(super) pooled_power: Vec<f32>,
    /// What the shrink added to `features` (`TAKE_SHRINK` times its pattern's mean),
    /// when it did.
    pub(super) drawn_towards: Option<Vec<f32>>,
    /// Energy of the take's samples over the decision window.
    pub(super) early_energy: f64,
    /// Length of the take from its onset, samples: how long an instance is taken to
    /// last when judging the context of the next onset.
    pub(super) length_after_onset: u64,
    /// How far this placement lies after the earlier one a quiet room gives the take,
    /// samples, when that is at least the decision window's frames (an impulse's; 0
    /// for that one, any closer and any other): an instance this template finds began
    /// that much before where it was placed. Closer, the two templates pool mostly the
    /// same frames, and which scores best says little about where an instance began.
    pub(super) after_earlier: u64,
    /// The mean power of the take's sound over those samples (its soft start) against
    /// its mean power over the decision window from this placement: how loud a sound
    /// must be before an instance's onset to have hidden that soft start.
    pub(super) soft_start_share: f64,
    /// The take's own later sounds: pooled power spectra as `pooled_power`, and
    /// energy over the decision window, from every frame after the onset frame
    /// (`[k - 1]`: k frames after it) to the end of the take.
    pub(super) later_power: Vec<f32>,
    pub(super) later_energy: Vec<f64>,
    /// For a take that is one sound repeated (at least `REPEATED_ATTACKS` attacks after
    /// this placement, each as alike its first window as a continuation must be), the
    /// longest time between two of them, frames; none for any other take.
    pub(super) repeats_every: Option<usize>,
}

impl Template {
    /// Whether this is one of `pattern`'s takes as placed once (its second placement
    /// is the same take again): what `shrink_takes_towards_their_mean` and
    /// `takes_agreement` compare.
    pub(super) fn is_take_of(&self, pattern: usize) -> bool {
        self.pattern == pattern && !self.second_placement
    }

    /// The pooled power spectrum of the take's decision window that starts `frames`
    /// frames after its onset: `pooled_power` at 0, one of `later_power` after; none
    /// past the take's end.
    pub(super) fn window_at(&self, frames: usize) -> Option<&[f32]> {
        match frames {
            0 => Some(&self.pooled_power),
            k => self.later_power.get((k - 1) * BANDS..k * BANDS),
        }
    }
}

/// An impulse pattern's takes are each moved this many times their pattern's mean
/// towards it (and scaled back to unit norm): two thirds of the way. A sound is scored
/// by its best take, so a pattern of several takes that differ reaches further, and
/// where patterns are alike it takes sounds from the others: on the repeated set of
/// `examples/eval_beatbox.rs`, three takes of each sound scored 0.829 on the later
/// repetitions against 0.902 for the first take alone. Moved towards their mean, three
/// takes score 0.854 at 0.5, 0.878 at 1 and 0.902 from 1.5 to 6 (0.878 at 100, all
/// but the mean); on the isolated set three takes score 1.000 at every setting, against
/// 0.980 for one. A pattern enrolled two different ways is still found both ways: a
/// take at right angles to the other keeps a similarity of 0.86 with itself at 2
/// (`tests/spectral.rs` has such a pattern: F1 at least 0.95 at 2, 0.700 at 100).
/// One take is its own mean, so a single-take pattern is unchanged. Over every dev set
/// (one take per pattern but for second placements) 0 to 4 score within 0.002 of each
/// other (`docs/classify.md`); over the real sets enrolled from two and three takes,
/// the hits lie on a plateau from 0.5 to 4 and real speech falls until 2
/// (`docs/classify.md`, "Several takes enrolling").
const TAKE_SHRINK: f32 = 2.0;

/// How near an impulse pattern's takes lie to one another ([`takes_agreement`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TakesAgree {
    /// The least over the takes of each one's score, left out, against the others;
    /// minus infinity for a held pattern or one take.
    pub score: f32,
    /// Which of the pattern's takes (counted from 0) scored it: the least typical.
    pub least_typical: usize,
}

impl TakesAgree {
    /// A pattern whose takes show no spread.
    pub const NONE: Self = Self {
        score: f32::NEG_INFINITY,
        least_typical: 0,
    };
}

/// How near each impulse pattern's takes lie to one another, scored as an instance is:
/// each take, left out, against the pattern's other takes drawn `TAKE_SHRINK` times
/// their own mean towards it, the best of them; the least over the takes, and which
/// take that was. Several takes show how far their user's sound varies, and an
/// instance further from them than that is not clearly it
/// ([`super::classify::Tracked`]). [`TakesAgree::NONE`] for a held pattern and for an
/// impulse pattern of one take, whose spread no enrolment shows. Called on the takes'
/// features before [`shrink_takes_towards_their_mean`]; allocates nothing (the bands
/// compared can change while a stream runs).
pub(super) fn takes_agreement(
    templates: &[Template],
    kinds: &[PatternKind],
    out: &mut [TakesAgree],
) {
    out.fill(TakesAgree::NONE);
    let mut others_mean = [0.0f32; FEATURES];
    let mut drawn = [0.0f32; FEATURES];
    for (pi, kind) in kinds.iter().enumerate() {
        if *kind != PatternKind::Impulse {
            continue;
        }
        let takes = || {
            templates
                .iter()
                .enumerate()
                .filter(move |(_, t)| t.is_take_of(pi))
        };
        for (k, (left_out, take)) in takes().enumerate() {
            let others = || takes().filter(move |&(j, _)| j != left_out);
            if others().next().is_none() {
                break;
            }
            others_mean.fill(0.0);
            for (_, other) in others() {
                for (m, x) in others_mean.iter_mut().zip(&other.features) {
                    *m += x;
                }
            }
            scale_to_unit(&mut others_mean);
            let mut best = f32::NEG_INFINITY;
            for (_, other) in others() {
                for ((d, x), m) in drawn.iter_mut().zip(&other.features).zip(&others_mean) {
                    *d = x + TAKE_SHRINK * m;
                }
                scale_to_unit(&mut drawn);
                best = best.max(similarity(&drawn, &take.features));
            }
            if k == 0 || best < out[pi].score {
                out[pi] = TakesAgree {
                    score: best,
                    least_typical: k,
                };
            }
        }
    }
}

/// Moves every impulse pattern's take features `TAKE_SHRINK` times their pattern's mean
/// towards it. Held patterns are left as enrolled: a swelling take gives them two
/// templates on purpose, its soft start and its full sound.
pub(super) fn shrink_takes_towards_their_mean(templates: &mut [Template], kinds: &[PatternKind]) {
    let mut mean = [0.0f32; FEATURES];
    for (pi, kind) in kinds.iter().enumerate() {
        if *kind != PatternKind::Impulse {
            continue;
        }
        mean.fill(0.0);
        for t in templates.iter().filter(|t| t.is_take_of(pi)) {
            for (m, x) in mean.iter_mut().zip(&t.features) {
                *m += x;
            }
        }
        scale_to_unit(&mut mean);
        let drawn = mean.map(|m| TAKE_SHRINK * m);
        for t in templates.iter_mut().filter(|t| t.is_take_of(pi)) {
            for (x, d) in t.features.iter_mut().zip(&drawn) {
                *x += d;
            }
            scale_to_unit(&mut t.features);
            // Made again in place when the comparison changes (a narrower stream).
            match &mut t.drawn_towards {
                Some(was) => was.copy_from_slice(&drawn),
                None => t.drawn_towards = Some(drawn.to_vec()),
            }
        }
    }
}

/// The pooled power spectrum of `template` over its first `windows` decision windows
/// of `decision_frames` frames from its onset (1: its `pooled_power`), into `out`:
/// the mean of each window's pooled power, where the take has ended, silence (the room
/// it is heard in adds its noise there).
pub(super) fn window_power(
    template: &Template,
    windows: usize,
    decision_frames: usize,
    out: &mut [f32],
) {
    out.copy_from_slice(&template.pooled_power);
    for w in 1..windows {
        if let Some(later) = template.window_at(w * decision_frames) {
            for (o, x) in out.iter_mut().zip(later) {
                *o += x;
            }
        }
    }
    let windows = windows.max(1) as f32;
    out.iter_mut().for_each(|o| *o /= windows);
}

/// A pair alike over one window that stays alike over every window allowed is still
/// worth waiting for when some of them make its takes this much less alike than one
/// window does. On the pairs of the development sets and of `scripts/other-voices.py`
/// that stay alike, waiting either makes them more alike (knocks on one table, two
/// kicks) or less alike by under 0.01, or by 0.06-0.28 (a "pop" and a "pew" whose "p"
/// lasts longer than the wait; a "tick" and a "pew"); 0 to 0.05 give the same waits
/// (`docs/classify.md`). Over 0, so that two takes that begin the same to the last bit
/// do not wait on rounding.
const PARTING_DROP: f32 = 0.02;

/// For every ordered pair of impulse patterns (`patterns` × `patterns`, row-major):
/// over how many decision windows a choice between the two is made. Two takes, one of
/// each, that look alike over one window (similarity `alike` or more, the most alike
/// of their placements) are told apart over the fewest windows, up to `max_windows`,
/// after which they are not that alike any more: a spoken "pop" and "pew" share their
/// first 25 ms (the "p" and its release) and part with their vowels. Two takes that
/// stay that alike over every window allowed, but are at least `PARTING_DROP` less
/// alike over some of them than over one (a voice whose "p" lasts nearly as long as the
/// wait), are told apart over the windows that part them most. Two that stay alike
/// however long they are heard (two knocks on one table) gain nothing by waiting, and
/// get 1, as do two that are not alike to begin with. Two patterns are told apart where
/// every pair of their takes that waiting can part is (the most alike pair over each
/// window); a pair that stays alike however long is left out, so that of three takes of
/// a "pop" and three of a "pew", one pair said slowly enough that its "p" outlasts the
/// wait does not keep the others from being told apart (`docs/classify.md`, "Patterns
/// alike, enrolled from several takes"). With one take each, the one pair decides.
///
/// Made with the templates, so that the waits can be made again without allocating
/// when the stream turns out to carry fewer bands than the takes.
pub(super) struct Separating {
    decision_frames: usize,
    alike: f32,
    max_windows: usize,
    /// Each take's features over 1..=max_windows windows.
    features: Vec<f32>,
    /// Per ordered pair of patterns and window, their most alike takes' similarity,
    /// of the pairs of takes that waiting can part.
    most_alike: Vec<f32>,
    /// One pair of takes' similarity over 1..=max_windows windows.
    pair_alike: Vec<f32>,
}

impl Separating {
    /// For `templates` of `patterns` with decision windows of `decision_frames`.
    pub(super) fn new(
        templates: usize,
        patterns: usize,
        decision_frames: usize,
        alike: f32,
        max_windows: usize,
    ) -> Self {
        Self {
            decision_frames,
            alike,
            max_windows,
            features: vec![0.0; templates * max_windows * FEATURES],
            most_alike: vec![0.0; patterns * patterns * max_windows],
            pair_alike: vec![0.0; max_windows],
        }
    }

    /// The waits of `templates` (as many as this was made for) compared through
    /// `cepstrum`, into `out` (patterns × patterns).
    pub(super) fn waits(
        &mut self,
        templates: &[Template],
        kinds: &[PatternKind],
        cepstrum: &Cepstrum,
        out: &mut [u8],
    ) {
        let (decision_frames, alike, max_windows) =
            (self.decision_frames, self.alike, self.max_windows);
        let n = kinds.len();
        // Each take's features over 1..=max_windows windows, made once.
        let mut power = [0.0f32; BANDS];
        let features = &mut self.features[..templates.len() * max_windows * FEATURES];
        for (t, chunk) in templates
            .iter()
            .zip(features.chunks_exact_mut(max_windows * FEATURES))
        {
            for (w, out) in chunk.chunks_exact_mut(FEATURES).enumerate() {
                window_power(t, w + 1, decision_frames, &mut power);
                features_of_power(&power, cepstrum, out);
            }
        }
        let of = |t: usize, w: usize| &features[(t * max_windows + w - 1) * FEATURES..][..FEATURES];
        let most_alike = &mut self.most_alike[..n * n * max_windows];
        most_alike.fill(f32::NEG_INFINITY);
        let pair_alike = &mut self.pair_alike[..max_windows];
        let takes = templates.iter().map(|t| t.take + 1).max().unwrap_or(0);
        let of_take = |take: usize| {
            templates
                .iter()
                .enumerate()
                .filter(move |(_, t)| t.take == take)
        };
        for a in 0..takes {
            for b in a + 1..takes {
                // Two takes are as alike as the most alike of their placements.
                pair_alike.fill(f32::NEG_INFINITY);
                let mut patterns = None;
                for (i, ta) in of_take(a) {
                    for (j, tb) in of_take(b) {
                        let (p, q) = (ta.pattern, tb.pattern);
                        if p == q
                            || kinds[p] != PatternKind::Impulse
                            || kinds[q] != PatternKind::Impulse
                        {
                            continue;
                        }
                        patterns = Some((p, q));
                        for (w, s) in pair_alike.iter_mut().enumerate() {
                            *s = s.max(similarity(of(i, w + 1), of(j, w + 1)));
                        }
                    }
                }
                let Some((p, q)) = patterns else { continue };
                // Waiting gains such a pair nothing: it does not keep the others from
                // being told apart.
                if pair_alike[0] >= alike && windows_that_part(pair_alike, alike) == 1 {
                    continue;
                }
                for (x, y) in [(p, q), (q, p)] {
                    let m = &mut most_alike[(x * n + y) * max_windows..][..max_windows];
                    for (m, &s) in m.iter_mut().zip(pair_alike.iter()) {
                        *m = m.max(s);
                    }
                }
            }
        }
        for (pair, windows) in out.iter_mut().enumerate().take(n * n) {
            *windows = windows_that_part(&most_alike[pair * max_windows..][..max_windows], alike);
        }
    }
}

/// Over how many windows two takes whose similarities over 1, 2, ... windows are
/// `by_window` are told apart ([`Separating`]): 1 if they are not alike to begin with;
/// the fewest after which they are not; the windows that part them most, if they stay
/// alike but part by `PARTING_DROP`; 1 if they stay alike however long.
fn windows_that_part(by_window: &[f32], alike: f32) -> u8 {
    if by_window[0] < alike {
        1
    } else if let Some(w) = by_window.iter().position(|&s| s < alike) {
        (w + 1) as u8
    } else {
        let mut most_parted = 0;
        for (w, &s) in by_window.iter().enumerate() {
            if s < by_window[most_parted] {
                most_parted = w;
            }
        }
        if by_window[most_parted] <= by_window[0] - PARTING_DROP {
            (most_parted + 1) as u8
        } else {
            1
        }
    }
}

/// What [`take_features`] finds in one take.
pub(super) struct TakeFeatures {
    /// Normalised decision frames from the onset...
    pub(super) features: Vec<f32>,
    /// ...from their mean power spectrum (linear).
    pub(super) pooled_power: Vec<f32>,
    /// Energy of the samples in the decision window from the onset.
    pub(super) early_energy: f64,
    /// Mean frame after the onset (for sustained sounds)...
    pub(super) mean_frame: Vec<f32>,
    /// ...over this many frames.
    pub(super) mean_frames: usize,
    /// As `pooled_power` and `early_energy` from every later frame of the take.
    pub(super) later_power: Vec<f32>,
    pub(super) later_energy: Vec<f64>,
}

/// Features of one take from its onset (`onset_in_take`, from [`take_placements`]): runs
/// the same analysis over the take (after a little silence) as over a stream.
pub(super) fn take_features(
    analyzer: &mut Analyzer,
    take: &[f32],
    decision_frames: usize,
    onset_in_take: usize,
) -> TakeFeatures {
    let hop = analyzer.hop;
    let win = analyzer.win;
    let lead = win;
    let tail = (decision_frames + 2 * MAX_SHIFT + 2) * hop + win;
    let mut padded = vec![0.0f32; lead + take.len() + tail];
    padded[lead..lead + take.len()].copy_from_slice(take);
    let n_frames = (padded.len() - win) / hop + 1;
    let mut frames = vec![0.0f32; n_frames * BANDS];
    for f in 0..n_frames {
        let (a, b) = (f * hop, f * hop + win);
        let mut frame = vec![0.0f32; BANDS];
        analyzer.frame(&padded[a..b], &mut frame);
        frames[f * BANDS..(f + 1) * BANDS].copy_from_slice(&frame);
    }
    let onset = analyzer.frame_centred_on((lead + onset_in_take) as u64) as usize;
    let onset = onset.min(n_frames - 1);
    let early_len = decision_frames * hop;
    let onset_sample = lead + onset_in_take;
    let power_from = |first: usize, power: &mut [f32]| {
        pool_power(
            decision_frames,
            |k| {
                let f = (first + k).min(n_frames - 1);
                &frames[f * BANDS..(f + 1) * BANDS]
            },
            power,
        )
    };
    let energy_from = |start: usize| -> f64 {
        padded[start.min(padded.len())..(start + early_len).min(padded.len())]
            .iter()
            .map(|&x| f64::from(x) * f64::from(x))
            .sum()
    };
    let mut pooled_power = vec![0.0f32; BANDS];
    power_from(onset, &mut pooled_power);
    let mut features = vec![0.0f32; FEATURES];
    features_of_power(&pooled_power, &analyzer.cepstrum, &mut features);
    let early_energy = energy_from(onset_sample);
    let take_frames_end = ((lead + take.len()).saturating_sub(win) / hop)
        .max(onset + 1)
        .min(n_frames);
    let mut mean = vec![0.0f32; BANDS];
    let count = take_frames_end - onset;
    for f in onset..take_frames_end {
        for (m, x) in mean.iter_mut().zip(&frames[f * BANDS..(f + 1) * BANDS]) {
            *m += x / count as f32;
        }
    }
    let later = count - 1;
    let mut later_energy = vec![0.0f64; later];
    let mut later_power = vec![0.0f32; later * BANDS];
    for k in 1..=later {
        power_from(onset + k, &mut later_power[(k - 1) * BANDS..k * BANDS]);
        later_energy[k - 1] = energy_from(onset_sample + k * hop);
    }
    TakeFeatures {
        features,
        pooled_power,
        early_energy,
        mean_frame: mean,
        mean_frames: count,
        later_power,
        later_energy,
    }
}

/// The highest frequency the takes carry when they were band-limited on their way in
/// (a 16 kHz source resampled to 48 kHz before it was saved): where the loudest frames,
/// band by band over every take, fall off a filter's edge ([`Passband`]); infinite when
/// they do not. The input a take was recorded through is the one its user performs
/// through, so the stream is taken to carry no more until it shows otherwise.
pub(super) fn takes_carry_under_hz<'a>(
    analyzer: &mut Analyzer,
    takes: impl IntoIterator<Item = &'a [f32]>,
    rate: f64,
) -> f64 {
    let (win, hop) = (analyzer.win, analyzer.hop);
    let mut passband = Passband::new(rate);
    let mut frame = [0.0f32; BANDS];
    for take in takes {
        let mut start = 0;
        while start + win <= take.len() {
            analyzer.frame(&take[start..start + win], &mut frame);
            passband.push(&analyzer.power);
            start += hop;
        }
    }
    passband.top_hz()
}

/// An onset within a take is another attack of it when its sound rises this far (dB)
/// out of the take's sound over this span before it (from, to; seconds before the
/// onset): the rise the quiet-before gate asks of a stream's new sound
/// (`GateParams::pre_quiet_db`, `PRE_QUIET_FROM_SECONDS` and `PRE_QUIET_TO_SECONDS`).
const ATTACK_RISE_DB: f32 = 10.0;
const ATTACK_BEFORE_SECONDS: (f64, f64) = (0.040, 0.005);

/// Enrolment's quiet room lies this far (dB) under a take's quietest 5 ms, so that
/// every part of the take stands out of its noise (`take_placements`).
const ONSET_ABOVE_FLOOR_DB: f32 = 15.0;

/// Where a stream places a take's onset, and the attacks a quiet room finds in it
/// ([`take_placements`]).
pub(super) struct TakePlacements {
    /// The take's onset...
    pub first: usize,
    /// ...and where a quiet room places it, when that differs.
    pub quiet_room: Option<usize>,
    /// The attacks that the quiet room finds in the take, samples from its start, in
    /// order: where it places the take's onset, then each later onset on sound within
    /// `TAKE_ONSET_RANGE_DB` of its loudest that rises `ATTACK_RISE_DB` out of the take
    /// before it. A sound made of one sound repeated (a teeth chatter, a tongue trill,
    /// a snare roll) has several.
    pub attacks: Vec<usize>,
}

/// Where a stream places a take's onset, in samples: the take is run through the
/// stream's own stages (onset detection and placement) after [`probe_lead_seconds`] of
/// noise, and the first onset placed on sound within `TAKE_ONSET_RANGE_DB` of the
/// take's loudest is its onset. Where that lies depends on the room: a spoken "pew" opens with a "p" 20
/// dB below its vowel, found in a quiet room and lost in the noise of a loud one. So
/// it is placed twice: in the loudest room the take allows (noise at the power of its
/// quietest 5 ms, which is sound, as takes are cut close), and in one quiet enough for
/// every part of the take to stand `ONSET_ABOVE_FLOOR_DB` out. Gives the first
/// placement, the second when it differs by more than a hop, and the attacks that the
/// quiet room finds in the take. A take the onset
/// stage finds nothing in is placed on its first block within `ONSET_RANGE_DB` of its
/// loudest. On the development sets a quiet room's placement raised the mean F1 from
/// 0.786 to 0.804 (D4_voice_m7 0.744 to 0.887, D4_voice_rpf1 0.741 to 0.891) and let
/// two more of those voices' words in speech pass for their patterns (rooms 5 and 10
/// dB quieter besides changed nothing; louder ones let speech through:
/// `docs/onset-stage.md`).
pub(super) fn take_placements(
    take: &[f32],
    settings: &DetectorSettings,
    hop: usize,
) -> TakePlacements {
    let fallback = first_block_within(take, hop, ONSET_RANGE_DB as f32);
    let rate = f64::from(settings.sample_rate);
    let block = ((0.005 * rate) as usize).max(1);
    let powers: Vec<f32> = take
        .chunks(block)
        .map(|c| c.iter().map(|v| v * v).sum::<f32>() / c.len() as f32)
        .collect();
    let quietest = powers.iter().cloned().fold(f32::INFINITY, f32::min);
    let loudest = powers.iter().cloned().fold(0.0f32, f32::max);
    if loudest.is_nan() || loudest <= 0.0 {
        return TakePlacements {
            first: fallback,
            quiet_room: None,
            attacks: Vec::new(),
        };
    }
    let loud_room = quietest.max(loudest * 1e-9);
    let quiet_room = loud_room * 10f32.powf(-ONSET_ABOVE_FLOOR_DB / 10.0);
    let placed = |noise_power| probe_onsets(take, settings, noise_power, &powers, block);
    let first = placed(loud_room).first().copied().unwrap_or(fallback);
    let placed_quietly = placed(quiet_room);
    let second = placed_quietly
        .first()
        .copied()
        .filter(|&at| at.abs_diff(first) > hop);
    // The onsets after the first that rise out of the sound before them as a new
    // sound of a stream must (the quiet-before gate's rise, over its span).
    let rises = |previous: usize, at: usize| {
        let loudest = |from: usize, to: usize| {
            powers[(from / block).min(powers.len() - 1)..=(to / block).min(powers.len() - 1)]
                .iter()
                .cloned()
                .fold(0.0f32, f32::max)
        };
        let span = |seconds: f64| (seconds * rate) as usize;
        // From no earlier than half-way since the last placement: a sound repeated
        // faster than the span (a fast chatter) would have its last attack in it, where
        // a stream hears that attack's fired sound, not quiet.
        let to = at.saturating_sub(span(ATTACK_BEFORE_SECONDS.1));
        let from = at
            .saturating_sub(span(ATTACK_BEFORE_SECONDS.0))
            .max(previous + (at - previous) / 2)
            .min(to);
        let before = loudest(from, to);
        let after = loudest(at, at + block);
        after >= before * 10f32.powf(ATTACK_RISE_DB / 10.0)
    };
    let attacks: Vec<usize> = placed_quietly
        .iter()
        .enumerate()
        .filter(|&(k, &at)| k == 0 || rises(placed_quietly[k - 1], at))
        .map(|(_, &at)| at)
        .collect();
    TakePlacements {
        first,
        quiet_room: second,
        attacks,
    }
}

/// The onsets a stream places on `take` after [`probe_lead_seconds`] of white noise of
/// power `noise_power`, on sound within `TAKE_ONSET_RANGE_DB` of the take's loudest, in
/// order; samples from the take's start. `powers` are the take's mean powers over
/// blocks of `block` samples.
fn probe_onsets(
    take: &[f32],
    settings: &DetectorSettings,
    noise_power: f32,
    powers: &[f32],
    block: usize,
) -> Vec<usize> {
    let rate = f64::from(settings.sample_rate);
    let loudest = powers.iter().cloned().fold(0.0f32, f32::max);
    let lead = (probe_lead_seconds() * rate) as usize;
    // Uniform in ±a has power a²/3.
    let amplitude = (3.0 * noise_power).sqrt();
    let mut signal = white_noise(lead, amplitude, NOISE_SEED);
    signal.extend_from_slice(take);
    let placed = placed_onsets(&signal, rate);
    let wanted = loudest * 10f32.powf(-TAKE_ONSET_RANGE_DB / 10.0);
    // The power of the 5-10 ms from a sample on.
    let power_at = |at: usize| {
        let i = at / block;
        powers[i.min(powers.len() - 1)].max(powers[(i + 1).min(powers.len() - 1)])
    };
    // An onset placed a little before the take's first sample (the take was cut on its
    // burst) is at its start.
    let early_slack = (0.005 * rate) as usize;
    placed
        .iter()
        .map(|&at| at as usize)
        .filter(|&at| at + early_slack >= lead)
        .map(|at| at.saturating_sub(lead))
        .filter(|&at| at < take.len() && power_at(at) >= wanted)
        .collect()
}

/// Where a stream places the onsets of `signal` (at `rate`), samples: the features,
/// onset and placement stages as the spectral matcher runs them, frame by frame, and on
/// into silence after it, so that an onset in its last frames is placed too (as a
/// stream's end is).
fn placed_onsets(signal: &[f32], rate: f64) -> Vec<u64> {
    let hop = Analyzer::hop_at(rate);
    let mut placer = Placer::new(hop);
    let mut placed = Vec::new();
    let sample = |n: u64| signal.get(n as usize).copied().unwrap_or(0.0);
    let tail = PLACE_AFTER_FRAMES as usize + 2;
    run_onset_stage(signal, rate, OnsetParams::default(), tail, |step| {
        if let Some(onset) = step.onset {
            placer.detected(onset.frame);
        }
        // Without the condition on the room's noise: with it, the loud room moves
        // some takes' onsets past a soft first consonant, and an unheard voice's
        // "pop" was then taken for its "pew" (`docs/onset-stage.md`).
        while let Some(at) = placer.next(step.frames, step.consumed, 0, 0.0, sample) {
            placed.push(at);
        }
    });
    placed
}

/// The noise a take is streamed after, seconds: the onset stage's longest memory for
/// a first onset (its recent mean, `OnsetParams::mean_seconds`) and a frame's window,
/// so that the take's first onset is judged against the noise alone. 0.3 s, as it
/// was, gives the same table on every dev set (two strengths of D3 differ), and
/// building a detector took half as long again (README, Performance).
fn probe_lead_seconds() -> f64 {
    OnsetParams::default().mean_seconds + WINDOW_SECONDS
}

/// A held sound's soft start: sound within this many dB of its loudest...
pub(super) const SOFT_ONSET_RANGE_DB: f32 = 30.0;
/// ...that begins this long before the take's onset gets a template of its own.
pub(super) const SOFT_ONSET_GAP_SECONDS: f64 = 0.01;

/// A streamed onset must lie on sound within this many dB of the take's loudest to be
/// the take's: not on the room before it. The onset stage finds the "p" of a spoken
/// "ping" 25-35 dB under its vowel in a stream, so a take's onset must be allowed there
/// too (on the development sets 35, 40, 45 and 60 dB give the same figures; 25 dB
/// loses exact copies: docs/onset-stage.md).
const TAKE_ONSET_RANGE_DB: f32 = 40.0;

/// First window of about 1.5 ms (at 22 kHz; `hop / 2` samples) within `range_db` of
/// the loudest block of the first 150 ms of `take`: its onset (`ONSET_RANGE_DB`), or
/// its soft start (`SOFT_ONSET_RANGE_DB`).
pub(super) fn first_block_within(take: &[f32], hop: usize, range_db: f32) -> usize {
    let head = take.len().min((0.15 / HOP_SECONDS * hop as f64) as usize) as u64;
    let block = (hop as u64 / 2).max(1);
    let wanted = |loudest: f64| loudest * 10f64.powf(-f64::from(range_db) / 10.0);
    first_window_within(0, head, block, |n| take[n as usize], wanted).map_or(0, |n| n as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::white_noise;

    /// [`Separating::waits`] over decision windows of 5 frames, pairs alike at 0.7.
    fn waits(
        templates: &[Template],
        kinds: &[PatternKind],
        cepstrum: &Cepstrum,
        max_windows: usize,
    ) -> Vec<u8> {
        let n = kinds.len();
        let mut out = vec![0; n * n];
        Separating::new(templates.len(), n, 5, 0.7, max_windows)
            .waits(templates, kinds, cepstrum, &mut out);
        out
    }

    fn settings() -> DetectorSettings {
        DetectorSettings {
            method: crate::config::Method::Spectral,
            ..DetectorSettings::default()
        }
    }

    /// `ms` of a tone of `amplitude` under a decay, as a burst or a vowel.
    fn tone(rate: f64, ms: f64, hz: f64, amplitude: f32) -> Vec<f32> {
        let n = (ms / 1000.0 * rate) as usize;
        (0..n)
            .map(|i| {
                let t = i as f64 / rate;
                amplitude * ((2.0 * std::f64::consts::PI * hz * t).sin() * (-t / 0.08).exp()) as f32
            })
            .collect()
    }

    #[test]
    fn takes_band_limited_on_their_way_in_carry_only_their_band() {
        let rate = f64::from(settings().sample_rate);
        let mut analyzer = Analyzer::new(rate);
        let hiss = white_noise(4096, 0.3, 7);
        let boom = tone(rate, 150.0, 120.0, 0.5);
        // A full band, a low sound alone (its spectrum falls, but as a sound does), and
        // both at 16 kHz brought back to the working rate: cut where the 16 kHz
        // resampler's passband ends.
        assert_eq!(
            takes_carry_under_hz(&mut analyzer, [&hiss[..], &boom[..]], rate),
            f64::INFINITY
        );
        assert_eq!(
            takes_carry_under_hz(&mut analyzer, [&boom[..]], rate),
            f64::INFINITY
        );
        let narrow = |x: &[f32]| {
            let at_16_khz = crate::audio::resample_clip(x, rate as u32, 16_000).unwrap();
            crate::audio::resample_clip(&at_16_khz, 16_000, rate as u32).unwrap()
        };
        let (hiss, boom) = (narrow(&hiss), narrow(&boom));
        let carried = takes_carry_under_hz(&mut analyzer, [&hiss[..], &boom[..]], rate);
        let passband = crate::audio::resampler_passband() * 8_000.0;
        assert!(
            (passband..passband + 1_000.0).contains(&carried),
            "{carried} Hz, passband to {passband} Hz"
        );
    }

    #[test]
    fn a_take_that_starts_loud_is_placed_once_at_its_start() {
        let s = settings();
        let rate = f64::from(s.sample_rate);
        let take = tone(rate, 150.0, 200.0, 0.5);
        let hop = Analyzer::new(rate).hop;
        let TakePlacements {
            first,
            quiet_room: second,
            ..
        } = take_placements(&take, &s, hop);
        assert!(first <= 2 * hop, "placed at {first}");
        assert_eq!(second, None);
    }

    #[test]
    fn a_soft_first_consonant_is_placed_where_a_quiet_room_finds_it() {
        // A "p" 20 dB under its vowel, 40 ms before it (a spoken "pew").
        let s = settings();
        let rate = f64::from(s.sample_rate);
        let mut take = tone(rate, 40.0, 3000.0, 0.05);
        let vowel_at = take.len();
        take.extend(tone(rate, 200.0, 250.0, 0.5));
        let hop = Analyzer::new(rate).hop;
        let TakePlacements {
            first,
            quiet_room: second,
            ..
        } = take_placements(&take, &s, hop);
        // As loud a room as the take allows hides the "p": placed on the vowel.
        assert!(
            first.abs_diff(vowel_at) <= 2 * hop,
            "{first} against {vowel_at}"
        );
        // A quiet room finds the "p".
        let early = second.expect("a second placement");
        assert!(early <= 2 * hop, "{early}");
    }

    #[test]
    fn a_take_of_several_attacks_is_placed_on_each() {
        let s = settings();
        let rate = f64::from(s.sample_rate);
        let hop = Analyzer::new(rate).hop;
        // One tone: one attack, however it fades.
        let tone_take = tone(rate, 150.0, 200.0, 0.5);
        assert_eq!(take_placements(&tone_take, &s, hop).attacks, vec![0]);
        let attacks_ms = |gaps_ms: &[f64], room: f64| {
            let attacks = take_placements(&clicks(rate, gaps_ms, room), &s, hop).attacks;
            attacks
                .iter()
                .map(|&a| a as f64 / rate * 1000.0)
                .collect::<Vec<_>>()
        };
        let placed_on = |ms: &[f64], at: &[f64]| {
            ms.len() == at.len() && ms.iter().zip(at).all(|(m, c)| (m - c).abs() <= 3.0)
        };
        // Four clicks 100, 130 and 110 ms apart (a teeth chatter), in digital silence.
        let ms = attacks_ms(&[100.0, 130.0, 110.0, 40.0], 0.0);
        assert!(placed_on(&ms, &[0.0, 100.0, 230.0, 340.0]), "{ms:?}");
        // Six clicks 45 ms apart (a fast chatter) in a room 60 dB down: each rises out
        // of the quiet since the last, though the last lies within the 40 ms the rise
        // looks back over.
        let ms = attacks_ms(&[45.0; 6], 1e-3);
        assert!(
            placed_on(&ms, &[0.0, 45.0, 90.0, 135.0, 180.0, 225.0]),
            "{ms:?}"
        );
    }

    /// Clicks, bursts of noise dying away within 4 ms, each `gaps_ms` before the next,
    /// over white noise of RMS `room`.
    fn clicks(rate: f64, gaps_ms: &[f64], room: f64) -> Vec<f32> {
        let ends: Vec<usize> = gaps_ms
            .iter()
            .scan(0.0, |at, gap_ms| {
                *at += gap_ms;
                Some((*at * rate / 1000.0) as usize)
            })
            .collect();
        let len = ends.last().copied().unwrap_or(0);
        // Uniform noise of RMS `room` is `room` times the root of 3 at its peaks.
        let mut x = white_noise(len, (room * 3f64.sqrt()) as f32, 7);
        let click_len = (0.004 * rate) as usize;
        for (k, start) in std::iter::once(0)
            .chain(ends)
            .take(gaps_ms.len())
            .enumerate()
        {
            let burst = white_noise(click_len, 0.5, 11 + k as u64);
            for (i, b) in burst.iter().enumerate() {
                x[start + i] += b * (-(i as f64) / (0.0008 * rate)).exp() as f32;
            }
        }
        x
    }

    /// A template of pattern `pattern` from `take`, placed at its start.
    fn template(analyzer: &mut Analyzer, take: &[f32], pattern: usize) -> Template {
        let t = take_features(analyzer, take, 5, 0);
        Template {
            pattern,
            take: pattern,
            second_placement: false,
            features: t.features,
            pooled_power: t.pooled_power,
            drawn_towards: None,
            early_energy: t.early_energy,
            length_after_onset: take.len() as u64,
            after_earlier: 0,
            soft_start_share: 0.0,
            later_power: t.later_power,
            later_energy: t.later_energy,
            repeats_every: None,
        }
    }

    /// A take of pattern `pattern` with the given features (unit norm) and nothing else.
    fn take_of(pattern: usize, features: &[f32]) -> Template {
        let mut padded = vec![0.0; FEATURES];
        padded[..features.len()].copy_from_slice(features);
        scale_to_unit(&mut padded);
        Template {
            pattern,
            take: 0,
            second_placement: false,
            features: padded,
            pooled_power: vec![0.0; BANDS],
            drawn_towards: None,
            early_energy: 0.0,
            length_after_onset: 0,
            after_earlier: 0,
            soft_start_share: 0.0,
            later_power: Vec::new(),
            later_energy: Vec::new(),
            repeats_every: None,
        }
    }

    #[test]
    fn takes_agree_as_far_as_the_least_typical_one_lies_from_the_others() {
        let kinds = [
            PatternKind::Impulse,
            PatternKind::Impulse,
            PatternKind::Impulse,
            PatternKind::Continuous,
        ];
        let mut templates = vec![
            // Pattern 0: two takes at an angle whose cosine is 0.6; each, left out,
            // meets the other alone, drawn towards itself.
            take_of(0, &[1.0, 0.0]),
            take_of(0, &[0.6, 0.8]),
            // Pattern 1: one take, and a second placement of it, which is no take.
            take_of(1, &[0.0, 0.0, 1.0]),
            // Pattern 2: three takes, two alike and one apart.
            take_of(2, &[0.0, 0.0, 0.0, 1.0]),
            take_of(2, &[0.0, 0.0, 0.0, 1.0]),
            take_of(2, &[0.0, 0.0, 0.0, 0.0, 1.0]),
            // A held pattern's two templates (its soft start and its sound).
            take_of(3, &[1.0]),
            take_of(3, &[0.0, 1.0]),
        ];
        templates.push(Template {
            second_placement: true,
            ..take_of(1, &[0.0, 1.0])
        });
        let mut agree = [TakesAgree::NONE; 4];
        takes_agreement(&templates, &kinds, &mut agree);
        assert!((agree[0].score - 0.6).abs() < 1e-6, "{agree:?}");
        assert_eq!(agree[1], TakesAgree::NONE);
        assert_eq!(agree[3], TakesAgree::NONE);
        // The take apart, left out, meets the mean of the two alike: drawn towards
        // that mean, each is that mean, at right angles to it. It is the least typical.
        assert!(agree[2].score.abs() < 1e-6, "{agree:?}");
        assert_eq!(agree[2].least_typical, 2);
        // Each of the two alike, left out, finds the other as it is.
        templates.truncate(5);
        takes_agreement(&templates, &kinds[..3], &mut agree[..3]);
        assert!((agree[2].score - 1.0).abs() < 1e-6, "{agree:?}");
    }

    #[test]
    fn a_pair_alike_at_first_waits_for_the_windows_that_part_it_and_no_other_does() {
        let rate = f64::from(settings().sample_rate);
        let mut analyzer = Analyzer::new(rate);
        // Three sounds open with the same 40 ms burst: two go on with different
        // vowels ("pop", "pew"), the third with nothing (a click).
        let burst = white_noise((0.04 * rate) as usize, 0.3, 5);
        let then = |vowel: Vec<f32>| -> Vec<f32> { burst.iter().copied().chain(vowel).collect() };
        let pop = then(tone(rate, 150.0, 250.0, 0.5));
        let pew = then(tone(rate, 150.0, 2500.0, 0.5));
        let click = burst.clone();
        // A knock and the same knock a little quieter: alike however long.
        let knock = tone(rate, 150.0, 900.0, 0.5);
        let softer: Vec<f32> = knock.iter().map(|x| 0.8 * x).collect();
        let takes = [pop, pew, click, knock, softer];
        let templates: Vec<Template> = takes
            .iter()
            .enumerate()
            .map(|(p, take)| template(&mut analyzer, take, p))
            .collect();
        let kinds = vec![PatternKind::Impulse; takes.len()];
        let wait = waits(&templates, &kinds, &analyzer.cepstrum, 3);
        let n = takes.len();
        let pair = |p: usize, q: usize| wait[p * n + q];
        // One window (26 ms of sound) holds the burst only; the later ones, the vowels.
        assert!((2..=3).contains(&pair(0, 1)), "{wait:?}");
        assert_eq!(pair(1, 0), pair(0, 1));
        // Waiting no longer than one window, nothing waits.
        let one = waits(&templates, &kinds, &analyzer.cepstrum, 1);
        assert!(one.iter().all(|&w| w == 1), "{one:?}");
        // The burst alone parts from a vowel's sound later as well.
        assert!(pair(0, 2) > 1, "{wait:?}");
        // Never parted: no wait; never alike: no wait; a pattern with itself: none.
        assert_eq!(pair(3, 4), 1);
        assert_eq!(pair(0, 3), 1);
        assert!((0..n).all(|p| pair(p, p) == 1));
        // Held patterns are never waited for.
        let mut held = kinds.clone();
        held[1] = PatternKind::Continuous;
        let wait = waits(&templates, &held, &analyzer.cepstrum, 3);
        assert_eq!(wait[1], 1);
    }

    #[test]
    fn a_pair_that_stays_alike_but_parts_far_waits_for_the_windows_that_part_it_most() {
        let rate = f64::from(settings().sample_rate);
        let mut analyzer = Analyzer::new(rate);
        // A breathy "p" nearly as long as the whole wait: over three windows the vowels
        // are only beginning, so the takes stay alike (0.81 with a 42 ms burst), but far
        // less than over one (1.00). With a 45 ms burst they part by 0.0004 only.
        let mut wait = |burst_seconds: f64, max_windows: usize| {
            let burst = white_noise((burst_seconds * rate) as usize, 0.3, 5);
            let then =
                |vowel: Vec<f32>| -> Vec<f32> { burst.iter().copied().chain(vowel).collect() };
            let takes = [
                then(tone(rate, 150.0, 250.0, 0.5)),
                then(tone(rate, 150.0, 2500.0, 0.5)),
            ];
            let templates: Vec<Template> = takes
                .iter()
                .enumerate()
                .map(|(p, take)| template(&mut analyzer, take, p))
                .collect();
            let kinds = [PatternKind::Impulse; 2];
            let w = waits(&templates, &kinds, &analyzer.cepstrum, max_windows);
            assert_eq!(w[1], w[2], "{w:?}");
            w[1]
        };
        assert_eq!(wait(0.042, 3), 3);
        assert_eq!(wait(0.045, 3), 1);
        // Over the first two windows the vowels have not begun: nothing parts them.
        assert_eq!(wait(0.042, 2), 1);
    }

    #[test]
    fn a_pair_of_takes_that_never_parts_does_not_keep_the_others_from_waiting() {
        let rate = f64::from(settings().sample_rate);
        let mut analyzer = Analyzer::new(rate);
        // Two takes each of a "pop" and a "pew": said briskly (a 20 ms "p"), they part
        // within three windows; said slowly (a "p" of 60 ms), they stay alike over all
        // three, and waiting makes them no less alike.
        let said = |burst_seconds: f64, hz: f64| -> Vec<f32> {
            let burst = white_noise((burst_seconds * rate) as usize, 0.3, 5);
            burst
                .into_iter()
                .chain(tone(rate, 150.0, hz, 0.5))
                .collect()
        };
        let takes = [
            (0, said(0.02, 250.0)),
            (0, said(0.06, 250.0)),
            (1, said(0.02, 2500.0)),
            (1, said(0.06, 2500.0)),
        ];
        let kinds = [PatternKind::Impulse; 2];
        let mut wait_of = |which: &[usize]| {
            let templates: Vec<Template> = which
                .iter()
                .map(|&k| Template {
                    take: k,
                    ..template(&mut analyzer, &takes[k].1, takes[k].0)
                })
                .collect();
            let w = waits(&templates, &kinds, &analyzer.cepstrum, 3);
            assert_eq!(w[1], w[2], "{w:?}");
            w[1]
        };
        let brisk = wait_of(&[0, 2]);
        assert!(brisk > 1, "{brisk}");
        assert_eq!(wait_of(&[1, 3]), 1);
        // All four: the slow pair is left out, the brisk one decides.
        assert_eq!(wait_of(&[0, 1, 2, 3]), brisk);
    }

    #[test]
    fn a_take_gives_unit_features_and_one_later_template_per_frame() {
        let s = settings();
        let rate = f64::from(s.sample_rate);
        let take = tone(rate, 120.0, 400.0, 0.5);
        let mut analyzer = Analyzer::new(rate);
        let hop = analyzer.hop;
        let t = take_features(&mut analyzer, &take, 5, 0);
        let norm: f32 = t.features.iter().map(|v| v * v).sum::<f32>().sqrt();
        assert!((norm - 1.0).abs() < 1e-4, "{norm}");
        assert_eq!(t.later_power.len(), t.later_energy.len() * BANDS);
        // Frames whose window lies in the take after the first, give or take one.
        let expected = (take.len() - analyzer.win) / hop;
        assert!(
            t.later_energy.len().abs_diff(expected) <= 2,
            "{} against {expected}",
            t.later_energy.len()
        );
        // The decision window's energy is the take's first 5 hops'.
        let energy: f64 = take[..5 * hop]
            .iter()
            .map(|&x| f64::from(x) * f64::from(x))
            .sum();
        assert!((t.early_energy - energy).abs() < 1e-6 * energy.max(1.0));
    }
}
