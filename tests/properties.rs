//! Properties over inputs no one wrote by hand (proptest): any TOML text, damaged WAV
//! files, and sample blocks of any size and content. Nothing panics, every error names
//! the file it is about, and the detector's events stay finite and in order.
//!
//! Each property runs 256 cases by default; `PROPTEST_CASES=100000 cargo test
//! --release --test properties` searches longer. A failing case is shrunk and saved
//! under `tests/properties.proptest-regressions`, which is committed and replayed first.

use std::path::Path;

use proptest::prelude::*;

use onomato::audio::{resample_clip, ChannelSelect, WavSource};
use onomato::config::{Config, Method};
use onomato::detect::Detector;

mod common;
use common::{root, RATE};

fn example_config() -> String {
    std::fs::read_to_string(root().join("config/onomato.toml")).unwrap()
}

/// The example config with lines dropped, doubled or cut short, and bytes changed.
fn damaged_config() -> impl Strategy<Value = String> {
    let lines = example_config().lines().count();
    (
        prop::collection::vec((0..lines, 0u8..4, any::<u8>()), 1..6),
        any::<u64>(),
    )
        .prop_map(|(edits, _)| {
            let mut lines: Vec<String> = example_config().lines().map(String::from).collect();
            for (at, what, byte) in edits {
                let at = at.min(lines.len().saturating_sub(1));
                if lines.is_empty() {
                    break;
                }
                match what {
                    0 => {
                        lines.remove(at);
                    }
                    1 => {
                        let copy = lines[at].clone();
                        lines.insert(at, copy);
                    }
                    2 => {
                        let keep = lines[at].len() * usize::from(byte) / 256;
                        let cut: String = lines[at].chars().take(keep).collect();
                        lines[at] = cut;
                    }
                    _ => {
                        let mut bytes = lines[at].clone().into_bytes();
                        if !bytes.is_empty() {
                            let i = usize::from(byte) % bytes.len();
                            bytes[i] = byte.clamp(b' ', b'~');
                        }
                        lines[at] = String::from_utf8_lossy(&bytes).into_owned();
                    }
                }
            }
            lines.join("\n")
        })
}

/// TOML-looking text: keys of the config, values of every type, tables and arrays.
fn toml_like() -> impl Strategy<Value = String> {
    let key = prop::sample::select(vec![
        "threshold",
        "method",
        "name",
        "kind",
        "takes",
        "note",
        "targets",
        "prefix",
        "bundle",
        "channel",
        "device",
        "speech_guard",
        "virtual_port",
        "gravity",
        "hard",
        "x",
    ]);
    let value = prop_oneof![
        any::<i64>().prop_map(|v| v.to_string()),
        any::<f64>().prop_map(|v| format!("{v:?}")),
        "[a-z0-9:./ ]{0,12}".prop_map(|s| format!("\"{s}\"")),
        Just("true".to_string()),
        Just("[]".to_string()),
        Just("[\"a\", 1]".to_string()),
        Just("nan".to_string()),
        Just("inf".to_string()),
    ];
    let table = prop::sample::select(vec![
        "[detector]",
        "[[pattern]]",
        "[osc]",
        "[midi]",
        "[input]",
        "[bounce]",
        "[nope]",
        "",
    ]);
    prop::collection::vec((table, prop::collection::vec((key, value), 0..4)), 0..6).prop_map(
        |tables| {
            tables
                .into_iter()
                .map(|(t, kv)| {
                    let body: Vec<String> =
                        kv.into_iter().map(|(k, v)| format!("{k} = {v}")).collect();
                    format!("{t}\n{}\n", body.join("\n"))
                })
                .collect()
        },
    )
}

fn check_config(text: &str) -> Result<(), TestCaseError> {
    match Config::parse(text, &root().join("config"), "config 'fuzz.toml'") {
        Ok(config) => {
            // What validation promises of a config it lets through.
            let mut names: Vec<&str> = config.patterns.iter().map(|p| p.name.as_str()).collect();
            names.sort_unstable();
            prop_assert!(
                names.windows(2).all(|w| w[0] != w[1]),
                "a name twice: {names:?}"
            );
            prop_assert!(config.patterns.iter().all(|p| !p.takes.is_empty()));
            let t = config.detector.threshold();
            prop_assert!(t > 0.0 && t <= 1.0, "threshold {t}");
        }
        Err(e) => {
            let message = e.to_string();
            prop_assert!(
                message.contains("fuzz.toml"),
                "an error that does not name the file: {message}"
            );
        }
    }
    Ok(())
}

proptest! {
    #[test]
    fn any_text_is_a_config_or_an_error_that_names_the_file(text in "\\PC{0,400}") {
        check_config(&text)?;
    }

    #[test]
    fn toml_with_the_configs_keys_and_any_values_is_a_config_or_a_named_error(text in toml_like()) {
        check_config(&text)?;
    }

    #[test]
    fn a_damaged_example_config_is_a_config_or_a_named_error(text in damaged_config()) {
        check_config(&text)?;
    }
}

/// A valid WAV file in memory.
fn wav_bytes(bits: u16, float: bool, channels: u16, rate: u32, frames: usize) -> Vec<u8> {
    let spec = hound::WavSpec {
        channels,
        sample_rate: rate,
        bits_per_sample: bits,
        sample_format: if float {
            hound::SampleFormat::Float
        } else {
            hound::SampleFormat::Int
        },
    };
    let mut cursor = std::io::Cursor::new(Vec::new());
    {
        let mut w = hound::WavWriter::new(&mut cursor, spec).unwrap();
        for i in 0..frames * usize::from(channels) {
            let x = ((i as f32) * 0.01).sin() * 0.5;
            if float {
                w.write_sample(x).unwrap();
            } else {
                w.write_sample((x * ((1i64 << (bits - 1)) - 1) as f32) as i32)
                    .unwrap();
            }
        }
        w.finalize().unwrap();
    }
    cursor.into_inner()
}

fn read_wav(path: &Path, select: ChannelSelect) -> Result<(), TestCaseError> {
    let named = |message: String| -> Result<(), TestCaseError> {
        prop_assert!(
            message.contains(&*path.to_string_lossy()),
            "an error that does not name the file: {message}"
        );
        Ok(())
    };
    match WavSource::open(path, select) {
        Err(e) => named(e.to_string())?,
        Ok(mut source) => match source.read_all() {
            Err(e) => named(e.to_string())?,
            Ok(samples) => {
                // What the loaders do next: bring it to the working rate.
                let _ = resample_clip(
                    &samples[..samples.len().min(4096)],
                    source.sample_rate(),
                    RATE,
                );
            }
        },
    }
    Ok(())
}

proptest! {
    #[test]
    fn a_damaged_wav_file_is_read_or_refused_with_its_name(
        format in prop::sample::select(vec![(8u16, false), (16, false), (24, false), (32, false), (32, true)]),
        channels in 1u16..4,
        rate in prop::sample::select(vec![8_000u32, 22_050, 44_100, 48_000, 96_000]),
        frames in 0usize..300,
        edits in prop::collection::vec((0usize..80, any::<u8>()), 0..8),
        cut in prop::option::of(0usize..2000),
        channel in prop::option::of(0u16..5),
    ) {
        let mut bytes = wav_bytes(format.0, format.1, channels, rate, frames);
        for (at, byte) in edits {
            if at < bytes.len() {
                bytes[at] = byte;
            }
        }
        if let Some(cut) = cut {
            bytes.truncate(cut);
        }
        let dir = common::temp_dir("properties-wav");
        let path = dir.join(format!("damaged-{}.wav", std::process::id()));
        std::fs::write(&path, &bytes).unwrap();
        let select = channel.map_or(ChannelSelect::Mix, ChannelSelect::Index);
        read_wav(&path, select)?;
    }

    #[test]
    fn any_bytes_are_read_or_refused_with_their_name(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let dir = common::temp_dir("properties-bytes");
        let path = dir.join("bytes.wav");
        let mut with_header = b"RIFF\x24\x00\x00\x00WAVEfmt ".to_vec();
        with_header.extend_from_slice(&bytes);
        for candidate in [&bytes, &with_header] {
            std::fs::write(&path, candidate).unwrap();
            read_wav(&path, ChannelSelect::Mix)?;
        }
    }
}

/// Samples that a float device or a corrupt stream can deliver.
fn nasty_sample() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -1.0f32..1.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(f32::MIN_POSITIVE / 4.0),
        1 => Just(1e20f32),
        1 => Just(-1e20f32),
        1 => Just(1.0f32),
        1 => Just(-1.0f32),
        1 => Just(0.0f32),
    ]
}

/// Runs of samples: a full-scale square wave, a constant, or sample by sample.
fn signal() -> impl Strategy<Value = Vec<f32>> {
    let run = prop_oneof![
        (1usize..400, 1usize..2000, -1.0f32..=1.0).prop_map(|(half, len, level)| {
            (0..len)
                .map(|i| if (i / half) % 2 == 0 { level } else { -level })
                .collect::<Vec<f32>>()
        }),
        (nasty_sample(), 1usize..3000).prop_map(|(x, len)| vec![x; len]),
        prop::collection::vec(nasty_sample(), 1..2000),
    ];
    prop::collection::vec(run, 1..12).prop_map(|runs| runs.concat())
}

fn detectors() -> Vec<(Method, Detector, u32)> {
    let mut out = Vec::new();
    for method in [Method::Spectral, Method::Waveform] {
        let (settings, patterns) = common::patterns_for(method);
        for rate in [RATE, 48_000] {
            out.push((
                method,
                Detector::new(patterns.clone(), &settings, rate).unwrap(),
                rate,
            ));
        }
    }
    out
}

proptest! {
    // Each case runs four detectors over up to a few seconds of audio: 64 by default,
    // `PROPTEST_CASES` when it is set.
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(64),
        ..ProptestConfig::default()
    })]
    #[test]
    fn any_samples_in_blocks_of_any_size_give_finite_events_in_order(
        samples in signal(),
        blocks in prop::collection::vec(1usize..5000, 1..20),
    ) {
        for (method, mut detector, rate) in detectors() {
            let mut events = Vec::with_capacity(1024);
            let mut at = 0;
            let mut k = 0;
            while at < samples.len() {
                let n = blocks[k % blocks.len()].min(samples.len() - at);
                detector.process(&samples[at..at + n], &mut events);
                at += n;
                k += 1;
            }
            detector.finish(&mut events);
            let end = samples.len() as f64 / f64::from(rate);
            for e in &events {
                prop_assert!(
                    e.time.is_finite() && e.strength.is_finite() && e.score.is_finite(),
                    "{method:?} at {rate} Hz: {e:?}"
                );
                prop_assert!(e.time >= 0.0 && e.time <= end + 1e-9, "{method:?}: {e:?} outside 0..{end}");
                prop_assert!(e.end.is_none_or(|x| x.is_finite() && x >= e.time), "{e:?}");
            }
            let ids: Vec<u64> = events.iter().filter(|e| e.end.is_none() || e.kind == onomato::PatternKind::Impulse).map(|e| e.id).collect();
            prop_assert!(ids.windows(2).all(|w| w[0] < w[1]), "{method:?}: ids {ids:?}");
        }
    }
}
