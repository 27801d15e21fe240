//! MIDI through JACK (the `jack` cargo feature): the port a [`super::MidiSink`] sends on.
//!
//! The output thread pushes each message into a bounded wait-free queue; JACK's process
//! thread writes the queued messages into the port's buffer at the start of its next
//! cycle, leaving in the queue what the buffer cannot take. JACK's shutdown callback (the
//! server stopped or died) only raises a flag, which the output thread reads through
//! [`Connection::lost`] before each message: the sink then drops this connection and
//! opens a new one when a server is back.

use std::ffi::{c_char, CStr};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Once};
use std::time::{Duration, Instant};

use jack::{
    AsyncClient, Client, ClientOptions, ClientStatus, Control, MidiOut, NotificationHandler, Port,
    PortFlags, ProcessHandler, ProcessScope, RawMidi,
};

use crate::config::MidiPortChoice;

/// What MIDI needs on this build, for error messages.
pub const BACKEND_HINT: &str = "this build sends MIDI through JACK: is a JACK server running?";

/// Messages waiting for JACK's next cycle. At a 1024-frame period and 48 kHz a cycle
/// lasts 21 ms; no performer makes 1024 sounds in that time.
const QUEUE: usize = 1024;

/// JACK's type name of MIDI ports.
const MIDI_TYPE: &str = "8 bit raw midi";

/// Every message the sink sends is a three-byte channel message.
type Message = [u8; 3];

/// An open output port on a running JACK server.
pub struct Connection {
    queue: rtrb::Producer<Message>,
    shut_down: Arc<ShutDown>,
    cycle: Arc<CycleClock>,
    // Dropping it deactivates and closes the client, which unregisters the port.
    _client: AsyncClient<Watch, Writer>,
}

#[derive(Default)]
struct ShutDown {
    happened: AtomicBool,
    /// JACK's status bits at the shutdown.
    status: AtomicU32,
    /// Cycles the server reported late (xruns): a receiver late in a cycle misses the
    /// messages of that cycle.
    xruns: AtomicU64,
}

/// When JACK's process thread last began a cycle, in nanoseconds after `base`.
struct CycleClock {
    base: Instant,
    last_start: AtomicU64,
}

/// JACK's notification callbacks: only the shutdown one matters here.
struct Watch(Arc<ShutDown>);

impl NotificationHandler for Watch {
    unsafe fn shutdown(&mut self, status: ClientStatus, _reason: &str) {
        // Called on a JACK thread as a signal handler would be: atomics only.
        self.0.status.store(status.bits(), Ordering::Relaxed);
        self.0.happened.store(true, Ordering::Release);
    }

    fn xrun(&mut self, _: &Client) -> Control {
        self.0.xruns.fetch_add(1, Ordering::Relaxed);
        Control::Continue
    }
}

/// JACK's process callback: the queued messages into the port's buffer.
struct Writer {
    port: Port<MidiOut>,
    queue: rtrb::Consumer<Message>,
    cycle: Arc<CycleClock>,
}

impl ProcessHandler for Writer {
    fn process(&mut self, _: &Client, scope: &ProcessScope) -> Control {
        let since = self.cycle.base.elapsed().as_nanos();
        self.cycle
            .last_start
            .store(u64::try_from(since).unwrap_or(u64::MAX), Ordering::Relaxed);
        let mut out = self.port.writer(scope);
        while let Ok(bytes) = self.queue.peek() {
            let message = RawMidi { time: 0, bytes };
            if out.write(&message).is_err() {
                // The buffer is full: the rest leaves in the next cycle.
                break;
            }
            let _ = self.queue.pop();
        }
        Control::Continue
    }
}

impl Connection {
    /// Opens the configured port as client `client` of the running server.
    pub fn open(client: &str, choice: &MidiPortChoice) -> Result<Self, String> {
        route_jack_messages_to_the_log();
        let (jack, _) = Client::new(client, ClientOptions::NO_START_SERVER)
            .map_err(|e| format!("MIDI is not available: {e} ({BACKEND_HINT})"))?;
        let port_name = match choice {
            MidiPortChoice::Connect(_) => "out",
            MidiPortChoice::Virtual(name) => name.as_str(),
        };
        let port = jack
            .register_port(port_name, MidiOut::default())
            .map_err(|e| format!("cannot open port '{port_name}': {e}"))?;
        let ours = port
            .name()
            .map_err(|e| format!("cannot name port '{port_name}': {e}"))?;
        // The receiver is looked for before activation so that a missing one costs
        // no client in the graph.
        let receiver = match choice {
            MidiPortChoice::Connect(wanted) => {
                let names = jack.ports(None, Some(MIDI_TYPE), PortFlags::IS_INPUT);
                Some(names[super::find_port(&names, wanted)?].clone())
            }
            MidiPortChoice::Virtual(_) => None,
        };
        let (producer, consumer) = rtrb::RingBuffer::new(QUEUE);
        let shut_down = Arc::new(ShutDown::default());
        let cycle = Arc::new(CycleClock {
            base: Instant::now(),
            last_start: AtomicU64::new(0),
        });
        let active = jack
            .activate_async(
                Watch(Arc::clone(&shut_down)),
                Writer {
                    port,
                    queue: consumer,
                    cycle: Arc::clone(&cycle),
                },
            )
            .map_err(|e| format!("cannot start the JACK client: {e}"))?;
        if let Some(receiver) = receiver {
            active
                .as_client()
                .connect_ports_by_name(&ours, &receiver)
                .map_err(|e| format!("cannot connect to '{receiver}': {e}"))?;
        }
        Ok(Self {
            queue: producer,
            shut_down,
            cycle,
            _client: active,
        })
    }

    pub fn send(&mut self, bytes: &[u8]) -> Result<(), String> {
        let message: Message = bytes
            .try_into()
            .map_err(|_| format!("a MIDI message of {} bytes, not 3", bytes.len()))?;
        self.queue
            .push(message)
            .map_err(|_| format!("{QUEUE} messages are waiting for JACK's process cycle"))
    }

    /// From when a sent message may not have reached the receivers: the start of the
    /// last cycle JACK ran. A message queued after it never left; one written in it
    /// left in a cycle the server may not have finished.
    pub fn undelivered_since(&self) -> Option<Instant> {
        let nanos = self.cycle.last_start.load(Ordering::Relaxed);
        Some(self.cycle.base + Duration::from_nanos(nanos))
    }

    /// Late cycles (xruns) the server has reported to this client.
    pub fn server_xruns(&self) -> u64 {
        self.shut_down.xruns.load(Ordering::Relaxed)
    }

    /// Why the port is gone, if the server shut the client down.
    pub fn lost(&self) -> Option<String> {
        if !self.shut_down.happened.load(Ordering::Acquire) {
            return None;
        }
        let status =
            ClientStatus::from_bits_truncate(self.shut_down.status.load(Ordering::Relaxed));
        Some(format!(
            "the JACK server shut the client down (status {status:?})"
        ))
    }
}

/// Names of the MIDI input ports of the running server, which `[midi] connect` can name.
pub fn list_ports(client: &str) -> Result<Vec<String>, String> {
    route_jack_messages_to_the_log();
    let (jack, _) = Client::new(client, ClientOptions::NO_START_SERVER)
        .map_err(|e| format!("MIDI is not available: {e} ({BACKEND_HINT})"))?;
    Ok(jack.ports(None, Some(MIDI_TYPE), PortFlags::IS_INPUT))
}

/// libjack prints its messages to stdout and stderr unless told otherwise; stdout
/// carries the events (`--print json`), so they go to the log instead.
fn route_jack_messages_to_the_log() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        jack::set_logger(jack::LoggerType::Custom {
            info: jack_info,
            error: jack_error,
        })
    });
}

/// # Safety
/// libjack passes a NUL-terminated string.
unsafe extern "C" fn jack_info(message: *const c_char) {
    if !message.is_null() {
        let text = unsafe { CStr::from_ptr(message) }.to_string_lossy();
        tracing::debug!(target: "jack", "{text}");
    }
}

/// # Safety
/// libjack passes a NUL-terminated string.
unsafe extern "C" fn jack_error(message: *const c_char) {
    if !message.is_null() {
        let text = unsafe { CStr::from_ptr(message) }.to_string_lossy();
        // Every failed attempt to reach a server that is not running says so here;
        // the sink logs its own, rate-limited warning.
        tracing::debug!(target: "jack", "{text}");
    }
}
