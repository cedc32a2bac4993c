//! `qemu-run [OPTIONS] FIRMWARE.elf [FIRMWARE ARGS...]`
//!
//! Runs the ELF in QEMU (netduinoplus2, semihosting, `-icount shift=0,sleep=off`), prints its
//! defmt log decoded (one line per frame: virtual time in seconds, level, message), and exits
//! with the firmware's exit code (124 if the time limit was hit, 125 if QEMU died by a signal,
//! 2 on a usage or start-up error). Arguments after the ELF reach the firmware as its
//! semihosting command line. This is the cargo runner for `thumbv7em-none-eabihf` (through
//! `tools/qemu-runner`).
//!
//! Options:
//!   --timeout SECS      host-time limit (default 60, or $QEMU_RUN_TIMEOUT)
//!   --quiet             do not print the log (only errors)
//!   --no-locations      do not append file:line to WARN/ERROR lines
//!   --qemu-arg ARG      pass ARG to QEMU (repeatable), e.g. --qemu-arg=-d --qemu-arg=unimp

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use qemu_run::{Config, Echo, Status};

fn usage() -> ExitCode {
    eprintln!("usage: qemu-run [--timeout SECS] [--quiet] [--no-locations] [--qemu-arg ARG]... FIRMWARE.elf [ARGS...]");
    ExitCode::from(2)
}

fn main() -> ExitCode {
    let mut cfg = Config {
        echo: Echo::Stdout,
        ..Config::default()
    };
    if let Ok(t) = std::env::var("QEMU_RUN_TIMEOUT") {
        match t.parse::<f64>() {
            Ok(s) if s > 0.0 => cfg.timeout = Duration::from_secs_f64(s),
            _ => {
                eprintln!("qemu-run: bad QEMU_RUN_TIMEOUT={t:?}");
                return ExitCode::from(2);
            }
        }
    }
    let mut args = std::env::args().skip(1);
    let mut elf: Option<PathBuf> = None;
    while let Some(a) = args.next() {
        let (flag, inline) = match a.split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f.to_string(), Some(v.to_string())),
            _ => (a.clone(), None),
        };
        let mut value = |name: &str| {
            inline
                .clone()
                .or_else(|| args.next())
                .ok_or_else(|| format!("{name} needs a value"))
        };
        match flag.as_str() {
            "--timeout" => match value("--timeout").map(|v| v.parse::<f64>()) {
                Ok(Ok(s)) if s > 0.0 => cfg.timeout = Duration::from_secs_f64(s),
                _ => return usage(),
            },
            "--quiet" => cfg.echo = Echo::None,
            "--no-locations" => cfg.locations = false,
            "--qemu-arg" => match value("--qemu-arg") {
                Ok(v) => cfg.extra_qemu_args.push(v),
                Err(_) => return usage(),
            },
            "-h" | "--help" => {
                usage();
                return ExitCode::SUCCESS;
            }
            s if s.starts_with("--") => return usage(),
            _ => {
                elf = Some(PathBuf::from(a));
                break;
            }
        }
    }
    let Some(elf) = elf else { return usage() };
    cfg.firmware_args = args.collect();

    let outcome = match qemu_run::run(&elf, &cfg) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("qemu-run: {e}");
            return ExitCode::from(2);
        }
    };
    if outcome.malformed > 0 {
        eprintln!(
            "qemu-run: {} malformed defmt frame(s) skipped",
            outcome.malformed
        );
    }
    match outcome.status {
        Status::Exited(0) => {}
        Status::Exited(qemu_run::EXIT_LOG_LOST) => eprintln!(
            "qemu-run: firmware exited with code 104: the host refused some of its log bytes, \
             the log above is incomplete"
        ),
        Status::Exited(c) => eprintln!("qemu-run: firmware exited with code {c}"),
        Status::TimedOut => eprintln!("qemu-run: time limit of {:?} hit, QEMU killed", cfg.timeout),
        Status::Signaled => eprintln!("qemu-run: QEMU was killed by a signal"),
    }
    ExitCode::from(u8::try_from(outcome.exit_code()).unwrap_or(1))
}
