//! The held stage: how long a held sound (an onset classified as a continuous pattern)
//! lasts. It is held while each frame still resembles its pattern's sustained spectrum
//! (the centred, unit-norm mean frame of the takes after their onsets) and stays within
//! `drop_db` of its loudest frame; it ends after `gap_seconds` of frames that do not.
//! Knows frames and levels only: the matcher begins a held sound, feeds it every frame
//! and turns the sound that ended into an event (with the pitch stage's estimate). A
//! sound that ends says why ([`HeldEnd`], for `analyze --explain`).
//!
//! Runs on the detector thread, inside the spectral matcher; allocates nothing.

/// Settings of the held stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldParams {
    /// A frame holds the sound only within this many dB of the sound's loudest frame.
    pub drop_db: f32,
    /// The sound ends after this long without a frame that holds it.
    pub gap_seconds: f64,
    /// A frame must resemble the sustained spectrum at least this much (or the
    /// pattern's `continuous_threshold`, when higher). Lower, speech holds a sung "hooo"
    /// through whole words: on the paragraph of `scripts/eval-speech.sh` a "hooo" held
    /// over "The morning" for 0.58 s at 0.3, hiding the speech after it from the speech
    /// guard (3 false events in 48 s at 0.3, 2 at 0.5).
    pub min_similarity: f32,
}

/// A sound goes on while its frames stay within this many dB of its loudest: the held
/// stage's default, and where the context stage takes a recognised impulse's sound to
/// be dying away ([`super::context`]).
pub(super) const SOUND_DROP_DB: f32 = 20.0;

impl Default for HeldParams {
    fn default() -> Self {
        Self {
            drop_db: SOUND_DROP_DB,
            gap_seconds: 0.030,
            min_similarity: 0.5,
        }
    }
}

/// Why a held sound ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum HeldEnd {
    /// Its frames fell `drop_db` under its loudest.
    Faded,
    /// Its frames stopped resembling its pattern's sustained spectrum.
    Unlike,
    /// A held sound began (of any pattern: one held sound at a time).
    Replaced,
    /// The stream ended while it went on.
    StreamEnded,
}

impl HeldEnd {
    /// The name `--explain` prints.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Faded => "faded",
            Self::Unlike => "unlike",
            Self::Replaced => "replaced",
            Self::StreamEnded => "stream_ended",
        }
    }
}

/// A held sound going on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Held {
    pub pattern: usize,
    pub begin_sample: u64,
    /// The score its onset was classified with.
    pub score: f32,
    loudest_db: f32,
    last_good_frame: u64,
    /// Why the first frame after the last good one did not hold it.
    first_miss: Option<HeldEnd>,
    /// Once it has ended: why.
    ended_by: Option<HeldEnd>,
}

impl Held {
    /// The last frame that held the sound.
    pub fn last_good_frame(&self) -> u64 {
        self.last_good_frame
    }

    /// Why it ended, once it has: the first way a frame after its last good one failed
    /// to hold it (a fall of `drop_db` counts before a frame unlike its spectrum), a
    /// held sound that began, or the stream's end.
    pub fn ended_by(&self) -> Option<HeldEnd> {
        self.ended_by
    }

    /// The same sound, ended for `why`.
    fn ending(self, why: HeldEnd) -> Self {
        Self {
            ended_by: Some(why),
            ..self
        }
    }
}

/// The held sound going on, if any.
pub(super) struct HeldStage {
    params: HeldParams,
    gap_frames: u64,
    current: Option<Held>,
}

impl HeldStage {
    pub fn new(params: HeldParams, hop_seconds: f64) -> Self {
        Self {
            params,
            gap_frames: (params.gap_seconds / hop_seconds) as u64,
            current: None,
        }
    }

    pub fn params(&self) -> HeldParams {
        self.params
    }

    pub fn current(&self) -> Option<&Held> {
        self.current.as_ref()
    }

    /// A held sound of `pattern` begins at `begin_sample`; `frame` is the newest frame
    /// and `loudest_db` the loudest level since the onset. Returns the sound that was
    /// going on, which this one ends.
    pub fn begin(
        &mut self,
        pattern: usize,
        begin_sample: u64,
        score: f32,
        loudest_db: f32,
        frame: u64,
    ) -> Option<Held> {
        let going = self.current.replace(Held {
            pattern,
            begin_sample,
            score,
            loudest_db,
            last_good_frame: frame,
            first_miss: None,
            ended_by: None,
        });
        going.map(|h| h.ending(HeldEnd::Replaced))
    }

    /// Frame `f` (`frame_db`, its bands in dB, at `level_db`), against the going
    /// sound's `sustain` and its pattern's `continuous_threshold`. Returns the sound
    /// when this frame ends it.
    pub fn follow(
        &mut self,
        f: u64,
        frame_db: &[f32],
        level_db: f32,
        sustain: &[f32],
        continuous_threshold: f32,
    ) -> Option<Held> {
        let h = self.current.as_mut()?;
        h.loudest_db = h.loudest_db.max(level_db);
        let alike = sustain_similarity(frame_db, sustain)
            >= continuous_threshold.max(self.params.min_similarity);
        let loud = level_db >= h.loudest_db - self.params.drop_db;
        if alike && loud {
            h.last_good_frame = f;
            h.first_miss = None;
        } else if h.first_miss.is_none() {
            h.first_miss = Some(if loud {
                HeldEnd::Unlike
            } else {
                HeldEnd::Faded
            });
        }
        if f > h.last_good_frame + self.gap_frames {
            let miss = h.first_miss.unwrap_or(HeldEnd::Unlike);
            self.current.take().map(|h| h.ending(miss))
        } else {
            None
        }
    }

    /// Ends the going sound (the stream ended, or the detector stops).
    pub fn end(&mut self) -> Option<Held> {
        self.current.take().map(|h| h.ending(HeldEnd::StreamEnded))
    }
}

/// How much a frame (bands in dB) resembles a sustained spectrum (centred and of unit
/// norm): the cosine of the centred frame with it, the Pearson correlation of the two.
pub(super) fn sustain_similarity(frame_db: &[f32], sustain: &[f32]) -> f32 {
    let mean = frame_db.iter().sum::<f32>() / frame_db.len().max(1) as f32;
    let (mut norm, mut dot) = (0.0f32, 0.0f32);
    for (x, s) in frame_db.iter().zip(sustain) {
        let c = x - mean;
        norm += c * c;
        dot += c * s;
    }
    if norm > 1e-9 {
        dot / norm.sqrt()
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOP: f64 = 0.003;
    const BANDS: usize = 8;

    /// A centred, unit-norm spectral shape.
    fn shape(tilt: f32) -> Vec<f32> {
        let mut s: Vec<f32> = (0..BANDS).map(|b| tilt * b as f32).collect();
        let mean = s.iter().sum::<f32>() / BANDS as f32;
        s.iter_mut().for_each(|x| *x -= mean);
        let norm = s.iter().map(|x| x * x).sum::<f32>().sqrt();
        s.iter_mut().for_each(|x| *x /= norm);
        s
    }

    /// A frame of that shape at `level` dB.
    fn frame(tilt: f32, level: f32) -> Vec<f32> {
        (0..BANDS).map(|b| level + tilt * b as f32).collect()
    }

    /// Feeds `frames` (bands, level) from frame 1 on; the frame at which the sound
    /// ended and its last good frame.
    fn run(
        stage: &mut HeldStage,
        frames: &[(Vec<f32>, f32)],
        threshold: f32,
    ) -> Option<(u64, u64)> {
        ended(stage, frames, threshold).map(|(at, h)| (at, h.last_good_frame()))
    }

    /// As [`run`], the sound that ended.
    fn ended(
        stage: &mut HeldStage,
        frames: &[(Vec<f32>, f32)],
        threshold: f32,
    ) -> Option<(u64, Held)> {
        let sustain = shape(-3.0);
        stage.begin(0, 0, 0.9, frames[0].1, 0);
        for (i, (f, level)) in frames.iter().enumerate() {
            let at = i as u64 + 1;
            if let Some(h) = stage.follow(at, f, *level, &sustain, threshold) {
                return Some((at, h));
            }
        }
        None
    }

    #[test]
    fn a_sound_of_the_sustained_shape_is_held_and_ends_a_gap_after_its_last_frame() {
        let mut stage = HeldStage::new(HeldParams::default(), HOP);
        let gap = (0.030 / HOP) as u64;
        let mut frames = vec![(frame(-3.0, -20.0), -20.0); 100];
        frames.extend(vec![(frame(4.0, -20.0), -20.0); 50]);
        let (at, h) = ended(&mut stage, &frames, 0.3).expect("it ends");
        assert_eq!((at, h.last_good_frame()), (100 + gap + 1, 100));
        assert_eq!(h.ended_by(), Some(HeldEnd::Unlike));
        assert!(stage.current().is_none());
    }

    #[test]
    fn a_sound_that_falls_further_than_drop_db_under_its_loudest_ends() {
        let mut stage = HeldStage::new(HeldParams::default(), HOP);
        let mut frames = vec![(frame(-3.0, -10.0), -10.0); 40];
        // The same shape, 25 dB down: no longer the sound.
        frames.extend(vec![(frame(-3.0, -35.0), -35.0); 40]);
        let (_, h) = ended(&mut stage, &frames, 0.3).expect("it ends");
        assert_eq!(h.last_good_frame(), 40);
        assert_eq!(h.ended_by(), Some(HeldEnd::Faded));
        // 15 dB down, it goes on.
        let mut stage = HeldStage::new(HeldParams::default(), HOP);
        let mut frames = vec![(frame(-3.0, -10.0), -10.0); 40];
        frames.extend(vec![(frame(-3.0, -25.0), -25.0); 40]);
        assert_eq!(run(&mut stage, &frames, 0.3), None);
    }

    #[test]
    fn the_pattern_threshold_rules_when_it_is_above_the_stage_minimum() {
        let sustain = shape(-3.0);
        // A frame that resembles the shape at about 0.8.
        let mut near = frame(-3.0, -20.0);
        near[0] -= 12.0;
        let similarity = sustain_similarity(&near, &sustain);
        assert!((0.6..0.95).contains(&similarity), "{similarity}");
        let frames = vec![(near, -20.0); 60];
        let mut lenient = HeldStage::new(HeldParams::default(), HOP);
        assert_eq!(run(&mut lenient, &frames, 0.3), None);
        let mut strict = HeldStage::new(HeldParams::default(), HOP);
        assert!(run(&mut strict, &frames, 0.98).is_some());
    }

    #[test]
    fn a_new_held_sound_ends_the_one_going_on() {
        let mut stage = HeldStage::new(HeldParams::default(), HOP);
        assert_eq!(stage.begin(0, 100, 0.9, -20.0, 3), None);
        let ended = stage.begin(1, 900, 0.8, -20.0, 9).expect("the first one");
        assert_eq!((ended.pattern, ended.begin_sample), (0, 100));
        assert_eq!(ended.ended_by(), Some(HeldEnd::Replaced));
        assert_eq!(stage.current().map(|h| h.pattern), Some(1));
        let last = stage.end().expect("the second one");
        assert_eq!(last.begin_sample, 900);
        assert_eq!(last.ended_by(), Some(HeldEnd::StreamEnded));
        assert_eq!(stage.end(), None);
    }

    #[test]
    fn a_flat_frame_resembles_nothing() {
        assert_eq!(sustain_similarity(&[-30.0; BANDS], &shape(-3.0)), 0.0);
        let s = shape(-3.0);
        assert!((sustain_similarity(&frame(-3.0, 7.0), &s) - 1.0).abs() < 1e-5);
    }
}
