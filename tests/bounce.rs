//! The reference bounce solver against the paper's closed-form solution, and the
//! trajectory's invariants: never below the floor, continuous, on the floor at every hit.
//! The live solver, which does not know the next hit, against the same invariants when
//! hits come on time, early and late.

use std::collections::BTreeMap;
use std::sync::Arc;

use onomato::config::{BounceSettings, ContactStyle, PatternKind};
use onomato::live_bounce::{BounceState, LiveBounce};
use onomato::solver::{solve, Trajectory};
use onomato::Event;

fn hit(id: u64, pattern: &str, time: f64, strength: f64) -> Event {
    Event {
        id,
        pattern: Arc::from(pattern),
        kind: PatternKind::Impulse,
        time,
        end: None,
        strength,
        score: 0.9,
        emitted_at: time + 0.1,
        pitch: None,
    }
}

fn held(id: u64, pattern: &str, time: f64, end: f64) -> Event {
    Event {
        kind: PatternKind::Continuous,
        end: Some(end),
        ..hit(id, pattern, time, 0.7)
    }
}

fn settings(g: f64) -> BounceSettings {
    let styles: BTreeMap<String, ContactStyle> = [
        ("tick".to_string(), ContactStyle::Hard),
        ("pop".to_string(), ContactStyle::Soft),
        ("chhh".to_string(), ContactStyle::Slide),
    ]
    .into_iter()
    .collect();
    BounceSettings {
        gravity: g,
        styles,
        max_squash: 0.4,
        default_interval_seconds: 0.5,
        state_delay_seconds: Some(0.05),
    }
}

#[test]
fn launch_speed_apex_and_landing_follow_the_closed_form() {
    let g = 9.81;
    let times = [0.5, 1.0, 1.8, 2.1, 3.3];
    let events: Vec<Event> = times
        .iter()
        .enumerate()
        .map(|(i, &t)| hit(i as u64, "tick", t, 0.8))
        .collect();
    let contacts = solve(&events, &settings(g));
    assert_eq!(contacts.len(), times.len());
    for (k, c) in contacts.iter().enumerate() {
        assert_eq!(c.time, times[k]);
        assert_eq!(c.end, times[k]);
        if k + 1 < times.len() {
            let dt = times[k + 1] - times[k];
            assert!((c.launch_velocity - g * dt / 2.0).abs() < 1e-12);
            assert!((c.apex_height - g * dt * dt / 8.0).abs() < 1e-12);
            assert!((c.flight_time - dt).abs() < 1e-12);
            assert_eq!(c.landing_time, Some(times[k + 1]));
            assert!((c.apex_time.unwrap() - (times[k] + dt / 2.0)).abs() < 1e-12);
        } else {
            assert_eq!(c.launch_velocity, 0.0);
            assert_eq!(c.landing_time, None);
        }
    }
    // Worked example: 0.5 s between hits at g = 9.81 leaves at 2.4525 m/s and peaks
    // 0.30656 m up, a quarter of a second later.
    assert!((contacts[0].launch_velocity - 2.4525).abs() < 1e-9);
    assert!((contacts[0].apex_height - 0.306_562_5).abs() < 1e-9);
}

#[test]
fn trajectory_stays_above_the_floor_is_continuous_and_touches_it_at_every_hit() {
    let g = 9.81;
    let events = vec![
        hit(0, "tick", 0.30, 0.9),
        hit(1, "pop", 0.72, 0.5),
        held(2, "chhh", 1.40, 1.95),
        hit(3, "tick", 2.20, 1.0),
        hit(4, "tick", 2.26, 0.3),
        hit(5, "pop", 3.10, 1.2),
    ];
    let contacts = solve(&events, &settings(g));
    let traj = Trajectory {
        gravity: g,
        contacts: &contacts,
    };
    let dt = 1e-4;
    let vmax = contacts
        .iter()
        .map(|c| c.launch_velocity)
        .fold(0.0, f64::max);
    let mut prev = traj.height_at(0.0);
    let mut t = 0.0;
    while t < 3.5 {
        t += dt;
        let h = traj.height_at(t);
        assert!(h >= 0.0, "below the floor at {t}");
        assert!(
            (h - prev).abs() <= vmax * dt * 1.01 + 1e-12,
            "jump at {t}: {prev} -> {h}"
        );
        prev = h;
    }
    for e in &events {
        assert!(
            traj.height_at(e.time).abs() < 1e-12,
            "not on the floor at hit {e:?}"
        );
    }
    // On the floor during the slide, in the air between contacts.
    for k in 0..50 {
        let s = 1.40 + 0.55 * f64::from(k) / 50.0;
        assert_eq!(traj.height_at(s), 0.0, "sliding at {s}");
    }
    let slide = contacts
        .iter()
        .find(|c| c.style == ContactStyle::Slide)
        .unwrap();
    assert_eq!((slide.time, slide.end), (1.40, 1.95));
    assert!((slide.launch_velocity - g * (2.20 - 1.95) / 2.0).abs() < 1e-12);
    let mid = traj.height_at(0.51);
    assert!(
        (mid - contacts[0].apex_height).abs() < 1e-12,
        "apex halfway between hits"
    );
}

#[test]
fn soft_bounces_squash_with_strength_and_hard_ones_do_not() {
    let events = vec![
        hit(0, "pop", 0.5, 0.25),
        hit(1, "pop", 1.0, 0.75),
        hit(2, "pop", 1.5, 2.0),
        hit(3, "tick", 2.0, 1.0),
    ];
    let contacts = solve(&events, &settings(9.81));
    let squash: Vec<f64> = contacts.iter().map(|c| c.squash).collect();
    assert!((squash[0] - 0.1).abs() < 1e-12);
    assert!((squash[1] - 0.3).abs() < 1e-12);
    assert!((squash[2] - 0.4).abs() < 1e-12, "clamped at max_squash");
    assert_eq!(squash[3], 0.0);
    assert!(squash[0] < squash[1]);
}

#[test]
fn hits_inside_a_slide_are_absorbed_and_unmapped_patterns_ignored() {
    let events = vec![
        held(0, "chhh", 1.0, 2.0),
        hit(1, "tick", 1.5, 0.9),
        hit(2, "boom", 2.2, 0.9),
        hit(3, "tick", 2.5, 0.9),
    ];
    let contacts = solve(&events, &settings(9.81));
    let ids: Vec<u64> = contacts.iter().map(|c| c.event).collect();
    assert_eq!(ids, [0, 3]);
    assert_eq!(contacts[0].landing_time, Some(2.5));
    assert!(solve(&[], &settings(9.81)).is_empty());
}

#[test]
fn events_out_of_time_order_are_sorted() {
    let events = vec![hit(5, "tick", 2.0, 1.0), hit(2, "tick", 1.0, 1.0)];
    let contacts = solve(&events, &settings(9.81));
    assert_eq!(contacts[0].time, 1.0);
    assert_eq!(contacts[0].landing_time, Some(2.0));
}

// ---------------------------------------------------------------- live solver

/// Streams `events` into a live solver the way the daemon does: each event reaches it
/// `latency` seconds after its onset (a complete held sound: after its end), and the states are drawn up to
/// "now" minus the settings' state delay, in steps of `step` seconds.
fn run_live(
    events: &[Event],
    latency: f64,
    state_rate: f64,
    until: f64,
) -> (Vec<BounceState>, Vec<onomato::live_bounce::LiveHit>, u64) {
    let s = settings(9.81);
    let mut solver = LiveBounce::new(&s, state_rate);
    let mut states = Vec::new();
    let mut hits = Vec::new();
    let mut next = 0;
    let step = 0.002;
    let mut now = 0.0;
    while now < until {
        // A held sound's complete event is decided at its end.
        while next < events.len() && events[next].end.unwrap_or(events[next].time) + latency <= now
        {
            if let Some(h) = solver.on_event(&events[next]) {
                hits.push(h);
            }
            next += 1;
        }
        solver.draw_until(now - s.state_delay_seconds.unwrap(), |st| states.push(st));
        now += step;
    }
    (states, hits, solver.late_hits())
}

/// Never below the floor; continuous (from one state to the next the height changes by
/// no more than the speed allows); exactly on the floor in the state drawn at each hit.
fn check_live_invariants(states: &[BounceState], hit_times: &[f64]) {
    assert!(states.len() > 100, "too few states: {}", states.len());
    for w in states.windows(2) {
        let (a, b) = (w[0], w[1]);
        assert!(b.time >= a.time, "states out of order: {a:?} then {b:?}");
        assert!(b.height >= 0.0, "below the floor: {b:?}");
        let dt = b.time - a.time;
        // Mean value theorem on a flight of constant acceleration (|a| < 5000 m/s² even
        // for the steepest re-planned descent here): a jump would break this.
        let allowed = (a.velocity.abs().max(b.velocity.abs()) + 5000.0 * dt) * dt + 1e-9;
        assert!(
            (b.height - a.height).abs() <= allowed,
            "height jumps by {:.4} m in {:.4} s between {a:?} and {b:?}",
            b.height - a.height,
            dt
        );
    }
    for &t in hit_times {
        let at: Vec<&BounceState> = states
            .iter()
            .filter(|s| (s.time - t).abs() < 1e-9)
            .collect();
        assert!(!at.is_empty(), "no state drawn at the hit at {t} s");
        assert!(
            at.iter().all(|s| s.height == 0.0),
            "the ball is not on the floor at the hit at {t} s: {at:?}"
        );
    }
}

#[test]
fn live_solver_lands_on_hits_that_come_as_predicted() {
    let times: Vec<f64> = (0..12).map(|k| 0.3 + 0.5 * k as f64).collect();
    let events: Vec<Event> = times
        .iter()
        .enumerate()
        .map(|(i, &t)| hit(i as u64, "tick", t, 0.8))
        .collect();
    let (states, hits, late) = run_live(&events, 0.03, 120.0, 7.0);
    assert_eq!(late, 0);
    check_live_invariants(&states, &times);
    assert_eq!(hits.len(), times.len());
    // Once two flights are known, the prediction is the rhythm: v0 = g·0.5/2.
    for h in &hits[3..] {
        assert!((h.launch_velocity - 9.81 * 0.25).abs() < 1e-9, "{h:?}");
        assert!((h.predicted_landing - h.time - 0.5).abs() < 1e-9, "{h:?}");
        assert!((h.apex - 9.81 * 0.25 / 8.0).abs() < 1e-9, "{h:?}");
    }
    // And the ball really flies between hits: its top is the predicted apex.
    let top = states
        .iter()
        .filter(|s| s.time > times[6] && s.time < times[7])
        .map(|s| s.height)
        .fold(0.0, f64::max);
    assert!((top - 9.81 * 0.25 / 8.0).abs() < 0.01, "top {top}");
}

#[test]
fn live_solver_keeps_its_invariants_when_hits_come_early_or_late() {
    // Intervals far from any prediction: much shorter, much longer, alternating.
    let intervals = [
        0.5, 0.5, 0.2, 1.1, 0.3, 0.9, 0.15, 0.6, 1.4, 0.25, 0.25, 0.7,
    ];
    let mut times = vec![0.4];
    for d in intervals {
        times.push(times.last().unwrap() + d);
    }
    let events: Vec<Event> = times
        .iter()
        .enumerate()
        .map(|(i, &t)| hit(i as u64, if i % 3 == 0 { "pop" } else { "tick" }, t, 0.6))
        .collect();
    let end = times.last().unwrap() + 1.0;
    let (states, hits, late) = run_live(&events, 0.03, 200.0, end);
    assert_eq!(late, 0, "every hit was known before the drawing reached it");
    check_live_invariants(&states, &times);
    // The early hits really were early: the ball was predicted to land later.
    let early = hits
        .windows(2)
        .filter(|w| w[1].time < w[0].predicted_landing - 0.05)
        .count();
    let late_hits = hits
        .windows(2)
        .filter(|w| w[1].time > w[0].predicted_landing + 0.05)
        .count();
    assert!(
        early >= 3 && late_hits >= 3,
        "early {early}, late {late_hits}"
    );
    // Soft hits ("pop") report a squash, hard ones none.
    assert!(hits.iter().step_by(3).all(|h| h.squash > 0.0));
    assert!(hits.iter().skip(1).step_by(3).all(|h| h.squash == 0.0));
}

#[test]
fn live_solver_holds_a_slide_on_the_floor_and_launches_at_its_end() {
    let begin = hit(1, "chhh", 1.2, 0.7);
    let begin = Event {
        kind: PatternKind::Continuous,
        end: None,
        ..begin
    };
    let events = vec![
        hit(0, "tick", 0.5, 0.8),
        begin,
        held(1, "chhh", 1.2, 1.9),
        hit(2, "tick", 2.4, 0.8),
    ];
    // The end of the slide is known 30 ms after it, like every event here.
    let (states, _, _) = run_live(&events, 0.03, 100.0, 3.5);
    check_live_invariants(&states, &[0.5, 1.2, 2.4]);
    let on_floor = states.iter().filter(|s| s.time >= 1.2 && s.time <= 1.9);
    assert!(on_floor.clone().count() > 50);
    assert!(
        on_floor.clone().all(|s| s.height == 0.0),
        "the ball left the floor during the slide"
    );
    assert!(
        states
            .iter()
            .any(|s| s.time > 1.9 && s.time < 2.4 && s.height > 0.05),
        "no launch after the slide"
    );
}

#[test]
fn a_hit_decided_after_the_drawing_passed_it_is_counted_late_and_grounds_the_ball() {
    let events = vec![
        hit(0, "tick", 0.5, 0.8),
        hit(1, "tick", 1.0, 0.8),
        hit(2, "tick", 1.3, 0.8),
    ];
    // Decided 200 ms after the onset, with a 50 ms state delay: every hit is late.
    let (states, _, late) = run_live(&events, 0.2, 100.0, 2.0);
    assert_eq!(late, 3);
    assert!(states.iter().all(|s| s.height >= 0.0));
    for t in [0.5, 1.0, 1.3] {
        // Grounded at the first state drawn after the hit became known.
        let after = states
            .iter()
            .find(|s| s.time >= t + 0.2 - 0.05 - 1e-9)
            .unwrap();
        assert_eq!(after.height, 0.0, "{after:?}");
    }
}
