//! Small streaming statistics used by the matchers: a trailing sliding maximum, a
//! trailing moving average, and a ring of cumulative frame energies. Each has a fixed
//! capacity set at construction and never allocates afterwards.
//!
//! Runs on the detector thread, inside the matcher.

/// Maximum over the last `width` values (monotonic deque in a fixed ring).
pub struct SlidingMax {
    width: u64,
    values: Vec<f32>,
    positions: Vec<u64>,
    head: usize,
    len: usize,
    next_pos: u64,
}

impl SlidingMax {
    pub fn new(width: usize) -> Self {
        let width = width.max(1);
        Self {
            width: width as u64,
            values: vec![0.0; width + 1],
            positions: vec![0; width + 1],
            head: 0,
            len: 0,
            next_pos: 0,
        }
    }

    /// Adds a value and returns the maximum of the last `width` values.
    pub fn push(&mut self, v: f32) -> f32 {
        let cap = self.values.len();
        let pos = self.next_pos;
        self.next_pos += 1;
        // Drop smaller values from the back: they can never be the maximum again.
        while self.len > 0 {
            let back = (self.head + self.len - 1) % cap;
            if self.values[back] <= v {
                self.len -= 1;
            } else {
                break;
            }
        }
        let slot = (self.head + self.len) % cap;
        self.values[slot] = v;
        self.positions[slot] = pos;
        self.len += 1;
        // Drop the front once it has left the window.
        while self.positions[self.head] + self.width <= pos {
            self.head = (self.head + 1) % cap;
            self.len -= 1;
        }
        self.values[self.head]
    }
}

/// Mean of the last `width` values (fewer at the start).
pub struct MovingAverage {
    ring: Vec<f32>,
    next: usize,
    count: usize,
    sum: f64,
}

impl MovingAverage {
    pub fn new(width: usize) -> Self {
        Self {
            ring: vec![0.0; width.max(1)],
            next: 0,
            count: 0,
            sum: 0.0,
        }
    }

    pub fn push(&mut self, v: f32) -> f32 {
        let old = self.ring[self.next];
        self.ring[self.next] = v;
        self.next = (self.next + 1) % self.ring.len();
        if self.count == self.ring.len() {
            self.sum -= f64::from(old);
        } else {
            self.count += 1;
        }
        self.sum += f64::from(v);
        (self.sum / self.count as f64) as f32
    }
}

/// Energy of the stream in short frames, kept as cumulative sums at frame boundaries for
/// the most recent `capacity` frames.
pub struct FrameEnergies {
    frame_len: usize,
    cum: Vec<f64>,
    /// Complete frames so far; boundary `complete` is the newest stored.
    complete: u64,
    partial: f64,
    partial_len: usize,
    total: f64,
}

impl FrameEnergies {
    pub fn new(frame_len: usize, capacity: usize) -> Self {
        Self {
            frame_len: frame_len.max(1),
            cum: vec![0.0; capacity.max(2)],
            complete: 0,
            partial: 0.0,
            partial_len: 0,
            total: 0.0,
        }
    }

    pub fn frame_len(&self) -> usize {
        self.frame_len
    }

    /// Number of complete frames.
    pub fn complete(&self) -> u64 {
        self.complete
    }

    pub fn push(&mut self, samples: &[f32]) {
        for &x in samples {
            self.partial += f64::from(x) * f64::from(x);
            self.partial_len += 1;
            if self.partial_len == self.frame_len {
                self.total += self.partial;
                self.complete += 1;
                let slot = (self.complete % self.cum.len() as u64) as usize;
                self.cum[slot] = self.total;
                self.partial = 0.0;
                self.partial_len = 0;
            }
        }
    }

    /// Oldest frame whose energy is still known.
    pub fn oldest(&self) -> u64 {
        (self.complete + 1).saturating_sub(self.cum.len() as u64)
    }

    /// Cumulative energy before frame `f` (boundary `f`), if still stored.
    pub fn boundary(&self, f: u64) -> Option<f64> {
        if f > self.complete || f < self.oldest() {
            return None;
        }
        if f == 0 {
            return Some(0.0);
        }
        Some(self.cum[(f % self.cum.len() as u64) as usize])
    }

    /// Energy of frame `f`, if complete and still stored.
    pub fn frame(&self, f: u64) -> Option<f64> {
        Some(self.boundary(f + 1)? - self.boundary(f)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sliding_max_matches_brute_force() {
        let data: Vec<f32> = (0..500).map(|i| ((i * 7919) % 101) as f32 - 50.0).collect();
        for width in [1, 2, 5, 33] {
            let mut m = SlidingMax::new(width);
            for (i, &v) in data.iter().enumerate() {
                let got = m.push(v);
                let lo = (i + 1).saturating_sub(width);
                let want = data[lo..=i].iter().cloned().fold(f32::MIN, f32::max);
                assert_eq!(got, want, "width {width} at {i}");
            }
        }
    }

    #[test]
    fn moving_average_matches_brute_force() {
        let data: Vec<f32> = (0..200).map(|i| (i % 13) as f32 * 0.25).collect();
        let mut m = MovingAverage::new(10);
        for (i, &v) in data.iter().enumerate() {
            let got = m.push(v);
            let lo = (i + 1).saturating_sub(10);
            let want = data[lo..=i].iter().sum::<f32>() / (i + 1 - lo) as f32;
            assert!((got - want).abs() < 1e-5, "at {i}: {got} vs {want}");
        }
    }

    #[test]
    fn frame_energies_sum_squares_and_forget_old_frames() {
        let mut f = FrameEnergies::new(4, 8);
        let samples: Vec<f32> = (0..40).map(|i| i as f32 * 0.1).collect();
        // Cut into uneven blocks: framing must not depend on them.
        f.push(&samples[..3]);
        f.push(&samples[3..17]);
        f.push(&samples[17..]);
        assert_eq!(f.complete(), 10);
        let want: f64 = samples[36..40].iter().map(|&x| f64::from(x * x)).sum();
        assert!((f.frame(9).unwrap() - want).abs() < 1e-4);
        assert!(f.frame(10).is_none(), "frame 10 is not complete");
        assert!(f.frame(1).is_none(), "frame 1 has left the ring");
        assert!(f.frame(f.oldest()).is_some());
    }
}
