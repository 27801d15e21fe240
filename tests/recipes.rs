//! The recipes in `examples/recipes/` work: the Pure Data patch runs in a real, headless
//! Pd (Debian's puredata-core, installed by scripts/test.sh), onomato sends it the
//! bundled example over OSC, and the test reads what the patch printed.

use std::fs;
use std::net::UdpSocket;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::root;

#[test]
fn the_pure_data_patch_routes_each_pattern_to_its_outlet() {
    let dir = common::temp_dir("recipe-pd");
    let port = UdpSocket::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let printed = dir.join("pd.txt");
    let mut pd = Command::new("pd")
        .args(["-nogui", "-noaudio", "-nomidi", "-stderr", "-send"])
        .arg(format!("onomato-port {port}"))
        .arg(root().join("examples/recipes/onomato-osc.pd"))
        .stdout(Stdio::null())
        .stderr(fs::File::create(&printed).unwrap())
        .spawn()
        .expect("cannot start pd (bash scripts/test.sh installs puredata-core)");
    std::thread::sleep(Duration::from_millis(1000));
    let sent = Command::new(env!("CARGO_BIN_EXE_onomato"))
        .args([
            "listen",
            "-c",
            "config/onomato.toml",
            "--input",
            "examples/beat.wav",
        ])
        .args(["--speed", "5", "--print", "none", "--osc"])
        .arg(format!("127.0.0.1:{port}"))
        .current_dir(root())
        .status()
        .unwrap();
    assert!(sent.success());
    // Pd prints as it receives; give it a moment for the last messages.
    let start = Instant::now();
    let text = loop {
        let text = fs::read_to_string(&printed).unwrap_or_default();
        if text.matches("hoo-end:").count() == 2 || start.elapsed() > Duration::from_secs(5) {
            break text;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let _ = pd.kill();
    let _ = pd.wait();

    // One line per sound from each pattern's outlet, in the order of the example.
    let lines: Vec<(&str, Vec<f64>)> = text
        .lines()
        .filter_map(|l| {
            let (name, args) = l.split_once(": ")?;
            let nums = args
                .split_whitespace()
                .filter_map(|a| a.parse().ok())
                .collect();
            Some((name, nums))
        })
        .collect();
    let routed: Vec<&str> = lines
        .iter()
        .map(|(n, _)| *n)
        .filter(|n| ["tick", "pop", "boom", "hoo-begin"].contains(n))
        .collect();
    let truth = fs::read_to_string(root().join("examples/beat.truth.csv")).unwrap();
    let expected: Vec<String> = truth
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().replace("hoo", "hoo-begin"))
        .collect();
    assert_eq!(routed, expected, "Pd printed:\n{text}");
    // The arguments arrive as numbers: strength, time, id, then the time exactly as
    // whole seconds and a fraction.
    let first_tick = &lines.iter().find(|(n, _)| *n == "tick").unwrap().1;
    assert_eq!(first_tick.len(), 5, "{first_tick:?}");
    assert!(
        (first_tick[1] - 0.4).abs() < 0.001 && first_tick[2] == 0.0,
        "{first_tick:?}"
    );
    assert!(
        first_tick[3] == first_tick[1].floor()
            && (first_tick[3] + first_tick[4] - first_tick[1]).abs() < 1e-5,
        "{first_tick:?}"
    );
    // Every held sound's end comes out of its own outlet, after its begin.
    assert_eq!(
        lines.iter().filter(|(n, _)| *n == "hoo-end").count(),
        2,
        "{text}"
    );
    // The generic /event message: 13 sounds, the held ones twice (begin, end).
    assert_eq!(
        lines.iter().filter(|(n, _)| *n == "event").count(),
        15,
        "{text}"
    );
}

#[test]
fn both_pure_data_patches_load_without_errors() {
    // The MIDI patch cannot get notes here (no ALSA sequencer), but every object in it
    // must exist; Pd says "couldn't create" for one that does not.
    for patch in ["onomato-osc.pd", "onomato-midi.pd"] {
        let out = Command::new("pd")
            .args([
                "-nogui", "-noaudio", "-nomidi", "-stderr", "-send", "pd quit",
            ])
            .arg(root().join("examples/recipes").join(patch))
            .output()
            .expect("cannot start pd");
        let log = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{patch}: {log}");
        assert!(!log.contains("couldn't create"), "{patch}: {log}");
        assert!(!log.to_lowercase().contains("error"), "{patch}: {log}");
    }
}
