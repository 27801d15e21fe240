//! The detector's per-block work allocates nothing: it will run on the daemon's
//! detector thread, fed from the audio ring. A counting global allocator watches the
//! test's own thread while blocks go through `Detector::process`, with impulses,
//! continuous spans and the resampler all at work. Then the daemon's whole detector
//! stage: reading the ring, mixing channels down, detecting and handing events to the
//! output channel.

mod common;

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use common::*;
use onomato::config::{DetectorSettings, Method};
use onomato::{Detector, Event};

struct CountingAllocator;

thread_local! {
    // const-initialised, no destructor: reading it never allocates.
    static WATCHING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if WATCHING.with(Cell::get) {
            ALLOCATIONS.with(|n| n.set(n.get() + 1));
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if WATCHING.with(Cell::get) {
            ALLOCATIONS.with(|n| n.set(n.get() + 1));
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Allocations made by `f` on this thread.
fn allocations_in(f: impl FnOnce()) -> usize {
    ALLOCATIONS.with(|n| n.set(0));
    WATCHING.with(|w| w.set(true));
    f();
    WATCHING.with(|w| w.set(false));
    ALLOCATIONS.with(Cell::get)
}

fn scene() -> Vec<f32> {
    let mut rec = vec![0.0f32; samples_for(12.0, RATE)];
    let mut at = samples_for(0.3, RATE);
    let mut k = 0;
    for (_, p) in three_impulses().iter().cycle().take(18) {
        place(&mut rec, p, at, 0.8);
        at += samples_for(0.45, RATE);
        k += 1;
    }
    assert_eq!(k, 18);
    place(
        &mut rec,
        &buzz(RATE, 1.2, 140.0),
        samples_for(9.5, RATE),
        0.6,
    );
    add_noise(&mut rec, 0.002, 2);
    rec
}

/// Three impulse patterns and a held hum, for `method`.
fn check(method: Method, input_rate: u32, block: usize) {
    let (settings, patterns) = patterns_for(method);
    let rec = onomato::audio::resample_clip(&scene(), RATE, input_rate).unwrap();
    let mut det = Detector::new(patterns, &settings, input_rate).unwrap();
    let mut events: Vec<Event> = Vec::with_capacity(256);
    // The first second warms up nothing in particular; it is here so that any lazy
    // one-time set-up (were there one) is not mistaken for per-block work.
    let warm = input_rate as usize;
    for chunk in rec[..warm].chunks(block) {
        det.process(chunk, &mut events);
    }
    let n = allocations_in(|| {
        for chunk in rec[warm..].chunks(block) {
            det.process(chunk, &mut events);
        }
    });
    assert_eq!(
        n, 0,
        "{n} allocations while processing at {input_rate} Hz, blocks of {block}"
    );
    det.finish(&mut events);
    // The bound the live bounce solver relies on holds for every impulse.
    let bound = det.decision_delay_bound();
    for e in events.iter().filter(|e| e.end.is_none()) {
        assert!(
            e.emitted_at - e.time <= bound,
            "{method:?}: decided {:.4} s after the onset, bound {bound:.4} s",
            e.emitted_at - e.time
        );
    }
    let impulses = events.iter().filter(|e| e.end.is_none()).count();
    let held = events.iter().filter(|e| e.end.is_some()).count();
    assert_eq!(
        (impulses, held),
        (18, 1),
        "the run detected what it should: {events:#?}"
    );
}

#[test]
fn processing_blocks_allocates_nothing_at_the_working_rate() {
    check(Method::Waveform, RATE, 256);
    check(Method::Spectral, RATE, 256);
}

/// The stream's first frames are read ahead, and its floors primed from them, when it
/// begins with a sound: that too allocates nothing, counted from the first block.
#[test]
fn a_stream_that_begins_with_a_sound_allocates_nothing_from_its_first_block() {
    let (settings, patterns) = patterns_for(Method::Spectral);
    let rec = scene();
    let rec = &rec[samples_for(0.3, RATE)..];
    let mut det = Detector::new(patterns, &settings, RATE).unwrap();
    let mut events: Vec<Event> = Vec::with_capacity(256);
    let n = allocations_in(|| {
        for chunk in rec.chunks(256) {
            det.process(chunk, &mut events);
        }
    });
    assert_eq!(n, 0, "{n} allocations from the stream's first block");
    det.finish(&mut events);
    let first = events.first().expect("no event");
    assert!(
        first.time < 0.005,
        "the first sound was not found: {first:?}"
    );
    assert_eq!(events.iter().filter(|e| e.end.is_none()).count(), 18);
}

#[test]
fn processing_blocks_allocates_nothing_through_the_resampler() {
    check(Method::Waveform, 48_000, 480);
    check(Method::Spectral, 48_000, 480);
}

/// Full-band takes heard through a 16 kHz source resampled to 48 kHz on its way in: the
/// stream shows its band with its first sound, and the comparison is made again for the
/// bands it carries while blocks are processed, allocating nothing.
#[test]
fn a_stream_found_to_carry_fewer_bands_is_followed_without_allocating() {
    let (settings, patterns) = patterns_for(Method::Spectral);
    let narrow = onomato::audio::resample_clip(&scene(), RATE, 16_000).unwrap();
    let rec = onomato::audio::resample_clip(&narrow, 16_000, 48_000).unwrap();
    let mut det = Detector::new(patterns, &settings, 48_000).unwrap();
    assert_eq!(det.compared_top_hz(), None, "the takes carry every band");
    let mut events: Vec<Event> = Vec::with_capacity(256);
    let n = allocations_in(|| {
        for chunk in rec.chunks(480) {
            det.process(chunk, &mut events);
        }
    });
    assert_eq!(n, 0, "{n} allocations while following the stream's band");
    let top = det
        .compared_top_hz()
        .expect("the stream's band is followed");
    assert!((5_000.0..8_000.0).contains(&top), "compared up to {top} Hz");
    det.finish(&mut events);
    let impulses = events.iter().filter(|e| e.end.is_none()).count();
    assert!(
        impulses >= 17,
        "{impulses} of 18 impulses found: {events:#?}"
    );
    // The bound the live bounce solver takes at start holds over the bands compared later.
    let bound = det.decision_delay_bound();
    for e in events.iter().filter(|e| e.end.is_none()) {
        let late = e.emitted_at - e.time;
        assert!(
            late <= bound,
            "decided {late:.4} s after, bound {bound:.4} s"
        );
    }
}

/// The daemon's detector thread work, block by block: stereo frames from the ring at
/// 48 kHz, given to two performers (the left channel, and the mix), resampled,
/// detected, handed over with `try_send`.
fn check_stage(method: Method) {
    use onomato::audio::ChannelSelect;
    use onomato::daemon::{DetectorStage, LaneDetector, Status};
    use onomato::output::OutputMessage;
    use std::sync::Arc;

    let (settings, patterns) = patterns_for(method);
    let rate = 48_000;
    let mono = onomato::audio::resample_clip(&scene(), RATE, rate).unwrap();
    let stereo: Vec<f32> = mono.iter().flat_map(|&x| [x, x]).collect();
    let lanes = [ChannelSelect::Index(0), ChannelSelect::Mix]
        .into_iter()
        .map(|select| LaneDetector {
            detector: Detector::new(patterns.clone(), &settings, rate).unwrap(),
            select,
        })
        .collect();
    let (mut producer, consumer) = rtrb::RingBuffer::<f32>::new(48_000 * 2);
    let (tx, rx) = std::sync::mpsc::sync_channel::<OutputMessage>(1024);
    let mut stage = DetectorStage::new(lanes, consumer, 2, 256, tx, Arc::new(Status::default()));
    let feed = 2 * 256;
    let warm = 2 * rate as usize;
    for chunk in stereo[..warm].chunks(feed) {
        let (_, rest) = producer.push_partial_slice(chunk);
        assert!(rest.is_empty(), "the ring holds a block");
        stage.poll(false);
    }
    let n = allocations_in(|| {
        for chunk in stereo[warm..].chunks(feed) {
            let (_, rest) = producer.push_partial_slice(chunk);
            assert!(rest.is_empty(), "the ring holds a block");
            while stage.poll(false) > 0 {}
        }
    });
    assert_eq!(n, 0, "{n} allocations in the detector stage ({method:?})");
    stage.finish();
    let events: Vec<(usize, Event)> = rx
        .try_iter()
        .filter_map(|m| match m {
            OutputMessage::Event(lane, e) => Some((lane, e)),
            _ => None,
        })
        .collect();
    for lane in 0..2 {
        let events: Vec<&Event> = events
            .iter()
            .filter(|(l, _)| *l == lane)
            .map(|(_, e)| e)
            .collect();
        let impulses = events
            .iter()
            .filter(|e| e.kind == onomato::PatternKind::Impulse)
            .count();
        let held = events.iter().filter(|e| e.end.is_some()).count();
        assert_eq!((impulses, held), (18, 1), "performer {lane}: {events:#?}");
    }
}

#[test]
fn the_daemon_detector_stage_allocates_nothing_per_block() {
    check_stage(Method::Waveform);
    check_stage(Method::Spectral);
}

#[test]
fn the_counter_sees_allocations() {
    // Guards the guard: an allocation on this thread is counted.
    let n = allocations_in(|| {
        let v: Vec<u64> = Vec::with_capacity(std::hint::black_box(32));
        std::hint::black_box(v);
    });
    assert_eq!(n, 1);
}

/// Two patterns that open with the same 30 ms burst and part on what follows: a choice
/// between them waits for more of the sound (`max_decision_seconds`). That path too
/// allocates nothing, stays within the decision delay bound, and gives the same events
/// whatever the block size.
#[test]
fn deciding_between_patterns_alike_at_first_allocates_nothing_and_ignores_block_size() {
    let settings = DetectorSettings {
        method: Method::Spectral,
        ..DetectorSettings::default()
    };
    // The burst 20 dB under what follows, as a "p" under its vowel.
    let opening: Vec<f32> = noise_burst(RATE, 0.03, 1.0, 31)
        .iter()
        .map(|x| 0.1 * x)
        .collect();
    let then = |rest: Vec<f32>| -> Vec<f32> { opening.iter().copied().chain(rest).collect() };
    let low = then(sweep(RATE, 0.15, 300.0, 250.0, 0.08));
    let high = then(sweep(RATE, 0.15, 2500.0, 2000.0, 0.08));
    let patterns = vec![
        impulse("low", low.clone(), &settings),
        impulse("high", high.clone(), &settings),
    ];
    let mut rec = vec![0.0f32; samples_for(6.0, RATE)];
    let mut truth = Vec::new();
    for i in 0..10 {
        let (name, sound) = if i % 3 == 0 {
            ("high", &high)
        } else {
            ("low", &low)
        };
        let at = samples_for(0.4 + 0.5 * i as f64, RATE);
        place(&mut rec, sound, at, 0.7);
        truth.push((name, at as f64 / f64::from(RATE)));
    }
    add_noise(&mut rec, 0.001, 5);
    let run = |block: usize, watch: bool| -> (Vec<Event>, usize, f64) {
        let mut det = Detector::new(patterns.clone(), &settings, RATE).unwrap();
        let mut events: Vec<Event> = Vec::with_capacity(64);
        let warm = samples_for(0.3, RATE);
        for chunk in rec[..warm].chunks(block) {
            det.process(chunk, &mut events);
        }
        let mut go = || {
            for chunk in rec[warm..].chunks(block) {
                det.process(chunk, &mut events);
            }
        };
        let n = if watch {
            allocations_in(go)
        } else {
            go();
            0
        };
        det.finish(&mut events);
        (events, n, det.decision_delay_bound())
    };
    let (events, n, bound) = run(256, true);
    assert_eq!(n, 0, "{n} allocations");
    let found: Vec<(&str, f64)> = events.iter().map(|e| (&*e.pattern, e.time)).collect();
    assert_eq!(found.len(), truth.len(), "{found:?}");
    for ((name, at), e) in truth.iter().zip(&events) {
        assert_eq!(&*e.pattern, *name, "{found:?}");
        assert!((e.time - at).abs() < 0.01, "{found:?}");
        // It waited for the part after the shared opening, and no longer than the bound.
        assert!(
            e.emitted_at - e.time > settings.decision_seconds + 0.005,
            "{e:?}"
        );
        assert!(e.emitted_at - e.time <= bound, "{e:?}, bound {bound}");
    }
    for block in [1, 7, 4096] {
        assert_eq!(run(block, false).0, events, "blocks of {block}");
    }
}

#[test]
fn a_cut_off_the_output_thread_cannot_take_yet_waits_without_blocking_detection_or_reordering() {
    use onomato::audio::ChannelSelect;
    use onomato::daemon::{DetectorStage, LaneDetector, Status};
    use onomato::output::OutputMessage;
    use std::sync::Arc;

    let (settings, patterns) = patterns_for(Method::Spectral);
    let rate = RATE;
    let mono = scene();
    let det = LaneDetector {
        detector: Detector::new(patterns, &settings, rate).unwrap(),
        select: ChannelSelect::Mix,
    };
    let (mut producer, consumer) = rtrb::RingBuffer::<f32>::new(rate as usize);
    // A queue of two that nobody reads for a while: an output thread that is stuck.
    let (tx, rx) = std::sync::mpsc::sync_channel::<OutputMessage>(2);
    let status = Arc::new(Status::default());
    let mut stage = DetectorStage::new(vec![det], consumer, 1, 256, tx, status.clone());
    let third = mono.len() / 3;
    let mut feed = |stage: &mut DetectorStage, part: &[f32]| {
        for chunk in part.chunks(256) {
            let (_, rest) = producer.push_partial_slice(chunk);
            assert!(rest.is_empty());
            while stage.poll(false) > 0 {}
        }
    };
    let mut got = Vec::new();
    for chunk in mono[..third].chunks(256 * 8) {
        feed(&mut stage, chunk);
        got.extend(rx.try_iter());
    }
    let before = got.len();
    assert!(before > 0);
    // The queue fills and stays full; the cut-off and what follows it must wait, and
    // detection goes on without waiting and without allocating.
    feed(&mut stage, &mono[third..third + rate as usize / 2]);
    stage.send_control(OutputMessage::CutOff);
    let n = allocations_in(|| feed(&mut stage, &mono[third + rate as usize / 2..2 * third]));
    assert_eq!(n, 0, "{n} allocations while the cut-off waited");
    // The output thread comes back: everything arrives in order, the cut-off after
    // every event decided before it and before every event decided after it.
    for chunk in mono[2 * third..].chunks(256 * 8) {
        got.extend(rx.try_iter());
        feed(&mut stage, chunk);
    }
    stage.finish();
    got.extend(rx.try_iter());
    let cut = got
        .iter()
        .position(|m| matches!(m, OutputMessage::CutOff))
        .expect("the cut-off never arrived");
    let ids: Vec<(usize, u64)> = got
        .iter()
        .enumerate()
        .filter_map(|(i, m)| match m {
            OutputMessage::Event(_, e)
                if e.end.is_none() || e.kind == onomato::PatternKind::Impulse =>
            {
                Some((i, e.id))
            }
            _ => None,
        })
        .collect();
    assert!(ids.windows(2).all(|w| w[0].1 < w[1].1), "{ids:?}");
    assert!(
        ids.iter().any(|&(i, _)| i > cut),
        "nothing after the cut-off"
    );
    let decided_while_full = status.dropped_events();
    assert!(decided_while_full > 0, "the queue never filled");
}
