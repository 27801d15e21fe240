//! `onomato record --input`: a file with silence, a good take, a clipped take and a
//! take that is too long gives exactly the good take, trimmed, and the two refusals;
//! the config gets the pattern and keeps its comments and layout.

use std::process::Command;

mod common;
use common::*;

const CONFIG: &str = r#"# My voice.
# A comment that must survive.

[detector]
threshold = 0.5   # kept as written

[[pattern]]
name = "tick"
# tick comes first
takes = ["TICK"]
"#;

/// Writes `CONFIG` (with the example's tick) as `voice.toml` in `dir`; returns its
/// path and text.
fn voice_config(dir: &std::path::Path) -> (std::path::PathBuf, String) {
    let config = dir.join("voice.toml");
    let tick = root().join("examples/patterns/tick.wav");
    let original = CONFIG.replace("TICK", &tick.to_string_lossy());
    std::fs::write(&config, &original).unwrap();
    (config, original)
}

/// Runs `onomato record ARGS --config CONFIG --input INPUT`: its exit code and log.
fn record_with(
    args: &[&str],
    config: &std::path::Path,
    input: &std::path::Path,
) -> (Option<i32>, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_onomato"))
        .arg("record")
        .args(args)
        .arg("--config")
        .arg(config)
        .arg("--input")
        .arg(input)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

#[test]
fn record_from_a_file_keeps_the_good_take_refuses_the_others_and_updates_the_config() {
    let dir = temp_dir("record");
    let rate = 22_050;
    let mut rec = vec![0.0f32; samples_for(9.0, rate)];
    place(
        &mut rec,
        &buzz(rate, 0.2, 160.0),
        samples_for(0.5, rate),
        0.5,
    );
    let mut clipped = buzz(rate, 0.2, 160.0);
    for x in &mut clipped {
        *x = (*x * 3.0).clamp(-1.0, 1.0);
    }
    place(&mut rec, &clipped, samples_for(1.4, rate), 1.0);
    place(
        &mut rec,
        &buzz(rate, 6.0, 160.0),
        samples_for(2.3, rate),
        0.3,
    );
    add_noise(&mut rec, 0.0003, 5);
    let input = dir.join("takes.wav");
    write_wav_f32(&input, &rec, rate);
    let (config, original) = voice_config(&dir);

    let (code, log) = record_with(&["hum", "--continuous", "--takes", "3"], &config, &input);
    assert_eq!(code, Some(0), "{log}");
    // Where each sound was found: "a-b s", within 30 ms of where it was placed.
    let span_after = |prefix: &str| -> (f64, f64) {
        let rest = log
            .split(prefix)
            .nth(1)
            .unwrap_or_else(|| panic!("no '{prefix}' in {log}"));
        let (a, rest) = rest.split_once('-').unwrap();
        let b = rest.split(" s").next().unwrap();
        (a.trim().parse().unwrap(), b.parse().unwrap())
    };
    let near = |x: f64, y: f64| (x - y).abs() < 0.03;
    let (a, b) = span_after("take 1: ");
    assert!(near(a, 0.5) && near(b, 0.7), "take at {a}-{b}: {log}");
    let clipped_line = log
        .lines()
        .find(|l| l.contains("clipped at"))
        .expect("a clipped refusal");
    let (a, b) = span_after("refused the sound at ");
    assert!(near(a, 1.4) && near(b, 1.6), "{clipped_line}");
    let long_line = log
        .lines()
        .find(|l| l.contains("more than max_pattern_seconds (5 s)"))
        .expect("a too-long refusal");
    assert!(long_line.contains("6.0"), "{long_line}");
    assert_eq!(log.matches("refused").count(), 2, "{log}");
    assert!(
        log.contains("1 of the 3 takes asked for were found"),
        "{log}"
    );

    // Exactly one take, trimmed to the sound (0.2 s and 10 ms either side).
    let saved = dir.join("hum-1.wav");
    let reader = hound::WavReader::open(&saved).unwrap();
    let seconds = reader.duration() as f64 / f64::from(reader.spec().sample_rate);
    assert!((seconds - 0.22).abs() < 0.02, "take is {seconds} s");
    assert!(!dir.join("hum-2.wav").exists());

    // The config: everything that was there, as it was, and the new pattern.
    let text = std::fs::read_to_string(&config).unwrap();
    assert!(
        text.starts_with(&original),
        "the config was rewritten:\n{text}"
    );
    let tail = &text[original.len()..];
    assert!(
        tail.contains("name = \"hum\"") && tail.contains("kind = \"continuous\""),
        "{tail}"
    );
    assert!(tail.contains("takes = [\"hum-1.wav\"]"), "{tail}");
    let check = Command::new(env!("CARGO_BIN_EXE_onomato"))
        .args(["check", "--config"])
        .arg(&config)
        .output()
        .unwrap();
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );

    // Recording it again replaces its takes; it does not add a second 'hum'.
    let (code, log) = record_with(&["hum", "--continuous", "--takes", "1"], &config, &input);
    assert_eq!(code, Some(0), "{log}");
    let text = std::fs::read_to_string(&config).unwrap();
    assert_eq!(text.matches("name = \"hum\"").count(), 1, "{text}");
    assert!(
        text.contains("# tick comes first") && text.contains("threshold = 0.5   # kept as written")
    );
}

#[test]
fn a_file_without_a_usable_take_is_an_error_and_the_config_is_untouched() {
    let dir = temp_dir("record-none");
    let rate = 22_050;
    let mut rec = vec![0.0f32; samples_for(3.0, rate)];
    add_noise(&mut rec, 0.0003, 6);
    let input = dir.join("silence.wav");
    write_wav_f32(&input, &rec, rate);
    let (config, original) = voice_config(&dir);
    let (code, log) = record_with(&["hum"], &config, &input);
    assert_eq!(code, Some(1));
    assert!(
        log.contains("no usable take of 'hum' was found in the input file"),
        "{log}"
    );
    assert_eq!(std::fs::read_to_string(&config).unwrap(), original);
    // A bad name is refused before anything is read.
    let out = Command::new(env!("CARGO_BIN_EXE_onomato"))
        .args(["record", "my hum", "--input"])
        .arg(&input)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("found 'my hum'"));
}

/// The example's take of `name`, read as mono samples at its own rate.
fn example_take(name: &str) -> (Vec<f32>, u32) {
    read_wav_16(&root().join("examples/patterns").join(format!("{name}.wav")))
}

#[test]
fn record_warns_when_the_new_pattern_looks_like_one_the_spectral_method_has() {
    let dir = temp_dir("record-alike");
    let tick = root().join("examples/patterns/tick.wav");
    let config = dir.join("voice.toml");
    let text = format!(
        "[detector]\nmethod = \"spectral\"\n\n[[pattern]]\nname = \"tick\"\ntakes = [{:?}]\n",
        tick.to_string_lossy()
    );
    // "tock" is the example's "tick" said again; "boom" is another sound.
    for (name, source, alike) in [("tock", "tick", true), ("boom", "boom", false)] {
        std::fs::write(&config, &text).unwrap();
        let (take, rate) = example_take(source);
        let mut rec = vec![0.0f32; samples_for(2.0, rate)];
        place(&mut rec, &take, samples_for(0.5, rate), 1.0);
        add_noise(&mut rec, 0.0003, 7);
        let input = dir.join(format!("{name}-takes.wav"));
        write_wav_f32(&input, &rec, rate);
        let (code, log) = record_with(&[name, "--takes", "1"], &config, &input);
        assert_eq!(code, Some(0), "{log}");
        assert!(
            log.contains(&format!("pattern '{name}' written to")),
            "{log}"
        );
        let warning =
            format!("warning: patterns 'tick' and '{name}' look alike over their first 25 ms");
        assert_eq!(log.contains(&warning), alike, "{name}: {log}");
    }
}

#[test]
fn record_for_a_performer_takes_its_channel_and_writes_its_own_pattern() {
    let dir = temp_dir("record-performer");
    let tick = root().join("examples/patterns/tick.wav");
    let config = dir.join("duo.toml");
    let pattern = |name: &str| {
        format!(
            "[[performer.pattern]]\nname = \"{name}\"\ntakes = [{:?}]\n",
            tick.to_string_lossy()
        )
    };
    let text = format!(
        "# Two of us.\n[[performer]]\nname = \"left\"\nchannel = 0\n{}\n[[performer]]\nname = \"right\"\nchannel = 1\n{}",
        pattern("tick"),
        pattern("tick")
    );
    std::fs::write(&config, &text).unwrap();
    // Left: booms at 0.5 and 2.0 s; right: pops at 1.0 and 2.5 s.
    let (boom, rate) = example_take("boom");
    let (pop, _) = example_take("pop");
    let mut left = vec![0.0f32; samples_for(3.5, rate)];
    let mut right = left.clone();
    for at in [0.5, 2.0] {
        place(&mut left, &boom, samples_for(at, rate), 1.0);
    }
    for at in [1.0, 2.5] {
        place(&mut right, &pop, samples_for(at, rate), 1.0);
    }
    let frames: Vec<Vec<f32>> = left.iter().zip(&right).map(|(l, r)| vec![*l, *r]).collect();
    let input = dir.join("two-channels.wav");
    write_wav_int(&input, &frames, rate, 16);

    let (code, log) = record_with(
        &["pop", "--performer", "right", "--takes", "2"],
        &config,
        &input,
    );
    assert_eq!(code, Some(0), "{log}");
    // The right channel's two pops, not the left channel's booms.
    let starts: Vec<f64> = log
        .lines()
        .filter_map(|l| {
            l.strip_prefix("take ")?
                .split_once(": ")?
                .1
                .split('-')
                .next()?
                .parse()
                .ok()
        })
        .collect();
    assert_eq!(starts.len(), 2, "{log}");
    for (start, placed) in starts.iter().zip([1.0, 2.5]) {
        assert!(
            (start - placed).abs() < 0.05,
            "a take at {start} s, not at {placed} s: {log}"
        );
    }
    for k in 1..=2 {
        assert!(dir.join(format!("right-pop-{k}.wav")).exists(), "{log}");
    }
    let updated = std::fs::read_to_string(&config).unwrap();
    assert!(updated.starts_with("# Two of us.\n"), "{updated}");
    let loaded = onomato::config::Config::load(&config).unwrap();
    let names = |who: &str| -> Vec<String> {
        loaded
            .select_performer(Some(who))
            .unwrap()
            .patterns
            .iter()
            .map(|p| p.name.clone())
            .collect()
    };
    assert_eq!(names("right"), ["tick", "pop"]);
    assert_eq!(names("left"), ["tick"], "the other performer is untouched");

    // A performer the config does not have, and a config of performers without one.
    let (code, log) = record_with(&["pop", "--performer", "middle"], &config, &input);
    assert_eq!(code, Some(1));
    assert!(
        log.contains("--performer 'middle': no such performer; the config has 'left', 'right'"),
        "{log}"
    );
    let (code, log) = record_with(&["pop"], &config, &input);
    assert_eq!(code, Some(1));
    assert!(log.contains("name one with --performer"), "{log}");
}

/// `record NAME --background --input FILE`: the whole file becomes a background
/// recording, saved beside the config and added to `[detector.spectral] background`
/// (the rest of the config as it was); a file with nothing in it, or a config of the
/// waveform method, is refused and the config left alone.
#[test]
fn record_background_from_a_file_adds_it_to_the_config_and_refuses_silence() {
    let dir = temp_dir("record-background");
    let rate = 22_050;
    let mut talking = vec![0.0f32; samples_for(4.0, rate)];
    for k in 0..4 {
        let at = samples_for(0.3 + 0.9 * k as f64, rate);
        place(
            &mut talking,
            &buzz(rate, 0.25, 110.0 + 25.0 * k as f64),
            at,
            0.4,
        );
    }
    add_noise(&mut talking, 0.0003, 8);
    let input = dir.join("talking-source.wav");
    write_wav_f32(&input, &talking, rate);
    let (config, original) = voice_config(&dir);

    let (code, log) = record_with(&["talking", "--background"], &config, &input);
    assert_eq!(code, Some(0), "{log}");
    assert!(log.contains("sounds that must never fire"), "{log}");
    assert!(dir.join("talking.wav").exists());
    let text = std::fs::read_to_string(&config).unwrap();
    assert!(text.contains("# A comment that must survive."), "{text}");
    assert!(
        text.contains("threshold = 0.5   # kept as written"),
        "{text}"
    );
    assert!(text.contains("[detector.spectral]"), "{text}");
    assert!(text.contains("background = [\"talking.wav\"]"), "{text}");
    // Again: the list holds it once.
    let (code, log) = record_with(&["talking", "--background"], &config, &input);
    assert_eq!(code, Some(0), "{log}");
    let text = std::fs::read_to_string(&config).unwrap();
    assert_eq!(text.matches("talking.wav").count(), 1, "{text}");
    let check = Command::new(env!("CARGO_BIN_EXE_onomato"))
        .args(["check", "--config"])
        .arg(&config)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&check.stderr).to_string();
    assert!(check.status.success(), "{said}");
    assert!(said.contains("talking.wav': "), "{said}");

    let mut silence = vec![0.0f32; samples_for(3.0, rate)];
    add_noise(&mut silence, 0.0003, 9);
    let quiet = dir.join("silence.wav");
    write_wav_f32(&quiet, &silence, rate);
    std::fs::write(&config, &original).unwrap();
    let (code, log) = record_with(&["room", "--background"], &config, &quiet);
    assert_eq!(code, Some(1), "{log}");
    assert!(
        log.contains("nothing in the recording stands out of its quiet"),
        "{log}"
    );
    assert_eq!(std::fs::read_to_string(&config).unwrap(), original);
    assert!(!dir.join("room.wav").exists());

    let waveform = original.replace("[detector]\n", "[detector]\nmethod = \"waveform\"\n");
    std::fs::write(&config, &waveform).unwrap();
    let (code, log) = record_with(&["talking", "--background"], &config, &input);
    assert_eq!(code, Some(1), "{log}");
    assert!(
        log.contains("a background recording is for the spectral method"),
        "{log}"
    );
    assert_eq!(std::fs::read_to_string(&config).unwrap(), waveform);
}

/// A microphone's DC offset is no sound: the takes of a recording 0.05 of full scale
/// off zero are found where they are without it. Before, the offset's power stood for
/// the room, and no sound rose 20 dB out of it.
#[test]
fn takes_are_found_through_a_dc_offset() {
    let rate = 22_050;
    let mut rec = vec![0.0f32; samples_for(3.0, rate)];
    for at in [0.5, 1.5] {
        place(
            &mut rec,
            &buzz(rate, 0.2, 160.0),
            samples_for(at, rate),
            0.3,
        );
    }
    add_noise(&mut rec, 0.0003, 5);
    let spans = |rec: &[f32]| -> Vec<(usize, usize)> {
        onomato::record::find_takes(rec, rate, 5.0)
            .into_iter()
            .map(|t| (t.span.start, t.span.end))
            .collect()
    };
    let clean = spans(&rec);
    assert_eq!(clean.len(), 2, "{clean:?}");
    let offset: Vec<f32> = rec.iter().map(|x| x + 0.05).collect();
    assert_eq!(spans(&offset), clean);
}
