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
        twice::table("a").map(|_| ()).map_err(|e| e.error),
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

/// `mons::MonitorTable` is the table's type without spelling out the control system and the
/// condition type: room for the declared monitors, or for `M` of them.
#[test]
fn the_monitor_module_names_the_tables_type() {
    let exact: mons::MonitorTable = mons::table().unwrap();
    let _: &Monitors<'static, Cell_, 2, Cond> = &exact;
    let mut roomy: mons::MonitorTable<5> = mons::table().unwrap();
    let _: &Monitors<'static, Cell_, 5, Cond> = &roomy;
    assert_eq!((exact.len(), roomy.len()), (2, 2));
    roomy
        .add(
            seqs::CYCLE,
            Monitor::with_condition("extra", Cond::Never, Behaviour::Nothing),
        )
        .unwrap();
    assert_eq!(roomy.name(rtseq::MonitorId::from_index(2)), Some("extra"));
}

rtseq::sequences! {
    /// One more than a word of 32: the sets need two.
    mod wide for () {
        S00 = SeqConfig::new("s00"),
        S01 = SeqConfig::new("s01"),
        S02 = SeqConfig::new("s02"),
        S03 = SeqConfig::new("s03"),
        S04 = SeqConfig::new("s04"),
        S05 = SeqConfig::new("s05"),
        S06 = SeqConfig::new("s06"),
        S07 = SeqConfig::new("s07"),
        S08 = SeqConfig::new("s08"),
        S09 = SeqConfig::new("s09"),
        S10 = SeqConfig::new("s10"),
        S11 = SeqConfig::new("s11"),
        S12 = SeqConfig::new("s12"),
        S13 = SeqConfig::new("s13"),
        S14 = SeqConfig::new("s14"),
        S15 = SeqConfig::new("s15"),
        S16 = SeqConfig::new("s16"),
        S17 = SeqConfig::new("s17"),
        S18 = SeqConfig::new("s18"),
        S19 = SeqConfig::new("s19"),
        S20 = SeqConfig::new("s20"),
        S21 = SeqConfig::new("s21"),
        S22 = SeqConfig::new("s22"),
        S23 = SeqConfig::new("s23"),
        S24 = SeqConfig::new("s24"),
        S25 = SeqConfig::new("s25"),
        S26 = SeqConfig::new("s26"),
        S27 = SeqConfig::new("s27"),
        S28 = SeqConfig::new("s28"),
        S29 = SeqConfig::new("s29"),
        S30 = SeqConfig::new("s30"),
        S31 = SeqConfig::new("s31"),
        S32 = SeqConfig::new("s32"),
    }
}

#[test]
fn a_table_of_33_sizes_a_sequencer_of_two_word_sets() {
    use rtseq::lock::CriticalSection;
    assert_eq!((wide::COUNT, wide::SET_WORDS, seqs::SET_WORDS), (33, 2, 1));
    const TABLE: rtseq::Table<(), { wide::COUNT }> = match wide::table() {
        Ok(t) => t,
        Err(_) => panic!("the table is valid"),
    };
    let seq: Sequencer<(), { wide::COUNT }, 64, CriticalSection, 8, { wide::SET_WORDS }> =
        Sequencer::new();
    seq.install(&TABLE).unwrap();
    // The module's `Sequencer` is that type, another lock and trace capacity given.
    let _: &wide::Sequencer = &seq;
    let small: wide::Sequencer<16, rtseq::lock::SingleThread> = wide::Sequencer::single_thread();
    small.install(&TABLE).unwrap();
    // The last id is in the second word.
    assert_eq!(wide::S32.index(), 32);
    assert_eq!(seq.sequence_by_name("s32").map(|h| h.id()), Some(wide::S32));
}
