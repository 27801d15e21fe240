//! The paper's matcher (`method = "waveform"`), streaming. For every take p of every
//! pattern, gamma(t) = <s[t..t+M], p> / (|p| |s[t..t+M]|), so a perfect match is 1. The
//! correlations are computed by FFT overlap-save: one forward FFT of each segment of the
//! stream is shared by all takes, each take costs one complex product and one inverse FFT.
//!
//! Impulse instances (the paper's rule): a local maximum of gamma_i at t_k above the
//! pattern's threshold, with no greater local maximum of any take's gamma within
//! [t_k - Δt/2, t_k + Δt/2], Δt the take's length (or `suppression_seconds`).
//! Strength: sqrt(energy(s[t_k..t_k+M]) / energy(p)).
//!
//! Continuous instances: the score is the best take's gamma, smoothed by a 20 ms sliding
//! maximum (one pitch period, so a periodic match is not lost between its peaks) and a
//! 30 ms moving average; an instance is a span where that stays above the lower
//! threshold and whose best gamma passes the pattern's threshold. Since gamma at t looks
//! at s[t..t+M], the span's ends are placed at the signal itself: the first and last
//! 2.5 ms frames, near the span's ends, within 12 dB of the sound's loudest frame.
//! Strength compares mean power over the span with the pattern's mean power.
//!
//! Runs on the detector thread. FFT plans, scratch and all buffers are made in
//! [`WaveformMatcher::new`]; `push` allocates nothing (unless a score trace is enabled).

use std::sync::Arc;

use realfft::num_complex::Complex32;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};

use super::envelope::{FrameEnergies, MovingAverage, SlidingMax};
use super::Event;
use crate::config::{DetectorSettings, PatternKind};
use crate::pattern::Pattern;

/// Windows quieter than this RMS (dBFS) count as this loud, so silence does not divide by 0.
const SILENCE_FLOOR_DBFS: f64 = -70.0;
/// Smallest FFT segment.
const MIN_FFT_LEN: usize = 1024;
/// Segment length as a multiple of the longest take (then rounded up to a power of two).
const FFT_LEN_PER_TAKE_LEN: usize = 2;
const ENVELOPE_SECONDS: f64 = 0.020;
const AVERAGE_SECONDS: f64 = 0.030;
const FRAME_SECONDS: f64 = 0.0025;
/// A frame belongs to a continuous sound when its energy is within 12 dB of the loudest.
const SPAN_LEVEL_RATIO: f64 = 1.0 / 16.0;
/// Continuous spans waiting for their end to be placed.
const MAX_CLOSING_SPANS: usize = 8;

/// Recorded match scores of one take (see [`super::Detector::enable_score_trace`]).
#[derive(Debug, Clone)]
pub struct TakeTrace {
    pub pattern: Arc<str>,
    /// Index of the take within its pattern.
    pub take: usize,
    /// gamma(t) for t = 0, 1, ... at the working rate.
    pub scores: Vec<f32>,
}

struct Template {
    pattern: usize,
    len: usize,
    energy: f64,
    /// conj(FFT(p)) / (|p| * fft_len): the product's inverse FFT is <s, p> / |p|.
    spectrum: Vec<Complex32>,
    silence_floor: f64,
    half_window: u64,
    /// Signed squared score q at the last two positions of the previous segment.
    prev: f32,
    prev_prev: f32,
    prev_energy: f64,
    continuous_slot: Option<usize>,
}

#[derive(Debug, Clone, Copy)]
struct Peak {
    template: usize,
    t: u64,
    value: f32,
    window_energy: f64,
    decided: bool,
}

struct PatternInfo {
    name: Arc<str>,
    kind: PatternKind,
    threshold: f32,
}

#[derive(Clone, Copy)]
struct SpanOpen {
    begin_sample: u64,
    begin_cum: f64,
    best_score: f32,
    best_template: usize,
}

#[derive(Clone, Copy)]
struct SpanClosing {
    open: SpanOpen,
    end_pos: u64,
}

/// Per continuous pattern: best take's gamma for the current segment and the span state.
struct SpanTracker {
    pattern: usize,
    low: f32,
    high: f32,
    max_len: u64,
    score: Vec<f32>,
    best_template: Vec<usize>,
    envelope: SlidingMax,
    average: MovingAverage,
    /// Raw (score, template) of the last `delay + 1` positions.
    delay_line: Vec<(f32, usize)>,
    open: Option<SpanOpen>,
    closing: Vec<SpanClosing>,
}

/// Streaming normalised cross-correlation matcher.
pub struct WaveformMatcher {
    rate: f64,
    fft_len: usize,
    hop: usize,
    max_len: usize,
    forward: Arc<dyn RealToComplex<f32>>,
    inverse: Arc<dyn ComplexToReal<f32>>,
    templates: Vec<Template>,
    patterns: Vec<PatternInfo>,
    trackers: Vec<SpanTracker>,
    segment: Vec<f32>,
    filled: usize,
    seg_start: u64,
    fft_in: Vec<f32>,
    spectrum: Vec<Complex32>,
    product: Vec<Complex32>,
    corr: Vec<f32>,
    /// Signed squared score of the current take over the hop.
    gamma: Vec<f32>,
    scratch_forward: Vec<Complex32>,
    scratch_inverse: Vec<Complex32>,
    prefix_energy: Vec<f64>,
    peaks: Vec<Peak>,
    peak_floor: f32,
    max_half_window: u64,
    /// gamma known for positions [0, computed).
    computed: u64,
    /// Real samples consumed (padding in `finish` excluded).
    consumed: u64,
    /// Events are not stamped later than this sample (the stream's end once finishing).
    emit_limit: u64,
    frames: FrameEnergies,
    span_delay: u64,
    envelope_len: u64,
    finished: bool,
    trace: Option<Vec<TakeTrace>>,
}

impl WaveformMatcher {
    /// Plans the FFTs and allocates every buffer. `patterns` must be non-empty and at
    /// `settings.sample_rate`.
    pub fn new(patterns: Vec<Pattern>, settings: &DetectorSettings) -> Self {
        let rate = f64::from(settings.sample_rate);
        let max_len = patterns
            .iter()
            .map(Pattern::max_len)
            .max()
            .unwrap_or(1)
            .max(1);
        let fft_len = (FFT_LEN_PER_TAKE_LEN * max_len)
            .next_power_of_two()
            .max(MIN_FFT_LEN);
        let hop = fft_len - max_len + 1;
        let mut planner = RealFftPlanner::<f32>::new();
        let forward = planner.plan_fft_forward(fft_len);
        let inverse = planner.plan_fft_inverse(fft_len);
        let floor_rms = 10f64.powf(SILENCE_FLOOR_DBFS / 20.0);

        let envelope_len = ((ENVELOPE_SECONDS * rate).round() as usize).max(1);
        let average_len = ((AVERAGE_SECONDS * rate).round() as usize).max(1);
        let span_delay = ((envelope_len + average_len).saturating_sub(2) / 2) as u64;
        let frame_len = ((FRAME_SECONDS * rate).round() as usize).max(1);

        let mut templates = Vec::new();
        let mut infos = Vec::new();
        let mut trackers = Vec::new();
        let mut fft_scratch = forward.make_input_vec();
        for (pi, pattern) in patterns.iter().enumerate() {
            infos.push(PatternInfo {
                name: pattern.name.clone(),
                kind: pattern.kind,
                threshold: pattern.threshold as f32,
            });
            let slot = (pattern.kind == PatternKind::Continuous).then(|| {
                trackers.push(SpanTracker {
                    pattern: pi,
                    low: pattern.continuous_threshold as f32,
                    high: pattern.threshold as f32,
                    max_len: pattern.max_len() as u64,
                    score: vec![0.0; hop],
                    best_template: vec![0; hop],
                    envelope: SlidingMax::new(envelope_len),
                    average: MovingAverage::new(average_len),
                    delay_line: vec![(0.0, 0); span_delay as usize + 1],
                    open: None,
                    closing: Vec::with_capacity(MAX_CLOSING_SPANS),
                });
                trackers.len() - 1
            });
            for take in &pattern.takes {
                let len = take.samples.len();
                let energy = take.energy();
                let spectrum =
                    template_spectrum(forward.as_ref(), &take.samples, energy, &mut fft_scratch);
                let half_window = match settings.suppression_seconds {
                    Some(s) => (s * rate).round() as u64,
                    None => (len / 2) as u64,
                };
                templates.push(Template {
                    pattern: pi,
                    len,
                    energy,
                    spectrum,
                    silence_floor: len as f64 * floor_rms * floor_rms,
                    half_window,
                    prev: f32::NEG_INFINITY,
                    prev_prev: f32::NEG_INFINITY,
                    prev_energy: 0.0,
                    continuous_slot: slot,
                });
            }
        }
        let peak_floor = infos
            .iter()
            .filter(|p| p.kind == PatternKind::Impulse)
            .map(|p| p.threshold)
            .fold(f32::INFINITY, f32::min);
        let max_half_window = templates.iter().map(|t| t.half_window).max().unwrap_or(0);
        // Peaks live for about 2 suppression windows plus a segment; local maxima are at
        // least 2 samples apart. Bounded so a pathological input cannot reserve gigabytes.
        let peak_capacity =
            (templates.len() * (2 * max_half_window as usize + hop + 4) / 2).clamp(64, 1 << 16);
        let frame_capacity =
            (3 * max_len + 2 * hop + 4 * (envelope_len + average_len)) / frame_len + 16;

        Self {
            rate,
            fft_len,
            hop,
            max_len,
            scratch_forward: forward.make_scratch_vec(),
            scratch_inverse: inverse.make_scratch_vec(),
            spectrum: forward.make_output_vec(),
            product: forward.make_output_vec(),
            corr: inverse.make_output_vec(),
            gamma: vec![0.0; hop],
            fft_in: forward.make_input_vec(),
            forward,
            inverse,
            templates,
            patterns: infos,
            trackers,
            segment: vec![0.0; fft_len],
            filled: 0,
            seg_start: 0,
            prefix_energy: vec![0.0; fft_len + 1],
            peaks: Vec::with_capacity(peak_capacity),
            peak_floor,
            max_half_window,
            computed: 0,
            consumed: 0,
            emit_limit: u64::MAX,
            frames: FrameEnergies::new(frame_len, frame_capacity),
            span_delay,
            envelope_len: envelope_len as u64,
            finished: false,
            trace: None,
        }
    }

    /// Longest time from an impulse's onset to its decision, seconds: a whole segment
    /// and the widest suppression window.
    pub fn decision_delay_bound(&self) -> f64 {
        (self.fft_len as u64 + self.max_half_window + 2) as f64 / self.rate
    }

    /// FFT segment length and hop (new samples per segment).
    pub fn segment_geometry(&self) -> (usize, usize) {
        (self.fft_len, self.hop)
    }

    pub fn enable_score_trace(&mut self) {
        if self.trace.is_none() {
            let mut per_pattern_take = vec![0usize; self.patterns.len()];
            let traces = self
                .templates
                .iter()
                .map(|t| {
                    let take = per_pattern_take[t.pattern];
                    per_pattern_take[t.pattern] += 1;
                    TakeTrace {
                        pattern: self.patterns[t.pattern].name.clone(),
                        take,
                        scores: Vec::new(),
                    }
                })
                .collect();
            self.trace = Some(traces);
        }
    }

    pub fn take_score_trace(&mut self) -> Option<Vec<TakeTrace>> {
        self.trace.take()
    }

    pub fn score_trace(&self) -> Option<&[TakeTrace]> {
        self.trace.as_deref()
    }

    /// Consumes samples at the working rate; appends decided events (id 0, `emitted_at`
    /// from the working-rate sample that completed the decision).
    pub fn push(&mut self, samples: &[f32], out: &mut Vec<Event>) {
        if self.finished {
            return;
        }
        self.consumed += samples.len() as u64;
        self.feed(samples, out);
    }

    fn feed(&mut self, mut samples: &[f32], out: &mut Vec<Event>) {
        while !samples.is_empty() {
            let take = (self.fft_len - self.filled).min(samples.len());
            self.segment[self.filled..self.filled + take].copy_from_slice(&samples[..take]);
            self.frames.push(&samples[..take]);
            self.filled += take;
            samples = &samples[take..];
            if self.filled == self.fft_len {
                self.process_segment(out);
            }
        }
    }

    /// Ends the stream: pads with silence until every pending decision can be taken,
    /// then decides what is left. Events past the end of the stream are dropped.
    pub fn finish(&mut self, out: &mut Vec<Event>) {
        if self.finished {
            return;
        }
        let end = self.consumed;
        self.emit_limit = end;
        // Impulses need gamma up to their suppression window (+2 to confirm the last
        // local maximum); continuous spans also need the smoothing delay and the frames
        // searched for their end.
        let spans_need = if self.trackers.is_empty() {
            0
        } else {
            self.span_delay + self.max_len as u64 + self.envelope_len
        };
        let target = end + self.max_half_window.max(spans_need) + 2;
        const ZEROS: [f32; 256] = [0.0; 256];
        while self.computed < target {
            let need = (self.fft_len - self.filled).min(ZEROS.len());
            self.feed(&ZEROS[..need], out);
        }
        self.decide_impulses(out, true);
        for slot in 0..self.trackers.len() {
            let tracker = &mut self.trackers[slot];
            if let Some(open) = tracker.open.take() {
                push_closing(
                    tracker,
                    SpanClosing {
                        open,
                        end_pos: end.saturating_sub(1),
                    },
                );
            }
            self.finalize_spans(slot, out, true);
        }
        self.finished = true;
        let end_s = end as f64 / self.rate;
        super::keep_within(out, end_s);
        if let Some(traces) = &mut self.trace {
            for t in traces {
                t.scores.truncate(end as usize);
            }
        }
    }

    fn process_segment(&mut self, out: &mut Vec<Event>) {
        let hop = self.hop;
        let seg_start = self.seg_start;
        // Window energies from prefix sums (f64: no drift, recomputed every segment).
        prefix_squares(&self.segment, &mut self.prefix_energy);
        self.fft_in.copy_from_slice(&self.segment);
        // Buffer lengths come from the plan, so the transform cannot fail.
        let _ = self.forward.process_with_scratch(
            &mut self.fft_in,
            &mut self.spectrum,
            &mut self.scratch_forward,
        );
        for tracker in &mut self.trackers {
            tracker
                .score
                .iter_mut()
                .for_each(|s| *s = f32::NEG_INFINITY);
        }

        for (ti, tmpl) in self.templates.iter_mut().enumerate() {
            correlate(
                self.inverse.as_ref(),
                &self.spectrum,
                &tmpl.spectrum,
                &mut self.product,
                &mut self.corr,
                &mut self.scratch_inverse,
            );
            // gamma for the hop, in a loop of its own so that it vectorises.
            // Signed squared score q = c·|c| / E = sign(gamma)·gamma²: same order as
            // gamma, so peaks and thresholds (squared) are found on q without a square
            // root. The prefix sums are subtracted in f64 (that is where precision is
            // lost); the window energy itself is well within f32's precision.
            let floor = tmpl.silence_floor as f32;
            let energies = self.prefix_energy[tmpl.len..tmpl.len + hop]
                .iter()
                .zip(&self.prefix_energy[..hop]);
            for ((q, &c), (&hi, &lo)) in self.gamma.iter_mut().zip(&self.corr[..hop]).zip(energies)
            {
                *q = c * c.abs() / ((hi - lo) as f32).max(floor);
            }
            let score2 = &self.gamma[..hop];
            let need_gamma = self.trace.is_some() || tmpl.continuous_slot.is_some();
            if need_gamma {
                for (g, &q) in self.corr[..hop].iter_mut().zip(score2) {
                    *g = q.abs().sqrt().copysign(q);
                }
            }
            let gamma = &self.corr[..hop];
            if let Some(trace) = self.trace.as_mut() {
                trace[ti].scores.extend_from_slice(gamma);
            }
            if let Some(slot) = tmpl.continuous_slot {
                let tracker = &mut self.trackers[slot];
                for (k, &g) in gamma.iter().enumerate() {
                    if g > tracker.score[k] {
                        tracker.score[k] = g;
                        tracker.best_template[k] = ti;
                    }
                }
            }
            // Local maxima above the floor, on q against the squared floor. At step k
            // the candidate is position k - 2; it is a peak when it rose from k - 3 and
            // does not fall short of k - 1. Positions -1 and -2 are the previous
            // segment's last two.
            let floor2 = self.peak_floor * self.peak_floor;
            let value_at = |k: usize, prev: f32, prev_prev: f32| match k {
                0 => prev_prev,
                1 => prev,
                _ => score2[k - 2],
            };
            let mut k = 1;
            while k <= hop {
                let candidate = if k == 1 { tmpl.prev } else { score2[k - 2] };
                // NaN counts as below the floor.
                if candidate.partial_cmp(&floor2) != Some(std::cmp::Ordering::Greater) {
                    // Skip ahead to the next value above the floor.
                    match first_above(&score2[k - 1..], floor2) {
                        Some(off) => {
                            k += off + 1;
                            continue;
                        }
                        None => break,
                    }
                }
                let before = value_at(k - 1, tmpl.prev, tmpl.prev_prev);
                let after = score2[k - 1];
                if candidate > before && candidate >= after {
                    if self.peaks.len() < self.peaks.capacity() {
                        let t = seg_start + k as u64 - 2;
                        let window_energy = if k >= 2 {
                            self.prefix_energy[k - 2 + tmpl.len] - self.prefix_energy[k - 2]
                        } else {
                            tmpl.prev_energy
                        };
                        self.peaks.push(Peak {
                            template: ti,
                            t,
                            value: candidate.sqrt(),
                            window_energy,
                            decided: false,
                        });
                    } else {
                        debug_assert!(false, "peak list full");
                    }
                }
                k += 1;
            }
            tmpl.prev_prev = score2[hop - 2];
            tmpl.prev = score2[hop - 1];
            tmpl.prev_energy = self.prefix_energy[hop - 1 + tmpl.len] - self.prefix_energy[hop - 1];
        }
        self.computed = seg_start + hop as u64;
        self.peaks
            .sort_unstable_by(|a, b| a.t.cmp(&b.t).then(a.template.cmp(&b.template)));
        self.decide_impulses(out, false);
        for slot in 0..self.trackers.len() {
            self.track_spans(slot);
            self.finalize_spans(slot, out, false);
        }
        self.segment.copy_within(hop.., 0);
        self.filled = self.fft_len - hop;
        self.seg_start += hop as u64;
    }

    fn emitted_at(&self) -> f64 {
        let decided = (self.seg_start + self.fft_len as u64).min(self.emit_limit);
        decided as f64 / self.rate
    }

    fn decide_impulses(&mut self, out: &mut Vec<Event>, final_pass: bool) {
        let emitted_at = self.emitted_at();
        for i in 0..self.peaks.len() {
            let c = self.peaks[i];
            let tmpl = &self.templates[c.template];
            let info = &self.patterns[tmpl.pattern];
            if c.decided || info.kind != PatternKind::Impulse || c.value <= info.threshold {
                continue;
            }
            let half = tmpl.half_window;
            // Local maxima are confirmed one position late: all peaks up to t + half
            // are known once gamma is computed up to t + half + 1.
            if !final_pass && c.t + half + 2 > self.computed {
                continue;
            }
            self.peaks[i].decided = true;
            let suppressed = self.peaks.iter().enumerate().any(|(j, q)| {
                j != i
                    && q.t.abs_diff(c.t) <= half
                    && (q.value > c.value
                        || (q.value == c.value && (q.t, q.template) < (c.t, c.template)))
            });
            if suppressed {
                continue;
            }
            out.push(Event {
                id: 0,
                pattern: info.name.clone(),
                kind: PatternKind::Impulse,
                time: c.t as f64 / self.rate,
                end: None,
                strength: (c.window_energy / tmpl.energy).sqrt(),
                score: f64::from(c.value),
                emitted_at,
                pitch: None,
            });
        }
        // A peak matters while a candidate within its window may still be undecided.
        let horizon = self.computed.saturating_sub(2 * self.max_half_window + 2);
        let patterns = &self.patterns;
        let templates = &self.templates;
        self.peaks.retain(|p| {
            let candidate = patterns[templates[p.template].pattern].kind == PatternKind::Impulse;
            p.t >= horizon || (candidate && !p.decided && !final_pass)
        });
    }

    /// Feeds this segment's best-take scores of one continuous pattern through the
    /// envelope and the span state machine.
    fn track_spans(&mut self, slot: usize) {
        let delay = self.span_delay;
        let seg_start = self.seg_start;
        for k in 0..self.hop {
            let tracker = &mut self.trackers[slot];
            let raw = tracker.score[k];
            let template = tracker.best_template[k];
            let smooth = tracker.average.push(tracker.envelope.push(raw));
            let p = seg_start + k as u64;
            let ring = tracker.delay_line.len() as u64;
            tracker.delay_line[(p % ring) as usize] = (raw, template);
            if p < delay {
                continue;
            }
            // The smoothed value at p describes position c (its window's centre).
            let c = p - delay;
            let (raw_c, template_c) = tracker.delay_line[(c % ring) as usize];
            match tracker.open.as_mut() {
                None if smooth >= tracker.low => {
                    let max_len = tracker.max_len;
                    let begin_sample = self.place_begin(c, max_len);
                    let begin_cum = self
                        .frames
                        .boundary(begin_sample / self.frames.frame_len() as u64)
                        .unwrap_or(0.0);
                    self.trackers[slot].open = Some(SpanOpen {
                        begin_sample,
                        begin_cum,
                        best_score: raw_c,
                        best_template: template_c,
                    });
                }
                None => {}
                Some(open) if smooth >= tracker.low && raw_c > open.best_score => {
                    open.best_score = raw_c;
                    open.best_template = template_c;
                }
                Some(_) if smooth >= tracker.low => {}
                Some(_) => {
                    if let Some(open) = tracker.open.take() {
                        push_closing(
                            tracker,
                            SpanClosing {
                                open,
                                end_pos: c.saturating_sub(1),
                            },
                        );
                    }
                }
            }
        }
    }

    /// The span's score rose at window position `c`: the sound starts within
    /// [c - W, c + M + W]. Returns the first frame there within 12 dB of the loudest.
    fn place_begin(&self, c: u64, max_len: u64) -> u64 {
        let f = self.frames.frame_len() as u64;
        let lo = (c.saturating_sub(self.envelope_len) / f).max(self.frames.oldest());
        let hi =
            ((c + max_len + self.envelope_len) / f).min(self.frames.complete().saturating_sub(1));
        let loudest = (lo..=hi)
            .filter_map(|i| self.frames.frame(i))
            .fold(0.0f64, f64::max);
        (lo..=hi)
            .find(|&i| {
                self.frames
                    .frame(i)
                    .is_some_and(|e| e >= loudest * SPAN_LEVEL_RATIO && e > 0.0)
            })
            .map_or(c, |i| i * f)
    }

    /// Places the end of closing spans once the frames after them are known, and emits
    /// the ones whose best gamma passed the threshold.
    fn finalize_spans(&mut self, slot: usize, out: &mut Vec<Event>, final_pass: bool) {
        let f = self.frames.frame_len() as u64;
        let emitted_at = self.emitted_at();
        let (max_len, high, pattern) = {
            let t = &self.trackers[slot];
            (t.max_len, t.high, t.pattern)
        };
        while let Some(&closing) = self.trackers[slot].closing.first() {
            let search_hi_sample = closing.end_pos + max_len + self.envelope_len;
            let available = self.frames.complete();
            if !final_pass && search_hi_sample / f >= available {
                break;
            }
            let open = closing.open;
            self.trackers[slot].closing.remove(0);
            if open.best_score <= high {
                continue;
            }
            let lo = (closing
                .end_pos
                .saturating_sub(max_len)
                .max(open.begin_sample)
                / f)
                .max(self.frames.oldest());
            let hi = (search_hi_sample / f).min(available.saturating_sub(1));
            let loudest = (lo..=hi)
                .filter_map(|i| self.frames.frame(i))
                .fold(0.0f64, f64::max);
            let first_end_frame = (closing.end_pos / f).max(lo);
            let end_frame = (first_end_frame..=hi)
                .rev()
                .find(|&i| {
                    self.frames
                        .frame(i)
                        .is_some_and(|e| e >= loudest * SPAN_LEVEL_RATIO && e > 0.0)
                })
                .unwrap_or(first_end_frame);
            let end_sample = ((end_frame + 1) * f).max(open.begin_sample + f);
            let span_energy = self
                .frames
                .boundary(end_sample / f)
                .map_or(0.0, |b| (b - open.begin_cum).max(0.0));
            let tmpl = &self.templates[open.best_template];
            let span_power = span_energy / (end_sample - open.begin_sample) as f64;
            let pattern_power = tmpl.energy / tmpl.len as f64;
            out.push(Event {
                id: 0,
                pattern: self.patterns[pattern].name.clone(),
                kind: PatternKind::Continuous,
                time: open.begin_sample as f64 / self.rate,
                end: Some(end_sample as f64 / self.rate),
                strength: (span_power / pattern_power).sqrt(),
                score: f64::from(open.best_score),
                emitted_at,
                pitch: None,
            });
        }
    }
}

/// A template's spectrum for [`correlate`]: conj(FFT(p)) / (|p| fft_len), `samples` of
/// `energy` zero-padded to the plan's length in `padded` (as long as the plan's input).
pub(super) fn template_spectrum(
    forward: &dyn RealToComplex<f32>,
    samples: &[f32],
    energy: f64,
    padded: &mut [f32],
) -> Vec<Complex32> {
    let norm = energy.sqrt().max(f64::MIN_POSITIVE);
    padded.fill(0.0);
    padded[..samples.len()].copy_from_slice(samples);
    let mut spectrum = forward.make_output_vec();
    // Lengths come from the plan itself, so the transform cannot fail.
    let _ = forward.process(padded, &mut spectrum);
    let scale = (1.0 / (norm * padded.len() as f64)) as f32;
    for c in &mut spectrum {
        *c = c.conj() * scale;
    }
    spectrum
}

/// The cross-correlation of a segment (its spectrum `segment`) with a template (its
/// [`template_spectrum`]) into `out`: `out[j]` = <s[j..j + M], p> / |p|, for the lags
/// where the template does not wrap around the segment. `product` and `scratch` are
/// the plan's buffers. Allocates nothing.
pub(super) fn correlate(
    inverse: &dyn ComplexToReal<f32>,
    segment: &[Complex32],
    template: &[Complex32],
    product: &mut [Complex32],
    out: &mut [f32],
    scratch: &mut [Complex32],
) {
    for ((p, s), t) in product.iter_mut().zip(segment).zip(template) {
        *p = s * t;
    }
    // Real signals: DC and Nyquist bins are real. Keep them exactly so.
    let last = product.len() - 1;
    product[0].im = 0.0;
    product[last].im = 0.0;
    // Buffer lengths come from the plan, so the transform cannot fail.
    let _ = inverse.process_with_scratch(product, out, scratch);
}

/// `out[i]` = sum of `x[..i]²` in f64 (`out.len() == x.len() + 1`). The four quarters
/// of `x` are summed as independent chains in one pass (four times the throughput of a
/// single dependent chain), then each quarter is offset by the ones before it.
pub(super) fn prefix_squares(x: &[f32], out: &mut [f64]) {
    debug_assert_eq!(out.len(), x.len() + 1);
    let sq = |v: f32| f64::from(v) * f64::from(v);
    let q = x.len() / 4;
    out[0] = 0.0;
    let (mut a0, mut a1, mut a2, mut a3) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for i in 0..q {
        a0 += sq(x[i]);
        a1 += sq(x[q + i]);
        a2 += sq(x[2 * q + i]);
        a3 += sq(x[3 * q + i]);
        out[i + 1] = a0;
        out[q + i + 1] = a1;
        out[2 * q + i + 1] = a2;
        out[3 * q + i + 1] = a3;
    }
    for quarter in 1..4 {
        let offset = out[quarter * q];
        for v in &mut out[quarter * q + 1..(quarter + 1) * q + 1] {
            *v += offset;
        }
    }
    // The last len % 4 samples, continuing from the shifted sums.
    for i in 4 * q..x.len() {
        out[i + 1] = out[i] + sq(x[i]);
    }
}

/// Index of the first value above `floor`. Scans 16 values at a time with a branch-free
/// maximum (which vectorises): gamma is below the threshold nearly everywhere.
fn first_above(values: &[f32], floor: f32) -> Option<usize> {
    let mut base = 0;
    for chunk in values.chunks(16) {
        if chunk.iter().fold(f32::NEG_INFINITY, |m, &v| m.max(v)) > floor {
            return chunk.iter().position(|&v| v > floor).map(|i| base + i);
        }
        base += chunk.len();
    }
    None
}

fn push_closing(tracker: &mut SpanTracker, closing: SpanClosing) {
    if tracker.closing.len() == tracker.closing.capacity() {
        // Far more spans closing at once than any voice makes: keep the newest.
        tracker.closing.remove(0);
    }
    tracker.closing.push(closing);
}

/// Direct O(N·M) normalised cross-correlation of `signal` with `pattern`, for every t
/// where the pattern fits: the paper's computation, kept as the reference the FFT path is
/// tested against and benchmarked with.
pub fn direct_ncc(signal: &[f32], pattern: &[f32]) -> Vec<f32> {
    let m = pattern.len();
    if m == 0 || signal.len() < m {
        return Vec::new();
    }
    let norm = pattern
        .iter()
        .map(|&x| f64::from(x) * f64::from(x))
        .sum::<f64>()
        .sqrt();
    let floor_rms = 10f64.powf(SILENCE_FLOOR_DBFS / 20.0);
    let floor = m as f64 * floor_rms * floor_rms;
    let mut window_energy: f64 = signal[..m]
        .iter()
        .map(|&x| f64::from(x) * f64::from(x))
        .sum();
    let mut out = Vec::with_capacity(signal.len() - m + 1);
    for t in 0..=signal.len() - m {
        if t > 0 {
            let gone = f64::from(signal[t - 1]);
            let new = f64::from(signal[t + m - 1]);
            window_energy += new * new - gone * gone;
        }
        let dot = dot_product(&signal[t..t + m], pattern);
        out.push((f64::from(dot) / (norm * window_energy.max(floor).sqrt())) as f32);
    }
    out
}

/// A dot product written so the compiler vectorises it (16 independent accumulators,
/// no bounds checks in the loop).
fn dot_product(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; 16];
    let (a16, b16) = (a.chunks_exact(16), b.chunks_exact(16));
    let tail: f32 = a16
        .remainder()
        .iter()
        .zip(b16.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a16.zip(b16) {
        for lane in 0..16 {
            acc[lane] += x[lane] * y[lane];
        }
    }
    acc.iter().sum::<f32>() + tail
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefix_squares_matches_a_sequential_sum() {
        for len in [0usize, 1, 3, 4, 7, 64, 1027] {
            let x: Vec<f32> = (0..len)
                .map(|i| ((i * 37) % 11) as f32 * 0.1 - 0.5)
                .collect();
            let mut out = vec![f64::NAN; len + 1];
            prefix_squares(&x, &mut out);
            let mut want = 0.0f64;
            assert_eq!(out[0], 0.0);
            for i in 0..len {
                want += f64::from(x[i]) * f64::from(x[i]);
                assert!(
                    (out[i + 1] - want).abs() < 1e-9,
                    "len {len} at {i}: {} vs {want}",
                    out[i + 1]
                );
            }
        }
    }

    #[test]
    fn first_above_finds_the_first_value_over_the_floor() {
        let mut v = vec![0.1f32; 100];
        assert_eq!(first_above(&v, 0.5), None);
        v[37] = 0.6;
        v[80] = 0.9;
        assert_eq!(first_above(&v, 0.5), Some(37));
        assert_eq!(first_above(&v[38..], 0.5), Some(42));
        v[3] = f32::NAN;
        assert_eq!(
            first_above(&v, 0.5),
            Some(37),
            "NaN is never above the floor"
        );
    }
}
