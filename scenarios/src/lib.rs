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
//! * [`Node<Child>`](Node): a sequence with a fixed set of optional ops (run up to two
//!   steps, a [`rtseq::Wait`], one blocking child of type `Child`, start non-blocking,
//!   join). Nesting the type gives the depth: [`N0`] … [`N4`]. Its action is a
//!   hand-written future ([`NodeAction`]).
//! * [`Root`]: an enum over the root shapes; every lane has the same type `Seq<Root>`.
//! * [`Scenario`]: a registration function, a script run before every tick, a duration.
//! * [`encode`] / [`decode`]: a [`rtseq::Transition`] as six integers, the wire format of
//!   the firmware's trace.
//! * [`emergency`]: the safety system of the emergency scenario (`tests/emergency.rs`,
//!   `boards/qemu-f405/src/bin/emergency.rs`), generic over the I/O type.
//!
//! ## Adding a scenario
//! Write a registration function (register names first with `Sequencer::register` so ids
//! come in a chosen order, bind bodies bottom-up with `Sequencer::bind`, add monitors with
//! conditions taken from [`Conds`]), a script (`fn(ms, &Ctrl, &Seqr)`: flags, requests
//! through handles found by name, abort-all) and add a [`Scenario`] to [`SCENARIOS`]. The
//! QEMU comparison test picks it up by itself.
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

pub use ctrl::{Conds, Ctrl, FlagCond, Summary, FLAGS};
pub use encode::{decode, encode, outcome_code, Encoded};
pub use list::SCENARIOS;
pub use node::{Done, Leaf, Never, Node, NodeAction, Op, Root, RootAction, N0, N1, N2, N3, N4};

use rtseq::{Monitors, Seq, SeqId, Sequencer};

/// Sequence capacity of a scenario's sequencer.
pub const CAPACITY: usize = 16;
/// Trace buffer of a scenario's sequencer (drained after every tick on the chip).
pub const TRACE: usize = 64;
/// Monitor capacity of a scenario.
pub const MONITORS: usize = 4;
/// Maximum number of lanes of a scenario (the firmware declares this many lane tasks).
pub const LANES: usize = 3;
/// Maximum number of sequences a scenario starts at time 0.
pub const STARTS: usize = 2;

/// The sequencer type every scenario registers into.
#[cfg(any(not(feature = "ceiling"), feature = "critical-section-lock"))]
pub type Seqr = Sequencer<Ctrl, CAPACITY, TRACE>;
/// The sequencer type every scenario registers into: on the firmware, guarded by RTIC's
/// priority ceiling (the tick runs at RTIC priority 2 of 4 NVIC priority bits).
#[cfg(all(feature = "ceiling", not(feature = "critical-section-lock")))]
pub type Seqr = Sequencer<
    Ctrl,
    CAPACITY,
    TRACE,
    rtseq::lock::PriorityCeiling<{ rtseq::lock::rtic_basepri(2, 4) }>,
>;
/// The monitor table type of a scenario.
pub type Mons<'a> = Monitors<'a, Ctrl, MONITORS>;

/// What a registration produced: the lanes (in poll order) and what to start at time 0.
pub struct Lanes {
    /// Lane root objects, in declaration (= poll) order.
    pub lanes: heapless::Vec<Seq<Root>, LANES>,
    /// Sequences started non-blocking at time 0, in this order.
    pub start: heapless::Vec<SeqId, STARTS>,
}

/// Why a registration failed (never a panic).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScenarioError {
    /// The sequencer or the monitor table refused.
    Rtseq(rtseq::Error),
    /// A [`Node`] has no room for another op, or a lane/start list is full.
    Capacity,
}

impl From<rtseq::Error> for ScenarioError {
    fn from(e: rtseq::Error) -> Self {
        ScenarioError::Rtseq(e)
    }
}

/// Registers a scenario's sequences and monitors; returns its lanes.
pub type Register = for<'a> fn(&Seqr, &mut Mons<'a>, &'a mut Conds) -> Result<Lanes, ScenarioError>;

/// Run before every tick with the tick's time in ms (1, 2, …): flag flips, requests.
pub type Script = fn(u32, &Ctrl, &Seqr);

/// One scenario: registration, script, duration.
pub struct Scenario {
    /// Unique name (the firmware's command-line argument).
    pub name: &'static str,
    /// Registers sequences and monitors.
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
