//! `onomato render`: the paper's animations drawn from a soundtrack's events. A scene
//! turns the events (and the bounce solver's contacts) into a list of shapes for every
//! frame; the writers put those frames beside the sound: a self-contained HTML page that
//! draws them on a canvas at the audio element's current time, or an MP4 video
//! ([`video`]: rasterised here, encoded by ffmpeg).
//!
//! The shapes are the one description of a scene, so every output shows the same
//! picture. A hit at time t is drawn at frame round(t · fps), with the ball on the floor.
//!
//! Runs on the main thread; allocates freely (offline).

mod scene;
pub mod video;

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use base64::Engine as _;
use serde::Serialize;

use std::collections::{BTreeMap, BTreeSet};

pub use crate::config::Scene;
use crate::config::{
    BounceSettings, ContactStyle, DartsAction, LaserAction, PatternKind, RenderSettings,
};
use crate::detect::Event;
pub use scene::track_color;

/// How the frames are laid out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameSettings {
    pub fps: u32,
    pub width: u32,
    pub height: u32,
}

impl FrameSettings {
    /// The frame that shows time `t`.
    pub fn frame_of(&self, t: f64) -> usize {
        (t * f64::from(self.fps)).round().max(0.0) as usize
    }
}

/// One thing to draw, in pixels from the top left.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "shape", rename_all = "lowercase")]
pub enum Shape {
    Ellipse {
        cx: f32,
        cy: f32,
        rx: f32,
        ry: f32,
        color: &'static str,
    },
    Rect {
        x: f32,
        y: f32,
        w: f32,
        h: f32,
        color: &'static str,
    },
    Text {
        x: f32,
        y: f32,
        size: f32,
        text: String,
        color: &'static str,
    },
    /// A filled polygon through `points`.
    Polygon {
        points: Vec<[f32; 2]>,
        color: &'static str,
    },
}

/// A scene, drawn: what every frame shows over a background that does not change.
#[derive(Debug, Clone, Serialize)]
pub struct Animation {
    pub fps: u32,
    pub width: u32,
    pub height: u32,
    pub duration_seconds: f64,
    pub background: &'static str,
    /// Drawn first in every frame.
    pub fixed: Vec<Shape>,
    /// Frame k shows time k / fps.
    pub frames: Vec<Vec<Shape>>,
    /// The ball scene's geometry, for whoever checks a frame: the floor's row and the
    /// ball's radius, pixels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ball: Option<BallGeometry>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BallGeometry {
    pub floor_y: f32,
    pub radius: f32,
    /// Pixels per metre of height.
    pub scale: f32,
}

const BACKGROUND: &str = "#f4f1ea";

/// Which pattern does what, in every scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Actions {
    /// The ball scene: which patterns are hard bounces, soft bounces, slides.
    pub bounce: BounceSettings,
    pub darts: BTreeMap<String, DartsAction>,
    pub laser: BTreeMap<String, LaserAction>,
    /// The patterns that drop a drop.
    pub rain: BTreeSet<String>,
}

impl Actions {
    /// The config's mappings; a scene the config does not map gets defaults from the
    /// patterns' kinds, in their order: the ball bounces hard on impulses and slides on
    /// held sounds; every impulse throws a dart, the first held pattern moves the ship
    /// up and the second down; the first impulse pattern shoots low, the second high,
    /// the others jump, held sounds slide; every impulse drops a drop.
    pub fn new(
        render: &RenderSettings,
        bounce: Option<BounceSettings>,
        patterns: &[(String, PatternKind)],
    ) -> Self {
        let impulses = || {
            patterns
                .iter()
                .filter(|(_, k)| *k == PatternKind::Impulse)
                .map(|(n, _)| n.clone())
        };
        let held = || {
            patterns
                .iter()
                .filter(|(_, k)| *k == PatternKind::Continuous)
                .map(|(n, _)| n.clone())
        };
        let bounce = bounce.unwrap_or_else(|| BounceSettings {
            styles: impulses()
                .map(|n| (n, ContactStyle::Hard))
                .chain(held().map(|n| (n, ContactStyle::Slide)))
                .collect(),
            ..BounceSettings::default_for(&[])
        });
        let darts = render.darts.clone().unwrap_or_else(|| {
            impulses()
                .map(|n| (n, DartsAction::Throw))
                .chain(held().zip([DartsAction::Up, DartsAction::Down]))
                .collect()
        });
        let laser = render.laser.clone().unwrap_or_else(|| {
            let shots = [LaserAction::ShootLow, LaserAction::ShootHigh];
            impulses()
                .enumerate()
                .map(|(i, n)| (n, shots.get(i).copied().unwrap_or(LaserAction::Jump)))
                .chain(held().map(|n| (n, LaserAction::Slide)))
                .collect()
        });
        let rain = match &render.rain {
            Some(names) => names.iter().cloned().collect(),
            None => impulses().collect(),
        };
        Self {
            bounce,
            darts,
            laser,
            rain,
        }
    }
}

/// The patterns of events, in the order they are first heard (soundtrack by
/// soundtrack), with their kinds: what a scene knows when no patterns are given.
pub fn patterns_of_events(tracks: &[Vec<Event>]) -> Vec<(String, PatternKind)> {
    let mut patterns: Vec<(String, PatternKind)> = Vec::new();
    for e in tracks.iter().flatten() {
        if !patterns.iter().any(|(n, _)| **n == *e.pattern) {
            patterns.push((e.pattern.to_string(), e.kind));
        }
    }
    patterns
}

/// Draws `scene` for soundtracks of `duration_seconds` (the longest) with these events,
/// one list per soundtrack.
pub fn animate(
    scene: Scene,
    tracks: &[Vec<Event>],
    actions: &Actions,
    frames: FrameSettings,
    duration_seconds: f64,
) -> Animation {
    let count = frames.frame_of(duration_seconds) + 1;
    let mut animation = Animation {
        fps: frames.fps,
        width: frames.width,
        height: frames.height,
        duration_seconds,
        background: BACKGROUND,
        fixed: Vec::new(),
        frames: Vec::with_capacity(count),
        ball: None,
    };
    match scene {
        Scene::Ball => scene::ball(&mut animation, tracks, actions, frames, count),
        Scene::Timeline => scene::timeline(&mut animation, tracks, frames, count),
        Scene::Rain => scene::rain(&mut animation, tracks, actions, frames, count),
        Scene::Darts => scene::darts(&mut animation, tracks, actions, frames, count),
        Scene::Laser => scene::laser(&mut animation, tracks, actions, frames, count),
    }
    animation
}

/// The sound of the soundtracks, aligned at their start, as WAV bytes: one soundtrack's
/// file as it is; several summed (at the first one's rate, each mixed to mono), scaled
/// down only as far as the sum would clip.
pub fn soundtrack(paths: &[std::path::PathBuf]) -> anyhow::Result<Vec<u8>> {
    use crate::audio::{resample_clip, ChannelSelect, WavSource};
    if let [one] = paths {
        return std::fs::read(one)
            .with_context(|| format!("cannot read the recording {}", one.display()));
    }
    let mut mix: Vec<f32> = Vec::new();
    let mut rate = 0;
    for path in paths {
        let mut source = WavSource::open(path, ChannelSelect::Mix)
            .with_context(|| format!("cannot read the recording {}", path.display()))?;
        let samples = source
            .read_all()
            .with_context(|| format!("cannot read the recording {}", path.display()))?;
        if rate == 0 {
            rate = source.sample_rate();
        }
        let samples = resample_clip(&samples, source.sample_rate(), rate)
            .with_context(|| format!("cannot resample {}", path.display()))?;
        if mix.len() < samples.len() {
            mix.resize(samples.len(), 0.0);
        }
        for (m, s) in mix.iter_mut().zip(&samples) {
            *m += s;
        }
    }
    let peak = mix.iter().fold(0.0_f32, |p, s| p.max(s.abs()));
    let gain = if peak > 1.0 { 1.0 / peak } else { 1.0 };
    let mut bytes = std::io::Cursor::new(Vec::new());
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: rate,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut writer = hound::WavWriter::new(&mut bytes, spec)?;
    for s in &mix {
        writer.write_sample((s * gain * f32::from(i16::MAX)).round() as i16)?;
    }
    writer.finalize()?;
    Ok(bytes.into_inner())
}

/// Writes one self-contained page: the recording embedded as a data URL, the frames as
/// JSON, and a script that draws the frame of the audio element's current time (or of
/// the time in the address's `#t=SECONDS`: a still, the frame alone at the top left).
pub fn write_html(
    animation: &Animation,
    sound: &[u8],
    title: &str,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    let audio = base64::engine::general_purpose::STANDARD.encode(sound);
    // In a <script> element, "</" would end it early; JSON allows "<\/".
    let data = serde_json::to_string(animation)?.replace("</", "<\\/");
    let title = escape_html(title);
    write!(
        out,
        r#"<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
body {{ margin: 0; background: #1d1d1d; color: #ddd; font: 14px sans-serif; }}
main {{ display: flex; flex-direction: column; align-items: center; gap: 8px; padding: 8px; }}
canvas {{ max-width: 100%; height: auto; }}
audio {{ width: min(100%, {width}px); }}
.still main {{ padding: 0; }}
.still audio {{ display: none; }}
</style>
</head>
<body>
<main>
<canvas id="scene" width="{width}" height="{height}"></canvas>
<audio id="sound" controls preload="auto" src="data:audio/wav;base64,{audio}"></audio>
</main>
<script id="frames" type="application/json">{data}</script>
<script>
"use strict";
const anim = JSON.parse(document.getElementById("frames").textContent);
const canvas = document.getElementById("scene");
const ctx = canvas.getContext("2d");
const sound = document.getElementById("sound");
function shape(s) {{
  ctx.fillStyle = s.color;
  if (s.shape === "ellipse") {{
    ctx.beginPath();
    ctx.ellipse(s.cx, s.cy, s.rx, s.ry, 0, 0, 2 * Math.PI);
    ctx.fill();
  }} else if (s.shape === "rect") {{
    ctx.fillRect(s.x, s.y, s.w, s.h);
  }} else if (s.shape === "polygon") {{
    ctx.beginPath();
    s.points.forEach(([x, y], i) => i === 0 ? ctx.moveTo(x, y) : ctx.lineTo(x, y));
    ctx.closePath();
    ctx.fill();
  }} else if (s.shape === "text") {{
    ctx.font = s.size + "px sans-serif";
    ctx.fillText(s.text, s.x, s.y);
  }}
}}
function draw(t) {{
  const k = Math.min(anim.frames.length - 1, Math.max(0, Math.round(t * anim.fps)));
  ctx.fillStyle = anim.background;
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  anim.fixed.forEach(shape);
  anim.frames[k].forEach(shape);
}}
const still = /[#&]t=([0-9.]+)/.exec(location.hash);
if (still) {{
  // A still: the frame alone, at the top left (for a link to one moment, or a test).
  document.body.classList.add("still");
  const t = parseFloat(still[1]);
  sound.currentTime = t;
  draw(t);
}} else {{
  const loop = () => {{ draw(sound.currentTime); requestAnimationFrame(loop); }};
  loop();
}}
</script>
</body>
</html>
"#,
        width = animation.width,
        height = animation.height,
    )?;
    Ok(())
}

/// Writes the animation as an MP4 video with `sound` (WAV bytes), through temporary
/// files beside `path`: a failure (ffmpeg missing, a full disk) leaves nothing.
pub fn write_video(
    animation: &Animation,
    sound: &[u8],
    path: &Path,
    progress: &mut dyn FnMut(usize),
) -> anyhow::Result<()> {
    write_through_partial(path, |partial| {
        let wav = partial.with_extension("wav");
        let written = std::fs::write(&wav, sound)
            .with_context(|| format!("cannot write {}", wav.display()))
            .and_then(|()| video::write_mp4(animation, &wav, partial, progress));
        let _ = std::fs::remove_file(&wav);
        written
    })
}

/// One event as `analyze` writes it; only what a scene needs is required.
#[derive(Debug, serde::Deserialize)]
struct EventRecord {
    pattern: String,
    kind: PatternKind,
    time: f64,
    end: Option<f64>,
    #[serde(default = "one")]
    strength: f64,
    id: Option<u64>,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, serde::Deserialize)]
struct EventsFile {
    events: Vec<EventRecord>,
}

/// Reads the events of an `analyze` JSON output (`{"events": [...]}`), checked: times
/// finite and not negative, an end not before its time, strengths finite.
pub fn read_events(path: &Path) -> anyhow::Result<Vec<Event>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the events file {}", path.display()))?;
    let file: EventsFile = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: expected the JSON that `onomato analyze` writes ({{\"events\": [{{\"pattern\", \"kind\", \"time\", ...}}]}})",
            path.display()
        )
    })?;
    let mut events = Vec::with_capacity(file.events.len());
    for (i, r) in file.events.into_iter().enumerate() {
        let bad =
            |what: &str| anyhow::anyhow!("{}: event {i} ({}): {what}", path.display(), r.pattern);
        if !(r.time.is_finite() && r.time >= 0.0) {
            return Err(bad(&format!(
                "time must be a number of seconds ≥ 0, found {}",
                r.time
            )));
        }
        if let Some(end) = r.end {
            if !(end.is_finite() && end >= r.time) {
                return Err(bad(&format!(
                    "end must be at or after its time {}, found {end}",
                    r.time
                )));
            }
        }
        if !(r.strength.is_finite() && r.strength >= 0.0) {
            return Err(bad(&format!(
                "strength must be a number ≥ 0, found {}",
                r.strength
            )));
        }
        events.push(Event {
            id: r.id.unwrap_or(i as u64),
            pattern: r.pattern.into(),
            kind: r.kind,
            time: r.time,
            end: r.end,
            strength: r.strength,
            score: 1.0,
            emitted_at: r.end.unwrap_or(r.time),
            pitch: None,
        });
    }
    events.sort_by(|a, b| a.time.total_cmp(&b.time));
    Ok(events)
}

/// Writes `path` through a temporary file beside it, renamed into place when whole:
/// a failure leaves nothing behind.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    write_through_partial(path, |partial| {
        let mut out = std::io::BufWriter::new(std::fs::File::create(partial)?);
        write(&mut out)?;
        out.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        Ok(())
    })
}

/// `fill` writes the whole output into a temporary file beside `path`, which is then
/// renamed to `path`; on any failure the temporary file is removed. Errors name `path`.
fn write_through_partial(
    path: &Path,
    fill: impl FnOnce(&Path) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let partial = dir.join(format!(".{name}.partial-{}", std::process::id()));
    let result = fill(&partial).and_then(|()| Ok(std::fs::rename(&partial, path)?));
    if result.is_err() {
        let _ = std::fs::remove_file(&partial);
    }
    result.with_context(|| format!("cannot write {}", path.display()))
}

fn escape_html(text: &str) -> String {
    text.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Events for the unit tests of the scenes and the writers.
#[cfg(test)]
mod test_events {
    use crate::config::PatternKind;
    use crate::detect::Event;
    use std::sync::Arc;

    pub(super) fn hit(id: u64, pattern: &str, time: f64, strength: f64) -> Event {
        Event {
            id,
            pattern: Arc::from(pattern),
            kind: PatternKind::Impulse,
            time,
            end: None,
            strength,
            score: 1.0,
            emitted_at: time,
            pitch: None,
        }
    }

    pub(super) fn held(id: u64, pattern: &str, time: f64, end: f64) -> Event {
        Event {
            kind: PatternKind::Continuous,
            end: Some(end),
            ..hit(id, pattern, time, 1.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::test_events::hit;
    use super::*;

    fn names(kinds: &[(&str, PatternKind)]) -> Vec<(String, PatternKind)> {
        kinds.iter().map(|(n, k)| (n.to_string(), *k)).collect()
    }

    #[test]
    fn scenes_the_config_does_not_map_get_actions_from_the_kinds_of_the_patterns() {
        use PatternKind::{Continuous, Impulse};
        let patterns = names(&[
            ("pew", Impulse),
            ("chhh", Continuous),
            ("boom", Impulse),
            ("hup", Impulse),
            ("hooo", Continuous),
            ("sss", Continuous),
        ]);
        let a = Actions::new(&RenderSettings::default(), None, &patterns);
        assert_eq!(a.bounce.styles["pew"], ContactStyle::Hard);
        assert_eq!(a.bounce.styles["chhh"], ContactStyle::Slide);
        assert_eq!(a.darts["pew"], DartsAction::Throw);
        assert_eq!(a.darts["chhh"], DartsAction::Up);
        assert_eq!(a.darts["hooo"], DartsAction::Down);
        assert!(
            !a.darts.contains_key("sss"),
            "a third held sound does nothing"
        );
        assert_eq!(a.laser["pew"], LaserAction::ShootLow);
        assert_eq!(a.laser["boom"], LaserAction::ShootHigh);
        assert_eq!(a.laser["hup"], LaserAction::Jump);
        assert_eq!(a.laser["sss"], LaserAction::Slide);
        assert_eq!(a.rain.len(), 3);
        // A mapping in the config is taken as it is: what it leaves out does nothing.
        let render = RenderSettings {
            darts: Some([("boom".to_string(), DartsAction::Throw)].into()),
            rain: Some(vec!["hup".into()]),
            ..RenderSettings::default()
        };
        let a = Actions::new(&render, None, &patterns);
        assert_eq!(a.darts.len(), 1);
        assert_eq!(a.rain, ["hup".to_string()].into());
        assert_eq!(a.laser.len(), 6, "laser still from the kinds");
    }

    #[test]
    fn patterns_of_events_are_in_the_order_first_heard() {
        let mut held = hit(2, "hooo", 0.2, 1.0);
        held.kind = PatternKind::Continuous;
        let tracks = vec![
            vec![hit(0, "pew", 0.5, 1.0), hit(1, "boom", 0.7, 1.0)],
            vec![held, hit(0, "pew", 0.1, 1.0)],
        ];
        let names: Vec<String> = patterns_of_events(&tracks)
            .into_iter()
            .map(|p| p.0)
            .collect();
        assert_eq!(names, ["pew", "boom", "hooo"]);
    }

    const FRAMES: FrameSettings = FrameSettings {
        fps: 50,
        width: 640,
        height: 360,
    };

    #[test]
    fn the_page_embeds_the_sound_and_the_frames_and_cannot_be_closed_by_a_label() {
        let dir = std::env::temp_dir();
        let wav = dir.join(format!("onomato-render-{}.wav", std::process::id()));
        std::fs::write(&wav, b"RIFF-not-really").unwrap();
        let events = [hit(0, "</script><b>", 0.5, 1.0)];
        let actions = Actions::new(&RenderSettings::default(), None, &[]);
        let a = animate(Scene::Timeline, &[events.to_vec()], &actions, FRAMES, 1.0);
        let mut page = Vec::new();
        write_html(
            &a,
            &soundtrack(std::slice::from_ref(&wav)).unwrap(),
            "a <title>",
            &mut page,
        )
        .unwrap();
        std::fs::remove_file(&wav).unwrap();
        let page = String::from_utf8(page).unwrap();
        assert!(page.contains("data:audio/wav;base64,UklGRi1ub3QtcmVhbGx5"));
        assert!(page.contains("<title>a &lt;title&gt;</title>"));
        assert_eq!(
            page.matches("</script>").count(),
            2,
            "a label ended a script"
        );
        let json = page.split("type=\"application/json\">").nth(1).unwrap();
        let json = json.split("</script>").next().unwrap();
        let parsed: serde_json::Value = serde_json::from_str(json).unwrap();
        assert_eq!(parsed["frames"].as_array().unwrap().len(), 51);
    }

    #[test]
    fn several_soundtracks_are_summed_at_the_first_ones_rate_and_kept_from_clipping() {
        let dir = std::env::temp_dir();
        let path = |n: &str| dir.join(format!("onomato-mix-{n}-{}.wav", std::process::id()));
        let write = |p: &std::path::Path, rate: u32, samples: &[f32]| {
            let spec = hound::WavSpec {
                channels: 1,
                sample_rate: rate,
                bits_per_sample: 32,
                sample_format: hound::SampleFormat::Float,
            };
            let mut w = hound::WavWriter::create(p, spec).unwrap();
            samples.iter().for_each(|s| w.write_sample(*s).unwrap());
            w.finalize().unwrap();
        };
        let (a, b) = (path("a"), path("b"));
        write(&a, 8000, &[0.25; 8000]);
        write(&b, 8000, &[0.5; 16000]);
        let mix = soundtrack(&[a.clone(), b.clone()]).unwrap();
        let mut reader = hound::WavReader::new(std::io::Cursor::new(mix)).unwrap();
        assert_eq!(reader.spec().sample_rate, 8000);
        let samples: Vec<i16> = reader.samples::<i16>().map(Result::unwrap).collect();
        assert_eq!(samples.len(), 16000, "as long as the longest");
        let full = f32::from(i16::MAX);
        assert!((f32::from(samples[4000]) / full - 0.75).abs() < 1e-3);
        assert!((f32::from(samples[12000]) / full - 0.5).abs() < 1e-3);
        // A sum over full scale is scaled down, not clipped.
        write(&b, 8000, &[0.9; 8000]);
        let mix = soundtrack(&[a.clone(), b.clone()]).unwrap();
        let mut reader = hound::WavReader::new(std::io::Cursor::new(mix)).unwrap();
        let first = reader.samples::<i16>().next().unwrap().unwrap();
        assert_eq!(first, i16::MAX);
        std::fs::remove_file(a).unwrap();
        std::fs::remove_file(b).unwrap();
    }
}
