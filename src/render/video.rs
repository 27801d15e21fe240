//! MP4 output: each frame's shapes rasterised in Rust (tiny-skia; labels with
//! ab_glyph in DejaVu Sans) and piped as raw RGBA to `ffmpeg`, which encodes H.264 and
//! muxes the soundtrack in from frame 0.
//!
//! Runs on the main thread.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

use ab_glyph::{Font, FontVec, PxScale, ScaleFont};
use anyhow::Context;
use tiny_skia::{FillRule, Paint, PathBuilder, Pixmap, Rect, Transform};

use super::{Animation, Shape};

/// Where Debian (fonts-dejavu-core) and other distributions keep DejaVu Sans.
const FONT_PATHS: [&str; 3] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
];

/// Draws frames of an animation into pixels.
pub struct Rasteriser {
    pixmap: Pixmap,
    font: Option<FontVec>,
}

impl Rasteriser {
    pub fn new(animation: &Animation) -> anyhow::Result<Self> {
        let pixmap = Pixmap::new(animation.width, animation.height).with_context(|| {
            format!(
                "cannot make a frame of {}x{} pixels",
                animation.width, animation.height
            )
        })?;
        let font = FONT_PATHS
            .iter()
            .find_map(|p| std::fs::read(p).ok())
            .and_then(|data| FontVec::try_from_vec(data).ok());
        let has_text = animation
            .fixed
            .iter()
            .chain(animation.frames.iter().flatten())
            .any(|s| matches!(s, Shape::Text { .. }));
        if font.is_none() && has_text {
            tracing::warn!(
                "no DejaVu Sans font (Debian: fonts-dejavu-core): the video's labels are left out"
            );
        }
        Ok(Self { pixmap, font })
    }

    /// Frame `k` as RGBA bytes (opaque, so premultiplied is plain).
    pub fn frame(&mut self, animation: &Animation, k: usize) -> &[u8] {
        self.pixmap.fill(parse_color(animation.background));
        for shape in animation.fixed.iter().chain(&animation.frames[k]) {
            self.draw(shape);
        }
        self.pixmap.data()
    }

    fn draw(&mut self, shape: &Shape) {
        let mut paint = Paint {
            anti_alias: true,
            ..Paint::default()
        };
        match shape {
            Shape::Ellipse {
                cx,
                cy,
                rx,
                ry,
                color,
            } => {
                paint.set_color(parse_color(color));
                let oval = Rect::from_xywh(cx - rx, cy - ry, 2.0 * rx, 2.0 * ry);
                if let Some(path) = oval.and_then(PathBuilder::from_oval) {
                    self.pixmap.fill_path(
                        &path,
                        &paint,
                        FillRule::Winding,
                        Transform::identity(),
                        None,
                    );
                }
            }
            Shape::Rect { x, y, w, h, color } => {
                paint.set_color(parse_color(color));
                if let Some(rect) = Rect::from_xywh(*x, *y, *w, *h) {
                    self.pixmap
                        .fill_rect(rect, &paint, Transform::identity(), None);
                }
            }
            Shape::Text {
                x,
                y,
                size,
                text,
                color,
            } => self.text(*x, *y, *size, text, color),
            Shape::Polygon { points, color } => {
                paint.set_color(parse_color(color));
                let mut path = PathBuilder::new();
                for (i, &[x, y]) in points.iter().enumerate() {
                    if i == 0 {
                        path.move_to(x, y);
                    } else {
                        path.line_to(x, y);
                    }
                }
                path.close();
                if let Some(path) = path.finish() {
                    self.pixmap.fill_path(
                        &path,
                        &paint,
                        FillRule::Winding,
                        Transform::identity(),
                        None,
                    );
                }
            }
        }
    }

    /// Text with its baseline at `y`, as a canvas's `fillText` draws it.
    fn text(&mut self, x: f32, y: f32, size: f32, text: &str, color: &str) {
        let Some(font) = &self.font else {
            return;
        };
        let [r, g, b] = rgb(color);
        let (width, height) = (self.pixmap.width(), self.pixmap.height());
        let data = self.pixmap.data_mut();
        let scale = PxScale::from(size);
        let scaled = font.as_scaled(scale);
        let mut pen = x;
        for c in text.chars() {
            let id = font.glyph_id(c);
            let glyph = id.with_scale_and_position(scale, ab_glyph::point(pen, y));
            pen += scaled.h_advance(id);
            let Some(outline) = font.outline_glyph(glyph) else {
                continue;
            };
            let bounds = outline.px_bounds();
            outline.draw(|gx, gy, coverage| {
                let px = bounds.min.x as i64 + i64::from(gx);
                let py = bounds.min.y as i64 + i64::from(gy);
                if px < 0 || py < 0 || px >= i64::from(width) || py >= i64::from(height) {
                    return;
                }
                let i = (py as usize * width as usize + px as usize) * 4;
                let a = coverage.clamp(0.0, 1.0);
                for (channel, value) in data[i..i + 3].iter_mut().zip([r, g, b]) {
                    *channel =
                        (f32::from(value) * a + f32::from(*channel) * (1.0 - a)).round() as u8;
                }
            });
        }
    }
}

/// "#rrggbb" as bytes; anything else is black.
fn rgb(color: &str) -> [u8; 3] {
    let hex = color.strip_prefix('#').unwrap_or("");
    let byte = |i: usize| {
        hex.get(i..i + 2)
            .and_then(|h| u8::from_str_radix(h, 16).ok())
            .unwrap_or(0)
    };
    if hex.len() == 6 {
        [byte(0), byte(2), byte(4)]
    } else {
        [0, 0, 0]
    }
}

fn parse_color(color: &str) -> tiny_skia::Color {
    let [r, g, b] = rgb(color);
    tiny_skia::Color::from_rgba8(r, g, b, 255)
}

/// Encodes the animation with the sound of the WAV file `sound` into `partial` (an MP4), through
/// `ffmpeg`. `progress` is told each frame written.
pub fn write_mp4(
    animation: &Animation,
    sound: &Path,
    partial: &Path,
    progress: &mut dyn FnMut(usize),
) -> anyhow::Result<()> {
    let mut raster = Rasteriser::new(animation)?;
    let size = format!("{}x{}", animation.width, animation.height);
    let fps = animation.fps.to_string();
    let mut ffmpeg = Command::new("ffmpeg")
        .args(["-hide_banner", "-loglevel", "error", "-nostdin", "-y"])
        .args(["-f", "rawvideo", "-pix_fmt", "rgba", "-s", &size, "-framerate", &fps])
        .args(["-i", "-"])
        .arg("-i")
        .arg(sound)
        .args(["-map", "0:v", "-map", "1:a"])
        .args(["-c:v", "libx264", "-preset", "veryfast", "-crf", "18"])
        .args(["-pix_fmt", "yuv420p", "-c:a", "aac", "-b:a", "192k"])
        .args(["-movflags", "+faststart", "-f", "mp4"])
        .arg(partial)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                anyhow::anyhow!(
                    "MP4 output needs ffmpeg, which is not installed (Debian: apt install ffmpeg); an .html output needs nothing"
                )
            } else {
                anyhow::anyhow!("cannot start ffmpeg: {e}")
            }
        })?;
    let mut sent = Ok(());
    if let Some(mut stdin) = ffmpeg.stdin.take() {
        for k in 0..animation.frames.len() {
            if let Err(e) = stdin.write_all(raster.frame(animation, k)) {
                sent = Err(e);
                break;
            }
            progress(k + 1);
        }
    }
    let out = ffmpeg.wait_with_output().context("ffmpeg did not finish")?;
    if !out.status.success() {
        anyhow::bail!(
            "ffmpeg could not encode the video: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    sent.context("ffmpeg stopped reading frames")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_are_drawn_where_the_page_draws_them() {
        let animation = Animation {
            fps: 10,
            width: 100,
            height: 50,
            duration_seconds: 0.1,
            background: "#ffffff",
            fixed: vec![Shape::Rect {
                x: 0.0,
                y: 40.0,
                w: 100.0,
                h: 2.0,
                color: "#000000",
            }],
            frames: vec![vec![Shape::Ellipse {
                cx: 50.0,
                cy: 30.0,
                rx: 10.0,
                ry: 10.0,
                color: "#ff0000",
            }]],
            ball: None,
        };
        let mut r = Rasteriser::new(&animation).unwrap();
        let px = r.frame(&animation, 0).to_vec();
        let at = |x: usize, y: usize| &px[(y * 100 + x) * 4..][..3];
        assert_eq!(at(50, 30), [255, 0, 0], "the ball's centre");
        assert_eq!(at(50, 21), [255, 0, 0], "inside its top");
        assert_eq!(at(50, 18), [255, 255, 255], "above it");
        assert_eq!(at(5, 40), [0, 0, 0], "the floor");
        assert_eq!(at(5, 43), [255, 255, 255], "under the floor");
    }

    #[test]
    fn colours_are_read_from_hex() {
        assert_eq!(rgb("#2f64d8"), [0x2f, 0x64, 0xd8]);
        assert_eq!(rgb("red"), [0, 0, 0]);
    }
}
