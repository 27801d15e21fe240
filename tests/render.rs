//! `onomato render` end to end: the page it writes is opened in a real headless Chromium
//! (Debian's `chromium`), which draws a still of chosen moments (`#t=SECONDS`); the
//! screenshots are read back as pixels and the ball is looked for in them.

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_onomato");

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn onomato(args: &[&str]) -> std::process::Output {
    Command::new(BIN)
        .args(args)
        .current_dir(root())
        .output()
        .expect("run onomato")
}

/// RGB pixels of a PNG: (width, height, rows of 3 bytes per pixel).
fn read_png(path: &Path) -> (usize, usize, Vec<u8>) {
    let file = std::io::BufReader::new(fs::File::open(path).expect("screenshot"));
    let mut reader = png::Decoder::new(file).read_info().expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size().expect("PNG size")];
    let info = reader.next_frame(&mut buf).expect("PNG pixels");
    let channels = info.line_size / info.width as usize;
    let mut rgb = Vec::with_capacity(info.width as usize * info.height as usize * 3);
    for row in buf[..info.line_size * info.height as usize].chunks(info.line_size) {
        for px in row.chunks(channels) {
            rgb.extend_from_slice(&px[..3]);
        }
    }
    (info.width as usize, info.height as usize, rgb)
}

/// Chromium draws `page` at time `t` (a still) into a screenshot of `size`.
fn still(page: &Path, t: f64, size: (u32, u32), dir: &Path) -> (usize, usize, Vec<u8>) {
    let shot = dir.join(format!("still-{t:.3}.png"));
    let profile = dir.join("chromium-profile");
    let out = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=3000",
            &format!("--user-data-dir={}", profile.display()),
            &format!("--window-size={},{}", size.0, size.1),
            &format!("--screenshot={}", shot.display()),
            &format!("file://{}#t={t}", page.display()),
        ])
        .output()
        .expect("chromium (Debian's package chromium) must be installed: bash scripts/test.sh installs it");
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && shot.exists(),
        "chromium failed: {log}"
    );
    for line in log.lines().filter(|l| l.contains("CONSOLE")) {
        assert!(
            !line.contains("Uncaught"),
            "the page raised an error: {line}"
        );
    }
    read_png(&shot)
}

/// Rows (top, bottom) and columns (left, right) of the pixels of the ball's colour.
fn ball_box(
    image: &(usize, usize, Vec<u8>),
    color: [u8; 3],
) -> Option<(usize, usize, usize, usize)> {
    ball_box_within(image, color, 12)
}

/// The same, for pixels within `tolerance` of the colour in every channel.
fn ball_box_within(
    image: &(usize, usize, Vec<u8>),
    color: [u8; 3],
    tolerance: u8,
) -> Option<(usize, usize, usize, usize)> {
    let (w, h, px) = image;
    let mut found: Option<(usize, usize, usize, usize)> = None;
    for y in 0..*h {
        for x in 0..*w {
            let p = &px[(y * w + x) * 3..][..3];
            let near = p.iter().zip(color).all(|(a, b)| a.abs_diff(b) <= tolerance);
            if near {
                found = Some(match found {
                    None => (y, y, x, x),
                    Some((t, b, l, r)) => (t.min(y), b.max(y), l.min(x), r.max(x)),
                });
            }
        }
    }
    found
}

const BLUE: [u8; 3] = [0x2f, 0x64, 0xd8];
const RED: [u8; 3] = [0xd8, 0x3a, 0x34];

/// The ball geometry the page carries.
fn geometry(page: &Path) -> (f64, f64, f64) {
    let html = fs::read_to_string(page).unwrap();
    let json = html
        .split("type=\"application/json\">")
        .nth(1)
        .and_then(|j| j.split("</script>").next())
        .expect("frames in the page");
    let v: serde_json::Value = serde_json::from_str(json).unwrap();
    let b = &v["ball"];
    (
        b["floor_y"].as_f64().unwrap(),
        b["radius"].as_f64().unwrap(),
        b["scale"].as_f64().unwrap(),
    )
}

/// Renders the bundled example's ball scene at 50 fps, 640x360, to `out` (.html or
/// .mp4).
fn render_example(out: &Path) {
    let out = onomato(&[
        "render",
        "examples/beat.wav",
        "-c",
        "config/onomato.toml",
        "--scene",
        "ball",
        "--fps",
        "50",
        "--size",
        "640x360",
        "-o",
        &out.to_string_lossy(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The bounce solver's hard contacts in the bundled example (`analyze --bounce`).
fn example_hard_contacts() -> Vec<serde_json::Value> {
    let solved = onomato(&[
        "analyze",
        "examples/beat.wav",
        "-c",
        "config/onomato.toml",
        "--bounce",
    ]);
    assert!(solved.status.success());
    let solved: serde_json::Value = serde_json::from_slice(&solved.stdout).unwrap();
    solved["bounce"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["style"] == "hard")
        .cloned()
        .collect()
}

#[test]
fn the_ball_page_shows_the_ball_on_the_floor_at_each_hit_and_at_the_solvers_apex_between() {
    let dir = common::temp_dir("render-ball");
    let page = dir.join("beat.html");
    render_example(&page);
    // The solver's contacts for the same recording and config.
    let hard = example_hard_contacts();
    assert!(hard.len() >= 4, "{hard:?}");
    let (floor_y, radius, scale) = geometry(&page);
    // Four hits and the flights after them: on the floor at the hit's frame, at the
    // apex height (to 2 px) at the frame half-way to the next contact.
    for c in hard.iter().take(4) {
        let time = c["time"].as_f64().unwrap();
        let image = still(&page, time, (640, 360), &dir);
        let (top, bottom, left, right) =
            ball_box(&image, BLUE).unwrap_or_else(|| panic!("no blue ball at {time}"));
        assert!(
            (bottom as f64 + 1.0 - floor_y).abs() <= 1.0,
            "at the hit {time} the ball's lowest row is {bottom}, the floor {floor_y}"
        );
        assert!(((bottom - top + 1) as f64 - 2.0 * radius).abs() <= 2.0);
        assert!(((right - left + 1) as f64 - 2.0 * radius).abs() <= 2.0);
        let (Some(apex_time), apex) = (c["apex_time"].as_f64(), c["apex_height"].as_f64().unwrap())
        else {
            continue;
        };
        // The frame nearest the apex: its own time's height.
        let frame_time = (apex_time * 50.0).round() / 50.0;
        let v0 = c["launch_velocity"].as_f64().unwrap();
        let dt = frame_time - time;
        let height = v0 * dt - 9.81 * dt * dt / 2.0;
        assert!(apex - height < 0.01);
        let image = still(&page, frame_time, (640, 360), &dir);
        let (_, bottom, _, _) =
            ball_box(&image, BLUE).unwrap_or_else(|| panic!("no ball at {frame_time}"));
        let drawn = floor_y - (bottom as f64 + 1.0);
        assert!(
            (drawn - height * scale).abs() <= 2.0,
            "at the apex {frame_time} the ball is {drawn:.1} px up, the solver says {:.1}",
            height * scale
        );
        assert!(drawn > 10.0, "the ball is in the air: {drawn:.1} px");
    }
}

#[test]
fn an_edited_events_file_is_rendered_with_its_own_timing_and_a_soft_bounce_is_squashed() {
    let dir = common::temp_dir("render-events");
    let events = dir.join("events.json");
    // Hand-made timing: a hit at 0.5 s, a soft one at 1.3 s (strength 1: the config's
    // [bounce] marks it soft), a hit at 2.0 s.
    fs::write(
        &events,
        r#"{"events": [
            {"pattern": "tick", "kind": "impulse", "time": 0.5, "strength": 1.0},
            {"pattern": "pop", "kind": "impulse", "time": 1.3, "strength": 1.0},
            {"pattern": "tick", "kind": "impulse", "time": 2.0, "strength": 0.8}
        ]}"#,
    )
    .unwrap();
    let config = dir.join("soft.toml");
    fs::write(
        &config,
        "[[pattern]]\nname = \"tick\"\ntakes = [\"PATTERNS/tick.wav\"]\n\n[[pattern]]\nname = \"pop\"\ntakes = [\"PATTERNS/pop.wav\"]\n\n[bounce]\nhard = [\"tick\"]\nsoft = [\"pop\"]\n"
            .replace("PATTERNS", &root().join("examples/patterns").to_string_lossy()),
    )
    .unwrap();
    let page = dir.join("edited.html");
    let out = onomato(&[
        "render",
        "examples/beat.wav",
        "--events",
        &events.to_string_lossy(),
        "-c",
        &config.to_string_lossy(),
        "--fps",
        "50",
        "--size",
        "640x360",
        "-o",
        &page.to_string_lossy(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (floor_y, radius, _) = geometry(&page);
    for t in [0.5, 2.0] {
        let (_, bottom, _, _) = ball_box(&still(&page, t, (640, 360), &dir), BLUE).expect("ball");
        assert!(
            (bottom as f64 + 1.0 - floor_y).abs() <= 1.0,
            "not on the floor at {t}"
        );
    }
    // Between the edited hits the ball is in the air.
    let (_, bottom, _, _) = ball_box(&still(&page, 0.9, (640, 360), &dir), BLUE).expect("ball");
    assert!(floor_y - (bottom as f64 + 1.0) > 30.0);
    // The soft bounce: red, on the floor, squashed by 0.4 × strength, its area kept.
    let (top, bottom, left, right) =
        ball_box(&still(&page, 1.3, (640, 360), &dir), RED).expect("red ball");
    let (w, h) = ((right - left + 1) as f64, (bottom - top + 1) as f64);
    let squash = 0.4;
    assert!((bottom as f64 + 1.0 - floor_y).abs() <= 1.0);
    assert!(
        (h - 2.0 * radius * (1.0 - squash)).abs() <= 2.0,
        "height {h}"
    );
    assert!(
        (w - 2.0 * radius / (1.0 - squash)).abs() <= 2.0,
        "width {w}"
    );
}

#[test]
fn bad_render_requests_name_the_item_and_leave_nothing_behind() {
    let dir = common::temp_dir("render-bad");
    let cases: [(&[&str], &str); 5] = [
        (&["--scene", "fireworks", "-o", "x.html"], "fireworks"),
        (&["--fps", "0", "-o", "x.html"], "--fps"),
        (&["-o", "x.avi"], "x.avi"),
        (&["--size", "640by360", "-o", "x.html"], "640by360"),
        (&["-o", "no/such/dir/x.html"], "no/such/dir/x.html"),
    ];
    // Run from the project's root so that the config resolves; outputs go to `dir`.
    for (extra, named) in cases {
        let mut args: Vec<String> = ["render", "examples/beat.wav", "-c", "config/onomato.toml"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        for a in extra {
            args.push(if a.ends_with(".html") || a.ends_with(".avi") {
                dir.join(a).to_string_lossy().into_owned()
            } else {
                a.to_string()
            });
        }
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = onomato(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(
            err.contains(named),
            "{args:?}: the error does not name '{named}': {err}"
        );
    }
    let left: Vec<_> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
    // An events file with a bad event names the file and the event.
    let events = dir.join("bad.json");
    fs::write(
        &events,
        r#"{"events": [{"pattern": "tick", "kind": "impulse", "time": -1}]}"#,
    )
    .unwrap();
    let out = onomato(&[
        "render",
        "examples/beat.wav",
        "--events",
        &events.to_string_lossy(),
        "-o",
        &dir.join("y.html").to_string_lossy(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("bad.json") && err.contains("event 0"),
        "{err}"
    );
    assert!(!dir.join("y.html").exists());
}

/// Frame `k` of a video, decoded by ffmpeg.
fn video_frame(video: &Path, k: usize, dir: &Path) -> (usize, usize, Vec<u8>) {
    let png = dir.join(format!("frame-{k}.png"));
    let ok = Command::new("ffmpeg")
        .args(["-v", "error", "-y", "-i"])
        .arg(video)
        .args(["-vf", &format!("select=eq(n\\,{k})"), "-vframes", "1"])
        .arg(&png)
        .status()
        .expect("ffmpeg (Debian's package ffmpeg)")
        .success();
    assert!(ok && png.exists(), "no frame {k}");
    read_png(&png)
}

#[test]
fn the_ball_video_has_the_sound_the_frame_rate_and_the_ball_where_the_solver_puts_it() {
    let dir = common::temp_dir("render-video");
    let (video, page) = (dir.join("beat.mp4"), dir.join("beat.html"));
    render_example(&video);
    render_example(&page);
    let probe = Command::new("ffprobe")
        .args(["-v", "error", "-show_entries"])
        .args([
            "stream=codec_type,width,height,r_frame_rate:format=duration",
            "-of",
            "json",
        ])
        .arg(&video)
        .output()
        .expect("ffprobe");
    let probe: serde_json::Value = serde_json::from_slice(&probe.stdout).unwrap();
    let streams = probe["streams"].as_array().unwrap();
    let of = |kind: &str| {
        streams
            .iter()
            .filter(|s| s["codec_type"] == kind)
            .collect::<Vec<_>>()
    };
    let (pictures, sounds) = (of("video"), of("audio"));
    assert_eq!((pictures.len(), sounds.len()), (1, 1), "{probe}");
    assert_eq!(
        (
            pictures[0]["width"].as_u64(),
            pictures[0]["height"].as_u64()
        ),
        (Some(640), Some(360))
    );
    assert_eq!(pictures[0]["r_frame_rate"], "50/1");
    let duration: f64 = probe["format"]["duration"]
        .as_str()
        .unwrap()
        .parse()
        .unwrap();
    // beat.wav lasts 10 s: frames 0 to 500.
    assert!(
        (duration - 10.0).abs() <= 1.0 / 50.0 + 0.005,
        "{duration} s"
    );

    let (floor_y, _, scale) = geometry(&page);
    let hard = example_hard_contacts();
    // The encoder blurs colours at edges (4:2:0): the ball's colour within 40.
    for c in hard.iter().take(3) {
        let time = c["time"].as_f64().unwrap();
        let k = (time * 50.0).round() as usize;
        let (_, bottom, _, _) = ball_box_within(&video_frame(&video, k, &dir), BLUE, 40)
            .unwrap_or_else(|| panic!("no ball in frame {k}"));
        assert!(
            (bottom as f64 + 1.0 - floor_y).abs() <= 2.0,
            "frame {k} (hit at {time}): lowest row {bottom}, floor {floor_y}"
        );
        let Some(apex_time) = c["apex_time"].as_f64() else {
            continue;
        };
        let k = (apex_time * 50.0).round() as usize;
        let dt = k as f64 / 50.0 - time;
        let height = c["launch_velocity"].as_f64().unwrap() * dt - 9.81 * dt * dt / 2.0;
        let (_, bottom, _, _) = ball_box_within(&video_frame(&video, k, &dir), BLUE, 40)
            .unwrap_or_else(|| panic!("no ball in frame {k}"));
        let drawn = floor_y - (bottom as f64 + 1.0);
        assert!(
            (drawn - height * scale).abs() <= 2.0,
            "frame {k}: {drawn:.1} px up, the solver says {:.1}",
            height * scale
        );
    }
}

#[test]
fn without_ffmpeg_an_mp4_is_refused_by_name_and_nothing_is_left() {
    let dir = common::temp_dir("render-no-ffmpeg");
    let empty = dir.join("empty-path");
    fs::create_dir_all(&empty).unwrap();
    let out = Command::new(BIN)
        .args([
            "render",
            "examples/beat.wav",
            "-c",
            "config/onomato.toml",
            "-o",
        ])
        .arg(dir.join("x.mp4"))
        .current_dir(root())
        .env("PATH", &empty)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("ffmpeg") && err.contains("x.mp4"),
        "{err}"
    );
    let left: Vec<_> = fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left, vec![std::ffi::OsString::from("empty-path")]);
}

/// The placed onsets of one label in a soundtrack of the duel example (its truth CSV).
fn duel_times(track: &str, label: &str) -> Vec<f64> {
    fs::read_to_string(root().join(format!("examples/duel/{track}.truth.csv")))
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| l.split(',').nth(1) == Some(label))
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect()
}

/// Root mean square of the video's sound from `from` to `to` seconds (ffmpeg decodes it).
fn sound_rms(video: &Path, from: f64, to: f64) -> f64 {
    let out = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(video)
        .args(["-ss", &from.to_string(), "-t", &(to - from).to_string()])
        .args(["-vn", "-ac", "1", "-f", "f32le", "-"])
        .output()
        .expect("ffmpeg");
    let samples: Vec<f32> = out
        .stdout
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    assert!(!samples.is_empty(), "no sound from {from} to {to}");
    (samples.iter().map(|s| f64::from(*s).powi(2)).sum::<f64>() / samples.len() as f64).sqrt()
}

#[test]
fn the_duel_video_shoots_with_one_soundtrack_and_moves_the_runner_with_the_other() {
    let dir = common::temp_dir("render-duel");
    let video = dir.join("duel.mp4");
    let out = onomato(&[
        "render",
        "examples/duel/shots.wav",
        "--track",
        "examples/duel/moves.wav",
        "-c",
        "config/duel.toml",
        "--fps",
        "50",
        "--size",
        "640x360",
        "-o",
        &video.to_string_lossy(),
    ]);
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{log}");
    assert!(log.contains("laser scene, 14 events"), "{log}");
    // Both soundtracks are heard: each one's sound where only it sounds, well above
    // where neither does.
    let quiet = sound_rms(&video, 7.3, 7.9);
    let whoo = sound_rms(&video, 1.75, 2.0);
    let pew = sound_rms(&video, 2.6, 2.75);
    assert!(
        whoo > 10.0 * quiet && pew > 10.0 * quiet,
        "{whoo} {pew} {quiet}"
    );
    // The colours of the two soundtracks; the encoder blurs them at edges (within 40).
    const RED_TRACK: [u8; 3] = RED;
    let ground = (360.0_f64 * 0.8).round();
    let cannon = 640.0 * 0.9;
    let frame = |t: f64| video_frame(&video, (t * 50.0).round() as usize, &dir);
    for t in duel_times("shots", "pew") {
        // Fired low at its frame: a blue beam at the cannon's mouth, near the ground.
        let (top, bottom, left, _) =
            ball_box_within(&frame(t), BLUE, 40).unwrap_or_else(|| panic!("no shot at {t}"));
        assert!(
            (left as f64 - cannon).abs() <= 2.0,
            "shot at x {left} at {t}"
        );
        assert!(
            ground - (bottom as f64) < 20.0 && bottom > top,
            "low: rows {top}-{bottom}"
        );
    }
    for t in duel_times("moves", "hup") {
        // Up in the air a quarter of a second after the jump begins, in the runner's
        // soundtrack's colour.
        let (_, bottom, _, _) = ball_box_within(&frame(t + 0.24), RED_TRACK, 40)
            .unwrap_or_else(|| panic!("no runner at {t}"));
        assert!(
            ground - (bottom as f64 + 1.0) > 50.0,
            "jump at {t}: feet at {bottom}"
        );
    }
    for t in duel_times("moves", "whoo") {
        // Flat on the ground while the held sound lasts.
        let (top, bottom, left, right) = ball_box_within(&frame(t + 0.2), RED_TRACK, 40)
            .unwrap_or_else(|| panic!("no runner at {t}"));
        assert!(
            right - left > 2 * (bottom - top),
            "slide at {t}: {}x{}",
            right - left,
            bottom - top
        );
    }
}

#[test]
fn the_rain_and_timeline_pages_draw_each_event_at_its_time() {
    let dir = common::temp_dir("render-pages");
    let (rain, strip) = (dir.join("rain.html"), dir.join("timeline.html"));
    for (scene, page) in [("rain", &rain), ("timeline", &strip)] {
        let out = onomato(&[
            "render",
            "examples/beat.wav",
            "-c",
            "config/onomato.toml",
            "--scene",
            scene,
            "--fps",
            "50",
            "--size",
            "640x360",
            "-o",
            &page.to_string_lossy(),
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let hard = example_hard_contacts();
    // Rain: each of the first two drops touches the ground (its full colour within 3
    // rows above it: the lowest row of an ellipse is only partly covered) at its
    // event's frame, and no drop does 0.15 s before.
    let ground = (360.0_f64 * 0.85).round() as usize;
    let touching = |image: &(usize, usize, Vec<u8>)| {
        let (w, _, px) = image;
        (ground - 3..ground).any(|y| {
            (0..*w).any(|x| {
                let p = &px[(y * w + x) * 3..][..3];
                p.iter().zip(BLUE).all(|(a, b)| a.abs_diff(b) <= 12)
            })
        })
    };
    for c in hard.iter().take(2) {
        let t = c["time"].as_f64().unwrap();
        assert!(
            touching(&still(&rain, t, (640, 360), &dir)),
            "no drop lands at {t}"
        );
        let before = still(&rain, t - 0.15, (640, 360), &dir);
        assert!(
            ball_box(&before, BLUE).is_some(),
            "no drop falling before {t}"
        );
        assert!(!touching(&before), "a drop on the ground before {t}");
    }
    // Timeline: the playhead (the only ink this high) at the time's place, and the
    // first event's bar at its own.
    let margin = 640.0 * 0.04;
    let x_of = |t: f64| margin + t / 10.0 * (640.0 - 2.0 * margin);
    for t in [2.0, 7.5] {
        let (w, _, px) = still(&strip, t, (640, 360), &dir);
        let row = (360.0 * 0.12) as usize;
        let ink: Vec<usize> = (0..w)
            .filter(|x| px[(row * w + x) * 3..][..3].iter().all(|c| *c < 0x50))
            .collect();
        assert!(!ink.is_empty(), "no playhead at {t}");
        let centre = (ink[0] + ink[ink.len() - 1]) as f64 / 2.0;
        assert!(
            (centre - x_of(t)).abs() <= 2.0,
            "playhead at {centre}, expected {}",
            x_of(t)
        );
    }
    let first = hard[0]["time"].as_f64().unwrap();
    let image = still(&strip, 0.0, (640, 360), &dir);
    let (_, _, left, _) = ball_box(&image, BLUE).expect("the first pattern's bars");
    assert!(
        (left as f64 - x_of(first)).abs() <= 2.0,
        "first bar at {left}"
    );
}

#[test]
fn render_settings_that_cannot_be_done_are_refused_by_name() {
    let dir = common::temp_dir("render-settings");
    let patterns = root().join("examples/patterns");
    let config = dir.join("darts.toml");
    fs::write(
        &config,
        format!(
            "[[pattern]]\nname = \"hoo\"\nkind = \"continuous\"\ntakes = [\"{}/hoo.wav\"]\n\n[render]\ndarts = {{ hoo = \"throw\" }}\n",
            patterns.display()
        ),
    )
    .unwrap();
    let out_page = dir.join("x.html");
    let run = |args: &[&str]| {
        let out = onomato(args);
        assert!(!out.status.success(), "{args:?} succeeded");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let page = out_page.to_string_lossy();
    let err = run(&[
        "render",
        "examples/beat.wav",
        "-c",
        &config.to_string_lossy(),
        "-o",
        &page,
    ]);
    assert!(
        err.contains("darts.toml")
            && err.contains("[render]")
            && err.contains("'hoo' cannot throw"),
        "{err}"
    );
    let err = run(&[
        "render",
        "examples/duel/shots.wav",
        "--track",
        "examples/duel/moves.wav",
        "--track",
        "examples/beat.wav",
        "-c",
        "config/duel.toml",
        "-o",
        &page,
    ]);
    assert!(
        err.contains("duel.toml")
            && err.contains("2 [[render.track]]")
            && err.contains("3 soundtracks"),
        "{err}"
    );
    let err = run(&[
        "render",
        "examples/duel/shots.wav",
        "--track",
        "examples/duel/moves.wav",
        "--events",
        "x.json",
        "-o",
        &page,
    ]);
    assert!(
        err.contains("--events given 1 times for 2 soundtracks"),
        "{err}"
    );
    assert!(!out_page.exists());
}
