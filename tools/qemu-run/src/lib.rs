//! Run an rtseq firmware ELF in QEMU and read what it says.
//!
//! QEMU (`qemu-system-arm -machine netduinoplus2`, semihosting on, `-icount
//! shift=0,sleep=off`) runs the ELF; the firmware's defmt frames arrive on QEMU's stdout and
//! are decoded here with `defmt-decoder` into [`LogLine`]s (optionally echoed live); the
//! firmware's semihosting exit code becomes QEMU's exit status and is returned; a host time
//! limit kills QEMU if the firmware never exits.
//!
//! Used by the `qemu-run` binary (the cargo runner for `thumbv7em-none-eabihf`, via
//! `tools/qemu-runner`) and in-process by the QEMU test suite (`tests/qemu.rs`).

use std::fmt;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use defmt_decoder::{DecodeError, Locations, Table};

/// Exit code reported when the time limit was hit (as `timeout(1)`).
pub const EXIT_TIMEOUT: i32 = 124;
/// Exit code reported when QEMU ended without an exit status (killed by a signal).
pub const EXIT_SIGNAL: i32 = 125;
/// Exit code of a board firmware that ended with success but whose logger could not hand
/// some log bytes to the host (`boards/qemu-f405/src/logger.rs`): the log is incomplete.
pub const EXIT_LOG_LOST: i32 = 104;
/// Default host-time limit for one run.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(60);

/// How to install what is missing.
pub const SETUP_HINT: &str = "run `./x setup` at the repository root (it installs qemu-system-arm \
    with apt-get and the thumbv7em-none-eabihf target with rustup)";

/// An error that prevented a run (not a failing firmware: that is an [`Outcome`]).
#[derive(Debug)]
pub struct Error(pub String);

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

fn err<T>(msg: impl Into<String>) -> Result<T, Error> {
    Err(Error(msg.into()))
}

/// Where decoded lines are echoed while QEMU runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Echo {
    /// Collect only.
    None,
    /// Print each line to stdout as it arrives (the cargo runner).
    Stdout,
    /// Print each line to stderr as it arrives (tests: shown with `--nocapture`).
    Stderr,
}

/// Run configuration.
#[derive(Clone, Debug)]
pub struct Config {
    /// QEMU binary (default `qemu-system-arm`, or `$QEMU_SYSTEM_ARM`).
    pub qemu: String,
    /// QEMU machine (default `netduinoplus2`, the STM32F405 board).
    pub machine: String,
    /// Host-time limit.
    pub timeout: Duration,
    /// Live echo of decoded lines.
    pub echo: Echo,
    /// Append the source location (`file:line`) to echoed lines of level WARN and above.
    pub locations: bool,
    /// Semihosting command-line arguments for the firmware (after the program name).
    pub firmware_args: Vec<String>,
    /// Further QEMU arguments (e.g. `-d unimp`).
    pub extra_qemu_args: Vec<String>,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            qemu: std::env::var("QEMU_SYSTEM_ARM").unwrap_or_else(|_| "qemu-system-arm".into()),
            machine: "netduinoplus2".into(),
            timeout: DEFAULT_TIMEOUT,
            echo: Echo::None,
            locations: true,
            firmware_args: Vec::new(),
            extra_qemu_args: Vec::new(),
        }
    }
}

/// One decoded defmt frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LogLine {
    /// Virtual time of the frame in microseconds (the board's `defmt::timestamp!`).
    pub time_us: Option<u64>,
    /// `TRACE`, `DEBUG`, `INFO`, `WARN`, `ERROR` (None for `println!`).
    pub level: Option<&'static str>,
    /// The formatted message.
    pub message: String,
    /// `file:line` of the log statement, when the ELF has debug info.
    pub location: Option<String>,
}

impl fmt::Display for LogLine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.time_us {
            Some(us) => write!(f, "{:>4}.{:06} ", us / 1_000_000, us % 1_000_000)?,
            None => f.write_str("           ")?,
        }
        write!(f, "{:<5} {}", self.level.unwrap_or(""), self.message)
    }
}

/// How QEMU ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// QEMU exited with this code (the firmware's semihosting exit code).
    Exited(i32),
    /// The time limit was hit; QEMU was killed.
    TimedOut,
    /// QEMU was killed by a signal.
    Signaled,
}

/// Result of one run.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub status: Status,
    pub lines: Vec<LogLine>,
    /// QEMU's own stderr (warnings, errors).
    pub qemu_stderr: String,
    /// Bytes or frames on stdout that were not valid defmt frames.
    pub malformed: usize,
    /// Host wall-clock time of the run.
    pub wall: Duration,
}

impl Outcome {
    /// The exit code to report ([`EXIT_TIMEOUT`], [`EXIT_SIGNAL`] for the non-exits).
    pub fn exit_code(&self) -> i32 {
        match self.status {
            Status::Exited(c) => c,
            Status::TimedOut => EXIT_TIMEOUT,
            Status::Signaled => EXIT_SIGNAL,
        }
    }

    /// The decoded messages, in order.
    pub fn messages(&self) -> impl Iterator<Item = &str> {
        self.lines.iter().map(|l| l.message.as_str())
    }

    /// The first line whose message starts with `prefix`.
    pub fn find(&self, prefix: &str) -> Option<&LogLine> {
        self.lines.iter().find(|l| l.message.starts_with(prefix))
    }

    /// The whole log as text, with the status and QEMU's stderr (for assertion messages).
    pub fn transcript(&self) -> String {
        let mut s = String::new();
        for l in &self.lines {
            s.push_str(&l.to_string());
            if let Some(loc) = &l.location {
                s.push_str("  (");
                s.push_str(loc);
                s.push(')');
            }
            s.push('\n');
        }
        s.push_str(&format!(
            "-- status: {:?}, {} malformed, wall {:?}\n",
            self.status, self.malformed, self.wall
        ));
        if self.status == Status::Exited(EXIT_LOG_LOST) {
            s.push_str("-- exit code 104: the host refused log bytes, this log is incomplete\n");
        }
        if !self.qemu_stderr.is_empty() {
            s.push_str("-- qemu stderr:\n");
            s.push_str(&self.qemu_stderr);
        }
        s
    }
}

/// Checks that the QEMU binary can be started; returns its version line.
pub fn check_qemu(cfg: &Config) -> Result<String, Error> {
    match Command::new(&cfg.qemu)
        .arg("--version")
        .stdin(Stdio::null())
        .output()
    {
        Ok(o) if o.status.success() => Ok(String::from_utf8_lossy(&o.stdout)
            .lines()
            .next()
            .unwrap_or("")
            .to_string()),
        Ok(o) => err(format!(
            "`{} --version` failed ({}); {SETUP_HINT}",
            cfg.qemu, o.status
        )),
        Err(e) => err(format!("cannot run `{}` ({e}); {SETUP_HINT}", cfg.qemu)),
    }
}

/// Escapes an argument for `-semihosting-config arg=...` (commas are doubled).
fn qemu_opt_escape(s: &str) -> String {
    s.replace(',', ",,")
}

/// The QEMU command line for `elf`.
pub fn qemu_command(elf: &Path, cfg: &Config) -> Command {
    let mut semi = String::from("enable=on,target=native");
    if !cfg.firmware_args.is_empty() {
        let name = elf
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        for a in std::iter::once(&name).chain(cfg.firmware_args.iter()) {
            semi.push_str(",arg=");
            semi.push_str(&qemu_opt_escape(a));
        }
    }
    let mut cmd = Command::new(&cfg.qemu);
    cmd.args([
        "-machine",
        &cfg.machine,
        "-cpu",
        "cortex-m4",
        "-nographic",
        "-monitor",
        "none",
    ])
    .args(["-serial", "null", "-semihosting-config", &semi])
    .args(["-icount", "shift=0,sleep=off"])
    .args(&cfg.extra_qemu_args)
    .arg("-kernel")
    .arg(elf);
    cmd
}

struct Decoder<'t> {
    table: &'t Table,
    locations: Option<Locations>,
    stream: Box<dyn defmt_decoder::StreamDecoder + Send + Sync + 't>,
    malformed: usize,
}

impl<'t> Decoder<'t> {
    fn feed(&mut self, bytes: &[u8], out: &mut Vec<LogLine>) -> Result<(), Error> {
        self.stream.received(bytes);
        loop {
            match self.stream.decode() {
                Ok(frame) => {
                    let location = self
                        .locations
                        .as_ref()
                        .and_then(|l| l.get(&frame.index()))
                        .map(|l| format!("{}:{}", l.file.display(), l.line));
                    let time_us = frame
                        .display_timestamp()
                        .and_then(|t| parse_seconds_us(&t.to_string()));
                    out.push(LogLine {
                        time_us,
                        level: frame.level().map(|l| level_name(l.as_str())),
                        message: frame.display_message().to_string(),
                        location,
                    });
                }
                Err(DecodeError::UnexpectedEof) => return Ok(()),
                Err(DecodeError::Malformed) => {
                    self.malformed += 1;
                    if !self.table.encoding().can_recover() {
                        return err("malformed defmt frame and the encoding cannot recover");
                    }
                }
            }
        }
    }
}

fn level_name(lowercase: &str) -> &'static str {
    match lowercase {
        "trace" => "TRACE",
        "debug" => "DEBUG",
        "info" => "INFO",
        "warn" => "WARN",
        "error" => "ERROR",
        _ => "?",
    }
}

/// Parses the decoder's rendering of a `{=u64:us}` timestamp ("1.000250") into µs.
fn parse_seconds_us(s: &str) -> Option<u64> {
    let s = s.trim();
    let (secs, frac) = s.split_once('.').unwrap_or((s, ""));
    let secs: u64 = secs.parse().ok()?;
    let mut frac = frac.to_string();
    if frac.len() > 6 || !frac.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    while frac.len() < 6 {
        frac.push('0');
    }
    Some(secs * 1_000_000 + frac.parse::<u64>().ok()?)
}

fn echo_line(line: &LogLine, cfg: &Config) {
    let mut text = line.to_string();
    if cfg.locations && matches!(line.level, Some("WARN" | "ERROR")) {
        if let Some(loc) = &line.location {
            text.push_str(&format!("  ({loc})"));
        }
    }
    match cfg.echo {
        Echo::None => {}
        Echo::Stdout => {
            let mut o = std::io::stdout().lock();
            let _ = writeln!(o, "{text}");
            let _ = o.flush();
        }
        Echo::Stderr => eprintln!("{text}"),
    }
}

/// Runs `elf` in QEMU until it exits or the time limit passes.
pub fn run(elf: &Path, cfg: &Config) -> Result<Outcome, Error> {
    let bytes =
        std::fs::read(elf).map_err(|e| Error(format!("cannot read ELF {}: {e}", elf.display())))?;
    let table = match Table::parse(&bytes) {
        Ok(Some(t)) => t,
        Ok(None) => {
            return err(format!(
                "{}: no .defmt section (not a defmt firmware?)",
                elf.display()
            ))
        }
        Err(e) => {
            return err(format!(
                "{}: cannot read the defmt table: {e}",
                elf.display()
            ))
        }
    };
    let locations = table.get_locations(&bytes).ok().filter(|l| !l.is_empty());

    let mut child = qemu_command(elf, cfg)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| Error(format!("cannot start `{}` ({e}); {SETUP_HINT}", cfg.qemu)))?;
    let start = Instant::now();
    let mut stdout = child
        .stdout
        .take()
        .ok_or_else(|| Error("no stdout pipe".into()))?;
    let mut stderr = child
        .stderr
        .take()
        .ok_or_else(|| Error("no stderr pipe".into()))?;

    std::thread::scope(|scope| {
        let (line_tx, line_rx) = mpsc::channel::<LogLine>();
        let reader = scope.spawn(move || -> Result<usize, Error> {
            let mut dec = Decoder {
                table: &table,
                locations,
                stream: table.new_stream_decoder(),
                malformed: 0,
            };
            let mut buf = [0u8; 4096];
            let mut lines = Vec::new();
            loop {
                let n = match stdout.read(&mut buf) {
                    Ok(0) => break,
                    Ok(n) => n,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                    Err(e) => return err(format!("reading QEMU stdout: {e}")),
                };
                dec.feed(&buf[..n], &mut lines)?;
                for l in lines.drain(..) {
                    echo_line(&l, cfg);
                    let _ = line_tx.send(l);
                }
            }
            Ok(dec.malformed)
        });
        let echo_stderr = cfg.echo != Echo::None;
        let err_reader = scope.spawn(move || {
            let mut all = Vec::new();
            let mut buf = [0u8; 1024];
            while let Ok(n) = stderr.read(&mut buf) {
                if n == 0 {
                    break;
                }
                if echo_stderr {
                    let _ = std::io::stderr().write_all(&buf[..n]);
                }
                all.extend_from_slice(&buf[..n]);
            }
            String::from_utf8_lossy(&all).into_owned()
        });

        let status = wait_with_timeout(&mut child, cfg.timeout)?;
        let malformed = reader
            .join()
            .map_err(|_| Error("decoder thread panicked".into()))??;
        let qemu_stderr = err_reader.join().unwrap_or_default();
        let lines: Vec<LogLine> = line_rx.try_iter().collect();
        Ok(Outcome {
            status,
            lines,
            qemu_stderr,
            malformed,
            wall: start.elapsed(),
        })
    })
}

fn wait_with_timeout(child: &mut std::process::Child, timeout: Duration) -> Result<Status, Error> {
    let deadline = Instant::now() + timeout;
    loop {
        match child.try_wait() {
            Ok(Some(st)) => return Ok(status_of(st)),
            Ok(None) => {}
            Err(e) => return err(format!("waiting for QEMU: {e}")),
        }
        if Instant::now() >= deadline {
            let _ = child.kill();
            let _ = child.wait();
            return Ok(Status::TimedOut);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn status_of(st: ExitStatus) -> Status {
    match st.code() {
        Some(c) => Status::Exited(c),
        None => Status::Signaled,
    }
}

/// `path` if it exists, else an error naming it.
pub fn existing(path: impl Into<PathBuf>) -> Result<PathBuf, Error> {
    let p = path.into();
    if p.exists() {
        Ok(p)
    } else {
        err(format!("{} does not exist", p.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_parse() {
        assert_eq!(parse_seconds_us("0.100000"), Some(100_000));
        assert_eq!(parse_seconds_us("12.000250"), Some(12_000_250));
        assert_eq!(parse_seconds_us("3"), Some(3_000_000));
        assert_eq!(parse_seconds_us("x"), None);
    }

    #[test]
    fn escape() {
        assert_eq!(qemu_opt_escape("a,b"), "a,,b");
    }

    #[test]
    fn line_display() {
        let l = LogLine {
            time_us: Some(1_000_250),
            level: Some("INFO"),
            message: "hi".into(),
            location: None,
        };
        assert_eq!(l.to_string(), "   1.000250 INFO  hi");
    }
}
