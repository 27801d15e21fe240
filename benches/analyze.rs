//! `cargo bench --bench analyze`: the waveform detector on a 15 s recording with 3 and 8
//! patterns, against the paper's computation (direct O(N·M) normalised correlation of
//! every pattern, `direct_ncc`) on the same signals; the same comparison for one
//! pattern of 0.1, 0.3 and 1 s; the spectral detector on 15 and 60 s; and
//! `analyze_file` end to end on a 44.1 kHz WAV (reading and resampling included).

#[path = "../tests/common/mod.rs"]
mod common;

use std::hint::black_box;
use std::time::Duration;

use common::*;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use onomato::analyze::{analyze_file, detect_in_blocks};
use onomato::config::{Config, DetectorSettings, Method, PatternKind, PatternSpec};
use onomato::detect::waveform::direct_ncc;
use onomato::{Detector, Pattern};

/// Eight vocal-mimic-like patterns, 60 to 400 ms long.
fn pattern_bank() -> Vec<(String, Vec<f32>)> {
    let specs: [(f64, u8); 8] = [
        (0.06, 0),
        (0.10, 1),
        (0.15, 2),
        (0.20, 0),
        (0.25, 1),
        (0.30, 2),
        (0.35, 0),
        (0.40, 1),
    ];
    specs
        .iter()
        .enumerate()
        .map(|(i, &(len, shape))| {
            let s = match shape {
                0 => noise_burst(RATE, len, len / 3.0, 100 + i as u64),
                1 => sweep(RATE, len, 300.0 + 200.0 * i as f64, 150.0, len / 2.0),
                _ => buzz(RATE, len, 110.0 + 15.0 * i as f64),
            };
            (format!("p{i}"), s)
        })
        .collect()
}

/// 15 s with every pattern placed a few times, in noise.
fn recording(bank: &[(String, Vec<f32>)]) -> Vec<f32> {
    let mut rec = vec![0.0f32; samples_for(15.0, RATE)];
    let mut rng = Rng::new(5);
    let mut at = samples_for(0.2, RATE);
    let mut i = 0;
    while at + samples_for(0.5, RATE) < rec.len() {
        place(
            &mut rec,
            &bank[i % bank.len()].1,
            at,
            rng.range(0.3, 1.0) as f32,
        );
        at += samples_for(rng.range(0.4, 0.8), RATE);
        i += 1;
    }
    add_noise(&mut rec, 0.003, 9);
    rec
}

fn patterns(bank: &[(String, Vec<f32>)], n: usize, settings: &DetectorSettings) -> Vec<Pattern> {
    bank[..n]
        .iter()
        .map(|(name, s)| {
            Pattern::from_samples(name, PatternKind::Impulse, vec![s.clone()], settings).unwrap()
        })
        .collect()
}

fn bench_detector(c: &mut Criterion) {
    let settings = waveform_settings();
    let bank = pattern_bank();
    let rec = recording(&bank);
    let mut group = c.benchmark_group("waveform_15s");
    for n in [3usize, 8] {
        let pats = patterns(&bank, n, &settings);
        group.bench_with_input(BenchmarkId::new("fft_streaming", n), &n, |b, _| {
            b.iter(|| {
                let mut det = Detector::new(pats.clone(), &settings, RATE).unwrap();
                black_box(detect_in_blocks(&mut det, black_box(&rec), 1024))
            })
        });
    }
    group.finish();

    let mut group = c.benchmark_group("direct_15s");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(100));
    group.measurement_time(Duration::from_secs(20));
    for n in [3usize, 8] {
        let pats = patterns(&bank, n, &settings);
        group.bench_with_input(BenchmarkId::new("direct_ncc", n), &n, |b, _| {
            b.iter(|| {
                for p in &pats {
                    black_box(direct_ncc(black_box(&rec), &p.takes[0].samples));
                }
            })
        });
    }
    group.finish();
}

/// The spectral detector with 3 and 8 patterns on 15 s, and with 8 on 60 s: the same
/// time per second of audio on both lengths shows that per-block work does not grow.
fn bench_spectral(c: &mut Criterion) {
    let settings = DetectorSettings {
        method: Method::Spectral,
        ..DetectorSettings::default()
    };
    let bank = pattern_bank();
    let rec15 = recording(&bank);
    let rec60: Vec<f32> = rec15
        .iter()
        .cycle()
        .take(rec15.len() * 4)
        .cloned()
        .collect();
    let mut group = c.benchmark_group("spectral");
    for (n, rec, label) in [
        (3usize, &rec15, "15s"),
        (8, &rec15, "15s"),
        (8, &rec60, "60s"),
    ] {
        let pats = patterns(&bank, n, &settings);
        group.bench_function(BenchmarkId::new(format!("{label}_patterns"), n), |b| {
            b.iter(|| {
                let mut det = Detector::new(pats.clone(), &settings, RATE).unwrap();
                black_box(detect_in_blocks(&mut det, black_box(rec), 256))
            })
        });
    }
    // What every run above pays before its first sample: enrolling the patterns.
    let pats = patterns(&bank, 8, &settings);
    group.bench_function(BenchmarkId::new("build_patterns", 8), |b| {
        b.iter(|| black_box(Detector::new(pats.clone(), &settings, RATE).unwrap()))
    });
    // The same with a minute of background recording (`background`), which is read and
    // pooled while the detector is built; and 15 s detected against it.
    let talking = temp_dir("bench-background").join("talking.wav");
    write_wav_f32(&talking, &rec60, RATE);
    let with_background = DetectorSettings {
        background: vec![talking.clone()],
        ..settings.clone()
    };
    group.bench_function(BenchmarkId::new("build_patterns_background_60s", 8), |b| {
        b.iter(|| black_box(Detector::new(pats.clone(), &with_background, RATE).unwrap()))
    });
    group.bench_function(BenchmarkId::new("15s_patterns_background_60s", 8), |b| {
        b.iter(|| {
            let mut det = Detector::new(pats.clone(), &with_background, RATE).unwrap();
            black_box(detect_in_blocks(&mut det, black_box(&rec15), 256))
        })
    });
    group.finish();
}

/// One pattern of growing length: the direct cost grows with the length, the FFT cost
/// with its logarithm.
fn bench_length_sweep(c: &mut Criterion) {
    let settings = waveform_settings();
    let mut group = c.benchmark_group("length_sweep_15s");
    group.sample_size(10);
    group.warm_up_time(Duration::from_millis(100));
    group.measurement_time(Duration::from_secs(10));
    for ms in [100u32, 300, 1000] {
        let take = noise_burst(RATE, f64::from(ms) / 1000.0, f64::from(ms) / 3000.0, 40);
        let bank = vec![("p".to_string(), take)];
        let rec = recording(&bank);
        let pats = patterns(&bank, 1, &settings);
        group.bench_with_input(BenchmarkId::new("fft_streaming_ms", ms), &ms, |b, _| {
            b.iter(|| {
                let mut det = Detector::new(pats.clone(), &settings, RATE).unwrap();
                black_box(detect_in_blocks(&mut det, black_box(&rec), 1024))
            })
        });
        group.bench_with_input(BenchmarkId::new("direct_ncc_ms", ms), &ms, |b, _| {
            b.iter(|| black_box(direct_ncc(black_box(&rec), &pats[0].takes[0].samples)))
        });
    }
    group.finish();
}

fn bench_analyze_file(c: &mut Criterion) {
    let bank = pattern_bank();
    let rec = recording(&bank);
    let dir = temp_dir("bench");
    let rec44 = onomato::audio::resample_clip(&rec, RATE, 44_100).unwrap();
    let rec_path = dir.join("rec44.wav");
    write_wav_f32(&rec_path, &rec44, 44_100);
    let specs = bank
        .iter()
        .map(|(name, s)| {
            let path = dir.join(format!("{name}.wav"));
            write_wav_f32(&path, s, RATE);
            PatternSpec {
                name: name.clone(),
                kind: PatternKind::Impulse,
                takes: vec![path],
                ..PatternSpec::default()
            }
        })
        .collect::<Vec<_>>();
    let mut group = c.benchmark_group("analyze_file_15s_44k");
    group.sample_size(20);
    for (label, method) in [
        ("waveform", Method::Waveform),
        ("spectral", Method::Spectral),
    ] {
        let config = Config {
            patterns: specs.clone(),
            detector: DetectorSettings {
                method,
                ..DetectorSettings::default()
            },
            ..Config::default()
        };
        group.bench_function(BenchmarkId::new("8_patterns", label), |b| {
            b.iter(|| black_box(analyze_file(&rec_path, &config).unwrap()))
        });
    }
    group.finish();
}

criterion_group!(
    benches,
    bench_detector,
    bench_spectral,
    bench_length_sweep,
    bench_analyze_file
);
criterion_main!(benches);
