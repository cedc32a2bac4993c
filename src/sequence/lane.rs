//! Lanes: statically declared execution contexts for non-blocking sequences.
//!
//! A lane is the seed's "thread that is put to sleep at once", without a thread: a future
//! (an RTIC async software task, or one of several futures joined in one task) that sleeps
//! until its sequence is started, runs it, and sleeps again.

use core::convert::Infallible;
use core::future::Future;

use crate::lock::Lock;
use crate::sequence::erased::{sequence_run, LaneRun};
use crate::sequence::run::Run;
use crate::{Cx, Seq, Sequence, Sequencer};

/// Runs `seq` every time it is started non-blocking, forever.
///
/// In RTIC, one async software task per lane; its body is one line:
///
/// ```
/// use rtseq::{lane, Cx, Failure, Seq, Sequence, Sequencer};
/// struct Blink;
/// impl Sequence<()> for Blink {
///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
/// }
/// static SEQ: Sequencer<(), 4> = Sequencer::new();
/// // #[task(priority = 1, local = [blink])]
/// async fn blink_lane(blink: &mut Seq<Blink>) {
///     // `lane` never returns; matching on its `Infallible` tells the compiler so, and the
///     // task's future then has no "resumed after completion" panic path.
///     match lane(&SEQ, &(), blink).await {}
/// }
/// ```
///
/// On the host, `sim::Sim::lane` (feature `std`) does the same.
///
/// A sequencer has `W` lane slots (its fifth type parameter, default 8). A lane beyond them
/// never runs its sequence: starting it is
/// [`Err(Error::LaneCapacityExceeded)`](crate::Error::LaneCapacityExceeded), an exception
/// sequence in it is counted in `Sequencer::exceptions_not_run`, and
/// [`Sequencer::check_lanes`] names the first such lane. Declare the lanes at start-up with
/// [`Handle::declare_lane`](crate::Handle::declare_lane) to get the error there.
///
/// The lane is the sequence's run itself (see `sequence/run.rs`): between runs it waits for
/// the next non-blocking start. Dropping the lane's future (the loser of a `select`, a
/// task that stops it) aborts its run, if any, with [`Cause::Dropped`](crate::Cause::Dropped)
/// and closes the lane: a start of the sequence is then `Err(Error::NoLane)` (an exception
/// sequence's counts as not run, and its behaviour applies at once), and
/// [`Sequencer::check_lanes`] names it, until a lane future for it waits again.
pub fn lane<
    'a,
    C,
    S: Sequence<C>,
    const N: usize,
    const T: usize,
    L: Lock,
    const W: usize,
    const B: usize,
>(
    sequencer: &'a Sequencer<C, N, T, L, W, B>,
    control: &'a C,
    seq: &'a mut Seq<S>,
) -> impl Future<Output = Infallible> + use<'a, C, S, N, T, L, W, B> {
    LaneRun(sequence_run(
        Run::lane(Cx::new(sequencer, control, seq.head.id)),
        seq,
    ))
}

/// Runs several lanes in one task: the future of `lane(sequencer, control, seq)` for each
/// `seq` (a variable holding a `&mut Seq<_>`), joined; every time the task is woken each
/// lane is polled, in the order given. Never returns (`Infallible`).
///
/// One RTIC task for all the lanes of a priority, instead of one task each:
///
/// ```
/// use rtseq::{Cx, Failure, Seq, Sequence, Sequencer};
/// struct Blink;
/// impl Sequence<()> for Blink {
///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
/// }
/// struct SafeStop;
/// impl Sequence<()> for SafeStop {
///     async fn action(&mut self, _cx: &Cx<'_, ()>) -> Result<(), Failure> { Ok(()) }
/// }
/// static SEQ: Sequencer<(), 4> = Sequencer::new();
/// // #[task(priority = 1, local = [blink, safe_stop])]
/// async fn lanes(blink: &mut Seq<Blink>, safe_stop: &mut Seq<SafeStop>) {
///     match rtseq::lanes!(&SEQ, &(), blink, safe_stop).await {}
/// }
/// ```
///
/// The cost of the convenience: a lane with nothing to do returns `Pending` at once, but
/// it is polled whenever any lane of the task is woken; a task per lane (see
/// [`lane`](fn@crate::lane)) polls only the lane that was woken.
#[macro_export]
macro_rules! lanes {
    ($sequencer:expr, $control:expr, $($seq:ident),+ $(,)?) => {
        async {
            let (sequencer, control) = ($sequencer, $control);
            // Each `Seq` name is rebound to its lane's pinned future.
            $( let mut $seq = ::core::pin::pin!($crate::lane(sequencer, control, $seq)); )+
            ::core::future::poll_fn(move |cx| {
                // A lane never ends: every poll is `Pending`.
                $( let _ = ::core::future::Future::poll($seq.as_mut(), cx); )+
                ::core::task::Poll::<::core::convert::Infallible>::Pending
            })
            .await
        }
    };
}
