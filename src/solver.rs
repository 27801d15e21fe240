//! The reference bounce solver (offline): the paper's exact solution. Every configured
//! hit is a floor contact; between two contacts the ball flies ballistically,
//! z(t) = v0 (t - t_k) - g (t - t_k)² / 2, and lands exactly on the next contact, so the
//! launch speed after contact k is v0 = g (t_{k+1} - t_k) / 2 and the apex g T² / 8.
//! A hard bounce leaves at once; a soft bounce also reports a squash that grows with the
//! hit's strength; a slide (a continuous event) keeps the ball on the floor from begin
//! to end and launches at the end.
//!
//! Pure computation on the caller's thread; allocates its result.

use std::sync::Arc;

use serde::Serialize;

use crate::config::{BounceSettings, ContactStyle};
use crate::detect::{opt_seconds, ratio, seconds, Event};

/// One floor contact and the flight that follows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Contact {
    /// Id of the event that caused the contact.
    pub event: u64,
    pub pattern: Arc<str>,
    pub style: ContactStyle,
    /// Contact begins (the hit, or the slide's begin), seconds.
    #[serde(serialize_with = "seconds")]
    pub time: f64,
    /// Contact ends and the ball launches (equal to `time` for hits).
    #[serde(serialize_with = "seconds")]
    pub end: f64,
    #[serde(serialize_with = "ratio")]
    pub strength: f64,
    /// Squash of a soft bounce, as a fraction of the ball's height (0 otherwise).
    #[serde(serialize_with = "ratio")]
    pub squash: f64,
    /// Vertical launch speed at `end`, m/s (0 after the last contact).
    #[serde(serialize_with = "ratio")]
    pub launch_velocity: f64,
    /// Time in the air until the next contact, s (0 after the last contact).
    #[serde(serialize_with = "seconds")]
    pub flight_time: f64,
    /// Highest point of the flight above the floor, m.
    #[serde(serialize_with = "ratio")]
    pub apex_height: f64,
    #[serde(serialize_with = "opt_seconds")]
    pub apex_time: Option<f64>,
    /// When the ball touches the floor again: the next contact's time.
    #[serde(serialize_with = "opt_seconds")]
    pub landing_time: Option<f64>,
}

/// Solves the bounce for the events that the settings map to a contact style.
pub fn solve(events: &[Event], settings: &BounceSettings) -> Vec<Contact> {
    let mut contacts: Vec<Contact> = events
        .iter()
        .filter_map(|e| {
            let style = *settings.styles.get(&*e.pattern)?;
            let end = match style {
                ContactStyle::Slide => e.end.unwrap_or(e.time).max(e.time),
                ContactStyle::Hard | ContactStyle::Soft => e.time,
            };
            let squash = match style {
                ContactStyle::Soft => settings.max_squash * e.strength.clamp(0.0, 1.0),
                ContactStyle::Hard | ContactStyle::Slide => 0.0,
            };
            Some(Contact {
                event: e.id,
                pattern: e.pattern.clone(),
                style,
                time: e.time,
                end,
                strength: e.strength,
                squash,
                launch_velocity: 0.0,
                flight_time: 0.0,
                apex_height: 0.0,
                apex_time: None,
                landing_time: None,
            })
        })
        .collect();
    contacts.sort_by(|a, b| a.time.total_cmp(&b.time).then(a.event.cmp(&b.event)));

    // A contact that starts while the ball is still on the floor (inside a slide) is
    // part of that contact: a slide extends it, a hit inside it is absorbed.
    let mut merged: Vec<Contact> = Vec::with_capacity(contacts.len());
    for c in contacts {
        match merged.last_mut() {
            Some(last) if c.time < last.end => last.end = last.end.max(c.end),
            _ => merged.push(c),
        }
    }
    let g = settings.gravity;
    for k in 0..merged.len().saturating_sub(1) {
        let next = merged[k + 1].time;
        let c = &mut merged[k];
        let flight = next - c.end;
        c.flight_time = flight;
        c.launch_velocity = g * flight / 2.0;
        c.apex_height = g * flight * flight / 8.0;
        c.apex_time = Some(c.end + flight / 2.0);
        c.landing_time = Some(next);
    }
    merged
}

/// The ball's height over time for solved contacts (floor at 0).
pub struct Trajectory<'a> {
    pub gravity: f64,
    pub contacts: &'a [Contact],
}

impl Trajectory<'_> {
    /// Height above the floor at time `t`: 0 before the first contact, during contacts
    /// and after the last one.
    pub fn height_at(&self, t: f64) -> f64 {
        // The last contact that has ended by t decides the flight in progress.
        let idx = self.contacts.partition_point(|c| c.end <= t);
        if idx == 0 {
            return 0.0;
        }
        let c = &self.contacts[idx - 1];
        match c.landing_time {
            Some(landing) if t < landing => {
                let dt = t - c.end;
                (c.launch_velocity * dt - self.gravity * dt * dt / 2.0).max(0.0)
            }
            _ => 0.0,
        }
    }
}
