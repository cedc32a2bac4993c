//! # rtseq — a hard-real-time sequencer for microcontroller motor controllers
//!
//! rtseq implements the sequencer of the EEROS robotics framework — a tree of sequences and
//! steps, started blocking or non-blocking, with pre- and exit conditions, monitors
//! (condition + exception sequence + behaviour), a timeout monitor on every sequence and
//! seven running states, plus a [`safety`] system with levels and events — without threads,
//! heap or polling loops:
//!
//! * the tree is statically allocated: control blocks live in the [`Sequencer`] (usually a
//!   `static`), sequence futures in their lanes' static task storage;
//! * the tree's configuration can be a [`Table`] checked by a `const fn`: a bad tree is a
//!   compile error, and the firmware only copies it in ([`Sequencer::install`]);
//! * a sequence's action is an `async fn`, i.e. a cooperative, statically sized state
//!   machine; a blocking start is an `.await` inside the caller ([`Cx::run`], [`Cx::step`]),
//!   a non-blocking start runs the sequence in its [`lane`](fn@lane) ([`Cx::start`]);
//! * the heartbeat [`Sequencer::tick`], called from a periodic timer interrupt, evaluates
//!   monitors and timeouts at each sequence's polling period and wakes exactly the lanes
//!   that must act;
//! * the `sim` module (feature `std`) runs the same code on the host in simulated time.
//!
//! ## Example
//!
//! A homing sequence of two steps, guarded by a monitor that aborts it when the axis
//! over-travels, run on the host simulator (on the chip the same sequence runs in an RTIC
//! task, see [the README](https://github.com/rtseq/rtseq#on-the-chip-rtic-wiring)):
//!
//! ```
//! # #[cfg(feature = "std")] {
//! use core::cell::Cell;
//! use rtseq::sim::Sim;
//! use rtseq::{Behaviour, Cx, Duration, Failure, Instant, Monitor, Monitors, Outcome, Seq,
//!             SeqConfig, Sequence, Sequencer, Step};
//!
//! /// The control system: what steps command and conditions read.
//! #[derive(Default)]
//! struct Axis { position: Cell<f32>, velocity: Cell<f32>, zero: Cell<f32> }
//!
//! /// A step: one command, then its exit condition is polled.
//! struct SeekEndStop;
//! impl Step<Axis> for SeekEndStop {
//!     fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
//!         cx.control().velocity.set(-20.0);
//!         Ok(())
//!     }
//!     fn check_exit_condition(&mut self, cx: &Cx<'_, Axis>) -> bool {
//!         cx.control().position.get() <= -50.0
//!     }
//! }
//! struct SetZero;
//! impl Step<Axis> for SetZero {
//!     fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
//!         cx.control().velocity.set(0.0);
//!         cx.control().zero.set(cx.control().position.get());
//!         Ok(())
//!     }
//! }
//!
//! /// A sequence: an `async fn` of blocking starts.
//! struct Homing { seek: Seq<SeekEndStop>, zero: Seq<SetZero> }
//! impl Sequence<Axis> for Homing {
//!     async fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
//!         // `?`: an aborted or failed step ends homing with the same failure.
//!         cx.step(&mut self.seek).await?;
//!         cx.step(&mut self.zero).await?;
//!         Ok(())
//!     }
//! }
//!
//! // Registration (on the chip: a `static` sequencer, filled in RTIC's `init`).
//! let seq: Sequencer<Axis, 8> = Sequencer::new();
//! let cfg = |name| SeqConfig::new(name).polling(Duration::from_millis(10));
//! let homing = Homing {
//!     seek: seq.add(cfg("seek"), SeekEndStop).unwrap(),
//!     zero: seq.add(cfg("zero"), SetZero).unwrap(),
//! };
//! let homing = seq.add(cfg("homing").timeout(Duration::from_secs(5)), homing).unwrap();
//! let id = homing.id();
//!
//! // A monitor owned by homing: over-travel aborts it (and every sequence it started).
//! let mut over_travel = |a: &Axis, _: Instant| a.position.get() < -60.0;
//! let mut monitors = Monitors::<Axis, 1>::new();
//! monitors
//!     .add(id, Monitor::new("over-travel", &mut over_travel, Behaviour::AbortOwner))
//!     .unwrap();
//!
//! // The host simulator: a lane for homing, a plant model stepped before every 1 ms tick.
//! let axis = Axis::default();
//! let mut sim = Sim::new(&seq, &axis, monitors);
//! sim.lane(homing);
//! sim.before_tick(|_, a| a.position.set(a.position.get() + a.velocity.get() * 0.001));
//! sim.start(id).unwrap();
//! sim.run_until_idle(Duration::from_secs(10));
//! assert_eq!(sim.handle(id).unwrap().last_outcome(), Some(Outcome::Completed));
//! assert!(axis.zero.get() <= -50.0);
//! # }
//! ```
//!
//! ## Where to read on
//!
//! * [`Sequence`], [`Step`] and [`Cx`]: writing sequences; [`Monitor`] and [`Behaviour`]:
//!   what happens when a condition fires; [`SeqConfig`]: polling period, timeout, cleanup;
//! * [`Sequencer`]: registration, the tick, requests, the trace; [`Handle`]: one
//!   sequence's state, caller stack and requests; [`lock`]: the locks;
//! * [`safety`]: safety levels, events, critical inputs and outputs;
//! * the [user's guide](https://github.com/rtseq/rtseq#readme) (how to structure an
//!   application, RTIC wiring, semantics, figures), the
//!   [firmware guide](https://github.com/rtseq/rtseq/blob/main/docs/firmware-guide.md)
//!   (sizing `N`, `T`, `W`, `B` and the monitor table, the time base, which RTIC priority
//!   may call what, a debounced following-error monitor, what to watch in production) and
//!   the [architecture](https://github.com/rtseq/rtseq/blob/main/docs/architecture.md).
//!
//! ## Features
//!
//! The crate is `no_std` and allocates nothing, with every feature set but `std`, whose host
//! simulator (`sim`) uses the heap; none is on by default.
//!
#![cfg_attr(feature = "document-features", doc = document_features::document_features!())]
#![cfg_attr(
    not(feature = "document-features"),
    doc = "See `[features]` in the crate's Cargo.toml."
)]
#![cfg_attr(docsrs, feature(doc_cfg))]
#![no_std]
#![deny(missing_docs, unsafe_op_in_unsafe_fn)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

mod condition;
mod declare;
pub mod lock;
mod model;
mod monitor;
mod names;
mod sequence;
mod sequencer;
mod tick;
mod trace;

pub mod safety;
#[cfg_attr(docsrs, doc(cfg(feature = "std")))]
#[cfg(feature = "std")]
pub mod sim;

pub use condition::{Condition, Stable, Toggle};
pub use model::{
    set_words, Cause, Done, Duration, Error, ErrorMessage, Failure, Instant, MonitorId, Outcome,
    RunningState, SeqConfig, SeqId, Table, TableError, MAX_SEQUENCES,
};
pub use monitor::{
    Behaviour, ConditionFn, DynCondition, Monitor, Monitors, OwnedMonitor, Trigger,
    DEFAULT_RESTART_LIMIT,
};
pub use names::{Failures, MonitorNames, Named, Names, WithNames};
pub use sequence::{lane, Cx, Scoped, Seq, Sequence, Step, Wait};
#[cfg_attr(docsrs, doc(cfg(feature = "counters")))]
#[cfg(feature = "counters")]
pub use sequencer::control_block::Counters;
pub use sequencer::handle::{CallerStack, Handle};
pub use sequencer::validation::{ConfigError, Raiser};
pub use sequencer::Sequencer;
pub use tick::schedule::MAX_POLLING_CLASSES;
pub use trace::{Entry, Event, Record, Request, Requester, Transition};

/// Maximum nesting of callers (`callerStack` length). Starting deeper is an
/// [`Error::CallerDepthExceeded`].
///
/// A chain of ten, each starting the next and waiting for it: `s8` has eight callers
/// (`s0` to `s7`), so its start of `s9` is refused, and the failure climbs the chain.
///
/// ```
/// # #[cfg(feature = "std")] {
/// use rtseq::{lock::CriticalSection, sim::Sim, Cx, Error, Failure, Monitors, Outcome,
///             SeqConfig, SeqId, Sequence, Sequencer, MAX_DEPTH};
/// struct Link(Option<SeqId>);
/// impl Sequence<()> for Link {
///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
///         if let Some(next) = self.0 {
///             cx.start(next)?;
///             cx.join(next).await?.done()?;
///         }
///         Ok(())
///     }
/// }
/// // Ten sequences, each in a lane of its own.
/// let seq: Sequencer<(), 10, 64, CriticalSection, 10> = Sequencer::new();
/// let names = ["s9", "s8", "s7", "s6", "s5", "s4", "s3", "s2", "s1", "s0"];
/// let (mut next, mut links) = (None, Vec::new());
/// for name in names {
///     let link = seq.add(SeqConfig::new(name), Link(next)).unwrap();
///     next = Some(link.id());
///     links.push(link);
/// }
/// let (s9, s8, s0) = (links[0].id(), links[1].id(), links[9].id());
/// let mut sim = Sim::new(&seq, &(), Monitors::<(), 1>::new());
/// links.into_iter().for_each(|link| sim.lane(link));
/// sim.start(s0).unwrap();
/// assert_eq!(sim.handle(s8).unwrap().caller_stack().len(), MAX_DEPTH);
/// let refused = Failure::NotStarted(Error::CallerDepthExceeded(s9));
/// assert_eq!(sim.handle(s0).unwrap().last_outcome(), Some(Outcome::Failed(refused)));
/// # }
/// ```
pub const MAX_DEPTH: usize = 8;

/// The README's examples are compiled and run as doctests (they use the simulator).
#[cfg(all(doctest, feature = "std"))]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;

/// So are the examples of docs/safety.md (the second on the simulator).
#[cfg(all(doctest, feature = "std"))]
#[doc = include_str!("../docs/safety.md")]
struct SafetyDocDoctests;

/// And the firmware guide's (the debounce on the simulator).
#[cfg(all(doctest, feature = "std"))]
#[doc = include_str!("../docs/firmware-guide.md")]
struct FirmwareGuideDoctests;

/// And the changelog's migration example (on the simulator).
#[cfg(all(doctest, feature = "std"))]
#[doc = include_str!("../CHANGELOG.md")]
struct ChangelogDoctests;
