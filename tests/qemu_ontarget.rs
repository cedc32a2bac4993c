//! On-target tests: the defmt-test suite `boards/qemu-f405/tests/ontarget.rs` (the
//! priority-ceiling lock under RTIC priorities, the trace ring, the safety cycle's output
//! writes), built with `cargo test --no-run` for the chip and run in QEMU through the shared
//! harness's runner. defmt-test logs each test and exits 0 when all passed; a failed
//! assertion ends the firmware through its panic handler (exit 101).

mod qemu_harness;

use std::path::PathBuf;
use std::process::Command;

use qemu_harness::{
    expect_exit, expect_line, free_of_outer_cargo, require_tools, root, BOARD, RUN_TIMEOUT, TARGET,
};
use qemu_run::{Config, Echo};

/// Builds the defmt-test target `ontarget` of the board; returns the ELF's path.
fn build() -> PathBuf {
    require_tools();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(root()) // the root .cargo/config.toml: linker, linker scripts
        .args(["test", "--no-run", "--release", "--target", TARGET])
        .args(["--test", "ontarget", "--message-format=json"])
        .arg("--manifest-path")
        .arg(root().join(BOARD).join("Cargo.toml"))
        .arg("--target-dir")
        .arg(root().join("target/firmware"));
    free_of_outer_cargo(&mut cmd);
    let out = cmd.output().expect("cannot run cargo");
    assert!(
        out.status.success(),
        "building the on-target tests failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The test executable's path, from cargo's JSON messages.
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| l.contains("\"compiler-artifact\"") && l.contains("\"name\":\"ontarget\""))
        .find_map(|l| {
            let at = l.find("\"executable\":\"")? + "\"executable\":\"".len();
            let end = l[at..].find('"')?;
            Some(PathBuf::from(&l[at..at + end]))
        })
        .expect("cargo reported no executable for the test target `ontarget`")
}

#[test]
fn defmt_test_suite_passes_on_the_emulated_stm32f405() {
    let elf = build();
    let cfg = Config {
        timeout: RUN_TIMEOUT,
        echo: Echo::Stderr,
        ..Config::default()
    };
    let out = qemu_run::run(&elf, &cfg).unwrap_or_else(|e| panic!("running {elf:?}: {e}"));
    expect_exit(&out, 0);
    assert_eq!(out.malformed, 0, "{}", out.transcript());
    expect_line(&out, "all tests passed!");
    for name in [
        "the_ceiling_is_the_nvic_value_of_the_priority",
        "a_section_at_the_top_priority_disables_interrupts",
        "a_section_holds_off_the_ceiling_and_lets_higher_priorities_in",
        "nested_sections_restore_the_outer_ceiling",
        "the_trace_ring_keeps_the_newest_and_counts_the_lost",
        "the_safety_cycle_writes_set_and_toggle_outputs_every_cycle_and_never_leave",
    ] {
        assert!(
            out.lines.iter().any(|l| l.message.contains(name)),
            "test {name} did not run:\n{}",
            out.transcript()
        );
    }
}
