//! Processor in the loop: the firmware itself, built with its emulated `qemu` board, runs
//! under `qemu-system-arm` against `host-sim`'s plant in lockstep (`host-sim pil`), and
//! `host-sim`'s built-in station configures it, uploads the path and arms it over the link.
//!
//! Four runs:
//!
//! 1. `paper-circle`, then `longest-path` (the most segments a path may have, followed by
//!    projection: the control interrupt's worst case), each for its whole duration: each
//!    summary must equal `host-sim run`'s (every field but the wall-clock time and the
//!    source) and each trajectory digest the host's.
//! 2. `paper-circle` with the left encoder disconnected at 1 s, [`FAULT_RUN_S`] long
//!    (shortened from the scenario's 30 s: the fault is detected within 0.6 s): the
//!    motors must reach duty 0 within the fault suite's limit for that fault, and the
//!    summary and digest must equal host-sim's for the same fault.
//! 3. `paper-circle` with the link cut 1 s after arming, [`FAULT_RUN_S`] long: the motors
//!    must reach duty 0 within the heartbeat timeout (plus 20 ms for link bytes still in
//!    the emulator at the cut; `host_sim::pil::verdict`).
//!
//! The firmware's figures (the control interrupt's and the link service's longest run in
//! instructions, the stack's high-water mark), the worst of the four runs', are printed
//! and checked against [`CONTROL_INTERRUPT_LIMIT`] and [`STACK_LIMIT`].
//!
//! `host-sim pil` judges each run itself and exits non-zero on a failed line; this step
//! reprints the lines CI is read by and applies the limits.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, ensure, Context as _, Result};

use crate::steps::{build_target_executables, display_command, Context};

/// The target for the control interrupt on the Cortex-M4F, instructions.
pub const CONTROL_INTERRUPT_TARGET: u64 = 1500;
/// The limit this step enforces on every step, armed or not, instructions: the target
/// itself. The worst step measured 1 375–1 440 across the four runs. Installs, the rest
/// of arming and a finished run's report are done between steps in the link task
/// (`robot_app::lend`); a link request waits a
/// step rather than fall on the step that applies the steering outcome (the heaviest), a
/// telemetry sample waits on that step and on the hand-over, and `controller-core` and
/// `robot-app` are built at opt-level 3; see the firmware's README.
pub const CONTROL_INTERRUPT_LIMIT: u64 = CONTROL_INTERRUPT_TARGET;
/// The target for the stack's high-water mark, bytes.
pub const STACK_TARGET: u64 = 4096;
/// The limit this step enforces on the measured high-water mark, bytes: the target
/// itself. It measured 2 172–2 668 after start-up; `cargo xtask panic-check` bounds the
/// F411 build's stack from its call graph at 3 820, within the target too.
pub const STACK_LIMIT: u64 = STACK_TARGET;
/// Simulated seconds of the fault and link-loss runs.
pub const FAULT_RUN_S: &str = "2.5";

/// The paper's scenario: run 1, and the base of runs 2 and 3.
const SCENARIO: &str = "paper-circle";
/// The longest path the firmware accepts (`MAX_SEGMENTS` segments, followed by
/// projection): run 1 too, for the control interrupt's worst case.
const LONGEST_PATH: &str = "longest-path";

/// Builds the firmware for the emulated board and `host-sim`, then runs the three runs.
pub fn check(ctx: &Context) -> Result<()> {
    let firmware = build_target_executables(ctx, "firmware", &["--features", "qemu"])?
        .into_iter()
        .find(|p| p.file_name().is_some_and(|n| n == "firmware"))
        .context("cargo built no `firmware` executable")?;
    let host_sim = build_host_sim(ctx)?;
    let out = target_dir(ctx).join("pil");

    // 1. The paper's circle and the longest path the firmware accepts, each against
    //    host-sim; 2. an encoder disconnect on the circle, against host-sim too; 3. a link
    //    loss on the circle, which has no counterpart there. The figures are the worst
    //    of the four runs.
    let fault_scenario = out.join("paper-circle-encoder-disconnect.toml");
    write_fault_scenario(&host_sim, &fault_scenario)?;
    let fault_scenario = path_str(&fault_scenario)?;
    let runs = [
        PilRun {
            name: SCENARIO,
            args: vec![SCENARIO],
            host_sim_scenario: Some(SCENARIO),
            stop_line: None,
        },
        PilRun {
            name: LONGEST_PATH,
            args: vec![LONGEST_PATH],
            host_sim_scenario: Some(LONGEST_PATH),
            stop_line: None,
        },
        PilRun {
            name: "encoder-disconnect",
            args: vec![fault_scenario, "--duration-s", FAULT_RUN_S],
            host_sim_scenario: Some("paper-circle-encoder-disconnect"),
            stop_line: Some(": encoder-disconnect at "),
        },
        PilRun {
            name: "link-loss",
            args: vec![
                SCENARIO,
                "--duration-s",
                FAULT_RUN_S,
                "--link-loss-at-s",
                "1.0",
            ],
            // host-sim has no link to lose.
            host_sim_scenario: None,
            stop_line: Some(": link lost at "),
        },
    ];
    let mut failures = Vec::new();
    let mut worst = Figures::default();
    for run in runs {
        let output = pil(&host_sim, &firmware, &run.args, &out.join(run.name))?;
        if let Some(stop_line) = run.stop_line {
            print_lines(&output, stop_line, 1)?;
        }
        if let Some(scenario) = run.host_sim_scenario {
            failures.extend(compare_with_host(&output, scenario)?);
        }
        let figures = Figures::read(&output)?;
        println!(
            "  {}: control interrupt max {} instructions ({} in any state), steering task max \
             {}, stack {} bytes, link service max {} instructions",
            run.name,
            figures.control,
            figures.any_state,
            figures.steering,
            figures.stack,
            figures.link
        );
        worst = worst.max(figures);
    }
    let Figures {
        control,
        any_state,
        steering,
        link,
        stack,
        start,
    } = worst;
    println!("control interrupt on Cortex-M4F (PIL): max {control} instructions");
    println!(
        "  (in any state, the step that arms, the one that faults and the disarmed steps \
         that take an install included: {any_state})"
    );
    println!("steering task on Cortex-M4F (PIL): max {steering} instructions");
    println!("stack high-water mark (PIL): {stack} bytes");
    println!("link service on Cortex-M4F (PIL): max {link} instructions");
    println!("  (start-up used {start} bytes of stack before the tasks ran)");
    println!(
        "  against the issue's targets: control interrupt {control} of {CONTROL_INTERRUPT_TARGET} \
         instructions ({}), stack {stack} of {STACK_TARGET} bytes ({}); enforced limits \
         {CONTROL_INTERRUPT_LIMIT} and {STACK_LIMIT}",
        verdict(control.max(any_state), CONTROL_INTERRUPT_TARGET),
        verdict(stack, STACK_TARGET),
    );
    if control.max(any_state) > CONTROL_INTERRUPT_LIMIT {
        failures.push(format!(
            "control interrupt {control} instructions armed, {any_state} in any state > \
             {CONTROL_INTERRUPT_LIMIT}"
        ));
    }
    if stack > STACK_LIMIT {
        failures.push(format!("stack {stack} bytes > {STACK_LIMIT}"));
    }

    ensure!(failures.is_empty(), "{}", failures.join("; "));
    Ok(())
}

/// One `host-sim pil` run of the step.
struct PilRun<'a> {
    /// Its name, and its output directory's.
    name: &'a str,
    /// `host-sim pil`'s arguments.
    args: Vec<&'a str>,
    /// The scenario name under which it prints its comparison with host-sim, if it
    /// compares (the firmware must then match host-sim).
    host_sim_scenario: Option<&'a str>,
    /// The start of the line that says how the motors stopped, if it stops them.
    stop_line: Option<&'a str>,
}

/// The summary and digest lines of a whole-scenario run, printed; the ones that say the
/// firmware differs from host-sim, as failures.
fn compare_with_host(output: &str, scenario: &str) -> Result<Vec<String>> {
    let mut failures = Vec::new();
    let summary_line = format!("PIL {scenario}: summary ");
    match output.lines().find(|l| l.starts_with(&summary_line)) {
        Some(line) if line.ends_with("identical to host-sim") => println!("{line}"),
        Some(line) => {
            // "… by at most X m (fields)": the line CI reads, then the fields.
            let (head, fields) = line.split_once(" (").unwrap_or((line, ""));
            println!("{head}");
            println!("  differing fields: ({fields}");
            failures.push(head.to_string());
        }
        None => bail!("`host-sim pil {scenario}` printed no summary comparison"),
    }
    let digest_line = format!("PIL {scenario}: trajectory digest");
    match output.lines().find(|l| l.starts_with(&digest_line)) {
        Some(line) => {
            println!("{line}");
            if !line.contains("identical") {
                failures.push(line.to_string());
            }
        }
        None => bail!("`host-sim pil {scenario}` printed no digest comparison"),
    }
    Ok(failures)
}

/// The firmware's own figures from one run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Figures {
    /// The control interrupt's longest armed step, instructions.
    control: u64,
    /// The control interrupt's longest step in any state, instructions.
    any_state: u64,
    /// The steering task's longest run, instructions.
    steering: u64,
    /// The link service's longest run, instructions.
    link: u64,
    /// The stack's high-water mark after start-up, bytes.
    stack: u64,
    /// Stack start-up used, bytes.
    start: u64,
}

impl Figures {
    fn read(output: &str) -> Result<Self> {
        Ok(Self {
            control: figure(output, "control interrupt on Cortex-M4F (PIL): max ")?,
            any_state: figure(
                output,
                "control interrupt on Cortex-M4F (PIL), any state: max ",
            )?,
            steering: figure(output, "steering task on Cortex-M4F (PIL): max ")?,
            link: figure(output, "link service on Cortex-M4F (PIL): max ")?,
            stack: figure(output, "stack high-water mark (PIL): ")?,
            start: figure(
                output,
                "stack used by start-up (PIL, before the tasks run): ",
            )?,
        })
    }

    /// Each figure the larger of the two.
    fn max(self, other: Self) -> Self {
        Self {
            control: self.control.max(other.control),
            any_state: self.any_state.max(other.any_state),
            steering: self.steering.max(other.steering),
            link: self.link.max(other.link),
            stack: self.stack.max(other.stack),
            start: self.start.max(other.start),
        }
    }
}

/// `within` or `NOT met`.
fn verdict(value: u64, target: u64) -> &'static str {
    if value <= target {
        "within"
    } else {
        "NOT met"
    }
}

/// Builds `host-sim` (the dev profile the tests share); its executable.
fn build_host_sim(ctx: &Context) -> Result<PathBuf> {
    let mut cmd = ctx.cargo(&["build", "--package", "host-sim", "--bin", "host-sim"]);
    println!("$ {}", display_command(&cmd));
    let status = cmd.status().context("could not start cargo")?;
    ensure!(status.success(), "building host-sim failed ({status})");
    let exe = target_dir(ctx).join("debug").join("host-sim");
    ensure!(exe.is_file(), "no host-sim at {}", exe.display());
    Ok(exe)
}

/// The workspace's target directory (`CARGO_TARGET_DIR` if set).
fn target_dir(ctx: &Context) -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| ctx.root.join("target"), PathBuf::from)
}

fn path_str(path: &Path) -> Result<&str> {
    path.to_str()
        .with_context(|| format!("{} is not UTF-8", path.display()))
}

/// Runs `host-sim pil ARGS --firmware FIRMWARE --out OUT`; its output (echoed). Fails
/// when it fails (a failed verdict line, or the run itself).
fn pil(host_sim: &Path, firmware: &Path, args: &[&str], out: &Path) -> Result<String> {
    let mut cmd = Command::new(host_sim);
    cmd.arg("pil")
        .args(args)
        .arg("--firmware")
        .arg(firmware)
        .arg("--out")
        .arg(out);
    let shown = display_command(&cmd);
    println!("$ {shown}");
    let output = cmd
        .output()
        .with_context(|| format!("could not start `{shown}`"))?;
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    for line in stdout.lines() {
        println!("  | {line}");
    }
    if !output.status.success() {
        eprint!("{}", String::from_utf8_lossy(&output.stderr));
        bail!("`{shown}` failed ({})", output.status);
    }
    Ok(stdout)
}

/// The number after `prefix` on the line that starts with it.
fn figure(output: &str, prefix: &str) -> Result<u64> {
    let line = output
        .lines()
        .find_map(|l| l.strip_prefix(prefix))
        .with_context(|| format!("no line `{prefix}N …` in host-sim's output"))?;
    let number: String = line.chars().take_while(char::is_ascii_digit).collect();
    number
        .parse()
        .with_context(|| format!("`{prefix}{line}`: no number"))
}

/// Prints the lines of `output` that contain `pattern`; at least `expected` of them.
fn print_lines(output: &str, pattern: &str, expected: usize) -> Result<()> {
    let lines: Vec<&str> = output.lines().filter(|l| l.contains(pattern)).collect();
    ensure!(
        lines.len() >= expected,
        "host-sim printed no line with `{pattern}`"
    );
    for line in lines {
        println!("{line}");
    }
    Ok(())
}

/// `paper-circle` with the left encoder disconnected 1 s after the start, as a scenario
/// file at `path`.
fn write_fault_scenario(host_sim: &Path, path: &Path) -> Result<()> {
    let output = Command::new(host_sim)
        .args(["show", SCENARIO])
        .output()
        .context("running `host-sim show`")?;
    ensure!(output.status.success(), "`host-sim show {SCENARIO}` failed");
    let text = String::from_utf8(output.stdout).context("host-sim show: not UTF-8")?;
    let mut renamed = String::new();
    let mut done = false;
    for line in text.lines() {
        if !done && line.starts_with("name = ") {
            renamed.push_str("name = \"paper-circle-encoder-disconnect\"");
            done = true;
        } else {
            renamed.push_str(line);
        }
        renamed.push('\n');
    }
    ensure!(
        done,
        "`host-sim show {SCENARIO}` printed no `name = …` line"
    );
    renamed.push_str("\n[[faults]]\nat_s = 1.0\nkind = \"encoder-disconnect\"\nwheel = \"left\"\n");
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(path, renamed).with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_worst_of_two_runs_takes_each_figure_from_either() {
        let a = Figures {
            control: 2000,
            any_state: 7000,
            steering: 500,
            link: 90,
            stack: 8000,
            start: 16000,
        };
        let b = Figures {
            control: 3000,
            any_state: 6000,
            steering: 10000,
            link: 80,
            stack: 9000,
            start: 15000,
        };
        let worst = Figures {
            control: 3000,
            any_state: 7000,
            steering: 10000,
            link: 90,
            stack: 9000,
            start: 16000,
        };
        assert_eq!(a.max(b), worst);
        assert_eq!(b.max(a), worst);
    }

    #[test]
    fn a_differing_summary_or_digest_is_a_failure() {
        let same = "PIL s: summary identical to host-sim\nPIL s: trajectory digest identical to host-sim (…)\n";
        assert!(compare_with_host(same, "s").unwrap().is_empty());
        let differs = "PIL s: summary differs from host-sim by at most 0.001 m (rms)\nPIL s: trajectory digest differs\n";
        assert_eq!(
            compare_with_host(differs, "s").unwrap(),
            [
                "PIL s: summary differs from host-sim by at most 0.001 m",
                "PIL s: trajectory digest differs"
            ]
        );
        assert!(compare_with_host("PIL s: trajectory digest identical", "s").is_err());
    }

    #[test]
    fn figures_are_read_from_their_line() {
        let output = "x\ncontrol interrupt on Cortex-M4F (PIL): max 2286 instructions\n\
                      control interrupt on Cortex-M4F (PIL), any state: max 7001 instructions\n\
                      stack high-water mark (PIL): 11888 bytes\n";
        assert_eq!(
            figure(output, "control interrupt on Cortex-M4F (PIL): max ").unwrap(),
            2286
        );
        assert_eq!(
            figure(
                output,
                "control interrupt on Cortex-M4F (PIL), any state: max "
            )
            .unwrap(),
            7001
        );
        assert_eq!(
            figure(output, "stack high-water mark (PIL): ").unwrap(),
            11888
        );
        assert!(figure(output, "link service on Cortex-M4F (PIL): max ").is_err());
        assert_eq!(verdict(1500, 1500), "within");
        assert_eq!(verdict(1501, 1500), "NOT met");
    }
}
