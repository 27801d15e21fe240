//! Accuracy and latency on real human vocal percussion, for both methods.
//!
//!     cargo run --release --example eval_beatbox -- BEATBOX_DIR [--method waveform|spectral]
//!         [--threshold X] [--verbose]
//!         [--set isolated|beats|repeated] [--speech-guard SECONDS] [--min-strength X]
//!         [--decision-seconds SECONDS]
//!
//! BEATBOX_DIR holds isolated/{b,c,ts}/*.wav (single hits), beats/*.wav with their
//! annotation CSVs, and repeated/*.wav (see the recordings' own README). Recordings are
//! fed to the detector at their own rate (44.1 kHz), so its resampler is part of what
//! is measured, latency included. The sets:
//! - isolated: take 01 of each class is enrolled; the other takes are laid out with
//!   gaps of 30-700 ms (and, in the "tight" set, 30-120 ms), gains of -9..0 dB and low
//!   noise. The truth onset of a take is its first 1 ms block within 20 dB of its
//!   loudest.
//! - beats: one instance of each label is enrolled from rec2 (cut around its annotated
//!   onset) and detected on rec3 (also resampled to 48 kHz) and rec4; rec6's labels
//!   that rec2 lacks are enrolled from rec6's first instance (its lip buzz "BB" as a
//!   continuous pattern), and rec6 is detected whole.
//!   A take whose derived labels are off by whole steps of the beat (`label_phase`, a
//!   check on the audio alone) is scored both as given and with its labels moved.
//! - repeated: each file repeats one sound; the first instance of every file is
//!   enrolled, and every repetition must be found with its own file's label. Onsets
//!   come from a simple energy rule (`repeated_onsets`), as the files have no labels.
//!
//! Scores: `onomato::eval` (label and onset within 50 ms, one to one). Every recording
//! is detected in blocks of 256 samples, and again in blocks of 64 and 1024, which must
//! give the very same events.

#[path = "../tests/common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use common::Rng;
use onomato::analyze::detect_in_blocks;
use onomato::audio::{resample_clip, ChannelSelect, WavSource};
use onomato::config::{DetectorSettings, Method, PatternKind};
use onomato::eval::{load_truth, score, Annotation, Score};
use onomato::{Detector, Event, Pattern};

/// A recording at its own rate, mono.
struct Audio {
    samples: Vec<f32>,
    rate: u32,
}

fn read(path: &Path) -> Audio {
    let mut src = WavSource::open(path, ChannelSelect::Mix).unwrap_or_else(|e| panic!("{e}"));
    let rate = src.sample_rate();
    let samples = src.read_all().unwrap_or_else(|e| panic!("{e}"));
    Audio { samples, rate }
}

/// Onset of the hit in a take: the first 1 ms block of the run of blocks within 20 dB
/// of the loudest that holds the loudest (gaps under 10 ms do not end a run). The first
/// such block of the whole take would be the same but for a take that opens with the
/// tail of another sound: isolated/b/zingerbox_04.wav has a 10 ms blip at its start and
/// 60 ms of quiet before its kick.
fn energy_onset(x: &[f32], rate: u32) -> usize {
    let block = (rate / 1000) as usize;
    let energies: Vec<f32> = x
        .chunks(block)
        .map(|c| c.iter().map(|v| v * v).sum())
        .collect();
    let (mut onset, loudest) = energies.iter().cloned().enumerate().fold(
        (0, 0.0),
        |best, (i, e)| if e > best.1 { (i, e) } else { best },
    );
    const MAX_GAP_BLOCKS: usize = 10;
    while let Some(earlier) =
        (onset.saturating_sub(MAX_GAP_BLOCKS)..onset).find(|&j| energies[j] >= loudest / 100.0)
    {
        onset = earlier;
    }
    onset * block
}

/// A pattern from takes each at its own rate (resampled to the working rate for
/// enrolment).
fn pattern(name: &str, kind: PatternKind, takes: &[Audio], settings: &DetectorSettings) -> Pattern {
    let takes = takes
        .iter()
        .map(|t| resample_clip(&t.samples, t.rate, settings.sample_rate).unwrap())
        .collect();
    Pattern::from_samples(name, kind, takes, settings).unwrap_or_else(|e| panic!("{e}"))
}

/// Block sizes every recording is detected with; the first gives the events scored.
const BLOCK_SIZES: [usize; 3] = [256, 64, 1024];
/// Detections checked for the same events at every block size.
static BLOCK_CHECKS: AtomicUsize = AtomicUsize::new(0);

/// The events of `rec`, detected in blocks of 256 samples; also detected in blocks of 64
/// and 1024, which must give the very same events (the process ends with an error if
/// not).
fn detect(patterns: &[Pattern], settings: &DetectorSettings, rec: &Audio) -> Vec<Event> {
    let runs: Vec<Vec<Event>> = BLOCK_SIZES
        .iter()
        .map(|&block| {
            let mut det = Detector::new(patterns.to_vec(), settings, rec.rate).unwrap();
            detect_in_blocks(&mut det, &rec.samples, block)
        })
        .collect();
    for (run, block) in runs.iter().zip(BLOCK_SIZES).skip(1) {
        if *run != runs[0] {
            eprintln!(
                "error: blocks of {block} samples gave other events than blocks of {} ({:?} method): {} against {} events",
                BLOCK_SIZES[0],
                settings.method,
                run.len(),
                runs[0].len()
            );
            std::process::exit(1);
        }
    }
    BLOCK_CHECKS.fetch_add(1, Ordering::Relaxed);
    runs.into_iter().next().unwrap()
}

fn run(
    patterns: &[Pattern],
    settings: &DetectorSettings,
    rec: &Audio,
    truth: &[Annotation],
) -> Score {
    score(&detect(patterns, settings, rec), truth, 0.05)
}

/// Which instances of each sound are enrolled (the first `takes`, as one pattern's
/// takes) and which are scored (from `scored_from` on; the ones before are left out).
/// In isolated/ an enrolled take is not laid out at all; in repeated/ it is part of the
/// recording, and the set's own protocol scores it too (`scored_from` 0).
#[derive(Clone, Copy, PartialEq)]
struct Enrolment {
    takes: usize,
    scored_from: usize,
}

impl Enrolment {
    /// The protocol of isolated/: take 01 enrolled, every other take scored.
    const FIRST_TAKE: Self = Self {
        takes: 1,
        scored_from: 1,
    };
    /// The protocol of repeated/: the first instance enrolled, every one scored.
    const FIRST_INSTANCE: Self = Self {
        takes: 1,
        scored_from: 0,
    };
}

fn isolated(
    dir: &Path,
    settings: &DetectorSettings,
    gaps: (f64, f64),
    seed: u64,
    enrolment: Enrolment,
) -> Score {
    let classes = ["b", "c", "ts"];
    let mut patterns = Vec::new();
    let mut others: Vec<(&str, Audio)> = Vec::new();
    for class in classes {
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("isolated").join(class))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        let takes: Vec<Audio> = files[..enrolment.takes].iter().map(|f| read(f)).collect();
        patterns.push(pattern(class, PatternKind::Impulse, &takes, settings));
        for f in &files[enrolment.scored_from..] {
            others.push((class, read(f)));
        }
    }
    let rate = others[0].1.rate;
    assert!(
        others.iter().all(|(_, a)| a.rate == rate),
        "one rate per set"
    );
    let mut rng = Rng::new(seed);
    let mut rec = vec![0.0f32; rate as usize / 2];
    let mut truth = Vec::new();
    for _round in 0..3 {
        let mut order: Vec<usize> = (0..others.len()).collect();
        for i in (1..order.len()).rev() {
            order.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
        }
        for &i in &order {
            let (class, take) = &others[i];
            let gain = 10f32.powf(rng.range(-9.0, 0.0) as f32 / 20.0);
            let at = rec.len();
            truth.push(Annotation {
                onset: (at + energy_onset(&take.samples, rate)) as f64 / f64::from(rate),
                label: class.to_string(),
                end: None,
            });
            rec.extend(take.samples.iter().map(|x| x * gain));
            let gap = rng.range(gaps.0, gaps.1);
            rec.extend(std::iter::repeat_n(0.0, (gap * f64::from(rate)) as usize));
        }
    }
    common::add_noise(&mut rec, 0.001, seed + 1);
    run(&patterns, settings, &Audio { samples: rec, rate }, &truth)
}

fn label_name(label: &str) -> String {
    label
        .chars()
        .filter(|c| c.is_ascii_alphanumeric())
        .collect()
}

/// The first instance of `label` in `rec`, cut by [`cut_at`].
fn cut_first(rec: &Audio, truth: &[Annotation], label: &str) -> Option<Audio> {
    let i = truth.iter().position(|t| t.label == label)?;
    Some(cut_at(rec, truth, i))
}

/// Instance `i` of `truth` in `rec`, cut from 20 ms before its onset to the next onset
/// (at most 300 ms).
fn cut_at(rec: &Audio, truth: &[Annotation], i: usize) -> Audio {
    let rate = f64::from(rec.rate);
    let start = ((truth[i].onset - 0.02).max(0.0) * rate) as usize;
    let next = truth
        .get(i + 1)
        .map_or(truth[i].onset + 0.3, |t| t.onset - 0.01);
    let end = ((next.min(truth[i].onset + 0.3)) * rate) as usize;
    Audio {
        samples: rec.samples[start..end.min(rec.samples.len())].to_vec(),
        rate: rec.rate,
    }
}

/// A beat take from `beats/` and its annotation, labels reduced to letters and digits.
fn load_beat(dir: &Path, name: &str) -> (Audio, Vec<Annotation>) {
    let beats = dir.join("beats");
    let rec = read(&beats.join(format!("{name}.wav")));
    let mut truth = load_truth(&beats.join(format!("{name}.csv"))).unwrap();
    for t in &mut truth {
        t.label = label_name(&t.label);
    }
    (rec, truth)
}

/// With `--verbose`: how alike the enrolled takes of `set` are, pair by pair, as
/// `onomato check` measures them (spectral method), most alike first.
fn print_look_alikes(set: &str, patterns: &[Pattern], settings: &DetectorSettings) {
    if settings.method != Method::Spectral {
        return;
    }
    let detector = Detector::new(patterns.to_vec(), settings, settings.sample_rate).unwrap();
    let pairs: Vec<String> = detector
        .look_alike_patterns(f32::NEG_INFINITY)
        .iter()
        .map(|p| format!("{}/{} {:.2}", p.first, p.second, p.similarity))
        .collect();
    eprintln!("{set}: take similarity {}", pairs.join(", "));
}

/// With `--verbose`: how alike the annotated instances of `recs` are, label by label, as
/// `onomato check` measures takes (spectral method): every instance is cut as a take
/// (`cut_at`), and for each label the mean similarity of two of its instances is printed
/// beside its mean similarity to the instances of the two most alike other labels. Two
/// labels whose instances are as alike across as within are one sound to any detector
/// that decides from the same opening.
fn print_label_similarity(
    name: &str,
    recs: &[(&Audio, &[Annotation])],
    settings: &DetectorSettings,
) {
    if settings.method != Method::Spectral {
        return;
    }
    // Instance `i` of them all is the pattern named `i`.
    let truth: Vec<&Annotation> = recs.iter().flat_map(|(_, t)| t.iter()).collect();
    let mut instances = Vec::new();
    for (rec, rec_truth) in recs {
        for i in 0..rec_truth.len() {
            let name = instances.len().to_string();
            let take = cut_at(rec, rec_truth, i);
            let take = resample_clip(&take.samples, take.rate, settings.sample_rate);
            instances.push(take.ok().and_then(|take| {
                Pattern::from_samples(&name, PatternKind::Impulse, vec![take], settings).ok()
            }));
        }
    }
    let instances: Vec<Pattern> = instances.into_iter().flatten().collect();
    let Ok(detector) = Detector::new(instances, settings, settings.sample_rate) else {
        return;
    };
    let label = |name: &str| {
        name.parse::<usize>()
            .map(|i| truth[i].label.clone())
            .unwrap()
    };
    let mut sums: std::collections::BTreeMap<(String, String), (f64, usize)> = Default::default();
    for pair in detector.look_alike_patterns(f32::NEG_INFINITY) {
        let (a, b, s) = (pair.first, pair.second, pair.similarity);
        let (la, lb) = (label(&a), label(&b));
        for key in [(la.clone(), lb.clone()), (lb, la)] {
            let entry = sums.entry(key).or_default();
            entry.0 += f64::from(s);
            entry.1 += 1;
        }
    }
    let mean = |a: &str, b: &str| {
        sums.get(&(a.to_string(), b.to_string()))
            .map(|(sum, n)| sum / *n as f64)
    };
    let mut labels: Vec<String> = truth.iter().map(|t| t.label.clone()).collect();
    labels.sort();
    labels.dedup();
    eprintln!("{name}: mean similarity of two instances, within a label / with the nearest labels");
    for l in &labels {
        let mut others: Vec<(String, f64)> = labels
            .iter()
            .filter(|o| *o != l)
            .filter_map(|o| Some((o.clone(), mean(l, o)?)))
            .collect();
        others.sort_by(|a, b| b.1.total_cmp(&a.1));
        let within = mean(l, l).map_or("-".into(), |m| format!("{m:.2}"));
        let nearest: Vec<String> = others
            .iter()
            .take(2)
            .map(|(o, m)| format!("{o} {m:.2}"))
            .collect();
        eprintln!("  {l:<4} {within} / {}", nearest.join(", "));
    }
}

fn beats(dir: &Path, settings: &DetectorSettings, verbose: bool) -> Vec<(String, Score)> {
    let load = |name: &str| load_beat(dir, name);
    let labels = |truth: &[Annotation]| {
        let mut l: Vec<String> = truth.iter().map(|t| t.label.clone()).collect();
        l.sort();
        l.dedup();
        l
    };
    let (rec2, truth2) = load("rsalazar_rec2");
    let labels2 = labels(&truth2);
    let enrol2: Vec<Pattern> = labels2
        .iter()
        .filter_map(|l| {
            Some(pattern(
                l,
                PatternKind::Impulse,
                &[cut_first(&rec2, &truth2, l)?],
                settings,
            ))
        })
        .collect();
    if verbose {
        print_look_alikes("rsalazar_rec2 takes", &enrol2, settings);
    }
    let mut out = Vec::new();
    for name in ["rsalazar_rec3", "rsalazar_rec4"] {
        let (rec, truth) = load(name);
        let shift = label_phase(&truth, &low_shares(&rec, &truth));
        if shift != 0 {
            out.push((
                format!("{name}, annotation as given"),
                run(&enrol2, settings, &rec, &truth),
            ));
            let fixed = shift_labels(&truth, shift);
            out.push((
                format!("{name}, labels moved {shift:+} step(s)"),
                run(&enrol2, settings, &rec, &fixed),
            ));
            continue;
        }
        out.push((name.to_string(), run(&enrol2, settings, &rec, &truth)));
        if name == "rsalazar_rec3" {
            let rec48 = Audio {
                samples: resample_clip(&rec.samples, rec.rate, 48_000).unwrap(),
                rate: 48_000,
            };
            out.push((
                format!("{name} at 48 kHz"),
                run(&enrol2, settings, &rec48, &truth),
            ));
        }
    }
    let (rec6, truth6) = load("rsalazar_rec6");
    let mut enrol6 = enrol2.clone();
    for l in labels(&truth6).iter().filter(|l| !labels2.contains(l)) {
        // "BB" is a lip buzz, a held sound: a continuous pattern.
        let kind = if l == "BB" {
            PatternKind::Continuous
        } else {
            PatternKind::Impulse
        };
        if let Some(take) = cut_first(&rec6, &truth6, l) {
            enrol6.push(pattern(l, kind, &[take], settings));
        }
    }
    if verbose {
        print_look_alikes("rsalazar_rec6 takes", &enrol6, settings);
        print_label_similarity("rsalazar_rec6 instances", &[(&rec6, &truth6)], settings);
    }
    out.push((
        "rsalazar_rec6".to_string(),
        run(&enrol6, settings, &rec6, &truth6),
    ));
    out
}

/// Onsets of a file that repeats one sound: 10 ms RMS frames rising above 20 dB below
/// the file's loudest after having fallen 30 dB below it. A simple rule, independent of
/// the detector, for recordings that come without annotations.
fn repeated_onsets(rec: &Audio) -> Vec<f64> {
    let hop = (rec.rate / 100) as usize;
    let db: Vec<f32> = rec
        .samples
        .chunks_exact(hop)
        .map(|c| 10.0 * (c.iter().map(|v| v * v).sum::<f32>() / hop as f32 + 1e-12).log10())
        .collect();
    let loudest = db.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
    let mut onsets = Vec::new();
    let mut armed = true;
    for (i, &v) in db.iter().enumerate() {
        if armed && v > loudest - 20.0 {
            onsets.push(i as f64 * 0.01);
            armed = false;
        }
        if v < loudest - 30.0 {
            armed = true;
        }
    }
    onsets
}

/// repeated/: the first instance of every file is enrolled (one pattern per sound);
/// each file must give its own label at every repetition. Files are scored together.
fn repeated(dir: &Path, settings: &DetectorSettings, verbose: bool, enrolment: Enrolment) -> Score {
    let Enrolment { takes, scored_from } = enrolment;
    let sounds = ["bass", "cymbal", "hi-hat", "snare", "tom"];
    let mut recs = Vec::new();
    let mut patterns = Vec::new();
    for sound in sounds {
        let rec = read(&dir.join("repeated").join(format!("{sound}-1.wav")));
        let label = label_name(sound);
        let truth: Vec<Annotation> = repeated_onsets(&rec)
            .iter()
            .map(|&t| Annotation {
                onset: t,
                label: label.clone(),
                end: None,
            })
            .collect();
        let cuts: Vec<Audio> = (0..takes.min(truth.len()))
            .map(|i| cut_at(&rec, &truth, i))
            .collect();
        if !cuts.is_empty() {
            patterns.push(pattern(&label, PatternKind::Impulse, &cuts, settings));
        }
        recs.push((rec, truth));
    }
    if verbose && enrolment == Enrolment::FIRST_INSTANCE {
        print_look_alikes("repeated takes", &patterns, settings);
        let all: Vec<(&Audio, &[Annotation])> =
            recs.iter().map(|(r, t)| (r, t.as_slice())).collect();
        print_label_similarity("repeated instances", &all, settings);
    }
    // One score over all files: each file's times are moved to their own 1000 s slot.
    let mut all_events = Vec::new();
    let mut all_truth = Vec::new();
    for (i, (rec, truth)) in recs.iter().enumerate() {
        let offset = 1000.0 * i as f64;
        let scored_after = match scored_from {
            0 => f64::NEG_INFINITY,
            n => truth.get(n).map_or(f64::INFINITY, |t| t.onset - 0.05),
        };
        for mut e in detect(&patterns, settings, rec) {
            if e.time < scored_after {
                continue;
            }
            e.time += offset;
            e.emitted_at += offset;
            all_events.push(e);
        }
        all_truth.extend(truth.iter().skip(scored_from).map(|t| Annotation {
            onset: t.onset + offset,
            ..t.clone()
        }));
    }
    score(&all_events, &all_truth, 0.05)
}

/// Share of the energy below 300 Hz in the 40 ms after each onset of `truth` (`None`
/// past the recording's end): kicks ("B") hold most of theirs there, hi-hats ("t")
/// almost none. A check of the derived annotations against the audio.
fn low_shares(rec: &Audio, truth: &[Annotation]) -> Vec<Option<f64>> {
    let len = (0.04 * f64::from(rec.rate)) as usize;
    let mut planner = realfft::RealFftPlanner::<f32>::new();
    let fft = planner.plan_fft_forward(len);
    truth
        .iter()
        .map(|t| {
            let start = (t.onset * f64::from(rec.rate)) as usize;
            let seg = rec.samples.get(start..start + len)?;
            let mut input: Vec<f32> = seg
                .iter()
                .enumerate()
                .map(|(i, x)| {
                    x * (0.5 - 0.5 * (2.0 * std::f32::consts::PI * i as f32 / len as f32).cos())
                })
                .collect();
            let mut spectrum = fft.make_output_vec();
            fft.process(&mut input, &mut spectrum).unwrap();
            let bin_hz = f64::from(rec.rate) / len as f64;
            let power: Vec<f64> = spectrum.iter().map(|c| f64::from(c.norm_sqr())).collect();
            let total: f64 = power.iter().sum();
            let low: f64 = power
                .iter()
                .enumerate()
                .filter(|(k, _)| (*k as f64) * bin_hz < 300.0)
                .map(|(_, p)| p)
                .sum();
            Some(low / total.max(1e-20))
        })
        .collect()
}

/// Mean low share per label.
fn low_share_by_label(truth: &[Annotation], shares: &[Option<f64>]) -> Vec<(String, f64, usize)> {
    let mut by_label: std::collections::BTreeMap<String, (f64, usize)> = Default::default();
    for (t, share) in truth.iter().zip(shares) {
        if let Some(share) = share {
            let entry = by_label.entry(t.label.clone()).or_default();
            entry.0 += share;
            entry.1 += 1;
        }
    }
    by_label
        .into_iter()
        .map(|(l, (sum, n))| (l, sum / n as f64, n))
        .collect()
}

/// The beats repeat a 16-step pattern. `truth` with every onset given the label of the
/// onset `shift` steps later (wrapping by one period at the ends).
fn shift_labels(truth: &[Annotation], shift: i64) -> Vec<Annotation> {
    const PERIOD: i64 = 16;
    let n = truth.len() as i64;
    truth
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let mut j = i as i64 + shift;
            while j >= n {
                j -= PERIOD;
            }
            while j < 0 {
                j += PERIOD;
            }
            Annotation {
                label: truth[j.clamp(0, n - 1) as usize].label.clone(),
                ..t.clone()
            }
        })
        .collect()
}

/// The label shift (-3..=3 steps) under which the annotation's kicks ("B") hold the
/// most low energy against its hi-hats ("t"): 0 when the annotation fits the audio.
/// Independent of the detector. `shares` are `low_shares` of the annotation's onsets.
fn label_phase(truth: &[Annotation], shares: &[Option<f64>]) -> i64 {
    let fit = |shift: i64| {
        let by = low_share_by_label(&shift_labels(truth, shift), shares);
        let get = |l: &str| by.iter().find(|b| b.0 == l).map_or(0.0, |b| b.1);
        get("B") - get("t")
    };
    // The best fit; on a tie, the smallest shift.
    (-3..=3)
        .map(|shift| (shift, fit(shift)))
        .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.abs().cmp(&a.0.abs())))
        .map_or(0, |(shift, _)| shift)
}

fn row(set: &str, method: Method, s: &Score) {
    let ms = |x: Option<f64>| x.map_or("-".into(), |v| format!("{:.0}", v * 1000.0));
    println!(
        "| {set} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {} |",
        match method {
            Method::Waveform => "waveform",
            Method::Spectral => "spectral",
        },
        s.overall.f1,
        s.overall.precision,
        s.overall.recall,
        s.onsets.f1,
        ms(s.latency_median),
        ms(s.latency_p95),
    );
}

/// The value after option `name` in `args`.
fn option_value<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    let i = args.iter().position(|a| a == name)?;
    args.get(i + 1).map(String::as_str)
}

/// The number after option `name`; exits with a message when it is not one.
fn number_option(args: &[String], name: &str, expected: &str) -> Option<f64> {
    let text = option_value(args, name)?;
    Some(text.parse().unwrap_or_else(|_| {
        eprintln!("{name} takes {expected}, found '{text}'");
        std::process::exit(2);
    }))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    const USAGE: &str = "usage: eval_beatbox BEATBOX_DIR [--method waveform|spectral] [--threshold X] [--verbose] [--set isolated|beats|repeated] [--speech-guard SECONDS] [--min-strength X] [--decision-seconds SECONDS]";
    let Some(dir) = args
        .first()
        .filter(|a| !a.starts_with("--"))
        .map(PathBuf::from)
    else {
        eprintln!("{USAGE}");
        std::process::exit(2);
    };
    // The folders each set reads (../shared/data/beatbox has them all).
    for sub in ["isolated", "beats", "repeated"] {
        if !dir.join(sub).is_dir() {
            eprintln!(
                "{}: expected a beatbox folder holding isolated/, beats/ and repeated/, found no {sub}/\n{USAGE}",
                dir.display()
            );
            std::process::exit(2);
        }
    }
    let methods = match option_value(&args, "--method") {
        Some("waveform") => vec![Method::Waveform],
        Some("spectral") => vec![Method::Spectral],
        None => vec![Method::Waveform, Method::Spectral],
        Some(other) => {
            eprintln!("--method takes waveform or spectral, found '{other}'");
            std::process::exit(2);
        }
    };
    let verbose = args.iter().any(|a| a == "--verbose");
    let only = option_value(&args, "--set");
    if let Some(set) = only.filter(|s| !["isolated", "beats", "repeated"].contains(s)) {
        eprintln!("--set takes isolated, beats or repeated, found '{set}'");
        std::process::exit(2);
    }
    let wanted = |set: &str| only.is_none_or(|o| o == set);
    // The options over the defaults, checked as a config's [detector] would be.
    // Without --threshold, each method uses its own default.
    let mut base = DetectorSettings {
        threshold: number_option(&args, "--threshold", "a number from 0 to 1"),
        ..DetectorSettings::default()
    };
    let options = [
        (
            "--speech-guard",
            "a number of seconds",
            &mut base.speech_guard_seconds,
        ),
        (
            "--min-strength",
            "a number from 0 to 1",
            &mut base.min_strength,
        ),
        (
            "--decision-seconds",
            "a number of seconds",
            &mut base.decision_seconds,
        ),
    ];
    for (name, expected, field) in options {
        if let Some(value) = number_option(&args, name, expected) {
            *field = value;
        }
    }
    if let Err(e) = base.validate("eval_beatbox options") {
        eprintln!("{e}");
        std::process::exit(2);
    }
    println!("| set | method | F1 | precision | recall | onset F1 | latency median ms | latency p95 ms |");
    println!("|---|---|---|---|---|---|---|---|");
    for method in methods {
        let settings = DetectorSettings {
            method,
            ..base.clone()
        };
        let show = |set: &str, s: &Score| {
            row(set, method, s);
            if verbose {
                eprintln!("{set} {method:?}\n{}", onomato::eval::render_text(s));
            }
        };
        // More takes: the first three enrolled against the first alone, on the same
        // later sounds.
        let later = |takes| Enrolment {
            takes,
            scored_from: 3,
        };
        if wanted("isolated") {
            show(
                "isolated, gaps 30-700 ms",
                &isolated(&dir, &settings, (0.03, 0.7), 1, Enrolment::FIRST_TAKE),
            );
            show(
                "isolated, gaps 30-120 ms",
                &isolated(&dir, &settings, (0.03, 0.12), 2, Enrolment::FIRST_TAKE),
            );
            for takes in [1, 3] {
                show(
                    &format!("isolated from take 04, gaps 30-120 ms, {takes} take(s) enrolled"),
                    &isolated(&dir, &settings, (0.03, 0.12), 2, later(takes)),
                );
            }
        }
        if wanted("beats") {
            for (name, s) in beats(&dir, &settings, verbose) {
                show(&name, &s);
            }
        }
        if wanted("repeated") {
            show(
                "repeated (5 sounds, 56 repetitions)",
                &repeated(&dir, &settings, verbose, Enrolment::FIRST_INSTANCE),
            );
            for takes in [1, 3] {
                show(
                    &format!("repeated from the 4th (41 repetitions), {takes} take(s) enrolled"),
                    &repeated(&dir, &settings, verbose, later(takes)),
                );
            }
        }
    }
    println!();
    println!(
        "Block sizes {BLOCK_SIZES:?} gave the same events in each of the {} detections above.",
        BLOCK_CHECKS.load(Ordering::Relaxed)
    );
    println!();
    println!("Annotation check: mean share of energy below 300 Hz in the 40 ms after each annotated onset");
    println!();
    println!("| take | label: share (count) | best label shift |");
    println!("|---|---|---|");
    for name in [
        "rsalazar_rec2",
        "rsalazar_rec3",
        "rsalazar_rec4",
        "rsalazar_rec6",
    ] {
        let (rec, truth) = load_beat(&dir, name);
        let shares = low_shares(&rec, &truth);
        let cells: Vec<String> = low_share_by_label(&truth, &shares)
            .into_iter()
            .map(|(l, share, n)| format!("{l}: {:.0}% ({n})", share * 100.0))
            .collect();
        let shift = label_phase(&truth, &shares);
        println!("| {name} | {} | {shift:+} |", cells.join(", "));
    }
}
