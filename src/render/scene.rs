//! The scenes of `onomato render`: each turns the soundtracks' events into the shapes of
//! every frame ([`Animation`]), following [`Actions`] (which pattern does what). Several
//! soundtracks each get their own colour and, where the scene has one actor per
//! soundtrack, their own lane.
//!
//! Runs on the main thread; allocates freely (offline).

use crate::config::{ContactStyle, DartsAction, LaserAction, PatternKind};
use crate::detect::Event;
use crate::solver::{self, Contact, Trajectory};

use super::{Actions, Animation, BallGeometry, FrameSettings, Shape};

pub(super) const INK: &str = "#2b2b2b";
const GREY: &str = "#8a8a8a";
/// Hard bounce, soft bounce, slide: blue, red, green as in the paper's figure.
const HARD: &str = "#2f64d8";
const SOFT: &str = "#d83a34";
const SLIDE: &str = "#2f9a4a";
/// Colours of soundtracks (and of patterns on a one-soundtrack timeline), in order.
const PALETTE: [&str; 6] = [HARD, SOFT, SLIDE, "#c47f12", "#7b3fb5", "#1b8f9a"];

/// The colour of soundtrack `i`.
pub fn track_color(i: usize) -> &'static str {
    PALETTE[i % PALETTE.len()]
}

/// The ground from row `y` to the bottom of a `w` × `h` frame.
fn ground_below(y: f32, w: f32, h: f32) -> Shape {
    Shape::Rect {
        x: 0.0,
        y,
        w,
        h: h - y,
        color: "#c9c2b3",
    }
}

/// Time of frame `k`.
fn time_of(frames: FrameSettings, k: usize) -> f64 {
    k as f64 / f64::from(frames.fps)
}

/// The ball scene: one ball per soundtrack, side by side on one floor. Heights are the
/// solver's, scaled so that the highest flight fits in the frame; a ball's x moves only
/// while it slides. One soundtrack's ball takes the colour of its last contact's style
/// (the paper's figure); several balls take their soundtrack's colour.
pub(super) fn ball(
    animation: &mut Animation,
    tracks: &[Vec<Event>],
    actions: &Actions,
    frames: FrameSettings,
    count: usize,
) {
    let bounce = &actions.bounce;
    let (w, h) = (frames.width as f32, frames.height as f32);
    let solved: Vec<Vec<Contact>> = tracks.iter().map(|e| solver::solve(e, bounce)).collect();
    let radius = (h * 0.045).max(3.0);
    let floor_y = (h * 0.85).round();
    let highest = solved
        .iter()
        .flatten()
        .map(|c| c.apex_height)
        .fold(0.0_f64, f64::max);
    let room = f64::from(floor_y - 2.0 * radius - h * 0.08).max(1.0);
    let scale = if highest > 0.0 { room / highest } else { 1.0 } as f32;
    animation.ball = Some(BallGeometry {
        floor_y,
        radius,
        scale,
    });
    animation.fixed.push(Shape::Rect {
        x: 0.0,
        y: floor_y,
        w,
        h: (h * 0.006).max(2.0),
        color: INK,
    });
    let lane_w = f64::from(w) / solved.len().max(1) as f64;
    let several = solved.len() > 1;
    // The frame of each contact: there the ball is on the floor whatever the frame's
    // own time, so that a hit is seen where it is heard.
    let contact_frames: Vec<Vec<usize>> = solved
        .iter()
        .map(|cs| cs.iter().map(|c| frames.frame_of(c.time)).collect())
        .collect();
    for k in 0..count {
        let t = time_of(frames, k);
        let mut balls = Vec::with_capacity(solved.len());
        let mut labels = Vec::new();
        for (i, contacts) in solved.iter().enumerate() {
            let trajectory = Trajectory {
                gravity: bounce.gravity,
                contacts,
            };
            let on_contact = contact_frames[i].iter().position(|&f| f == k);
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
            let (left, span) = (lane_w * (i as f64 + 0.15), lane_w * 0.7);
            let cx = (left + (slid * lane_w * 0.25) % span) as f32;
            let last = on_contact
                .map(|c| &contacts[c])
                .or_else(|| contacts.iter().rev().find(|c| c.time <= t));
            let color = match last.map(|c| c.style) {
                _ if several => track_color(i),
                None => GREY,
                Some(ContactStyle::Hard) => HARD,
                Some(ContactStyle::Soft) => SOFT,
                Some(ContactStyle::Slide) => SLIDE,
            };
            // A soft bounce's frame squashes the ball, its area kept.
            let squash = on_contact.map_or(0.0, |c| contacts[c].squash) as f32;
            let (rx, ry) = (radius / (1.0 - squash), radius * (1.0 - squash));
            let bottom = floor_y - height as f32 * scale;
            balls.push(Shape::Ellipse {
                cx,
                cy: bottom - ry,
                rx,
                ry,
                color,
            });
            if let Some(c) = last.filter(|c| t - c.time < 0.4) {
                labels.push(Shape::Text {
                    x: (lane_w * i as f64) as f32 + radius,
                    y: radius * 2.0,
                    size: radius * 1.2,
                    text: format!("{}  {:.2}", c.pattern, c.strength),
                    color: if several { track_color(i) } else { INK },
                });
            }
        }
        balls.append(&mut labels);
        animation.frames.push(balls);
    }
}

/// How long a drop falls, seconds: long enough to be seen, short enough that drops of
/// a quick rhythm do not pile up.
const RAIN_FALL_SECONDS: f64 = 0.6;
/// How long a splash stays, seconds.
const RAIN_SPLASH_SECONDS: f64 = 0.25;

/// A place in [0, 1) for `key`, the same on every run (SplitMix64).
pub(super) fn place_of(key: u64) -> f64 {
    let mut z = key.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// The rain scene: each event of a dropping pattern is a drop falling as a dropped
/// body does (distance growing with the square of time) from the top to the ground,
/// touching it at the event's time, then a splash; in its soundtrack's colour.
pub(super) fn rain(
    animation: &mut Animation,
    tracks: &[Vec<Event>],
    actions: &Actions,
    frames: FrameSettings,
    count: usize,
) {
    let (w, h) = (frames.width as f32, frames.height as f32);
    let ground = (h * 0.85).round();
    let top = h * 0.05;
    let unit = (h * 0.02).max(2.0);
    animation.fixed.push(ground_below(ground, w, h));
    let drops: Vec<(f64, f32, f32, &'static str)> = tracks
        .iter()
        .enumerate()
        .flat_map(|(i, events)| events.iter().map(move |e| (i, e)))
        .filter(|(_, e)| actions.rain.contains(&*e.pattern))
        .map(|(i, e)| {
            // Each soundtrack's ids count from 0: the track keeps their places apart.
            let x = w * (0.05 + 0.9 * place_of(e.id ^ ((i as u64) << 40)) as f32);
            let size = unit * (0.5 + e.strength.clamp(0.0, 2.0) as f32);
            (e.time, x, size, track_color(i))
        })
        .collect();
    for k in 0..count {
        let t = time_of(frames, k);
        let mut shapes = Vec::new();
        for &(land, x, size, color) in &drops {
            let k_land = frames.frame_of(land);
            if k < k_land && t >= land - RAIN_FALL_SECONDS {
                let fallen = ((t - (land - RAIN_FALL_SECONDS)) / RAIN_FALL_SECONDS).powi(2) as f32;
                shapes.push(Shape::Ellipse {
                    cx: x,
                    cy: top + (ground - size * 1.5 - top) * fallen,
                    rx: size,
                    ry: size * 1.5,
                    color,
                });
            } else if k >= k_land && t < land + RAIN_SPLASH_SECONDS {
                // Touching the ground at its frame, then spreading flat.
                let spread = 1.0 + 3.0 * (time_of(frames, k - k_land) / RAIN_SPLASH_SECONDS) as f32;
                let ry = size * 1.5 / spread;
                shapes.push(Shape::Ellipse {
                    cx: x,
                    cy: ground - ry,
                    rx: size * spread,
                    ry,
                    color,
                });
            }
        }
        animation.frames.push(shapes);
    }
}

/// The timeline: one strip per soundtrack of its events (a bar as high as its strength;
/// a held sound as long as it lasts), seconds marked, and a playhead. One soundtrack's
/// patterns each get a colour; several soundtracks each get theirs.
pub(super) fn timeline(
    animation: &mut Animation,
    tracks: &[Vec<Event>],
    frames: FrameSettings,
    count: usize,
) {
    let (w, h) = (frames.width as f32, frames.height as f32);
    let margin = w * 0.04;
    let duration = animation.duration_seconds.max(1e-3);
    let x_of = |t: f64| margin + (t / duration) as f32 * (w - 2.0 * margin);
    let lane_h = h * 0.8 / tracks.len().max(1) as f32;
    let text = (lane_h * 0.045).clamp(8.0, h * 0.035).max(8.0);
    let fixed = &mut animation.fixed;
    let mut names: Vec<&str> = Vec::new();
    for (i, events) in tracks.iter().enumerate() {
        let base = h * 0.1 + lane_h * (i as f32 + 0.75);
        let tall = lane_h * 0.55;
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
        for e in events {
            let color = if tracks.len() > 1 {
                track_color(i)
            } else {
                let n = names
                    .iter()
                    .position(|n| **n == *e.pattern)
                    .unwrap_or_else(|| {
                        names.push(&e.pattern);
                        names.len() - 1
                    });
                PALETTE[n % PALETTE.len()]
            };
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
    }
    for k in 0..count {
        animation.frames.push(vec![Shape::Rect {
            x: x_of(time_of(frames, k)) - 1.0,
            y: h * 0.1,
            w: 2.0,
            h: h * 0.8,
            color: INK,
        }]);
    }
}

/// How long a dart flies from the ship to the board, seconds.
const DART_FLIGHT_SECONDS: f64 = 0.5;
/// How long a dart stays in the board, seconds.
const DART_STUCK_SECONDS: f64 = 0.6;
/// How far a held sound moves the ship in a second, as a fraction of its lane.
const SHIP_SPEED_LANES_PER_SECOND: f64 = 0.5;

/// Where the ship of the darts scene is over a soundtrack: its height in every frame.
/// It moves only while an "up" or "down" sound is held, by the time the frame's
/// interval shares with that sound, and stays within its lane.
pub(super) fn ship_heights(
    events: &[Event],
    actions: &Actions,
    frames: FrameSettings,
    count: usize,
    (lowest, highest): (f64, f64),
    speed: f64,
) -> Vec<f64> {
    let spans: Vec<(f64, f64, f64)> = events
        .iter()
        .filter_map(|e| {
            let sign = match actions.darts.get(&*e.pattern)? {
                DartsAction::Up => 1.0,
                DartsAction::Down => -1.0,
                DartsAction::Throw => return None,
            };
            Some((e.time, e.end.unwrap_or(f64::INFINITY), sign))
        })
        .collect();
    let mut y = (lowest + highest) / 2.0;
    let mut heights = Vec::with_capacity(count);
    for k in 0..count {
        if k > 0 {
            let (a, b) = (time_of(frames, k - 1), time_of(frames, k));
            let moved: f64 = spans
                .iter()
                .map(|&(begin, end, sign)| sign * (b.min(end) - a.max(begin)).max(0.0))
                .sum();
            y = (y + moved * speed).clamp(lowest, highest);
        }
        heights.push(y);
    }
    heights
}

/// The darts scene (the paper's spaceship): one ship per soundtrack at the left of its
/// lane; a held "up" or "down" sound moves it for exactly its span; each throw sends a
/// dart, as long as the throw is strong, from the ship's nose to the board at the
/// right, where it stays a moment.
pub(super) fn darts(
    animation: &mut Animation,
    tracks: &[Vec<Event>],
    actions: &Actions,
    frames: FrameSettings,
    count: usize,
) {
    let (w, h) = (frames.width as f32, frames.height as f32);
    let lane_h = h / tracks.len().max(1) as f32;
    let ship = (lane_h * 0.08).max(4.0);
    let ship_x = w * 0.06;
    let nose = ship_x + ship * 1.6;
    let board_x = w * 0.9;
    for i in 0..tracks.len() {
        animation.fixed.push(Shape::Rect {
            x: board_x,
            y: lane_h * i as f32 + lane_h * 0.05,
            w: w * 0.02,
            h: lane_h * 0.9,
            color: "#b89b72",
        });
    }
    let mut lanes = Vec::with_capacity(tracks.len());
    for (i, events) in tracks.iter().enumerate() {
        let top = f64::from(lane_h) * i as f64;
        // Heights from the lane's bottom, kept a ship's size inside it.
        let room = (f64::from(ship), f64::from(lane_h - ship));
        let speed = f64::from(lane_h) * SHIP_SPEED_LANES_PER_SECOND;
        let heights = ship_heights(events, actions, frames, count, room, speed);
        let throws: Vec<(f64, f32, f32)> = events
            .iter()
            .filter(|e| actions.darts.get(&*e.pattern) == Some(&DartsAction::Throw))
            .map(|e| {
                let k = frames.frame_of(e.time).min(count - 1);
                let y = (top + f64::from(lane_h) - heights[k]) as f32;
                (e.time, y, dart_length(ship, e.strength))
            })
            .collect();
        lanes.push((top, heights, throws));
    }
    for k in 0..count {
        let t = time_of(frames, k);
        let mut shapes = Vec::new();
        for (i, (top, heights, throws)) in lanes.iter().enumerate() {
            let color = track_color(i);
            let y = (top + f64::from(lane_h) - heights[k]) as f32;
            shapes.push(Shape::Polygon {
                points: vec![
                    [ship_x, y - ship * 0.6],
                    [ship_x + ship * 1.6, y],
                    [ship_x, y + ship * 0.6],
                ],
                color,
            });
            for &(thrown, dart_y, length) in throws {
                if k < frames.frame_of(thrown)
                    || t > thrown + DART_FLIGHT_SECONDS + DART_STUCK_SECONDS
                {
                    continue;
                }
                let flown = ((t - thrown) / DART_FLIGHT_SECONDS).clamp(0.0, 1.0) as f32;
                let tip = nose + (board_x - nose) * flown;
                let half = length * 0.12;
                shapes.push(Shape::Polygon {
                    points: vec![
                        [tip, dart_y],
                        [tip - length, dart_y - half],
                        [tip - length * 0.85, dart_y],
                        [tip - length, dart_y + half],
                    ],
                    color,
                });
            }
        }
        animation.frames.push(shapes);
    }
}

/// A dart's length, pixels: linear in the throw's strength (up to twice an enrolled
/// take's), four ship sizes at strength 1.
pub(super) fn dart_length(ship: f32, strength: f64) -> f32 {
    ship * 4.0 * strength.clamp(0.0, 2.0) as f32
}

/// How long a shot takes from the cannon to the runner, seconds.
const SHOT_SECONDS: f64 = 0.4;
/// How long a jump lasts, seconds.
const JUMP_SECONDS: f64 = 0.5;

/// The laser scene (the paper's): a cannon at the right fires shots low (at the
/// runner's feet) or high (at its head), each leaving the cannon at its event's time;
/// a runner at the left jumps (leaving the ground at its event's time) or slides flat
/// for exactly a held sound's span. A shot takes its soundtrack's colour, the runner
/// the colour of the soundtrack that last moved it.
pub(super) fn laser(
    animation: &mut Animation,
    tracks: &[Vec<Event>],
    actions: &Actions,
    frames: FrameSettings,
    count: usize,
) {
    let (w, h) = (frames.width as f32, frames.height as f32);
    let ground = (h * 0.8).round();
    let runner_x = w * 0.22;
    let body = (h * 0.14, h * 0.035);
    let head = h * 0.03;
    let cannon_x = w * 0.9;
    let (low, high) = (ground - h * 0.035, ground - h * 0.13);
    let beam = (w * 0.06, (h * 0.008).max(2.0));
    let shot_speed = f64::from(cannon_x - runner_x) / SHOT_SECONDS;
    animation.fixed.push(ground_below(ground, w, h));
    animation.fixed.push(Shape::Rect {
        x: cannon_x,
        y: high - h * 0.04,
        w: w * 0.05,
        h: ground - high + h * 0.04,
        color: INK,
    });
    let mut shots = Vec::new();
    let mut jumps = Vec::new();
    let mut slides = Vec::new();
    for (i, events) in tracks.iter().enumerate() {
        for e in events {
            match actions.laser.get(&*e.pattern) {
                Some(LaserAction::ShootLow) => shots.push((e.time, low, track_color(i))),
                Some(LaserAction::ShootHigh) => shots.push((e.time, high, track_color(i))),
                Some(LaserAction::Jump) => jumps.push((e.time, track_color(i))),
                Some(LaserAction::Slide) => {
                    slides.push((e.time, e.end.unwrap_or(f64::INFINITY), track_color(i)))
                }
                None => {}
            }
        }
    }
    for k in 0..count {
        let t = time_of(frames, k);
        let mut shapes = Vec::new();
        let sliding = slides
            .iter()
            .find(|&&(begin, end, _)| frames.frame_of(begin) <= k && t <= end);
        let jumping = jumps
            .iter()
            .find(|&&(at, _)| frames.frame_of(at) <= k && t < at + JUMP_SECONDS);
        // The colour of the last move begun.
        let color = jumps
            .iter()
            .copied()
            .chain(slides.iter().map(|&(at, _, c)| (at, c)))
            .filter(|&(at, _)| frames.frame_of(at) <= k)
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map_or(INK, |(_, c)| c);
        if sliding.is_some() {
            // Flat on the ground, head first, under a high shot.
            shapes.push(Shape::Rect {
                x: runner_x - body.0 / 2.0,
                y: ground - body.1,
                w: body.0,
                h: body.1,
                color,
            });
            shapes.push(Shape::Ellipse {
                cx: runner_x + body.0 / 2.0 + head,
                cy: ground - head,
                rx: head,
                ry: head,
                color,
            });
        } else {
            // Standing, or in the air: a jump rises and falls as a thrown body does.
            let lift = jumping.map_or(0.0, |&(at, _)| {
                let u = ((t - at) / JUMP_SECONDS).clamp(0.0, 1.0) as f32;
                4.0 * h * 0.22 * u * (1.0 - u)
            });
            let feet = ground - lift;
            shapes.push(Shape::Rect {
                x: runner_x - body.1 / 2.0,
                y: feet - body.0,
                w: body.1,
                h: body.0,
                color,
            });
            shapes.push(Shape::Ellipse {
                cx: runner_x,
                cy: feet - body.0 - head,
                rx: head,
                ry: head,
                color,
            });
        }
        for &(fired, y, color) in &shots {
            if k < frames.frame_of(fired) {
                continue;
            }
            let x = cannon_x - ((t - fired).max(0.0) * shot_speed) as f32;
            if x + beam.0 < 0.0 {
                continue;
            }
            shapes.push(Shape::Rect {
                x,
                y: y - beam.1 / 2.0,
                w: beam.0,
                h: beam.1,
                color,
            });
        }
        animation.frames.push(shapes);
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_events::{held, hit};
    use super::super::{animate, Scene};
    use super::*;
    use crate::config::{BounceSettings, RenderSettings};

    /// Actions from these patterns' kinds, the ball's styles as given.
    fn actions(patterns: &[(&str, PatternKind)], styles: &[(&str, ContactStyle)]) -> Actions {
        let bounce = BounceSettings {
            gravity: 9.81,
            styles: styles.iter().map(|(n, s)| (n.to_string(), *s)).collect(),
            max_squash: 0.4,
            default_interval_seconds: 0.5,
            state_delay_seconds: None,
        };
        let patterns: Vec<(String, PatternKind)> =
            patterns.iter().map(|(n, k)| (n.to_string(), *k)).collect();
        Actions::new(&RenderSettings::default(), Some(bounce), &patterns)
    }

    const FRAMES: FrameSettings = FrameSettings {
        fps: 50,
        width: 640,
        height: 360,
    };

    fn ellipse(shape: &Shape) -> (f32, f32, f32, f32) {
        match shape {
            Shape::Ellipse { cx, cy, rx, ry, .. } => (*cx, *cy, *rx, *ry),
            other => panic!("expected an ellipse, found {other:?}"),
        }
    }

    fn ball_of(frame: &[Shape]) -> (f32, f32, f32, f32) {
        ellipse(&frame[0])
    }

    #[test]
    fn the_ball_is_on_the_floor_at_each_hit_frame_and_at_the_apex_half_way() {
        let events = vec![
            hit(0, "tick", 0.5, 1.0),
            hit(1, "tick", 1.0, 1.0),
            hit(2, "tick", 1.73, 1.0),
        ];
        let acts = actions(&[], &[("tick", ContactStyle::Hard)]);
        let a = animate(
            Scene::Ball,
            std::slice::from_ref(&events),
            &acts,
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
        let events = vec![hit(0, "pop", 0.5, 0.5), hit(1, "pop", 1.0, 1.0)];
        let acts = actions(&[], &[("pop", ContactStyle::Soft)]);
        let a = animate(
            Scene::Ball,
            std::slice::from_ref(&events),
            &acts,
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
        let events = vec![held(0, "chhh", 0.5, 1.5), hit(1, "tick", 2.0, 1.0)];
        let styles = [("chhh", ContactStyle::Slide), ("tick", ContactStyle::Hard)];
        let a = animate(Scene::Ball, &[events], &actions(&[], &styles), FRAMES, 2.5);
        let x = |t: f64| ball_of(&a.frames[FRAMES.frame_of(t)]).0;
        assert_eq!(x(0.2), x(0.5));
        assert!(x(1.0) > x(0.5) && x(1.5) > x(1.0));
        assert_eq!(x(1.5), x(2.4), "it stops when the sound ends");
        let floor = a.ball.unwrap().floor_y;
        let (_, cy, _, ry) = ball_of(&a.frames[FRAMES.frame_of(1.0)]);
        assert_eq!(cy + ry, floor, "on the floor while it slides");
    }

    #[test]
    fn two_soundtracks_bounce_two_balls_each_on_its_own_hits_in_its_own_colour() {
        let first = vec![hit(0, "tick", 0.5, 1.0), hit(1, "tick", 1.5, 1.0)];
        let second = vec![
            hit(0, "pop", 0.3, 1.0),
            hit(1, "pop", 1.0, 1.0),
            hit(2, "pop", 1.8, 1.0),
        ];
        let styles = [("tick", ContactStyle::Hard), ("pop", ContactStyle::Hard)];
        let a = animate(
            Scene::Ball,
            &[first, second],
            &actions(&[], &styles),
            FRAMES,
            2.0,
        );
        let floor = a.ball.unwrap().floor_y;
        let bottom = |t: f64, i: usize| {
            let (_, cy, _, ry) = ellipse(&a.frames[FRAMES.frame_of(t)][i]);
            cy + ry
        };
        assert_eq!(bottom(1.5, 0), floor);
        assert!(
            bottom(1.5, 1) < floor - 10.0,
            "the other ball is in the air"
        );
        assert_eq!(bottom(1.0, 1), floor);
        assert!(bottom(1.0, 0) < floor - 10.0);
        let (x0, _, _, _) = ellipse(&a.frames[0][0]);
        let (x1, _, _, _) = ellipse(&a.frames[0][1]);
        assert!(x0 < 320.0 && x1 > 320.0, "side by side: {x0}, {x1}");
        let colors: Vec<&str> = a.frames[0][..2]
            .iter()
            .map(|s| match s {
                Shape::Ellipse { color, .. } => *color,
                _ => unreachable!(),
            })
            .collect();
        assert_eq!(colors, [track_color(0), track_color(1)]);
    }

    #[test]
    fn each_drop_falls_faster_and_faster_and_touches_the_ground_at_its_event() {
        let events = vec![hit(0, "knock", 1.0, 0.5), hit(1, "knock", 1.2, 1.5)];
        let acts = actions(&[("knock", PatternKind::Impulse)], &[]);
        let a = animate(
            Scene::Rain,
            std::slice::from_ref(&events),
            &acts,
            FRAMES,
            2.0,
        );
        let ground = (360.0_f32 * 0.85).round();
        let drop = |t: f64, i: usize| ellipse(&a.frames[FRAMES.frame_of(t)][i]);
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
        let again = animate(Scene::Rain, &[events], &acts, FRAMES, 2.0);
        assert_eq!(again.frames, a.frames);
        assert!(a.frames[FRAMES.frame_of(1.9)].is_empty(), "splashes gone");
    }

    fn polygon(shape: &Shape) -> &[[f32; 2]] {
        match shape {
            Shape::Polygon { points, .. } => points,
            other => panic!("expected a polygon, found {other:?}"),
        }
    }

    /// The ship's nose: its rightmost point.
    fn nose(frame: &[Shape]) -> [f32; 2] {
        polygon(&frame[0])[1]
    }

    #[test]
    fn held_sounds_move_the_ship_for_exactly_their_spans_up_then_down() {
        use PatternKind::{Continuous, Impulse};
        let events = vec![
            held(0, "hooo", 0.5, 1.0),
            held(1, "chhh", 1.5, 1.7),
            hit(2, "pew", 1.9, 1.0),
        ];
        let acts = actions(
            &[("pew", Impulse), ("hooo", Continuous), ("chhh", Continuous)],
            &[],
        );
        let a = animate(Scene::Darts, &[events], &acts, FRAMES, 2.5);
        let y = |t: f64| nose(&a.frames[FRAMES.frame_of(t)])[1];
        let speed = 360.0 * SHIP_SPEED_LANES_PER_SECOND as f32;
        assert_eq!(y(0.0), 180.0, "the middle of its lane");
        assert_eq!(y(0.5), y(0.0), "still until the sound begins");
        assert!((y(0.5) - y(1.0) - 0.5 * speed).abs() < 0.01, "up for 0.5 s");
        assert_eq!(y(1.0), y(1.5), "still between the sounds");
        assert!(
            (y(1.7) - y(1.5) - 0.2 * speed).abs() < 0.01,
            "down for 0.2 s"
        );
        assert_eq!(y(1.7), y(2.4), "still after");
    }

    #[test]
    fn a_dart_leaves_the_nose_at_its_frame_as_long_as_its_throw_is_strong() {
        let events = vec![hit(0, "pew", 0.5, 0.5), hit(1, "pew", 1.0, 1.0)];
        let acts = actions(&[("pew", PatternKind::Impulse)], &[]);
        let a = animate(Scene::Darts, &[events], &acts, FRAMES, 2.5);
        let darts = |t: f64| a.frames[FRAMES.frame_of(t)][1..].to_vec();
        assert!(darts(0.48).is_empty(), "nothing before the throw");
        let first = darts(0.5);
        let tip = polygon(&first[0])[0];
        assert_eq!(tip, nose(&a.frames[FRAMES.frame_of(0.5)]), "from the nose");
        let length = |s: &Shape| polygon(s)[0][0] - polygon(s)[1][0];
        let second = darts(1.0);
        assert_eq!(second.len(), 2);
        assert!((length(&second[1]) - 2.0 * length(&second[0])).abs() < 1e-3);
        // On the board when the flight is over, gone a while later.
        let board = 640.0 * 0.9;
        assert_eq!(polygon(&darts(0.5 + DART_FLIGHT_SECONDS)[0])[0][0], board);
        assert_eq!(darts(2.3).len(), 0);
    }

    #[test]
    fn a_shot_leaves_the_cannon_at_its_frame_and_the_runner_jumps_and_slides_on_time() {
        use PatternKind::{Continuous, Impulse};
        let shots = vec![hit(0, "pew", 0.5, 1.0), hit(1, "boom", 1.5, 1.0)];
        let moves = vec![hit(0, "hup", 0.7, 1.0), held(1, "chhh", 1.8, 2.2)];
        let acts = actions(
            &[
                ("pew", Impulse),
                ("boom", Impulse),
                ("hup", Impulse),
                ("chhh", Continuous),
            ],
            &[],
        );
        let a = animate(Scene::Laser, &[shots, moves], &acts, FRAMES, 3.0);
        let frame = |t: f64| &a.frames[FRAMES.frame_of(t)];
        let rect = |s: &Shape| match s {
            Shape::Rect { x, y, w, h, color } => (*x, *y, *w, *h, *color),
            other => panic!("expected a rect, found {other:?}"),
        };
        let ground = (360.0_f32 * 0.8).round();
        let cannon = 640.0 * 0.9;
        // Body, head, then the shots in flight.
        assert_eq!(frame(0.48).len(), 2);
        let (x, y, _, h, color) = rect(&frame(0.5)[2]);
        assert_eq!(x, cannon, "the low shot leaves the cannon at its frame");
        assert!(y + h > ground - 360.0 * 0.05, "low");
        assert_eq!(color, track_color(0));
        let (x, ..) = rect(&frame(0.5 + SHOT_SECONDS)[2]);
        assert!(
            (x - 640.0 * 0.22).abs() < 0.01,
            "at the runner {SHOT_SECONDS} s later"
        );
        // The jump: on the ground at its frame, in the air a quarter of it later, down
        // when it is over.
        let feet = |t: f64| {
            let (_, y, _, h, _) = rect(&frame(t)[0]);
            y + h
        };
        assert_eq!(feet(0.7), ground);
        assert!(feet(0.7 + JUMP_SECONDS / 2.0) < ground - 50.0);
        assert_eq!(feet(0.7 + JUMP_SECONDS), ground);
        assert_eq!(
            rect(&frame(0.8)[0]).4,
            track_color(1),
            "moved by the second"
        );
        // The slide: flat (wider than tall) for exactly the held sound's span.
        let flat = |t: f64| {
            let (_, _, w, h, _) = rect(&frame(t)[0]);
            w > h
        };
        assert!(!flat(1.78) && flat(1.8) && flat(2.2) && !flat(2.24));
        // The high shot passes over the sliding runner's head.
        let (_, y, _, h, _) = rect(&frame(1.5 + SHOT_SECONDS)[2]);
        let (_, head_y, _, head_r) = ellipse(&frame(1.5 + SHOT_SECONDS)[1]);
        assert!(y + h < head_y - head_r, "over the head");
    }
}
