//! The live view: the tree of sequences (nested by caller) with each one's state and active
//! exception, the safety level and the latest events, from a decoded log read line by line
//! (QEMU's or a probe's).

use std::collections::VecDeque;
use std::io::BufRead;
use std::sync::mpsc;
use std::time::Duration;

use crossterm::event::{self, Event as TermEvent, KeyCode, KeyEventKind, KeyModifiers};
use ratatui::backend::TestBackend;
use ratatui::layout::{Constraint, Layout};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line as TextLine, Span};
use ratatui::widgets::{Block, Borders, Paragraph};
use ratatui::{Frame, Terminal};

use crate::log::{Hints, Line, LogParser};
use crate::model::{secs, State, Transition};

/// The exceptions the view shows, per sequence.
#[derive(Default)]
struct ExceptionMarks {
    /// The exception (a monitor or timeout) that holds the sequence, stopped it or is
    /// restarting it.
    marks: Vec<Option<String>>,
    /// The sequence runs as an exception sequence (its caller is the owner).
    handling: Vec<bool>,
}

impl ExceptionMarks {
    /// Follows one transition into the exceptions shown: what a log tells of the library's
    /// `exception_is_active` (docs/semantics.md, item 3), and of the sequences an exception
    /// stopped or restarts. The start of an exception sequence (cause the monitor or
    /// timeout, from a state at rest) marks its caller, the owner, until it ends; the
    /// exception sequence itself is not marked. A transition the exception causes (an
    /// abort, a restart, a `PauseOwner` hold, of the owner or of a sequence its behaviour
    /// reaches) marks its sequence; a hold's release, a restart's new round, a new start,
    /// an end, and an abort for another cause clear the mark. A pause or resume request
    /// leaves it.
    fn note(&mut self, t: &Transition, owner: Option<usize>, sequences: usize) {
        self.marks.resize(sequences, None);
        self.handling.resize(sequences, false);
        let exceptional = t.cause.starts_with("monitor ") || t.cause.starts_with("timeout ");
        let handling = self.handling.get_mut(t.seq);
        if exceptional && !t.from.is_active() && t.to == State::Running {
            if let Some(h) = handling {
                *h = true;
            }
            if let Some(mark) = owner.and_then(|o| self.marks.get_mut(o)) {
                *mark = Some(t.cause.clone());
            }
            return;
        }
        if let Some(h) = handling.filter(|h| **h && !t.to.is_active()) {
            // The exception sequence ended: its owner's exception is handled (a behaviour
            // that stops the owner marks it again).
            *h = false;
            if let Some(mark) = owner.and_then(|o| self.marks.get_mut(o)) {
                *mark = None;
            }
        }
        if let Some(mark) = self.marks.get_mut(t.seq) {
            if exceptional {
                let released = t.from == State::Paused && t.to == State::Running;
                *mark = (!released).then(|| t.cause.clone());
            } else if !matches!(t.cause.as_str(), "pause" | "resume") {
                *mark = None;
            }
        }
    }

    /// The exception shown beside sequence `i`.
    fn of(&self, i: usize) -> Option<&str> {
        self.marks.get(i).and_then(Option::as_deref)
    }
}

/// How many events the view keeps.
const LATEST: usize = 200;

/// What the live view knows.
pub struct Live {
    parser: LogParser,
    exceptions: ExceptionMarks,
    latest: VecDeque<String>,
    ended: bool,
    title: String,
}

impl Live {
    /// An empty view.
    pub fn new(hints: Hints, title: &str) -> Live {
        Live {
            parser: LogParser::new(hints),
            exceptions: ExceptionMarks::default(),
            latest: VecDeque::new(),
            ended: false,
            title: title.to_string(),
        }
    }

    /// Reads one line of the log.
    pub fn feed(&mut self, line: &str) {
        let what = self.parser.line(line);
        let run = &self.parser.run;
        let text = match what {
            Line::Transition(k) => {
                let Some(t) = run.transitions.get(k) else {
                    return;
                };
                let owner = run.sequences.get(t.seq).and_then(|s| s.caller);
                self.exceptions.note(t, owner, run.sequences.len());
                let name = run.sequences.get(t.seq).map_or("?", |s| s.name.as_str());
                format!(
                    "{} {name}: {} -> {} ({})",
                    secs(t.time_us),
                    t.from,
                    t.to,
                    t.cause
                )
            }
            Line::Event(k) => match run.events.get(k) {
                Some(e) => format!(
                    "{} {}",
                    secs(e.time_us),
                    e.text.split_whitespace().collect::<Vec<_>>().join(" ")
                ),
                None => return,
            },
            Line::Level => match run.levels.last() {
                Some(l) => format!("{} safety level {}", secs(l.time_us), l.level),
                None => return,
            },
            Line::Signals | Line::Hint | Line::Other => return,
        };
        if self.latest.len() == LATEST {
            self.latest.pop_front();
        }
        self.latest.push_back(text);
    }

    /// Marks the end of the input.
    pub fn end(&mut self) {
        self.ended = true;
    }

    /// The current state of the sequence called `name`.
    pub fn state(&self, name: &str) -> Option<State> {
        let run = &self.parser.run;
        let i = run.sequences.iter().position(|s| s.name == name)?;
        Some(
            run.transitions
                .iter()
                .rev()
                .find(|t| t.seq == i)
                .map_or(State::Idle, |t| t.to),
        )
    }

    /// The current safety level.
    pub fn level(&self) -> Option<&str> {
        self.parser.run.levels.last().map(|l| l.level.as_str())
    }

    /// Draws the view.
    pub fn draw(&self, f: &mut Frame) {
        let run = &self.parser.run;
        let [head, body] =
            Layout::vertical([Constraint::Length(3), Constraint::Min(3)]).areas(f.area());
        let [left, right] =
            Layout::horizontal([Constraint::Percentage(45), Constraint::Percentage(55)])
                .areas(body);
        let level = self.level().unwrap_or("?");
        let status = if self.ended {
            "input ended; q: quit"
        } else {
            "running; q: quit"
        };
        let mut head_spans = vec![
            Span::raw(format!("t = {} s   ", secs(self.parser.now_us()))),
            Span::raw("safety level: "),
            Span::styled(
                level.to_string(),
                Style::default().add_modifier(Modifier::BOLD),
            ),
            Span::raw(format!(
                "   {} sequences, {} transitions   {status}",
                run.sequences.len(),
                run.transitions.len()
            )),
        ];
        if run.lost.any() {
            // First, so that a narrow terminal does not cut it off.
            head_spans.insert(
                0,
                Span::styled(
                    "RECORDS LOST (incomplete)   ",
                    Style::default().fg(Color::Red).add_modifier(Modifier::BOLD),
                ),
            );
        }
        let head_line = TextLine::from(head_spans);
        f.render_widget(
            Paragraph::new(head_line).block(
                Block::default()
                    .borders(Borders::ALL)
                    .title(format!(" {} ", self.title)),
            ),
            head,
        );

        let width = run
            .tree_order()
            .iter()
            .filter_map(|(i, d)| {
                run.sequences
                    .get(*i)
                    .map(|s| s.name.chars().count() + 2 * d)
            })
            .max()
            .unwrap_or(0);
        let mut lines = Vec::new();
        for (i, depth) in run.tree_order() {
            let Some(s) = run.sequences.get(i) else {
                continue;
            };
            let state = self.state(&s.name).unwrap_or(State::Idle);
            let label = format!("{}{}", "  ".repeat(depth), s.name);
            let mut spans = vec![
                Span::raw(format!("{label:<width$}  ")),
                Span::styled(format!("{:<10}", state.name()), state_style(state)),
            ];
            if let Some(x) = self.exceptions.of(i) {
                spans.push(Span::styled(
                    format!(" exception: {}", x.strip_prefix("monitor ").unwrap_or(x)),
                    Style::default().fg(Color::Red),
                ));
            }
            lines.push(TextLine::from(spans));
        }
        f.render_widget(
            Paragraph::new(lines).block(
                Block::default()
                    .borders(Borders::ALL)
                    .title(" sequences (nested by caller) "),
            ),
            left,
        );
        let rows = usize::from(right.height.saturating_sub(2));
        let skip = self.latest.len().saturating_sub(rows);
        let events: Vec<TextLine> = self
            .latest
            .iter()
            .skip(skip)
            .map(|s| TextLine::from(s.as_str()))
            .collect();
        f.render_widget(
            Paragraph::new(events).block(
                Block::default()
                    .borders(Borders::ALL)
                    .title(" latest events "),
            ),
            right,
        );
    }

    /// The view as text, `w` × `h` characters (tests, and the output when not on a terminal).
    pub fn to_text(&self, w: u16, h: u16) -> String {
        let mut term = match Terminal::new(TestBackend::new(w, h)) {
            Ok(t) => t,
            Err(e) => return format!("cannot draw: {e}"),
        };
        if let Err(e) = term.draw(|f| self.draw(f)) {
            return format!("cannot draw: {e}");
        }
        buffer_text(term.backend())
    }
}

/// The characters of a test backend's buffer, one line per row, trailing blanks removed.
pub fn buffer_text(b: &TestBackend) -> String {
    let buf = b.buffer();
    let mut out = String::new();
    for y in 0..buf.area.height {
        let mut line = String::new();
        for x in 0..buf.area.width {
            line.push_str(buf[(x, y)].symbol());
        }
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}

fn state_style(s: State) -> Style {
    let c = match s {
        State::Idle => Color::DarkGray,
        State::Running => Color::Green,
        State::Paused => Color::Yellow,
        State::Aborting => Color::LightRed,
        State::Aborted => Color::Red,
        State::Terminated => Color::Blue,
        State::Restarting => Color::Magenta,
    };
    Style::default().fg(c).add_modifier(Modifier::BOLD)
}

/// Runs the view in the terminal on lines from `input` (read on a thread) until `q`, Esc or
/// Ctrl-C; the input's end is shown, the view stays. Keys come from the terminal even when
/// the log is piped into standard input.
pub fn run_terminal<R: BufRead + Send + 'static>(mut live: Live, input: R) -> std::io::Result<()> {
    let (tx, rx) = mpsc::channel::<Option<String>>();
    std::thread::spawn(move || {
        for line in input.lines() {
            match line {
                Ok(l) => {
                    if tx.send(Some(l)).is_err() {
                        return;
                    }
                }
                Err(_) => break,
            }
        }
        let _ = tx.send(None);
    });
    let mut terminal = ratatui::init();
    let result = (|| -> std::io::Result<()> {
        loop {
            while let Ok(msg) = rx.try_recv() {
                match msg {
                    Some(l) => live.feed(&l),
                    None => live.end(),
                }
            }
            terminal.draw(|f| live.draw(f))?;
            if event::poll(Duration::from_millis(50))? {
                if let TermEvent::Key(k) = event::read()? {
                    let ctrl_c =
                        k.code == KeyCode::Char('c') && k.modifiers.contains(KeyModifiers::CONTROL);
                    if k.kind == KeyEventKind::Press
                        && (ctrl_c || matches!(k.code, KeyCode::Char('q') | KeyCode::Esc))
                    {
                        return Ok(());
                    }
                }
            }
        }
    })();
    ratatui::restore();
    result
}

/// Reads all of `input`, then prints the view once as text (when not on a terminal).
pub fn run_plain<R: BufRead>(mut live: Live, input: R, w: u16, h: u16) -> std::io::Result<()> {
    for line in input.lines() {
        live.feed(&line?);
    }
    live.end();
    print!("{}", live.to_text(w, h));
    Ok(())
}
