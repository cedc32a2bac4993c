//! The connection to the safety system (seed §3): the handle sequences reach it by, and what
//! the safety cycle tells the sequencer. The cycle runs above the sequencer's priority
//! ceiling, so it takes no lock: it raises a bit of the sequencer's inbox (abort-all) or
//! queues a note (a level entered, an input tripped) that the next tick records in the trace.

use core::sync::atomic::{AtomicU16, AtomicU32, Ordering};

use crate::lock::Lock;
use crate::safety::{InputId, SafetyHandle, SafetyLevel, Sequences};
use crate::sequencer::inbox;
use crate::{Event, Sequencer};

/// Room for notes between two ticks: a level change and a few tripped inputs per safety
/// cycle, a cycle or two per tick.
const NOTES: usize = 8;

/// A note of the safety system for the sequencer's trace.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Note {
    LevelEntered(SafetyLevel),
    InputTripped(InputId),
}

impl Note {
    /// Kind in the high byte, id in the low one.
    const fn to_bits(self) -> u16 {
        match self {
            Note::LevelEntered(level) => 0x100 | level.id() as u16,
            Note::InputTripped(input) => 0x200 | input.0 as u16,
        }
    }

    const fn from_bits(bits: u16) -> Option<Self> {
        let id = bits as u8;
        match bits >> 8 {
            1 => Some(Note::LevelEntered(SafetyLevel::new(id))),
            2 => Some(Note::InputTripped(InputId(id))),
            _ => None,
        }
    }

    const fn event(self) -> Event {
        match self {
            Note::LevelEntered(level) => Event::SafetyLevel { level },
            Note::InputTripped(input) => Event::InputTripped { input },
        }
    }
}

/// The safety system's notes, oldest first, until the tick records them: a bounded
/// lock-free queue with one writer (the safety cycle) and one reader (the tick, under the
/// sequencer's lock). A note that finds the queue full is dropped and counted, and the
/// trace reports it as lost.
pub(crate) struct SafetyNotes {
    slots: [AtomicU16; NOTES],
    /// Notes queued since the start (wrapping); stored by the writer only.
    written: AtomicU32,
    /// Notes taken since the start (wrapping); stored by the reader only.
    read: AtomicU32,
    /// Notes dropped since the reader last looked.
    dropped: AtomicU32,
}

impl SafetyNotes {
    pub(crate) const fn new() -> Self {
        SafetyNotes {
            slots: [const { AtomicU16::new(0) }; NOTES],
            written: AtomicU32::new(0),
            read: AtomicU32::new(0),
            dropped: AtomicU32::new(0),
        }
    }

    /// Queues `note`; the writer's side. Returns whether it found room.
    fn push(&self, note: Note) -> bool {
        let written = self.written.load(Ordering::Relaxed);
        // Acquire: the reader is done with the slot it gave back.
        let read = self.read.load(Ordering::Acquire);
        let Some(slot) = self.slots.get(written as usize % NOTES) else {
            return false;
        };
        if written.wrapping_sub(read) as usize >= NOTES {
            self.dropped.fetch_add(1, Ordering::Relaxed);
            return false;
        }
        slot.store(note.to_bits(), Ordering::Relaxed);
        // Release: the note is in its slot before the reader sees it counted.
        self.written
            .store(written.wrapping_add(1), Ordering::Release);
        true
    }

    /// Takes the oldest note; the reader's side.
    fn pop(&self) -> Option<Note> {
        let read = self.read.load(Ordering::Relaxed);
        // Acquire: see the note the writer counted.
        if self.written.load(Ordering::Acquire) == read {
            return None;
        }
        let bits = self
            .slots
            .get(read as usize % NOTES)?
            .load(Ordering::Relaxed);
        // Release: the slot is read before the writer may fill it again.
        self.read.store(read.wrapping_add(1), Ordering::Release);
        Note::from_bits(bits)
    }

    /// How many notes were dropped since the last call; the reader's side.
    fn take_dropped(&self) -> u32 {
        if self.dropped.load(Ordering::Relaxed) == 0 {
            return 0;
        }
        self.dropped.swap(0, Ordering::Relaxed)
    }
}

impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize>
    Sequencer<C, N, T, L, W, B>
{
    /// The handle to build this sequencer's [`SafetySystem`](crate::safety::SafetySystem)
    /// on. The sequencer holds it, so its sequences reach the system that is built on it
    /// without a further step: [`Cx::safety_system`](crate::Cx::safety_system) triggers
    /// public events and reads the level through it. Pass the same sequencer to the
    /// system's [`cycle`](crate::safety::SafetySystem::cycle).
    ///
    /// ```
    /// use rtseq::safety::*;
    /// use rtseq::Sequencer;
    /// # struct Io;
    /// const OFF: SafetyLevel = SafetyLevel::new(0);
    /// static PROPS: SafetyProperties<'static, Io, 1> =
    ///     SafetyProperties::new([LevelDef::new(OFF, "off")], &[], &[], &[], OFF);
    /// static SEQ: Sequencer<(), 4> = Sequencer::new();
    /// assert!(SEQ.safety_system().is_none());
    /// let safety = SafetySystem::new(&PROPS, SEQ.safety_handle())?;
    /// SEQ.safety_system().unwrap().trigger(PublicEvent::new(0));
    /// assert_eq!(SEQ.safety_handle().pending_events(), 1 << 0);
    /// # drop(safety);
    /// # Ok::<(), SafetyError>(())
    /// ```
    ///
    /// A `const fn`: a `static` control system can keep the handle, for the code that has
    /// no [`Cx`](crate::Cx), such as a cleanup hook that asks the safety system to switch
    /// the actuators off:
    ///
    /// ```
    /// use rtseq::safety::{PublicEvent, SafetyHandle};
    /// use rtseq::{SeqConfig, Sequencer};
    /// const STOP: PublicEvent = PublicEvent::new(1);
    /// struct Station { safety: &'static SafetyHandle }
    /// static SEQ: Sequencer<Station, 4> = Sequencer::new();
    /// static STATION: Station = Station { safety: SEQ.safety_handle() };
    /// fn stop_actuators(s: &Station) { s.safety.trigger(STOP) }
    /// let config = SeqConfig::new("fill").on_abort(stop_actuators);
    /// # let _ = (config, &STATION);
    /// ```
    pub const fn safety_handle(&self) -> &SafetyHandle {
        &self.safety
    }

    /// The seed's `getSafetySystem()`: the handle of the safety system built on
    /// [`safety_handle`](Self::safety_handle), or `None` while there is none (before
    /// `init` built it, in a firmware without one, or one built on a handle of its own).
    ///
    /// ```
    /// use rtseq::Sequencer;
    /// let seq: Sequencer<(), 4> = Sequencer::new();
    /// assert!(seq.safety_system().is_none());
    /// ```
    pub fn safety_system(&self) -> Option<&SafetyHandle> {
        self.safety.is_bound().then_some(&self.safety)
    }

    /// Queues `note` for the next tick's trace.
    fn note(&self, note: Note) {
        if self.safety_notes.push(note) {
            self.safety
                .inbox
                .fetch_or(inbox::SAFETY_NOTES, Ordering::Release);
        }
    }

    /// Records the safety system's notes in the trace, one section per note, at the tick's
    /// time; the dropped ones are counted as lost.
    #[cold]
    #[inline(never)]
    pub(crate) fn record_safety_notes(&self) {
        while let Some(note) = self.safety_notes.pop() {
            self.with(|s| s.record(note.event()));
        }
        let dropped = self.safety_notes.take_dropped();
        if dropped != 0 {
            self.with(|s| s.trace.count_lost(dropped));
        }
    }
}

/// The safety system aborts every sequence through the sequencer and tells it the levels it
/// enters and the inputs that trip, for the trace. One safety system per sequencer: the
/// notes' queue has room for one writer.
impl<C, const N: usize, const T: usize, L: Lock, const W: usize, const B: usize> Sequences
    for Sequencer<C, N, T, L, W, B>
{
    fn abort_all(&self) {
        self.safety.request_abort_all();
    }

    fn level_entered(&self, level: SafetyLevel) {
        self.note(Note::LevelEntered(level));
    }

    fn input_tripped(&self, input: InputId) {
        self.note(Note::InputTripped(input));
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing)]
mod tests {
    extern crate std;
    use super::*;

    /// First in, first out; a full queue drops the newest and counts it; room again once
    /// the reader took some; ids and kinds survive the encoding.
    #[test]
    fn queue_keeps_order_and_counts_what_it_drops() {
        let q = SafetyNotes::new();
        assert_eq!(q.pop(), None);
        for i in 0..NOTES as u8 + 3 {
            let note = if i % 2 == 0 {
                Note::LevelEntered(SafetyLevel::new(i))
            } else {
                Note::InputTripped(InputId(200 + i))
            };
            assert_eq!(q.push(note), usize::from(i) < NOTES);
        }
        assert_eq!(q.take_dropped(), 3);
        assert_eq!(q.take_dropped(), 0);
        assert_eq!(q.pop(), Some(Note::LevelEntered(SafetyLevel::new(0))));
        assert_eq!(q.pop(), Some(Note::InputTripped(InputId(201))));
        assert!(q.push(Note::InputTripped(InputId(31))));
        assert!(q.push(Note::LevelEntered(SafetyLevel::new(255))));
        assert!(!q.push(Note::LevelEntered(SafetyLevel::new(1))));
        let rest: std::vec::Vec<Note> = core::iter::from_fn(|| q.pop()).collect();
        assert_eq!(rest.len(), NOTES);
        assert_eq!(rest[NOTES - 2], Note::InputTripped(InputId(31)));
        assert_eq!(rest[NOTES - 1], Note::LevelEntered(SafetyLevel::new(255)));
        assert_eq!(q.take_dropped(), 1);
    }
}
