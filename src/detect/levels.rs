//! The level stage: how far the sound of each frame stands out of the room's noise.
//! Three floors follow the room, each as the onset stage's band floors do (towards a
//! quieter frame quickly, upwards slowly, and after digital silence catching up with
//! the room as fast as they fall), and never under the quietest their level has been
//! over the last `ROOM_WINDOW_SECONDS` (a room that got louder for good): under the
//! frame's level as the analyser gives it (the room's noise for placing an onset on the
//! samples), under the frame's
//! power as the bands hear it (the sound level the speech guard and a held sound's
//! strength read), and under the power of the last `PERIOD_HOPS` hops (the sound level
//! the quiet-before rise and the spans of recognised sounds read). It also tells how a
//! stream begins ([`StreamStart`]): the floors of one that begins with a sound start
//! from the room that follows it ([`Levels::prime`]), as the onset stage's do; and it
//! keeps the room as last heard before digital silence, for a held sound that begins
//! as the silence ends ([`Levels::room_before_silence`]). Runs on the detector thread,
//! inside the spectral matcher, once per frame; allocates nothing after `new`.

use super::features::HOP_SECONDS;
use super::onset::OnsetParams;
use super::recent_min::RecentMinimum;

/// The level of a frame without sound, dB.
pub(super) const SILENT_DB: f32 = -120.0;

/// The hops that cover the longest period of mains hum (50 Hz, 20 ms): 7 hops of 2.9
/// ms, 20.3 ms. A frame (11.6 ms) is shorter than a period, so the power
/// of a frame of steady hum swings with the hum's phase (by 6 dB at 50 Hz, 40 dB under
/// full scale), and a floor that follows the quietest frames sits in the dips. The
/// quiet-before rise, and the spans of recognised sounds that end where a new sound
/// rises by its measure, measure the sound over a floor that follows the power of whole
/// periods instead ([`FrameLevels::rise`]): over that floor, the swing is no sound
/// before an onset. Over every dev set, the unheard voices and the rooms, the hits are
/// as they were and the hum rooms regain most of their exact copies; from 6 to 35 hops
/// they do, 7 and 8 alike, longer lets more speech through, half a period (10 ms) does
/// not (`docs/rooms.md`, "Mains hum").
const PERIOD_HOPS: usize = 7;

/// A floor is never under the quietest its level has been over this long: a room that
/// gets louder for good (a fan switched on, a window opened on a street) is sound over
/// floors that rise at the onset stage's 3 dB/s for as long as its step takes at that
/// pace (7 s for 20 dB), and every gate that measures sound over them stops the sounds
/// made in it; over this window it is the room within 3-3.75 s, whatever its step.
/// Longer than a phrase of speech without a pause, which must stay sound over the room;
/// a held sound, which can be held for longer, is followed over the floor that the
/// window does not lift (`FrameLevels::held`). Swept, with the onset stage's band
/// floors given the same window or not (they are not: there it let real speech
/// through), in `docs/rooms.md`, "A room that gets louder": shorter windows lift the
/// floors under running speech.
const ROOM_WINDOW_SECONDS: f64 = 3.0;

/// The level of the sound in a frame of `level_db`, over a room whose noise is at
/// `floor_db`: the frame's power less twice the noise's, in dB (`SILENT_DB` when that
/// is nothing). The gates compare sounds with each other: noise a few dB under a
/// sound must not pass for a sound just before it, or for speech around it.
pub(super) fn sound_level_db(level_db: f32, floor_db: f32) -> f32 {
    let excess = 10f32.powf(level_db / 10.0) - 2.0 * 10f32.powf(floor_db / 10.0);
    if excess > 0.0 {
        (10.0 * excess.log10()).max(SILENT_DB)
    } else {
        SILENT_DB
    }
}

/// One frame's sound over the room's noise ([`sound_level_db`]; `SILENT_DB` for none).
#[derive(Clone, Copy, Debug)]
pub(super) struct FrameLevels {
    /// Over the floor under the frames' power as the bands hear it.
    pub(super) sound: f32,
    /// Over the floor under the power of the last `PERIOD_HOPS` hops.
    pub(super) rise: f32,
    /// The frame's power as the bands hear it, dB.
    pub(super) heard: f32,
    /// Over the floor under the same power that the window does not lift: what a held
    /// sound is followed by, so that one held longer than the window is not taken for
    /// the room.
    pub(super) held: f32,
}

/// What the level stage takes of a frame ([`Levels::push`], [`Levels::prime`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct LevelInput {
    /// Its level as the analyser gives it, dB.
    pub(super) frame_db: f32,
    /// The energy of its samples as the bands hear them, and of its newest hop's.
    pub(super) heard: f64,
    pub(super) newest_hop: f64,
    /// Whether it holds any sound at all (`onset::holds_sound`).
    pub(super) sound: bool,
}

/// Reads a stream's first frames ahead until it is known how the stream begins
/// ([`Self::read`]): the floors of a stream that begins with a sound start from the room
/// that follows it ([`Levels::prime`]), those of one that begins in its room from its
/// first frame, as they always did. Whichever comes first decides, each frame's level
/// compared with the first's by the rise an onset must make out of the quiet before it
/// (`rise_db`):
/// - a frame `rise_db` over every frame whose window ended before its own began, those
///   frames spanning at least `room_frames` (the room heard for as long as the
///   quiet-before gate looks back for it), and none `rise_db` under the first before:
///   the stream began in its room, and a sound now rises out of it (a sound the stream
///   begins with, a few milliseconds in, swelling, or opening softly, is no such rise);
/// - a frame `rise_db` under the first: the stream began with a sound. It goes on being
///   read until a sound rises `rise_db` out of the quietest frame since (the room after
///   the first sound has been heard), so that the floors start from the room itself;
/// - the most frames it may read: a steady stream (a room, or a long sound), judged on
///   all of them by [`Levels::prime`].
///
/// So a stream that begins in its room and soon holds a sound is read ahead no longer
/// than until that sound rises, and its decisions are not delayed.
pub(super) struct StreamStart {
    rise_db: f32,
    most: usize,
    /// Frames per window: a frame's window overlaps the `window_frames - 1` before it.
    window_frames: usize,
    /// A rise counts only from this frame on: the room before it heard for long enough.
    room_frames: usize,
    /// Each frame's level so far.
    levels: Vec<f32>,
    first_db: f32,
    /// The loudest frame whose window ended before the newest frame's began.
    loudest_db: f32,
    /// The quietest frame after one `rise_db` under the first (index, dB), once there
    /// has been one.
    quietest: Option<(usize, f32)>,
}

impl StreamStart {
    /// At most `most` frames, of `window_frames` hops each; a rise out of the room
    /// counts once `room_frames` have been heard (two windows at least).
    pub(super) fn new(rise_db: f32, most: usize, window_frames: usize, room_frames: usize) -> Self {
        Self {
            rise_db,
            most: most.max(1),
            window_frames: window_frames.max(1),
            room_frames: room_frames.max(2 * window_frames),
            levels: Vec::with_capacity(most.max(1)),
            first_db: 0.0,
            loudest_db: f32::NEG_INFINITY,
            quietest: None,
        }
    }

    /// The next frame read ahead, its power as the bands hear it (dB); once it is known
    /// how the stream begins, how many of the frames read the floors are to be primed
    /// with (0: none, the stream began in its room).
    pub(super) fn read(&mut self, heard_db: f32) -> Option<usize> {
        let f = self.levels.len();
        self.levels.push(heard_db);
        if f == 0 {
            self.first_db = heard_db;
        }
        if let Some(clear) = f.checked_sub(self.window_frames) {
            self.loudest_db = self.loudest_db.max(self.levels[clear]);
        }
        match self.quietest {
            None if f >= self.room_frames && heard_db >= self.loudest_db + self.rise_db => {
                return Some(0)
            }
            None if heard_db <= self.first_db - self.rise_db => self.quietest = Some((f, heard_db)),
            Some((_, quietest)) if heard_db >= quietest + self.rise_db => {
                return self.quietest.map(|(q, _)| q + 1);
            }
            Some((_, quietest)) if heard_db < quietest => self.quietest = Some((f, heard_db)),
            _ => {}
        }
        (self.levels.len() >= self.most).then_some(self.levels.len())
    }
}

pub(super) struct Levels {
    /// Samples per hop and per frame.
    hop: usize,
    win: usize,
    /// How far a floor may rise and fall in a frame, dB.
    rise_per_frame: f32,
    fall_per_frame: f32,
    frames: u64,
    /// Under the analyser's frame level.
    noise_floor_db: f32,
    /// Under the frame's power as the bands hear it.
    heard_floor_db: f32,
    /// The same, never lifted by the window (`FrameLevels::held`).
    held_floor_db: f32,
    /// Under the power of the last `PERIOD_HOPS` hops as the bands hear them.
    period_floor_db: f32,
    /// Energy of each of the last `PERIOD_HOPS` hops (by frame, modulo `PERIOD_HOPS`).
    hop_energies: [f64; PERIOD_HOPS],
    /// How many of `hop_energies` hold a hop's (all, once a period has come).
    period_hops_seen: usize,
    /// Per floor (noise, heard, period, held): under the sound after digital silence,
    /// rising to it as fast as a floor falls until a frame meets it.
    catching_up: [bool; 4],
    /// The last frame was digital silence.
    after_silence: bool,
    /// The heard floor when the last digital silence began (the room as last heard),
    /// and the frame where sound came back after it.
    room_before_silence_db: f32,
    resumed_at: Option<u64>,
    /// The floors were set by [`Self::prime`].
    primed: bool,
    /// The quietest of each floor's level (noise, heard, period) over the last
    /// `ROOM_WINDOW_SECONDS`: a floor is never under it.
    recent: RecentMinimum,
}

impl Levels {
    /// For frames of `win` samples, `hop` apart; each floor rises and falls at most as
    /// fast as the onset stage's band floors (`onset`).
    pub(super) fn new(win: usize, hop: usize, onset: &OnsetParams) -> Self {
        Self {
            hop,
            win,
            rise_per_frame: onset.floor_rise_db_per_s * HOP_SECONDS as f32,
            fall_per_frame: onset.floor_fall_db_per_s * HOP_SECONDS as f32,
            frames: 0,
            noise_floor_db: 0.0,
            heard_floor_db: 0.0,
            held_floor_db: 0.0,
            period_floor_db: 0.0,
            hop_energies: [0.0; PERIOD_HOPS],
            period_hops_seen: 0,
            catching_up: [false; 4],
            after_silence: false,
            room_before_silence_db: SILENT_DB,
            resumed_at: None,
            primed: false,
            recent: RecentMinimum::new(3, (ROOM_WINDOW_SECONDS / HOP_SECONDS).round() as usize),
        }
    }

    /// The room as it was heard before the last digital silence, if sound came back
    /// after that silence at frame `since` or later: a sound that begins there is heard
    /// by floors that rise to it as to a room coming back (`push`), not yet over them.
    pub(super) fn room_before_silence(&self, since: u64) -> Option<f32> {
        self.resumed_at
            .filter(|&f| f >= since)
            .map(|_| self.room_before_silence_db)
    }

    /// Whether a stream begins with a sound, from its first frames (before the first is
    /// pushed): its first frame stands `rise_db` (the rise an onset must make out of
    /// the quiet before it) over the room that follows it, the floor under the power
    /// as the bands hear it read from the last frame back to the first by the rule that
    /// makes it follow the room forwards. If it does, every floor starts from the room
    /// so read (`OnsetDetector::prime` says why); if not, the stream begins in its room
    /// and the floors start from its first frame, as they always did.
    pub(super) fn prime(&mut self, frames: &[LevelInput], rise_db: f32) -> bool {
        if !frames.first().is_some_and(|f| f.sound) {
            return false;
        }
        let (rise, fall) = (self.rise_per_frame, self.fall_per_frame);
        let back = |level: &dyn Fn(usize) -> f32| {
            let last = frames.len() - 1;
            (0..last).rev().fold(level(last), |floor, f| {
                (floor + rise).min(level(f).max(floor - fall))
            })
        };
        let heard_floor_db = back(&|f| self.heard_db(frames[f].heard));
        if self.heard_db(frames[0].heard) < heard_floor_db + rise_db {
            return false;
        }
        self.heard_floor_db = heard_floor_db;
        self.held_floor_db = heard_floor_db;
        self.noise_floor_db = back(&|f| frames[f].frame_db);
        let hop = self.hop;
        self.period_floor_db = back(&|f| {
            let hops = &frames[f.saturating_sub(PERIOD_HOPS - 1)..=f];
            let energy: f64 = hops.iter().map(|h| h.newest_hop).sum();
            Self::power_db(energy / (hops.len() * hop) as f64)
        });
        self.primed = true;
        true
    }

    fn power_db(power: f64) -> f32 {
        10.0 * (power + 1e-12).log10() as f32
    }

    /// A frame's power as the bands hear it, dB, from its energy `heard`.
    pub(super) fn heard_db(&self, heard: f64) -> f32 {
        Self::power_db(heard / self.win as f64)
    }

    /// The next frame. After digital silence (a frame without `sound`) the floors catch
    /// up with the room as the onset stage's do.
    pub(super) fn push(&mut self, frame: LevelInput) -> FrameLevels {
        let LevelInput {
            frame_db,
            heard,
            newest_hop,
            sound,
        } = frame;
        let heard_db = self.heard_db(heard);
        let first = self.frames == 0 && !self.primed;
        if !sound && !self.after_silence {
            self.room_before_silence_db = if first {
                SILENT_DB
            } else {
                self.heard_floor_db
            };
        }
        let resumed = std::mem::replace(&mut self.after_silence, !sound) && sound;
        if resumed {
            self.resumed_at = Some(self.frames);
        }
        let (rise, fall) = (self.rise_per_frame, self.fall_per_frame);
        let follow = |floor: f32, level: f32, catching: &mut bool| {
            if first {
                *catching = !sound;
                level
            } else {
                let floor = if resumed { floor.max(level) } else { floor };
                *catching |= !sound;
                let rise = if *catching && sound { fall } else { rise };
                if sound && !resumed && level <= floor + rise {
                    *catching = false;
                }
                (floor + rise).min(level.max(floor - fall))
            }
        };
        let [noise, heard_catching, period, held_catching] = &mut self.catching_up;
        self.noise_floor_db = follow(self.noise_floor_db, frame_db, noise);
        self.heard_floor_db = follow(self.heard_floor_db, heard_db, heard_catching);
        self.held_floor_db = follow(self.held_floor_db, heard_db, held_catching);
        self.hop_energies[(self.frames % PERIOD_HOPS as u64) as usize] = newest_hop;
        self.period_hops_seen = (self.period_hops_seen + 1).min(PERIOD_HOPS);
        let period_power =
            self.hop_energies.iter().sum::<f64>() / (self.period_hops_seen * self.hop) as f64;
        let period_db = Self::power_db(period_power);
        // Until a whole period is in, the floor is that of the hops so far (unless the
        // stream's start was read ahead).
        self.period_floor_db = if self.period_hops_seen == PERIOD_HOPS || self.primed {
            follow(self.period_floor_db, period_db, period)
        } else {
            period_db
        };
        for (c, (floor, level)) in [
            (&mut self.noise_floor_db, frame_db),
            (&mut self.heard_floor_db, heard_db),
            (&mut self.period_floor_db, period_db),
        ]
        .into_iter()
        .enumerate()
        {
            self.recent.push(c, level);
            if let Some(quietest) = self.recent.over_window(c) {
                *floor = floor.max(quietest);
            }
        }
        self.recent.end_frame();
        self.frames += 1;
        FrameLevels {
            sound: sound_level_db(heard_db, self.heard_floor_db),
            held: sound_level_db(heard_db, self.held_floor_db),
            rise: sound_level_db(heard_db, self.period_floor_db),
            heard: heard_db,
        }
    }

    /// The room's noise power under the analyser's frame levels (for placing an onset
    /// on the samples).
    pub(super) fn noise_power(&self) -> f64 {
        10f64.powf(f64::from(self.noise_floor_db) / 10.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATE: f64 = 22_050.0;
    const WIN: usize = 256;
    const HOP: usize = 64;

    #[test]
    fn a_room_after_digital_silence_is_no_sound_within_a_fifth_of_a_second() {
        // Noise at -30 dB after 0.5 s of zeros, muted for 0.5 s from 1.5 s.
        let zeros = |s: f64| vec![0.0f32; (s * RATE) as usize];
        let room = crate::detect::white_noise((2.0 * RATE) as usize, 0.03, 5);
        let mut x = zeros(0.5);
        x.extend_from_slice(&room);
        let muted = (1.5 * RATE) as usize..(2.0 * RATE) as usize;
        x[muted].fill(0.0);
        let levels = levels_of(&x);
        let frame = |s: f64| (s * RATE) as usize / HOP;
        // The room's noise stands under twice its floor once the floors have caught
        // up with it, after the zeros before it and after the mute.
        for (from, to) in [(0.7, 1.5), (2.2, 2.5)] {
            for l in &levels[frame(from)..frame(to) - WIN / HOP] {
                assert_eq!(l.sound, SILENT_DB, "{from}-{to} s: {l:?}");
                assert_eq!(l.rise, SILENT_DB, "{from}-{to} s: {l:?}");
            }
        }
    }

    /// A room that gets 20 dB louder for good is the room within the window; a tone
    /// held over it for as long as a held sound is, is sound over it all along.
    #[test]
    fn a_room_that_gets_louder_is_the_room_within_its_window_and_a_held_tone_is_not() {
        let n = |s: f64| (s * RATE) as usize;
        let mut x = crate::detect::white_noise(n(1.0), 0.003, 5);
        x.extend(crate::detect::white_noise(n(8.0), 0.03, 6));
        // A 1.5 s tone 20 dB over the louder room, from 6 s.
        for (k, v) in x[n(6.0)..n(7.5)].iter_mut().enumerate() {
            *v += 0.3 * (2.0 * std::f64::consts::PI * 500.0 * k as f64 / RATE).sin() as f32;
        }
        let levels = levels_of(&x);
        let frame = |s: f64| (s * RATE) as usize / HOP;
        // 2.5 s after the step the floors, rising 3 dB a second, still lie 12 dB under
        // the room; the window (and a quarter of it more, at most) lifts them to it.
        let window = ROOM_WINDOW_SECONDS;
        assert!(
            levels[frame(3.5)].sound > SILENT_DB,
            "{:?}",
            levels[frame(3.5)]
        );
        for l in &levels[frame(1.0 + 1.25 * window + 0.1)..frame(6.0) - WIN / HOP] {
            assert_eq!(l.sound, SILENT_DB, "{l:?}");
            assert_eq!(l.rise, SILENT_DB, "{l:?}");
        }
        for l in &levels[frame(6.0)..frame(7.5) - WIN / HOP] {
            assert!(l.sound > l.heard - 1.0, "{l:?}");
        }
    }

    /// What the level stage takes of each frame of `x`, as in [`levels_of`].
    fn inputs_of(x: &[f32]) -> Vec<LevelInput> {
        (WIN..=x.len())
            .step_by(HOP)
            .map(|end| {
                let energy = |from: usize| x[from..end].iter().map(|&v| f64::from(v).powi(2)).sum();
                let heard: f64 = energy(end - WIN);
                LevelInput {
                    frame_db: Levels::power_db(heard / WIN as f64),
                    heard,
                    newest_hop: energy(end - HOP),
                    sound: heard > 0.0,
                }
            })
            .collect()
    }

    /// After digital silence (a noise gate closed) the room as last heard before it is
    /// kept for a sound that begins when the silence ends, and only for that one.
    #[test]
    fn the_room_before_digital_silence_is_kept_for_the_sound_after_it() {
        let n = |s: f64| (s * RATE) as usize;
        let mut x = crate::detect::white_noise(n(1.0), 0.003, 5);
        x.extend(vec![0.0; n(0.3)]);
        x.extend(crate::detect::white_noise(n(0.3), 0.1, 6));
        let mut levels = Levels::new(WIN, HOP, &OnsetParams::default());
        let mut resumed = None;
        let mut room = f32::NAN;
        for (f, input) in inputs_of(&x).into_iter().enumerate() {
            let was_silent = levels.after_silence;
            if input.sound && !was_silent && levels.frames > 0 && resumed.is_none() {
                room = levels.heard_floor_db;
            }
            levels.push(input);
            if was_silent && input.sound {
                resumed = Some(f as u64);
            }
        }
        let resumed = resumed.expect("sound after the silence");
        // The room of uniform noise of amplitude 0.003 (power 3e-6, -55 dB), as last
        // heard before the silence; not the floors that caught up with the sound.
        let kept = levels.room_before_silence(resumed).expect("kept");
        assert!(
            (kept - room).abs() < 1.0 && kept < -50.0,
            "{kept} dB, room {room} dB"
        );
        assert_eq!(levels.room_before_silence(resumed + 1), None);
        assert!(
            levels.heard_floor_db > kept + 20.0,
            "{}",
            levels.heard_floor_db
        );
    }

    #[test]
    fn a_stream_that_begins_with_a_sound_is_told_from_one_that_begins_in_its_room() {
        let n = |s: f64| (s * RATE) as usize;
        let room = crate::detect::white_noise(n(0.5), 0.003, 5);
        // A hit of 30 ms, 30 dB over the room, at the first sample.
        let mut hit = room.clone();
        for (k, x) in crate::detect::white_noise(n(0.03), 0.1, 6)
            .iter()
            .enumerate()
        {
            hit[k] += x;
        }
        let mut zeros_after = crate::detect::white_noise(n(0.03), 0.1, 6);
        zeros_after.resize(n(0.5), 0.0);
        let begins =
            |x: &[f32]| Levels::new(WIN, HOP, &OnsetParams::default()).prime(&inputs_of(x), 10.0);
        assert!(begins(&hit));
        assert!(begins(&zeros_after));
        assert!(!begins(&room));
        assert!(!begins(&vec![0.0; n(0.5)]));
        // Primed, the hit stands out of the room in the first frame.
        let mut levels = Levels::new(WIN, HOP, &OnsetParams::default());
        let inputs = inputs_of(&hit);
        levels.prime(&inputs, 10.0);
        let first = inputs[0];
        let l = levels.push(first);
        assert!(l.sound > -25.0 && l.rise > -25.0, "{l:?}");
        let mut unprimed = Levels::new(WIN, HOP, &OnsetParams::default());
        let l = unprimed.push(first);
        assert_eq!(l.sound, SILENT_DB, "{l:?}");
    }

    /// The frames `StreamStart` reads of `levels` (dB, one a frame, windows of 4 hops)
    /// before it knows how the stream begins, and what it then says.
    fn stream_start(levels: &[f32]) -> (usize, Option<usize>) {
        let mut start = StreamStart::new(10.0, 100, 4, 14);
        for (f, &l) in levels.iter().enumerate() {
            if let Some(prime) = start.read(l) {
                return (f + 1, Some(prime));
            }
        }
        (levels.len(), None)
    }

    #[test]
    fn how_a_stream_begins_is_known_as_soon_as_its_levels_tell() {
        let room = [-60.0f32; 20];
        // A room, then a sound that rises out of it over a window's frames: known at
        // its first frame 10 dB over the room; nothing primed.
        let mut x = room.to_vec();
        x.extend([-57.0, -53.0, -49.0, -45.0, -30.0]);
        assert_eq!(stream_start(&x), (23, Some(0)));
        // A sound that swells from its first frame, 2 dB a frame: no frame stands 10
        // dB over the frames whose windows ended before its own.
        let swell: Vec<f32> = (0..8).map(|k| -40.0 + 2.0 * k as f32).collect();
        assert_eq!(stream_start(&swell).1, None);
        // A soft opening of 10 frames, then the burst: the opening is too short to be
        // the room (the bundled "pop" take, analysed alone).
        let mut x = vec![-50.0f32; 10];
        x.extend([-30.0, -25.0, -35.0]);
        assert_eq!(stream_start(&x).1, None);
        // A hit, its tail, the room, then another sound: the floors are primed with
        // the frames up to the quietest before the second sound.
        let mut x = vec![-20.0f32, -24.0, -32.0, -45.0, -58.0, -60.0, -61.0, -60.0];
        x.extend([-55.0, -45.0]);
        assert_eq!(stream_start(&x), (10, Some(7)));
        // A steady stream: every frame it may read, then judged on all of them.
        assert_eq!(stream_start(&[-60.0; 100]), (100, Some(100)));
    }

    #[test]
    fn the_period_hops_cover_a_period_of_50_hz_mains_and_less_than_a_hop_more() {
        let covered = PERIOD_HOPS as f64 * HOP_SECONDS;
        let period = 1.0 / 50.0;
        assert!(
            covered >= period && covered - HOP_SECONDS < period,
            "{covered} s"
        );
    }

    /// Each frame's levels for `x`, its frames as the matcher makes them (the
    /// analyser's level taken as the heard power's).
    fn levels_of(x: &[f32]) -> Vec<FrameLevels> {
        let mut levels = Levels::new(WIN, HOP, &OnsetParams::default());
        inputs_of(x).into_iter().map(|i| levels.push(i)).collect()
    }

    /// Mains hum as the bands hear it: the harmonics of 50 Hz, each as loud as a
    /// sawtooth's (1/k), from the second (the fundamental lies under the low cut), 40 dB
    /// under full scale at its peaks.
    fn hum(seconds: f64) -> Vec<f32> {
        let at = |n: usize| -> f64 {
            let t = n as f64 / RATE;
            (2..=8)
                .map(|k| (2.0 * std::f64::consts::PI * 50.0 * k as f64 * t).sin() / k as f64)
                .sum()
        };
        let peak = (0..(RATE / 50.0) as usize)
            .map(|n| at(n).abs())
            .fold(0.0, f64::max);
        (0..(seconds * RATE) as usize)
            .map(|n| (0.01 * at(n) / peak) as f32)
            .collect()
    }

    #[test]
    fn over_steady_hum_the_rise_hears_no_sound_where_a_frame_swings_with_its_phase() {
        let levels = levels_of(&hum(3.0));
        // Once every floor has settled: the last second.
        let settled = &levels[levels.len() - (RATE / HOP as f64) as usize..];
        let swinging = settled.iter().filter(|l| l.sound > SILENT_DB).count();
        let rising = settled.iter().filter(|l| l.rise > SILENT_DB).count();
        assert!(
            swinging > settled.len() / 10,
            "{swinging} of {}",
            settled.len()
        );
        assert_eq!(rising, 0, "{rising} of {}", settled.len());
    }

    #[test]
    fn a_burst_over_hum_rises_with_its_own_power_out_of_silence() {
        let mut x = hum(2.0);
        let at = (1.5 * RATE) as usize;
        // A tone over the hum, -29 dB.
        let amplitude = 0.05f32;
        for (n, v) in x[at..at + 2 * WIN].iter_mut().enumerate() {
            *v += amplitude * (2.0 * std::f32::consts::PI * 1000.0 * n as f32 / RATE as f32).sin();
        }
        let levels = levels_of(&x);
        let burst_db = 10.0 * (amplitude * amplitude / 2.0).log10();
        // Frame k's window ends at sample WIN + k HOP.
        let (before, inside) = (at / HOP - WIN / HOP - 1, at / HOP + 2);
        assert_eq!(levels[before].rise, SILENT_DB);
        let rise = levels[inside].rise;
        assert!((rise - burst_db).abs() < 1.0, "{rise} dB for {burst_db} dB");
    }

    #[test]
    fn a_full_scale_burst_lifts_no_floor_so_a_sound_after_it_rises_as_before() {
        // The room: steady noise-like hiss 50 dB under full scale (a fixed sequence).
        let mut state = 1u32;
        let mut hiss = |_| {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            0.003 * ((state >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 2.0
        };
        let room: Vec<f32> = (0..(2.0 * RATE) as usize).map(&mut hiss).collect();
        let tone_at = (1.6 * RATE) as usize;
        let with_tone = |mut x: Vec<f32>| {
            for (n, v) in x[tone_at..tone_at + 2 * WIN].iter_mut().enumerate() {
                *v += 0.03 * (2.0 * std::f32::consts::PI * 1000.0 * n as f32 / RATE as f32).sin();
            }
            x
        };
        let mut burst = room.clone();
        // 10 ms at full scale, 0.3 s before the tone.
        let burst_at = tone_at - (0.3 * RATE) as usize;
        for v in &mut burst[burst_at..burst_at + (0.01 * RATE) as usize] {
            *v = if *v >= 0.0 { 1.0 } else { -1.0 };
        }
        let (plain, after_burst) = (levels_of(&with_tone(room)), levels_of(&with_tone(burst)));
        let inside = tone_at / HOP + 2;
        let (a, b) = (plain[inside], after_burst[inside]);
        assert!(a.sound > SILENT_DB && a.rise > SILENT_DB, "{a:?}");
        assert!(
            (a.sound - b.sound).abs() < 0.5,
            "{a:?} without the burst, {b:?} after it"
        );
        assert!(
            (a.rise - b.rise).abs() < 0.5,
            "{a:?} without the burst, {b:?} after it"
        );
    }
}
