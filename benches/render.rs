//! `cargo bench --bench render`: what `onomato render` computes in Rust for the bundled
//! example's length (10 s at 60 fps, 1280x720): drawing each scene (the shapes of all
//! 601 frames) and rasterising one frame. The whole command, ffmpeg's encoding
//! included, is timed by `scripts/bench-render.sh`.

use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use onomato::config::{PatternKind, RenderSettings};
use onomato::detect::Event;
use onomato::render::video::Rasteriser;
use onomato::render::{animate, patterns_of_events, Actions, FrameSettings, Scene};

/// The bundled example's timeline (examples/beat.truth.csv): impulses and two held
/// sounds over 10 s.
fn events() -> Vec<Event> {
    let placed = [
        (0.40, "tick", None, 1.0),
        (0.95, "tick", None, 0.5),
        (1.50, "pop", None, 0.9),
        (2.10, "tick", None, 0.8),
        (2.45, "boom", None, 1.0),
        (3.30, "hoo", Some(3.93), 0.8),
        (5.00, "pop", None, 0.6),
        (5.45, "tick", None, 0.9),
        (5.80, "boom", None, 0.7),
        (6.60, "tick", None, 0.4),
        (7.05, "pop", None, 1.0),
        (7.60, "boom", None, 0.5),
        (8.30, "hoo", Some(8.93), 0.5),
    ];
    placed
        .iter()
        .enumerate()
        .map(|(i, &(time, pattern, end, strength))| Event {
            id: i as u64,
            pattern: Arc::from(pattern),
            kind: if end.is_some() {
                PatternKind::Continuous
            } else {
                PatternKind::Impulse
            },
            time,
            end,
            strength,
            score: 1.0,
            emitted_at: end.unwrap_or(time),
            pitch: None,
        })
        .collect()
}

const FRAMES: FrameSettings = FrameSettings {
    fps: 60,
    width: 1280,
    height: 720,
};

const SCENES: [Scene; 5] = [
    Scene::Ball,
    Scene::Timeline,
    Scene::Rain,
    Scene::Darts,
    Scene::Laser,
];

fn bench_render(c: &mut Criterion) {
    let tracks = vec![events()];
    let actions = Actions::new(
        &RenderSettings::default(),
        None,
        &patterns_of_events(&tracks),
    );
    let mut group = c.benchmark_group("render");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(4));
    for scene in SCENES {
        group.bench_with_input(
            BenchmarkId::new("animate_10s", scene.name()),
            &scene,
            |b, &scene| b.iter(|| animate(scene, black_box(&tracks), &actions, FRAMES, 10.0)),
        );
        let animation = animate(scene, &tracks, &actions, FRAMES, 10.0);
        let mut raster = Rasteriser::new(&animation).expect("a 1280x720 frame");
        let mut k = 0;
        group.bench_with_input(
            BenchmarkId::new("rasterise_frame_1280x720", scene.name()),
            &scene,
            |b, _| {
                b.iter(|| {
                    k = (k + 37) % animation.frames.len();
                    black_box(raster.frame(&animation, k)[0])
                })
            },
        );
    }
    group.finish();
}

criterion_group!(benches, bench_render);
criterion_main!(benches);
