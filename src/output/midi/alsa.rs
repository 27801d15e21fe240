//! MIDI through the ALSA sequencer, by midir: the port a [`super::MidiSink`] sends on in
//! the default build. Owned by the output thread.

use midir::{MidiOutput, MidiOutputConnection};

use crate::config::MidiPortChoice;

/// What MIDI needs on this build, for error messages.
pub const BACKEND_HINT: &str =
    "this build sends MIDI through the ALSA sequencer (/dev/snd/seq); build with --features jack for JACK";

/// An open output port.
pub struct Connection(MidiOutputConnection);

impl Connection {
    /// Opens the configured port as client `client`.
    pub fn open(client: &str, choice: &MidiPortChoice) -> Result<Self, String> {
        let output = MidiOutput::new(client)
            .map_err(|e| format!("MIDI is not available: {e} ({BACKEND_HINT})"))?;
        match choice {
            MidiPortChoice::Connect(wanted) => {
                let ports = output.ports();
                let names: Vec<String> = ports
                    .iter()
                    .map(|p| output.port_name(p).unwrap_or_default())
                    .collect();
                let i = super::find_port(&names, wanted)?;
                output
                    .connect(&ports[i], "out")
                    .map(Self)
                    .map_err(|e| format!("cannot connect to '{}': {e}", names[i]))
            }
            MidiPortChoice::Virtual(name) => open_virtual(output, name).map(Self),
        }
    }

    pub fn send(&mut self, bytes: &[u8]) -> Result<(), String> {
        self.0.send(bytes).map_err(|e| e.to_string())
    }

    /// From when a sent message may not have reached the receivers: the sequencer
    /// takes each message in `send`.
    pub fn undelivered_since(&self) -> Option<std::time::Instant> {
        None
    }

    /// Late cycles reported by a server: the sequencer has none.
    pub fn server_xruns(&self) -> u64 {
        0
    }

    /// Why the port is gone, if it is: the sequencer has no server that can die under
    /// its clients, so never.
    pub fn lost(&self) -> Option<String> {
        None
    }
}

#[cfg(unix)]
fn open_virtual(output: MidiOutput, name: &str) -> Result<MidiOutputConnection, String> {
    use midir::os::unix::VirtualOutput;
    output
        .create_virtual(name)
        .map_err(|e| format!("cannot open virtual port '{name}': {e}"))
}

#[cfg(not(unix))]
fn open_virtual(_output: MidiOutput, name: &str) -> Result<MidiOutputConnection, String> {
    Err(format!(
        "virtual MIDI ports are not available on this system; set [midi] connect to an existing port instead of virtual_port '{name}'"
    ))
}

/// Names of the MIDI output ports that can be connected to.
pub fn list_ports(client: &str) -> Result<Vec<String>, String> {
    let output = MidiOutput::new(client).map_err(|e| format!("MIDI is not available: {e}"))?;
    Ok(output
        .ports()
        .iter()
        .map(|p| {
            output
                .port_name(p)
                .unwrap_or_else(|e| format!("(unnamed: {e})"))
        })
        .collect())
}
