//! Project automation, run as `cargo xtask <command>` (an alias in `.cargo/config.toml`).
//!
//! | command | what it does |
//! |---|---|
//! | `ci` | every check, in order: set-up, fmt, clippy (host, firmware, QEMU programs), host tests (the station end to end among them), Miri on the lock-free channels, firmware build and size budget, the first-flash programs (hello under QEMU), the panic check, the core and the link on an emulated Cortex-M4F, the firmware in the loop (`pil`), the docs, the protocol page and its client, the velocity mode's figures, the Foxglove file and live stream, the ROS 2 bridge against a Cyclone DDS peer, the figures. Ends with `N passed, N failed`. `.ci/run` runs exactly this. |
//! | `e2e` | the station against the virtual robot: in process, and the binary over TCP (same result as `host-sim run`, link loss, corruption, refusals), and two guided bring-ups of miswired robots |
//! | `bringup-matrix` | `station bringup` against the virtual robot miswired every single way and a few pairs: each detected and corrected, then paper-circle settling within 5 % of the correctly wired robot; prints `bring-up matrix: N of N miswirings detected and corrected`; then the tune and calibration steps on a robot whose wheels and track are off (about five minutes; `e2e` runs two matrix cases) |
//! | `setup` | installs what is missing: the ARM target, `flip-link`, `qemu-system-arm` (the `miri` step sets up its own toolchain) |
//! | `miri` | `robot-app`'s lock-free channels (`robot_app::channel`, its only `unsafe` code) under Miri: the channel modules' unit tests (including every interleaving of the mailbox's handshake and of the ring) and the integration tests that take the channels through the robot cheaply; each must run and pass. Sets itself up: installs the nightly toolchain with its `miri` and `rust-src` components when missing (rustup), then `cargo +nightly miri setup`; without a network, fails naming what is missing. Prints its times; under two minutes from a fresh clone on 2 cores |
//! | `size` | builds the firmware and checks it against the flash and RAM budget |
//! | `first-flash` | builds the first-flash programs (`firmware/examples/`: hello, encoders, motors, supply) for the F411 and prints their sizes; runs `hello` on the emulated board under QEMU and prints its report, `hello under QEMU: reset cause …, clock …` |
//! | `qemu` | runs the core under QEMU, compares its digest with the host's, checks the step budget |
//! | `link-qemu` | runs the link crate under QEMU and talks to it over its USART: replies, corrupted frames, counters |
//! | `docs` | `cargo doc --no-deps` with warnings denied, for the host crates and the firmware |
//! | `figures` | regenerates `docs/figures.md`, the README's headline rows and the fault matrix in `docs/safety.md` from what the simulator writes (`ci` fails when one is stale) |
//! | `protocol-page` | checks `docs/protocol.md` against the `link` crate: every type, field and variant of the messages in wire order, the constants (the schema hash among them) and the example frame; names each difference with the row or section to write |
//! | `protocol-client` | runs the Python client written from `docs/protocol.md` (`tools/protocol-client/`) against `host-sim serve` on an ephemeral port: handshake, `Info`, the configuration and telemetry decoded and checked; needs `python3` (installed with apt-get as root, otherwise named) |
//! | `velocity-check` | `host-sim velocity-check` on `velocity-steps`: how soon a step in the command moves the limited command, when the ramp to zero starts after the last command, the largest velocity, acceleration and jerk against the limits; one line, fails when the mode's contract is broken |
//! | `foxglove-file` | `host-sim run --mcap` and `station run --mcap` (against the virtual robot) read by PyPI's `mcap` and `mcap-protobuf-support` in a venv: every channel and schema, the poses equal to `trace.csv` within 1e-6 m and rad, the 30 s run at 100 Hz at most 10 MB; prints `mcap: N channels, M messages, poses equal trace.csv` |
//! | `foxglove-live` | npm's `@foxglove/ws-protocol` 0.8 on a `ws` socket (subprotocol `foxglove.sdk.v1`) subscribed to `host-sim serve --foxglove` while a station runs paper-circle: every channel, the rates, the arrival delays, the parameter set (changed while disarmed, read-only while armed); prints `foxglove live: N channels, M messages in S s` |
//! | `ros2 [--stamped]` | `station ros2 --arm` against a Cyclone DDS peer from Python (`tools/ros2-peer/`, in a virtual environment under `target/venvs/` made on first use with PyPI's `cyclonedds`) and the virtual robot: `cmd_vel` at 20 Hz drives it, it stops after the last command within its timeout, an L-shaped `nav_msgs/Path` is followed and settles like the same path uploaded by `station run`; `--stamped` sends `cmd_vel` as `TwistStamped` to a bridge with `use_stamped_vel` |
//! | `pil` | processor in the loop: the firmware (emulated `qemu` board) under QEMU against host-sim's plant, driven over its link: `paper-circle` and `longest-path` identical to `host-sim run`, the control interrupt's instructions and the stack, an encoder disconnect and a link loss stopping the motors in time |
//! | `size-of ELF` | flash and static RAM of any ARM ELF, against the firmware budget (no build) |
//! | `panic-check` | builds the firmware (and its `panic-canary` variant, which must fail) and proves from the release ELF that the control interrupt, the steering task and the link USART's interrupt reach no panic and no indirect call; then bounds the firmware's worst-case stack from the same call graph |
//! | `panic-check ELF [--root NAME:IRQ]…` | the same proof on a given ELF (no build), from the given interrupts (default `TIM5:50`, `EXTI3:9`, `USART2:38`) |
//! | `long` | the checks too long for CI: a 1 000-run sweep, the tune's spread matrix, mutation testing and 10 minutes of each fuzz target (`long.rs`) |
//! | `fuzz [SECONDS]` | every fuzz target of `fuzz/` (cargo-fuzz on nightly: the link's frames and messages, the parameter record, scenarios, robot files) for SECONDS each (default 60), one at a time, then a table of executions, coverage and corpus per target; fails on a crash, a broken property or a hang. Installs nightly and cargo-fuzz when missing (`fuzz.rs`). CI replays the committed corpus instead (`fuzz-checks`' tests) |
//! | `mutants [ARGS…]` | mutation testing of `controller-core` (and `link`) with cargo-mutants: score, missed list, wall time. Slow; not part of `ci` |
//!
//! Every step runs even if an earlier one failed, so one CI log shows every problem.

#[cfg(test)]
mod build_figures;
mod elf_size;
mod figures;
#[cfg(test)]
mod firmware_logger;
mod first_flash;
mod foxglove_check;
mod fuzz;
mod link_qemu;
mod long;
mod miri;
mod mutants;
mod panic_check;
mod pil;
mod protocol_client;
mod protocol_page;
mod python_venv;
mod qemu;
mod ros2_peer;
mod setup;
mod steps;
mod task_priorities;

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context as _, Result};

use crate::steps::{Context, Step};

const USAGE: &str = "usage: cargo xtask <command>

commands:
  ci      run every check (what CI runs): setup, fmt, clippy, tests, Miri, firmware
          size, panic check, QEMU
  setup   install what is missing: ARM target, flip-link, qemu-system-arm
  bringup-matrix
          station bringup against the virtual robot miswired every single way and a few
          pairs: detected, corrected, paper-circle settling as the correctly wired robot;
          then the tune and calibration steps on a robot whose geometry is off
  miri    robot-app's lock-free channels under Miri (their unit tests, every interleaving
          of the mailbox and the ring, cheap integration tests); installs the nightly
          toolchain with miri when missing and runs `cargo +nightly miri setup`
  size    build the firmware and check its flash / static RAM budget
  first-flash
          build the first-flash programs (hello, encoders, motors, supply) for the F411;
          run hello on the emulated board under QEMU and print its report
  qemu    run the core on an emulated Cortex-M4F and compare with the host
  link-qemu
          run the link on an emulated Cortex-M4F and talk to it over its USART
  docs    cargo doc --no-deps with warnings denied (host crates, firmware)
  figures regenerate docs/figures.md, the README's headline rows and the fault
          matrix in docs/safety.md from the simulator (CI fails when stale)
  protocol-page
          check docs/protocol.md against the link crate (types, constants, schema
          hash, example frame); names each difference
  protocol-client
          the Python client written from docs/protocol.md against host-sim serve
  velocity-check
          the velocity mode's figures on host-sim's velocity-steps: latency of a step,
          the ramp after the command timeout, the limits held (one line)
  foxglove-file
          host-sim's and the station's MCAP files read by PyPI's mcap: every channel,
          the poses equal trace.csv, the 30 s run within 10 MB
  foxglove-live
          npm's Foxglove client subscribed to host-sim serve --foxglove during a run:
          every channel, the rates and delays, the parameter set
  ros2 [--stamped]
          station ros2 against a Cyclone DDS peer (Python, venv under target/) and
          host-sim serve: cmd_vel drives, the stop after the last command, a path followed
          (--stamped: cmd_vel as TwistStamped, use_stamped_vel set)
  pil     the firmware on an emulated Cortex-M4F against host-sim's plant (processor in
          the loop): paper-circle vs host-sim, instructions, stack, a fault, a link loss
  size-of ELF
          flash and static RAM of an ARM ELF against the firmware budget (no build)
  panic-check
          build the firmware and prove that its control (TIM5), steering (EXTI3) and link
          USART (USART2) interrupts cannot reach a panic or an indirect call; the
          `panic-canary` build must fail the same check
  panic-check ELF [--root NAME:IRQ]...
          the same proof on an ELF (no build), from the given interrupts (default TIM5:50,
          EXTI3:9, USART2:38)
  long    the checks too long for CI: a 1 000-run sweep of paper-circle, the tune's
          spread matrix (host-sim tune --sweep), mutation testing (cargo xtask
          mutants) and every fuzz target for 10 minutes
  fuzz [SECONDS]
          run every fuzz target of fuzz/ (cargo-fuzz, libFuzzer) for SECONDS each
          (default 60), one at a time, and print executions, coverage and corpus per
          target; fails on a crash, a broken property or a hang. Installs the nightly
          toolchain and cargo-fuzz when missing. Run it under `nice` on a shared machine
  mutants [ARGS...]
          mutation testing of controller-core (and link, when the workspace has it) with
          cargo-mutants: prints the score, the missed mutants and the wall time; ARGS go to
          cargo-mutants, e.g. `-f controller-core/src/pid.rs` for one file or `-j 2`.
          Slow (a build and a test run per mutant); not part of `ci`. Needs
          `cargo install cargo-mutants --locked`";

fn main() -> ExitCode {
    match run() {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Runs the command named on the command line; `Ok(false)` when a step failed.
fn run() -> Result<bool> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let ctx = Context::new(workspace_root()?);
    if args.first().map(String::as_str) == Some("mutants") {
        return mutants::run(&ctx, &args[1..]);
    }
    if args == ["long"] {
        return long::run(&ctx);
    }
    let selected: Vec<Step> = match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        ["ci"] => steps::ci(),
        ["setup"] => vec![steps::setup()],
        ["size"] => vec![steps::setup(), steps::firmware_size()],
        ["first-flash"] => vec![steps::setup(), steps::first_flash()],
        ["qemu"] => vec![steps::setup(), steps::qemu()],
        ["e2e"] => vec![steps::end_to_end()],
        ["bringup-matrix"] => vec![steps::bringup_matrix()],
        ["miri"] => vec![steps::miri()],
        ["fuzz"] => vec![fuzz_step(fuzz::DEFAULT_SECONDS)],
        ["fuzz", seconds] => {
            let seconds = seconds
                .parse()
                .ok()
                .filter(|&s: &u32| s > 0)
                .with_context(|| {
                    format!("fuzz: SECONDS must be a whole number > 0, got `{seconds}`\n\n{USAGE}")
                })?;
            vec![fuzz_step(seconds)]
        }
        ["link-qemu"] => vec![steps::setup(), steps::link_qemu()],
        ["pil"] => vec![steps::setup(), steps::pil()],
        ["docs"] => vec![steps::setup(), steps::docs()],
        ["figures"] => vec![Step::new(
            "figures: regenerate docs/figures.md, the README's headline rows and docs/safety.md's fault matrix",
            |ctx| figures::run(ctx, false),
        )],
        ["protocol-page"] => vec![steps::protocol_page()],
        ["protocol-client"] => vec![steps::protocol_client()],
        ["velocity-check"] => vec![steps::velocity_check()],
        ["foxglove-file"] => vec![steps::foxglove_file()],
        ["foxglove-live"] => vec![steps::foxglove_live()],
        ["ros2"] => vec![steps::ros2_peer()],
        ["ros2", "--stamped"] => vec![Step::new("ros2: cmd_vel as TwistStamped", |ctx| {
            ros2_peer::check_with(ctx, ros2_peer::CmdVel::TwistStamped)
        })],
        ["figures", "--check"] => vec![Step::new(
            "figures: docs/figures.md, the README's headline rows and docs/safety.md's fault matrix up to date",
            |ctx| figures::run(ctx, true),
        )],
        ["size-of", elf] => {
            let elf = PathBuf::from(elf);
            vec![Step::new("size of an ELF", move |_| {
                elf_size::check_budget("ELF", &elf, elf_size::FLASH_BUDGET, elf_size::RAM_BUDGET)
                    .map(drop)
            })]
        }
        ["panic-check"] => vec![steps::setup(), steps::panic_check()],
        ["panic-check", ref rest @ ..] => {
            let (elf, roots) = panic_check_arguments(rest)?;
            vec![Step::new("panic check of an ELF", move |ctx| {
                panic_check::check_elf(&elf, &roots, &ctx.root)
            })]
        }
        ["help" | "-h" | "--help"] => {
            println!("{USAGE}");
            return Ok(true);
        }
        _ => bail!("unknown command {args:?}\n\n{USAGE}"),
    };
    let budget_s = (args == ["ci"]).then_some(steps::CI_BUDGET_S);
    Ok(steps::run_all(&ctx, &selected, budget_s))
}

/// Every fuzz target for `seconds` each.
fn fuzz_step(seconds: u32) -> Step {
    Step::new("fuzz: every target of fuzz/", move |ctx| {
        fuzz::run(ctx, seconds)
    })
}

/// `ELF [--root NAME:IRQ]...` of `panic-check`: the ELF and the roots (default: the
/// control interrupt).
fn panic_check_arguments(args: &[&str]) -> Result<(PathBuf, Vec<panic_check::Root>)> {
    let mut elf = None;
    let mut roots = Vec::new();
    let mut args = args.iter();
    while let Some(&arg) = args.next() {
        if arg == "--root" {
            let spec = args.next().context("--root needs NAME:IRQ")?;
            roots.push(panic_check::Root::parse(spec)?);
        } else if elf.is_none() && !arg.starts_with('-') {
            elf = Some(PathBuf::from(arg));
        } else {
            bail!("panic-check: unexpected argument `{arg}`\n\n{USAGE}");
        }
    }
    if roots.is_empty() {
        roots = panic_check::default_roots();
    }
    Ok((elf.context("panic-check: no ELF given")?, roots))
}

/// The workspace root: the parent of this crate's manifest directory.
fn workspace_root() -> Result<PathBuf> {
    let manifest_dir = std::env::var_os("CARGO_MANIFEST_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")));
    let root = manifest_dir
        .parent()
        .context("xtask's manifest directory has no parent")?
        .to_path_buf();
    if !root.join("Cargo.toml").is_file() {
        bail!(
            "no Cargo.toml in {} (expected the workspace root)",
            root.display()
        );
    }
    Ok(root)
}
