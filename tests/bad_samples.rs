//! Corrupt input: bursts of NaN or of samples far beyond full scale, as a float device or
//! a damaged stream can deliver, must not deafen the detector. Regression test named
//! after the failure: a 10 ms burst of NaN or of ±1e20, 0.2 s into the bundled example,
//! made the spectral method miss every sound of the next 3 s. And input that clips (a
//! gain set too high) is counted and warned of.

mod common;

use std::process::{Command, Output};

use common::root;
use onomato::analyze::detect_in_blocks;
use onomato::audio::{ChannelSelect, WavSource};
use onomato::pattern::load_patterns;
use onomato::{Config, Detector, Event};

fn example() -> (Config, Vec<f32>, u32) {
    let config = Config::load(&root().join("config/onomato.toml")).unwrap();
    let mut source =
        WavSource::open(&root().join("examples/beat.wav"), ChannelSelect::Mix).unwrap();
    let rate = source.sample_rate();
    (config, source.read_all().unwrap(), rate)
}

fn detect(config: &Config, signal: &[f32], rate: u32) -> (Vec<Event>, u64) {
    let patterns = load_patterns(&config.patterns, &config.detector).unwrap();
    let mut det = Detector::new(patterns, &config.detector, rate).unwrap();
    let events = detect_in_blocks(&mut det, signal, 256);
    (events, det.bad_samples())
}

#[test]
fn a_10_ms_burst_of_nan_or_out_of_range_samples_costs_no_sound_0_3_s_after_it() {
    let (config, clean, rate) = example();
    let (reference, bad) = detect(&config, &clean, rate);
    assert_eq!(bad, 0);
    assert!(reference.len() >= 10, "{reference:#?}");
    let burst_len = (0.010 * f64::from(rate)) as usize;
    for value in [f32::NAN, f32::INFINITY, 1e20, -1e20, 1.0] {
        for at_s in [0.2, 2.0, 5.0, 7.7] {
            let mut signal = clean.clone();
            let at = (at_s * f64::from(rate)) as usize;
            for (k, x) in signal[at..at + burst_len].iter_mut().enumerate() {
                *x = if k % 2 == 0 { value } else { -value };
            }
            let (events, bad) = detect(&config, &signal, rate);
            let expected_bad = if value.abs() > 1.0 || !value.is_finite() {
                burst_len as u64
            } else {
                0
            };
            assert_eq!(bad, expected_bad, "burst of {value} at {at_s} s");
            // Every event decided before the burst is unchanged...
            let before: Vec<&Event> = reference.iter().filter(|e| e.emitted_at < at_s).collect();
            let now: Vec<&Event> = events.iter().filter(|e| e.emitted_at < at_s).collect();
            assert_eq!(
                before, now,
                "burst of {value} at {at_s} s changed earlier events"
            );
            // ...and every sound more than 0.3 s after it is found, at its time.
            for e in reference.iter().filter(|e| e.time > at_s + 0.01 + 0.3) {
                assert!(
                    events
                        .iter()
                        .any(|d| d.pattern == e.pattern && (d.time - e.time).abs() < 0.005),
                    "burst of {value} at {at_s} s: {} at {:.3} s lost; found {events:#?}",
                    e.pattern,
                    e.time
                );
            }
        }
    }
}

/// Digital silence (samples that are all zero: a recording exported with silence before
/// it, a microphone that delivers zeros until it starts or while it is muted) is no
/// room. Regression test named after the failure: the room's noise floors took
/// digital silence for a room, started from nothing and rose 3 dB a second once the
/// room began: in the bundled example in white noise 29 dB under full scale (RMS), 0.5
/// s of zeros before it left none of its 10 sounds found (and, on the development sets,
/// 0.5 s of zeros before D1_noise_zingerbox's sequence in -40 dB of noise left 9 of its
/// 70 events).
#[test]
fn digital_silence_before_or_amid_a_noisy_room_costs_no_sound_after_it() {
    let (config, clean, rate) = example();
    let mut noisy = clean;
    // White noise, its peaks 24 dB under full scale.
    let mut rng = common::Rng::new(29);
    for x in &mut noisy {
        *x += rng.range(-1.0, 1.0) as f32 * 0.063;
    }
    let (reference, _) = detect(&config, &noisy, rate);
    assert!(reference.len() >= 10, "{reference:#?}");
    let found = |events: &[Event], e: &Event, shift: f64| {
        events
            .iter()
            .any(|d| d.pattern == e.pattern && (d.time - shift - e.time).abs() < 0.005)
    };
    // Zeros before the room: the same sounds, as much later. A whole number of the
    // analysis' 64-sample hops, so that its frames fall on the sounds as they did
    // (part of a hop moves some marginal decisions: README, "Development sets").
    for hops in [172, 1034] {
        let lead = hops * 64;
        let shift = lead as f64 / f64::from(rate);
        let mut signal = vec![0.0; lead];
        signal.extend_from_slice(&noisy);
        let (events, _) = detect(&config, &signal, rate);
        for e in &reference {
            assert!(
                found(&events, e, shift),
                "{shift:.2} s of zeros before: {} at {:.3} s lost; found {events:#?}",
                e.pattern,
                e.time
            );
        }
        assert_eq!(events.len(), reference.len(), "{events:#?}");
    }
    // Zeros amid it (the microphone muted for a second): every sound from 0.3 s after
    // is found, at its time.
    let (from, to) = (3.5, 4.5);
    let mut signal = noisy.clone();
    let at = |s: f64| (s * f64::from(rate)) as usize;
    signal[at(from)..at(to)].fill(0.0);
    let (events, _) = detect(&config, &signal, rate);
    for e in reference.iter().filter(|e| e.time > to + 0.3) {
        assert!(
            found(&events, e, 0.0),
            "muted {from}-{to} s: {} at {:.3} s lost; found {events:#?}",
            e.pattern,
            e.time
        );
    }
}

/// A microphone's or a converter's DC offset is no sound: the bundled example 0.05
/// over (26 dB under full scale) gives the events it gives without. Before the offset
/// was taken away, its strengths grew with the offset's power (a "pop" 0.97 of its
/// take's level, 3.25 with it), a "boom" and a held "hoo" were lost under the lowest
/// band's leakage, and the step out of the offset when the stream ended fired a "hoo".
#[test]
fn a_dc_offset_changes_no_event() {
    let (config, clean, working_rate) = example();
    // At the working rate, and at 48 kHz, where the resampler too pads the stream's end.
    for rate in [working_rate, 48_000] {
        let clean = onomato::audio::resample_clip(&clean, working_rate, rate).unwrap();
        let (reference, _) = detect(&config, &clean, rate);
        for offset in [0.01f32, 0.05] {
            let shifted: Vec<f32> = clean.iter().map(|x| x + offset).collect();
            let (events, _) = detect(&config, &shifted, rate);
            assert_eq!(
                events.len(),
                reference.len(),
                "offset {offset} at {rate} Hz: {events:#?}"
            );
            for (e, r) in events.iter().zip(&reference) {
                assert!(
                    e.pattern == r.pattern
                        && (e.time - r.time).abs() < 0.001
                        && (e.strength / r.strength - 1.0).abs() < 0.02,
                    "offset {offset} at {rate} Hz: {e:?} where {r:?}"
                );
            }
        }
    }
}

/// A take analysed alone (a user checking what was enrolled) is a stream that begins
/// with its sound: each of the bundled impulse takes gives one event, of its own
/// pattern, at its start. The "pop" opens softly for 30 ms before its burst; until the
/// room had to be heard for as long as the quiet-before gate looks back (40 ms), that
/// opening was taken for the room and the take gave nothing.
#[test]
fn each_bundled_impulse_take_alone_is_found_as_itself() {
    let (config, _, _) = example();
    for name in ["tick", "pop", "boom"] {
        let mut source = WavSource::open(
            &root().join(format!("examples/patterns/{name}.wav")),
            ChannelSelect::Mix,
        )
        .unwrap();
        let rate = source.sample_rate();
        let (events, _) = detect(&config, &source.read_all().unwrap(), rate);
        assert!(
            events.len() == 1 && &*events[0].pattern == name && events[0].time < 0.005,
            "the {name} take alone: {events:#?}"
        );
    }
}

/// A noise gate, as a live performer or a streamer sets one before the detector: in 5
/// ms blocks, open from a block whose RMS stands 10 dB over the room (its 10th
/// percentile block) until 0.1 s after the last such block, zeros while closed.
fn gated(signal: &[f32], rate: u32) -> Vec<f32> {
    let block = (rate / 200) as usize;
    let power = |b: &[f32]| b.iter().map(|x| x * x).sum::<f32>() / b.len() as f32;
    let mut levels: Vec<f32> = signal.chunks(block).map(power).collect();
    levels.sort_by(f32::total_cmp);
    let threshold = levels[levels.len() / 10] * 10.0;
    let mut open_for = 0;
    let mut out = signal.to_vec();
    for chunk in out.chunks_mut(block) {
        if power(chunk) >= threshold {
            open_for = 21;
        }
        if open_for == 0 {
            chunk.fill(0.0);
        } else {
            open_for -= 1;
        }
    }
    out
}

/// Through a noise gate the stream is digital silence between its sounds, and a sound
/// the gate lets through may hold, to the level stage, next to nothing over a room it
/// has only just caught up with. Digital silence is no sound to the speech guard: in the
/// bundled example through a gate, a "pop" 1 s after the held "hoo" was stopped by the
/// guard, which counted the zeros before it as unrecognised sound near its peak. And a
/// held sound the gate opens on lasts as long as without the gate.
#[test]
fn every_hit_of_a_gated_stream_is_found() {
    let (config, clean, rate) = example();
    let (reference, _) = detect(&config, &clean, rate);
    let signal = gated(&clean, rate);
    let zeros = signal.iter().filter(|&&x| x == 0.0).count() as f64 / signal.len() as f64;
    assert!(zeros > 0.3, "the gate closed on {zeros:.2} of the stream");
    let (events, _) = detect(&config, &signal, rate);
    for e in reference.iter().filter(|e| e.end.is_none()) {
        assert!(
            events
                .iter()
                .any(|d| d.pattern == e.pattern && (d.time - e.time).abs() < 0.01),
            "{} at {:.3} s lost through the gate; found {events:#?}",
            e.pattern,
            e.time
        );
    }
    // A held sound the gate opens on is whole: the floors rise to it after the
    // silence as to a room coming back, and it is heard over the room before the
    // silence instead. (Over those floors each "hoo" ended in three pieces.)
    let held = |events: &[Event]| -> Vec<(f64, f64)> {
        events
            .iter()
            .filter_map(|e| e.end.map(|end| (e.time, end)))
            .collect()
    };
    let (whole, gated) = (held(&reference), held(&events));
    assert_eq!(whole.len(), 2, "{reference:#?}");
    assert_eq!(gated.len(), whole.len(), "{events:#?}");
    for (g, w) in gated.iter().zip(&whole) {
        assert!(
            (g.0 - w.0).abs() < 0.01 && (g.1 - w.1).abs() < 0.02,
            "held {g:?} through the gate, {w:?} without"
        );
    }
}

/// `signal` written as a float WAV named `name`, then run through `analyze` (JSON) and
/// `listen` (replayed at 20x, info log) with the bundled config: both outputs, each
/// asserted to have succeeded.
fn analyze_and_listen(name: &str, signal: &[f32], rate: u32) -> (Output, Output) {
    let dir = common::temp_dir(name);
    let wav = dir.join(format!("{name}.wav"));
    common::write_wav_f32(&wav, signal, rate);
    let bin = env!("CARGO_BIN_EXE_onomato");
    let analyzed = Command::new(bin)
        .args(["analyze"])
        .arg(&wav)
        .args(["-c", "config/onomato.toml", "--format", "json"])
        .current_dir(root())
        .output()
        .unwrap();
    assert!(analyzed.status.success());
    let listened = Command::new(bin)
        .args(["listen", "-c", "config/onomato.toml", "--input"])
        .arg(&wav)
        .args(["--speed", "20", "--print", "none", "--osc", "127.0.0.1:9"])
        .env("RUST_LOG", "info")
        .current_dir(root())
        .output()
        .unwrap();
    assert!(listened.status.success());
    (analyzed, listened)
}

/// The same burst in a float WAV file, through `analyze` and `listen`: the sounds are
/// found and the replaced samples are counted and named in the log.
#[test]
fn analyze_and_listen_report_the_samples_they_replaced() {
    let (_, mut signal, rate) = example();
    let burst = (0.010 * f64::from(rate)) as usize;
    let at = (2.0 * f64::from(rate)) as usize;
    for x in &mut signal[at..at + burst] {
        *x = f32::NAN;
    }
    let (analyzed, listened) = analyze_and_listen("bad-samples-cli", &signal, rate);
    let log = String::from_utf8_lossy(&analyzed.stderr);
    assert!(
        log.contains("were replaced") && log.contains(&format!("samples={burst}")),
        "{log}"
    );
    let json: serde_json::Value = serde_json::from_slice(&analyzed.stdout).unwrap();
    assert!(json["events"].as_array().unwrap().len() >= 13, "{json}");
    let log = String::from_utf8_lossy(&listened.stderr);
    assert!(log.contains("were replaced"), "{log}");
    assert!(log.contains(&format!("bad_samples={burst}")), "{log}");
}

/// A recording whose input gain was too high clips: its samples at full scale are
/// counted (not replaced: they are numbers within range) and warned of by `analyze` and
/// `listen`, which name the remedy.
#[test]
fn clipped_samples_are_counted_and_warned_of() {
    let (config, clean, rate) = example();
    let loud: Vec<f32> = clean.iter().map(|x| (x * 4.0).clamp(-1.0, 1.0)).collect();
    let at_full_scale = loud
        .iter()
        .filter(|x| x.abs() >= onomato::audio::CLIP_LEVEL)
        .count() as u64;
    assert!(at_full_scale > 100, "{at_full_scale}");
    let patterns = load_patterns(&config.patterns, &config.detector).unwrap();
    let mut det = Detector::new(patterns.clone(), &config.detector, rate).unwrap();
    detect_in_blocks(&mut det, &loud, 256);
    assert_eq!(
        (det.bad_samples(), det.clipped_samples()),
        (0, at_full_scale)
    );
    let mut det = Detector::new(patterns, &config.detector, rate).unwrap();
    detect_in_blocks(&mut det, &clean, 256);
    assert_eq!(det.clipped_samples(), 0);

    let (analyzed, listened) = analyze_and_listen("clipped-cli", &loud, rate);
    let log = String::from_utf8_lossy(&analyzed.stderr);
    assert!(
        log.contains("the recording clips")
            && log.contains("less gain")
            && log.contains(&format!("samples={at_full_scale}")),
        "{log}"
    );
    let log = String::from_utf8_lossy(&listened.stderr);
    assert!(log.contains("the input clips"), "{log}");
    assert!(
        log.contains(&format!("clipped_samples={at_full_scale}")),
        "{log}"
    );
}
