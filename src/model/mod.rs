//! The model: the specification's vocabulary as plain data, shared by every other module.
//!
//! Running states and their transition table, causes and outcomes, the ids of sequences and
//! monitors, sequencer time, a sequence's configuration and a whole tree's [`Table`], sets of
//! sequences, and the errors. Nothing here knows about locks or lanes; a [`Table`] is the
//! one piece that builds the sequencer's own data (control blocks, polling classes) at
//! compile time.

pub(crate) mod config;
pub(crate) mod error;
pub(crate) mod id;
pub(crate) mod message;
pub(crate) mod outcome;
pub(crate) mod set;
pub(crate) mod state;
pub(crate) mod table;
pub(crate) mod time;

pub use config::SeqConfig;
pub use error::{Error, TableError};
pub use id::{MonitorId, SeqId};
pub use message::ErrorMessage;
pub use outcome::{Cause, Done, Failure, Outcome};
pub use set::{set_words, MAX_SEQUENCES};
pub use state::RunningState;
pub use table::Table;
pub use time::{Duration, Instant};
