//! The configuration: the shipped example loads (it is a fixture, so it cannot go
//! stale), and every mistake is an error naming the key, the expected and the found value.

use std::path::Path;

use onomato::config::{
    parse_pattern_args, Config, ContactStyle, DartsAction, LaserAction, Method, PatternKind, Scene,
};
use onomato::pattern::load_patterns;

fn parse_err(text: &str) -> String {
    match Config::parse(text, Path::new("."), "config 'test.toml'") {
        Ok(c) => panic!("accepted: {c:?}"),
        Err(e) => e.to_string(),
    }
}

const TICK: &str = "[[pattern]]\nname = \"tick\"\ntakes = [\"tick.wav\"]\n";

#[test]
fn the_example_config_loads_with_its_patterns() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/onomato.toml");
    let config = Config::load(&path).expect("example config is valid");
    assert_eq!(config.detector.method, Method::Spectral);
    assert_eq!(config.detector.sample_rate, 22_050);
    assert_eq!(config.detector.min_strength, 0.06);
    assert_eq!(config.detector.max_decision_seconds, 0.055);
    let names: Vec<&str> = config.patterns.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["tick", "pop", "boom", "hoo"]);
    assert_eq!(config.patterns[3].kind, PatternKind::Continuous);
    let bounce = config.bounce.as_ref().expect("example has [bounce]");
    assert_eq!(bounce.styles["pop"], ContactStyle::Soft);
    assert_eq!(bounce.styles["hoo"], ContactStyle::Slide);
    assert_eq!(config.input.buffer_frames, 256);
    let osc = config.osc.as_ref().expect("example has [osc]");
    assert_eq!(osc.targets, ["127.0.0.1:9000"]);
    assert_eq!(osc.prefix, "/onomato");
    let notes: Vec<Option<u8>> = config.patterns.iter().map(|p| p.note).collect();
    assert_eq!(notes, [Some(42), Some(38), Some(36), Some(60)]);
    // Its take paths are relative to the config file, and the files are there.
    let patterns =
        load_patterns(&config.patterns, &config.detector).expect("example patterns load");
    assert_eq!(patterns.len(), 4);
    let render = &config.render;
    assert_eq!(render.scene, Some(Scene::Ball));
    assert_eq!(render.darts.as_ref().unwrap()["hoo"], DartsAction::Up);
    assert_eq!(
        render.laser.as_ref().unwrap()["pop"],
        LaserAction::ShootHigh
    );
    assert_eq!(render.rain.as_ref().unwrap().len(), 3);
    assert!(render.tracks.is_empty());
}

#[test]
fn the_threshold_left_out_is_the_methods_own_and_one_written_is_kept() {
    let parse = |text: &str| Config::parse(text, Path::new("."), "config 'test.toml'").unwrap();
    let spectral = parse(TICK);
    assert_eq!(spectral.detector.threshold(), 0.3);
    let mut waveform = parse(&format!("[detector]\nmethod = \"waveform\"\n{TICK}"));
    assert_eq!(waveform.detector.threshold(), 0.5);
    // A method chosen later (as --method does) brings its own default along...
    waveform.detector.method = Method::Spectral;
    assert_eq!(waveform.detector.threshold(), 0.3);
    // ...but not over a threshold that was written.
    let mut written = parse(&format!("[detector]\nthreshold = 0.6\n{TICK}"));
    written.detector.method = Method::Waveform;
    assert_eq!(written.detector.threshold(), 0.6);
}

#[test]
fn unknown_keys_are_errors_that_name_the_key() {
    let msg = parse_err("[detector]\ntreshold = 0.5\n");
    assert!(
        msg.contains("unknown field `treshold`") && msg.contains("expected one of"),
        "{msg}"
    );
    let msg = parse_err(&format!("{TICK}colour = \"red\"\n"));
    assert!(msg.contains("unknown field `colour`"), "{msg}");
    let msg = parse_err("[output]\nosc = 1\n");
    assert!(msg.contains("unknown field `output`"), "{msg}");
    let msg = parse_err(&format!("{TICK}[bounce]\ngravty = 3\n"));
    assert!(msg.contains("unknown field `gravty`"), "{msg}");
    assert!(
        msg.contains("test.toml"),
        "the message names the file: {msg}"
    );
}

#[test]
fn bad_values_name_the_item_and_what_was_expected_and_found() {
    let cases: &[(&str, &[&str])] = &[
        ("[detector]\nmethod = \"fourier\"\n", &["unknown variant `fourier`", "`waveform`"]),
        ("[detector]\nthreshold = 1.5\n", &["[detector]", "threshold must be greater than 0 and at most 1, found 1.5"]),
        ("[detector]\nsample_rate = 4000\n", &["sample_rate must be between 8000 and 192000 Hz, found 4000"]),
        ("[detector]\nsample_rate = \"fast\"\n", &["invalid type", "expected u32"]),
        ("[detector]\nmax_pattern_seconds = 0\n", &["max_pattern_seconds must be between 0.05 and 60, found 0"]),
        ("[detector]\nmethod = \"waveform\"\n[detector.waveform]\nsuppression_seconds = -1\n", &["[detector.waveform]", "suppression_seconds must be between 0 and 5, found -1"]),
        ("[detector.spectral]\nspeech_guard_seconds = 2\n", &["[detector.spectral]", "speech_guard_seconds must be between 0 (off) and 1, found 2"]),
        ("[detector.spectral]\nmin_strength = 1.5\n", &["[detector.spectral]", "min_strength must be between 0 (any level) and 1, found 1.5"]),
        ("[detector.spectral]\ndecision_seconds = 0.01\n", &["[detector.spectral]", "decision_seconds must be between 0.015 and 0.2, found 0.01"]),
        ("[detector.spectral]\nmax_decision_seconds = 0.02\n", &["[detector.spectral]", "max_decision_seconds must be between decision_seconds (0.025) and 0.2, found 0.02"]),
        ("[detector]\nmax_decision_seconds = 0.05\n", &["max_decision_seconds is a setting of the spectral method: put it in [detector.spectral]"]),
        // A method's settings live in its own table, and only the configured method's
        // table may be there.
        ("[detector]\nmin_strength = 0.1\n", &["[detector]", "min_strength is a setting of the spectral method: put it in [detector.spectral]"]),
        ("[detector]\nsuppression_seconds = 0.1\n", &["suppression_seconds is a setting of the waveform method: put it in [detector.waveform]"]),
        ("[detector.waveform]\nsuppression_seconds = 0.1\n", &["[detector.waveform] is for method = \"waveform\", but this config's method is \"spectral\""]),
        ("[detector]\nmethod = \"waveform\"\n[detector.spectral]\nmin_strength = 0.1\n", &["[detector.spectral] is for method = \"spectral\", but this config's method is \"waveform\""]),
        ("[detector.spectral]\nsuppression_seconds = 0.1\n", &["unknown field `suppression_seconds`", "min_strength"]),
        ("[detector.spectral]\nbackground = \"talking.wav\"\n", &["invalid type", "expected a sequence"]),
        (&format!("{TICK}threshold = 0\n"), &["pattern #1 ('tick')", "threshold must be greater than 0 and at most 1, found 0"]),
        ("[[pattern]]\nname = \"tick\"\ntakes = []\n", &["pattern #1 ('tick')", "takes is empty; expected at least one WAV file"]),
        ("[[pattern]]\nname = \"tick\"\n", &["missing field `takes`"]),
        ("[[pattern]]\nname = \"my tick\"\ntakes = [\"a.wav\"]\n", &["letters, digits", "found 'my tick'"]),
        ("[[pattern]]\nname = \"a/b\"\ntakes = [\"a.wav\"]\n", &["found 'a/b'"]),
        (&format!("{TICK}{TICK}"), &["pattern #2 ('tick')", "is used twice"]),
        ("[[pattern]]\nname = \"x\"\nkind = \"held\"\ntakes = [\"a.wav\"]\n", &["unknown variant `held`", "`impulse`", "`continuous`"]),
        (&format!("{TICK}continuous_threshold = 0.2\n"), &["only for kind = \"continuous\""]),
        ("[detector]\nmethod = \"waveform\"\n[[pattern]]\nname = \"hum\"\nkind = \"continuous\"\ntakes = [\"a.wav\"]\nthreshold = 0.4\ncontinuous_threshold = 0.6\n", &["pattern #1 ('hum')", "continuous_threshold (0.6) must not be above threshold (0.4)"]),
        (&format!("{TICK}[bounce]\nhard = [\"pop\"]\n"), &["[bounce]", "hard names pattern 'pop', which is not defined"]),
        (&format!("{TICK}[bounce]\nslide = [\"tick\"]\n"), &["slide expects continuous patterns, but 'tick' is impulse"]),
        (&format!("{TICK}[bounce]\nhard = [\"tick\"]\nsoft = [\"tick\"]\n"), &["'tick' is given more than one contact style"]),
        (&format!("{TICK}[bounce]\ngravity = -9.81\n"), &["gravity must be a positive number (m/s²), found -9.81"]),
        (&format!("{TICK}[bounce]\nmax_squash = 1.5\n"), &["max_squash must be at least 0 and below 1, found 1.5"]),
        (&format!("{TICK}[bounce]\nstate_delay_seconds = 7\n"), &["state_delay_seconds must be between 0 and 5 seconds, found 7"]),
        (&format!("{TICK}note = 128\n"), &["pattern #1 ('tick')", "note must be a MIDI number from 0 to 127, found 128"]),
        (&format!("{TICK}channel = 0\n"), &["pattern #1 ('tick')", "channel must be a MIDI channel from 1 to 16, found 0"]),
        ("[input]\nbuffer_frames = 4\n", &["[input]", "buffer_frames must be between 16 and 8192, found 4"]),
        ("[input]\nsample_rate = 1000\n", &["[input]", "sample_rate must be between 8000 and 192000 Hz, found 1000"]),
        ("[input]\ndevice = \" \"\n", &["[input]", "device is empty"]),
        ("[input]\nbuffer = 256\n", &["unknown field `buffer`", "buffer_frames"]),
        ("[osc]\ntargets = [\"localhost\"]\n", &["[osc]", "expected HOST:PORT", "found 'localhost'"]),
        ("[osc]\ntargets = [\"localhost:0\"]\n", &["UDP port from 1 to 65535", "found '0'"]),
        ("[osc]\ntargets = [\"localhost:70000\"]\n", &["found '70000'"]),
        ("[osc]\nprefix = \"onomato\"\n", &["[osc]", "prefix must start with '/'", "found 'onomato'"]),
        ("[osc]\nprefix = \"/my app\"\n", &["found '/my app'"]),
        ("[osc]\nheartbeat_seconds = 0\n", &["heartbeat_seconds must be between 0.1 and 3600 seconds, found 0"]),
        ("[osc]\nbounce_state_rate = 5000\n", &["bounce_state_rate must be between 1 and 1000 Hz, found 5000"]),
        ("[osc]\nport = 9000\n", &["unknown field `port`", "targets"]),
        ("[midi]\nconnect = \"a\"\nvirtual_port = \"b\"\n", &["[midi]", "not both"]),
        ("[midi]\nchannel = 17\n", &["[midi]", "found 17"]),
        ("[midi]\nvelocity_min = 100\nvelocity_max = 50\n", &["velocity_min (100) must not be above velocity_max (50)"]),
        ("[midi]\nvelocity_max = 0\n", &["velocity_max must be from 1 to 127, found 0"]),
        ("[midi]\ngate_seconds = 20\n", &["gate_seconds must be between 0.001 and 10 seconds, found 20"]),
        ("[midi]\nfull_strength = 0\n", &["full_strength must be a positive number, found 0"]),
        ("[midi]\nvelocity_curve = 50\n", &["velocity_curve must be between 0.1 and 10, found 50"]),
    ];
    for (text, wanted) in cases {
        let msg = parse_err(text);
        for w in *wanted {
            assert!(msg.contains(w), "for {text:?}\nexpected {w:?} in: {msg}");
        }
    }
}

#[test]
fn listen_settings_default_when_left_out() {
    use onomato::config::{MidiPortChoice, MidiSettings, DEFAULT_OSC_PREFIX};
    let config = Config::parse(&format!("{TICK}[osc]\n[midi]\n"), Path::new("."), "x").unwrap();
    assert_eq!(config.input.device, None);
    assert_eq!(config.input.sample_rate, None);
    assert_eq!(config.input.buffer_frames, 256);
    let osc = config.osc.unwrap();
    assert!(osc.targets.is_empty());
    assert_eq!(osc.prefix, DEFAULT_OSC_PREFIX);
    assert!(!osc.bundle);
    assert_eq!(osc.heartbeat_seconds, None);
    let midi = config.midi.unwrap();
    assert_eq!(midi.port, MidiPortChoice::Virtual("onomato".into()));
    assert_eq!(midi.channel, 10);
    assert_eq!(
        midi,
        MidiSettings::with_port(MidiPortChoice::Virtual("onomato".into()))
    );
    // No [osc] or [midi]: no OSC, no MIDI.
    let config = Config::parse(TICK, Path::new("."), "x").unwrap();
    assert!(config.osc.is_none() && config.midi.is_none());
}

#[test]
fn velocity_follows_the_strength_through_the_curve_and_stays_in_1_to_127() {
    use onomato::config::{MidiPortChoice, MidiSettings};
    let mut m = MidiSettings::with_port(MidiPortChoice::Virtual("x".into()));
    m.full_strength = 2.0;
    assert_eq!(m.velocity(0.0), 1);
    assert_eq!(m.velocity(1.0), 64); // 1 + 126 × 0.5
    assert_eq!(m.velocity(2.0), 127);
    assert_eq!(m.velocity(50.0), 127);
    assert_eq!(m.velocity(f64::NAN), 1);
    assert_eq!(m.velocity(-1.0), 1);
    m.velocity_curve = 2.0;
    assert_eq!(m.velocity(1.0), 33); // 1 + 126 × 0.25 = 32.5, rounded up
    m.velocity_min = 40;
    m.velocity_max = 100;
    m.velocity_curve = 1.0;
    assert_eq!(m.velocity(0.0), 40);
    assert_eq!(m.velocity(1.0), 70);
    assert_eq!(m.velocity(9.0), 100);
}

#[test]
fn a_missing_config_file_is_named() {
    let msg = Config::load(Path::new("no/such/onomato.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("cannot read config 'no/such/onomato.toml'"),
        "{msg}"
    );
}

#[test]
fn take_paths_are_relative_to_the_config_file() {
    let config = Config::parse(TICK, Path::new("/srv/voice"), "x").unwrap();
    assert_eq!(
        config.patterns[0].takes[0],
        Path::new("/srv/voice/tick.wav")
    );
}

#[test]
fn background_recordings_are_relative_to_the_config_file_and_the_spectral_methods() {
    let toml = format!(
        "{TICK}[detector.spectral]\nbackground = [\"me/talking.wav\", \"/rec/room.wav\"]\n"
    );
    let config = Config::parse(&toml, Path::new("/srv/voice"), "x").unwrap();
    assert_eq!(
        config.detector.background,
        [
            Path::new("/srv/voice/me/talking.wav"),
            Path::new("/rec/room.wav")
        ]
    );
    assert!(Config::parse(TICK, Path::new("/srv/voice"), "x")
        .unwrap()
        .detector
        .background
        .is_empty());
    // Given on the command line with the paper's method: refused, not ignored.
    let mut waveform = config.detector.clone();
    waveform.method = Method::Waveform;
    let msg = waveform.validate("command line").unwrap_err().to_string();
    assert!(
        msg.contains("background is a setting of the spectral method")
            && msg.contains("\"waveform\""),
        "{msg}"
    );
}

#[test]
fn pattern_arguments_parse_and_repeat_names_add_takes() {
    let args: Vec<String> = ["tick=a.wav", "hum=b.wav:continuous", "tick=c.wav:impulse"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let specs = parse_pattern_args(&args).unwrap();
    assert_eq!(specs.len(), 2);
    assert_eq!(specs[0].name, "tick");
    assert_eq!(specs[0].takes, [Path::new("a.wav"), Path::new("c.wav")]);
    assert_eq!(specs[1].kind, PatternKind::Continuous);
    assert_eq!(specs[1].takes, [Path::new("b.wav")]);
}

#[test]
fn bad_pattern_arguments_are_explained() {
    let err = |a: &[&str]| {
        let args: Vec<String> = a.iter().map(|s| s.to_string()).collect();
        parse_pattern_args(&args).unwrap_err().to_string()
    };
    let msg = err(&["tick.wav"]);
    assert!(
        msg.contains("--pattern 'tick.wav'") && msg.contains("expected NAME=FILE.wav"),
        "{msg}"
    );
    let msg = err(&["tick="]);
    assert!(msg.contains("file name after '=' is empty"), "{msg}");
    let msg = err(&["=a.wav"]);
    assert!(msg.contains("found ''"), "{msg}");
    let msg = err(&["hum=a.wav:continuous", "hum=b.wav"]);
    assert!(
        msg.contains("given as continuous before, and as impulse here"),
        "{msg}"
    );
}

#[test]
fn command_line_patterns_may_not_reuse_a_config_name() {
    let mut config = Config::parse(TICK, Path::new("."), "x").unwrap();
    let specs = parse_pattern_args(&["tick=other.wav".to_string()]).unwrap();
    let msg = config.add_cli_patterns(specs).unwrap_err().to_string();
    assert!(
        msg.contains("pattern 'tick' is already defined in the config"),
        "{msg}"
    );
}

const TICK_AND_HOO: &str = "[[pattern]]\nname = \"tick\"\ntakes = [\"tick.wav\"]\n\
[[pattern]]\nname = \"hoo\"\nkind = \"continuous\"\ntakes = [\"hoo.wav\"]\n";

#[test]
fn render_actions_and_tracks_are_checked_against_the_patterns() {
    let render = |section: &str| parse_err(&format!("{TICK_AND_HOO}[render]\n{section}"));
    let e = render("darts = { hoo = \"throw\" }");
    assert!(
        e.contains("[render]")
            && e.contains("darts: 'hoo' cannot throw")
            && e.contains("impulse patterns, and 'hoo' is continuous"),
        "{e}"
    );
    let e = render("laser = { tick = \"slide\" }");
    assert!(e.contains("laser: 'tick' cannot slide"), "{e}");
    let e = render("darts = { tick = \"fly\" }");
    assert!(
        e.contains("fly") && e.contains("throw") && e.contains("down"),
        "{e}"
    );
    let e = render("laser = { pew = \"jump\" }");
    assert!(
        e.contains("laser names pattern 'pew', which is not defined"),
        "{e}"
    );
    let e = render("rain = [\"hoo\"]");
    assert!(e.contains("rain: 'hoo' cannot drop a drop"), "{e}");
    let e = render("scene = \"snow\"");
    assert!(e.contains("snow") && e.contains("laser"), "{e}");
    let e = render("[[render.track]]\npatterns = [\"tick\"]\n[[render.track]]\npatterns = []");
    assert!(e.contains("track #2: patterns is empty"), "{e}");
    let e = render("[[render.track]]\npatterns = [\"tock\"]");
    assert!(e.contains("track #1 names pattern 'tock'"), "{e}");
    let e = render("balls = 2");
    assert!(e.contains("balls"), "{e}");
    let ok = Config::parse(
        &format!("{TICK_AND_HOO}[render]\nscene = \"darts\"\n[[render.track]]\npatterns = [\"tick\"]\n[[render.track]]\npatterns = [\"hoo\", \"tick\"]\n"),
        Path::new("."),
        "config 'test.toml'",
    )
    .unwrap();
    assert_eq!(ok.render.scene, Some(Scene::Darts));
    assert_eq!(ok.render.tracks, [vec!["tick"], vec!["hoo", "tick"]]);
}

#[test]
fn the_preview_section_defaults_to_loopback_and_refuses_what_is_not_an_address() {
    use onomato::config::DEFAULT_PREVIEW_ADDRESS;
    let config = Config::parse(&format!("{TICK}[preview]\n"), Path::new("."), "x").unwrap();
    assert_eq!(
        config.preview.unwrap().address.to_string(),
        DEFAULT_PREVIEW_ADDRESS
    );
    assert!(Config::parse(TICK, Path::new("."), "x")
        .unwrap()
        .preview
        .is_none());
    // The example config's commented section, as a user would uncomment it.
    let example = std::fs::read_to_string("config/onomato.toml").unwrap();
    let uncommented = example.replace(
        "# [preview]\n# address = \"127.0.0.1:8765\"",
        "[preview]\naddress = \"127.0.0.1:8765\"",
    );
    assert_ne!(
        uncommented, example,
        "the example config documents [preview]"
    );
    let config = Config::parse(&uncommented, Path::new("config"), "example").unwrap();
    assert_eq!(
        config.preview.unwrap().address.to_string(),
        "127.0.0.1:8765"
    );
    for (text, want) in [
        ("[preview]\naddress = \"localhost\"\n", "[preview]: address must be an IP address and a port, such as '127.0.0.1:8765', found 'localhost'"),
        ("[preview]\naddress = \"127.0.0.1\"\n", "found '127.0.0.1'"),
        ("[preview]\nport = 8765\n", "unknown field `port`"),
    ] {
        let msg = parse_err(&format!("{TICK}{text}"));
        assert!(msg.contains(want), "{text:?}: {msg}");
    }
}

#[test]
fn the_two_performer_config_loads_with_each_performers_patterns_and_outputs() {
    let config = Config::load(Path::new("config/duo.toml")).unwrap();
    assert!(config.patterns.is_empty());
    let lanes = config.lanes();
    let names: Vec<Option<&str>> = lanes.iter().map(|l| l.0.as_deref()).collect();
    assert_eq!(names, [Some("shooter"), Some("runner")]);
    let (shooter, runner) = (&lanes[0].1, &lanes[1].1);
    assert_eq!(shooter.detector.channel, Some(0));
    assert_eq!(runner.detector.channel, Some(1));
    assert_eq!(shooter.osc.as_ref().unwrap().prefix, "/onomato/shooter");
    assert_eq!(runner.osc.as_ref().unwrap().prefix, "/onomato/runner");
    assert_eq!(shooter.midi.as_ref().unwrap().channel, 1);
    assert_eq!(runner.midi.as_ref().unwrap().channel, 2);
    let pattern_names = |c: &Config| {
        c.patterns
            .iter()
            .map(|p| p.name.clone())
            .collect::<Vec<_>>()
    };
    assert_eq!(pattern_names(shooter), ["pew", "boom"]);
    assert_eq!(pattern_names(runner), ["hup", "whoo"]);
    assert_eq!(runner.patterns[1].kind, PatternKind::Continuous);
    let bounce = runner.bounce.as_ref().unwrap();
    assert_eq!(bounce.styles.get("whoo"), Some(&ContactStyle::Slide));
    assert!(shooter.bounce.is_none());
    for (_, c) in &lanes {
        load_patterns(&c.patterns, &c.detector).unwrap();
    }
    // One performer alone, for analyze and record.
    let runner_alone = config.select_performer(Some("runner")).unwrap();
    assert_eq!(pattern_names(&runner_alone), ["hup", "whoo"]);
    assert!(runner_alone.performers.is_empty());
    let e = config.select_performer(Some("drummer")).unwrap_err();
    assert!(
        e.contains("no such performer") && e.contains("'shooter', 'runner'"),
        "{e}"
    );
    let e = config.select_performer(None).unwrap_err();
    assert!(e.contains("name one with --performer"), "{e}");
}

#[test]
fn performer_mistakes_name_the_performer_and_what_was_expected() {
    const ONE: &str = "[[performer]]\nname = \"anna\"\nchannel = 0\n[[performer.pattern]]\nname = \"tick\"\ntakes = [\"tick.wav\"]\n";
    for (text, want) in [
        (
            format!("{TICK}{ONE}"),
            "[[pattern]] sections cannot be used with [[performer]]",
        ),
        (
            format!("{ONE}{ONE}"),
            "performer #2 ('anna'): performer name 'anna' is used twice",
        ),
        (
            "[[performer]]\nname = \"a b\"\n".to_string(),
            "performer name must be 1-64 characters",
        ),
        (
            "[[performer]]\nname = \"anna\"\n".to_string(),
            "performer #1 ('anna'): no [[performer.pattern]]",
        ),
        (
            ONE.replace("channel = 0\n", "channel = 0\nmidi_channel = 17\n"),
            "performer #1 ('anna'): midi_channel must be a MIDI channel from 1 to 16, found 17",
        ),
        (
            format!("{ONE}[bounce]\n"),
            "[bounce] cannot be used with [[performer]]",
        ),
        (
            format!("[detector]\nchannel = 1\n{ONE}"),
            "[detector] channel cannot be used with [[performer]]",
        ),
        (
            format!("{ONE}[performer.bounce]\nhard = [\"pop\"]\n"),
            "performer #1 ('anna'), [performer.bounce]",
        ),
        (
            "[[performer]]\nname = \"anna\"\nchanel = 0\n".to_string(),
            "unknown field `chanel`",
        ),
        (
            ONE.replace("channel = 0", "osc_prefix = \"anna\""),
            "osc_prefix",
        ),
        (
            ONE.replace("takes = [\"tick.wav\"]", "takes = []"),
            "performer #1 ('anna'), pattern #1 ('tick'): takes is empty",
        ),
    ] {
        let msg = parse_err(&text);
        assert!(msg.contains(want), "{text:?}\nexpected {want:?} in: {msg}");
    }
    let nine: String = (0..9)
        .map(|i| ONE.replace("\"anna\"", &format!("\"p{i}\"")))
        .collect();
    assert!(parse_err(&nine).contains("at most 8 performers, found 9"));
}
