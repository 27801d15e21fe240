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

pub mod video;

use std::io::Write;
use std::path::Path;

use anyhow::Context;
use base64::Engine as _;
use serde::Serialize;

use crate::config::{BounceSettings, ContactStyle, PatternKind};
use crate::detect::Event;
use crate::solver::{self, Contact, Trajectory};

/// What is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Scene {
    /// A ball bouncing on the floor: it lands on every hard bounce, squashes on soft
    /// ones by their strength and slides along the floor through held sounds.
    Ball,
    /// Every event on a strip over time, with its label and strength, and a playhead.
    Timeline,
    /// The paper's rain: each impulse drops a drop at a place of its own (the same on
    /// every run), landing at its time, as large as it is strong.
    Rain,
}

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
const INK: &str = "#2b2b2b";
const GREY: &str = "#8a8a8a";
/// Hard bounce, soft bounce, slide: blue, red, green as in the paper's figure.
const HARD: &str = "#2f64d8";
const SOFT: &str = "#d83a34";
const SLIDE: &str = "#2f9a4a";
/// Colours of patterns on the timeline, in the order the patterns first appear.
const PALETTE: [&str; 6] = [HARD, SOFT, SLIDE, "#c47f12", "#7b3fb5", "#1b8f9a"];

/// Draws `scene` for a soundtrack of `duration_seconds` with these events.
pub fn animate(
    scene: Scene,
    events: &[Event],
    bounce: &BounceSettings,
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
        Scene::Ball => ball(&mut animation, events, bounce, frames, count),
        Scene::Timeline => timeline(&mut animation, events, frames, count),
        Scene::Rain => rain(&mut animation, events, frames, count),
    }
    animation
}

/// The ball scene. Heights are the solver's, scaled so that the highest flight fits
/// in the frame; the ball's x moves only while it slides.
fn ball(
    animation: &mut Animation,
    events: &[Event],
    bounce: &BounceSettings,
    frames: FrameSettings,
    count: usize,
) {
    let (w, h) = (frames.width as f32, frames.height as f32);
    let contacts = solver::solve(events, bounce);
    let radius = (h * 0.045).max(3.0);
    let floor_y = (h * 0.85).round();
    let highest = contacts
        .iter()
        .map(|c| c.apex_height)
        .fold(0.0_f64, f64::max);
    let room = f64::from(floor_y - 2.0 * radius - h * 0.08).max(1.0);
    let scale = if highest > 0.0 { room / highest } else { 1.0 } as f32;
    let geometry = BallGeometry {
        floor_y,
        radius,
        scale,
    };
    animation.ball = Some(geometry);
    animation.fixed.push(Shape::Rect {
        x: 0.0,
        y: floor_y,
        w,
        h: (h * 0.006).max(2.0),
        color: INK,
    });
    let trajectory = Trajectory {
        gravity: bounce.gravity,
        contacts: &contacts,
    };
    // The frame of each contact: there the ball is on the floor whatever the frame's
    // own time, so that a hit is seen where it is heard.
    let contact_frame: Vec<usize> = contacts.iter().map(|c| frames.frame_of(c.time)).collect();
    let slide_speed = f64::from(w) * 0.25;
    let (left, span) = (f64::from(w) * 0.15, f64::from(w) * 0.7);
    for k in 0..count {
        let t = k as f64 / f64::from(frames.fps);
        let on_contact = contact_frame.iter().position(|&f| f == k);
        let height = if on_contact.is_some() {
            0.0
        } else {
            trajectory.height_at(t)
        };
        // Time spent sliding before t moves the ball along the floor, wrapping.
        let slid: f64 = contacts
            .iter()
            .filter(|c| c.style == ContactStyle::Slide)
            .map(|c| (t.min(c.end) - c.time).max(0.0))
            .sum();
        let cx = (left + (slid * slide_speed) % span) as f32;
        let last = on_contact
            .map(|i| &contacts[i])
            .or_else(|| contacts.iter().rev().find(|c| c.time <= t));
        let color = match last.map(|c| c.style) {
            None => GREY,
            Some(ContactStyle::Hard) => HARD,
            Some(ContactStyle::Soft) => SOFT,
            Some(ContactStyle::Slide) => SLIDE,
        };
        // A soft bounce's frame squashes the ball, its area kept.
        let squash = on_contact.map_or(0.0, |i| contacts[i].squash) as f32;
        let (rx, ry) = (radius / (1.0 - squash), radius * (1.0 - squash));
        let bottom = floor_y - height as f32 * scale;
        let mut shapes = vec![Shape::Ellipse {
            cx,
            cy: bottom - ry,
            rx,
            ry,
            color,
        }];
        if let Some(c) = last.filter(|c| t - c.time < 0.4) {
            shapes.push(label(c, radius));
        }
        animation.frames.push(shapes);
    }
}

/// The name and strength of the contact just made, top left.
fn label(c: &Contact, radius: f32) -> Shape {
    Shape::Text {
        x: radius,
        y: radius * 2.0,
        size: radius * 1.2,
        text: format!("{}  {:.2}", c.pattern, c.strength),
        color: INK,
    }
}

/// How long a drop falls, seconds: long enough to be seen, short enough that drops of
/// a quick rhythm do not pile up.
const RAIN_FALL_SECONDS: f64 = 0.6;
/// How long a splash stays, seconds.
const RAIN_SPLASH_SECONDS: f64 = 0.25;

/// A place in [0, 1) for event `id`, the same on every run (SplitMix64).
fn place_of(id: u64) -> f64 {
    let mut z = id.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// The rain scene: each impulse is a drop falling as a dropped body does (distance
/// growing with the square of time) from the top to the ground, touching it at the
/// event's time, then a splash.
fn rain(animation: &mut Animation, events: &[Event], frames: FrameSettings, count: usize) {
    let (w, h) = (frames.width as f32, frames.height as f32);
    let ground = (h * 0.85).round();
    let top = h * 0.05;
    let unit = (h * 0.02).max(2.0);
    animation.fixed.push(Shape::Rect {
        x: 0.0,
        y: ground,
        w,
        h: h - ground,
        color: "#c9c2b3",
    });
    let drops: Vec<(f64, f32, f32)> = events
        .iter()
        .filter(|e| e.kind == PatternKind::Impulse)
        .map(|e| {
            let x = w * (0.05 + 0.9 * place_of(e.id) as f32);
            let size = unit * (0.5 + e.strength.clamp(0.0, 2.0) as f32);
            (e.time, x, size)
        })
        .collect();
    for k in 0..count {
        let t = k as f64 / f64::from(frames.fps);
        let mut shapes = Vec::new();
        for &(land, x, size) in &drops {
            let k_land = frames.frame_of(land);
            if k < k_land && t >= land - RAIN_FALL_SECONDS {
                let fallen = ((t - (land - RAIN_FALL_SECONDS)) / RAIN_FALL_SECONDS).powi(2) as f32;
                shapes.push(Shape::Ellipse {
                    cx: x,
                    cy: top + (ground - size * 1.5 - top) * fallen,
                    rx: size,
                    ry: size * 1.5,
                    color: HARD,
                });
            } else if k >= k_land && t < land + RAIN_SPLASH_SECONDS {
                // Touching the ground at its frame, then spreading flat.
                let spread = 1.0
                    + 3.0
                        * ((k - k_land) as f64 / f64::from(frames.fps) / RAIN_SPLASH_SECONDS)
                            as f32;
                let ry = size * 1.5 / spread;
                shapes.push(Shape::Ellipse {
                    cx: x,
                    cy: ground - ry,
                    rx: size * spread,
                    ry,
                    color: HARD,
                });
            }
        }
        animation.frames.push(shapes);
    }
}

/// The timeline: a strip of every event (a bar as high as its strength; a held sound
/// as long as it lasts), seconds marked, and a playhead.
fn timeline(animation: &mut Animation, events: &[Event], frames: FrameSettings, count: usize) {
    let (w, h) = (frames.width as f32, frames.height as f32);
    let margin = w * 0.04;
    let duration = animation.duration_seconds.max(1e-3);
    let x_of = |t: f64| margin + (t / duration) as f32 * (w - 2.0 * margin);
    let base = h * 0.7;
    let tall = h * 0.45;
    let text = (h * 0.035).max(8.0);
    let fixed = &mut animation.fixed;
    fixed.push(Shape::Rect {
        x: margin,
        y: base,
        w: w - 2.0 * margin,
        h: 1.5,
        color: INK,
    });
    for s in 0..=duration.floor() as u32 {
        let x = x_of(f64::from(s));
        fixed.push(Shape::Rect {
            x,
            y: base,
            w: 1.0,
            h: text * 0.6,
            color: GREY,
        });
        fixed.push(Shape::Text {
            x: x + 2.0,
            y: base + text * 1.6,
            size: text,
            text: format!("{s} s"),
            color: GREY,
        });
    }
    let mut names: Vec<&str> = Vec::new();
    for e in events {
        let i = match names.iter().position(|n| **n == *e.pattern) {
            Some(i) => i,
            None => {
                names.push(&e.pattern);
                names.len() - 1
            }
        };
        let color = PALETTE[i % PALETTE.len()];
        let bar = (e.strength.clamp(0.0, 1.5) / 1.5) as f32 * tall + 2.0;
        let x = x_of(e.time);
        let width = match (e.kind, e.end) {
            (PatternKind::Continuous, Some(end)) => (x_of(end) - x).max(2.0),
            _ => 2.0,
        };
        fixed.push(Shape::Rect {
            x,
            y: base - bar,
            w: width,
            h: bar,
            color,
        });
        fixed.push(Shape::Text {
            x: x + 3.0,
            y: base - bar - text * 0.4,
            size: text,
            text: format!("{} {:.2}", e.pattern, e.strength),
            color,
        });
    }
    for k in 0..count {
        let t = k as f64 / f64::from(frames.fps);
        animation.frames.push(vec![Shape::Rect {
            x: x_of(t) - 1.0,
            y: h * 0.1,
            w: 2.0,
            h: h * 0.8,
            color: INK,
        }]);
    }
}

/// Writes one self-contained page: the recording embedded as a data URL, the frames as
/// JSON, and a script that draws the frame of the audio element's current time (or of
/// the time in the address's `#t=SECONDS`: a still, the frame alone at the top left).
pub fn write_html(
    animation: &Animation,
    recording: &Path,
    title: &str,
    out: &mut dyn Write,
) -> anyhow::Result<()> {
    let audio = std::fs::read(recording)
        .with_context(|| format!("cannot read the recording {}", recording.display()))?;
    let audio = base64::engine::general_purpose::STANDARD.encode(audio);
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

/// Writes the animation as an MP4 video with the recording's sound, through a
/// temporary file beside `path`: a failure (ffmpeg missing, a full disk) leaves nothing.
pub fn write_video(
    animation: &Animation,
    recording: &Path,
    path: &Path,
    progress: &mut dyn FnMut(usize),
) -> anyhow::Result<()> {
    write_through_partial(path, |partial| {
        video::write_mp4(animation, recording, partial, progress)
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

/// Bounce styles from the events themselves (no patterns given): an impulse is a hard
/// bounce, a held sound a slide.
pub fn bounce_for_events(events: &[Event]) -> BounceSettings {
    let mut styles = std::collections::BTreeMap::new();
    for e in events {
        let style = match e.kind {
            PatternKind::Impulse => ContactStyle::Hard,
            PatternKind::Continuous => ContactStyle::Slide,
        };
        styles.entry(e.pattern.to_string()).or_insert(style);
    }
    BounceSettings {
        styles,
        ..BounceSettings::default_for(&[])
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    fn hit(id: u64, pattern: &str, time: f64, strength: f64) -> Event {
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

    fn settings(styles: &[(&str, ContactStyle)]) -> BounceSettings {
        BounceSettings {
            gravity: 9.81,
            styles: styles.iter().map(|(n, s)| (n.to_string(), *s)).collect(),
            max_squash: 0.4,
            default_interval_seconds: 0.5,
            state_delay_seconds: None,
        }
    }

    const FRAMES: FrameSettings = FrameSettings {
        fps: 50,
        width: 640,
        height: 360,
    };

    fn ball_of(frame: &[Shape]) -> (f32, f32, f32, f32) {
        match frame[0] {
            Shape::Ellipse { cx, cy, rx, ry, .. } => (cx, cy, rx, ry),
            _ => panic!("the ball is drawn first"),
        }
    }

    #[test]
    fn the_ball_is_on_the_floor_at_each_hit_frame_and_at_the_apex_half_way() {
        let events = [
            hit(0, "tick", 0.5, 1.0),
            hit(1, "tick", 1.0, 1.0),
            hit(2, "tick", 1.73, 1.0),
        ];
        let a = animate(
            Scene::Ball,
            &events,
            &settings(&[("tick", ContactStyle::Hard)]),
            FRAMES,
            2.0,
        );
        let g = a.ball.unwrap();
        assert_eq!(a.frames.len(), 101);
        for e in &events {
            let (_, cy, _, ry) = ball_of(&a.frames[FRAMES.frame_of(e.time)]);
            assert_eq!(cy + ry, g.floor_y, "at {}", e.time);
        }
        // Half-way between 1.0 and 1.73 (frame 68.25 → the nearest frame's height).
        let apex = 9.81 * 0.73 * 0.73 / 8.0;
        let k = FRAMES.frame_of(1.365);
        let t = k as f64 / 50.0;
        let dt = t - 1.0;
        let height = 9.81 * 0.73 / 2.0 * dt - 9.81 * dt * dt / 2.0;
        let (_, cy, _, ry) = ball_of(&a.frames[k]);
        assert!((g.floor_y - (cy + ry) - height as f32 * g.scale).abs() < 0.01);
        assert!(height <= apex && apex - height < 0.01);
        // The highest flight fills the room above the floor.
        assert!(g.scale * apex as f32 > 150.0);
    }

    #[test]
    fn a_soft_bounce_squashes_the_ball_by_its_strength_keeping_its_area() {
        let events = [hit(0, "pop", 0.5, 0.5), hit(1, "pop", 1.0, 1.0)];
        let a = animate(
            Scene::Ball,
            &events,
            &settings(&[("pop", ContactStyle::Soft)]),
            FRAMES,
            1.5,
        );
        let r = a.ball.unwrap().radius;
        for (e, squash) in events.iter().zip([0.2_f32, 0.4]) {
            let (_, _, rx, ry) = ball_of(&a.frames[FRAMES.frame_of(e.time)]);
            assert!((ry - r * (1.0 - squash)).abs() < 1e-3);
            assert!((rx * ry - r * r).abs() < 1e-2);
        }
        let (_, _, rx, ry) = ball_of(&a.frames[FRAMES.frame_of(0.75)]);
        assert_eq!((rx, ry), (r, r), "round in the air");
    }

    #[test]
    fn a_held_sound_slides_the_ball_along_the_floor_for_exactly_its_span() {
        let mut held = hit(0, "chhh", 0.5, 1.0);
        held.kind = PatternKind::Continuous;
        held.end = Some(1.5);
        let events = [held, hit(1, "tick", 2.0, 1.0)];
        let a = animate(
            Scene::Ball,
            &events,
            &settings(&[("chhh", ContactStyle::Slide), ("tick", ContactStyle::Hard)]),
            FRAMES,
            2.5,
        );
        let x = |t: f64| ball_of(&a.frames[FRAMES.frame_of(t)]).0;
        assert_eq!(x(0.2), x(0.5));
        assert!(x(1.0) > x(0.5) && x(1.5) > x(1.0));
        assert_eq!(x(1.5), x(2.4), "it stops when the sound ends");
        let floor = a.ball.unwrap().floor_y;
        let (_, cy, _, ry) = ball_of(&a.frames[FRAMES.frame_of(1.0)]);
        assert_eq!(cy + ry, floor, "on the floor while it slides");
    }

    #[test]
    fn each_drop_falls_faster_and_faster_and_touches_the_ground_at_its_event() {
        let events = [hit(0, "knock", 1.0, 0.5), hit(1, "knock", 1.2, 1.5)];
        let a = animate(Scene::Rain, &events, &settings(&[]), FRAMES, 2.0);
        let ground = (360.0_f32 * 0.85).round();
        let drop = |t: f64, i: usize| match &a.frames[FRAMES.frame_of(t)][i] {
            Shape::Ellipse { cx, cy, rx, ry, .. } => (*cx, *cy, *rx, *ry),
            _ => panic!("a drop"),
        };
        assert!(
            a.frames[FRAMES.frame_of(0.3)].is_empty(),
            "nothing before the fall"
        );
        // The first drop: on the ground at its frame, having fallen more in its second
        // half than in its first.
        let (x, cy, _, ry) = drop(1.0, 0);
        assert_eq!(cy + ry, ground);
        let (x0, y0, _, _) = drop(0.4, 0);
        let (_, y1, _, _) = drop(0.7, 0);
        let (_, y2, _, _) = drop(0.98, 0);
        assert_eq!(x0, x, "it falls straight");
        assert!(y1 - y0 < y2 - y1);
        // The stronger drop is larger, elsewhere, and lands at 1.2 s.
        let (x1, cy1, rx1, ry1) = drop(1.2, 1);
        assert_eq!(cy1 + ry1, ground);
        assert!(rx1 > drop(1.0, 0).2 && x1 != x);
        // The same places on every run.
        let again = animate(Scene::Rain, &events, &settings(&[]), FRAMES, 2.0);
        assert_eq!(again.frames, a.frames);
        assert!(a.frames[FRAMES.frame_of(1.9)].is_empty(), "splashes gone");
    }

    #[test]
    fn the_page_embeds_the_sound_and_the_frames_and_cannot_be_closed_by_a_label() {
        let dir = std::env::temp_dir();
        let wav = dir.join(format!("onomato-render-{}.wav", std::process::id()));
        std::fs::write(&wav, b"RIFF-not-really").unwrap();
        let events = [hit(0, "</script><b>", 0.5, 1.0)];
        let a = animate(Scene::Timeline, &events, &settings(&[]), FRAMES, 1.0);
        let mut page = Vec::new();
        write_html(&a, &wav, "a <title>", &mut page).unwrap();
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
}
