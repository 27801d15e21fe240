//! Scoring detections against an annotation: precision, recall and F1 overall and per
//! label, onset F1 ignoring labels, detection latency (`emitted_at − time`) and mean IoU
//! of continuous events. Used by `onomato eval`, and by the evaluation on real voices.
//!
//! Pure computation on the caller's thread.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::detect::Event;

/// One annotated sound.
#[derive(Debug, Clone, PartialEq)]
pub struct Annotation {
    pub onset: f64,
    pub label: String,
    pub end: Option<f64>,
}

#[derive(Debug, thiserror::Error)]
pub enum TruthError {
    #[error("cannot read annotation '{}': {cause}", path.display())]
    Read {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("annotation '{}', line {line}: {message}", path.display())]
    Bad {
        path: PathBuf,
        line: usize,
        message: String,
    },
}

/// Reads an annotation CSV with a header naming at least `onset_s` and `label`, and
/// optionally `end_s` (empty for impulses). Other columns are ignored.
pub fn load_truth(path: &Path) -> Result<Vec<Annotation>, TruthError> {
    let text = std::fs::read_to_string(path).map_err(|cause| TruthError::Read {
        path: path.to_path_buf(),
        cause,
    })?;
    parse_truth(&text, path)
}

/// Parses annotation CSV text; `path` names it in messages.
pub fn parse_truth(text: &str, path: &Path) -> Result<Vec<Annotation>, TruthError> {
    let bad = |line: usize, message: String| TruthError::Bad {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(bad(
            1,
            "the file is empty; expected a header such as onset_s,label,end_s".into(),
        ));
    };
    let columns: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |name: &str| columns.iter().position(|c| *c == name);
    let (Some(onset_col), Some(label_col)) = (find("onset_s"), find("label")) else {
        return Err(bad(
            1,
            format!("the header must name onset_s and label columns, found '{header}'"),
        ));
    };
    let end_col = find("end_s");
    let mut out = Vec::new();
    for (i, line) in lines {
        let n = i + 1;
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let field = |col: usize| fields.get(col).copied().unwrap_or("");
        let onset: f64 = field(onset_col).parse().map_err(|_| {
            bad(
                n,
                format!(
                    "onset_s must be a number of seconds, found '{}'",
                    field(onset_col)
                ),
            )
        })?;
        let label = field(label_col);
        if label.is_empty() {
            return Err(bad(n, "label is empty".into()));
        }
        let end = match end_col.map(field) {
            None | Some("") => None,
            Some(text) => {
                let end: f64 = text.parse().map_err(|_| {
                    bad(
                        n,
                        format!("end_s must be a number of seconds or empty, found '{text}'"),
                    )
                })?;
                if end < onset {
                    return Err(bad(n, format!("end_s ({end}) is before onset_s ({onset})")));
                }
                Some(end)
            }
        };
        out.push(Annotation {
            onset,
            label: label.to_string(),
            end,
        });
    }
    Ok(out)
}

/// Precision, recall and F1 of one label (or of all).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct Counts {
    pub true_positives: usize,
    pub false_positives: usize,
    pub false_negatives: usize,
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
}

impl Counts {
    fn new(tp: usize, fp: usize, fn_: usize) -> Self {
        let ratio = |a: usize, b: usize| if b == 0 { 1.0 } else { a as f64 / b as f64 };
        let precision = ratio(tp, tp + fp);
        let recall = ratio(tp, tp + fn_);
        let f1 = if tp + fp + fn_ == 0 {
            1.0
        } else {
            2.0 * tp as f64 / (2 * tp + fp + fn_) as f64
        };
        Self {
            true_positives: tp,
            false_positives: fp,
            false_negatives: fn_,
            precision,
            recall,
            f1,
        }
    }
}

/// The full score of one run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Score {
    /// Onset tolerance used, seconds.
    pub tolerance: f64,
    pub overall: Counts,
    pub per_label: BTreeMap<String, Counts>,
    /// Matching onsets only, labels ignored.
    pub onsets: Counts,
    /// `emitted_at − time` of impulse detections, seconds.
    pub latency_median: Option<f64>,
    pub latency_p95: Option<f64>,
    /// Mean intersection over union of matched continuous events.
    pub mean_iou: Option<f64>,
    /// What each annotated label was detected as: annotated label, then detected
    /// pattern (or `"(missed)"`) and count, from the one-to-one matching of onsets with
    /// labels ignored. Detections that match no annotation are under `"(none)"`.
    pub confusions: BTreeMap<String, BTreeMap<String, usize>>,
}

/// Row and column name in [`Score::confusions`] for an annotation with no detection.
pub const MISSED: &str = "(missed)";
/// Row name in [`Score::confusions`] for detections that match no annotation.
pub const NO_ANNOTATION: &str = "(none)";

/// One-to-one matching: pairs with the closest onsets first, each detection and each
/// annotation used once, onsets within `tolerance`, labels equal unless `any_label`.
fn match_pairs(
    events: &[Event],
    truth: &[Annotation],
    tolerance: f64,
    any_label: bool,
) -> Vec<(usize, usize)> {
    let mut candidates: Vec<(f64, usize, usize)> = Vec::new();
    for (i, e) in events.iter().enumerate() {
        for (j, t) in truth.iter().enumerate() {
            let dt = (e.time - t.onset).abs();
            if dt <= tolerance && (any_label || *e.pattern == *t.label) {
                candidates.push((dt, i, j));
            }
        }
    }
    candidates.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut event_used = vec![false; events.len()];
    let mut truth_used = vec![false; truth.len()];
    let mut pairs = Vec::new();
    for (_, i, j) in candidates {
        if !event_used[i] && !truth_used[j] {
            event_used[i] = true;
            truth_used[j] = true;
            pairs.push((i, j));
        }
    }
    pairs
}

fn quantile(sorted: &[f64], q: f64) -> Option<f64> {
    if sorted.is_empty() {
        return None;
    }
    let idx = ((sorted.len() - 1) as f64 * q).round() as usize;
    Some(sorted[idx])
}

/// Scores `events` against `truth`.
pub fn score(events: &[Event], truth: &[Annotation], tolerance: f64) -> Score {
    let pairs = match_pairs(events, truth, tolerance, false);
    let mut labels: Vec<&str> = truth.iter().map(|t| t.label.as_str()).collect();
    labels.extend(events.iter().map(|e| &*e.pattern));
    labels.sort_unstable();
    labels.dedup();
    let per_label = labels
        .into_iter()
        .map(|label| {
            let tp = pairs
                .iter()
                .filter(|&&(_, j)| truth[j].label == label)
                .count();
            let detected = events.iter().filter(|e| &*e.pattern == label).count();
            let annotated = truth.iter().filter(|t| t.label == label).count();
            (
                label.to_string(),
                Counts::new(tp, detected - tp, annotated - tp),
            )
        })
        .collect();
    let overall = Counts::new(
        pairs.len(),
        events.len() - pairs.len(),
        truth.len() - pairs.len(),
    );
    let any_label_pairs = match_pairs(events, truth, tolerance, true);
    let onset_pairs = any_label_pairs.len();
    let mut confusions: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    let mut event_matched = vec![false; events.len()];
    let mut truth_matched = vec![false; truth.len()];
    for &(i, j) in &any_label_pairs {
        event_matched[i] = true;
        truth_matched[j] = true;
        *confusions
            .entry(truth[j].label.clone())
            .or_default()
            .entry(events[i].pattern.to_string())
            .or_default() += 1;
    }
    for t in truth.iter().zip(&truth_matched).filter(|(_, m)| !**m) {
        *confusions
            .entry(t.0.label.clone())
            .or_default()
            .entry(MISSED.to_string())
            .or_default() += 1;
    }
    for e in events.iter().zip(&event_matched).filter(|(_, m)| !**m) {
        *confusions
            .entry(NO_ANNOTATION.to_string())
            .or_default()
            .entry(e.0.pattern.to_string())
            .or_default() += 1;
    }
    let onsets = Counts::new(
        onset_pairs,
        events.len() - onset_pairs,
        truth.len() - onset_pairs,
    );
    let mut latencies: Vec<f64> = events
        .iter()
        .filter(|e| e.end.is_none())
        .map(|e| e.emitted_at - e.time)
        .collect();
    latencies.sort_by(f64::total_cmp);
    let ious: Vec<f64> = pairs
        .iter()
        .filter_map(|&(i, j)| {
            let (e, t) = (&events[i], &truth[j]);
            let (e_end, t_end) = (e.end?, t.end?);
            let inter = (e_end.min(t_end) - e.time.max(t.onset)).max(0.0);
            let union = e_end.max(t_end) - e.time.min(t.onset);
            Some(if union > 0.0 { inter / union } else { 1.0 })
        })
        .collect();
    Score {
        tolerance,
        overall,
        per_label,
        onsets,
        latency_median: quantile(&latencies, 0.5),
        latency_p95: quantile(&latencies, 0.95),
        mean_iou: (!ious.is_empty()).then(|| ious.iter().sum::<f64>() / ious.len() as f64),
        confusions,
    }
}

/// The score as a few lines of text.
pub fn render_text(score: &Score) -> String {
    let line = |name: &str, c: &Counts| {
        format!(
            "{name:<12} P {:.3}  R {:.3}  F1 {:.3}  (tp {}, fp {}, fn {})\n",
            c.precision, c.recall, c.f1, c.true_positives, c.false_positives, c.false_negatives
        )
    };
    let mut out = String::new();
    out += &line("overall", &score.overall);
    out += &line("onsets", &score.onsets);
    for (label, c) in &score.per_label {
        out += &line(&format!("  {label}"), c);
    }
    let ms = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{:.1} ms", v * 1000.0));
    out += &format!(
        "latency      median {}  p95 {}\n",
        ms(score.latency_median),
        ms(score.latency_p95)
    );
    if let Some(iou) = score.mean_iou {
        out += &format!("continuous   mean IoU {iou:.3}\n");
    }
    out += "detected as (annotated: detected count, ...)\n";
    for (label, row) in &score.confusions {
        let cells: Vec<String> = row.iter().map(|(d, n)| format!("{d} {n}")).collect();
        out += &format!("  {label:<10} {}\n", cells.join(", "));
    }
    out
}
