//! Scoring against an annotation, on hand-made cases whose answers are worked out by hand.

use std::path::Path;
use std::process::Command;
use std::sync::Arc;

use onomato::config::PatternKind;
use onomato::eval::{parse_truth, render_text, score, Annotation, MISSED, NO_ANNOTATION};
use onomato::Event;

fn ev(pattern: &str, time: f64, end: Option<f64>, latency: f64) -> Event {
    Event {
        id: 0,
        pattern: Arc::from(pattern),
        kind: if end.is_some() {
            PatternKind::Continuous
        } else {
            PatternKind::Impulse
        },
        time,
        end,
        strength: 1.0,
        score: 1.0,
        emitted_at: end.unwrap_or(time) + latency,
        pitch: None,
    }
}

fn truth(onset: f64, label: &str, end: Option<f64>) -> Annotation {
    Annotation {
        onset,
        label: label.into(),
        end,
    }
}

#[test]
fn counts_hits_misses_wrong_labels_and_extra_detections() {
    let t = vec![
        truth(1.0, "B", None),
        truth(2.0, "t", None),
        truth(3.0, "K", None),
        truth(4.0, "t", None),
    ];
    let e = vec![
        ev("B", 1.01, None, 0.02),  // hit
        ev("t", 2.049, None, 0.02), // hit, just inside 50 ms
        ev("t", 3.0, None, 0.03),   // right time, wrong label
        ev("t", 4.2, None, 0.04),   // too late: 200 ms
        ev("B", 5.0, None, 0.05),   // nothing there
    ];
    let s = score(&e, &t, 0.05);
    assert_eq!(
        (
            s.overall.true_positives,
            s.overall.false_positives,
            s.overall.false_negatives
        ),
        (2, 3, 2)
    );
    assert!((s.overall.precision - 0.4).abs() < 1e-12);
    assert!((s.overall.recall - 0.5).abs() < 1e-12);
    assert!((s.overall.f1 - 4.0 / 9.0).abs() < 1e-12);
    // Ignoring labels, the wrong-label detection at 3.0 counts.
    assert_eq!(s.onsets.true_positives, 3);
    let k = s.per_label["K"];
    assert_eq!((k.true_positives, k.false_negatives, k.recall), (0, 1, 0.0));
    let tl = s.per_label["t"];
    assert_eq!(
        (tl.true_positives, tl.false_positives, tl.false_negatives),
        (1, 2, 1)
    );
    // Latencies 20, 20, 30, 40, 50 ms.
    assert!((s.latency_median.unwrap() - 0.03).abs() < 1e-9);
    assert!((s.latency_p95.unwrap() - 0.05).abs() < 1e-9);
    assert_eq!(s.mean_iou, None);
    // What each annotated label was taken for.
    let row = |label: &str| -> Vec<(String, usize)> {
        s.confusions[label]
            .iter()
            .map(|(d, n)| (d.clone(), *n))
            .collect()
    };
    assert_eq!(row("B"), [("B".to_string(), 1)]);
    assert_eq!(row("K"), [("t".to_string(), 1)]);
    assert_eq!(row("t"), [(MISSED.to_string(), 1), ("t".to_string(), 1)]);
    assert_eq!(
        row(NO_ANNOTATION),
        [("B".to_string(), 1), ("t".to_string(), 1)]
    );
    assert!(render_text(&s).contains("  K          t 1\n"));
}

#[test]
fn matching_is_one_to_one_and_prefers_the_closest() {
    let t = vec![truth(1.0, "t", None), truth(1.06, "t", None)];
    // Two detections near both annotations: the closest pairs win, each used once.
    let e = vec![ev("t", 1.03, None, 0.0), ev("t", 1.061, None, 0.0)];
    let s = score(&e, &t, 0.05);
    assert_eq!(s.overall.true_positives, 2);
    // Two detections of one sound: one is a false positive.
    let s = score(
        &[ev("t", 1.0, None, 0.0), ev("t", 1.01, None, 0.0)],
        &t[..1],
        0.05,
    );
    assert_eq!(
        (s.overall.true_positives, s.overall.false_positives),
        (1, 1)
    );
}

#[test]
fn continuous_events_report_their_overlap() {
    let t = vec![truth(1.0, "chhh", Some(2.0)), truth(3.0, "chhh", Some(3.5))];
    let e = vec![
        ev("chhh", 1.02, Some(1.82), 0.0), // inter 0.80, union 1.00
        ev("chhh", 3.0, Some(3.5), 0.0),   // exact
    ];
    let s = score(&e, &t, 0.05);
    assert_eq!(s.overall.true_positives, 2);
    assert!((s.mean_iou.unwrap() - 0.9).abs() < 1e-9);
    assert_eq!(s.latency_median, None, "latency is measured on impulses");
}

#[test]
fn nothing_to_find_and_nothing_found_is_perfect() {
    let s = score(&[], &[], 0.05);
    assert_eq!(s.overall.f1, 1.0);
    let s = score(&[], &[truth(1.0, "B", None)], 0.05);
    assert_eq!((s.overall.recall, s.overall.f1), (0.0, 0.0));
}

#[test]
fn annotations_are_read_by_header_name() {
    // The beatbox annotations have extra columns and no end_s.
    let text =
        "onset_s,label,pattern_time_s,matched_energy_onset\n3.630,B,3.650,1\n4.050,t,4.024,1\n";
    let t = parse_truth(text, Path::new("a.csv")).unwrap();
    assert_eq!(t, vec![truth(3.63, "B", None), truth(4.05, "t", None)]);
    let text = "label,end_s,onset_s\nchhh,2.5,1.0\ntick,,3\n";
    let t = parse_truth(text, Path::new("b.csv")).unwrap();
    assert_eq!(
        t,
        vec![truth(1.0, "chhh", Some(2.5)), truth(3.0, "tick", None)]
    );
}

#[test]
fn bad_annotations_name_the_file_line_and_problem() {
    let err = |text: &str| {
        parse_truth(text, Path::new("t.csv"))
            .unwrap_err()
            .to_string()
    };
    let m = err("time,label\n1,B\n");
    assert!(
        m.contains("annotation 't.csv', line 1") && m.contains("must name onset_s and label"),
        "{m}"
    );
    let m = err("onset_s,label\n1.0,B\nsoon,t\n");
    assert!(
        m.contains("line 3") && m.contains("onset_s must be a number of seconds, found 'soon'"),
        "{m}"
    );
    let m = err("onset_s,label,end_s\n2.0,chhh,1.0\n");
    assert!(m.contains("end_s (1) is before onset_s (2)"), "{m}");
    let m = err("onset_s,label\n1.0,\n");
    assert!(m.contains("line 2: label is empty"), "{m}");
    let m = err("");
    assert!(m.contains("the file is empty"), "{m}");
}

#[test]
fn the_eval_command_scores_the_bundled_example() {
    let root = env!("CARGO_MANIFEST_DIR");
    let out = Command::new(env!("CARGO_BIN_EXE_onomato"))
        .args([
            "eval",
            "examples/beat.wav",
            "--truth",
            "examples/beat.truth.csv",
            "--config",
            "config/onomato.toml",
            "--format",
            "json",
        ])
        .current_dir(root)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // Every impulse of the example is found exactly by the waveform method.
    for label in ["tick", "pop", "boom"] {
        assert_eq!(v["per_label"][label]["f1"], 1.0, "{label}: {v}");
    }
    assert!(v["latency_median"].as_f64().unwrap() > 0.0);
}

#[test]
fn the_eval_command_names_a_bad_annotation_or_tolerance() {
    let root = env!("CARGO_MANIFEST_DIR");
    let run = |extra: &[&str]| {
        let mut args = vec!["eval", "examples/beat.wav", "-c", "config/onomato.toml"];
        args.extend_from_slice(extra);
        Command::new(env!("CARGO_BIN_EXE_onomato"))
            .args(&args)
            .current_dir(root)
            .output()
            .unwrap()
    };
    let out = run(&["--truth", "examples/none.csv"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cannot read annotation 'examples/none.csv'"),
        "{err}"
    );
    let out = run(&["--truth", "examples/beat.truth.csv", "--tolerance", "0"]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--tolerance must be a positive number of seconds, found 0"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
}
