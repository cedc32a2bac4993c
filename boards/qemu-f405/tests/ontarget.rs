//! On-target tests (defmt-test): assertions that belong inside the firmware, run on the
//! emulated STM32F405 by `tests/qemu_ontarget.rs` (plain `cargo test` at the root).
//!
//! * the priority-ceiling lock: a section raises BASEPRI to the ceiling's value (`Ceiling::of`),
//!   holds off an interrupt at the tick's priority until it ends, never one above it, and
//!   restores BASEPRI when it ends, also when nested;
//! * the trace ring: `Sequencer::drain_records` hands the records over oldest first; when
//!   more happen than it holds, the oldest are lost, counted, and the newest kept;
//! * the safety cycle's output writes: `set` writes every cycle, `leave` never, `toggle`
//!   low, high, low, … from the cycle its level is entered.
//!
//! Only rtseq's public API is used (the lock through the `Lock` trait that the sequencer's
//! sections go through). defmt-test exits through semihosting: 0 when every test passed; a
//! failed assertion panics, and the board's panic handler exits 101.
#![no_std]
#![no_main]

use rtseq_qemu_f405 as _; // logger, exit codes, panic and fault handlers

use core::sync::atomic::{AtomicU32, Ordering};

use rtseq_qemu_f405::pac::interrupt;

/// Runs at logical priority 2 (the tick's): must wait for a section with that ceiling.
static AT_CEILING: AtomicU32 = AtomicU32::new(0);
/// Runs at logical priority 3 (the safety task's): must preempt a section.
static ABOVE_CEILING: AtomicU32 = AtomicU32::new(0);

#[interrupt]
fn EXTI0() {
    AT_CEILING.fetch_add(1, Ordering::SeqCst);
}

#[interrupt]
fn EXTI1() {
    ABOVE_CEILING.fetch_add(1, Ordering::SeqCst);
}

/// NVIC priority byte of RTIC logical priority `p` with 4 priority bits.
const fn nvic_prio(p: u8) -> u8 {
    ((1u8 << 4) - p) << 4
}

use rtseq::lock::CriticalSection;
use rtseq::safety::{
    CriticalOutput, IoValue, LevelDef, LevelTransition as Row, OutputId, PublicEvent, SafetyIo,
    SafetyLevel, SafetyProperties, ValidProperties,
};
use rtseq::{
    Cause, Entry, Event, Instant, Monitors, Record, Request, Requester, RunningState, SeqId,
    Sequencer,
};

/// One start and one abort, each applied by a tick: the transitions of `rounds` rounds.
fn run_rounds(
    seq: &Sequencer<(), 4, 4, CriticalSection>,
    monitors: &mut Monitors<'static, (), 1>,
    rounds: u64,
    mut drain_each: Option<&mut heapless::Vec<Record, 32>>,
) {
    let h = seq.sequence_by_name("s").expect("registered");
    for r in 0..rounds {
        assert!(h.start().is_ok());
        seq.tick(Instant::from_ticks(2 * r * 1000 + 1000), &(), monitors)
            .unwrap();
        if let Some(v) = drain_each.as_deref_mut() {
            assert_eq!(seq.drain_records(|r| keep(v, r)), 0);
        }
        assert!(h.abort().is_ok());
        seq.tick(Instant::from_ticks(2 * r * 1000 + 2000), &(), monitors)
            .unwrap();
        if let Some(v) = drain_each.as_deref_mut() {
            assert_eq!(seq.drain_records(|r| keep(v, r)), 0);
        }
    }
}

fn keep(v: &mut heapless::Vec<Record, 32>, r: Record) {
    assert!(v.push(r).is_ok());
}

/// A record's time (µs).
fn time_of(r: &Record) -> u64 {
    r.time.as_ticks()
}

/// A transition record.
fn transition(
    us: u64,
    sequence: SeqId,
    from: RunningState,
    to: RunningState,
    cause: Cause,
) -> Record {
    Record {
        time: Instant::from_ticks(us),
        entry: Entry::Transition {
            sequence,
            from,
            to,
            cause,
        },
    }
}

const SAFE: SafetyLevel = SafetyLevel::new(0);
const RUN: SafetyLevel = SafetyLevel::new(1);
const GO: PublicEvent = PublicEvent::new(0);
const ENABLE: CriticalOutput<bool> = CriticalOutput::new(0, "enable");
const LAMP: CriticalOutput<bool> = CriticalOutput::new(1, "lamp");
const SPARE: CriticalOutput<bool> = CriticalOutput::new(2, "spare");

/// Every output write, in order.
struct Io {
    writes: heapless::Vec<(u8, bool), 64>,
}

impl SafetyIo for Io {
    fn read_input(&mut self, _: rtseq::safety::InputId) -> IoValue {
        IoValue::Bool(false)
    }
    fn write_output(&mut self, output: OutputId, value: IoValue) {
        let index = if output == ENABLE.id() {
            0
        } else if output == LAMP.id() {
            1
        } else {
            2
        };
        assert!(self
            .writes
            .push((index, value == IoValue::Bool(true)))
            .is_ok());
    }
}

static PROPS: ValidProperties<'static, Io, 2> = match SafetyProperties::new(
    [
        LevelDef::new(SAFE, "safe").outputs(&[ENABLE.set(false), LAMP.set(false), SPARE.leave()]),
        LevelDef::new(RUN, "run").outputs(&[ENABLE.set(true), LAMP.toggle(), SPARE.leave()]),
    ],
    &[],
    &[ENABLE.info(), LAMP.info(), SPARE.info()],
    &[Row::on(SAFE, GO, RUN)],
    SAFE,
)
.validated()
{
    Ok(p) => p,
    Err(_) => panic!("invalid safety properties"),
};

/// The BASEPRI value RTIC uses for a ceiling of logical priority `p` (4 bits).
fn basepri_of(p: u8) -> u8 {
    match rtseq::lock::Ceiling::of(p, 4) {
        Some(rtseq::lock::Ceiling::Basepri(v)) => v,
        _ => panic!("priority {} has no BASEPRI ceiling", p),
    }
}

#[defmt_test::tests]
mod tests {
    use super::*;
    use cortex_m::peripheral::NVIC;
    use cortex_m::register::basepri;
    use rtseq::lock::{Ceiling, Lock, PriorityCeiling};
    use rtseq::safety::{NoSequences, SafetyHandle, SafetySystem};
    use rtseq::SeqConfig;
    use rtseq_qemu_f405::pac;

    /// The tick at logical priority 2 of 16.
    type Tick = PriorityCeiling<2>;

    #[init]
    fn init() {
        // SAFETY: the handlers above only count; priorities are set before unmasking.
        unsafe {
            let mut p = cortex_m::Peripherals::steal();
            p.NVIC.set_priority(pac::Interrupt::EXTI0, nvic_prio(2));
            p.NVIC.set_priority(pac::Interrupt::EXTI1, nvic_prio(3));
            NVIC::unmask(pac::Interrupt::EXTI0);
            NVIC::unmask(pac::Interrupt::EXTI1);
        }
    }

    #[test]
    fn the_ceiling_is_the_nvic_value_of_the_priority() {
        assert_eq!(basepri_of(2), nvic_prio(2));
        assert_eq!(basepri_of(1), 0xF0);
        assert_eq!(basepri_of(15), nvic_prio(15));
        assert!(Ceiling::of(16, 4) == Some(Ceiling::InterruptsDisabled));
    }

    #[test]
    fn a_section_at_the_top_priority_disables_interrupts() {
        let before = ABOVE_CEILING.load(Ordering::SeqCst);
        let (masked, ran_inside) = <PriorityCeiling<16> as Lock>::lock(|| {
            NVIC::pend(pac::Interrupt::EXTI1);
            cortex_m::asm::dsb();
            cortex_m::asm::isb();
            (
                cortex_m::register::primask::read().is_inactive(),
                ABOVE_CEILING.load(Ordering::SeqCst) != before,
            )
        });
        cortex_m::asm::isb();
        assert!(masked, "interrupts not disabled inside the section");
        assert!(
            !ran_inside,
            "an interrupt ran inside a top-priority section"
        );
        assert_eq!(
            ABOVE_CEILING.load(Ordering::SeqCst),
            before + 1,
            "not run after"
        );
    }

    #[test]
    fn a_section_holds_off_the_ceiling_and_lets_higher_priorities_in() {
        assert_eq!(basepri::read(), 0);
        let before = (
            AT_CEILING.load(Ordering::SeqCst),
            ABOVE_CEILING.load(Ordering::SeqCst),
        );
        let inside = <Tick as Lock>::lock(|| {
            NVIC::pend(pac::Interrupt::EXTI0);
            NVIC::pend(pac::Interrupt::EXTI1);
            cortex_m::asm::dsb();
            cortex_m::asm::isb();
            (
                basepri::read(),
                AT_CEILING.load(Ordering::SeqCst),
                ABOVE_CEILING.load(Ordering::SeqCst),
            )
        });
        cortex_m::asm::isb();
        assert_eq!(inside.0, basepri_of(2), "BASEPRI inside the section");
        assert_eq!(
            inside.1, before.0,
            "an interrupt at the ceiling ran inside the section"
        );
        assert_eq!(
            inside.2,
            before.1 + 1,
            "an interrupt above the ceiling was held off"
        );
        assert_eq!(basepri::read(), 0, "BASEPRI not restored");
        assert_eq!(
            AT_CEILING.load(Ordering::SeqCst),
            before.0 + 1,
            "not run after the section"
        );
    }

    #[test]
    fn nested_sections_restore_the_outer_ceiling() {
        type Higher = PriorityCeiling<3>;
        let (outer, inner, after_inner) = <Tick as Lock>::lock(|| {
            let outer = basepri::read();
            // A lower ceiling inside a higher one never lowers the priority.
            let inner = <Higher as Lock>::lock(|| <Tick as Lock>::lock(basepri::read));
            (outer, inner, basepri::read())
        });
        assert_eq!(outer, basepri_of(2));
        assert_eq!(inner, basepri_of(3));
        assert_eq!(after_inner, basepri_of(2));
        assert_eq!(basepri::read(), 0);
    }

    #[test]
    fn the_trace_ring_keeps_the_newest_and_counts_the_lost() {
        // Drained after every tick: nothing lost, the whole history.
        let seq: Sequencer<(), 4, 4, CriticalSection> = Sequencer::new();
        let id = seq.register(SeqConfig::new("s")).expect("register");
        assert!(seq.sequence_by_id(id).expect("id").declare_lane().is_ok());
        let mut monitors = Monitors::new();
        let mut all = heapless::Vec::new();
        run_rounds(&seq, &mut monitors, 3, Some(&mut all));
        assert!(
            all.len() > 4,
            "3 starts and aborts make more records than the ring holds"
        );
        // Each round: the start, the abort request (recorded when made), the teardown.
        let id0 = id;
        assert_eq!(
            all[..4],
            [
                transition(
                    0,
                    id0,
                    RunningState::Idle,
                    RunningState::Running,
                    Cause::Start
                ),
                Record {
                    time: Instant::from_ticks(1000),
                    entry: Entry::Event(Event::Requested {
                        sequence: id0,
                        request: Request::Abort,
                        by: Requester::Application,
                    }),
                },
                transition(
                    2000,
                    id0,
                    RunningState::Running,
                    RunningState::Aborting,
                    Cause::Abort
                ),
                transition(
                    2000,
                    id0,
                    RunningState::Aborting,
                    RunningState::Aborted,
                    Cause::Abort
                ),
            ]
        );

        // The same without draining: the ring of 4 keeps the newest 4, the rest is counted.
        let seq: Sequencer<(), 4, 4, CriticalSection> = Sequencer::new();
        let id = seq.register(SeqConfig::new("s")).expect("register");
        assert!(seq.sequence_by_id(id).expect("id").declare_lane().is_ok());
        let mut monitors = Monitors::new();
        run_rounds(&seq, &mut monitors, 3, None);
        let mut kept: heapless::Vec<Record, 32> = heapless::Vec::new();
        let mut last_time = 0;
        let lost = seq.drain_records(|r| {
            assert!(time_of(&r) >= last_time, "not oldest first");
            last_time = time_of(&r);
            keep(&mut kept, r);
        });
        assert_eq!(kept.len(), 4);
        assert_eq!(lost as usize, all.len() - 4);
        assert_eq!(kept.as_slice(), &all[all.len() - 4..]);
        // Drained: empty.
        assert_eq!(seq.drain_records(|_| panic!("a record after draining")), 0);
    }

    #[test]
    fn the_safety_cycle_writes_set_and_toggle_outputs_every_cycle_and_never_leave() {
        static HANDLE: SafetyHandle = SafetyHandle::new();
        let mut system = SafetySystem::new_validated(&PROPS, &HANDLE).expect("valid");
        let mut io = Io {
            writes: heapless::Vec::new(),
        };
        system.cycle(&mut io, &NoSequences);
        assert_eq!(io.writes.as_slice(), &[(0, false), (1, false)]);
        io.writes.clear();
        HANDLE.trigger(GO);
        for _ in 0..3 {
            system.cycle(&mut io, &NoSequences);
        }
        assert_eq!(HANDLE.level(), RUN);
        // enable set high every cycle; the lamp toggles low, high, low from the entry cycle;
        // the spare output (leave) is never written.
        assert_eq!(
            io.writes.as_slice(),
            &[
                (0, true),
                (1, false),
                (0, true),
                (1, true),
                (0, true),
                (1, false)
            ]
        );
    }
}
