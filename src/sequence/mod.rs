//! Sequences and steps (seed §1.3–§1.5): the traits an application implements, the
//! [`Seq`] that binds one to its id, the context [`Cx`] it works with, and how it runs.
//!
//! | file | what |
//! |---|---|
//! | `mod.rs` | [`Sequence`], [`Step`], [`Seq`] |
//! | `context.rs` | [`Cx`]: what an action and a condition see and can do |
//! | `run.rs` | a run: the seed's `actionFramework` as a state machine, with its diagram |
//! | `erased.rs` | all type erasure (and so all `unsafe`) of this module, its invariants listed |
//! | `lane.rs` | [`lane`](fn@crate::lane): a non-blocking sequence's execution context; [`lanes!`](crate::lanes) (several joined in one task) |
//! | `scoped.rs` | [`Scoped`]: a non-blocking child that ends with its caller's action |
//! | `wait.rs` | [`Wait`], the dwell-time step |

pub(crate) mod context;
pub(crate) mod erased;
pub(crate) mod lane;
pub(crate) mod run;
pub(crate) mod scoped;
pub(crate) mod wait;

pub use context::Cx;
pub use lane::lane;
pub use scoped::Scoped;
pub use wait::Wait;

use crate::{Failure, SeqId};

/// A sequence: an `async` action made of steps and sub-sequences, plus the optional pre- and
/// exit conditions.
///
/// The action is an `async fn`: the compiler turns it into a statically sized state machine.
/// Started blocking ([`Cx::run`]) it runs inside its caller's future; started non-blocking
/// ([`Cx::start`], [`Handle::start`](crate::Handle::start)) it runs in its lane
/// ([`lane`](fn@crate::lane)). It must not block: wait with steps and their exit conditions.
///
/// ```
/// use rtseq::{Cx, Failure, Seq, Sequence, Step};
/// struct Enable;
/// impl Step<()> for Enable {
///     fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
/// }
/// struct PowerOn { enable: Seq<Enable> }
/// impl Sequence<()> for PowerOn {
///     async fn action(&mut self, cx: &Cx<'_, ()>) -> Result<(), Failure> {
///         cx.step(&mut self.enable).await?;
///         Ok(())
///     }
/// }
/// ```
///
/// # Panic-free actions
///
/// rtseq itself has no panic path (the board's no-panic build proves it), but every
/// `async fn` that returns carries a compiler-generated "`async fn` resumed after completion"
/// panic path of its own. Firmware that must be provably panic-free implements `action` as a
/// plain function returning a hand-written future (the futures of [`Cx::run`] and
/// [`Cx::step`] borrow only the child, not the context, so they can be stored in it):
///
/// ```
/// use core::future::Future;
/// use core::pin::Pin;
/// use core::task::{Context, Poll};
/// use rtseq::{Cx, Failure, Seq, Sequence, Step};
/// struct Enable;
/// impl Step<()> for Enable {
///     fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
/// }
/// struct PowerOn { enable: Seq<Enable> }
/// impl Sequence<()> for PowerOn {
///     fn action<'a, 'b, 'c>(&'a mut self, cx: &'b Cx<'c, ()>)
///         -> impl Future<Output = Result<(), Failure>> + use<'a, 'b, 'c>
///     {
///         // Drop the outcome: a future adapter that cannot panic.
///         struct Ignore<F>(F);
///         impl<F: Future> Future for Ignore<F> {
///             type Output = Result<(), Failure>;
///             fn poll(self: Pin<&mut Self>, w: &mut Context<'_>) -> Poll<Self::Output> {
///                 // SAFETY: `0` is structurally pinned, never moved out.
///                 unsafe { self.map_unchecked_mut(|s| &mut s.0) }.poll(w).map(|_| Ok(()))
///             }
///         }
///         Ignore(cx.step(&mut self.enable))
///     }
/// }
/// ```
#[allow(async_fn_in_trait)] // lanes poll on one core: no `Send` bound wanted
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not a `Sequence<{C}>`",
    label = "not a sequence of this control system",
    note = "`Cx::run` runs a `Sequence`; a `Step` (one command and an exit condition) is run with `Cx::step`"
)]
pub trait Sequence<C> {
    /// The sequence's work: starts steps and sub-sequences and awaits them. `Err` ends the
    /// run at once with [`Outcome::Failed`](crate::Outcome::Failed) (no exit condition is polled); `?` on a child's
    /// result hands its abort or failure on.
    async fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure>;

    /// Checked before the action; `false` skips the run (outcome [`Outcome::Skipped`](crate::Outcome::Skipped)).
    fn check_pre_condition(&mut self, _cx: &Cx<'_, C>) -> bool {
        true
    }

    /// Checked right after the action, then at every poll of the sequence's polling
    /// period; the run ends when it is `true`. Default: ends right after the action.
    fn check_exit_condition(&mut self, _cx: &Cx<'_, C>) -> bool {
        true
    }
}

/// A step: one command to the control or safety system, then its exit condition is polled.
/// Always started blocking ([`Cx::step`]).
///
/// ```
/// use core::sync::atomic::{AtomicI32, Ordering::Relaxed};
/// use rtseq::{Cx, Failure, Step};
/// struct Axis { setpoint: AtomicI32, position: AtomicI32 }
/// struct MoveTo(i32);
/// impl Step<Axis> for MoveTo {
///     fn action(&mut self, cx: &Cx<'_, Axis>) -> Result<(), Failure> {
///         cx.control().setpoint.store(self.0, Relaxed);
///         Ok(())
///     }
///     fn check_exit_condition(&mut self, cx: &Cx<'_, Axis>) -> bool {
///         (cx.control().position.load(Relaxed) - self.0).abs() <= 2
///     }
/// }
/// ```
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not a `Step<{C}>`",
    label = "not a step of this control system",
    note = "`Cx::step` runs a `Step`; a `Sequence` (an async action) is run with `Cx::run`"
)]
pub trait Step<C> {
    /// The single, non-blocking command. `Err` ends the step at once with
    /// [`Outcome::Failed`](crate::Outcome::Failed) (no exit condition is polled).
    fn action(&mut self, cx: &Cx<'_, C>) -> Result<(), Failure>;

    /// Checked before the action; `false` skips the step.
    fn check_pre_condition(&mut self, _cx: &Cx<'_, C>) -> bool {
        true
    }

    /// Checked right after the action, then at every poll of the step's polling period;
    /// the step ends when it is `true`.
    fn check_exit_condition(&mut self, _cx: &Cx<'_, C>) -> bool {
        true
    }
}

/// A sequence or step object bound to its registered id: what callers own and run.
///
/// Created by [`Sequencer::add`](crate::Sequencer::add) or
/// [`Sequencer::bind`](crate::Sequencer::bind), once per id. It belongs to the sequencer
/// that made it: another sequencer refuses it (started blocking there the child's result
/// is `Err(Failure::NotStarted(Error::ForeignSequence(id)))`; as a lane there it never runs,
/// so a start of its id says `NoLane`, or `LaneCapacityExceeded` once every slot is
/// declared), even when the id names a sequence there too.
/// Sequencers are told apart by a 16-bit tag given at their first registration, so among more than
/// 65 535 sequencers made in one program two may share one.
///
/// ```
/// use rtseq::{Duration, SeqConfig, Sequencer, Wait};
/// let seq: Sequencer<(), 2> = Sequencer::new();
/// let mut dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5))).unwrap();
/// dwell.body_mut().set_duration(Duration::from_millis(8)); // configure before the next run
/// assert_eq!(seq.sequence_by_id(dwell.id()).unwrap().name(), "dwell");
/// ```
pub struct Seq<S> {
    pub(crate) body: S,
    pub(crate) head: SeqHead,
}

/// The part of a [`Seq`] that does not depend on the body type.
pub(crate) struct SeqHead {
    pub(crate) id: SeqId,
    /// The tag of the sequencer that made it ([`State::tag`](crate::sequencer::state::State)):
    /// a lane or a blocking start refuses the object of another sequencer.
    pub(crate) maker: u16,
}

impl<S> Seq<S> {
    /// The registered id.
    ///
    /// ```
    /// use rtseq::{Duration, SeqConfig, Sequencer, Wait};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let settle = seq.register(SeqConfig::new("settle")).unwrap();
    /// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5))).unwrap();
    /// assert_eq!(dwell.id().index(), 1); // registered after `settle`
    /// assert_ne!(dwell.id(), settle);
    /// ```
    pub fn id(&self) -> SeqId {
        self.head.id
    }

    /// The sequence object.
    ///
    /// ```
    /// use rtseq::{Duration, SeqConfig, Sequencer, Wait};
    /// let seq: Sequencer<(), 2> = Sequencer::new();
    /// let dwell = seq.add(SeqConfig::new("dwell"), Wait::new(Duration::from_millis(5))).unwrap();
    /// assert_eq!(dwell.body().duration(), Duration::from_millis(5));
    /// ```
    pub fn body(&self) -> &S {
        &self.body
    }

    /// The sequence object, mutably (e.g. to set a target before running it).
    ///
    /// A caller sets a step's target before each run:
    ///
    /// ```
    /// # #[cfg(feature = "std")] {
    /// use core::cell::Cell;
    /// use rtseq::{sim::Sim, Cx, Failure, Monitors, Seq, SeqConfig, Sequence, Sequencer, Step};
    /// struct MoveTo(i32);
    /// impl Step<Cell<i32>> for MoveTo {
    ///     fn action(&mut self, cx: &Cx<'_, Cell<i32>>) -> Result<(), Failure> {
    ///         cx.control().set(self.0);
    ///         Ok(())
    ///     }
    /// }
    /// struct Scan(Seq<MoveTo>);
    /// impl Sequence<Cell<i32>> for Scan {
    ///     async fn action(&mut self, cx: &Cx<'_, Cell<i32>>) -> Result<(), Failure> {
    ///         for target in [10, 20, 30] {
    ///             self.0.body_mut().0 = target;
    ///             let _ = cx.step(&mut self.0).await;
    ///         }
    ///         Ok(())
    ///     }
    /// }
    /// let seq: Sequencer<Cell<i32>, 2> = Sequencer::new();
    /// let move_to = seq.add(SeqConfig::new("move to"), MoveTo(0)).unwrap();
    /// let scan = seq.add(SeqConfig::new("scan"), Scan(move_to)).unwrap();
    /// let (id, setpoint) = (scan.id(), Cell::new(0));
    /// let mut sim = Sim::new(&seq, &setpoint, Monitors::<Cell<i32>, 1>::new());
    /// sim.lane(scan);
    /// sim.start(id).unwrap();
    /// assert_eq!(setpoint.get(), 30);
    /// # }
    /// ```
    pub fn body_mut(&mut self) -> &mut S {
        &mut self.body
    }
}
