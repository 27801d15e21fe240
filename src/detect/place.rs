//! The placement stage: puts each onset that the onset stage detected on the samples.
//! Onset functions peak on the frames' grid, a few milliseconds into an attack; an
//! onset is placed `PLACE_AFTER_FRAMES` frames after its detection, once the attack has
//! arrived, on the first short window of samples within `ONSET_RANGE_DB` of the
//! loudest one since two frames before the detection that stands `OVER_NOISE` times
//! over the room's noise (if any does). Windows slide a sample at a time, so a signal a
//! few samples later gives an onset as many samples later, wherever the frames fall.
//!
//! It knows nothing of patterns or of what became of an onset, so its placements do
//! not depend on any decision. The same stage places a stream's onsets (inside the
//! spectral matcher, on the detector thread) and an enrolled take's
//! ([`super::enrol::take_placements`], on the thread that builds the detector, without the
//! condition on the room's noise): a take's onset lies where a stream in a quiet room
//! would place it. Allocates nothing after `new`.

use super::fifo::Fifo;

/// An onset is placed on the samples this many frames after its detection, once the
/// attack has arrived. Waiting longer lets the loudest so far come nearer the sound's
/// peak; 2 to 4 frames score alike over every dev set, 6 lose knocks, whose loudest
/// part comes at once (`docs/onset-stage.md`).
pub(super) const PLACE_AFTER_FRAMES: u64 = 3;

/// An onset is the first block within this many dB of the sound's loudest. Swept over
/// every dev set from 9 to 20 dB, the mean F1 peaks here; wider ranges fall into the
/// breath before a hit (`docs/onset-stage.md`).
pub(super) const ONSET_RANGE_DB: f64 = 12.0;

/// ...and whose energy is at least this many times the room's noise in as long a window
/// (when some window there is). A sound whose first milliseconds lie within 12 dB of
/// the noise (a fricative at -11 dB in a -50 dB room) would otherwise be placed in the
/// noise before it. A window of `hop / 2` samples of white noise holds some 32 independent
/// samples and never reaches 4 times its mean; noise as narrow as a hum, about two
/// degrees of freedom per window, does once in 50 windows. Swept 2-8 over every dev
/// set: the mean F1 stands level from 3 to 6, and 4 finds the most exact copies of
/// unheard voices' words and of onsets in the loudest noise (`docs/onset-stage.md`).
pub(super) const OVER_NOISE: f64 = 4.0;

/// Onsets detected and not yet placed: at most one per `min_gap_seconds` (20 ms) within
/// `PLACE_AFTER_FRAMES` frames, so a handful would do.
const WAITING: usize = 8;

/// Onsets waiting to be placed, oldest first.
pub(super) struct Placer {
    hop: u64,
    /// Frames at which the waiting onsets were detected. Detections that found the
    /// queue full are counted there (none on any input so far: detections are at least
    /// `min_gap_seconds` apart and wait 3 frames).
    detected: Fifo<u64, WAITING>,
}

impl Placer {
    pub(super) fn new(hop: usize) -> Self {
        Self {
            hop: hop.max(1) as u64,
            detected: Fifo::new(),
        }
    }

    /// The onset stage detected an onset at frame `frame`.
    pub(super) fn detected(&mut self, frame: u64) {
        self.detected.push(frame);
    }

    /// Detections the queue had no room for.
    pub(super) fn dropped(&self) -> u64 {
        self.detected.dropped()
    }

    /// The next onset whose placement is due, once `frames` frames have been computed
    /// and `consumed` samples received (`oldest`: the oldest sample `sample(n)` can
    /// still read; `noise_power`: the room's noise, mean power per sample): its
    /// sample. Call until `None` after every frame.
    pub(super) fn next(
        &mut self,
        frames: u64,
        consumed: u64,
        oldest: u64,
        noise_power: f64,
        sample: impl Fn(u64) -> f32,
    ) -> Option<u64> {
        let detected = self.detected.front()?;
        if frames <= detected + PLACE_AFTER_FRAMES {
            return None;
        }
        self.detected.pop();
        // Two frames before the detection: the frame whose window first held the attack.
        let from = (detected.saturating_sub(2) * self.hop).max(oldest);
        let block = (self.hop / 2).max(1);
        let noise = OVER_NOISE * noise_power * block as f64;
        Some(
            first_window_within(from, consumed, block, sample, |loudest| {
                let range = loudest * 10f64.powf(-ONSET_RANGE_DB / 10.0);
                // Nothing stands out of the noise yet: placed as in a quiet room.
                if loudest < noise {
                    range
                } else {
                    range.max(noise)
                }
            })
            .unwrap_or(from),
        )
    }
}

/// The first start `n` in `[from, to - block]` of a window of `block` samples whose
/// energy reaches `wanted(loudest)`, `loudest` being the greatest such window's energy
/// there. Windows slide a sample at a time, so a signal shifted by some samples gives
/// an onset shifted by as many, whatever the frames' grid (`sample(n)` reads sample
/// `n`; nothing is allocated).
pub(super) fn first_window_within(
    from: u64,
    to: u64,
    block: u64,
    sample: impl Fn(u64) -> f32,
    wanted: impl Fn(f64) -> f64,
) -> Option<u64> {
    if to < from + block {
        return None;
    }
    let power = |n: u64| f64::from(sample(n)).powi(2);
    let mut energy: f64 = (from..from + block).map(power).sum();
    let mut loudest = energy;
    for n in from + block..to {
        energy += power(n) - power(n - block);
        loudest = loudest.max(energy);
    }
    let wanted = wanted(loudest);
    let mut energy: f64 = (from..from + block).map(power).sum();
    if energy >= wanted && energy > 0.0 {
        return Some(from);
    }
    for n in from + block..to {
        energy += power(n) - power(n - block);
        if energy >= wanted && energy > 0.0 {
            return Some(n + 1 - block);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOP: usize = 64;

    /// Quiet, then a burst from sample `at` on.
    fn burst_at(at: usize, len: usize) -> Vec<f32> {
        (0..len)
            .map(|n| if n >= at { 0.5 } else { 0.001 })
            .collect()
    }

    #[test]
    fn an_onset_is_placed_on_its_attack_three_frames_after_its_detection() {
        let x = burst_at(1000, 4000);
        let mut placer = Placer::new(HOP);
        // The onset function peaks in the frame after the one whose window reached the
        // attack.
        let detected = 1000 / HOP as u64 + 1;
        placer.detected(detected);
        let at = |frames: u64| {
            let consumed = (frames - 1) * HOP as u64 + 256;
            (consumed, frames)
        };
        let (consumed, frames) = at(detected + PLACE_AFTER_FRAMES);
        assert_eq!(
            placer.next(frames, consumed, 0, 0.0, |n| x[n as usize]),
            None
        );
        let (consumed, frames) = at(detected + PLACE_AFTER_FRAMES + 1);
        let placed = placer.next(frames, consumed, 0, 0.0, |n| x[n as usize]);
        // The first 32-sample window within 12 dB of one full of the burst holds 3 of
        // its samples (2 are 0.06 of its power, 3 are 0.09; -12 dB is 0.063).
        assert_eq!(placed, Some(1000 - 29));
        assert_eq!(
            placer.next(frames, consumed, 0, 0.0, |n| x[n as usize]),
            None
        );
    }

    #[test]
    fn a_signal_later_by_some_samples_is_placed_later_by_as_many() {
        let place = |at: usize| {
            let x = burst_at(at, 4000);
            let mut placer = Placer::new(HOP);
            let detected = at as u64 / HOP as u64 + 1;
            placer.detected(detected);
            let frames = detected + PLACE_AFTER_FRAMES + 1;
            let consumed = (frames - 1) * HOP as u64 + 256;
            placer
                .next(frames, consumed, 0, 0.0, |n| x[n as usize])
                .unwrap()
        };
        // Same frame of detection, the burst 5 samples later.
        assert_eq!(place(1029) - place(1024), 5);
    }

    #[test]
    fn a_sound_that_begins_as_loud_as_the_noise_is_placed_where_it_rises_out_of_it() {
        // The room's noise: power 1 per sample. From 800 a sound as loud as the noise
        // (power 2 with it), from 1000 its body (power 9), 9.5 dB over its beginning.
        let x: Vec<f32> = (0..4000)
            .map(|n| {
                let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
                sign * match n {
                    0..800 => 1.0f32,
                    800..1000 => 2f32.sqrt(),
                    _ => 3.0,
                }
            })
            .collect();
        let place = |noise_power: f64| {
            let mut placer = Placer::new(HOP);
            let detected = 1000 / HOP as u64 + 1;
            placer.detected(detected);
            let frames = detected + PLACE_AFTER_FRAMES + 1;
            let consumed = (frames - 1) * HOP as u64 + 256;
            placer
                .next(frames, consumed, 0, noise_power, |n| x[n as usize])
                .unwrap()
        };
        // In a silent room the beginning is within 12 dB of the body: the onset goes
        // to the start of the search, two frames before the detection.
        assert_eq!(place(0.0), (1000 / HOP as u64 - 1) * HOP as u64);
        // Over this noise, the first 32-sample window 4 times the noise holds 10
        // samples of the body (9 * 10 + 2 * 22 = 134 >= 128; 9 of them give 127).
        assert_eq!(place(1.0), 1000 - 22);
        // In noise louder than a quarter of the body nothing stands out yet: placed as
        // in a silent room.
        assert_eq!(place(2.5), place(0.0));
    }

    #[test]
    fn onsets_are_placed_in_their_order_and_a_full_queue_counts_what_it_drops() {
        let x = burst_at(0, 40_000);
        let mut placer = Placer::new(HOP);
        for k in 0..WAITING as u64 + 2 {
            placer.detected(10 + 10 * k);
        }
        assert_eq!(placer.dropped(), 2);
        let consumed = 30_000;
        let mut last = 0;
        for _ in 0..WAITING {
            let placed = placer
                .next(1_000, consumed, 0, 0.0, |n| x[n as usize])
                .unwrap();
            assert!(placed > last || last == 0, "{placed} after {last}");
            last = placed;
        }
        assert_eq!(
            placer.next(1_000, consumed, 0, 0.0, |n| x[n as usize]),
            None
        );
    }
}
