//! # rtseq — a hard-real-time sequencer for microcontroller motor controllers
//!
//! rtseq implements the sequencer of the EEROS robotics framework — a tree of sequences and
//! steps, started blocking or non-blocking, with pre- and exit conditions, monitors
//! (condition + exception sequence + behaviour), a timeout monitor on every sequence and
//! seven running states — without threads, heap or polling loops:
//!
//! * the tree is statically allocated: control blocks live in the [`Sequencer`] (usually a
//!   `static`), sequence futures in their lanes' static task storage;
//! * the tree's configuration can be a [`Table`] checked by a `const fn`: a bad tree is a
//!   compile error, and the firmware only copies it in ([`Sequencer::install`]);
//! * a sequence's action is an `async fn`, i.e. a cooperative, statically sized state
//!   machine; a blocking start is an `.await` inside the caller ([`Cx::run`], [`Cx::step`]),
//!   a non-blocking start runs the sequence in its [`lane`] ([`Cx::start`]);
//! * the heartbeat [`Sequencer::tick`], called from a periodic timer interrupt, evaluates
//!   monitors and timeouts at each sequence's polling period and wakes exactly the lanes
//!   that must act;
//! * the `sim` module (feature `std`) runs the same code on the host in simulated time.
//!
//! See the README for the mapping of every term of the specification to rtseq.
#![no_std]
#![deny(missing_docs, unsafe_op_in_unsafe_fn)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod bits;
mod condition;
mod config;
mod context;
mod control_block;
mod engine;
mod error;
mod handle;
mod id;
mod lane;
pub mod lock;
mod monitor;
mod polling;
mod sequence;
mod sequencer;
mod state;
mod table;
pub(crate) mod tick;
mod time;
mod trace;
mod tree;
mod wait;

pub mod safety;
#[cfg(feature = "std")]
pub mod sim;

pub use bits::MAX_SEQUENCES;
pub use condition::{Condition, Stable, Toggle};
pub use config::SeqConfig;
pub use context::Cx;
#[cfg(feature = "counters")]
pub use control_block::Counters;
pub use error::Error;
pub use handle::{CallerStack, Handle};
pub use id::{MonitorId, SeqId};
pub use lane::lane;
pub use monitor::{
    Behaviour, DynCondition, Monitor, Monitors, OwnedMonitor, Trigger, DEFAULT_RESTART_LIMIT,
};
pub use polling::MAX_POLLING_CLASSES;
pub use sequence::{Seq, Sequence, Step};
pub use sequencer::Sequencer;
pub use state::{Cause, Outcome, RunningState};
pub use table::Table;
pub use time::{Duration, Instant};
pub use trace::Transition;
pub use wait::Wait;

/// Maximum nesting of callers (`callerStack` length). Starting deeper is an
/// [`Error::CallerDepthExceeded`].
pub const MAX_DEPTH: usize = 8;

/// The README's examples are compiled and run as doctests (they use the simulator).
#[cfg(all(doctest, feature = "std"))]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
