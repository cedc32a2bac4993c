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
/// A sequencer has `W` lane slots (its last type parameter, default 8). A lane beyond them
/// never runs its sequence: starting it is `Err(Error::NoLane)`, and an exception sequence in
/// it is counted in `Sequencer::exceptions_not_run`. Declare the lanes at start-up with
/// [`Handle::declare_lane`](crate::Handle::declare_lane) to get
/// [`Error::LaneCapacityExceeded`](crate::Error::LaneCapacityExceeded) there instead.
///
/// The lane is the sequence's run itself (see `sequence/run.rs`): between runs it waits for
/// the next non-blocking start.
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
    let Seq { head, body } = seq;
    LaneRun(sequence_run(
        Run::lane(Cx::new(sequencer, control, head.id), &head.result),
        body,
    ))
}
