//! The tree declared once: [`sequences!`](crate::sequences) and
//! [`monitors!`](crate::monitors) state each sequence or monitor in one line — its id's name
//! and its configuration — and the ids, their count and the `const fn` that builds the
//! table follow from the order of the lines. No id is written by hand, so ids and table
//! cannot disagree.

/// Declares a module of sequence ids and the [`Table`](crate::Table) they index.
///
/// Each line is `ID = config`, where `config` is a [`SeqConfig`](crate::SeqConfig)
/// expression; the line's position is the id. The module gets:
///
/// * `pub const ID: SeqId` for every line, with the line's doc comment;
/// * `pub const COUNT: usize`, the number of lines, and `pub const SET_WORDS: usize`, the
///   words of the sets of a sequencer that holds them (its `B`, [`set_words`](crate::set_words));
/// * `pub type Sequencer<T = 64, L = CriticalSection, W = 8>`, the
///   [`Sequencer`](crate::Sequencer) of the control type, `COUNT` sequences and sets of
///   `SET_WORDS` words, the other parameters in `Sequencer`'s order with its defaults;
/// * `pub const fn table(..) -> Result<Table<C, COUNT>, TableError>`, with the parameters given
///   after the module's name (none: `table()`), checked as [`Table::new`](crate::Table::new)
///   checks it. Evaluate it in a `const` and a bad table is a compile error.
///
/// The configurations see the module's ids and, through `use super::*`, everything in the
/// module around the macro; the module's own names (the ids, `COUNT`, `SET_WORDS`,
/// `Sequencer`, `table`) hide items of the same name from around it: write `super::Name`
/// for those.
///
/// ```
/// use rtseq::{lock::CriticalSection, Behaviour, Duration, SeqConfig, Sequencer, Table};
///
/// struct Axis;
/// struct Limits { homing_timeout: Duration }
///
/// rtseq::sequences! {
///     /// The sequences of the axis, in table order.
///     pub mod seqs(limits: &Limits) for Axis {
///         /// Safe stop: the homing's timeout exception.
///         SAFE_STOP = SeqConfig::new("safe stop"),
///         /// Homing, aborted after `homing_timeout`.
///         HOMING = SeqConfig::new("homing")
///             .timeout(limits.homing_timeout)
///             .timeout_exception(SAFE_STOP)
///             .timeout_behaviour(Behaviour::AbortOwner),
///     }
/// }
///
/// const LIMITS: Limits = Limits { homing_timeout: Duration::from_secs(10) };
/// // Checked by the compiler: a duplicate name would not compile.
/// static TABLE: Table<Axis, { seqs::COUNT }> = match seqs::table(&LIMITS) {
///     Ok(table) => table,
///     Err(e) => panic!("{}", e.message().as_str()),
/// };
///
/// fn main() {
///     // Sized by the table: `COUNT` sequences, sets of `SET_WORDS` words (here 1).
///     let seq: seqs::Sequencer = seqs::Sequencer::new();
///     seq.install(&TABLE).unwrap();
///     // The same type, spelt out; another lock or trace capacity: `seqs::Sequencer<16, L>`.
///     let _: &Sequencer<Axis, { seqs::COUNT }, 64, CriticalSection, 8, { seqs::SET_WORDS }> =
///         &seq;
///     assert_eq!(seqs::HOMING.index(), 1);
///     assert_eq!(seq.sequence_by_name("homing").map(|h| h.id()), Some(seqs::HOMING));
/// }
/// ```
#[macro_export]
macro_rules! sequences {
    (
        $(#[$attr:meta])*
        $vis:vis mod $module:ident $( ( $($param:ident : $param_ty:ty),* $(,)? ) )? for $control:ty {
            $( $(#[$id_attr:meta])* $id:ident = $config:expr ),+ $(,)?
        }
    ) => {
        $(#[$attr])*
        $vis mod $module {
            #[allow(unused_imports)]
            use super::*;

            /// The lines, in order: a line's discriminant is its id's index.
            #[allow(non_camel_case_types, dead_code, clippy::upper_case_acronyms)]
            enum Line { $($id),+ }

            $(
                $(#[$id_attr])*
                pub const $id: $crate::SeqId = $crate::SeqId::from_index(Line::$id as usize);
            )+

            /// How many sequences and steps the table holds.
            pub const COUNT: usize = [$(Line::$id),+].len();

            /// The words of the sets of a sequencer that holds the table (its `B`).
            pub const SET_WORDS: usize = $crate::set_words(COUNT);

            /// A sequencer that holds the table: `COUNT` sequences, sets of `SET_WORDS`
            /// words; the trace's capacity `T`, the lock `L` and the lanes `W` as
            /// `rtseq::Sequencer`'s, in its order, with its defaults.
            #[allow(dead_code)]
            pub type Sequencer<
                const T: usize = 64,
                L = $crate::lock::CriticalSection,
                const W: usize = 8,
            > = $crate::Sequencer<$control, COUNT, T, L, W, SET_WORDS>;

            /// The sequence table: entry `i` configures the sequence whose id has index `i`.
            ///
            /// Errors as `rtseq::Table::new`.
            pub const fn table(
                $( $($param: $param_ty),* )?
            ) -> ::core::result::Result<$crate::Table<$control, COUNT>, $crate::TableError> {
                $crate::Table::new([$($config),+])
            }
        }
    };
}

/// Declares a module of monitor ids and the [`Monitors`](crate::Monitors) table they
/// index.
///
/// Each line is `ID = monitor`, where `monitor` is an owned monitor
/// ([`Monitor::owned_by`](crate::Monitor::owned_by)) whose condition is of the type `K`
/// named after the control system; the line's position is the id. The module gets:
///
/// * `pub const ID: MonitorId` for every line, with the line's doc comment;
/// * `pub const COUNT: usize`, the number of lines;
/// * `pub type MonitorTable<const M: usize = COUNT>`: the table's type,
///   `rtseq::Monitors<'static, C, M, K>`, with room for `M` monitors (by default these), for
///   a `static` or an RTIC resource;
/// * `pub const fn table<const M: usize>(..) -> Result<Monitors<'static, C, M, K>, Error>`
///   with the parameters given after the module's name; `M` < `COUNT` does not compile;
/// * `pub const fn validate<const N: usize>(sequences: &Table<C, N>, ..) -> Result<(),
///   ConfigError>`: [`Table::validate`](crate::Table::validate) of the monitors with a
///   sequence table, in a `const` item a compile-time check of the whole configuration;
/// * `pub const fn names(..) -> MonitorNames<COUNT>`: the monitors' names by id
///   ([`MonitorNames`](crate::MonitorNames)), to print records where the table is out of
///   reach (`static NAMES: MonitorNames<{ monitor_ids::COUNT }> = monitor_ids::names(..);`).
///
/// The monitors see the module's ids and, through `use super::*`, everything in the module
/// around the macro (the sequence ids, typically); the module's own names (the ids,
/// `COUNT`, `MonitorTable`, `table`, `validate`, `names`) hide items of the same name from
/// around it: write `super::Name` for those.
///
/// ```
/// use rtseq::{Behaviour, Condition, Instant, Monitor, SeqConfig};
///
/// struct Axis { over_travel: bool }
///
/// /// The conditions of the table: one type, so that the tick needs no `dyn` call.
/// enum AxisCondition { OverTravel }
/// impl Condition<Axis> for AxisCondition {
///     fn validate(&mut self, axis: &Axis, _now: Instant) -> bool {
///         match self {
///             AxisCondition::OverTravel => axis.over_travel,
///         }
///     }
/// }
///
/// rtseq::sequences! {
///     mod seqs for Axis {
///         HOMING = SeqConfig::new("homing"),
///         SAFE_STOP = SeqConfig::new("safe stop").in_lane(),
///     }
/// }
/// use seqs::{HOMING, SAFE_STOP};
///
/// rtseq::monitors! {
///     /// The monitors of the axis, in table order.
///     mod monitor_ids for Axis, AxisCondition {
///         /// Over-travel aborts the homing; the safe stop takes over.
///         OVER_TRAVEL = Monitor::with_condition(
///             "over-travel",
///             AxisCondition::OverTravel,
///             Behaviour::AbortOwner,
///         )
///         .exception(SAFE_STOP)
///         .owned_by(HOMING),
///     }
/// }
///
/// // The whole configuration, checked by the compiler: without `.in_lane()` on the safe
/// // stop this item would not compile ("the exception sequence `safe stop` of monitor
/// // `over-travel` has no lane ...").
/// const CHECKED: () = match seqs::table() {
///     Ok(table) => match monitor_ids::validate(&table) {
///         Ok(()) => (),
///         Err(e) => panic!("{}", e.message().as_str()),
///     },
///     Err(e) => panic!("{}", e.message().as_str()),
/// };
///
/// fn main() {
///     // Room for these monitors only; `monitor_ids::MonitorTable<4>` has room for 4.
///     let monitors: monitor_ids::MonitorTable = monitor_ids::table().unwrap();
///     assert_eq!(monitors.name(monitor_ids::OVER_TRAVEL), Some("over-travel"));
///     assert_eq!(monitors.owner(monitor_ids::OVER_TRAVEL), Some(HOMING));
///     // The names alone, for a task that drains the records (the tick's owns the table):
///     const NAMES: rtseq::MonitorNames<{ monitor_ids::COUNT }> = monitor_ids::names();
///     use rtseq::{Cause, WithNames};
///     let cause = Cause::Monitor(monitor_ids::OVER_TRAVEL);
///     assert_eq!(cause.named(&NAMES).to_string(), "monitor `over-travel`");
/// }
/// ```
#[macro_export]
macro_rules! monitors {
    (
        $(#[$attr:meta])*
        $vis:vis mod $module:ident $( ( $($param:ident : $param_ty:ty),* $(,)? ) )?
            for $control:ty, $condition:ty {
            $( $(#[$id_attr:meta])* $id:ident = $monitor:expr ),+ $(,)?
        }
    ) => {
        $(#[$attr])*
        $vis mod $module {
            #[allow(unused_imports)]
            use super::*;

            /// The lines, in order: a line's discriminant is its id's index.
            #[allow(non_camel_case_types, dead_code, clippy::upper_case_acronyms)]
            enum Line { $($id),+ }

            $(
                $(#[$id_attr])*
                pub const $id: $crate::MonitorId =
                    $crate::MonitorId::from_index(Line::$id as usize);
            )+

            /// How many monitors the table holds.
            pub const COUNT: usize = [$(Line::$id),+].len();

            /// The table's type, with room for `M` monitors (by default these).
            pub type MonitorTable<const M: usize = COUNT> =
                $crate::Monitors<'static, $control, M, $condition>;

            /// The monitor table, with room for `M` monitors: entry `i` is the monitor whose
            /// id has index `i`.
            ///
            /// Errors as `rtseq::Monitors::table`.
            pub const fn table<const M: usize>(
                $( $($param: $param_ty),* )?
            ) -> ::core::result::Result<
                $crate::Monitors<'static, $control, M, $condition>,
                $crate::TableError,
            > {
                $crate::Monitors::table([$($monitor),+])
            }

            /// Checks these monitors with the sequence table `sequences`, as
            /// `rtseq::Table::validate` (in a `const` item: by the compiler).
            pub const fn validate<const N: usize>(
                sequences: &$crate::Table<$control, N>,
                $( $($param: $param_ty),* )?
            ) -> ::core::result::Result<(), $crate::ConfigError> {
                let monitors = [$($monitor),+];
                let checked = sequences.validate(&monitors);
                // A `const fn` may not drop a condition (whether its type needs a drop or
                // not: the macro serves both).
                #[allow(clippy::forget_non_drop)]
                ::core::mem::forget(monitors);
                checked
            }

            /// The monitors' names by id, apart from the table (for printing records
            /// where the table is out of reach).
            pub const fn names(
                $( $($param: $param_ty),* )?
            ) -> $crate::MonitorNames<COUNT> {
                let monitors: [$crate::OwnedMonitor<'static, $control, $condition>; COUNT] =
                    [$($monitor),+];
                let names = $crate::MonitorNames::of(&monitors);
                #[allow(clippy::forget_non_drop)]
                ::core::mem::forget(monitors);
                names
            }
        }
    };
}
