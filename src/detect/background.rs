//! Background stage: how near an onset is to ordinary speech. Owns the built-in
//! background model, the features of every onset that stands out of its own quiet in
//! some minutes of speech by other synthetic voices, in English and three other
//! languages (none of them a voice of the development sets). An onset nearer to one of
//! them than to every take of its best pattern (by a margin) is taken for speech, not
//! for the pattern. The model is fixed, so no decision of the detector can feed it.
//!
//! The model is made by `scripts/background-speech.sh` (espeak-ng and sox) and
//! `cargo run --release --example background_model`, and embedded at build time. Its
//! features are pooled over the decision window it was made with; a detector with
//! another `decision_seconds` does not use it. A user's own recordings of sounds that
//! must never fire (their talking, the room; `background` in `[detector.spectral]`) are
//! pooled by the matcher that uses them and joined to it ([`BackgroundModel::joined`]).
//!
//! Runs on the detector thread, inside the spectral matcher; parses the model in `new`
//! and allocates nothing afterwards.

use std::sync::{Arc, OnceLock};

use super::features::{Cepstrum, FEATURES};

/// The built-in model (see the module comment).
const BUILTIN: &[u8] = include_bytes!("background.bin");

/// Leading bytes of a model file.
const MAGIC: &[u8; 4] = b"ONBG";

/// Adds the least noise any input carries to `samples` (full scale 1): white noise
/// with the power of one step of 16-bit audio (2^-15, -90.3 dB of full scale), the same
/// every run. The built-in model's speech is heard over it: a synthesiser writes
/// digital silence between phrases, which no microphone delivers, and the stages take
/// such silence for a room of its own, out of which every faint sound after a pause
/// rises and would be pooled as speech. From -90 to -70 dB the model and the figures
/// stand alike; with no noise the model pools a quarter more sounds and stops more
/// real hits (`docs/background.md`, "The model made again, over the least noise an
/// input carries").
pub fn add_least_input_noise(samples: &mut [f32]) {
    // Uniform noise in ±a has power a² / 3.
    let amplitude = 3f32.sqrt() / 32_768.0;
    let noise = super::white_noise(samples.len(), amplitude, super::NOISE_SEED);
    for (x, n) in samples.iter_mut().zip(noise) {
        *x += n;
    }
}

/// Background feature vectors, all of one length and pooled over one number of frames.
#[derive(Debug, Clone, Default)]
pub struct BackgroundModel {
    features: usize,
    decision_frames: usize,
    /// Shared: every matcher (and every take's probe) holds the one built-in copy.
    templates: Arc<[f32]>,
    /// The same templates, `AT_ONCE` at a time, value by value
    /// ([`BackgroundModel::nearest`]); those after the last whole group are left out.
    groups: Arc<[f32]>,
}

/// Templates scored at once: one sum each, in the order one alone is summed in, but
/// side by side, so that the additions of eight sums go together instead of waiting one
/// for another.
const AT_ONCE: usize = 8;

/// `templates` (of `features` values each) as [`BackgroundModel::groups`] keeps them.
fn fill_groups(templates: &[f32], features: usize, groups: &mut [f32]) {
    let whole = features * AT_ONCE;
    for (group, block) in groups
        .chunks_exact_mut(whole)
        .zip(templates.chunks_exact(whole))
    {
        for (j, template) in block.chunks_exact(features).enumerate() {
            for (k, &x) in template.iter().enumerate() {
                group[k * AT_ONCE + j] = x;
            }
        }
    }
}

impl BackgroundModel {
    /// The model embedded in the program, parsed once.
    pub fn builtin() -> Self {
        static PARSED: OnceLock<BackgroundModel> = OnceLock::new();
        // The embedded file is made by this module's own `to_bytes`; a file that does
        // not parse is a build defect, caught by the tests.
        PARSED
            .get_or_init(|| Self::from_bytes(BUILTIN).unwrap_or_default())
            .clone()
    }

    /// `templates` are unit-norm vectors of `features` values each, pooled over
    /// `decision_frames` frames.
    pub fn new(features: usize, decision_frames: usize, templates: Vec<f32>) -> Self {
        let whole = features.max(1) * AT_ONCE;
        let mut groups = vec![0.0; templates.len() / whole * whole];
        fill_groups(&templates, features.max(1), &mut groups);
        Self {
            features,
            decision_frames,
            templates: templates.into(),
            groups: groups.into(),
        }
    }

    pub fn len(&self) -> usize {
        self.templates.len() / self.features.max(1)
    }

    /// Values per template, and the frames they were pooled over.
    pub fn shape(&self) -> (usize, usize) {
        (self.features, self.decision_frames)
    }

    /// Every template's values, one after the other.
    pub fn templates(&self) -> &[f32] {
        &self.templates
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The model if it was pooled as a matcher with `features` values over
    /// `decision_frames` frames pools; an empty one otherwise.
    pub fn for_matcher(self, features: usize, decision_frames: usize) -> Self {
        if self.features == features && self.decision_frames == decision_frames {
            self
        } else {
            Self::default()
        }
    }

    /// A model of its own templates, which [`Self::compare_on`] can make again in place.
    pub(super) fn own_copy(&self) -> Self {
        Self::new(self.features, self.decision_frames, self.templates.to_vec())
    }

    /// This model made again as a matcher that compares only `cepstrum`'s bands sees
    /// `full` (of as many templates, pooled over every band): each template taken
    /// through [`Cepstrum::refeature_into`]. In place when this model's templates are
    /// its own ([`Self::own_copy`]), as a matcher's are: while a stream runs, without
    /// allocating.
    pub(super) fn compare_on(&mut self, full: &Self, cepstrum: &Cepstrum) {
        debug_assert!(
            full.is_empty() || full.features == FEATURES,
            "a model pooled as a matcher pools"
        );
        if Arc::get_mut(&mut self.templates).is_none_or(|own| own.len() != full.templates.len())
            || Arc::get_mut(&mut self.groups).is_none()
        {
            *self = full.own_copy();
        }
        if let (Some(own), Some(groups)) = (
            Arc::get_mut(&mut self.templates),
            Arc::get_mut(&mut self.groups),
        ) {
            cepstrum.refeature_into(&full.templates, own);
            fill_groups(own, self.features.max(1), groups);
        }
    }

    /// This model's templates and `other`'s, which must be pooled alike (an empty
    /// model takes the other's shape).
    pub fn joined(&self, other: &BackgroundModel) -> Self {
        if self.is_empty() {
            return other.clone();
        }
        if other.is_empty() {
            return self.clone();
        }
        debug_assert_eq!(
            self.shape(),
            other.shape(),
            "background models pooled alike"
        );
        let templates = self.templates.iter().chain(other.templates.iter());
        Self::new(
            self.features,
            self.decision_frames,
            templates.copied().collect(),
        )
    }

    /// The best similarity (cosine) of `instance` with any template; minus infinity
    /// for an empty model.
    pub fn nearest(&self, instance: &[f32]) -> f32 {
        let features = self.features.max(1);
        let n = features.min(instance.len());
        // Each side by side sum keeps its own best (a sum that is not a number never is).
        let mut bests = [f32::NEG_INFINITY; AT_ONCE];
        for group in self.groups.chunks_exact(features * AT_ONCE) {
            let mut sums = [-0.0f32; AT_ONCE];
            for (values, &x) in group.chunks_exact(AT_ONCE).zip(&instance[..n]) {
                for (sum, &v) in sums.iter_mut().zip(values) {
                    *sum += v * x;
                }
            }
            for (best, sum) in bests.iter_mut().zip(sums) {
                *best = best.max(sum);
            }
        }
        let best = bests.into_iter().fold(f32::NEG_INFINITY, f32::max);
        self.templates[self.groups.len()..]
            .chunks_exact(features)
            .map(|t| dot(t, instance))
            .fold(best, f32::max)
    }

    /// The file format: `ONBG`, then little-endian u32 features, decision frames and
    /// count, then every value as i16 (times 32767; the vectors have unit norm).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(16 + 2 * self.templates.len());
        out.extend_from_slice(MAGIC);
        for n in [self.features, self.decision_frames, self.len()] {
            out.extend_from_slice(&(n as u32).to_le_bytes());
        }
        for &x in self.templates.iter() {
            let q = (x.clamp(-1.0, 1.0) * 32767.0).round() as i16;
            out.extend_from_slice(&q.to_le_bytes());
        }
        out
    }

    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        if bytes.len() < 16 || &bytes[..4] != MAGIC {
            return Err("not a background model (no ONBG header)".into());
        }
        let word = |i: usize| {
            u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]) as usize
        };
        let (features, decision_frames, count) = (word(4), word(8), word(12));
        let values = features
            .checked_mul(count)
            .ok_or("background model: too many values")?;
        let body = &bytes[16..];
        if body.len() != 2 * values {
            return Err(format!(
                "background model: expected {values} values of 2 bytes, found {} bytes",
                body.len()
            ));
        }
        let templates: Vec<f32> = body
            .chunks_exact(2)
            .map(|c| f32::from(i16::from_le_bytes([c[0], c[1]])) / 32767.0)
            .collect();
        Ok(Self::new(features, decision_frames, templates))
    }
}

/// The dot product of `a` and `b`, summed in order.
fn dot(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_nearest_template_is_found_to_the_bit_however_many_there_are() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut value = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 23) as f32 - 1.0
        };
        for count in [1, 7, 8, 9, 16, 35] {
            let templates: Vec<f32> = (0..count * 5).map(|_| value()).collect();
            let model = BackgroundModel::new(5, 3, templates.clone());
            for _ in 0..20 {
                let instance: Vec<f32> = (0..5).map(|_| value()).collect();
                let one_by_one = templates
                    .chunks_exact(5)
                    .map(|t| dot(t, &instance))
                    .fold(f32::NEG_INFINITY, f32::max);
                assert_eq!(model.nearest(&instance).to_bits(), one_by_one.to_bits());
            }
        }
    }

    #[test]
    fn a_model_compared_on_fewer_bands_scores_its_new_templates_to_the_bit() {
        use super::super::features::BANDS;
        let full = BackgroundModel::builtin();
        let mut narrow = full.own_copy();
        for bands in [BANDS - 6, BANDS - 12] {
            narrow.compare_on(&full, &Cepstrum::new(bands));
            let probe = &full.templates()[..FEATURES];
            let one_by_one = narrow
                .templates()
                .chunks_exact(FEATURES)
                .map(|t| dot(t, probe))
                .fold(f32::NEG_INFINITY, f32::max);
            assert_eq!(narrow.nearest(probe).to_bits(), one_by_one.to_bits());
            assert_ne!(narrow.templates(), full.templates());
        }
    }

    #[test]
    fn the_builtin_model_parses_and_is_not_empty() {
        let parsed = BackgroundModel::from_bytes(BUILTIN).expect("the embedded model parses");
        assert!(parsed.len() > 100, "{} templates", parsed.len());
        assert!(parsed.features > 0 && parsed.decision_frames > 0);
    }

    #[test]
    fn a_model_survives_its_file_format() {
        let a = [0.6f32, 0.8, 0.0];
        let b = [0.0f32, 0.0, 1.0];
        let model = BackgroundModel::new(3, 5, [a, b].concat());
        let back = BackgroundModel::from_bytes(&model.to_bytes()).unwrap();
        assert_eq!((back.len(), back.features, back.decision_frames), (2, 3, 5));
        assert!((back.nearest(&a) - 1.0).abs() < 1e-4);
        assert!((back.nearest(&[0.0, 1.0, 0.0]) - 0.8).abs() < 1e-4);
        let truncated = &model.to_bytes()[..20];
        assert!(BackgroundModel::from_bytes(truncated).is_err());
    }

    #[test]
    fn joined_models_hold_both_and_an_empty_one_takes_the_others_shape() {
        let a = BackgroundModel::new(3, 5, vec![1.0, 0.0, 0.0]);
        let b = BackgroundModel::new(3, 5, vec![0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        let both = a.joined(&b);
        assert_eq!((both.len(), both.shape()), (3, (3, 5)));
        for probe in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] {
            assert!((both.nearest(&probe) - 1.0).abs() < 1e-6);
        }
        let from_empty = BackgroundModel::default().joined(&b);
        assert_eq!((from_empty.len(), from_empty.shape()), (2, (3, 5)));
        assert_eq!(a.joined(&BackgroundModel::default()).len(), 1);
    }

    #[test]
    fn a_model_pooled_otherwise_is_not_used() {
        let model = BackgroundModel::new(3, 5, vec![1.0, 0.0, 0.0]);
        assert!(model.clone().for_matcher(3, 6).is_empty());
        assert!(model.clone().for_matcher(4, 5).is_empty());
        assert_eq!(model.for_matcher(3, 5).len(), 1);
        assert_eq!(
            BackgroundModel::default().nearest(&[1.0]),
            f32::NEG_INFINITY
        );
    }
}
