//! Builds the background model of `src/detect/background.rs` from the speech that
//! `scripts/background-speech.sh` synthesises: the features of every onset that stands
//! out of its quiet, pooled as the spectral matcher with the default settings pools
//! them, from every WAV in a folder (in name order), each heard over the least noise an
//! input carries ([`add_least_input_noise`]).
//!
//!     bash scripts/background-speech.sh /tmp/background
//!     cargo run --release --example background_model -- /tmp/background src/detect/background.bin

use std::path::PathBuf;

use onomato::audio::{resample_clip, ChannelSelect, WavSource};
use onomato::config::DetectorSettings;
use onomato::detect::background::{add_least_input_noise, BackgroundModel};
use onomato::detect::spectral::background_model;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [dir, out] = args.as_slice() else {
        return Err("usage: background_model SPEECH_DIR OUT_FILE".into());
    };
    let settings = DetectorSettings::default();
    let mut wavs: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "wav"))
        .collect();
    wavs.sort();
    let (mut features, mut frames, mut templates) = (0, 0, Vec::new());
    for path in &wavs {
        let mut source = WavSource::open(path, ChannelSelect::Mix)?;
        let rate = source.sample_rate();
        let mut samples = resample_clip(&source.read_all()?, rate, settings.sample_rate)?;
        add_least_input_noise(&mut samples);
        let model = background_model(&samples, &settings);
        println!("{}: {} onsets", path.display(), model.len());
        (features, frames) = model.shape();
        templates.extend_from_slice(model.templates());
    }
    let model = BackgroundModel::new(features, frames, templates);
    std::fs::write(out, model.to_bytes())?;
    println!(
        "{out}: {} templates of {features} features over {frames} frames",
        model.len()
    );
    Ok(())
}
