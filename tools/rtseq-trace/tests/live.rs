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
