//! `rtseq-trace`: the command line (see `rtseq-trace --help`).

use std::io::{BufWriter, IsTerminal, Read, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use rtseq_trace::log::Hints;
use rtseq_trace::{html, live, perfetto, read_run, tracefile, vcd};

/// Looks at an rtseq run: a trace file written by the simulator (Sim::save_trace) or the
/// decoded defmt log of a firmware (./x demo, probe-rs run).
#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Writes pictures and exports of a finished run.
    ///
    /// When the run's source lost records (a trace file's `lost`, a firmware's failed
    /// check), it says so on standard error and in every output.
    ///
    /// Example: rtseq-trace render run.log --html run.html --vcd run.vcd --perfetto run.json
    Render {
        /// The run: a trace file (JSON lines, docs/trace-format.md) or a decoded defmt log;
        /// `-` or nothing for standard input.
        input: Option<PathBuf>,
        /// A self-contained HTML timeline (SVG, no network).
        #[arg(long, value_name = "FILE")]
        html: Option<PathBuf>,
        /// VCD for GTKWave or Surfer.
        #[arg(long, value_name = "FILE")]
        vcd: Option<PathBuf>,
        /// Chrome trace-event JSON for Perfetto (ui.perfetto.dev) or chrome://tracing.
        #[arg(long, value_name = "FILE")]
        perfetto: Option<PathBuf>,
        /// The run in the trace file format (converts a log).
        #[arg(long, value_name = "FILE")]
        trace: Option<PathBuf>,
        /// Caller hints for a log (`CHILD < CALLER` a line): the log has no callers.
        #[arg(long, value_name = "FILE")]
        tree: Option<PathBuf>,
        /// The title of the HTML page (default: the input's file name).
        #[arg(long)]
        title: Option<String>,
    },
    /// Shows a run live in the terminal while its decoded log arrives on standard input
    /// (or from a file): the tree of sequences with states and active exceptions, the
    /// safety level, the latest events. q, Esc or Ctrl-C quits.
    ///
    /// Example: probe-rs run --chip STM32F446RETx firmware.elf | rtseq-trace live
    Live {
        /// A log file instead of standard input.
        input: Option<PathBuf>,
        /// Caller hints (`CHILD < CALLER` a line).
        #[arg(long, value_name = "FILE")]
        tree: Option<PathBuf>,
        /// Print the final view as text instead of the terminal UI (the default when
        /// standard output is not a terminal).
        #[arg(long)]
        plain: bool,
        /// Width and height of the --plain view.
        #[arg(long, default_value = "120x40", value_name = "WxH")]
        size: String,
        /// The title of the view.
        #[arg(long, default_value = "rtseq live")]
        title: String,
    },
}

fn hints(tree: Option<&Path>) -> Result<Hints, String> {
    match tree {
        None => Ok(Hints::default()),
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .map_err(|e| format!("cannot read {}: {e}", p.display()))?;
            Hints::parse(&text).map_err(|e| format!("{}: {e}", p.display()))
        }
    }
}

fn read_input(input: Option<&Path>) -> Result<String, String> {
    match input {
        Some(p) if p != Path::new("-") => {
            std::fs::read_to_string(p).map_err(|e| format!("cannot read {}: {e}", p.display()))
        }
        _ => {
            let mut s = String::new();
            std::io::stdin()
                .read_to_string(&mut s)
                .map_err(|e| format!("cannot read standard input: {e}"))?;
            Ok(s)
        }
    }
}

fn write_file(
    path: &Path,
    what: &str,
    f: impl FnOnce(&mut BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<(), String> {
    let file = std::fs::File::create(path)
        .map_err(|e| format!("cannot create {}: {e}", path.display()))?;
    let mut out = BufWriter::new(file);
    f(&mut out)
        .and_then(|()| out.flush())
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    eprintln!("rtseq-trace: {what} written to {}", path.display());
    Ok(())
}

fn run(cli: Cli) -> Result<(), String> {
    match cli.command {
        Command::Render {
            input,
            html: html_out,
            vcd: vcd_out,
            perfetto: perfetto_out,
            trace,
            tree,
            title,
        } => {
            if html_out.is_none() && vcd_out.is_none() && perfetto_out.is_none() && trace.is_none()
            {
                return Err(String::from(
                    "nothing to write: give --html, --vcd, --perfetto or --trace (see --help)",
                ));
            }
            let text = read_input(input.as_deref())?;
            let run = read_run(&text, hints(tree.as_deref())?)?;
            if let Some(w) = run.lost.warning() {
                eprintln!("rtseq-trace: warning: {w}");
            }
            let title = title.unwrap_or_else(|| {
                let name = input.as_deref().and_then(Path::file_name).map_or_else(
                    || String::from("stdin"),
                    |n| n.to_string_lossy().into_owned(),
                );
                format!("rtseq timeline: {name}")
            });
            if let Some(p) = &html_out {
                write_file(p, "HTML timeline", |o| html::write(&run, &title, o))?;
            }
            if let Some(p) = &vcd_out {
                write_file(p, "VCD", |o| vcd::write(&run, o))?;
            }
            if let Some(p) = &perfetto_out {
                write_file(p, "Perfetto trace-event JSON", |o| perfetto::write(&run, o))?;
            }
            if let Some(p) = &trace {
                write_file(p, "trace file", |o| tracefile::write(&run, o))?;
            }
            Ok(())
        }
        Command::Live {
            input,
            tree,
            plain,
            size,
            title,
        } => {
            let view = live::Live::new(hints(tree.as_deref())?, &title);
            let (w, h) = plain_size(&size)?;
            let name = input
                .as_deref()
                .filter(|p| *p != Path::new("-"))
                .map_or_else(|| "standard input".to_string(), |p| p.display().to_string());
            let mut reader: Box<dyn std::io::BufRead + Send> = match input.as_deref() {
                Some(p) if p != Path::new("-") => Box::new(std::io::BufReader::new(
                    std::fs::File::open(p)
                        .map_err(|e| format!("cannot read {}: {e}", p.display()))?,
                )),
                _ => Box::new(std::io::BufReader::new(std::io::stdin())),
            };
            // A firmware's log line never begins with `{`; a trace file (JSON Lines) does.
            let head = reader
                .fill_buf()
                .map_err(|e| format!("cannot read {name}: {e}"))?;
            if head.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{') {
                return Err(format!(
                    "{name}: a trace file (JSON Lines); the live view reads a firmware's log \
                     (render a trace file with `rtseq-trace render`)"
                ));
            }
            let result = if plain || !std::io::stdout().is_terminal() {
                live::run_plain(view, reader, w, h)
            } else {
                live::run_terminal(view, reader)
            };
            result.map_err(|e| format!("live view: {e}"))
        }
    }
}

/// The most columns and rows of the `--plain` view (its text is drawn in memory).
const PLAIN_MAX: u16 = 1000;

/// `--size WxH` of the `--plain` view: 1 to [`PLAIN_MAX`] each.
fn plain_size(size: &str) -> Result<(u16, u16), String> {
    let (w, h) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u64>().ok()?, h.parse::<u64>().ok()?)))
        .ok_or_else(|| format!("--size {size}: expected WIDTHxHEIGHT"))?;
    let fits = |n: u64| (1..=u64::from(PLAIN_MAX)).contains(&n);
    if w == 0 || h == 0 {
        return Err(format!("--size {size}: too small (at least 1x1)"));
    }
    match (u16::try_from(w), u16::try_from(h)) {
        (Ok(w), Ok(h)) if fits(u64::from(w)) && fits(u64::from(h)) => Ok((w, h)),
        _ => Err(format!(
            "--size {size}: too large (at most {PLAIN_MAX}x{PLAIN_MAX})"
        )),
    }
}

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("rtseq-trace: {e}");
            ExitCode::FAILURE
        }
    }
}
