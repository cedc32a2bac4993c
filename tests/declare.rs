//! The tree declared once: `sequences!` and `monitors!` number their lines, and the tables
//! they build are checked like hand-written ones.

use rtseq::{Behaviour, Error, Instant, Monitor, Monitors, SeqConfig, SeqId, Sequencer};

/// The control system of these tests: one flag per monitor.
#[derive(Default)]
struct Cell_ {
    jam: bool,
}

enum Cond {
    Jam,
    Never,
}

impl rtseq::Condition<Cell_> for Cond {
    fn validate(&mut self, c: &Cell_, _: Instant) -> bool {
        match self {
            Cond::Jam => c.jam,
            Cond::Never => false,
        }
    }
}

rtseq::sequences! {
    mod seqs for Cell_ {
        SAFE_STOP = SeqConfig::new("safe stop"),
        GRIP = SeqConfig::new("grip").timeout_exception(SAFE_STOP),
        CYCLE = SeqConfig::new("cycle"),
    }
}

rtseq::sequences! {
    /// The same name twice.
    mod twice(name: &'static str) for Cell_ {
        A = SeqConfig::new("a"),
        B = SeqConfig::new(name),
    }
}

rtseq::monitors! {
    mod mons for Cell_, Cond {
        JAM = Monitor::with_condition("jam", Cond::Jam, Behaviour::AbortOwner)
            .exception(seqs::SAFE_STOP)
            .owned_by(seqs::GRIP),
        IDLE = Monitor::with_condition("idle", Cond::Never, Behaviour::Nothing)
            .owned_by(seqs::CYCLE),
    }
}

#[test]
fn ids_are_the_lines_positions_and_the_table_follows_them() {
    assert_eq!(seqs::COUNT, 3);
    assert_eq!(
        [seqs::SAFE_STOP, seqs::GRIP, seqs::CYCLE],
        [0, 1, 2].map(SeqId::from_index)
    );
    let table = seqs::table().unwrap();
    let seq: Sequencer<Cell_, 4> = Sequencer::new();
    seq.install(&table).unwrap();
    for (id, name) in [
        (seqs::SAFE_STOP, "safe stop"),
        (seqs::GRIP, "grip"),
        (seqs::CYCLE, "cycle"),
    ] {
        assert_eq!(seq.sequence_by_id(id).unwrap().name(), name);
    }
}

#[test]
fn a_table_with_a_duplicate_name_is_the_error_table_new_gives() {
    assert_eq!(twice::table("b").map(|_| ()), Ok(()));
    assert_eq!(
        twice::table("a").map(|_| ()),
        Err(Error::DuplicateName(twice::A))
    );
}

#[test]
fn monitor_ids_are_the_lines_positions_with_their_owners() {
    assert_eq!(mons::COUNT, 2);
    let m: Monitors<'static, Cell_, 2, Cond> = mons::table().unwrap();
    assert_eq!(m.name(mons::JAM), Some("jam"));
    assert_eq!(m.owner(mons::JAM), Some(seqs::GRIP));
    assert_eq!(m.name(mons::IDLE), Some("idle"));
    assert_eq!(m.owner(mons::IDLE), Some(seqs::CYCLE));
    let seq: Sequencer<Cell_, 4> = Sequencer::new();
    seq.install(&seqs::table().unwrap()).unwrap();
    // The safe stop has no lane: the declared tree is validated like any other.
    assert!(seq.validate(&m).is_err());
    seq.sequence_by_id(seqs::SAFE_STOP)
        .unwrap()
        .declare_lane()
        .unwrap();
    assert_eq!(seq.validate(&m), Ok(()));
}
