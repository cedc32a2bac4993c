//! The live view on ratatui's test backend, fed the demo's following-error log line by
//! line as `./x demo --live` feeds it: the moves are shown `Restarting`, later `Aborted`,
//! with the monitor as their exception, and the safety level ends `off`.

mod common;

use ratatui::backend::TestBackend;
use ratatui::Terminal;
use rtseq_trace::live::{buffer_text, Live};
use rtseq_trace::model::State;

/// The row of `name` in the tree panel (the left half of the screen).
fn try_row<'a>(screen: &'a str, name: &str) -> Option<&'a str> {
    screen
        .lines()
        .map(|l| l.split('│').nth(1).unwrap_or(""))
        .find(|l| l.trim_start().starts_with(&format!("{name} ")))
}

fn row<'a>(screen: &'a str, name: &str) -> &'a str {
    try_row(screen, name).unwrap_or_else(|| panic!("no row {name} in\n{screen}"))
}

#[test]
fn following_error_restarting_then_aborted_and_level_off() {
    let mut live = Live::new(common::demo_hints(), "rtseq live");
    let mut term = Terminal::new(TestBackend::new(140, 32)).unwrap();
    let mut seen = Vec::new();
    for line in common::fixture_text().lines() {
        live.feed(line);
        term.draw(|f| live.draw(f)).unwrap();
        let screen = buffer_text(term.backend());
        let moves = try_row(&screen, "moves").unwrap_or("").to_string();
        for st in [State::Running, State::Restarting, State::Aborted] {
            if moves.contains(&format!(" {} ", st.name())) && seen.last() != Some(&st) {
                seen.push(st);
            }
        }
        if line.contains("moves          Running -> Restarting") {
            assert!(moves.contains("Restarting"), "{screen}");
            assert!(moves.contains("exception: following error"), "{screen}");
        }
    }
    live.end();
    term.draw(|f| live.draw(f)).unwrap();
    let screen = buffer_text(term.backend());
    // Restarting (three times), then Aborted for good.
    assert_eq!(
        seen,
        [
            State::Running,
            State::Restarting,
            State::Running,
            State::Restarting,
            State::Running,
            State::Restarting,
            State::Running,
            State::Aborted
        ],
        "{screen}"
    );
    assert!(row(&screen, "moves").contains("Aborted"), "{screen}");
    assert!(row(&screen, "moves").contains("exception: following error"));
    assert!(screen.contains("safety level: off"), "{screen}");
    assert_eq!(live.level(), Some("off"));
    assert_eq!(live.state("moves"), Some(State::Aborted));
    // Nested by caller: move under moves under main.
    let indent = |name: &str| row(&screen, name).len() - row(&screen, name).trim_start().len();
    assert_eq!(indent("main") + 2, indent("moves"));
    assert_eq!(indent("moves") + 2, indent("move"));
    assert_eq!(indent("move") + 2, indent("safe stop"));
    assert!(screen.contains("input ended"));
}

/// The demo's log as if its firmware had lost records (its final check failed): from that
/// line on, the header of the view says the record is incomplete, and the check is among
/// the latest events; the HTML timeline of the same log has the warning banner.
#[test]
fn a_failed_lost_check_shows_in_the_header() {
    let ok = "check     ok    no trace record or event lost";
    let text = common::fixture_text();
    assert_eq!(text.matches(ok).count(), 1);
    let text = text.replace(ok, "check     FAIL  no trace record or event lost");
    let mut live = Live::new(common::demo_hints(), "rtseq live");
    let mut failed = false;
    for line in text.lines() {
        live.feed(line);
        failed |= line.contains("FAIL  no trace record");
        let screen = live.to_text(140, 32);
        let head = screen.lines().nth(1).unwrap_or("");
        assert_eq!(
            head.contains("RECORDS LOST (incomplete)"),
            failed,
            "{screen}"
        );
    }
    live.end();
    let screen = live.to_text(140, 32);
    assert!(
        screen.contains("check FAIL no trace record or event lost"),
        "{screen}"
    );
    // Narrow: the warning comes first in the header.
    let narrow = live.to_text(40, 12);
    assert!(
        narrow.lines().nth(1).unwrap_or("").contains("RECORDS LOST"),
        "{narrow}"
    );

    let run = rtseq_trace::log::LogParser::parse_all(&text, common::demo_hints());
    assert_eq!(run.lost, rtseq_trace::model::Lost::Uncounted);
    let page = rtseq_trace::html::render(&run, "demo");
    assert!(page
        .contains("records were lost (the source does not say how many): the trace is incomplete"));
    // The fixture itself lost nothing.
    assert!(!common::fixture_run().lost.any());
}

/// The view's exception marks (live.rs, `ExceptionMarks::note`), line by line: the owner is
/// marked from its exception sequence's start, not the exception sequence; the mark ends
/// with the exception sequence when its behaviour leaves the owner running, comes back
/// with a behaviour that stops it, stays through a pause request, and ends with an abort
/// for another cause, a `PauseOwner` release and a restart's new round.
#[test]
fn exception_marks_follow_the_owner() {
    let hints = rtseq_trace::log::Hints::parse("axis < main\nstop < axis\n").unwrap();
    let mut live = Live::new(hints, "marks");
    let marked = |live: &Live, name: &str| {
        let screen = live.to_text(100, 20);
        row(&screen, name).contains("exception: jam")
    };
    let feed = |live: &mut Live, t: &str, rest: &str| {
        live.feed(&format!("{t} INFO  seq       {rest}"));
    };
    feed(&mut live, "0.001000", "main  Idle -> Running  (start)");
    feed(&mut live, "0.001001", "axis  Idle -> Running  (start)");
    assert!(!marked(&live, "axis"));
    // `jam` fires with an exception sequence and `Nothing`: marked while `stop` runs.
    feed(
        &mut live,
        "0.002000",
        "stop  Idle -> Running  (monitor jam)",
    );
    assert!(marked(&live, "axis"));
    assert!(!marked(&live, "stop"));
    feed(
        &mut live,
        "0.003000",
        "stop  Running -> Terminated  (completed)",
    );
    assert!(!marked(&live, "axis"), "the owner runs on");
    // Again, with `AbortOwner`: marked again when the behaviour aborts it, and it stays.
    feed(
        &mut live,
        "0.004000",
        "stop  Terminated -> Running  (monitor jam)",
    );
    feed(
        &mut live,
        "0.005000",
        "stop  Running -> Terminated  (completed)",
    );
    feed(
        &mut live,
        "0.006000",
        "axis  Running -> Aborting  (monitor jam)",
    );
    feed(
        &mut live,
        "0.006001",
        "axis  Aborting -> Aborted  (monitor jam)",
    );
    assert!(marked(&live, "axis"));
    assert!(!marked(&live, "stop"));
    // A new start ends it; a `PauseOwner` hold marks, a pause request keeps, the release
    // ends it.
    feed(&mut live, "0.007000", "axis  Aborted -> Running  (start)");
    assert!(!marked(&live, "axis"));
    feed(
        &mut live,
        "0.008000",
        "axis  Running -> Paused  (monitor jam)",
    );
    assert!(marked(&live, "axis"));
    feed(&mut live, "0.008500", "main  Running -> Paused  (pause)");
    assert!(marked(&live, "axis"));
    feed(&mut live, "0.008600", "main  Paused -> Running  (resume)");
    feed(
        &mut live,
        "0.009000",
        "axis  Paused -> Running  (monitor jam)",
    );
    assert!(!marked(&live, "axis"));
    // A restart marks its target until the new round; an abort for another cause during
    // an exception ends the mark.
    feed(
        &mut live,
        "0.010000",
        "main  Running -> Restarting  (monitor jam)",
    );
    assert!(marked(&live, "main"));
    feed(
        &mut live,
        "0.010001",
        "main  Restarting -> Running  (restart)",
    );
    assert!(!marked(&live, "main"));
    feed(
        &mut live,
        "0.011000",
        "stop  Terminated -> Running  (monitor jam)",
    );
    assert!(marked(&live, "axis"));
    feed(&mut live, "0.012000", "stop  Running -> Aborting  (abort)");
    feed(&mut live, "0.012001", "stop  Aborting -> Aborted  (abort)");
    feed(&mut live, "0.012002", "axis  Running -> Aborting  (abort)");
    assert!(!marked(&live, "axis"));
}
