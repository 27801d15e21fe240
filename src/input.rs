//! Audio into a ring, for `listen` and `record`: the microphone through cpal ([`open_capture`]), or a
//! WAV file replayed in real time (or faster) by its own thread ([`spawn_replay`]).
//! Both write interleaved `f32` frames into the same preallocated lock-free ring
//! (rtrb) that the detector thread reads.
//!
//! The cpal callback runs on the audio thread and does nothing but convert and copy
//! into the ring; what does not fit is counted as an overrun. No locks, no logging, no
//! allocation there. The replay thread waits for room instead (a file loses nothing).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use cpal::traits::{DeviceTrait, HostTrait, StreamTrait};
use cpal::{FromSample, SizedSample};
use rtrb::{Consumer, Producer, RingBuffer};

use crate::audio::{AudioError, ChannelSelect, WavSource};
use crate::config::InputSettings;
use crate::status::Status;

#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    #[error("no audio input device: the system has no default input (see `onomato devices`)")]
    NoDefaultDevice,
    #[error("no audio input device name contains '{wanted}'; inputs: {available}")]
    NoSuchDevice { wanted: String, available: String },
    #[error("cannot list audio devices: {0}")]
    Devices(String),
    #[error("audio input '{device}': {message}")]
    Device { device: String, message: String },
    #[error("replay: {0}")]
    Replay(#[from] AudioError),
}

/// A running microphone capture. Dropping it stops the stream.
pub struct Capture {
    _stream: cpal::Stream,
    pub device: String,
    pub rate: u32,
    pub channels: u16,
}

/// Frames the ring holds for `seconds` of `channels`-channel audio at `rate`.
fn ring_samples(seconds: f64, rate: u32, channels: u16) -> usize {
    ((seconds * f64::from(rate)).ceil() as usize).max(4096) * usize::from(channels)
}

fn device_label(device: &cpal::Device) -> String {
    match device.description() {
        Ok(d) => d.name().to_string(),
        Err(_) => device.to_string(),
    }
}

/// A stream error, as the capture reports it.
#[derive(Debug, Clone)]
pub struct StreamFault {
    pub message: String,
    /// The stream is gone and must be opened again (device or server lost).
    pub fatal: bool,
}

/// Opens the configured input device and starts capturing into a new ring. The
/// `on_error` closure is called (from cpal's thread, not the audio callback) when the
/// stream reports an error; overruns of the device (xruns) are only counted.
pub fn open_capture(
    settings: &InputSettings,
    status: Arc<Status>,
    on_error: impl FnMut(StreamFault) + Send + 'static,
) -> Result<(Capture, Consumer<f32>), CaptureError> {
    let host = cpal::default_host();
    let device = match &settings.device {
        None => host
            .default_input_device()
            .ok_or(CaptureError::NoDefaultDevice)?,
        Some(wanted) => {
            let needle = wanted.to_lowercase();
            let devices: Vec<cpal::Device> = host
                .input_devices()
                .map_err(|e| CaptureError::Devices(e.to_string()))?
                .collect();
            let found = devices.iter().position(|d| {
                device_label(d).to_lowercase().contains(&needle)
                    || d.to_string().to_lowercase().contains(&needle)
                    || d.id()
                        .is_ok_and(|id| id.to_string().to_lowercase().contains(&needle))
            });
            match found {
                Some(i) => devices
                    .into_iter()
                    .nth(i)
                    .ok_or(CaptureError::NoDefaultDevice)?,
                None => {
                    return Err(CaptureError::NoSuchDevice {
                        wanted: wanted.clone(),
                        available: devices
                            .iter()
                            .map(device_label)
                            .collect::<Vec<_>>()
                            .join(", "),
                    })
                }
            }
        }
    };
    let label = device_label(&device);
    let fail = |message: String| CaptureError::Device {
        device: label.clone(),
        message,
    };
    let default = device
        .default_input_config()
        .map_err(|e| fail(format!("no usable input configuration: {e}")))?;
    let rate = settings.sample_rate.unwrap_or(default.sample_rate());
    let channels = default.channels();
    let format = default.sample_format();
    let config = cpal::StreamConfig {
        channels,
        sample_rate: rate,
        buffer_size: cpal::BufferSize::Fixed(settings.buffer_frames),
    };
    let on_error = Arc::new(std::sync::Mutex::new(on_error));
    let build = |config: cpal::StreamConfig, producer: Producer<f32>| {
        let on_error = on_error.clone();
        let status = status.clone();
        let xrun_status = status.clone();
        let errors = move |e: cpal::Error| {
            use cpal::ErrorKind as K;
            let fatal = match e.kind() {
                K::Xrun => {
                    xrun_status.add_xrun();
                    return;
                }
                K::DeviceChanged | K::RealtimeDenied | K::DeviceBusy => false,
                _ => true,
            };
            if let Ok(mut f) = on_error.lock() {
                f(StreamFault {
                    message: e.to_string(),
                    fatal,
                });
            }
        };
        match format {
            cpal::SampleFormat::F32 => {
                build_stream::<f32>(&device, config, producer, status, errors)
            }
            cpal::SampleFormat::I16 => {
                build_stream::<i16>(&device, config, producer, status, errors)
            }
            cpal::SampleFormat::I32 => {
                build_stream::<i32>(&device, config, producer, status, errors)
            }
            cpal::SampleFormat::U16 => {
                build_stream::<u16>(&device, config, producer, status, errors)
            }
            cpal::SampleFormat::U8 => build_stream::<u8>(&device, config, producer, status, errors),
            cpal::SampleFormat::I8 => build_stream::<i8>(&device, config, producer, status, errors),
            other => Err(format!("sample format {other} is not supported")),
        }
    };
    let new_ring = || RingBuffer::<f32>::new(ring_samples(settings.ring_seconds, rate, channels));
    let (producer, consumer) = new_ring();
    let (stream, consumer) = match build(config, producer) {
        Ok(s) => (s, consumer),
        Err(fixed) => {
            // Some devices refuse a fixed buffer size: take theirs rather than nothing.
            let (producer, consumer) = new_ring();
            let fallback = cpal::StreamConfig {
                buffer_size: cpal::BufferSize::Default,
                ..config
            };
            match build(fallback, producer) {
                Ok(s) => {
                    tracing::warn!(
                        device = %label,
                        buffer_frames = settings.buffer_frames,
                        "the device refused the buffer size ({fixed}); using its default"
                    );
                    (s, consumer)
                }
                Err(e) => {
                    return Err(fail(format!(
                        "cannot capture {channels} channel(s) at {rate} Hz: {e} (with {} frames per buffer: {fixed})",
                        settings.buffer_frames
                    )))
                }
            }
        }
    };
    stream
        .play()
        .map_err(|e| fail(format!("cannot start capturing: {e}")))?;
    Ok((
        Capture {
            _stream: stream,
            device: label,
            rate,
            channels,
        },
        consumer,
    ))
}

fn build_stream<T>(
    device: &cpal::Device,
    config: cpal::StreamConfig,
    mut producer: Producer<f32>,
    status: Arc<Status>,
    errors: impl FnMut(cpal::Error) + Send + 'static,
) -> Result<cpal::Stream, String>
where
    T: SizedSample + Send + 'static,
    f32: FromSample<T>,
{
    let channels = usize::from(config.channels).max(1);
    // The real-time callback: count what the device delivered (the watchdog's evidence
    // that capture is alive, whatever the threads after it do), convert, copy whole
    // frames into the ring, count the rest.
    let callback = move |data: &[T], _: &cpal::InputCallbackInfo| {
        status.add_captured((data.len() / channels) as u64);
        let fits = (data.len().min(producer.slots()) / channels) * channels;
        if let Ok(chunk) = producer.write_chunk_uninit(fits) {
            chunk.fill_from_iter(data[..fits].iter().map(|s| s.to_sample::<f32>()));
        }
        if fits < data.len() {
            status.add_overrun((data.len() - fits) as u64);
        }
    };
    device
        .build_input_stream::<T, _, _>(config, callback, errors, Some(Duration::from_secs(5)))
        .map_err(|e| e.to_string())
}

/// A replay thread's handle.
pub struct Replay {
    pub rate: u32,
    /// Channels of each frame in the ring: the file's.
    pub channels: u16,
    pub thread: std::thread::JoinHandle<Result<(), AudioError>>,
}

/// Replays `path` into a new ring, every channel interleaved as a device delivers them,
/// `buffer_frames` at a time, at `speed` times real time, `repeat` times over. Sets
/// `done` when the file has been played (or `stop` was set).
pub fn spawn_replay(
    path: &Path,
    buffer_frames: usize,
    speed: f64,
    repeat: u32,
    stop: Arc<AtomicBool>,
    done: Arc<AtomicBool>,
) -> Result<(Replay, Consumer<f32>), CaptureError> {
    let source = WavSource::open(path, ChannelSelect::Mix)?;
    let (rate, channels) = (source.sample_rate(), source.channels());
    drop(source);
    let (producer, consumer) = RingBuffer::<f32>::new(ring_samples(2.0, rate, channels));
    let path: PathBuf = path.to_path_buf();
    let thread = std::thread::Builder::new()
        .name("onomato-replay".into())
        .spawn(move || {
            let result = replay(&path, buffer_frames, speed, repeat, &stop, producer);
            done.store(true, Ordering::Release);
            result
        })
        .map_err(|e| CaptureError::Device {
            device: "replay".into(),
            message: format!("cannot start the replay thread: {e}"),
        })?;
    Ok((
        Replay {
            rate,
            channels,
            thread,
        },
        consumer,
    ))
}

fn replay(
    path: &Path,
    buffer_frames: usize,
    speed: f64,
    repeat: u32,
    stop: &AtomicBool,
    mut producer: Producer<f32>,
) -> Result<(), AudioError> {
    let mut block = Vec::with_capacity(buffer_frames);
    let start = Instant::now();
    let mut pushed = 0u64;
    for _ in 0..repeat.max(1) {
        let mut source = WavSource::open(path, ChannelSelect::Mix)?;
        let rate = f64::from(source.sample_rate());
        loop {
            if stop.load(Ordering::Acquire) {
                return Ok(());
            }
            let n = source.read_interleaved(buffer_frames, &mut block)?;
            if n == 0 {
                break;
            }
            // Pace: this block is due when the previous ones have played.
            let due = start + Duration::from_secs_f64(pushed as f64 / rate / speed);
            let now = Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
            let mut rest: &[f32] = &block;
            while !rest.is_empty() {
                let (_, left) = producer.push_partial_slice(rest);
                rest = left;
                if !rest.is_empty() {
                    if stop.load(Ordering::Acquire) {
                        return Ok(());
                    }
                    std::thread::sleep(Duration::from_millis(2));
                }
            }
            pushed += n as u64;
        }
    }
    Ok(())
}

/// The audio inputs of the default host, with their default configuration; the
/// default input is marked.
pub fn list_inputs() -> Result<Vec<String>, CaptureError> {
    let host = cpal::default_host();
    let default = host.default_input_device().and_then(|d| d.id().ok());
    let devices = host
        .input_devices()
        .map_err(|e| CaptureError::Devices(e.to_string()))?;
    Ok(devices
        .map(|d| {
            let config = d
                .default_input_config()
                .map(|c| {
                    format!(
                        "{} ch, {} Hz, {}",
                        c.channels(),
                        c.sample_rate(),
                        c.sample_format()
                    )
                })
                .unwrap_or_else(|e| format!("no input configuration: {e}"));
            let id = d.id().ok();
            let mark = if id.is_some() && id == default {
                "  [default]"
            } else {
                ""
            };
            let id = id.map(|i| i.to_string()).unwrap_or_default();
            format!("{} ({id}): {config}{mark}", device_label(&d))
        })
        .collect())
}
