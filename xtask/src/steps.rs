//! The steps of `cargo xtask ci`, and running them: headers, timing, the closing tally.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use anyhow::{bail, ensure, Context as _, Result};

use crate::{elf_size, link_qemu, miri, panic_check, qemu, setup};

/// The ARM target of the firmware and the QEMU program.
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// Packages built only for [`TARGET`], never for the host.
pub const TARGET_ONLY_PACKAGES: [&str; 3] = ["firmware", "qemu-m4f", "qemu-link"];

/// The cargo profile the firmware is built with (size over speed, the control step's
/// crate excepted; see the workspace's `Cargo.toml`).
pub const FIRMWARE_PROFILE: &str = "firmware";

/// The profile `package` is built with for [`TARGET`]: the firmware's for the firmware
/// and for the link's QEMU program (so that its size is what the firmware pays),
/// `release` for the rest (the core's QEMU program measures the core at opt-level 3).
pub fn profile_for(package: &str) -> &'static str {
    match package {
        "firmware" | "qemu-link" => FIRMWARE_PROFILE,
        _ => "release",
    }
}

/// What every step needs: where the workspace is and which `cargo` runs it.
pub struct Context {
    /// The workspace root (where the workspace's `Cargo.toml` is).
    pub root: PathBuf,
    /// The `cargo` that started xtask (`$CARGO`), so nested builds use the same toolchain.
    cargo: OsString,
}

impl Context {
    /// A context for the workspace at `root`.
    pub fn new(root: PathBuf) -> Self {
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        Self { root, cargo }
    }

    /// `cargo <args>`, run in the workspace root.
    pub fn cargo(&self, args: &[&str]) -> Command {
        let mut cmd = Command::new(&self.cargo);
        cmd.args(args).current_dir(&self.root).stdin(Stdio::null());
        cmd
    }
}

/// Prints `$ program args…` (for the log) and runs `cmd` with inherited output.
pub fn run_command(cmd: &mut Command) -> Result<()> {
    let shown = display_command(cmd);
    println!("$ {shown}");
    let status = cmd
        .status()
        .with_context(|| format!("could not start `{shown}`"))?;
    if !status.success() {
        bail!("`{shown}` failed ({status})");
    }
    Ok(())
}

/// `program args…` with the program shown by its file name.
pub fn display_command(cmd: &Command) -> String {
    let program = Path::new(cmd.get_program())
        .file_name()
        .unwrap_or(cmd.get_program())
        .to_string_lossy()
        .into_owned();
    cmd.get_args().fold(program, |mut line, arg| {
        line.push(' ');
        line.push_str(&arg.to_string_lossy());
        line
    })
}

/// Builds `package` for [`TARGET`] with its profile ([`profile_for`]) and `extra_args`
/// (e.g. `--features`, possibly empty), and returns the paths of the executables it
/// produced (diagnostics go to the terminal as usual).
pub fn build_target_executables(
    ctx: &Context,
    package: &str,
    extra_args: &[&str],
) -> Result<Vec<PathBuf>> {
    build_target_artifacts(ctx, package, extra_args, "bin")
}

/// [`build_target_executables`] for the targets of cargo's `kind` (`bin`, `example`):
/// the paths of the executables of that kind the build produced.
pub fn build_target_artifacts(
    ctx: &Context,
    package: &str,
    extra_args: &[&str],
    kind: &str,
) -> Result<Vec<PathBuf>> {
    let mut args = vec![
        "build",
        "--profile",
        profile_for(package),
        "--package",
        package,
        "--target",
        TARGET,
        "--message-format=json-render-diagnostics",
    ];
    args.extend_from_slice(extra_args);
    let mut cmd = ctx.cargo(&args);
    let shown = display_command(&cmd);
    println!("$ {shown}");
    let output = cmd
        .stderr(Stdio::inherit())
        .output()
        .with_context(|| format!("could not start `{shown}`"))?;
    if !output.status.success() {
        bail!("`{shown}` failed ({})", output.status);
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
    let mut executables = Vec::new();
    for line in stdout.lines().filter(|l| l.starts_with('{')) {
        let message: serde_json::Value = serde_json::from_str(line)
            .with_context(|| format!("cargo printed a line that is not JSON: {line}"))?;
        if message["reason"] != "compiler-artifact" {
            continue;
        }
        let of_kind = message["target"]["kind"]
            .as_array()
            .is_some_and(|kinds| kinds.iter().any(|k| k == kind));
        if let (true, Some(path)) = (of_kind, message["executable"].as_str()) {
            executables.push(PathBuf::from(path));
        }
    }
    Ok(executables)
}

/// What a step runs; an error fails the step.
pub type Check = dyn Fn(&Context) -> Result<()>;

/// A named check.
pub struct Step {
    /// Shown in the header and the summary.
    pub name: &'static str,
    /// The check.
    pub run: Box<Check>,
}

impl Step {
    /// A step named `name` that runs `run`.
    pub fn new(name: &'static str, run: impl Fn(&Context) -> Result<()> + 'static) -> Self {
        Self {
            name,
            run: Box::new(run),
        }
    }
}

/// Runs every step (all of them, whatever fails), prints a summary (with the total time
/// against `budget_s`, if given) and the closing line `N passed, N failed`. Returns true
/// when all passed.
pub fn run_all(ctx: &Context, steps: &[Step], budget_s: Option<u32>) -> bool {
    let started = Instant::now();
    let mut results = Vec::with_capacity(steps.len());
    for (i, step) in steps.iter().enumerate() {
        println!("\n==> [{}/{}] {}", i + 1, steps.len(), step.name);
        let t0 = Instant::now();
        let result = (step.run)(ctx);
        let secs = t0.elapsed().as_secs_f64();
        match &result {
            Ok(()) => println!("--> ok: {} ({secs:.1} s)", step.name),
            Err(e) => println!("--> FAILED: {} ({secs:.1} s)\n    {e:#}", step.name),
        }
        results.push((step.name, secs, result));
    }

    let total_s = started.elapsed().as_secs_f64();
    match budget_s {
        Some(budget) => println!(
            "\n==> summary ({total_s:.0} s; the budget is {budget} s on 2 cores, from a fresh \
             clone)"
        ),
        None => println!("\n==> summary ({total_s:.0} s)"),
    }
    for (name, secs, result) in &results {
        match result {
            Ok(()) => println!("    ok     {name} ({secs:.1} s)"),
            // The reason again, so that the end of a long log says why.
            Err(e) => println!(
                "    FAILED {name} ({secs:.1} s)\n           {}",
                failure_reason(e)
            ),
        }
    }
    let failed = results.iter().filter(|(_, _, r)| r.is_err()).count();
    println!("{} passed, {failed} failed", results.len() - failed);
    failed == 0
}

/// The first lines of a step's error (its context chain on one line each, at most
/// [`REASON_LINES`]), for the summary.
fn failure_reason(e: &anyhow::Error) -> String {
    let text = format!("{e:#}");
    let mut lines: Vec<&str> = text.lines().take(REASON_LINES + 1).collect();
    if lines.len() > REASON_LINES {
        lines.truncate(REASON_LINES);
        lines.push("…");
    }
    lines.join("\n           ")
}

/// Lines of a failed step's error the summary repeats.
const REASON_LINES: usize = 6;

/// `cargo test` over the workspace's host crates (every crate but the target-only ones),
/// followed by `extra`: CI's host-tests step, and the build every binary-running step
/// shares ([`host_binary`]).
fn host_tests(extra: &[&'static str]) -> Vec<&'static str> {
    let mut args = vec!["test", "--workspace"];
    for package in TARGET_ONLY_PACKAGES {
        args.extend(["--exclude", package]);
    }
    args.extend_from_slice(extra);
    args
}

/// Builds the host crates' tests, and with them their binaries (`host-sim`, `station`),
/// exactly as the host-tests step does, and returns the path of `name`'s. Every step that
/// runs one of them shares that build: any other package selection (`cargo build
/// --package host-sim`, `cargo run --package host-sim`) resolves the shared crates'
/// features for itself and builds them again, about a minute each from a fresh clone.
pub fn host_binary(ctx: &Context, name: &str) -> Result<PathBuf> {
    run_command(&mut ctx.cargo(&host_tests(&["--no-run"])))?;
    let exe = crate::pil::target_dir(ctx).join("debug").join(name);
    ensure!(exe.is_file(), "no {name} at {}", exe.display());
    Ok(exe)
}

/// The time `cargo xtask ci` may take from a fresh clone on a 2-core machine, s.
pub const CI_BUDGET_S: u32 = 15 * 60;

/// proptest's seed variable, and the seed CI's host tests use.
const PROPTEST_SEED_VAR: &str = "PROPTEST_RNG_SEED";
const CI_PROPTEST_SEED: &str = "20111";

/// Every check, in the order `cargo xtask ci` runs them.
pub fn ci() -> Vec<Step> {
    vec![
        setup(),
        Step::new("rustfmt", |ctx| {
            run_command(&mut ctx.cargo(&["fmt", "--all", "--check"]))
        }),
        Step::new("clippy: host crates", |ctx| {
            let mut args = vec!["clippy", "--workspace"];
            for package in TARGET_ONLY_PACKAGES {
                args.extend(["--exclude", package]);
            }
            args.extend(["--all-targets", "--", "-D", "warnings"]);
            run_command(&mut ctx.cargo(&args))
        }),
        Step::new("clippy: the station without its figures", |ctx| {
            // The figures (plotters) are a default feature: the build without them must not
            // rot just because the default build skips it.
            run_command(&mut ctx.cargo(&[
                "clippy",
                "--package",
                "station",
                "--no-default-features",
                "--",
                "-D",
                "warnings",
            ]))
        }),
        Step::new(
            "clippy: firmware and its first-flash programs (thumbv7em-none-eabihf)",
            |ctx| clippy_for_target(ctx, "firmware", &FIRMWARE_TARGETS),
        ),
        Step::new(
            "clippy: firmware feature variants, the STM32F401 port and the emulated board",
            |ctx| {
                // Every optional feature at once, then the porting example's other chip: code
                // behind a feature must not rot just because the default build skips it.
                let variant = |features: &[&str]| {
                    let mut args = FIRMWARE_TARGETS.to_vec();
                    args.extend_from_slice(features);
                    clippy_for_target(ctx, "firmware", &args)
                };
                variant(&[
                    "--features",
                    "drv8833,nucleo,auto-arm,bring-up,path-line,panic-canary",
                ])?;
                variant(&["--no-default-features", "--features", "stm32f401"])?;
                // The emulated board, with the one first-flash program it runs.
                clippy_for_target(
                    ctx,
                    "firmware",
                    &[
                        "--lib",
                        "--bins",
                        "--example",
                        "hello",
                        "--features",
                        "qemu",
                    ],
                )
            },
        ),
        Step::new("clippy: qemu-m4f (thumbv7em-none-eabihf)", |ctx| {
            clippy_for_target(ctx, "qemu-m4f", &[])
        }),
        Step::new("clippy: qemu-link (thumbv7em-none-eabihf)", |ctx| {
            clippy_for_target(ctx, "qemu-link", &[])
        }),
        Step::new(
            "tests: host crates, the station end to end against the virtual robot among them",
            |ctx| {
                // --no-fail-fast: one failing crate must not hide the others' results. The
                // station's end-to-end tests (`end_to_end`) run here, in the same build: a
                // `cargo test -p station` of its own resolves the shared crates' features for
                // the station alone and builds about 95 crates again.
                let mut cmd = ctx.cargo(&host_tests(&["--no-fail-fast"]));
                // The property tests draw from one fixed seed here, so that a CI run can be
                // repeated exactly; a plain `cargo test` draws new cases every time. A seed
                // already in the environment wins.
                if std::env::var_os(PROPTEST_SEED_VAR).is_none() {
                    cmd.env(PROPTEST_SEED_VAR, CI_PROPTEST_SEED);
                }
                run_command(&mut cmd)
            },
        ),
        self::miri(),
        firmware_size(),
        first_flash(),
        panic_check(),
        qemu(),
        link_qemu(),
        pil(),
        docs(),
        protocol_page(),
        protocol_client(),
        velocity_check(),
        foxglove_file(),
        foxglove_live(),
        ros2_peer(),
        Step::new(
            "figures: docs/figures.md, the README's headline rows and docs/safety.md's fault matrix up to date with the simulator",
            |ctx| crate::figures::run(ctx, true),
        ),
    ]
}

/// `cargo doc --no-deps` with warnings denied: the host crates, then the firmware for its
/// target (a broken intra-doc link or a missing doc fails it).
pub fn docs() -> Step {
    Step::new(
        "docs: cargo doc --no-deps, warnings denied (host and firmware)",
        |ctx| {
            let mut args = vec!["doc", "--no-deps", "--workspace"];
            for package in TARGET_ONLY_PACKAGES {
                args.extend(["--exclude", package]);
            }
            run_command(ctx.cargo(&args).env("RUSTDOCFLAGS", "-D warnings"))?;
            run_command(
                ctx.cargo(&[
                    "doc",
                    "--no-deps",
                    "--package",
                    "firmware",
                    "--target",
                    TARGET,
                ])
                .env("RUSTDOCFLAGS", "-D warnings"),
            )
        },
    )
}

/// `docs/protocol.md` against the `link` crate: every type, field and variant of the
/// messages, the constants (the schema hash among them) and the example frame (see
/// `crate::protocol_page`).
pub fn protocol_page() -> Step {
    Step::new(
        "protocol page: docs/protocol.md against the link crate (types, constants, schema hash, example frame)",
        crate::protocol_page::check,
    )
}

/// The velocity mode's figures: `host-sim velocity-check` on the built-in `velocity-steps`
/// (a step in the command reaching the limited command, the ramp to zero 0.5 s after the
/// last command, the limits held), printed as one line; fails when they break the mode's
/// contract.
pub fn velocity_check() -> Step {
    Step::new(
        "velocity check: host-sim velocity-check (latency, timeout, limits of the velocity mode)",
        |ctx| {
            let host_sim = host_binary(ctx, "host-sim")?;
            run_command(Command::new(host_sim).arg("velocity-check"))
        },
    )
}

/// A run's MCAP files, host-sim's and the station's, read by PyPI's `mcap` (see
/// `crate::foxglove_check`).
pub fn foxglove_file() -> Step {
    Step::new(
        "foxglove file: host-sim and station MCAP files read by PyPI mcap, poses equal trace.csv",
        crate::foxglove_check::check_file,
    )
}

/// The live stream read by npm's Foxglove client (see `crate::foxglove_check`).
pub fn foxglove_live() -> Step {
    Step::new(
        "foxglove live: npm @foxglove/ws-protocol subscribed to host-sim serve --foxglove",
        crate::foxglove_check::check_live,
    )
}

/// The Python client written from `docs/protocol.md` against the virtual robot: the
/// handshake, `Info`, the configuration and telemetry decoded and checked (see
/// `crate::protocol_client`).
pub fn protocol_client() -> Step {
    Step::new(
        "protocol client: tools/protocol-client (Python, from docs/protocol.md) against host-sim serve",
        crate::protocol_client::check,
    )
}

/// `station ros2` against a Cyclone DDS peer from Python and the virtual robot (see
/// `crate::ros2_peer`).
pub fn ros2_peer() -> Step {
    Step::new(
        "ros2: station ros2 against a Cyclone DDS peer (Python) and host-sim serve",
        crate::ros2_peer::check,
    )
}

/// The lock-free channels of `robot-app` under Miri, with its own set-up (the nightly
/// toolchain with Miri, and Miri's standard library): see `crate::miri`.
pub fn miri() -> Step {
    Step::new("miri: the lock-free channels", miri::check)
}

/// The station against the virtual robot (`station/tests`): in this process in lockstep
/// (a run bit for bit equal to `host-sim run`, refusals while armed), and the `station`
/// binary over TCP against `host-sim serve`'s loop at 4× real time (the same result, a
/// killed station disarming the robot within the heartbeat timeout, a corrupted line),
/// and two cases of the bring-up matrix (about 10 s more). About 60 s of tests once
/// built. `cargo xtask e2e` runs them alone; CI runs them in its host-tests step.
pub fn end_to_end() -> Step {
    Step::new("end-to-end: station against the virtual robot", |ctx| {
        run_command(&mut ctx.cargo(&["test", "-p", "station", "--no-fail-fast"]))
    })
}

/// The guided bring-up against every single miswiring of the virtual robot and a few
/// pairs (`station/tests/bringup_matrix.rs`, its ignored tests): each detected and
/// corrected, then paper-circle settling within 5 % of the correctly wired robot. Prints
/// `bring-up matrix: N of N miswirings detected and corrected`; then the tune and the
/// calibration steps on a robot whose wheels and track are off, which print how far the
/// calibrated geometry is from the plant's. About five minutes; CI runs two of the
/// matrix's cases with the station's other tests.
pub fn bringup_matrix() -> Step {
    Step::new(
        "bring-up matrix: station bringup against every miswiring of the virtual robot",
        |ctx| {
            run_command(&mut ctx.cargo(&[
                "test",
                "-p",
                "station",
                "--test",
                "bringup_matrix",
                "--",
                "--ignored",
                "--nocapture",
                "--test-threads=1",
            ]))
        },
    )
}

/// The firmware package's targets clippy checks: the board layer, the application and
/// the first-flash programs.
const FIRMWARE_TARGETS: [&str; 3] = ["--lib", "--bins", "--examples"];

/// Clippy with `-D warnings` on `package` for the ARM target, with `features` (cargo
/// feature flags, possibly empty).
fn clippy_for_target(ctx: &Context, package: &str, features: &[&str]) -> Result<()> {
    let mut args = vec![
        "clippy",
        "--package",
        package,
        "--target",
        TARGET,
        "--release",
    ];
    args.extend_from_slice(features);
    args.extend(["--", "-D", "warnings"]);
    run_command(&mut ctx.cargo(&args))
}

/// Installs or checks the ARM target, flip-link and qemu-system-arm.
pub fn setup() -> Step {
    Step::new(
        "setup: thumbv7em target, flip-link, qemu-system-arm",
        setup::ensure_all,
    )
}

/// Builds the firmware and checks flash and static RAM against the budget.
pub fn firmware_size() -> Step {
    Step::new(
        "firmware: build (firmware profile) and size budget",
        elf_size::check_firmware,
    )
}

/// The first-flash programs: built for the F411, and `hello` run under QEMU (see
/// `crate::first_flash`).
pub fn first_flash() -> Step {
    Step::new(
        "first-flash programs: built for the F411, hello under QEMU",
        crate::first_flash::check,
    )
}

/// The control interrupt of the release firmware cannot reach a panic (and the check does
/// see the one the `panic-canary` build adds); the firmware's worst-case stack, bounded
/// from the same call graph, is within its limit.
pub fn panic_check() -> Step {
    Step::new(
        "firmware: no panic path from the control, steering and link-USART interrupts (firmware ELF, with a canary), and the stack's worst case",
        panic_check::check_firmware,
    )
}

/// The core on an emulated Cortex-M4F: digest against the host, step budget.
pub fn qemu() -> Step {
    Step::new(
        "qemu: core on an emulated Cortex-M4F (digest vs host, instructions reported)",
        qemu::check,
    )
}

/// The link crate on an emulated Cortex-M4F, driven over its USART from the host.
pub fn link_qemu() -> Step {
    Step::new(
        "link-qemu: the link on an emulated Cortex-M4F (USART1 over TCP, corrupted frames)",
        link_qemu::check,
    )
}

/// The firmware in the loop: `host-sim pil` on `paper-circle`, an encoder disconnect, a
/// link loss and a robot with a gyro (see `crate::pil`).
pub fn pil() -> Step {
    Step::new(
        "pil: the firmware on an emulated Cortex-M4F against host-sim's plant (paper-circle, longest-path, encoder disconnect by either heading, link loss, with a gyro, the velocity mode)",
        crate::pil::check,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failure_reason_keeps_its_context_and_at_most_its_first_lines() {
        let e = anyhow::anyhow!("no answer").context("`host-sim pil velocity-steps` failed");
        assert_eq!(
            failure_reason(&e),
            "`host-sim pil velocity-steps` failed: no answer"
        );
        let long = anyhow::anyhow!(
            "{}",
            (1..=9)
                .map(|i| format!("line {i}"))
                .collect::<Vec<_>>()
                .join("\n")
        );
        let reason = failure_reason(&long);
        assert!(reason.starts_with("line 1\n"), "{reason}");
        assert!(
            reason.contains("line 6") && !reason.contains("line 7"),
            "{reason}"
        );
        assert!(reason.ends_with('…'), "{reason}");
    }
}
