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
