//! `analyze --plot OUT.svg`: the recording's waveform and, under it, one panel per
//! pattern with its match score over time, the threshold as a dashed line, and a mark
//! at every detected event (a line for an impulse, a shaded span for a held sound), as
//! in figure 2 of the paper. With the spectral method, which scores a sound only at its
//! onset, each panel shows the score of each decided event as a dot, and every onset
//! that did not fire as a ring at its best score, under the pattern it resembled most,
//! with the name of the gate that stopped it (as `--explain` lists them; once for a run
//! of rings closer than the name is wide) and, as a thin
//! line at its height, the sound that gate held against it (the unrecognised sound that
//! closed the speech guard, the impulse it continues...); the waveform panel marks
//! those onsets with a grey line. A held sound's span is labelled at its end with why
//! it ended.
//!
//! Runs on the main thread of `onomato analyze`, after the analysis.

use std::path::Path;

use plotters::prelude::*;

use crate::analyze::Analysis;
use crate::config::PatternKind;
use crate::detect::Outcome;

/// Width of the picture, pixels; curves are reduced to one min/max pair per pixel.
const WIDTH: u32 = 1400;
const WAVE_HEIGHT: u32 = 220;
const PANEL_HEIGHT: u32 = 130;
const BOTTOM: u32 = 40;
/// The column right of the recording's time, in every panel, that holds the panel's
/// legend, pixels: beside the scores, not over them. The time axis runs on under it,
/// unlabelled.
const LEGEND_PIXELS: u32 = 290;
/// A panel's margin and the width of its score axis, pixels.
const MARGIN: u32 = 8;
const Y_LABELS: u32 = 60;
/// The width of a gate's name under a ring, pixels (the longest, "below_threshold", in
/// 10-pixel sans-serif).
const LABEL_PIXELS: f64 = 80.0;

/// Colours of the patterns, in order (repeated beyond ten).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

#[derive(Debug, thiserror::Error)]
#[error("cannot draw the plot '{}': {message}", path.display())]
pub struct PlotError {
    path: std::path::PathBuf,
    message: String,
}

/// Per column of the picture, the least and greatest of `values` (sampled at `rate`)
/// over the column's time span.
fn columns(values: &[f32], rate: f64, duration: f64, n: usize) -> Vec<(f64, f32, f32)> {
    (0..n)
        .filter_map(|c| {
            let t0 = duration * c as f64 / n as f64;
            let t1 = duration * (c + 1) as f64 / n as f64;
            let a = ((t0 * rate) as usize).min(values.len());
            let b = ((t1 * rate).ceil() as usize).clamp(a, values.len());
            let span = &values[a..b];
            if span.is_empty() {
                return None;
            }
            let lo = span.iter().copied().fold(f32::INFINITY, f32::min);
            let hi = span.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            Some(((t0 + t1) / 2.0, lo, hi))
        })
        .collect()
}

/// Draws the plot of `analysis` of the mono signal `samples` (at `analysis.sample_rate`).
pub fn write_svg(path: &Path, samples: &[f32], analysis: &Analysis) -> Result<(), PlotError> {
    let fail = |e: &dyn std::fmt::Display| PlotError {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let patterns: Vec<&(std::sync::Arc<str>, f64)> = analysis.thresholds.iter().collect();
    let height = WAVE_HEIGHT + PANEL_HEIGHT * patterns.len() as u32 + BOTTOM;
    let duration = analysis.duration.max(1e-3);
    let root = SVGBackend::new(path, (WIDTH + LEGEND_PIXELS, height)).into_drawing_area();
    // The time axis of every panel, reaching on under the legend column.
    let plotted = f64::from(WIDTH + LEGEND_PIXELS - 2 * MARGIN - Y_LABELS);
    // The pixels the recording's own time spans.
    let duration_pixels = plotted - f64::from(LEGEND_PIXELS);
    let axis_end = duration * plotted / duration_pixels;
    let time_label = |t: &f64| {
        if *t <= duration * (1.0 + 1e-9) {
            format!("{t:.1}")
        } else {
            String::new()
        }
    };
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let (wave_area, rest) = root.split_vertically(WAVE_HEIGHT);
    let colour = |i: usize| PALETTE[i % PALETTE.len()];
    let index_of = |name: &str| patterns.iter().position(|(n, _)| &**n == name);

    // The waveform, with every event marked in its pattern's colour.
    {
        let peak = samples.iter().fold(0.0f32, |m, x| m.max(x.abs())).max(1e-6);
        let mut chart = ChartBuilder::on(&wave_area)
            .caption("recording, with the detected events", ("sans-serif", 18))
            .margin(MARGIN)
            .x_label_area_size(0)
            .y_label_area_size(Y_LABELS)
            .build_cartesian_2d(0.0..axis_end, -(peak as f64)..peak as f64)
            .map_err(|e| fail(&e))?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .y_max_light_lines(0)
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .y_desc("amplitude")
            .y_labels(5)
            .draw()
            .map_err(|e| fail(&e))?;
        let cols = columns(
            samples,
            f64::from(analysis.sample_rate),
            duration,
            WIDTH as usize,
        );
        chart
            .draw_series(cols.iter().map(|&(t, lo, hi)| {
                PathElement::new(vec![(t, f64::from(lo)), (t, f64::from(hi))], BLACK.mix(0.6))
            }))
            .map_err(|e| fail(&e))?;
        for e in &analysis.events {
            let c = colour(index_of(&e.pattern).unwrap_or(0));
            match e.end {
                Some(end) => chart.draw_series(std::iter::once(Rectangle::new(
                    [(e.time, -(peak as f64)), (end, peak as f64)],
                    c.mix(0.15).filled(),
                ))),
                None => chart.draw_series(std::iter::once(PathElement::new(
                    vec![(e.time, -(peak as f64)), (e.time, peak as f64)],
                    c.stroke_width(2),
                ))),
            }
            .map_err(|e| fail(&e))?;
        }
        for o in stopped(analysis) {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(o.time, -(peak as f64) * 0.5), (o.time, peak as f64 * 0.5)],
                    BLACK.mix(0.3),
                )))
                .map_err(|e| fail(&e))?;
        }
    }

    // One panel per pattern: score, threshold, events.
    // Equal panels; the last one also holds the time axis under it.
    let mut panels = Vec::with_capacity(patterns.len());
    let mut below = rest;
    for _ in 1..patterns.len() {
        let (panel, remainder) = below.split_vertically(PANEL_HEIGHT);
        panels.push(panel);
        below = remainder;
    }
    panels.push(below);
    for (i, ((name, threshold), area)) in patterns.iter().zip(panels.iter()).enumerate() {
        let c = colour(i);
        let last = i + 1 == patterns.len();
        let mut builder = ChartBuilder::on(area);
        builder
            .margin(MARGIN)
            .y_label_area_size(Y_LABELS)
            .x_label_area_size(if last { BOTTOM } else { 0 });
        let mut chart = builder
            .build_cartesian_2d(0.0..axis_end, 0.0..1.05)
            .map_err(|e| fail(&e))?;
        let mut mesh = chart.configure_mesh();
        mesh.disable_x_mesh()
            .y_labels(3)
            .y_max_light_lines(0)
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 14))
            .y_desc(format!("{name}: match"))
            .x_labels(15)
            .x_label_formatter(&time_label);
        if last {
            mesh.x_desc("time (s)");
        }
        mesh.draw().map_err(|e| fail(&e))?;
        // The score: the best take's, per column.
        if let Some(traces) = &analysis.score_traces {
            let takes: Vec<&Vec<f32>> = traces
                .iter()
                .filter(|t| *t.pattern == **name)
                .map(|t| &t.scores)
                .collect();
            if let Some(len) = takes.iter().map(|s| s.len()).max() {
                let best: Vec<f32> = (0..len)
                    .map(|k| {
                        takes
                            .iter()
                            .filter_map(|s| s.get(k))
                            .fold(0.0f32, |m, &x| m.max(x))
                    })
                    .collect();
                let cols = columns(
                    &best,
                    f64::from(analysis.working_rate),
                    duration,
                    WIDTH as usize,
                );
                chart
                    .draw_series(LineSeries::new(
                        cols.iter()
                            .map(|&(t, _, hi)| (t, f64::from(hi.clamp(0.0, 1.0)))),
                        c.stroke_width(1),
                    ))
                    .map_err(|e| fail(&e))?
                    .label(format!("{name}: match score"))
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
            }
        }
        // The threshold.
        chart
            .draw_series(DashedLineSeries::new(
                vec![(0.0, *threshold), (duration, *threshold)],
                6,
                4,
                BLACK.mix(0.7).into(),
            ))
            .map_err(|e| fail(&e))?
            .label(format!("threshold {threshold}"))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.mix(0.7)));
        // The events of this pattern.
        let mine: Vec<_> = analysis
            .events
            .iter()
            .filter(|e| *e.pattern == **name)
            .collect();
        for e in &mine {
            match (e.kind, e.end) {
                (PatternKind::Continuous, Some(end)) => chart.draw_series(std::iter::once(
                    Rectangle::new([(e.time, 0.0), (end, 1.05)], c.mix(0.2).filled()),
                )),
                _ => chart.draw_series(std::iter::once(PathElement::new(
                    vec![(e.time, 0.0), (e.time, 1.05)],
                    c.mix(0.35).stroke_width(3),
                ))),
            }
            .map_err(|e| fail(&e))?;
        }
        // Why each of its held sounds ended, at its end (`--explain`'s `held_ends`).
        let ends = analysis.held_ends.iter().flatten();
        let style = ("sans-serif", 10).into_font().color(&BLACK.mix(0.7));
        chart
            .draw_series(
                ends.filter(|r| *r.pattern == **name)
                    .map(|r| Text::new(r.ended_by.as_str(), (r.end, 0.12), style.clone())),
            )
            .map_err(|e| fail(&e))?;
        if analysis.score_traces.is_none() {
            chart
                .draw_series(
                    mine.iter()
                        .map(|e| Circle::new((e.time, e.score.clamp(0.0, 1.05)), 4, c.filled())),
                )
                .map_err(|e| fail(&e))?
                .label(format!("{name}: score at the decision"))
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, c.filled()));
        }
        let rejected: Vec<_> = stopped(analysis)
            .filter(|o| o.best.as_deref() == Some(&**name))
            .collect();
        if !rejected.is_empty() {
            let at = |o: &crate::detect::OnsetRecord| {
                (o.time, o.best_score.unwrap_or(0.0).clamp(0.0, 1.05))
            };
            chart
                .draw_series(
                    rejected
                        .iter()
                        .map(|o| Circle::new(at(o), 4, c.stroke_width(1))),
                )
                .map_err(|e| fail(&e))?
                .label(format!("{name}: onset that did not fire"))
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, c.stroke_width(1)));
            let held_against: Vec<_> = rejected
                .iter()
                .filter_map(|o| o.because_of.map(|s| (s, at(o).1)))
                .collect();
            if !held_against.is_empty() {
                chart
                    .draw_series(held_against.iter().map(|&(s, y)| {
                        PathElement::new(vec![(s.from, y), (s.to, y)], c.mix(0.5).stroke_width(2))
                    }))
                    .map_err(|e| fail(&e))?
                    .label(format!("{name}: the sound held against it"))
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], c.mix(0.5).stroke_width(2))
                    });
            }
            // A name over its ring, or under it where that would overprint a name drawn in
            // this panel; none where both would, or where the name it would overprint is
            // its own: a run of rings within a name's width (the syllables of a word, the
            // onsets inside a held sound) is named once, every ring still drawn.
            let label_seconds = duration * LABEL_PIXELS / duration_pixels;
            let mut labels: Vec<(&'static str, (f64, f64))> = Vec::new();
            for o in &rejected {
                let (t, y) = at(o);
                let name = o.outcome.as_str();
                let near =
                    |labels: &[(&'static str, (f64, f64))], y: f64| -> Option<&'static str> {
                        labels
                            .iter()
                            .rev()
                            .take_while(|(_, (lt, _))| t - lt < label_seconds)
                            .find(|(_, (_, ly))| (y - ly).abs() < 0.12)
                            .map(|(other, _)| *other)
                    };
                let over = (y + 0.08).min(1.0);
                let under = y - 0.1;
                match (near(&labels, over), near(&labels, under)) {
                    (None, _) => labels.push((name, (t, over))),
                    (Some(other), None) if other != name => labels.push((name, (t, under))),
                    _ => {}
                }
            }
            chart
                .draw_series(
                    labels
                        .into_iter()
                        .map(|(name, at)| Text::new(name, at, style.clone())),
                )
                .map_err(|e| fail(&e))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.4))
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(|e| fail(&e))?;
    }
    root.present().map_err(|e| fail(&e))?;
    Ok(())
}

/// The onsets of `analysis` (when kept) that did not fire.
fn stopped(analysis: &Analysis) -> impl Iterator<Item = &crate::detect::OnsetRecord> {
    analysis
        .onsets
        .iter()
        .flatten()
        .filter(|o| o.outcome != Outcome::Fired)
}
