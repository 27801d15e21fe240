//! Audio files in: every WAV format and channel layout, any sample rate, and a clear
//! refusal, naming the file, for every kind of bad pattern or recording.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use onomato::analyze::{analyze_file, AnalyzeError};
use onomato::config::{Config, DetectorSettings, PatternKind, PatternSpec};
use onomato::pattern::{Pattern, PatternError};

/// A 4 s scene: tick at 0.5 s (gain 0.9), pop at 1.7 s (0.6), tick at 3.0 s (0.5).
fn scene() -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let tick = noise_burst(RATE, 0.05, 0.012, 11);
    let pop = sweep(RATE, 0.08, 420.0, 110.0, 0.03);
    let mut rec = vec![0.0f32; samples_for(4.0, RATE)];
    place(&mut rec, &tick, samples_for(0.5, RATE), 0.9);
    place(&mut rec, &pop, samples_for(1.7, RATE), 0.6);
    place(&mut rec, &tick, samples_for(3.0, RATE), 0.5);
    add_noise(&mut rec, 0.002, 1);
    (rec, tick, pop)
}

const TRUTH: [(&str, f64); 3] = [("tick", 0.5), ("pop", 1.7), ("tick", 3.0)];

fn config_for(dir: &Path, tick: &[f32], pop: &[f32]) -> Config {
    let tick_path = dir.join("tick.wav");
    let pop_path = dir.join("pop.wav");
    write_wav_f32(&tick_path, tick, RATE);
    write_wav_f32(&pop_path, pop, RATE);
    let spec = |name: &str, path: PathBuf| PatternSpec {
        name: name.into(),
        kind: PatternKind::Impulse,
        takes: vec![path],
        ..PatternSpec::default()
    };
    // The paper's method places exact copies to the sample, so every format can be
    // held to 1 ms.
    Config {
        patterns: vec![spec("tick", tick_path), spec("pop", pop_path)],
        detector: waveform_settings(),
        ..Config::default()
    }
}

fn assert_truth(path: &Path, config: &Config, tolerance: f64) {
    let analysis = analyze_file(path, config).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let found: Vec<(&str, f64)> = analysis
        .events
        .iter()
        .map(|e| (&*e.pattern, e.time))
        .collect();
    assert_eq!(found.len(), TRUTH.len(), "{}: {found:?}", path.display());
    for ((name, time), (want_name, want_time)) in found.iter().zip(TRUTH) {
        assert_eq!(*name, want_name, "{}: {found:?}", path.display());
        assert!(
            (time - want_time).abs() <= tolerance,
            "{}: {name} at {time:.5}, expected {want_time}",
            path.display()
        );
    }
}

#[test]
fn every_integer_and_float_format_gives_the_same_events() {
    let dir = temp_dir("formats");
    let (rec, tick, pop) = scene();
    let config = config_for(&dir, &tick, &pop);
    let mono: Vec<Vec<f32>> = rec.iter().map(|&x| vec![x]).collect();
    for bits in [8u16, 16, 24, 32] {
        let path = dir.join(format!("rec-{bits}bit.wav"));
        write_wav_int(&path, &mono, RATE, bits);
        assert_truth(&path, &config, 0.001);
    }
    let path = dir.join("rec-float.wav");
    write_wav_f32(&path, &rec, RATE);
    assert_truth(&path, &config, 0.001);
}

#[test]
fn stereo_is_mixed_down_or_one_channel_is_taken() {
    let dir = temp_dir("stereo");
    let (rec, tick, pop) = scene();
    let mut config = config_for(&dir, &tick, &pop);
    // The sounds in channel 1, unrelated noise in channel 0.
    let mut other = vec![0.0f32; rec.len()];
    add_noise(&mut other, 0.01, 77);
    let frames: Vec<Vec<f32>> = rec.iter().zip(&other).map(|(&a, &b)| vec![b, a]).collect();
    let path = dir.join("stereo.wav");
    write_wav_int(&path, &frames, RATE, 16);
    assert_truth(&path, &config, 0.001);
    config.detector.channel = Some(1);
    assert_truth(&path, &config, 0.001);
    config.detector.channel = Some(0);
    let noise_only = analyze_file(&path, &config).unwrap();
    assert!(noise_only.events.is_empty(), "{:?}", noise_only.events);
    config.detector.channel = Some(2);
    let err = analyze_file(&path, &config).unwrap_err().to_string();
    assert!(
        err.contains("has 2 channel(s); channel 2 does not exist"),
        "{err}"
    );
}

#[test]
fn recordings_at_other_rates_are_resampled() {
    let dir = temp_dir("rates");
    let (rec, tick, pop) = scene();
    let config = config_for(&dir, &tick, &pop);
    for rate in [44_100u32, 48_000, 32_000] {
        let resampled = onomato::audio::resample_clip(&rec, RATE, rate).unwrap();
        let path = dir.join(format!("rec-{rate}.wav"));
        write_wav_f32(&path, &resampled, rate);
        assert_truth(&path, &config, 0.001);
    }
    // Patterns at another rate than the working rate are resampled too.
    let tick48 = onomato::audio::resample_clip(&tick, RATE, 48_000).unwrap();
    let mut config48 = config.clone();
    let path = dir.join("tick48.wav");
    write_wav_f32(&path, &tick48, 48_000);
    config48.patterns[0].takes = vec![path];
    let rec_path = dir.join("rec-float.wav");
    write_wav_f32(&rec_path, &rec, RATE);
    assert_truth(&rec_path, &config48, 0.001);
}

fn load_error(dir: &Path, file: &str, settings: &DetectorSettings) -> String {
    let spec = PatternSpec {
        name: "tick".into(),
        kind: PatternKind::Impulse,
        takes: vec![dir.join(file)],
        ..PatternSpec::default()
    };
    match Pattern::load(&spec, settings) {
        Ok(_) => panic!("{file} was accepted"),
        Err(e) => {
            let text = format!("{e}");
            assert!(text.contains(file), "the message names the file: {text}");
            assert!(
                text.contains("pattern 'tick'"),
                "the message names the pattern: {text}"
            );
            let _: &PatternError = &e;
            text
        }
    }
}

/// A mono WAV of 100 zero frames whose fmt chunk declares `format_tag` (1 PCM, 3 float,
/// 7 mu-law) at `bits` per sample.
fn wav_header(format_tag: u16, bits: u16) -> Vec<u8> {
    let block = bits / 8;
    let data = 100 * u32::from(block);
    let mut b = Vec::new();
    b.extend_from_slice(b"RIFF");
    b.extend_from_slice(&(36 + data).to_le_bytes());
    b.extend_from_slice(b"WAVEfmt ");
    b.extend_from_slice(&16u32.to_le_bytes());
    b.extend_from_slice(&format_tag.to_le_bytes());
    b.extend_from_slice(&1u16.to_le_bytes());
    b.extend_from_slice(&RATE.to_le_bytes());
    b.extend_from_slice(&(RATE * u32::from(block)).to_le_bytes());
    b.extend_from_slice(&block.to_le_bytes());
    b.extend_from_slice(&bits.to_le_bytes());
    b.extend_from_slice(b"data");
    b.extend_from_slice(&data.to_le_bytes());
    b.resize(b.len() + data as usize, 0);
    b
}

#[test]
fn bad_pattern_files_are_refused_with_the_file_and_the_reason() {
    let dir = temp_dir("bad-patterns");
    let settings = DetectorSettings::default();

    let msg = load_error(&dir, "missing.wav", &settings);
    assert!(msg.contains("cannot open"), "{msg}");

    write_wav_f32(&dir.join("empty.wav"), &[], RATE);
    let msg = load_error(&dir, "empty.wav", &settings);
    assert!(msg.contains("holds no audio (0 samples)"), "{msg}");

    std::fs::write(
        dir.join("garbage.wav"),
        b"this is not a wave file at all, just text",
    )
    .unwrap();
    let msg = load_error(&dir, "garbage.wav", &settings);
    assert!(msg.contains("is not a readable WAV file"), "{msg}");

    // A real WAV cut short in the middle of its data: the header promises more.
    write_wav_f32(
        &dir.join("full.wav"),
        &noise_burst(RATE, 0.2, 0.05, 3),
        RATE,
    );
    let bytes = std::fs::read(dir.join("full.wav")).unwrap();
    std::fs::write(dir.join("truncated.wav"), &bytes[..bytes.len() / 2 + 1]).unwrap();
    let msg = load_error(&dir, "truncated.wav", &settings);
    assert!(
        msg.contains("is corrupt: reading frame") && msg.contains("ends before its header says"),
        "{msg}"
    );
    // The frame named is where the data stops, not the start of the block.
    assert!(!msg.contains("reading frame 0 "), "{msg}");

    // Headers of sample formats the WAV reader does not take: each says what it holds.
    std::fs::write(dir.join("double.wav"), wav_header(3, 64)).unwrap();
    let msg = load_error(&dir, "double.wav", &settings);
    assert!(
        msg.contains("floating point but not 32-bit") && msg.contains("32-bit float PCM"),
        "{msg}"
    );
    std::fs::write(dir.join("mulaw.wav"), wav_header(7, 8)).unwrap();
    let msg = load_error(&dir, "mulaw.wav", &settings);
    assert!(msg.contains("not PCM (mu-law"), "{msg}");
    let mut flac = b"fLaC".to_vec();
    flac.extend_from_slice(&[0u8; 64]);
    std::fs::write(dir.join("take.flac"), flac).unwrap();
    let msg = load_error(&dir, "take.flac", &settings);
    assert!(
        msg.contains("take.flac") && msg.contains("not a WAV file"),
        "{msg}"
    );

    write_wav_f32(&dir.join("silent.wav"), &vec![0.0; 4410], RATE);
    let msg = load_error(&dir, "silent.wav", &settings);
    assert!(msg.contains("is silent (peak -inf dBFS)"), "{msg}");

    // Dither at the last bits of 16-bit audio: nothing was recorded.
    let mut dither = vec![0.0f32; 4410];
    add_noise(&mut dither, 0.00001, 5);
    write_wav_f32(&dir.join("dither.wav"), &dither, RATE);
    let msg = load_error(&dir, "dither.wav", &settings);
    assert!(
        msg.contains("is silent (peak -") && msg.contains("louder than -60 dBFS"),
        "{msg}"
    );
    // A hiss 70 dB down: something, recorded with too little gain.
    let mut hiss = vec![0.0f32; 4410];
    add_noise(&mut hiss, 0.0001, 5);
    write_wav_f32(&dir.join("hiss.wav"), &hiss, RATE);
    let msg = load_error(&dir, "hiss.wav", &settings);
    assert!(
        msg.contains("is too quiet (peak -")
            && msg.contains("louder than -60 dBFS")
            && msg.contains("more input gain"),
        "{msg}"
    );

    write_wav_f32(
        &dir.join("long.wav"),
        &noise_burst(RATE, 12.0, 100.0, 4),
        RATE,
    );
    let msg = load_error(&dir, "long.wav", &settings);
    assert!(
        msg.contains("is 12.0 s long") && msg.contains("at most 5 s"),
        "{msg}"
    );

    let mut spike = vec![0.0f32; 2000];
    spike[1000..1020].copy_from_slice(&noise_burst(RATE, 0.001, 1.0, 6)[..20]);
    write_wav_f32(&dir.join("spike.wav"), &spike, RATE);
    let msg = load_error(&dir, "spike.wav", &settings);
    assert!(
        msg.contains("after trimming silence") && msg.contains("at least 2 ms"),
        "{msg}"
    );
}

#[test]
fn pattern_takes_are_trimmed_to_the_sound() {
    let settings = DetectorSettings::default();
    let tick = noise_burst(RATE, 0.05, 0.012, 11);
    let mut padded = vec![0.0f32; samples_for(0.3, RATE)];
    padded.extend_from_slice(&tick);
    padded.extend(vec![0.0f32; samples_for(0.4, RATE)]);
    let p = Pattern::from_samples("tick", PatternKind::Impulse, vec![padded], &settings).unwrap();
    let len = p.takes[0].samples.len();
    assert!(
        len <= tick.len() && len + samples_for(0.005, RATE) >= tick.len(),
        "trimmed to {len} samples, the sound has {}",
        tick.len()
    );
}

#[test]
fn bad_recordings_are_refused_with_the_file_and_the_reason() {
    let dir = temp_dir("bad-recordings");
    let (_, tick, pop) = scene();
    let config = config_for(&dir, &tick, &pop);

    let err = analyze_file(&dir.join("nope.wav"), &config).unwrap_err();
    assert!(matches!(err, AnalyzeError::Recording(_)));
    let msg = err.to_string();
    assert!(
        msg.contains("nope.wav") && msg.contains("cannot open"),
        "{msg}"
    );

    write_wav_f32(&dir.join("empty.wav"), &[], RATE);
    let msg = analyze_file(&dir.join("empty.wav"), &config)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("empty.wav") && msg.contains("holds no audio"),
        "{msg}"
    );

    std::fs::write(dir.join("text.wav"), "RIFF but not really").unwrap();
    let msg = analyze_file(&dir.join("text.wav"), &config)
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("text.wav") && msg.contains("not a readable WAV"),
        "{msg}"
    );
}

#[test]
fn a_silent_recording_is_analysed_and_gives_no_event() {
    let dir = temp_dir("silent-recording");
    let (_, tick, pop) = scene();
    let config = config_for(&dir, &tick, &pop);
    write_wav_f32(
        &dir.join("quiet.wav"),
        &vec![0.0; samples_for(2.0, RATE)],
        RATE,
    );
    let analysis = analyze_file(&dir.join("quiet.wav"), &config).unwrap();
    assert!(analysis.events.is_empty());
    assert!((analysis.duration - 2.0).abs() < 1e-9);
}
