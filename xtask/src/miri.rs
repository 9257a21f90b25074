//! `cargo xtask miri`: the lock-free channels of `robot-app` (`robot_app::channel`, the
//! only `unsafe` code of the application) under Miri, which reports undefined behaviour
//! as it runs: out-of-bounds or uninitialised reads, use after free, double drops,
//! leaks, aliasing violations (Stacked Borrows) and data races between threads, with
//! weak-memory effects emulated for the atomics.
//!
//! What runs: every unit test of the channel modules (the rings, the mailbox, their two-
//! thread tests, and every interleaving of the mailbox's handshake and of the ring), and
//! the integration tests in [`INTEGRATION_TESTS`], which take the channels through the
//! whole robot and cost a few seconds each under Miri (most of the robot's tests would
//! take minutes there). Each of those must have run and passed: a renamed test fails the
//! step instead of silently dropping out of it.
//!
//! Budget: under two minutes on the 2-core machine from a fresh clone, set-up included
//! (about 40 s of it is `cargo miri setup` building Miri's standard library, once per
//! machine); the step prints its times.

use std::io::{BufRead as _, BufReader};
use std::process::Stdio;
use std::time::{Duration, Instant};

use anyhow::{bail, Context as _, Result};

use crate::setup;
use crate::steps::{display_command, Context};

/// The filter that selects the channel modules' unit tests in `robot-app`'s library.
const UNIT_TESTS: &str = "channel::";

/// Integration tests of `robot-app` (file, test) that take the channels through the
/// whole robot cheaply enough for Miri.
pub const INTEGRATION_TESTS: [(&str, &str); 5] = [
    // The outer loop's mailbox: lent, left unrun for a period, collected.
    (
        "outer_loop",
        "an_outer_loop_that_overruns_the_period_is_an_overrun",
    ),
    // The command ring full, its last place kept for the stop.
    (
        "link_service",
        "a_full_command_queue_answers_busy_but_keeps_room_for_an_emergency_stop",
    ),
    // The staging mailbox: a configuration staged, installed, read back.
    (
        "link_service",
        "set_params_applies_a_valid_configuration_atomically",
    ),
    // The staging mailbox's slot: an upload assembled in it, a configuration over it.
    (
        "path_upload",
        "a_configuration_set_during_an_upload_discards_it",
    ),
    // Three paths assembled, staged and installed one after another.
    (
        "path_upload",
        "uploads_one_after_another_each_become_active",
    ),
];

/// The time the whole step should stay under on the 2-core machine.
const BUDGET: Duration = Duration::from_secs(120);

/// Sets Miri up ([`setup::ensure_miri`]), runs the tests, checks that every one of them
/// ran and passed, and prints the times.
pub fn check(ctx: &Context) -> Result<()> {
    let started = Instant::now();
    setup::ensure_miri(ctx)?;
    let set_up = started.elapsed();

    let mut args = vec!["miri", "test", "--package", "robot-app", "--lib"];
    let mut files: Vec<&str> = INTEGRATION_TESTS.iter().map(|&(file, _)| file).collect();
    files.sort_unstable();
    files.dedup();
    for file in files {
        args.extend(["--test", file]);
    }
    // libtest's filters select a test whose name contains any of them; the integration
    // tests' names are whole names, and no unit test's name contains one.
    args.push("--");
    args.push(UNIT_TESTS);
    args.extend(INTEGRATION_TESTS.iter().map(|&(_, name)| name));
    let tests_started = Instant::now();
    let passed = run_tests(&mut setup::nightly_cargo(ctx, &args))?;
    let tests = tests_started.elapsed();

    let units = passed.iter().filter(|n| n.starts_with(UNIT_TESTS)).count();
    let missing: Vec<&str> = INTEGRATION_TESTS
        .iter()
        .map(|&(_, name)| name)
        .filter(|name| !passed.iter().any(|n| n == name))
        .collect();
    let total = started.elapsed();
    println!(
        "miri: {units} channel unit tests and {} integration tests passed; set-up {:.1} s, \
         tests {:.1} s, {:.1} s in all (budget {} s)",
        INTEGRATION_TESTS.len() - missing.len(),
        set_up.as_secs_f64(),
        tests.as_secs_f64(),
        total.as_secs_f64(),
        BUDGET.as_secs()
    );
    if units == 0 {
        bail!("no test of robot-app's `{UNIT_TESTS}` modules ran under Miri");
    }
    if !missing.is_empty() {
        bail!(
            "these integration tests did not run under Miri (renamed or moved? see \
             INTEGRATION_TESTS in xtask/src/miri.rs): {}",
            missing.join(", ")
        );
    }
    if total > BUDGET {
        println!(
            "miri: note: over the {} s budget (a busy machine, or tests to trim)",
            BUDGET.as_secs()
        );
    }
    Ok(())
}

/// Runs `cmd` (a `cargo test`), echoing its output as it comes, and returns the names of
/// the tests it reports passed; an error if it fails.
fn run_tests(cmd: &mut std::process::Command) -> Result<Vec<String>> {
    let shown = display_command(cmd);
    println!("$ {shown}");
    let mut child = cmd
        .stdout(Stdio::piped())
        .spawn()
        .with_context(|| format!("could not start `{shown}`"))?;
    let mut passed = Vec::new();
    if let Some(stdout) = child.stdout.take() {
        for line in BufReader::new(stdout).lines() {
            let line = line.context("reading the tests' output")?;
            println!("{line}");
            if let Some(name) = passed_test(&line) {
                passed.push(name.to_owned());
            }
        }
    }
    let status = child
        .wait()
        .with_context(|| format!("`{shown}` did not finish"))?;
    if !status.success() {
        bail!("`{shown}` failed ({status})");
    }
    Ok(passed)
}

/// The test's name in libtest's `test NAME ... ok` (or `test NAME - should panic ... ok`).
fn passed_test(line: &str) -> Option<&str> {
    let rest = line.strip_prefix("test ")?.strip_suffix(" ... ok")?;
    Some(rest.strip_suffix(" - should panic").unwrap_or(rest))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passed_tests_are_read_from_libtest_lines() {
        assert_eq!(
            passed_test("test channel::ring::tests::a_single_slot_ring_works ... ok"),
            Some("channel::ring::tests::a_single_slot_ring_works")
        );
        assert_eq!(
            passed_test("test channel::x::fails_loudly - should panic ... ok"),
            Some("channel::x::fails_loudly")
        );
        assert_eq!(passed_test("test it ... FAILED"), None);
        assert_eq!(passed_test("test it ... ignored"), None);
        assert_eq!(passed_test("running 7 tests"), None);
        assert_eq!(
            passed_test("test result: ok. 7 passed; 0 failed; 0 ignored"),
            None
        );
    }

    #[test]
    fn the_integration_tests_exist() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../robot-app/tests");
        for (file, name) in INTEGRATION_TESTS {
            let path = root.join(format!("{file}.rs"));
            let source = std::fs::read_to_string(&path)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(
                source.contains(&format!("fn {name}()")),
                "{name} is not a test of {}",
                path.display()
            );
        }
    }
}
