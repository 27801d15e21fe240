//! False onsets per minute of steady noise, for the onset stage alone, over a grid of
//! its two noise settings (`floor_weight`, `threshold_db`): the table from which the
//! defaults are chosen (docs/onset-stage.md).
//!
//!     cargo run --release --example onset_sweep
//!
//! Noise is white and red (one-pole, 0.95), 60 s each, at -60, -30 and -10 dBFS (RMS),
//! at the working rate of 22.05 kHz. The onset function is a log ratio, so its counts
//! should not depend on the level: the table shows whether they do.

use onomato::detect::onset::OnsetParams;
use onomato::detect::spectral::onset_times;

const RATE: f64 = 22_050.0;

fn noise(seconds: f64, rms_db: f64, red: bool, seed: u64) -> Vec<f32> {
    let mut state = seed | 1;
    let mut last = 0.0f64;
    let raw: Vec<f64> = (0..(seconds * RATE) as usize)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let white = (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
            if red {
                last = 0.95 * last + white;
                last
            } else {
                white
            }
        })
        .collect();
    let rms = (raw.iter().map(|x| x * x).sum::<f64>() / raw.len() as f64).sqrt();
    let gain = 10f64.powf(rms_db / 20.0) / rms;
    raw.iter().map(|x| (x * gain) as f32).collect()
}

fn main() {
    let levels = [-60.0, -30.0, -10.0];
    let signals: Vec<(String, Vec<f32>)> = [false, true]
        .iter()
        .flat_map(|&red| {
            levels.iter().enumerate().map(move |(i, &db)| {
                let name = format!("{} {db} dB", if red { "red" } else { "white" });
                (name, noise(60.0, db, red, 17 + i as u64))
            })
        })
        .collect();
    print!("| floor_weight | threshold_db |");
    for (name, _) in &signals {
        print!(" {name} |");
    }
    println!();
    println!("|---|---|{}", "---|".repeat(signals.len()));
    for floor_weight in [1.0, 4.0, 8.0, 16.0, 64.0] {
        for threshold_db in [0.5, 0.75, 1.0, 1.5, 2.0] {
            let params = OnsetParams {
                floor_weight,
                threshold_db,
                ..OnsetParams::default()
            };
            print!("| {floor_weight} | {threshold_db} |");
            for (_, signal) in &signals {
                print!(" {} |", onset_times(signal, RATE, params).len());
            }
            println!();
        }
    }
}
