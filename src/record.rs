//! `onomato record NAME`: enrolment. Takes come from the microphone (the daemon's
//! capture code, with a countdown and a live level on stderr) or from a file
//! (`--input`). Each take is cut to the sound by an energy rule, checked (silent,
//! clipped, too short or too long takes are refused with the reason, and the microphone
//! asks again), saved as a WAV file beside the config, and the pattern is added to the
//! config, or its takes replaced, without touching the rest of the file (toml_edit
//! keeps the user's comments and layout). With `--background`, a recording of the user
//! talking (what must never fire) is taken whole instead, checked to hold sounds the
//! detector pools, saved, and added to `[detector.spectral] background`.
//!
//! Runs on the main thread of `onomato record`; the microphone's samples arrive through
//! the same ring as the daemon's.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use rtrb::Consumer;

use crate::audio::ChannelSelect;
use crate::config::{Config, DetectorSettings, InputSettings, PatternKind};
use crate::input;
use crate::status::Status;

/// Analysis frame of the energy rule, seconds.
const FRAME_SECONDS: f64 = 0.01;
/// A sound is where the frame level is this far above the noise floor...
const ABOVE_FLOOR_DB: f64 = 20.0;
/// ...and above this absolute level (dBFS): quieter is silence.
const SILENCE_DBFS: f64 = -55.0;
/// Gaps shorter than this inside a sound do not split it ("t-k").
const JOIN_GAP_SECONDS: f64 = 0.2;
/// Kept before and after the frames above the threshold.
const PAD_SECONDS: f64 = 0.01;
/// A take must be at least this long.
const MIN_TAKE_SECONDS: f64 = 0.02;

/// A sound found in a recording, in samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Span {
    pub start: usize,
    pub end: usize,
}

/// Why a take was refused.
#[derive(Debug, Clone, PartialEq)]
pub enum Refusal {
    Clipped { at: f64 },
    TooLong { seconds: f64, max: f64 },
    TooShort { seconds: f64 },
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refusal::Clipped { at } => write!(
                f,
                "clipped at {at:.2} s (the signal reached full scale): lower the input gain or move back from the microphone"
            ),
            Refusal::TooLong { seconds, max } => write!(
                f,
                "{seconds:.2} s long, more than max_pattern_seconds ({max} s): make the sound shorter"
            ),
            Refusal::TooShort { seconds } => write!(
                f,
                "only {:.0} ms long: make the sound a little longer",
                seconds * 1000.0
            ),
        }
    }
}

/// One take found: its span, and the verdict.
#[derive(Debug, Clone, PartialEq)]
pub struct FoundTake {
    pub span: Span,
    pub verdict: Result<(), Refusal>,
}

/// Frame levels (dBFS) of `samples`, one per `FRAME_SECONDS`, around their mean: a
/// microphone's DC offset is no sound, and would otherwise stand for the room.
fn frame_levels(samples: &[f32], frame: usize) -> Vec<f64> {
    let mean = samples.iter().map(|&x| f64::from(x)).sum::<f64>() / samples.len().max(1) as f64;
    samples
        .chunks(frame)
        .map(|c| {
            let ms = c
                .iter()
                .map(|&x| (f64::from(x) - mean).powi(2))
                .sum::<f64>()
                / c.len() as f64;
            10.0 * ms.max(1e-14).log10()
        })
        .collect()
}

/// Finds the sounds of `samples` (mono, at `rate`) by the energy rule, and judges each:
/// clipped, too long (over `max_seconds`) or too short takes are refused.
pub fn find_takes(samples: &[f32], rate: u32, max_seconds: f64) -> Vec<FoundTake> {
    let frame = ((FRAME_SECONDS * f64::from(rate)) as usize).max(1);
    let levels = frame_levels(samples, frame);
    if levels.is_empty() {
        return Vec::new();
    }
    // The noise floor: the 10th percentile of the frame levels.
    let mut sorted = levels.clone();
    sorted.sort_by(f64::total_cmp);
    let floor = sorted[sorted.len() / 10];
    let threshold = (floor + ABOVE_FLOOR_DB).max(SILENCE_DBFS);
    let join = (JOIN_GAP_SECONDS / FRAME_SECONDS).ceil() as usize;
    let mut spans: Vec<(usize, usize)> = Vec::new(); // frames [first, last]
    for (i, &l) in levels.iter().enumerate() {
        if l < threshold {
            continue;
        }
        match spans.last_mut() {
            Some((_, last)) if i - *last <= join => *last = i,
            _ => spans.push((i, i)),
        }
    }
    let pad = (PAD_SECONDS * f64::from(rate)) as usize;
    spans
        .into_iter()
        .map(|(first, last)| {
            let start = (first * frame).saturating_sub(pad);
            let end = ((last + 1) * frame + pad).min(samples.len());
            let span = Span { start, end };
            let seconds = (end - start) as f64 / f64::from(rate);
            let clipped = samples[start..end]
                .iter()
                .position(|x| x.abs() >= crate::audio::CLIP_LEVEL);
            let verdict = if let Some(k) = clipped {
                Err(Refusal::Clipped {
                    at: (start + k) as f64 / f64::from(rate),
                })
            } else if seconds > max_seconds {
                Err(Refusal::TooLong {
                    seconds,
                    max: max_seconds,
                })
            } else if seconds < MIN_TAKE_SECONDS {
                Err(Refusal::TooShort { seconds })
            } else {
                Ok(())
            };
            FoundTake { span, verdict }
        })
        .collect()
}

/// Writes a take as 16-bit mono WAV.
pub fn write_take(path: &Path, samples: &[f32], rate: u32) -> anyhow::Result<()> {
    use anyhow::Context;
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: rate,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(path, spec)
        .with_context(|| format!("cannot write take '{}'", path.display()))?;
    for &x in samples {
        w.write_sample((x.clamp(-1.0, 1.0) * 32767.0).round() as i16)
            .with_context(|| format!("cannot write take '{}'", path.display()))?;
    }
    w.finalize()
        .with_context(|| format!("cannot write take '{}'", path.display()))?;
    Ok(())
}

/// Adds the pattern `name` to the config text (to the `[[performer]]` named
/// `performer`, when given), or replaces its kind and takes, and leaves everything else
/// as it was (comments, order, layout). `takes` are written as given (relative to the
/// config file).
pub fn update_config_text(
    text: &str,
    performer: Option<&str>,
    name: &str,
    kind: PatternKind,
    takes: &[String],
) -> Result<String, String> {
    let mut doc: toml_edit::DocumentMut = text
        .parse()
        .map_err(|e: toml_edit::TomlError| e.to_string())?;
    let mut files = toml_edit::Array::new();
    for t in takes {
        files.push(t.as_str());
    }
    let owner: &mut toml_edit::Table = match performer {
        None => doc.as_table_mut(),
        Some(who) => doc
            .get_mut("performer")
            .and_then(toml_edit::Item::as_array_of_tables_mut)
            .and_then(|all| {
                all.iter_mut()
                    .find(|t| t.get("name").and_then(|n| n.as_str()) == Some(who))
            })
            .ok_or_else(|| format!("it has no [[performer]] named '{who}'"))?,
    };
    let patterns = owner
        .entry("pattern")
        .or_insert(toml_edit::Item::ArrayOfTables(
            toml_edit::ArrayOfTables::new(),
        ))
        .as_array_of_tables_mut()
        .ok_or("'pattern' is not an array of tables ([[pattern]])".to_string())?;
    let existing = patterns
        .iter_mut()
        .find(|t| t.get("name").and_then(|n| n.as_str()) == Some(name));
    match existing {
        Some(table) => {
            table["kind"] = toml_edit::value(kind.as_str());
            table["takes"] = toml_edit::value(files);
        }
        None => {
            let mut table = toml_edit::Table::new();
            table["name"] = toml_edit::value(name);
            table["kind"] = toml_edit::value(kind.as_str());
            table["takes"] = toml_edit::value(files);
            patterns.push(table);
        }
    }
    Ok(doc.to_string())
}

/// Adds `file` to the `background` list of `[detector.spectral]` in the config text
/// (once), and leaves everything else as it was.
pub fn add_background_to_config_text(text: &str, file: &str) -> Result<String, String> {
    let mut doc: toml_edit::DocumentMut = text
        .parse()
        .map_err(|e: toml_edit::TomlError| e.to_string())?;
    let spectral = doc
        .entry("detector")
        .or_insert(toml_edit::table())
        .as_table_mut()
        .ok_or("'detector' is not a table ([detector])")?
        .entry("spectral")
        .or_insert(toml_edit::table())
        .as_table_mut()
        .ok_or("'detector.spectral' is not a table ([detector.spectral])")?;
    let list = spectral
        .entry("background")
        .or_insert(toml_edit::value(toml_edit::Array::new()))
        .as_array_mut()
        .ok_or("'background' in [detector.spectral] is not a list of files")?;
    if !list.iter().any(|v| v.as_str() == Some(file)) {
        list.push(file);
    }
    Ok(doc.to_string())
}

/// Options of `record`.
#[derive(Debug, Clone)]
pub struct RecordOptions {
    pub name: String,
    /// The `[[performer]]` of the config the pattern is for; its channel is recorded.
    pub performer: Option<String>,
    /// The channel recorded (from the microphone or the file), or the mix.
    pub channel: ChannelSelect,
    pub kind: PatternKind,
    pub takes: usize,
    /// The config to update; takes are saved beside it. `None`: saved in `dir`.
    pub config: Option<PathBuf>,
    pub dir: PathBuf,
    /// Takes from this file instead of the microphone.
    pub input: Option<PathBuf>,
    /// The config's detector settings: the longest take (`max_pattern_seconds`), and
    /// how a background recording is pooled.
    pub detector: DetectorSettings,
    pub input_settings: InputSettings,
    /// Records a background recording of this many seconds (from the microphone; the
    /// whole of `input` otherwise) instead of a pattern's takes.
    pub background_seconds: Option<f64>,
}

/// What `record` did.
#[derive(Debug, Clone)]
pub struct RecordReport {
    pub saved: Vec<PathBuf>,
    pub refused: Vec<(Span, Refusal)>,
}

/// Runs `record`: finds takes, saves them, updates the config. Messages for the user go
/// to `err`.
pub fn record(options: &RecordOptions, err: &mut dyn Write) -> anyhow::Result<RecordReport> {
    use anyhow::{bail, Context};
    crate::config::check_pattern_name(&options.name).map_err(|m| anyhow::anyhow!(m))?;
    // Read the config first: a config that does not load is not touched.
    let config_text = match &options.config {
        Some(path) => {
            Config::load(path)?;
            Some(
                std::fs::read_to_string(path)
                    .with_context(|| format!("cannot read config '{}'", path.display()))?,
            )
        }
        None => None,
    };
    let dir = match &options.config {
        Some(path) => path.parent().unwrap_or(Path::new(".")).to_path_buf(),
        None => options.dir.clone(),
    };
    let mut report = RecordReport {
        saved: Vec::new(),
        refused: Vec::new(),
    };
    if let Some(seconds) = options.background_seconds {
        let saved = record_background(options, seconds, config_text.as_deref(), &dir, err)?;
        report.saved.push(saved);
        return Ok(report);
    }
    let mut good: Vec<(Vec<f32>, u32)> = Vec::new();
    match &options.input {
        Some(path) => {
            let mut source = crate::audio::WavSource::open(path, options.channel)?;
            let rate = source.sample_rate();
            let samples = source.read_all()?;
            for found in find_takes(&samples, rate, options.detector.max_pattern_seconds) {
                let (a, b) = (found.span.start, found.span.end);
                let at = |n: usize| n as f64 / f64::from(rate);
                match found.verdict {
                    Ok(()) if good.len() < options.takes => {
                        let _ =
                            writeln!(err, "take {}: {:.2}-{:.2} s", good.len() + 1, at(a), at(b));
                        good.push((samples[a..b].to_vec(), rate));
                    }
                    Ok(()) => {}
                    Err(r) => {
                        let _ =
                            writeln!(err, "refused the sound at {:.2}-{:.2} s: {r}", at(a), at(b));
                        report.refused.push((found.span, r));
                    }
                }
            }
        }
        None => {
            good = record_from_microphone(options, &mut report, err)?;
        }
    }
    if good.is_empty() {
        bail!(
            "no usable take of '{}' was found{}",
            options.name,
            if options.input.is_some() {
                " in the input file"
            } else {
                ""
            }
        );
    }
    if good.len() < options.takes {
        let _ = writeln!(
            err,
            "warning: {} of the {} takes asked for were found",
            good.len(),
            options.takes
        );
    }
    let mut names = Vec::new();
    for (k, (samples, rate)) in good.iter().enumerate() {
        // A performer's takes carry its name: two performers may both have a "tick".
        let file = match &options.performer {
            Some(who) => format!("{who}-{}-{}.wav", options.name, k + 1),
            None => format!("{}-{}.wav", options.name, k + 1),
        };
        let path = dir.join(&file);
        write_take(&path, samples, *rate)?;
        let _ = writeln!(err, "saved {}", path.display());
        report.saved.push(path);
        names.push(file);
    }
    match (&options.config, config_text) {
        (Some(path), Some(text)) => {
            let updated = update_config_text(
                &text,
                options.performer.as_deref(),
                &options.name,
                options.kind,
                &names,
            )
            .map_err(|m| anyhow::anyhow!("cannot update config '{}': {m}", path.display()))?;
            // The new config must load, takes included, before it replaces the old one.
            let base = path.parent().unwrap_or(Path::new("."));
            let origin = format!("config '{}'", path.display());
            let config = Config::parse(&updated, base, &origin)?
                .select_performer(options.performer.as_deref())
                .map_err(|m| anyhow::anyhow!("config '{}': {m}", path.display()))?;
            let patterns = crate::pattern::load_patterns(&config.patterns, &config.detector)?;
            let report = crate::pattern::takes_report(&patterns, &config.detector)?;
            let temp = path.with_extension("toml.new");
            std::fs::write(&temp, updated)
                .with_context(|| format!("cannot write '{}'", temp.display()))?;
            std::fs::rename(&temp, path)
                .with_context(|| format!("cannot replace config '{}'", path.display()))?;
            let _ = writeln!(
                err,
                "pattern '{}' written to {}",
                options.name,
                path.display()
            );
            for spread in report.spread.iter().filter(|s| *s.pattern == *options.name) {
                let _ = writeln!(err, "{spread}");
            }
            for repeated in report
                .repeated
                .iter()
                .filter(|r| *r.pattern == *options.name)
            {
                let _ = writeln!(err, "{repeated}");
            }
            for pair in report
                .look_alike
                .iter()
                .filter(|l| l.involves(&options.name))
            {
                let _ = writeln!(err, "warning: {pair}");
            }
        }
        _ => {
            let args: Vec<String> = report
                .saved
                .iter()
                .map(|p| {
                    let kind = if options.kind == PatternKind::Continuous {
                        ":continuous"
                    } else {
                        ""
                    };
                    format!("--pattern {}={}{kind}", options.name, p.display())
                })
                .collect();
            let _ = writeln!(err, "use it with: {}", args.join(" "));
        }
    }
    Ok(report)
}

/// Records takes from the microphone: a countdown, a live level, one sound per take;
/// a refused take is explained and asked again.
fn record_from_microphone(
    options: &RecordOptions,
    report: &mut RecordReport,
    err: &mut dyn Write,
) -> anyhow::Result<Vec<(Vec<f32>, u32)>> {
    let status = Arc::new(Status::default());
    let (capture, mut consumer) = input::open_capture(&options.input_settings, status, |_| {})?;
    let rate = capture.rate;
    let channels = usize::from(capture.channels).max(1);
    let mut good = Vec::new();
    let mut attempts = 0;
    let window = options.detector.max_pattern_seconds + 1.5;
    while good.len() < options.takes && attempts < options.takes * 3 {
        attempts += 1;
        let what = format!("take {} of {}", good.len() + 1, options.takes);
        count_down(&what, &mut consumer, err);
        let _ = writeln!(
            err,
            "\rtake {} of {}: now!            ",
            good.len() + 1,
            options.takes
        );
        let mut mono: Vec<f32> = Vec::new();
        let started = Instant::now();
        let mut last_sound: Option<Instant> = None;
        let mut meter = Meter::new(channels, options.channel);
        while started.elapsed().as_secs_f64() < window {
            let Some((block, db)) = meter.next_block(&mut consumer, err) else {
                continue;
            };
            if db > SILENCE_DBFS + 15.0 {
                last_sound = Some(Instant::now());
            }
            mono.extend_from_slice(block);
            // The sound is over after 0.5 s of quiet.
            if last_sound.is_some_and(|t| t.elapsed() > Duration::from_millis(500)) {
                break;
            }
        }
        let _ = writeln!(err);
        let found = find_takes(&mono, rate, options.detector.max_pattern_seconds);
        match found.first() {
            None => {
                let _ = writeln!(
                    err,
                    "nothing was heard (silent): speak louder or closer, again"
                );
            }
            Some(t) => match &t.verdict {
                Ok(()) if found.len() == 1 => {
                    good.push((mono[t.span.start..t.span.end].to_vec(), rate));
                }
                Ok(()) => {
                    let _ = writeln!(
                        err,
                        "{} sounds were heard: one sound per take, again",
                        found.len()
                    );
                }
                Err(r) => {
                    let _ = writeln!(err, "refused: {r}; again");
                    report.refused.push((t.span, r.clone()));
                }
            },
        }
    }
    drop(capture);
    Ok(good)
}

/// "3... 2... 1..." after `what` on `err`, then drops what the microphone heard meanwhile.
fn count_down(what: &str, consumer: &mut Consumer<f32>, err: &mut dyn Write) {
    for n in (1..=3).rev() {
        let _ = write!(err, "\r{what}: {n}... ");
        let _ = err.flush();
        std::thread::sleep(Duration::from_millis(700));
    }
    let stale = consumer.slots();
    if let Ok(chunk) = consumer.read_chunk(stale) {
        chunk.commit_all();
    }
}

/// Mono blocks of the microphone's ring (the recorded channel, or the mix), with the
/// level shown on stderr ten times a second: the loudest since the last.
struct Meter {
    channels: usize,
    select: ChannelSelect,
    frame: Vec<f32>,
    block: Vec<f32>,
    shown_peak: f64,
    last_shown: Instant,
}

impl Meter {
    fn new(channels: usize, select: ChannelSelect) -> Self {
        Self {
            channels,
            select,
            frame: vec![0.0; 1024 * channels],
            block: Vec::with_capacity(1024),
            shown_peak: -120.0,
            last_shown: Instant::now(),
        }
    }

    /// The next block and its peak (dBFS), or `None` after a short wait when the ring
    /// is empty.
    fn next_block(
        &mut self,
        consumer: &mut Consumer<f32>,
        err: &mut dyn Write,
    ) -> Option<(&[f32], f64)> {
        let channels = self.channels;
        let frames = (consumer.slots() / channels).min(1024);
        if frames == 0 {
            std::thread::sleep(Duration::from_millis(5));
            return None;
        }
        let _ = consumer.pop_partial_slice(&mut self.frame[..frames * channels]);
        let select = self.select;
        self.block.clear();
        self.block.extend(
            self.frame[..frames * channels]
                .chunks_exact(channels)
                .map(|f| match select {
                    ChannelSelect::Index(i) if usize::from(i) < channels => f[usize::from(i)],
                    _ => f.iter().sum::<f32>() / channels as f32,
                }),
        );
        let peak = self.block.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        let db = 20.0 * f64::from(peak.max(1e-6)).log10();
        self.shown_peak = self.shown_peak.max(db);
        if self.last_shown.elapsed() >= Duration::from_millis(100) {
            let bars = (((self.shown_peak + 60.0) / 60.0).clamp(0.0, 1.0) * 30.0) as usize;
            let _ = write!(
                err,
                "\r  level {:<30} {:6.1} dB",
                "#".repeat(bars),
                self.shown_peak
            );
            let _ = err.flush();
            self.last_shown = Instant::now();
            self.shown_peak = -120.0;
        }
        Some((&self.block, db))
    }
}

/// `record NAME --background`: `seconds` of the user talking as they do between hits
/// (from the microphone; the whole of `--input` otherwise), saved as NAME.wav in `dir`
/// once the detector finds sounds in it, and added to the config's `background` list.
fn record_background(
    options: &RecordOptions,
    seconds: f64,
    config_text: Option<&str>,
    dir: &Path,
    err: &mut dyn Write,
) -> anyhow::Result<PathBuf> {
    use anyhow::{bail, Context};
    let detector = &options.detector;
    if detector.method != crate::config::Method::Spectral {
        bail!(
            "a background recording is for the spectral method; the config's method is \"{}\"",
            detector.method.name()
        );
    }
    let (samples, rate) = match &options.input {
        Some(path) => crate::detect::read_background(path, options.channel)?,
        None => record_talking(options, seconds, err)?,
    };
    let at_rate = crate::audio::resample_clip(&samples, rate, detector.sample_rate)?;
    let sounds = crate::detect::spectral::background_model(&at_rate, detector).len();
    if sounds == 0 {
        bail!(
            "nothing in the recording stands out of its quiet ({:.1} s): talk as you do between hits, closer to the microphone",
            samples.len() as f64 / f64::from(rate.max(1))
        );
    }
    let file = match &options.performer {
        Some(who) => format!("{who}-{}.wav", options.name),
        None => format!("{}.wav", options.name),
    };
    let path = dir.join(&file);
    write_take(&path, &samples, rate)?;
    let _ = writeln!(
        err,
        "saved {} ({:.1} s, {sounds} sounds that must never fire)",
        path.display(),
        samples.len() as f64 / f64::from(rate)
    );
    match (&options.config, config_text) {
        (Some(config), Some(text)) => {
            let updated = add_background_to_config_text(text, &file)
                .map_err(|m| anyhow::anyhow!("cannot update config '{}': {m}", config.display()))?;
            // The new config must load, its background included, before it replaces
            // the old one.
            let base = config.parent().unwrap_or(Path::new("."));
            let origin = format!("config '{}'", config.display());
            let parsed = Config::parse(&updated, base, &origin)?;
            crate::detect::own_background(&parsed.detector)?;
            let temp = config.with_extension("toml.new");
            std::fs::write(&temp, updated)
                .with_context(|| format!("cannot write '{}'", temp.display()))?;
            std::fs::rename(&temp, config)
                .with_context(|| format!("cannot replace config '{}'", config.display()))?;
            let _ = writeln!(err, "background '{file}' written to {}", config.display());
        }
        _ => {
            let _ = writeln!(err, "use it with: --background {}", path.display());
        }
    }
    Ok(path)
}

/// `seconds` of the microphone after a countdown, the level shown as it records.
fn record_talking(
    options: &RecordOptions,
    seconds: f64,
    err: &mut dyn Write,
) -> anyhow::Result<(Vec<f32>, u32)> {
    let status = Arc::new(Status::default());
    let (capture, mut consumer) = input::open_capture(&options.input_settings, status, |_| {})?;
    let rate = capture.rate;
    let _ = writeln!(
        err,
        "talk as you do between your sounds for {seconds:.0} s (leave the enrolled sounds out)"
    );
    count_down("background", &mut consumer, err);
    let _ = writeln!(err, "\rbackground: now!            ");
    let wanted = (seconds * f64::from(rate)) as usize;
    let mut mono = Vec::with_capacity(wanted);
    let mut meter = Meter::new(usize::from(capture.channels).max(1), options.channel);
    let started = Instant::now();
    // The ring is read as it fills; a stalled device ends the recording a second late.
    while mono.len() < wanted && started.elapsed().as_secs_f64() < seconds + 1.0 {
        if let Some((block, _)) = meter.next_block(&mut consumer, err) {
            mono.extend_from_slice(block);
        }
    }
    mono.truncate(wanted);
    let _ = writeln!(err);
    drop(capture);
    Ok((mono, rate))
}
