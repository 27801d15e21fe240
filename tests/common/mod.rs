//! Deterministic synthetic sounds and helpers shared by the integration tests and the
//! benchmark: patterns with a known shape, placed at known sample positions and gains.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use onomato::config::{DetectorSettings, Method, PatternKind};
use onomato::Pattern;

pub mod procs;

pub const RATE: u32 = 22_050;

/// The project's folder (the example, its config and its patterns are there).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// xorshift64*: a small deterministic generator, so every test signal is reproducible.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal (Box-Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.unit().max(1e-12);
        let u2 = self.unit();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

pub fn samples_for(seconds: f64, rate: u32) -> usize {
    (seconds * f64::from(rate)).round() as usize
}

/// A click: white noise under a fast exponential decay ("tick", "t", a knock).
pub fn noise_burst(rate: u32, seconds: f64, decay: f64, seed: u64) -> Vec<f32> {
    let mut rng = Rng::new(seed);
    (0..samples_for(seconds, rate))
        .map(|i| {
            let t = i as f64 / f64::from(rate);
            (0.5 * rng.normal() * (-t / decay).exp()) as f32
        })
        .collect()
}

/// A decaying sine sweeping from `f0` to `f1` Hz ("pop", "pew").
pub fn sweep(rate: u32, seconds: f64, f0: f64, f1: f64, decay: f64) -> Vec<f32> {
    let n = samples_for(seconds, rate);
    let mut phase = 0.0f64;
    (0..n)
        .map(|i| {
            let t = i as f64 / f64::from(rate);
            let f = f0 + (f1 - f0) * t / seconds;
            phase += 2.0 * std::f64::consts::PI * f / f64::from(rate);
            (0.6 * phase.sin() * (-t / decay).exp()) as f32
        })
        .collect()
}

/// A voiced, held sound: harmonics of `f0` up to 4 kHz with 1/k amplitudes and 5 ms
/// fades ("hooo", "mmm").
pub fn buzz(rate: u32, seconds: f64, f0: f64) -> Vec<f32> {
    let n = samples_for(seconds, rate);
    let fade = samples_for(0.005, rate).max(1);
    let harmonics = (4000.0 / f0) as usize;
    (0..n)
        .map(|i| {
            let t = i as f64 / f64::from(rate);
            let mut x = 0.0;
            for k in 1..=harmonics {
                x += (2.0 * std::f64::consts::PI * f0 * k as f64 * t).sin() / k as f64;
            }
            let ramp = (i.min(n - 1 - i) as f64 / fade as f64).min(1.0);
            (0.25 * x * ramp) as f32
        })
        .collect()
}

/// Adds `pattern * gain` into `rec` from sample `at`.
pub fn place(rec: &mut [f32], pattern: &[f32], at: usize, gain: f32) {
    for (r, p) in rec[at..].iter_mut().zip(pattern) {
        *r += p * gain;
    }
}

/// Adds white Gaussian noise of the given RMS.
pub fn add_noise(rec: &mut [f32], rms: f64, seed: u64) {
    let mut rng = Rng::new(seed);
    for x in rec {
        *x += (rms * rng.normal()) as f32;
    }
}

pub fn rms(x: &[f32]) -> f64 {
    (x.iter().map(|&v| f64::from(v) * f64::from(v)).sum::<f64>() / x.len() as f64).sqrt()
}

/// A fresh, empty folder for one test, in the build's own temporary folder (under
/// `target/`, so that test runs leave nothing in the system's; the system's for the
/// examples that share this module, which Cargo gives no such folder): one per binary
/// and name, emptied when a run asks for it again.
pub fn temp_dir(name: &str) -> PathBuf {
    let base = option_env!("CARGO_TARGET_TMPDIR").map_or_else(std::env::temp_dir, PathBuf::from);
    let dir = base.join(format!("onomato-test-{}-{name}", env!("CARGO_CRATE_NAME")));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create temp dir");
    dir
}

/// Writes mono 32-bit float WAV.
pub fn write_wav_f32(path: &Path, samples: &[f32], rate: u32) {
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: rate,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let mut w = hound::WavWriter::create(path, spec).expect("create wav");
    for &s in samples {
        w.write_sample(s).expect("write sample");
    }
    w.finalize().expect("finalize wav");
}

/// Writes integer PCM WAV with `channels` channels, each frame holding `frame(i)`.
pub fn write_wav_int(path: &Path, frames: &[Vec<f32>], rate: u32, bits: u16) {
    let spec = hound::WavSpec {
        channels: frames[0].len() as u16,
        sample_rate: rate,
        bits_per_sample: bits,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(path, spec).expect("create wav");
    let full = ((1i64 << (bits - 1)) - 1) as f32;
    for frame in frames {
        for &s in frame {
            let v = (s.clamp(-1.0, 1.0) * full).round() as i32;
            if bits == 8 {
                w.write_sample(v as i8).expect("write sample");
            } else {
                w.write_sample(v).expect("write sample");
            }
        }
    }
    w.finalize().expect("finalize wav");
}

/// The defaults with the paper's method, for the tests that pin it down.
pub fn waveform_settings() -> DetectorSettings {
    DetectorSettings {
        method: Method::Waveform,
        ..DetectorSettings::default()
    }
}

pub fn impulse(name: &str, samples: Vec<f32>, settings: &DetectorSettings) -> Pattern {
    Pattern::from_samples(name, PatternKind::Impulse, vec![samples], settings).expect("pattern")
}

pub fn continuous(name: &str, samples: Vec<f32>, settings: &DetectorSettings) -> Pattern {
    Pattern::from_samples(name, PatternKind::Continuous, vec![samples], settings).expect("pattern")
}

/// The three impulse patterns most tests use: distinct, realistic lengths.
pub fn three_impulses() -> Vec<(&'static str, Vec<f32>)> {
    vec![
        ("tick", noise_burst(RATE, 0.050, 0.012, 11)),
        ("pop", sweep(RATE, 0.080, 420.0, 110.0, 0.030)),
        ("pew", sweep(RATE, 0.150, 2200.0, 600.0, 0.080)),
    ]
}

/// Three synthetic impulses and a held buzz, enrolled for `method`.
pub fn patterns_for(method: Method) -> (DetectorSettings, Vec<Pattern>) {
    let settings = DetectorSettings {
        method,
        ..DetectorSettings::default()
    };
    let mut patterns: Vec<_> = three_impulses()
        .into_iter()
        .map(|(n, s)| impulse(n, s, &settings))
        .collect();
    patterns.push(continuous("hum", buzz(RATE, 0.2, 140.0), &settings));
    (settings, patterns)
}

/// A 16-bit mono WAV file of the project's, as samples and its rate.
pub fn read_wav_16(path: &Path) -> (Vec<f32>, u32) {
    let mut reader = hound::WavReader::open(path).unwrap();
    let rate = reader.spec().sample_rate;
    let samples = reader
        .samples::<i16>()
        .map(|s| f32::from(s.unwrap()) / 32768.0)
        .collect();
    (samples, rate)
}

/// The duel example's two soundtracks as one stereo file: the shots (one voice) on
/// the left, the jumps and slides (another voice) on the right.
pub fn duel_in_stereo(dir: &Path) -> PathBuf {
    let read = |name: &str| read_wav_16(&root().join("examples/duel").join(name));
    let ((left, rate), (right, _)) = (read("shots.wav"), read("moves.wav"));
    let frames: Vec<Vec<f32>> = left.iter().zip(&right).map(|(l, r)| vec![*l, *r]).collect();
    let path = dir.join("duel-stereo.wav");
    write_wav_int(&path, &frames, rate, 16);
    path
}
