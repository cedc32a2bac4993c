//! `rtseq-trace`: looks at an rtseq run.
//!
//! Reads a run — a trace file written by the simulator (`rtseq::sim::Sim::save_trace`,
//! format in `docs/trace-format.md`) or the decoded defmt log of a firmware (QEMU's
//! `./x demo`, or `probe-rs run` on a board) — and writes a self-contained HTML timeline,
//! VCD, Perfetto trace-event JSON, the trace format itself, or shows it live in the
//! terminal.
//!
//! A run whose source lost records ([`model::Run::lost`]: a trace file's `"lost"`, a
//! firmware's failed `no trace record or event lost` check) is incomplete, and every output
//! says so: a banner on the HTML page, a `$comment` in the VCD, the Perfetto document's
//! `metadata` and process label, `"lost"` in a written trace file, a warning on standard
//! error from the command line and in the live view's header.

pub mod html;
pub mod live;
pub mod log;
pub mod model;
pub mod perfetto;
pub mod tracefile;
pub mod vcd;

use model::Run;

/// Reads a run from text: a trace file if its first line that is not blank is a trace
/// header (after a UTF-8 byte order mark, if any: [`tracefile::is_trace`]), else a log.
pub fn read_run(text: &str, hints: log::Hints) -> Result<Run, String> {
    if tracefile::is_trace(text) {
        tracefile::read(text)
    } else {
        let run = log::LogParser::parse_all(text, hints);
        if run.transitions.is_empty() && run.events.is_empty() && run.levels.is_empty() {
            return Err(String::from(
                "no sequencer transitions, events or levels found: neither a trace file nor a decoded rtseq log",
            ));
        }
        Ok(run)
    }
}
