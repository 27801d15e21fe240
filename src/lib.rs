//! onomato: turns short vocal sounds ("tick", "pop", "chhh") into timed events for
//! animation and game engines.
//!
//! The library holds everything; the `onomato` binary is a thin command-line layer
//! ([`cli`]). Modules, by concern: [`config`] (TOML and command-line settings),
//! [`audio`] (WAV in, resampling), [`pattern`] (enrolled takes), [`detect`] (the one
//! streaming detection core), [`solver`] (the bounce solver), [`analyze`] (the offline
//! command and its output formats), [`eval`] (scoring against an annotation),
//! [`input`] (the microphone and replayed files, into a ring; `listen` and `record`),
//! [`daemon`] and [`output`] (`listen`'s threads), [`status`] (the counters they share).
//!
//! The detector's stages are private modules that its public types' documentation links
//! to: `cargo doc --document-private-items` renders those links.
#![allow(rustdoc::private_intra_doc_links)]

pub mod analyze;
pub mod audio;
pub mod cli;
pub mod config;
pub mod daemon;
pub mod detect;
pub mod eval;
pub mod input;
pub mod live_bounce;
pub mod output;
pub mod pattern;
pub mod plot;
pub mod record;
pub mod render;
pub mod solver;
pub mod status;

pub use config::{Config, DetectorSettings, Method, PatternKind};
pub use detect::{Detector, Event};
pub use pattern::Pattern;
