//! Audio in: WAV files read block by block (any integer or float format, any channel
//! count, mixed down or one channel picked) and a streaming resampler whose output does
//! not depend on how its input is cut into blocks.
//!
//! Runs on whichever thread reads a file (`analyze`, pattern loading) or, for
//! [`StreamResampler`], on the detector thread; nothing here allocates after construction
//! except [`WavSource::read_block`] growing the caller's buffer once.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use rubato::audioadapter_buffers::direct::InterleavedSlice;
use rubato::{Async, FixedAsync, Indexing, Resampler, SincInterpolationParameters, WindowFunction};

/// Which channel of a multi-channel file becomes the mono signal.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ChannelSelect {
    /// The mean of all channels.
    #[default]
    Mix,
    /// One channel, counted from 0.
    Index(u16),
}

/// Errors reading audio files. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum AudioError {
    #[error("cannot open '{}': {cause}", path.display())]
    Open {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("'{}' is not a readable WAV file: {reason}", path.display())]
    NotWav { path: PathBuf, reason: String },
    #[error("'{}' has an unsupported sample format: {found}; {}", path.display(), PCM_FORMATS)]
    Format { path: PathBuf, found: String },
    #[error("'{}' has {channels} channel(s); channel {wanted} does not exist (channels are counted from 0)", path.display())]
    Channel {
        path: PathBuf,
        channels: u16,
        wanted: u16,
    },
    #[error("'{}' is corrupt: reading frame {frame} failed: {reason}", path.display())]
    Corrupt {
        path: PathBuf,
        frame: u64,
        reason: String,
    },
    #[error("cannot resample from {from} Hz to {to} Hz: {reason}")]
    Resample { from: u32, to: u32, reason: String },
}

enum SampleKind {
    Int { scale: f32 },
    Float,
}

/// A WAV file opened for block-wise reading as mono f32 in [-1, 1].
pub struct WavSource {
    path: PathBuf,
    reader: hound::WavReader<BufReader<File>>,
    kind: SampleKind,
    channels: u16,
    select: ChannelSelect,
    sample_rate: u32,
    frames_total: u64,
    frames_read: u64,
    interleaved: Vec<f32>,
}

fn hound_reason(err: hound::Error) -> String {
    match err {
        // hound reports a short data chunk as UnexpectedEof or as "Failed to read enough bytes."
        hound::Error::IoError(e)
            if e.kind() == std::io::ErrorKind::UnexpectedEof
                || e.to_string().contains("read enough bytes") =>
        {
            "the file ends before its header says it should (truncated?)".to_string()
        }
        // hound names these by what its parser missed; say what the file holds instead.
        hound::Error::FormatError("no RIFF tag found") => {
            "it has no RIFF header, so it is not a WAV file (convert FLAC, AIFF, MP3 and \
             others to WAV first, e.g. `sox IN.flac OUT.wav`)"
                .to_string()
        }
        hound::Error::FormatError("bits per sample is not 32") => format!(
            "its samples are floating point but not 32-bit (64-bit?); {PCM_FORMATS} \
             (`sox IN.wav -b 32 OUT.wav` converts it)"
        ),
        hound::Error::Unsupported => format!(
            "its samples are not PCM (mu-law, A-law or a compressed encoding?); {PCM_FORMATS}"
        ),
        other => other.to_string(),
    }
}

/// The sample formats a WAV file may hold.
const PCM_FORMATS: &str = "expected 8, 16, 24 or 32-bit integer or 32-bit float PCM";

impl WavSource {
    /// Opens `path` and checks its format and the chosen channel.
    pub fn open(path: &Path, select: ChannelSelect) -> Result<Self, AudioError> {
        let file = File::open(path).map_err(|cause| AudioError::Open {
            path: path.to_path_buf(),
            cause,
        })?;
        let reader =
            hound::WavReader::new(BufReader::new(file)).map_err(|e| AudioError::NotWav {
                path: path.to_path_buf(),
                reason: hound_reason(e),
            })?;
        let spec = reader.spec();
        let kind = match (spec.sample_format, spec.bits_per_sample) {
            (hound::SampleFormat::Float, 32) => SampleKind::Float,
            (hound::SampleFormat::Int, bits @ (8 | 16 | 24 | 32)) => SampleKind::Int {
                scale: 1.0 / (1u64 << (bits - 1)) as f32,
            },
            (format, bits) => {
                return Err(AudioError::Format {
                    path: path.to_path_buf(),
                    found: format!("{bits}-bit {format:?}"),
                })
            }
        };
        if spec.channels == 0 {
            return Err(AudioError::NotWav {
                path: path.to_path_buf(),
                reason: "the header declares 0 channels".to_string(),
            });
        }
        // A mono file has only one channel to take, whatever the choice.
        let select = if spec.channels == 1 {
            ChannelSelect::Mix
        } else {
            select
        };
        if let ChannelSelect::Index(wanted) = select {
            if wanted >= spec.channels {
                return Err(AudioError::Channel {
                    path: path.to_path_buf(),
                    channels: spec.channels,
                    wanted,
                });
            }
        }
        Ok(Self {
            path: path.to_path_buf(),
            frames_total: u64::from(reader.duration()),
            reader,
            kind,
            channels: spec.channels,
            select,
            sample_rate: spec.sample_rate,
            frames_read: 0,
            interleaved: Vec::new(),
        })
    }

    pub fn sample_rate(&self) -> u32 {
        self.sample_rate
    }

    pub fn channels(&self) -> u16 {
        self.channels
    }

    /// Number of frames the header announces.
    pub fn frames_total(&self) -> u64 {
        self.frames_total
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Reads up to `max_frames` frames with every channel, interleaved (the replay
    /// hands them on as a device would).
    pub fn read_interleaved(
        &mut self,
        max_frames: usize,
        out: &mut Vec<f32>,
    ) -> Result<usize, AudioError> {
        let frames = self.fill(max_frames)?;
        out.clear();
        out.extend_from_slice(&self.interleaved);
        Ok(frames)
    }

    /// Reads up to `max_frames` frames into `self.interleaved`; returns the frames read.
    fn fill(&mut self, max_frames: usize) -> Result<usize, AudioError> {
        let channels = usize::from(self.channels);
        let wanted = max_frames * channels;
        self.interleaved.clear();
        let path = &self.path;
        let frames_before = self.frames_read;
        let interleaved = &mut self.interleaved;
        let corrupt = |e: hound::Error, done: usize| AudioError::Corrupt {
            path: path.clone(),
            frame: frames_before + (done / channels) as u64,
            reason: hound_reason(e),
        };
        match self.kind {
            SampleKind::Float => {
                for s in self.reader.samples::<f32>().take(wanted) {
                    let v = s.map_err(|e| corrupt(e, interleaved.len()))?;
                    interleaved.push(v);
                }
            }
            SampleKind::Int { scale } => {
                for s in self.reader.samples::<i32>().take(wanted) {
                    let v = s.map_err(|e| corrupt(e, interleaved.len()))?;
                    interleaved.push(v as f32 * scale);
                }
            }
        }
        let frames = self.interleaved.len() / channels;
        self.frames_read += frames as u64;
        Ok(frames)
    }

    /// Reads up to `max_frames` frames as mono into `out` (cleared first). Returns the
    /// number of frames read; 0 at the end of the file.
    pub fn read_block(
        &mut self,
        max_frames: usize,
        out: &mut Vec<f32>,
    ) -> Result<usize, AudioError> {
        out.clear();
        let channels = usize::from(self.channels);
        self.fill(max_frames)?;
        let frames = self.interleaved.len() / channels;
        match self.select {
            ChannelSelect::Mix if channels == 1 => out.extend_from_slice(&self.interleaved),
            ChannelSelect::Mix => {
                let norm = 1.0 / channels as f32;
                out.extend(
                    self.interleaved
                        .chunks_exact(channels)
                        .map(|f| f.iter().sum::<f32>() * norm),
                );
            }
            ChannelSelect::Index(c) => out.extend(
                self.interleaved
                    .chunks_exact(channels)
                    .map(|f| f[usize::from(c)]),
            ),
        }
        Ok(frames)
    }

    /// Reads the rest of the file as mono.
    pub fn read_all(&mut self) -> Result<Vec<f32>, AudioError> {
        // The header's length is a claim, not a fact: a damaged one may announce 4 GB.
        let mut all = Vec::with_capacity(self.frames_total.min(1 << 22) as usize);
        let mut block = Vec::new();
        while self.read_block(1 << 16, &mut block)? > 0 {
            all.extend_from_slice(&block);
        }
        Ok(all)
    }
}

/// Input frames per resampler chunk: decisions can be taken this often (1.5 ms at
/// 44.1 kHz), so the chunk adds little latency.
pub(crate) const RESAMPLER_CHUNK: usize = 64;

/// A sample this close to full scale is clipped (a 16-bit sample within 33 steps of
/// it): the input's gain was too high for the sound, whose spectrum is then no longer
/// its take's.
pub const CLIP_LEVEL: f32 = 0.999;
/// Length of the resampler's windowed-sinc filter. Its delay, half of it, is removed
/// from the output; 128 taps cost about 1.5 ms of latency at 44.1 kHz.
pub(crate) const RESAMPLER_SINC_LEN: usize = 128;
/// The window of the resampler's sinc filter.
const RESAMPLER_WINDOW: WindowFunction = WindowFunction::BlackmanHarris2;

/// The part of the output's band, from 0 Hz up to this fraction of its Nyquist
/// frequency, that the resampler passes unchanged. rubato places the filter's cutoff
/// so that its transition band, centred on the cutoff, ends at the Nyquist frequency:
/// the passband ends as far below the cutoff, at twice the cutoff less one (0.789 of
/// the Nyquist frequency for 128 taps of Blackman-Harris).
pub(crate) fn resampler_passband() -> f64 {
    2.0 * rubato::calculate_cutoff::<f64>(RESAMPLER_SINC_LEN, RESAMPLER_WINDOW) - 1.0
}

/// A windowed-sinc resampler (rubato) fed with blocks of any size. Input is collected
/// into fixed chunks, so the output is the same whatever the block sizes; the resampler's
/// own delay is removed, so output sample `n` is at time `n / output_rate`.
pub struct StreamResampler {
    inner: Async<f32>,
    from: u32,
    to: u32,
    chunk: Vec<f32>,
    filled: usize,
    out: Vec<f32>,
    delay_left: usize,
    consumed: u64,
    produced: u64,
}

impl StreamResampler {
    pub fn new(from: u32, to: u32) -> Result<Self, AudioError> {
        let parameters = SincInterpolationParameters::new(RESAMPLER_SINC_LEN, RESAMPLER_WINDOW);
        let inner = Async::<f32>::new_sinc(
            f64::from(to) / f64::from(from),
            1.0,
            &parameters,
            RESAMPLER_CHUNK,
            1,
            FixedAsync::Input,
        )
        .map_err(|e| AudioError::Resample {
            from,
            to,
            reason: e.to_string(),
        })?;
        let chunk_len = inner.input_frames_next();
        let out_len = inner.output_frames_max();
        let delay_left = inner.output_delay();
        Ok(Self {
            inner,
            from,
            to,
            chunk: vec![0.0; chunk_len],
            filled: 0,
            out: vec![0.0; out_len],
            delay_left,
            consumed: 0,
            produced: 0,
        })
    }

    /// Input samples consumed so far.
    pub fn consumed(&self) -> u64 {
        self.consumed
    }

    /// Feeds `input`; `sink` receives each resampled piece together with the number of
    /// input samples consumed when it became available.
    pub fn push(&mut self, mut input: &[f32], sink: &mut dyn FnMut(&[f32], u64)) {
        while !input.is_empty() {
            let take = (self.chunk.len() - self.filled).min(input.len());
            self.chunk[self.filled..self.filled + take].copy_from_slice(&input[..take]);
            self.filled += take;
            self.consumed += take as u64;
            input = &input[take..];
            if self.filled == self.chunk.len() {
                self.run_chunk(None, sink);
            }
        }
    }

    /// Flushes what is buffered and the resampler's delay, so that the total output is
    /// `round(consumed * to / from)` samples.
    pub fn finish(&mut self, sink: &mut dyn FnMut(&[f32], u64)) {
        let expected =
            (self.consumed as f64 * f64::from(self.to) / f64::from(self.from)).round() as u64;
        let partial = self.filled;
        self.run_chunk_limited(Some(partial), expected, sink);
        while self.produced < expected {
            self.run_chunk_limited(Some(0), expected, sink);
        }
    }

    fn run_chunk(&mut self, partial: Option<usize>, sink: &mut dyn FnMut(&[f32], u64)) {
        self.run_chunk_limited(partial, u64::MAX, sink);
    }

    fn run_chunk_limited(
        &mut self,
        partial: Option<usize>,
        limit: u64,
        sink: &mut dyn FnMut(&[f32], u64),
    ) {
        let frames_in = self.chunk.len();
        let frames_out = self.out.len();
        // Both adapters wrap buffers sized from the resampler's own figures, so neither
        // construction nor processing can fail; a failure is a bug, reported as silence.
        let (Ok(input), Ok(mut output)) = (
            InterleavedSlice::new(&self.chunk[..], 1, frames_in),
            InterleavedSlice::new_mut(&mut self.out[..], 1, frames_out),
        ) else {
            debug_assert!(false, "resampler buffers have the wrong size");
            return;
        };
        let indexing = partial.map(|n| Indexing {
            partial_len: Some(n),
            ..Indexing::default()
        });
        let written = match self
            .inner
            .process_into_buffer(&input, &mut output, indexing.as_ref())
        {
            Ok((_, written)) => written,
            Err(_) => {
                debug_assert!(false, "resampler rejected its own buffers");
                0
            }
        };
        self.filled = 0;
        let skip = self.delay_left.min(written);
        self.delay_left -= skip;
        let room = limit.saturating_sub(self.produced) as usize;
        let end = written.min(skip.saturating_add(room));
        if end > skip {
            self.produced += (end - skip) as u64;
            sink(&self.out[skip..end], self.consumed);
        }
    }
}

/// Resamples a whole clip (patterns, test signals). Allocates; not for the stream path.
pub fn resample_clip(samples: &[f32], from: u32, to: u32) -> Result<Vec<f32>, AudioError> {
    if from == to {
        return Ok(samples.to_vec());
    }
    let mut resampler = StreamResampler::new(from, to)?;
    let mut out =
        Vec::with_capacity((samples.len() as f64 * f64::from(to) / f64::from(from)) as usize + 16);
    let mut sink = |piece: &[f32], _: u64| out.extend_from_slice(piece);
    resampler.push(samples, &mut sink);
    resampler.finish(&mut sink);
    Ok(out)
}
