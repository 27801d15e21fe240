//! The waveform method on signals with a known answer: positions, labels, strengths,
//! close-by sounds, continuous spans, sounds that are no pattern, and independence from
//! the block size.

mod common;

use common::*;
use onomato::analyze::detect_in_blocks;
use onomato::config::{DetectorSettings, PatternKind};
use onomato::detect::waveform::direct_ncc;
use onomato::{Detector, Event, Pattern};

struct Placed {
    pattern: &'static str,
    at: usize,
    gain: f32,
}

type NamedSound = (&'static str, Vec<f32>);

/// A 12 s recording: the three impulse patterns at known places and gains in noise.
fn known_recording(rate_noise_rms: f64) -> (Vec<f32>, Vec<Placed>, Vec<NamedSound>) {
    let pats = three_impulses();
    let mut rng = Rng::new(7);
    let mut rec = vec![0.0f32; samples_for(12.0, RATE)];
    let mut placed = Vec::new();
    let mut at = samples_for(0.3, RATE);
    let mut i = 0;
    while at + samples_for(0.5, RATE) < rec.len() {
        let (name, p) = &pats[i % pats.len()];
        let gain = rng.range(0.25, 1.0) as f32;
        place(&mut rec, p, at, gain);
        placed.push(Placed {
            pattern: name,
            at,
            gain,
        });
        at += samples_for(rng.range(0.25, 0.6), RATE);
        i += 1;
    }
    add_noise(&mut rec, rate_noise_rms, 99);
    (rec, placed, pats)
}

fn build(pats: &[NamedSound], settings: &DetectorSettings) -> Vec<Pattern> {
    pats.iter()
        .map(|(n, s)| impulse(n, s.clone(), settings))
        .collect()
}

#[test]
fn finds_every_placed_pattern_with_label_time_and_strength() {
    let settings = waveform_settings();
    let (rec, placed, pats) = known_recording(0.002);
    let mut det = Detector::new(build(&pats, &settings), &settings, RATE).unwrap();
    let events = detect_in_blocks(&mut det, &rec, 512);
    assert_eq!(
        events.len(),
        placed.len(),
        "one event per placed sound, no more: {events:#?}"
    );
    for p in &placed {
        let truth = p.at as f64 / f64::from(RATE);
        let e = events
            .iter()
            .find(|e| (e.time - truth).abs() < 0.05)
            .unwrap_or_else(|| panic!("no event near {truth:.4} s ({})", p.pattern));
        assert_eq!(&*e.pattern, p.pattern, "label at {truth:.4} s");
        assert!(
            (e.time - truth).abs() <= 0.001,
            "time {:.5} vs {truth:.5}",
            e.time
        );
        let rel = (e.strength - f64::from(p.gain)).abs() / f64::from(p.gain);
        assert!(
            rel <= 0.02,
            "{} at {truth:.3} s: strength {:.4} vs gain {:.4}",
            p.pattern,
            e.strength,
            p.gain
        );
        assert!(e.score > 0.5 && e.score <= 1.0 + 1e-4, "score {}", e.score);
        assert!(e.emitted_at >= e.time, "decided before the sound: {e:?}");
    }
}

#[test]
fn fft_scores_equal_the_direct_correlation() {
    let settings = waveform_settings();
    let (rec, _, pats) = known_recording(0.002);
    let rec = &rec[..samples_for(3.0, RATE)];
    let patterns = build(&pats, &settings);
    let takes: Vec<Vec<f32>> = patterns
        .iter()
        .map(|p| p.takes[0].samples.clone())
        .collect();
    let mut det = Detector::new(patterns, &settings, RATE).unwrap();
    det.enable_score_trace();
    detect_in_blocks(&mut det, rec, 1000);
    let traces = det.score_trace().unwrap();
    assert_eq!(traces.len(), 3);
    for (trace, take) in traces.iter().zip(&takes) {
        let direct = direct_ncc(rec, take);
        assert_eq!(trace.scores.len(), rec.len());
        let worst = direct
            .iter()
            .zip(&trace.scores)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(
            worst < 1e-3,
            "{}: FFT and direct gamma differ by {worst}",
            trace.pattern
        );
    }
}

#[test]
fn two_different_short_patterns_30_ms_apart_are_both_found() {
    let settings = waveform_settings();
    let pats = vec![
        ("tick", noise_burst(RATE, 0.045, 0.010, 21)),
        ("knock", noise_burst(RATE, 0.050, 0.012, 22)),
    ];
    let mut rec = vec![0.0f32; samples_for(3.0, RATE)];
    let a = samples_for(1.0, RATE);
    let b = a + samples_for(0.030, RATE);
    place(&mut rec, &pats[0].1, a, 0.8);
    place(&mut rec, &pats[1].1, b, 0.7);
    add_noise(&mut rec, 0.002, 5);
    let mut det = Detector::new(build(&pats, &settings), &settings, RATE).unwrap();
    let events = detect_in_blocks(&mut det, &rec, 256);
    let labels: Vec<(&str, f64)> = events.iter().map(|e| (&*e.pattern, e.time)).collect();
    assert_eq!(events.len(), 2, "{labels:?}");
    assert_eq!(&*events[0].pattern, "tick");
    assert!((events[0].time - 1.0).abs() < 0.001, "{labels:?}");
    assert_eq!(&*events[1].pattern, "knock");
    assert!((events[1].time - 1.030).abs() < 0.001, "{labels:?}");
}

/// The paper's suppression window is half the pattern's length: two 150 ms patterns
/// 30 ms apart fall in each other's window, and only the better match survives. A
/// narrower `suppression_seconds` recovers both.
#[test]
fn paper_window_suppresses_close_long_patterns_and_a_narrow_window_keeps_both() {
    let pats = vec![
        ("pew", sweep(RATE, 0.150, 2200.0, 600.0, 0.080)),
        ("zap", noise_burst(RATE, 0.150, 0.060, 31)),
    ];
    let mut rec = vec![0.0f32; samples_for(3.0, RATE)];
    let a = samples_for(1.0, RATE);
    place(&mut rec, &pats[0].1, a, 0.8);
    place(&mut rec, &pats[1].1, a + samples_for(0.030, RATE), 0.8);
    add_noise(&mut rec, 0.002, 6);

    let paper = waveform_settings();
    let mut det = Detector::new(build(&pats, &paper), &paper, RATE).unwrap();
    assert_eq!(detect_in_blocks(&mut det, &rec, 256).len(), 1);

    let narrow = DetectorSettings {
        suppression_seconds: Some(0.015),
        ..waveform_settings()
    };
    let mut det = Detector::new(build(&pats, &narrow), &narrow, RATE).unwrap();
    let events = detect_in_blocks(&mut det, &rec, 256);
    let mut names: Vec<&str> = events.iter().map(|e| &*e.pattern).collect();
    names.sort();
    assert_eq!(names, ["pew", "zap"], "{events:#?}");
}

#[test]
fn continuous_span_is_found_within_20_ms_at_each_end() {
    let settings = waveform_settings();
    let pattern = buzz(RATE, 0.200, 140.0);
    let hum = continuous("hum", pattern, &settings);
    let tick = impulse("tick", noise_burst(RATE, 0.05, 0.012, 11), &settings);
    let mut rec = vec![0.0f32; samples_for(8.0, RATE)];
    // Held sounds of 0.6, 1.5 and 0.35 s at different levels, and a tick between.
    let spans = [(0.8, 0.6, 0.9f32), (2.5, 1.5, 0.5), (5.6, 0.35, 1.0)];
    for &(at, dur, gain) in &spans {
        place(
            &mut rec,
            &buzz(RATE, dur, 140.0),
            samples_for(at, RATE),
            gain,
        );
    }
    place(
        &mut rec,
        &noise_burst(RATE, 0.05, 0.012, 11),
        samples_for(4.6, RATE),
        0.7,
    );
    add_noise(&mut rec, 0.003, 8);
    let mut det = Detector::new(vec![hum, tick], &settings, RATE).unwrap();
    let events = detect_in_blocks(&mut det, &rec, 300);
    let hums: Vec<&Event> = events.iter().filter(|e| &*e.pattern == "hum").collect();
    assert_eq!(
        hums.len(),
        spans.len(),
        "one event per held sound: {events:#?}"
    );
    for (e, &(at, dur, gain)) in hums.iter().zip(&spans) {
        let end = e.end.expect("continuous events have an end");
        assert_eq!(e.kind, PatternKind::Continuous);
        assert!((e.time - at).abs() <= 0.020, "begin {:.4} vs {at}", e.time);
        assert!(
            (end - (at + dur)).abs() <= 0.020,
            "end {end:.4} vs {}",
            at + dur
        );
        assert!(
            (e.strength - f64::from(gain)).abs() / f64::from(gain) < 0.1,
            "strength {:.3} vs gain {gain}",
            e.strength
        );
        assert!(e.emitted_at >= end, "a span is decided after its end");
    }
    let ticks: Vec<&Event> = events.iter().filter(|e| &*e.pattern == "tick").collect();
    assert_eq!(ticks.len(), 1, "{events:#?}");
    assert!((ticks[0].time - 4.6).abs() < 0.001);
}

#[test]
fn a_recording_without_the_patterns_gives_no_event() {
    let settings = waveform_settings();
    let pats = three_impulses();
    let hum = continuous("hum", buzz(RATE, 0.2, 140.0), &settings);
    let mut patterns = build(&pats, &settings);
    patterns.push(hum);
    // Other clicks, sweeps, a voiced sound at another pitch, and noise.
    let mut rec = vec![0.0f32; samples_for(10.0, RATE)];
    let mut rng = Rng::new(3);
    for k in 0..20u64 {
        let at = samples_for(0.2 + 0.45 * k as f64, RATE);
        let sound = match k % 4 {
            0 => noise_burst(RATE, 0.05, 0.012, 1000 + k),
            1 => sweep(RATE, 0.1, 300.0 + 50.0 * k as f64, 900.0, 0.04),
            2 => buzz(RATE, 0.3, 230.0),
            _ => sweep(RATE, 0.15, 3000.0, 1800.0, 0.06),
        };
        place(&mut rec, &sound, at, rng.range(0.3, 1.0) as f32);
    }
    add_noise(&mut rec, 0.01, 4);
    let mut det = Detector::new(patterns, &settings, RATE).unwrap();
    let events = detect_in_blocks(&mut det, &rec, 1024);
    assert!(events.is_empty(), "false events: {events:#?}");
}

#[test]
fn silence_and_digital_zero_give_no_event() {
    let settings = waveform_settings();
    let pats = three_impulses();
    let mut det = Detector::new(build(&pats, &settings), &settings, RATE).unwrap();
    let events = detect_in_blocks(&mut det, &vec![0.0; samples_for(3.0, RATE)], 512);
    assert!(events.is_empty(), "{events:#?}");
}

fn mixed_scene() -> (Vec<f32>, Vec<Pattern>, DetectorSettings) {
    let settings = waveform_settings();
    let (mut rec, _, pats) = known_recording(0.002);
    place(
        &mut rec,
        &buzz(RATE, 0.9, 140.0),
        samples_for(10.6, RATE),
        0.6,
    );
    let mut patterns = build(&pats, &settings);
    patterns.push(continuous("hum", buzz(RATE, 0.2, 140.0), &settings));
    (rec, patterns, settings)
}

#[test]
fn block_size_does_not_change_any_event() {
    let (rec, patterns, settings) = mixed_scene();
    let run = |block: usize| {
        let mut det = Detector::new(patterns.clone(), &settings, RATE).unwrap();
        detect_in_blocks(&mut det, &rec, block)
    };
    let reference = run(rec.len());
    assert!(
        reference.len() > 20,
        "the scene has events: {}",
        reference.len()
    );
    assert!(reference.iter().any(|e| e.end.is_some()));
    for block in [1, 64, 256, 1000, 1024, 4096] {
        assert_eq!(run(block), reference, "block size {block}");
    }
}

#[test]
fn resampled_input_gives_the_same_events_at_any_block_size() {
    let (rec, patterns, settings) = mixed_scene();
    let rec44 = onomato::audio::resample_clip(&rec, RATE, 44_100).unwrap();
    let run = |block: usize| {
        let mut det = Detector::new(patterns.clone(), &settings, 44_100).unwrap();
        detect_in_blocks(&mut det, &rec44, block)
    };
    let reference = run(rec44.len());
    for block in [64, 441, 1024] {
        assert_eq!(run(block), reference, "block size {block}");
    }
    // And the same sounds as at the working rate, within a sample or two. Strength may
    // drop a little: the white-noise tick fills the band up to 11 kHz, and the round
    // trip through 44.1 kHz loses the top of it in the anti-aliasing filters.
    let mut det = Detector::new(patterns.clone(), &settings, RATE).unwrap();
    let native = detect_in_blocks(&mut det, &rec, 512);
    assert_eq!(native.len(), reference.len());
    for (a, b) in native.iter().zip(&reference) {
        assert_eq!(a.pattern, b.pattern);
        assert!((a.time - b.time).abs() < 0.001, "{a:?} vs {b:?}");
        assert!(
            (a.strength - b.strength).abs() / a.strength < 0.1,
            "{a:?} vs {b:?}"
        );
    }
}
