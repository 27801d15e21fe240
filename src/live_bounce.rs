//! The live bounce solver: the paper's ballistic bounce, for a stream whose next hit is
//! not known yet. At each contact it predicts the next one from the recent intervals
//! (median of the last three flights, or `default_interval_seconds` before there are
//! any), launches with v0 = g·Δ̂/2 so that the ball would land exactly then, and reports
//! the launch velocity, the predicted landing time and the apex g·Δ̂²/8.
//!
//! It also draws the ball's height as a stream of states. The drawing runs a fixed
//! delay behind the input (`state_delay_seconds`), so each hit is known before the
//! drawing reaches it; when a hit comes earlier than predicted, the flight is re-planned
//! from the last drawn state to reach the floor exactly at the hit, and when it comes
//! later, the ball waits on the floor. Either way the height never goes below the floor,
//! is continuous, and is exactly zero in the state drawn at each contact's time. A hit
//! that arrives after the drawing passed it (the detector decided later than the delay)
//! puts the ball on the floor at the next state and is counted as late.
//!
//! Owned and run by the output thread. Fixed-size storage: nothing allocates after
//! construction.

use std::collections::BTreeMap;

use crate::config::{BounceSettings, ContactStyle, PatternKind};
use crate::detect::Event;

/// Hits known ahead of the drawing; more than this many at once are drawn late.
const PENDING_CAPACITY: usize = 32;
/// Flights kept for the prediction.
const RECENT_FLIGHTS: usize = 3;
/// Predicted flights are kept within these bounds, seconds.
const MIN_FLIGHT: f64 = 0.05;
const MAX_FLIGHT: f64 = 10.0;

/// A launch, as sent in `/bounce/hit`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveHit {
    /// Id of the event that launched the ball.
    pub event: u64,
    /// Launch time (the hit, or the end of a slide), stream seconds.
    pub time: f64,
    /// Vertical launch speed, m/s.
    pub launch_velocity: f64,
    /// When the ball will land if the next hit comes as predicted.
    pub predicted_landing: f64,
    /// Height of the flight's top, m.
    pub apex: f64,
    /// Squash of a soft bounce (0 for hard bounces and slides).
    pub squash: f64,
}

/// One drawn state of the ball.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BounceState {
    pub time: f64,
    /// Height above the floor, m (never negative).
    pub height: f64,
    /// Vertical speed, m/s.
    pub velocity: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Action {
    /// The ball is on the floor from this time (a hit, or a slide's begin).
    Contact,
    /// The ball leaves the floor at this time.
    Launch { velocity: f64, flight: f64 },
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    time: f64,
    action: Action,
}

/// Height h0 + v0·τ + a·τ²/2 for τ = t - start in [0, land - start]; on the floor after.
#[derive(Debug, Clone, Copy)]
struct Flight {
    start: f64,
    h0: f64,
    v0: f64,
    accel: f64,
    land: f64,
}

impl Flight {
    fn grounded(at: f64) -> Self {
        Self {
            start: at,
            h0: 0.0,
            v0: 0.0,
            accel: 0.0,
            land: at,
        }
    }

    fn state(&self, t: f64) -> BounceState {
        if t >= self.land {
            return BounceState {
                time: t,
                height: 0.0,
                velocity: 0.0,
            };
        }
        let tau = (t - self.start).max(0.0);
        BounceState {
            time: t,
            height: (self.h0 + self.v0 * tau + 0.5 * self.accel * tau * tau).max(0.0),
            velocity: self.v0 + self.accel * tau,
        }
    }
}

/// The live solver. See the module documentation.
pub struct LiveBounce {
    gravity: f64,
    default_interval: f64,
    state_period: f64,
    max_squash: f64,
    styles: BTreeMap<String, ContactStyle>,
    flights: [f64; RECENT_FLIGHTS],
    flight_count: usize,
    /// Time the ball last left the floor.
    last_launch: Option<f64>,
    pending: [Option<Pending>; PENDING_CAPACITY],
    flight: Flight,
    /// Time of the last drawn state.
    drawn_until: f64,
    last_drawn: BounceState,
    /// Index of the next regular state: it is drawn at `index × period`.
    next_frame: u64,
    late_hits: u64,
}

impl LiveBounce {
    /// `state_rate`: states drawn per second of stream.
    pub fn new(settings: &BounceSettings, state_rate: f64) -> Self {
        Self {
            gravity: settings.gravity,
            default_interval: settings.default_interval_seconds,
            state_period: 1.0 / state_rate,
            max_squash: settings.max_squash,
            styles: settings.styles.clone(),
            flights: [0.0; RECENT_FLIGHTS],
            flight_count: 0,
            last_launch: None,
            pending: [None; PENDING_CAPACITY],
            flight: Flight::grounded(0.0),
            drawn_until: f64::NEG_INFINITY,
            last_drawn: BounceState {
                time: 0.0,
                height: 0.0,
                velocity: 0.0,
            },
            next_frame: 0,
            late_hits: 0,
        }
    }

    /// Hits that reached the solver after the drawing had passed them.
    pub fn late_hits(&self) -> u64 {
        self.late_hits
    }

    /// The flight time expected for the next launch, seconds.
    pub fn predicted_interval(&self) -> f64 {
        let n = self.flight_count.min(RECENT_FLIGHTS);
        if n == 0 {
            return self.default_interval;
        }
        let mut recent = [0.0; RECENT_FLIGHTS];
        recent[..n].copy_from_slice(&self.flights[..n]);
        recent[..n].sort_by(f64::total_cmp);
        recent[n / 2].clamp(MIN_FLIGHT, MAX_FLIGHT)
    }

    /// Takes one event (impulses, begin markers and complete continuous events). Returns
    /// the launch it causes, if any: a hard or soft hit launches at once, a slide
    /// launches at its end.
    pub fn on_event(&mut self, event: &Event) -> Option<LiveHit> {
        let style = *self.styles.get(&*event.pattern)?;
        match (style, event.kind, event.end) {
            (ContactStyle::Hard | ContactStyle::Soft, PatternKind::Impulse, _) => {
                self.contact(event.time);
                let squash = if style == ContactStyle::Soft {
                    (self.max_squash * event.strength).clamp(0.0, self.max_squash)
                } else {
                    0.0
                };
                Some(self.launch(event.id, event.time, squash))
            }
            (ContactStyle::Slide, PatternKind::Continuous, None) => {
                self.contact(event.time);
                None
            }
            (ContactStyle::Slide, PatternKind::Continuous, Some(end)) => {
                // A slide whose begin was not reported separately (waveform method).
                if !self.has_contact_at(event.time) {
                    self.contact(event.time);
                }
                Some(self.launch(event.id, end.max(event.time), 0.0))
            }
            _ => None,
        }
    }

    fn has_contact_at(&self, t: f64) -> bool {
        self.pending
            .iter()
            .flatten()
            .any(|p| p.action == Action::Contact && (p.time - t).abs() < 1e-9)
            || (self.flight.start - t).abs() < 1e-9
    }

    fn contact(&mut self, t: f64) {
        if let Some(launched) = self.last_launch {
            if t > launched {
                self.flights[self.flight_count % RECENT_FLIGHTS] = t - launched;
                self.flight_count += 1;
            }
        }
        if t <= self.drawn_until {
            self.late_hits += 1;
        } else if let Some(next) = self.next_pending_time() {
            // The flight being drawn is re-planned below only for the earliest contact.
            if next < t {
                self.push(t, Action::Contact);
                return;
            }
        }
        self.replan_to(t);
        self.push(t, Action::Contact);
    }

    fn launch(&mut self, event: u64, t: f64, squash: f64) -> LiveHit {
        let flight = self.predicted_interval();
        let velocity = self.gravity * flight / 2.0;
        self.last_launch = Some(t);
        self.push(t, Action::Launch { velocity, flight });
        LiveHit {
            event,
            time: t,
            launch_velocity: velocity,
            predicted_landing: t + flight,
            apex: self.gravity * flight * flight / 8.0,
            squash,
        }
    }

    /// Makes the flight being drawn reach the floor exactly at `t` when it would still be
    /// in the air then: from the last drawn state (h, v), h(τ) = h + v·τ + a·τ²/2 with
    /// a = -2(h + v·T)/T², T = t - (last drawn time). This never dips below the floor:
    /// the flight was above it at `t`, so h + v·T > 0 and a < 0.
    fn replan_to(&mut self, t: f64) {
        if t <= self.drawn_until || self.flight.land <= t {
            return;
        }
        let from = self.last_drawn;
        let start = self.drawn_until.max(self.flight.start);
        let now = if start == self.drawn_until {
            from
        } else {
            self.flight.state(start)
        };
        let span = t - start;
        if span <= 0.0 || now.height <= 0.0 && now.velocity <= 0.0 {
            return;
        }
        let accel = -2.0 * (now.height + now.velocity * span) / (span * span);
        self.flight = Flight {
            start,
            h0: now.height,
            v0: now.velocity,
            accel,
            land: t,
        };
    }

    fn next_pending_time(&self) -> Option<f64> {
        self.pending
            .iter()
            .flatten()
            .map(|p| p.time)
            .min_by(f64::total_cmp)
    }

    fn push(&mut self, time: f64, action: Action) {
        let p = Pending { time, action };
        if let Some(slot) = self.pending.iter_mut().find(|s| s.is_none()) {
            *slot = Some(p);
        } else {
            // Full: apply the oldest now (drawn late) to make room.
            self.late_hits += 1;
            if let Some(oldest) = self.take_earliest(f64::INFINITY) {
                self.apply(oldest);
            }
            if let Some(slot) = self.pending.iter_mut().find(|s| s.is_none()) {
                *slot = Some(p);
            }
        }
    }

    /// Removes and returns the earliest pending item at or before `until` (contacts
    /// before launches at the same time).
    fn take_earliest(&mut self, until: f64) -> Option<Pending> {
        let mut best: Option<usize> = None;
        for (i, slot) in self.pending.iter().enumerate() {
            let Some(p) = slot else { continue };
            if p.time > until {
                continue;
            }
            let better = match best.and_then(|b| self.pending[b]) {
                None => true,
                Some(q) => {
                    p.time < q.time
                        || (p.time == q.time
                            && p.action == Action::Contact
                            && q.action != Action::Contact)
                }
            };
            if better {
                best = Some(i);
            }
        }
        best.and_then(|i| self.pending[i].take())
    }

    fn apply(&mut self, p: Pending) {
        self.flight = match p.action {
            Action::Contact => Flight::grounded(p.time),
            Action::Launch { velocity, flight } => Flight {
                start: p.time,
                h0: 0.0,
                v0: velocity,
                accel: -self.gravity,
                land: p.time + flight,
            },
        };
        // A contact already known may come before the new landing: plan for it.
        if let Some(next) = self.next_pending_time() {
            let saved = self.drawn_until;
            self.drawn_until = p.time;
            self.last_drawn = self.flight.state(p.time);
            self.replan_to(next);
            self.drawn_until = saved;
        }
    }

    /// Draws every state up to stream time `until`: one every state period, and one
    /// exactly at each contact and launch.
    pub fn draw_until(&mut self, until: f64, mut emit: impl FnMut(BounceState)) {
        loop {
            let frame = self.next_frame as f64 * self.state_period;
            let next_pending = self.next_pending_time();
            match next_pending {
                Some(t) if t <= until && t <= frame => {
                    let Some(p) = self.take_earliest(t) else {
                        break;
                    };
                    if p.time <= self.drawn_until {
                        // Late: applied at the next regular state, which shows it.
                        let at = frame.max(self.drawn_until + 1e-6);
                        self.apply(Pending {
                            time: at,
                            action: p.action,
                        });
                        if self
                            .next_pending_time()
                            .is_some_and(|t| t <= self.drawn_until)
                        {
                            continue;
                        }
                        self.draw(at, &mut emit);
                        continue;
                    }
                    self.apply(p);
                    // Several items at the same time are drawn as one state.
                    if self.next_pending_time() == Some(p.time) {
                        continue;
                    }
                    self.draw(p.time, &mut emit);
                }
                _ if frame <= until => {
                    // A regular state a hair after one drawn at a hit adds nothing.
                    if frame > self.drawn_until + 1e-9 {
                        self.draw(frame, &mut emit);
                    }
                    self.next_frame += 1;
                }
                _ => break,
            }
        }
    }

    fn draw(&mut self, t: f64, emit: &mut impl FnMut(BounceState)) {
        let state = self.flight.state(t);
        self.drawn_until = t;
        self.last_drawn = state;
        emit(state);
    }
}
