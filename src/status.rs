//! [`Status`]: the daemon's counters and levels, shared by every thread through
//! atomics (the capture callback, the detector, output and main threads). A leaf: it
//! depends on nothing of the crate, so the daemon and the output can both use it.

use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

/// Counters and levels shared by the threads. Writers never block.
#[derive(Debug, Default)]
pub struct Status {
    pub(crate) stream_samples: AtomicU64,
    pub(crate) captured_frames: AtomicU64,
    pub(crate) bad_samples: AtomicU64,
    pub(crate) clipped_samples: AtomicU64,
    pub(crate) input_rate: AtomicU32,
    pub(crate) overrun_samples: AtomicU64,
    pub(crate) dropped_events: AtomicU64,
    pub(crate) xruns: AtomicU64,
    pub(crate) level_db_bits: AtomicU32,
    /// Each performer's level (its channel), as `level_db_bits`.
    pub(crate) lane_level_db_bits: [AtomicU32; MAX_LANES],
}

/// Performers whose level is kept (the config allows no more).
pub const MAX_LANES: usize = 8;

impl Status {
    /// Stream time the detector has reached, seconds.
    pub fn stream_seconds(&self) -> f64 {
        let rate = self.input_rate.load(Ordering::Relaxed);
        if rate == 0 {
            return 0.0;
        }
        self.stream_samples.load(Ordering::Relaxed) as f64 / f64::from(rate)
    }
    /// Frames the audio device delivered to the capture callback (counted there).
    pub fn captured_frames(&self) -> u64 {
        self.captured_frames.load(Ordering::Relaxed)
    }
    pub(crate) fn add_captured(&self, frames: u64) {
        self.captured_frames.fetch_add(frames, Ordering::Relaxed);
    }
    /// Input samples the detector replaced: not numbers (taken as 0) or beyond full
    /// scale (clamped).
    pub fn bad_samples(&self) -> u64 {
        self.bad_samples.load(Ordering::Relaxed)
    }
    /// Input samples that reached full scale (clipped): the input gain is too high.
    pub fn clipped_samples(&self) -> u64 {
        self.clipped_samples.load(Ordering::Relaxed)
    }
    /// Samples the capture could not put in the ring.
    pub fn overrun_samples(&self) -> u64 {
        self.overrun_samples.load(Ordering::Relaxed)
    }
    pub(crate) fn add_overrun(&self, n: u64) {
        self.overrun_samples.fetch_add(n, Ordering::Relaxed);
    }
    /// Overruns and underruns the audio device reported.
    pub fn xruns(&self) -> u64 {
        self.xruns.load(Ordering::Relaxed)
    }
    pub(crate) fn add_xrun(&self) {
        self.xruns.fetch_add(1, Ordering::Relaxed);
    }
    /// Events the output thread could not take (queue full).
    pub fn dropped_events(&self) -> u64 {
        self.dropped_events.load(Ordering::Relaxed)
    }
    /// Peak level of the last block read, dBFS.
    pub fn level_db(&self) -> f32 {
        f32::from_bits(self.level_db_bits.load(Ordering::Relaxed))
    }
    /// Peak level of performer `lane`'s channel in the last block read, dBFS.
    pub fn lane_level_db(&self, lane: usize) -> f32 {
        self.lane_level_db_bits
            .get(lane)
            .map_or(-120.0, |b| f32::from_bits(b.load(Ordering::Relaxed)))
    }
}
