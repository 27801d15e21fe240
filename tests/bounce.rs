//! The reference bounce solver against the paper's closed-form solution, and the
//! trajectory's invariants: never below the floor, continuous, on the floor at every hit.

use std::collections::BTreeMap;
use std::sync::Arc;

use onomato::config::{BounceSettings, ContactStyle, PatternKind};
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
