//! `analyze --plot`: the SVG for the bundled example holds its parts (the waveform, one
//! score curve and one threshold per pattern, one mark per event, axis labels, a
//! legend), and it is a valid SVG that rsvg-convert renders (scripts/test.sh installs
//! librsvg2-bin).

use std::process::Command;

mod common;
use common::root;

/// The texts of an SVG's `<text>` elements.
fn texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let body = t.split_once('>')?.1;
            Some(body.split("</text>").next()?.trim().to_string())
        })
        .collect()
}

/// Plots the example with `method` (and `extra` arguments); the SVG and the JSON.
fn plot(dir: &std::path::Path, method: &str, extra: &[&str]) -> (String, serde_json::Value) {
    let svg = dir.join(format!("{method}.svg"));
    let out = Command::new(env!("CARGO_BIN_EXE_onomato"))
        .args([
            "analyze",
            "examples/beat.wav",
            "-c",
            "config/onomato.toml",
            "--method",
            method,
        ])
        .args(extra)
        .arg("--plot")
        .arg(&svg)
        .current_dir(root())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json = serde_json::from_slice(&out.stdout).expect("stdout is still the JSON");
    let png = dir.join(format!("{method}.png"));
    let rendered = Command::new("rsvg-convert")
        .arg("-o")
        .arg(&png)
        .arg(&svg)
        .status()
        .expect("rsvg-convert (librsvg2-bin)");
    assert!(rendered.success(), "rsvg-convert refused the SVG");
    assert!(std::fs::metadata(&png).unwrap().len() > 10_000);
    (std::fs::read_to_string(&svg).unwrap(), json)
}

#[test]
fn the_plot_shows_each_pattern_score_threshold_and_every_event() {
    let dir = common::temp_dir("plot");
    let (svg, json) = plot(&dir, "waveform", &[]);
    let t = texts(&svg);
    let events = json["events"].as_array().unwrap();
    let impulses = events.iter().filter(|e| e["kind"] == "impulse").count();
    let held = events.len() - impulses;
    assert_eq!((impulses, held), (11, 2));
    for name in ["tick", "pop", "boom", "hoo"] {
        assert!(
            t.contains(&format!("{name}: match")),
            "no axis for {name}: {t:?}"
        );
        assert!(
            t.contains(&format!("{name}: match score")),
            "no legend for {name}"
        );
    }
    assert_eq!(t.iter().filter(|x| *x == "threshold 0.5").count(), 4);
    assert!(t.contains(&"time (s)".to_string()) && t.contains(&"amplitude".to_string()));
    for second in ["0.0", "5.0", "10.0"] {
        assert!(
            t.contains(&second.to_string()),
            "no {second} s on the time axis"
        );
    }
    // One score curve per pattern, each in its own colour.
    let curves: std::collections::BTreeSet<&str> = svg
        .split("<polyline")
        .skip(1)
        .filter(|p| p.contains("stroke-width=\"1\"") && p.contains("opacity=\"1\""))
        .filter_map(|p| p.split("stroke=\"").nth(1)?.split('"').next())
        .filter(|c| *c != "#000000")
        .collect();
    assert_eq!(curves.len(), 4, "{curves:?}");
    // Every impulse marked twice (on the waveform and in its panel), every held sound
    // shaded twice.
    assert_eq!(svg.matches("stroke-width=\"2\"").count(), impulses);
    assert_eq!(svg.matches("stroke-width=\"3\"").count(), impulses);
    assert_eq!(svg.matches("opacity=\"0.15\" fill=").count(), held);
    assert_eq!(svg.matches("opacity=\"0.2\" fill=").count(), held);
}

#[test]
fn the_spectral_plot_shows_the_score_of_each_decision_and_why_other_onsets_did_not_fire() {
    let dir = common::temp_dir("plot-spectral");
    let (svg, json) = plot(&dir, "spectral", &["--explain"]);
    let t = texts(&svg);
    let events = json["events"].as_array().unwrap();
    for name in ["tick", "pop", "boom", "hoo"] {
        assert!(
            t.contains(&format!("{name}: score at the decision")),
            "{t:?}"
        );
    }
    // Every onset that did not fire, as `--explain` lists it in the same run, is a
    // ring under the pattern it resembled most, labelled with the gate that stopped it
    // (once for a run of rings closer than the label is wide).
    let stopped: Vec<&serde_json::Value> = json["onsets"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|o| o["outcome"] != "fired")
        .collect();
    assert!(
        !stopped.is_empty(),
        "the example has onsets that do not fire"
    );
    for o in &stopped {
        let outcome = o["outcome"].as_str().unwrap();
        let labels = t.iter().filter(|x| *x == outcome).count();
        let rings = stopped.iter().filter(|p| p["outcome"] == outcome).count();
        assert!((1..=rings).contains(&labels), "labels '{outcome}'");
    }
    let patterns_with_rings = ["tick", "pop", "boom", "hoo"]
        .iter()
        .filter(|name| t.contains(&format!("{name}: onset that did not fire")))
        .count();
    let with_rings: std::collections::HashSet<&str> = stopped
        .iter()
        .map(|o| o["best"].as_str().unwrap())
        .collect();
    assert_eq!(patterns_with_rings, with_rings.len());
    // A dot per event and a ring per stopped onset, plus one of each per legend.
    assert_eq!(
        svg.matches("<circle").count(),
        events.len() + 4 + stopped.len() + patterns_with_rings
    );
}
