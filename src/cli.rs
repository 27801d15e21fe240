//! The command line (clap): raw arguments are parsed here and turned into a validated
//! [`Config`] in one place, then handed to the commands. Errors are printed with their
//! whole chain; the exit code says what happened.
//!
//! Runs on the main thread.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};

use crate::analyze;
use crate::config::{self, Config, Method};
use crate::eval;
use crate::pattern;

/// Turns short vocal sounds ("tick", "pop", "chhh") into timed events for animation and
/// game engines.
#[derive(Debug, Parser)]
#[command(name = "onomato", version)]
pub struct Cli {
    /// More log output on stderr (-v info, -vv debug). RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Detect the patterns in a recording and print the events on stdout.
    Analyze(AnalyzeArgs),
    /// Validate a configuration and load its pattern files; exit 1 if anything is wrong.
    Check(PatternSource),
    /// Analyse a recording and score the events against an annotation CSV.
    Eval(EvalArgs),
}

/// Where the patterns come from: a config file, `--pattern` arguments, or both.
#[derive(Debug, clap::Args)]
pub struct PatternSource {
    /// TOML configuration (see config/onomato.toml).
    #[arg(long, short = 'c', value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// A pattern to detect, repeatable; the same NAME again adds a take.
    #[arg(
        long = "pattern",
        short = 'p',
        value_name = "NAME=FILE.wav[:continuous]"
    )]
    pub patterns: Vec<String>,
    /// Matching method (overrides the config).
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// Match threshold for every pattern without its own, 0 to 1 (overrides the config).
    #[arg(long)]
    pub threshold: Option<f64>,
    /// Use this channel of multi-channel files (from 0) instead of mixing them.
    #[arg(long)]
    pub channel: Option<u16>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    Json,
    Csv,
}

#[derive(Debug, clap::Args)]
pub struct AnalyzeArgs {
    /// The recording to analyse (WAV).
    pub recording: PathBuf,
    #[command(flatten)]
    pub source: PatternSource,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Json)]
    pub format: Format,
    /// Add the bounce solver's contacts ("bounce" array, JSON only).
    #[arg(long)]
    pub bounce: bool,
    /// Gravity for --bounce, m/s² (overrides the config).
    #[arg(long)]
    pub gravity: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ScoreFormat {
    Text,
    Json,
}

#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// The recording to analyse (WAV).
    pub recording: PathBuf,
    /// Annotation CSV with a header: onset_s,label[,end_s] (other columns are ignored).
    #[arg(long, value_name = "CSV")]
    pub truth: PathBuf,
    #[command(flatten)]
    pub source: PatternSource,
    /// A detection is correct when its label matches and its onset is this close, seconds.
    #[arg(long, default_value_t = 0.05)]
    pub tolerance: f64,
    /// Output format.
    #[arg(long, value_enum, default_value_t = ScoreFormat::Text)]
    pub format: ScoreFormat,
}

impl PatternSource {
    /// The validated configuration these arguments describe.
    pub fn to_config(&self) -> anyhow::Result<Config> {
        let mut config = match &self.config {
            Some(path) => Config::load(path)?,
            None => Config::default(),
        };
        config.add_cli_patterns(config::parse_pattern_args(&self.patterns)?)?;
        if let Some(method) = self.method {
            config.detector.method = method;
        }
        if let Some(threshold) = self.threshold {
            config.detector.threshold = threshold;
        }
        if let Some(channel) = self.channel {
            config.detector.channel = Some(channel);
        }
        config.detector.validate("command line")?;
        config.check_pattern_thresholds("command line")?;
        if config.patterns.is_empty() {
            anyhow::bail!(
                "no patterns to detect: give --pattern NAME=FILE.wav (repeatable) or --config FILE with [[pattern]] entries"
            );
        }
        Ok(config)
    }
}

fn run_analyze(args: &AnalyzeArgs) -> anyhow::Result<()> {
    if args.bounce && args.format != Format::Json {
        anyhow::bail!("--bounce adds a \"bounce\" array to the JSON output; it cannot be used with --format csv");
    }
    let mut config = args.source.to_config()?;
    if let Some(g) = args.gravity {
        if !(g.is_finite() && g > 0.0) {
            anyhow::bail!("--gravity must be a positive number (m/s²), found {g}");
        }
        let mut bounce = config.bounce_or_default();
        bounce.gravity = g;
        config.bounce = Some(bounce);
    }
    let analysis = analyze::analyze_file(&args.recording, &config)?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match args.format {
        Format::Json => {
            let contacts = args
                .bounce
                .then(|| analyze::bounce(&analysis.events, &config));
            analyze::write_json(&mut out, &analysis.events, contacts.as_deref())
        }
        Format::Csv => analyze::write_csv(&mut out, &analysis.events),
    }
    .and_then(|()| out.flush())
    .context("cannot write to stdout")
}

fn run_eval(args: &EvalArgs) -> anyhow::Result<()> {
    if !(args.tolerance.is_finite() && args.tolerance > 0.0) {
        anyhow::bail!(
            "--tolerance must be a positive number of seconds, found {}",
            args.tolerance
        );
    }
    let truth = eval::load_truth(&args.truth)?;
    let config = args.source.to_config()?;
    let analysis = analyze::analyze_file(&args.recording, &config)?;
    let score = eval::score(&analysis.events, &truth, args.tolerance);
    let text = match args.format {
        ScoreFormat::Text => eval::render_text(&score),
        ScoreFormat::Json => serde_json::to_string(&score)? + "\n",
    };
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    out.write_all(text.as_bytes())
        .and_then(|()| out.flush())
        .context("cannot write to stdout")
}

fn run_check(source: &PatternSource) -> anyhow::Result<()> {
    let config = source.to_config()?;
    let patterns = pattern::load_patterns(&config.patterns, &config.detector)?;
    let mut err = std::io::stderr().lock();
    for p in &patterns {
        let _ = writeln!(
            err,
            "pattern '{}' ({}): {} take(s), {:.0} ms longest, threshold {}",
            p.name,
            p.kind.as_str(),
            p.takes.len(),
            p.max_len() as f64 * 1000.0 / f64::from(config.detector.sample_rate),
            p.threshold
        );
    }
    let _ = writeln!(err, "configuration is valid");
    Ok(())
}

fn init_logging(verbose: u8) {
    use tracing_subscriber::EnvFilter;
    let default = match verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}

/// Entry point of the binary: parses arguments, runs the command, prints errors.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(cli.verbose);
    let result = match &cli.command {
        Command::Analyze(args) => run_analyze(args),
        Command::Check(source) => run_check(source),
        Command::Eval(args) => run_eval(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
