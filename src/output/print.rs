//! [`Printer`]: the events as lines on stdout (`--print text|json`) and, in a terminal,
//! the input level under them on stderr, written by a thread of its own.
//!
//! The output thread formats a line and hands it over through a bounded queue without
//! waiting. A reader of stdout that stops reading (a pipe nobody drains, a paused
//! terminal) then blocks only the printing thread: once the queue is full, lines are
//! dropped and counted, and OSC, MIDI and detection go on as if nothing happened.

use std::io::Write;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use crate::config::PatternKind;
use crate::detect::Event;

use super::PrintMode;

/// Lines waiting for a slow reader: a burst of events of several seconds.
pub const PRINT_QUEUE: usize = 1024;
/// How long the stop waits for the queued lines to be written.
const FINISH_WAIT: Duration = Duration::from_secs(2);

enum Line {
    Event(String),
    /// The level line: level (dBFS), stream seconds, events sent.
    Meter(f32, f64, u64),
}

/// The printing thread's handle.
pub struct Printer {
    mode: PrintMode,
    tx: Option<SyncSender<Line>>,
    done: Receiver<()>,
    thread: Option<JoinHandle<()>>,
    /// Lines queued, and lines the thread has written (or tried to, into a closed
    /// stdout).
    sent: u64,
    written: Arc<AtomicU64>,
    dropped: u64,
}

impl Printer {
    /// Starts the printing thread into `out` (stdout in the daemon); `meter`: draw the
    /// level line on stderr between events.
    pub fn start(
        mode: PrintMode,
        meter: bool,
        capacity: usize,
        out: impl Write + Send + 'static,
    ) -> Self {
        let (tx, rx) = mpsc::sync_channel::<Line>(capacity);
        let (done_tx, done) = mpsc::channel();
        let written = Arc::new(AtomicU64::new(0));
        let counter = written.clone();
        let thread = std::thread::Builder::new()
            .name("onomato-print".into())
            .spawn(move || {
                write_lines(rx, out, meter, &counter);
                let _ = done_tx.send(());
            })
            .map_err(|e| tracing::warn!("cannot start the printing thread; printing nothing: {e}"))
            .ok();
        Self {
            mode,
            tx: thread.as_ref().map(|_| tx),
            done,
            thread,
            sent: 0,
            written,
            dropped: 0,
        }
    }

    /// Prints one event, unless the queue is full: then it is counted as dropped.
    /// `performer`: its performer's name, with `[[performer]]`s.
    pub fn event(&mut self, performer: Option<&str>, e: &Event, begin_sent: bool) {
        let Some(line) = format_event(performer, e, begin_sent, self.mode) else {
            return;
        };
        let Some(tx) = &self.tx else { return };
        match tx.try_send(Line::Event(line)) {
            Ok(()) => self.sent += 1,
            Err(TrySendError::Full(_)) => {
                self.dropped += 1;
                // The first, then one in a thousand: a reader that is gone must not
                // flood the log.
                if self.dropped % 1000 == 1 {
                    tracing::warn!(
                        dropped = self.dropped,
                        "stdout is not being read; printed lines are dropped (OSC and MIDI go on)"
                    );
                }
            }
            Err(TrySendError::Disconnected(_)) => self.tx = None,
        }
    }

    /// Draws the level line, if the queue has room (it is redrawn soon anyway).
    pub fn meter(&mut self, level_db: f32, stream_seconds: f64, events: u64) {
        if let Some(tx) = &self.tx {
            let _ = tx.try_send(Line::Meter(level_db, stream_seconds, events));
        }
    }

    /// Lines dropped so far because the reader did not keep up.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    /// Lets the queued lines be written, waiting `FINISH_WAIT` at most; returns the lines
    /// dropped, those still unwritten then included (a reader that has stopped cannot
    /// hold up the daemon's stop).
    pub fn finish(self) -> u64 {
        self.finish_within(FINISH_WAIT)
    }

    fn finish_within(mut self, wait: Duration) -> u64 {
        drop(self.tx.take());
        if self.thread.is_none() {
            return self.dropped;
        }
        if self.done.recv_timeout(wait).is_ok() {
            if let Some(t) = self.thread.take() {
                let _ = t.join();
            }
        } else {
            // The thread stays blocked in its write; the process's exit ends it.
            let unwritten = self.sent - self.written.load(Ordering::Acquire);
            tracing::warn!(
                unwritten,
                "stdout is not being read; the last printed lines are not written"
            );
            self.dropped += unwritten;
        }
        self.dropped
    }
}

fn write_lines(rx: Receiver<Line>, mut out: impl Write, meter: bool, written: &AtomicU64) {
    let mut meter_shown = false;
    for line in rx {
        match line {
            Line::Event(text) => {
                if meter_shown {
                    clear_meter();
                    meter_shown = false;
                }
                // A closed stdout (a pipe whose reader left) is not an error.
                let _ = out.write_all(text.as_bytes());
                let _ = out.flush();
                written.fetch_add(1, Ordering::Release);
            }
            Line::Meter(level_db, stream_seconds, events) if meter => {
                draw_meter(level_db, stream_seconds, events);
                meter_shown = true;
            }
            Line::Meter(..) => {}
        }
    }
    if meter_shown {
        clear_meter();
    }
}

/// The input level line on stderr: `input ####------  -23 dB   12.3 s  4 events`.
fn draw_meter(level_db: f32, stream_seconds: f64, events: u64) {
    let filled = (((level_db + 60.0) / 60.0).clamp(0.0, 1.0) * 20.0) as usize;
    let bar: String = "#".repeat(filled) + &"-".repeat(20 - filled);
    let mut err = std::io::stderr().lock();
    let _ = write!(
        err,
        "\r\x1b[K  input {bar} {level_db:6.1} dB  {stream_seconds:8.1} s  {events} events"
    );
    let _ = err.flush();
}

fn clear_meter() {
    let mut err = std::io::stderr().lock();
    let _ = write!(err, "\r\x1b[K");
    let _ = err.flush();
}

/// An event record with its performer (a name, or an index) before its own fields.
#[derive(serde::Serialize)]
pub struct PerformerEvent<'a, P: serde::Serialize> {
    pub performer: P,
    #[serde(flatten)]
    pub event: &'a Event,
}

/// One event as its printed line (with its newline); `None` when nothing is printed.
pub fn format_event(
    performer: Option<&str>,
    e: &Event,
    begin_sent: bool,
    mode: PrintMode,
) -> Option<String> {
    match mode {
        PrintMode::None => None,
        // The event record, with the performer's name first when there are performers.
        PrintMode::Json => match performer {
            None => serde_json::to_string(e),
            Some(performer) => serde_json::to_string(&PerformerEvent {
                performer,
                event: e,
            }),
        }
        .ok()
        .map(|l| l + "\n"),
        PrintMode::Text => {
            let (at, phase, held) = match (e.kind, e.end) {
                (PatternKind::Impulse, _) => (e.time, "impulse", String::new()),
                (PatternKind::Continuous, None) => (e.time, "begin", String::new()),
                (PatternKind::Continuous, Some(end)) if begin_sent => {
                    (end, "end", format!("  held {:.3} s", end - e.time))
                }
                // Begin and end decided together (waveform method).
                (PatternKind::Continuous, Some(end)) => {
                    (e.time, "held", format!("  until {end:.3} s"))
                }
            };
            let pitch = e
                .pitch
                .map(|p| format!("  pitch {p:.0} Hz"))
                .unwrap_or_default();
            let who = performer.map(|p| format!("{p:<8} ")).unwrap_or_default();
            Some(format!(
                "{at:9.3} s  {who}{:<10} {phase:<8} strength {:.2}  score {:.2}  #{:<4} decided at {:.3} s{held}{pitch}\n",
                e.pattern, e.strength, e.score, e.id, e.emitted_at
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    /// A stdout whose reader has stopped until `open` is set, recording what it got.
    #[derive(Clone)]
    struct StalledOut {
        open: Arc<std::sync::atomic::AtomicBool>,
        writing: Arc<std::sync::atomic::AtomicBool>,
        got: Arc<Mutex<Vec<u8>>>,
    }

    impl StalledOut {
        fn new() -> Self {
            Self {
                open: Arc::new(false.into()),
                writing: Arc::new(false.into()),
                got: Arc::new(Mutex::new(Vec::new())),
            }
        }
    }

    impl Write for StalledOut {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.writing.store(true, Ordering::Release);
            while !self.open.load(Ordering::Acquire) {
                std::thread::sleep(Duration::from_millis(1));
            }
            self.got.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    fn event(id: u64) -> Event {
        Event {
            id,
            pattern: "tick".into(),
            kind: PatternKind::Impulse,
            time: id as f64,
            end: None,
            strength: 1.0,
            score: 1.0,
            emitted_at: id as f64 + 0.02,
            pitch: None,
        }
    }

    #[test]
    fn a_reader_that_stops_loses_counted_lines_and_never_holds_up_the_caller() {
        let out = StalledOut::new();
        let mut printer = Printer::start(PrintMode::Json, false, 4, out.clone());
        // The thread takes one line and blocks in its write; four more fill the queue;
        // the other five are dropped, and none of the ten calls waits.
        printer.event(None, &event(0), false);
        while !out.writing.load(Ordering::Acquire) {
            std::thread::sleep(Duration::from_millis(1));
        }
        for id in 1..10 {
            printer.event(None, &event(id), false);
        }
        assert_eq!(printer.dropped(), 5);
        out.open.store(true, Ordering::Release);
        assert_eq!(printer.finish(), 5);
        let got = String::from_utf8(out.got.lock().unwrap().clone()).unwrap();
        let ids: Vec<u64> = got
            .lines()
            .map(|l| {
                serde_json::from_str::<serde_json::Value>(l).unwrap()["id"]
                    .as_u64()
                    .unwrap()
            })
            .collect();
        assert_eq!(ids, [0, 1, 2, 3, 4]);
    }

    #[test]
    fn the_stop_does_not_wait_for_a_reader_that_never_comes_back() {
        let mut printer = Printer::start(PrintMode::Text, false, 8, StalledOut::new());
        for id in 0..3 {
            printer.event(None, &event(id), false);
        }
        // Three lines never written: one in the blocked write, two queued.
        assert_eq!(printer.finish_within(Duration::from_millis(50)), 3);
    }
}
