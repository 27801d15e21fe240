//! The quietest each of a few channels has been over a last stretch of frames (minimum
//! statistics, after Martin, "Noise power spectral density estimation based on optimal
//! smoothing and minimum statistics", 2001): the level stage's floors rise slowly, so
//! that no sound lifts them, and a channel that has not come down to its floor once in
//! the stretch is no longer over the room: the room is at least its quietest value
//! since (`levels::ROOM_WINDOW_SECONDS`). Kept as the minima of `BLOCKS` blocks of
//! frames, so that each frame costs one comparison per channel. Runs on the detector
//! thread, inside the level stage; allocates only in `new`.

/// Blocks the window is kept in: the window reaches back between `window` and
/// `window` plus a block's frames.
const BLOCKS: usize = 4;

pub(super) struct RecentMinimum {
    channels: usize,
    /// Frames a block holds (0: never a minimum).
    block_frames: usize,
    /// Each channel's minimum over each of the last `BLOCKS` whole blocks, block by
    /// block (`channels` values each), a ring whose next slot is `next`.
    past: Vec<f32>,
    next: usize,
    whole_blocks: usize,
    /// Each channel's minimum over the block being filled, and its frames so far.
    current: Vec<f32>,
    in_current: usize,
}

impl RecentMinimum {
    /// For `channels` values a frame, over at least `window` frames (0: none is ever
    /// known, and [`Self::over_window`] says nothing).
    pub(super) fn new(channels: usize, window: usize) -> Self {
        Self {
            channels,
            block_frames: window.div_ceil(BLOCKS),
            past: vec![f32::INFINITY; channels * BLOCKS],
            next: 0,
            whole_blocks: 0,
            current: vec![f32::INFINITY; channels],
            in_current: 0,
        }
    }

    /// The next frame's value of channel `c`; [`Self::end_frame`] after the frame's last.
    pub(super) fn push(&mut self, c: usize, value: f32) {
        let m = &mut self.current[c];
        // A value that is not a number holds nothing (and compares as no minimum).
        if value < *m {
            *m = value;
        }
    }

    pub(super) fn end_frame(&mut self) {
        if self.block_frames == 0 {
            return;
        }
        self.in_current += 1;
        if self.in_current == self.block_frames {
            let slot = self.next * self.channels;
            self.past[slot..slot + self.channels].copy_from_slice(&self.current);
            self.current.fill(f32::INFINITY);
            self.in_current = 0;
            self.next = (self.next + 1) % BLOCKS;
            self.whole_blocks = (self.whole_blocks + 1).min(BLOCKS);
        }
    }

    /// The least value of channel `c` over the window and the frames since, once the
    /// window has been heard whole.
    pub(super) fn over_window(&self, c: usize) -> Option<f32> {
        if self.whole_blocks < BLOCKS {
            return None;
        }
        let least = (0..BLOCKS)
            .map(|b| self.past[b * self.channels + c])
            .fold(self.current[c], f32::min);
        least.is_finite().then_some(least)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn feed(m: &mut RecentMinimum, values: &[f32]) {
        for &v in values {
            m.push(0, v);
            m.end_frame();
        }
    }

    #[test]
    fn nothing_is_known_before_the_window_has_been_heard() {
        let mut m = RecentMinimum::new(1, 8);
        feed(&mut m, &[3.0; 7]);
        assert_eq!(m.over_window(0), None);
        feed(&mut m, &[3.0]);
        assert_eq!(m.over_window(0), Some(3.0));
        assert_eq!(RecentMinimum::new(1, 0).over_window(0), None);
    }

    #[test]
    fn a_dip_counts_for_a_window_and_at_most_a_block_more() {
        // Window of 8 frames in blocks of 2: a dip is the minimum for at least 8 frames
        // after it and gone within 10.
        let mut m = RecentMinimum::new(1, 8);
        feed(&mut m, &[5.0; 8]);
        feed(&mut m, &[1.0]);
        for frames in 0..8 {
            assert_eq!(m.over_window(0), Some(1.0), "{frames} frames after the dip");
            feed(&mut m, &[5.0]);
        }
        feed(&mut m, &[5.0; 2]);
        assert_eq!(m.over_window(0), Some(5.0));
    }

    #[test]
    fn channels_are_kept_apart() {
        let mut m = RecentMinimum::new(2, 4);
        for f in 0..4 {
            m.push(0, f as f32);
            m.push(1, 10.0 - f as f32);
            m.end_frame();
        }
        assert_eq!(m.over_window(0), Some(0.0));
        assert_eq!(m.over_window(1), Some(7.0));
    }
}
