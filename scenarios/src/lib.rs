//! # rtseq-scenarios — the core scenarios, runnable on the host and on the chip
//!
//! The scenarios of rtseq's host tests (`tests/behaviours.rs`, `tests/scenarios.rs`) as
//! plain data: `no_std`, no heap, no recursion, no `async fn` (so a firmware running them
//! passes the board's no-panic proof). The same [`Scenario`] runs
//!
//! * on the host in `rtseq::sim::Sim` (`host::run`, feature `std`), and
//! * under RTIC on the emulated STM32F405 (`boards/qemu-f405/src/bin/scenarios.rs`),
//!
//! and `tests/qemu_scenarios.rs` asserts that both produce the same transition trace.
//!
//! ## Pieces
//! * [`Ctrl`]: the control system, atomic flags (a `static` on the chip) plus a digest of
//!   every action line and every outcome returned to a caller ([`Summary`]).
//! * [`Leaf`]: a step whose pre- and exit conditions are flags.
//! * [`Node`]: a sequence with a fixed set of optional ops (run up to two steps, a
//!   [`rtseq::Wait`], one blocking child, start non-blocking, join). One type for every
//!   depth of a tree: a node's blocking child lives in an [`Arena`] slot, with the room for
//!   the future that runs it. Its action is a hand-written future ([`NodeAction`]); every
//!   lane has the type `Seq<Node>`.
//! * [`Scenario`]: a set-up function, a script run before every tick, a duration.
//! * [`encode`](fn@encode) / [`decode`](fn@decode): a [`rtseq::Transition`] as six integers, the wire format of
//!   the firmware's trace.
//! * [`emergency`]: the safety system of the emergency scenario (`tests/emergency.rs`,
//!   `boards/qemu-f405/src/bin/emergency.rs`), generic over the I/O type.
//!
//! ## Adding a scenario
//! Write a set-up function: a `const` [`rtseq::Table`] of the sequences (its order is the
//! order of the ids), a `const` monitor table ([`rtseq::Monitors::table`] of [`FlagCond`]
//! monitors) and, at run time, `Sequencer::install` and the bodies bound bottom-up with
//! `Sequencer::bind`, each blocking child moved into the arena ([`Arena::child`]); nothing
//! is registered at run time, so the firmware links no registration code. Then a script (`fn(ms, &Ctrl, &Seqr)`: flags, requests through
//! handles found by name, abort-all) and add a [`Scenario`] to [`SCENARIOS`]. The QEMU
//! comparison test picks it up by itself.
#![no_std]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod ctrl;
pub mod emergency;
mod encode;
mod list;
mod node;

#[cfg(feature = "std")]
pub mod host;

pub use ctrl::{Ctrl, FlagCond, Summary, FLAGS};
pub use encode::{decode, encode, encode_event, encode_record, outcome_code, Encoded, Kind};
pub use list::SCENARIOS;
pub use node::{Arena, AtOnce, Child, Leaf, Node, NodeAction, Op};

use rtseq::{Monitors, Seq, SeqId, Sequencer};

/// Sequence capacity of a scenario's sequencer.
pub const CAPACITY: usize = 16;
/// Trace buffer of a scenario's sequencer (drained after every tick on the chip).
pub const TRACE: usize = 64;
/// Monitor capacity of a scenario.
pub const MONITORS: usize = 4;
/// Maximum number of lanes of a scenario (the firmware declares this many lane tasks).
pub const LANES: usize = 3;
/// Maximum number of blocking children ([`Node::run`]) in a scenario: the slots of its
/// [`Arena`].
pub const CHILDREN: usize = 3;
/// Maximum number of sequences a scenario starts at time 0.
pub const STARTS: usize = 2;

/// the sequencer type every scenario is installed into.
#[cfg(any(not(feature = "ceiling"), feature = "critical-section-lock"))]
pub type Seqr = Sequencer<Ctrl, CAPACITY, TRACE>;
/// the sequencer type every scenario is installed into: on the firmware, guarded by RTIC's
/// priority ceiling (the tick runs at RTIC priority 2 of 4 NVIC priority bits).
#[cfg(all(feature = "ceiling", not(feature = "critical-section-lock")))]
pub type Seqr = Sequencer<Ctrl, CAPACITY, TRACE, rtseq::lock::PriorityCeiling<2>>;
/// The monitor table type of a scenario: every condition is a [`FlagCond`], so a `const`
/// item builds the table.
pub type Mons = Monitors<'static, Ctrl, MONITORS, FlagCond>;

/// What a set-up produced: the lanes (in poll order), what to start at time 0 and the
/// monitors. The lanes' trees borrow the set-up's [`Arena`] for `'t`.
pub struct Setup<'t> {
    /// Lane root objects, in declaration (= poll) order.
    pub lanes: heapless::Vec<Seq<Node<'t>>, LANES>,
    /// Sequences started non-blocking at time 0, in this order.
    pub start: heapless::Vec<SeqId, STARTS>,
    /// The monitor table (for the tick).
    pub monitors: Mons,
}

/// Why a set-up failed (never a panic).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScenarioError {
    /// The sequencer refused (installing the table or binding a body).
    Rtseq(rtseq::Error),
    /// A [`Node`] has no room for another op, or a lane/start list is full.
    Capacity,
}

impl ScenarioError {
    /// What went wrong, as text (an rtseq error without its name or id): what the firmware
    /// prints, without linking the formatting of every error variant.
    pub const fn reason(&self) -> &'static str {
        match self {
            ScenarioError::Rtseq(e) => e.reason(),
            ScenarioError::Capacity => "a node, the arena or a lane or start list is full",
        }
    }
}

impl From<rtseq::Error> for ScenarioError {
    fn from(e: rtseq::Error) -> Self {
        ScenarioError::Rtseq(e)
    }
}

/// Installs a scenario's sequences into an empty sequencer and binds them (blocking children
/// into the arena); returns its lanes and monitors.
pub type Register = for<'t> fn(&Seqr, Arena<'t>) -> Result<Setup<'t>, ScenarioError>;

/// Run before every tick with the tick's time in ms (1, 2, …): flag flips, requests.
pub type Script = fn(u32, &Ctrl, &Seqr);

/// One scenario: set-up, script, duration.
pub struct Scenario {
    /// Unique name (the firmware's command-line argument).
    pub name: &'static str,
    /// Installs the sequences, binds them, returns the lanes and the monitors.
    pub register: Register,
    /// Run before every tick.
    pub script: Script,
    /// Number of 1 ms ticks to run.
    pub ticks: u32,
}

/// The scenario called `name`.
pub fn find(name: &str) -> Option<&'static Scenario> {
    SCENARIOS.iter().find(|s| s.name == name)
}
