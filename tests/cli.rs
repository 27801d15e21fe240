//! The `onomato` binary on the bundled example: output contracts (JSON on stdout and
//! nothing else, CSV), the bounce array, `check`, and the exit codes and messages of
//! mistakes.

use std::path::Path;
use std::process::{Command, Output};

use serde_json::Value;

mod common;
use common::{noise_burst, place, root, samples_for, temp_dir, write_wav_f32, RATE};

fn onomato(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_onomato"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("run onomato")
}

/// Each command exits 1, says what is wrong on stderr (no panic), prints nothing on
/// stdout.
fn assert_each_fails_with(cases: &[(&[&str], &str)]) {
    for (args, wanted) in cases {
        let out = onomato(args);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {}", stderr(&out));
        assert!(
            stderr(&out).contains(wanted),
            "{args:?}: expected {wanted:?} in {}",
            stderr(&out)
        );
        assert!(stdout(&out).is_empty(), "{args:?} printed on stdout");
        assert!(!stderr(&out).contains("panicked"), "{args:?}");
    }
}

/// What onomato run with `args` shows when stdin, stdout and stderr are a terminal
/// (`script` from util-linux gives it one). `args` hold no spaces.
fn in_terminal(args: &[&str]) -> String {
    let command = format!("{} {}", env!("CARGO_BIN_EXE_onomato"), args.join(" "));
    let out = Command::new("script")
        .args(["-qec", &command, "/dev/null"])
        .current_dir(root())
        .output()
        .expect("script (util-linux)");
    assert!(out.status.success());
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).expect("utf-8 stdout")
}

fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).expect("utf-8 stderr")
}

struct Truth {
    onset: f64,
    label: String,
    end: Option<f64>,
    gain: f64,
}

/// A truth CSV written by examples/make-example.sh from its timeline.
fn truth_in(dir: &Path) -> Vec<Truth> {
    let text = std::fs::read_to_string(dir.join("beat.truth.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            Truth {
                onset: f[0].parse().unwrap(),
                label: f[1].to_string(),
                end: (!f[2].is_empty()).then(|| f[2].parse().unwrap()),
                gain: f[3].parse().unwrap(),
            }
        })
        .collect()
}

fn truth() -> Vec<Truth> {
    truth_in(&root().join("examples"))
}

fn analyze_example(extra: &[&str]) -> Value {
    let mut args = vec![
        "analyze",
        "examples/beat.wav",
        "--config",
        "config/onomato.toml",
    ];
    args.extend_from_slice(extra);
    let out = onomato(&args);
    assert!(out.status.success(), "stderr: {}", stderr(&out));
    serde_json::from_str(&stdout(&out)).expect("stdout is one JSON document")
}

/// How closely a method must find the example's sounds.
struct Tolerance {
    /// Onset of an impulse, seconds.
    onset: f64,
    /// Strength against the gain the sound was placed at, relative.
    strength: f64,
    /// Begin and end of a held sound, seconds.
    span: f64,
}

/// The paper's method finds exact copies to the sample and their level to a few %.
const WAVEFORM: Tolerance = Tolerance {
    onset: 0.002,
    strength: 0.03,
    span: 0.03,
};

/// The spectral method places onsets to a few ms and takes the level of the first
/// 25 ms, where a millisecond's shift moves a spoken "tick"'s vowel in or out.
const SPECTRAL: Tolerance = Tolerance {
    onset: 0.005,
    strength: 0.25,
    span: 0.05,
};

/// Every placed sound is found once, with its label, onset and level.
fn assert_matches_truth(json: &Value, truth: &[Truth], tolerance: &Tolerance) {
    let events = json["events"].as_array().unwrap();
    assert_eq!(events.len(), truth.len(), "{json:#}");
    for (i, e) in events.iter().enumerate() {
        assert_eq!(e["id"].as_u64(), Some(i as u64), "ids count up in order");
        let time = e["time"].as_f64().unwrap();
        let t = truth
            .iter()
            .find(|t| (t.onset - time).abs() < 0.1)
            .unwrap_or_else(|| panic!("event {e} matches nothing placed"));
        assert_eq!(e["pattern"], t.label.as_str());
        let strength = e["strength"].as_f64().unwrap();
        assert!(e["emitted_at"].as_f64().unwrap() >= time);
        assert!(
            (strength - t.gain).abs() / t.gain < tolerance.strength,
            "{e} vs gain {}",
            t.gain
        );
        match t.end {
            None => {
                assert_eq!(e["kind"], "impulse");
                assert!(e.get("end").is_none(), "impulses have no end: {e}");
                assert!(
                    (time - t.onset).abs() <= tolerance.onset,
                    "{e} vs {}",
                    t.onset
                );
            }
            Some(end) => {
                assert_eq!(e["kind"], "continuous");
                assert!(
                    (time - t.onset).abs() <= tolerance.span,
                    "{e} vs {}",
                    t.onset
                );
                let got_end = e["end"].as_f64().unwrap();
                assert!((got_end - end).abs() <= tolerance.span, "{e} vs end {end}");
            }
        }
    }
}

#[test]
fn analyze_prints_only_the_events_object_and_finds_the_example() {
    let json = analyze_example(&[]);
    let obj = json.as_object().unwrap();
    assert_eq!(obj.keys().collect::<Vec<_>>(), ["events"]);
    assert_matches_truth(&json, &truth(), &SPECTRAL);
    let json = analyze_example(&["--method", "waveform"]);
    assert_matches_truth(&json, &truth(), &WAVEFORM);
}

/// The bundled example is made by examples/make-example.sh (espeak-ng and sox, which
/// the test script installs): rebuilt from scratch, it must still be found exactly.
#[test]
fn the_example_script_rebuilds_an_example_that_is_found() {
    for tool in ["espeak-ng", "sox"] {
        let found = Command::new(tool).arg("--version").output().is_ok();
        assert!(
            found,
            "{tool} is needed to rebuild the example: run scripts/test.sh, which installs it"
        );
    }
    let dir = temp_dir("example");
    let script = root().join("examples/make-example.sh");
    let made = Command::new("bash")
        .arg(&script)
        .arg(&dir)
        .output()
        .unwrap();
    assert!(made.status.success(), "{}", stderr(&made));
    let pattern = |name: &str, suffix: &str| {
        format!(
            "{name}={}{suffix}",
            dir.join(format!("patterns/{name}.wav")).display()
        )
    };
    let args = [
        pattern("tick", ""),
        pattern("pop", ""),
        pattern("boom", ""),
        pattern("hoo", ":continuous"),
    ];
    let rec = dir.join("beat.wav");
    for (method, tolerance) in [("spectral", &SPECTRAL), ("waveform", &WAVEFORM)] {
        let mut argv = vec!["analyze", rec.to_str().unwrap(), "--method", method];
        for a in &args {
            argv.extend(["--pattern", a.as_str()]);
        }
        let out = onomato(&argv);
        assert!(out.status.success(), "{}", stderr(&out));
        let json: Value = serde_json::from_str(&stdout(&out)).unwrap();
        assert_matches_truth(&json, &truth_in(&dir), tolerance);
    }
}

#[test]
fn analyze_csv_has_a_header_and_a_row_per_event() {
    let out = onomato(&[
        "analyze",
        "examples/beat.wav",
        "-c",
        "config/onomato.toml",
        "--format",
        "csv",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("id,pattern,kind,time,end,strength,score,emitted_at,pitch")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), truth().len());
    assert!(rows.iter().all(|r| r.len() == 9));
    let held: Vec<&Vec<&str>> = rows.iter().filter(|r| r[2] == "continuous").collect();
    assert_eq!(held.len(), 2);
    assert!(held.iter().all(|r| !r[4].is_empty()));
    assert!(rows
        .iter()
        .filter(|r| r[2] == "impulse")
        .all(|r| r[4].is_empty()));
}

#[test]
fn bounce_adds_contacts_whose_flights_land_on_the_next_contact() {
    let json = analyze_example(&["--bounce", "--gravity", "9.81"]);
    let contacts = json["bounce"].as_array().expect("a bounce array");
    let events = json["events"].as_array().unwrap();
    assert_eq!(
        contacts.len(),
        events.len(),
        "every example sound is a contact"
    );
    for pair in contacts.windows(2) {
        let (a, b) = (&pair[0], &pair[1]);
        let launch = a["end"].as_f64().unwrap();
        let next = b["time"].as_f64().unwrap();
        let v = a["launch_velocity"].as_f64().unwrap();
        assert!((v - 9.81 * (next - launch) / 2.0).abs() < 1e-3, "{a}");
        assert_eq!(a["landing_time"].as_f64(), Some(next));
    }
    let styles: Vec<&str> = contacts
        .iter()
        .map(|c| c["style"].as_str().unwrap())
        .collect();
    assert!(styles.contains(&"soft") && styles.contains(&"slide") && styles.contains(&"hard"));
    let last = contacts.last().unwrap();
    assert_eq!(last["launch_velocity"].as_f64(), Some(0.0));
    assert!(last["landing_time"].is_null());
}

#[test]
fn patterns_can_be_given_on_the_command_line() {
    let out = onomato(&[
        "analyze",
        "examples/beat.wav",
        "--pattern",
        "tick=examples/patterns/tick.wav",
        "--pattern",
        "pop=examples/patterns/pop.wav",
        "--pattern",
        "boom=examples/patterns/boom.wav",
        "--pattern",
        "hoo=examples/patterns/hoo.wav:continuous",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: Value = serde_json::from_str(&stdout(&out)).unwrap();
    let labels: Vec<&str> = json["events"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["pattern"].as_str().unwrap())
        .collect();
    let truth = truth();
    for name in ["tick", "pop", "boom", "hoo"] {
        assert_eq!(
            labels.iter().filter(|l| **l == name).count(),
            truth.iter().filter(|t| t.label == name).count(),
            "{name}: {labels:?}"
        );
    }
    assert_eq!(labels.len(), truth.len(), "{labels:?}");
    let hoo = json["events"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["pattern"] == "hoo")
        .unwrap();
    assert_eq!(hoo["kind"], "continuous", "{hoo}");
}

#[test]
fn mistakes_exit_non_zero_with_a_message_and_print_nothing_on_stdout() {
    let cases: &[(&[&str], &str)] = &[
        (
            &[
                "analyze",
                "examples/beat.wav",
                "--pattern",
                "tick=missing.wav",
            ],
            "pattern 'tick': cannot open 'missing.wav'",
        ),
        (
            &["analyze", "examples/beat.wav"],
            "no patterns to detect: give --pattern NAME=FILE.wav",
        ),
        (
            &[
                "analyze",
                "nothing.wav",
                "-p",
                "tick=examples/patterns/tick.wav",
            ],
            "recording: cannot open 'nothing.wav'",
        ),
        (
            &[
                "analyze",
                "examples/beat.wav",
                "-c",
                "config/onomato.toml",
                "--bounce",
                "--format",
                "csv",
            ],
            "cannot be used with --format csv",
        ),
        (
            &[
                "analyze",
                "examples/beat.wav",
                "-c",
                "config/onomato.toml",
                "--threshold",
                "3",
            ],
            "threshold must be greater than 0 and at most 1, found 3",
        ),
        (
            &[
                "analyze",
                "examples/beat.wav",
                "-c",
                "config/onomato.toml",
                "--speech-guard",
                "2",
            ],
            "speech_guard_seconds must be between 0 (off) and 1, found 2",
        ),
        (
            &[
                "analyze",
                "examples/beat.wav",
                "-c",
                "config/onomato.toml",
                "--method",
                "waveform",
                "--speech-guard",
                "0",
            ],
            "--speech-guard is a setting of the spectral method; the method here is \"waveform\"",
        ),
        (
            &[
                "analyze",
                "examples/beat.wav",
                "-c",
                "config/onomato.toml",
                "--gravity",
                "0",
            ],
            "--gravity must be a positive number",
        ),
        (
            &["analyze", "examples/beat.wav", "-p", "tick"],
            "--pattern 'tick': expected NAME=FILE.wav",
        ),
        (
            &[
                "analyze",
                "examples/beat.wav",
                "-c",
                "config/onomato.toml",
                "--background",
                "missing.wav",
            ],
            "background recording: cannot open 'missing.wav'",
        ),
        (
            &[
                "analyze",
                "examples/beat.wav",
                "-c",
                "config/onomato.toml",
                "--method",
                "waveform",
                "--background",
                "examples/beat.wav",
            ],
            "background is a setting of the spectral method",
        ),
        (
            &["check", "--config", "config/missing.toml"],
            "cannot read config 'config/missing.toml'",
        ),
        (
            &["record", "talking", "--background", "--seconds", "400"],
            "--seconds must be from 5 to 300, found 400",
        ),
    ];
    assert_each_fails_with(cases);
}

#[test]
fn both_methods_run_and_an_unknown_method_is_a_usage_error() {
    for method in ["waveform", "spectral"] {
        let json = analyze_example(&["--method", method]);
        assert!(
            !json["events"].as_array().unwrap().is_empty(),
            "{method}: {json}"
        );
    }
    let out = onomato(&[
        "analyze",
        "examples/beat.wav",
        "-c",
        "config/onomato.toml",
        "--method",
        "fourier",
    ]);
    assert_eq!(out.status.code(), Some(2), "clap's usage-error code");
    assert!(
        stderr(&out).contains("invalid value 'fourier' for '--method <METHOD>'"),
        "{}",
        stderr(&out)
    );
    assert!(stderr(&out).contains("[possible values: waveform, spectral]"));
}

#[test]
fn check_accepts_the_example_and_refuses_a_broken_config() {
    let out = onomato(&["check", "--config", "config/onomato.toml"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("configuration is valid"));
    assert!(stderr(&out).contains("pattern 'hoo' (continuous): 1 take(s)"));
    // A background recording is loaded and pooled too.
    let out = onomato(&[
        "check",
        "--config",
        "config/onomato.toml",
        "--background",
        "examples/beat.wav",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("background 'examples/beat.wav': ")
            && stderr(&out).contains(" sounds that must never fire"),
        "{}",
        stderr(&out)
    );

    let dir = temp_dir("check");
    let broken = dir.join("broken.toml");
    std::fs::write(
        &broken,
        "[[pattern]]\nname = \"tick\"\ntakes = [\"tick.wav\"]\nthreshhold = 0.6\n",
    )
    .unwrap();
    let out = onomato(&["check", "--config", broken.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("unknown field `threshhold`"),
        "{}",
        stderr(&out)
    );

    // Valid TOML whose take file does not exist: check loads the takes too.
    std::fs::write(
        &broken,
        "[[pattern]]\nname = \"tick\"\ntakes = [\"tick.wav\"]\n",
    )
    .unwrap();
    let out = onomato(&["check", "--config", broken.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let want = format!(
        "cannot open '{}'",
        Path::new(&dir).join("tick.wav").display()
    );
    assert!(stderr(&out).contains(&want), "{}", stderr(&out));
}

#[test]
fn listen_mistakes_are_named_and_exit_1() {
    let cases: &[(&[&str], &str)] = &[
        (
            &[
                "listen",
                "-c",
                "config/onomato.toml",
                "--input",
                "no/such.wav",
            ],
            "no/such.wav",
        ),
        (
            &[
                "listen",
                "-c",
                "config/onomato.toml",
                "--input",
                "examples/beat.wav",
                "--speed",
                "0",
            ],
            "--speed must be above 0 and at most 1000, found 0",
        ),
        (
            &["listen", "-c", "config/onomato.toml", "--osc", "localhost"],
            "--osc: expected HOST:PORT",
        ),
        (
            &[
                "listen",
                "-c",
                "config/onomato.toml",
                "--input",
                "examples/beat.wav",
                "--background",
                "no/talking.wav",
            ],
            "background recording: cannot open 'no/talking.wav'",
        ),
        (
            &["listen", "--input", "examples/beat.wav"],
            "no patterns to detect",
        ),
        (
            &[
                "listen",
                "-c",
                "config/onomato.toml",
                "--device",
                "no-such-device",
            ],
            "no audio input device name contains 'no-such-device'",
        ),
        (
            &[
                "analyze",
                "examples/beat.wav",
                "-c",
                "config/onomato.toml",
                "--plot",
                "no/such/dir/out.svg",
            ],
            "cannot draw the plot 'no/such/dir/out.svg'",
        ),
    ];
    assert_each_fails_with(cases);
    // --speed without --input is a usage error.
    let o = onomato(&["listen", "-c", "config/onomato.toml", "--speed", "2"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn listen_logs_json_lines_when_asked() {
    let o = onomato(&[
        "listen",
        "-c",
        "config/onomato.toml",
        "--input",
        "examples/beat.wav",
        "--speed",
        "20",
        "--log-format",
        "json",
        "--print",
        "none",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).is_empty(), "--print none prints nothing");
    let lines: Vec<Value> = stderr(&o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not JSON: {l}: {e}")))
        .collect();
    assert!(lines.iter().any(|l| l["fields"]["message"] == "listening"));
    let stopped = lines
        .iter()
        .find(|l| l["fields"]["message"] == "stopped")
        .expect("a final log line");
    assert_eq!(stopped["fields"]["events"], 13);
    assert_eq!(stopped["fields"]["dropped_events"], 0);
}

#[test]
fn devices_lists_audio_inputs_and_midi_ports() {
    let o = onomato(&["devices"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(
        out.contains("audio inputs:") && out.contains("MIDI output ports:"),
        "{out}"
    );
}

#[test]
fn analyze_shows_a_progress_bar_in_a_terminal_and_nothing_otherwise() {
    // Ten minutes of audio: the example sixty times.
    let dir = temp_dir("progress");
    let mut reader = hound::WavReader::open(root().join("examples/beat.wav")).unwrap();
    let spec = reader.spec();
    let samples: Vec<i16> = reader.samples::<i16>().map(Result::unwrap).collect();
    let long = dir.join("long.wav");
    let mut w = hound::WavWriter::create(&long, spec).unwrap();
    for _ in 0..60 {
        for &s in &samples {
            w.write_sample(s).unwrap();
        }
    }
    w.finalize().unwrap();
    let long_arg = long.to_string_lossy();
    let shown = in_terminal(&[
        "analyze",
        &long_arg,
        "-c",
        "config/onomato.toml",
        ">",
        "/dev/null",
    ]);
    assert!(
        shown.contains("analysing") && shown.contains('%'),
        "{shown}"
    );
    let piped = onomato(&[
        "analyze",
        &long.to_string_lossy(),
        "-c",
        "config/onomato.toml",
    ]);
    assert!(piped.status.success());
    assert_eq!(stderr(&piped), "", "no bar when stderr is not a terminal");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn listen_in_a_terminal_prints_events_and_a_level_and_as_a_service_only_logs() {
    let args = [
        "listen",
        "-c",
        "config/onomato.toml",
        "--input",
        "examples/beat.wav",
        "--speed",
        "8",
    ];
    let shown = in_terminal(&args);
    assert!(
        shown.contains("  input #") && shown.contains(" dB "),
        "no level: {shown}"
    );
    assert_eq!(shown.matches(" impulse ").count(), 11, "{shown}");
    // As a service (stdout and stderr not terminals): no events and no level on stdout,
    // only logs on stderr.
    let service = onomato(&args);
    assert!(service.status.success());
    assert_eq!(stdout(&service), "");
    let log = stderr(&service);
    assert!(
        log.contains("listening") && !log.contains(" input #"),
        "{log}"
    );
}

/// The project's WAV at `path` resampled to 16 kHz (a narrow input), and its own rate.
fn at_16_khz(path: &str) -> (Vec<f32>, u32) {
    let mut source =
        onomato::audio::WavSource::open(&root().join(path), onomato::audio::ChannelSelect::Mix)
            .unwrap();
    let rate = source.sample_rate();
    let samples = source.read_all().unwrap();
    (
        onomato::audio::resample_clip(&samples, rate, 16_000).unwrap(),
        rate,
    )
}

#[test]
fn check_warns_of_patterns_the_spectral_method_would_take_for_each_other() {
    let tick = "examples/patterns/tick.wav";
    let boom = "examples/patterns/boom.wav";
    let same_twice = |method: &str| {
        let a = format!("a={tick}");
        let b = format!("b={tick}");
        let boom = format!("boom={boom}");
        onomato(&["check", "--method", method, "-p", &a, "-p", &b, "-p", &boom])
    };
    let out = same_twice("spectral");
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stderr(&out);
    assert!(
        text.contains("warning: patterns 'a' and 'b' look alike over their first 25 ms (similarity 1.00 of 1)"),
        "{text}"
    );
    assert_eq!(text.matches("warning:").count(), 1, "{text}");
    assert!(text.contains("configuration is valid"), "{text}");
    // The waveform method matches whole takes: no such warning.
    let out = same_twice("waveform");
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(!stderr(&out).contains("warning:"), "{}", stderr(&out));
    // The example's four sounds are told apart, over every band.
    let out = onomato(&[
        "check",
        "--config",
        "config/onomato.toml",
        "--method",
        "spectral",
    ]);
    assert!(!stderr(&out).contains("warning:"), "{}", stderr(&out));
    assert!(
        !stderr(&out).contains("carry sound up to"),
        "{}",
        stderr(&out)
    );
    // A take recorded at 16 kHz carries sound up to where the resampler's passband ends
    // there, and only the bands under it are compared.
    let dir = temp_dir("check-narrow");
    let (narrow, _) = at_16_khz(tick);
    let narrow_tick = dir.join("tick-16k.wav");
    common::write_wav_f32(&narrow_tick, &narrow, 16_000);
    let out = onomato(&[
        "check",
        "-p",
        &format!("tick={}", narrow_tick.display()),
        "-p",
        &format!("boom={boom}"),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("the takes carry sound up to 6.3 kHz"),
        "{}",
        stderr(&out)
    );
    // `analyze --explain` says so above its table.
    let out = onomato(&[
        "analyze",
        &narrow_tick.display().to_string(),
        "-p",
        &format!("tick={}", narrow_tick.display()),
        "--explain",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        stderr(&out).starts_with("only the bands under 6.3 kHz are compared"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn check_says_which_patterns_are_one_sound_repeated() {
    let dir = temp_dir("check-repeated");
    // A teeth chatter: four clicks, 15 a second.
    let click = noise_burst(RATE, 0.006, 0.0008, 41);
    let period = samples_for(1.0 / 15.0, RATE);
    let mut chatter = vec![0.0f32; samples_for(0.05, RATE) + 3 * period + click.len()];
    for k in 0..4 {
        place(
            &mut chatter,
            &click,
            samples_for(0.05, RATE) + k * period,
            1.0,
        );
    }
    let take = dir.join("chatter.wav");
    write_wav_f32(&take, &chatter, RATE);
    let out = onomato(&[
        "check",
        "-p",
        &format!("chatter={}", take.display()),
        "-p",
        "tick=examples/patterns/tick.wav",
    ]);
    let text = stderr(&out);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("pattern 'chatter': one sound repeated, its attacks at most 67 ms apart"),
        "{text}"
    );
    assert!(!text.contains("pattern 'tick': one sound"), "{text}");
}

#[test]
fn check_says_how_near_one_another_a_patterns_takes_lie() {
    let tick = "examples/patterns/tick.wav";
    let boom = "examples/patterns/boom.wav";
    let pop = "examples/patterns/pop.wav";
    // `check` with each (name, take) as a --pattern argument, its stderr.
    let check = |patterns: &[(&str, &str)], method: &str| {
        let mut args = vec!["check".to_string(), "--method".into(), method.into()];
        for (name, take) in patterns {
            args.extend(["-p".to_string(), format!("{name}={take}")]);
        }
        let out = onomato(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(out.status.success(), "{}", stderr(&out));
        stderr(&out)
    };
    // Two takes that are one sound agree fully.
    let text = check(&[("x", tick), ("x", tick), ("y", boom)], "spectral");
    assert!(
        text.contains(&format!(
            "pattern 'x': its 2 takes agree at 1.00, the least typical '{tick}'"
        )),
        "{text}"
    );
    // One take shows no spread.
    assert!(!text.contains("pattern 'y': its"), "{text}");
    // A third take that is another sound lies apart.
    let three = [("x", tick), ("x", tick), ("x", pop)];
    let text = check(&three, "spectral");
    let agree: f32 = text
        .split("its 3 takes agree at ")
        .nth(1)
        .and_then(|rest| rest.get(..4))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{text}"));
    assert!(agree < 0.9, "{text}");
    assert!(
        text.contains(&format!("the least typical '{pop}'")),
        "{text}"
    );
    // The waveform method has no tracking: nothing said.
    let text = check(&three, "waveform");
    assert!(!text.contains("takes agree"), "{text}");
}

/// The example beat heard through a 16 kHz source resampled back to its own rate on its
/// way in, its takes as recorded: `analyze -v` says how far up the recording carries
/// sound, and finds what it finds in the full-band beat.
#[test]
fn analyze_follows_a_recording_that_carries_fewer_bands_than_its_takes() {
    let (narrow, rate) = at_16_khz("examples/beat.wav");
    let back = onomato::audio::resample_clip(&narrow, 16_000, rate).unwrap();
    let dir = temp_dir("analyze-narrow");
    let narrow_beat = dir.join("beat-via-16k.wav");
    common::write_wav_f32(&narrow_beat, &back, rate);
    let events = |recording: &str| {
        let out = onomato(&[
            "analyze",
            recording,
            "--config",
            "config/onomato.toml",
            "-v",
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        let doc: Value = serde_json::from_str(&stdout(&out)).unwrap();
        let events: Vec<(String, f64)> = doc["events"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| {
                (
                    e["pattern"].as_str().unwrap().to_string(),
                    e["time"].as_f64().unwrap(),
                )
            })
            .collect();
        (events, stderr(&out))
    };
    let (full, log) = events("examples/beat.wav");
    assert!(!log.contains("the recording carries sound up to"), "{log}");
    let (heard, log) = events(&narrow_beat.display().to_string());
    assert!(log.contains("the recording carries sound up to"), "{log}");
    let found = full
        .iter()
        .filter(|(p, t)| heard.iter().any(|(q, u)| p == q && (t - u).abs() <= 0.05))
        .count();
    assert!(
        found as f64 >= 0.9 * full.len() as f64 && heard.len() <= full.len() + 1,
        "{found} of {} found again: {heard:?} against {full:?}",
        full.len()
    );
}

#[test]
fn explain_lists_every_onset_with_what_became_of_it() {
    let out = onomato(&[
        "analyze",
        "examples/beat.wav",
        "--config",
        "config/onomato.toml",
        "--explain",
    ]);
    assert!(out.status.success(), "stderr: {}", stderr(&out));
    let doc: Value = serde_json::from_str(&stdout(&out)).unwrap();
    let events = doc["events"].as_array().unwrap();
    let onsets = doc["onsets"].as_array().expect("an onsets array");
    assert!(onsets.len() >= events.len());
    // Every impulse (and every held sound's begin) is a fired onset at its time, with
    // its pattern as the best and its score.
    for e in events {
        let fired = onsets.iter().find(|o| {
            o["outcome"] == "fired"
                && (o["time"].as_f64().unwrap() - e["time"].as_f64().unwrap()).abs() < 1e-4
        });
        let o = fired.unwrap_or_else(|| panic!("no fired onset for {e}"));
        assert_eq!(o["best"], e["pattern"]);
        assert_eq!(o["best_score"], e["score"]);
    }
    let fired = onsets.iter().filter(|o| o["outcome"] == "fired").count();
    assert_eq!(fired, events.len());
    // Every other onset names the gate that stopped it.
    let named = [
        "quiet_before",
        "speech_guard",
        "continuation",
        "below_threshold",
        "background",
        "held_continues",
        "min_strength",
        "same_onset",
    ];
    for o in onsets.iter().filter(|o| o["outcome"] != "fired") {
        assert!(named.contains(&o["outcome"].as_str().unwrap()), "{o}");
    }
    // The rise above the quiet before the onset is what the first gate judged: under
    // 10 dB for every onset it stopped, at least 10 dB for every other scored one,
    // unless it began over an impulse that fired and an impulse pattern scored 0.95 (an
    // onset placed on the attack of one that fired is not scored).
    let config = onomato::Config::load(&root().join("config/onomato.toml")).unwrap();
    let held: Vec<String> = config
        .patterns
        .iter()
        .filter(|p| p.kind == onomato::PatternKind::Continuous)
        .map(|p| p.name.to_string())
        .collect();
    assert!(!held.is_empty());
    for o in onsets.iter().filter(|o| o["outcome"] != "same_onset") {
        let rise = o["rise_db"]
            .as_f64()
            .unwrap_or_else(|| panic!("no rise_db: {o}"));
        let over_a_word = o["over_fired_impulse"]
            .as_bool()
            .unwrap_or_else(|| panic!("no over_fired_impulse: {o}"));
        let impulse = held.iter().all(|name| o["best"] != *name);
        // A clear instance, or one whose take explains what is new over the tail.
        let explained = o["explained_over_tail"].as_f64().unwrap_or(0.0);
        let excused = over_a_word
            && impulse
            && (o["best_score"].as_f64().unwrap() >= 0.95 || explained >= 0.85);
        assert_eq!(
            o["outcome"] == "quiet_before",
            rise < 10.0 && !excused,
            "{o}"
        );
    }
    // Whether an impulse event has its time at `t`.
    let impulse_at = |t: f64| {
        events
            .iter()
            .any(|e| e["kind"] == "impulse" && (e["time"].as_f64().unwrap() - t).abs() < 1e-4)
    };
    // Every scored onset says how much of its sound the choice of its pattern heard:
    // about the decision window (25 ms) here, where no two patterns begin alike, or
    // two over a fired word's tail, where what a take adds to it is judged.
    for o in onsets.iter().filter(|o| o["outcome"] != "same_onset") {
        let heard = o["window_seconds"]
            .as_f64()
            .unwrap_or_else(|| panic!("no window_seconds: {o}"));
        let most = if o["explained_over_tail"].is_number() {
            0.045
        } else {
            0.03
        };
        assert!((0.015..=most).contains(&heard), "{o}");
        // More than one window, and it says why.
        let waited = o["waited_for"].as_str();
        assert_eq!(heard > 0.03, waited.is_some(), "{o}");
        if let Some(why) = waited {
            assert!(
                ["pair_alike_at_first", "between_two", "over_tail"].contains(&why),
                "{o}"
            );
        }
        // And what of its best pattern it resembled most.
        let by = o["matched_by"]
            .as_str()
            .unwrap_or_else(|| panic!("no matched_by: {o}"));
        assert!(["take", "tracked", "kept"].contains(&by), "{o}");
        // An impulse that fired says what it taught tracking; nothing else does.
        let fired_impulse = o["outcome"] == "fired" && impulse_at(o["time"].as_f64().unwrap());
        let taught = o["taught"].as_str();
        assert_eq!(fired_impulse, taught.is_some(), "{o}");
        if let Some(taught) = taught {
            assert!(
                [
                    "template_and_kept",
                    "template",
                    "nothing_amid_talk",
                    "nothing_unsure",
                    "nothing_further_than_takes"
                ]
                .contains(&taught),
                "{o}"
            );
        }
    }
    // The sound the deciding stage held against an onset, where one did: the impulse
    // that fired and whose own later sound it is, or that it repeats, from its event's
    // time; the sound before it, for the guard; nothing for the gates that judge the onset
    // alone.
    let mut continued = 0;
    for o in onsets.iter().filter(|o| o["outcome"] != "fired") {
        let time = o["time"].as_f64().unwrap();
        let held_against = &o["because_of"];
        let from = held_against["from"].as_f64();
        match o["outcome"].as_str().unwrap() {
            "continuation" | "same_onset" => {
                let from = from.unwrap_or_else(|| panic!("no because_of: {o}"));
                assert!(impulse_at(from) && from < time, "{o}");
                continued += 1;
            }
            "speech_guard" | "held_continues" => {
                assert!(from.is_some_and(|f| f < time), "{o}");
            }
            _ => assert!(held_against.is_null(), "{o}"),
        }
    }
    assert!(continued > 0, "no onset continued an impulse: {onsets:?}");
    // How each held sound ended: one record per held event, its span the event's.
    let held: Vec<&Value> = events
        .iter()
        .filter(|e| e["kind"] == "continuous")
        .collect();
    let ends = doc["held_ends"].as_array().expect("a held_ends array");
    assert_eq!(ends.len(), held.len(), "{ends:?}");
    for (e, end) in held.iter().zip(ends) {
        assert_eq!(
            (&end["pattern"], &end["time"], &end["end"]),
            (&e["pattern"], &e["time"], &e["end"])
        );
        assert!(
            ["faded", "unlike", "replaced", "stream_ended"]
                .contains(&end["ended_by"].as_str().unwrap()),
            "{end}"
        );
    }
    // A repeated sound is soon matched by what tracking kept of it, not only the takes.
    assert!(
        onsets
            .iter()
            .any(|o| o["outcome"] == "fired" && o["matched_by"] != "take"),
        "every fired onset matched a take"
    );
    // The same, as a table on stderr.
    let table = stderr(&out);
    assert!(
        table.contains("outcome") && table.contains(" by "),
        "{table}"
    );
    assert_eq!(
        table.lines().filter(|l| l.ends_with(" fired")).count(),
        events.len()
    );
}

#[test]
fn one_threshold_scale_for_both_methods_and_a_low_threshold_is_accepted() {
    // The example config's held sound keeps 0.3 as its continuous threshold: for the
    // spectral method that is a frame's likeness to the held spectrum, not a hysteresis
    // under the match threshold, so a threshold of 0.2 is accepted, and the example's
    // sounds are still found, each once.
    assert_matches_truth(
        &analyze_example(&["--threshold", "0.2"]),
        &truth(),
        &SPECTRAL,
    );
    // For the waveform method it is a hysteresis, and the error says which.
    let out = onomato(&[
        "analyze",
        "examples/beat.wav",
        "-c",
        "config/onomato.toml",
        "--method",
        "waveform",
        "--threshold",
        "0.2",
    ]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("continuous_threshold (0.3) must not be above threshold (0.2)"),
        "{}",
        stderr(&out)
    );
}

/// A config of performers: `check` checks each; `analyze` works on the one named;
/// mistakes name what there is.
#[test]
fn commands_on_a_config_of_performers_take_one_by_name() {
    let out = onomato(&["check", "-c", "config/duo.toml"]);
    assert!(out.status.success(), "{}", stderr(&out));
    for line in [
        "performer 'shooter', pattern 'pew' (impulse)",
        "performer 'runner', pattern 'whoo' (continuous)",
        "configuration is valid",
    ] {
        assert!(stderr(&out).contains(line), "{}", stderr(&out));
    }
    let out = onomato(&[
        "analyze",
        "examples/duel/moves.wav",
        "-c",
        "config/duo.toml",
        "--performer",
        "runner",
        "--format",
        "csv",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let found: Vec<String> = stdout(&out)
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().to_string())
        .collect();
    let truth: Vec<String> = std::fs::read_to_string(root().join("examples/duel/moves.truth.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().to_string())
        .collect();
    assert_eq!(found, truth);
    assert_each_fails_with(&[
        (
            &[
                "analyze",
                "examples/duel/moves.wav",
                "-c",
                "config/duo.toml",
            ],
            "the config has performers ('shooter', 'runner'); name one with --performer",
        ),
        (
            &[
                "analyze",
                "examples/duel/moves.wav",
                "-c",
                "config/duo.toml",
                "--performer",
                "drummer",
            ],
            "--performer 'drummer': no such performer",
        ),
        (
            &[
                "analyze",
                "examples/beat.wav",
                "-c",
                "config/onomato.toml",
                "--performer",
                "runner",
            ],
            "--performer 'runner': the config has no [[performer]] sections",
        ),
        (
            &["listen", "-c", "config/duo.toml", "--channel", "1"],
            "--channel: each performer of config 'config/duo.toml' has its own channel",
        ),
        (
            &[
                "listen",
                "-c",
                "config/duo.toml",
                "--input",
                "examples/duel/moves.wav",
            ],
            "performer 'runner': channel 1 (counted from 0), but the input has 1 channel",
        ),
    ]);
}

/// The README's quick start is what a stranger checks first: its printed lines (every
/// impulse, and each held sound's end) and its JSON excerpt are what the bundled example
/// gives with the present build.
#[test]
fn the_readme_quick_start_shows_what_the_example_gives() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let quoted: Vec<&str> = readme
        .lines()
        .skip_while(|l| !l.starts_with("bash scripts/example.sh"))
        .skip_while(|l| !l.trim_start().starts_with("0.400 s"))
        .take_while(|l| l.trim() != "...")
        .collect();
    assert!(quoted.len() >= 5, "no printed events in the quick start");
    let config = onomato::Config::load(&root().join("config/onomato.toml")).unwrap();
    let analysis =
        onomato::analyze::analyze_file(&root().join("examples/beat.wav"), &config).unwrap();
    let printed: Vec<String> = analysis
        .events
        .iter()
        .filter_map(|e| {
            onomato::output::print::format_event(None, e, true, onomato::output::PrintMode::Text)
        })
        .map(|l| l.trim_end().to_string())
        .collect();
    for line in quoted.iter().filter(|l| !l.contains(" begin ")) {
        assert!(
            printed.iter().any(|p| p == line),
            "the README prints\n{line}\nthe example gives\n{}",
            printed.join("\n")
        );
    }
    // The JSON excerpt: each record it shows whole (events by id, bounces by event) is
    // the example's.
    let out = onomato(&[
        "analyze",
        "examples/beat.wav",
        "--config",
        "config/onomato.toml",
        "--bounce",
    ]);
    let doc: Value = serde_json::from_str(&stdout(&out)).unwrap();
    let excerpt = readme
        .split("```json")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("a JSON excerpt");
    let mut shown = 0;
    for (start, _) in excerpt.match_indices("{\"") {
        let Some(len) = excerpt[start..].find('}') else {
            continue;
        };
        let Ok(record) = serde_json::from_str::<Value>(&excerpt[start..=start + len]) else {
            continue;
        };
        let (list, key) = if record.get("launch_velocity").is_some() {
            ("bounce", "event")
        } else {
            ("events", "id")
        };
        let given = doc[list]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r[key] == record[key]);
        assert_eq!(given, Some(&record), "the README shows {record}");
        shown += 1;
    }
    assert!(shown >= 3, "{excerpt}");
}
