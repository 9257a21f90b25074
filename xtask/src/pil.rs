//! Processor in the loop: the firmware itself, built with its emulated `qemu` board, runs
//! under `qemu-system-arm` against `host-sim`'s plant in lockstep (`host-sim pil`), and
//! `host-sim`'s built-in station configures it, uploads the path and arms it over the link.
//!
//! Seven runs:
//!
//! 1. `paper-circle`, then `longest-path` (the most segments a path may have, followed by
//!    projection: the control interrupt's worst case), each for its whole duration: each
//!    summary must equal `host-sim run`'s (every field but the wall-clock time and the
//!    source) and each trajectory digest the host's.
//! 2. `paper-circle` with the left encoder disconnected at 1 s, [`FAULT_RUN_S`] long
//!    (shortened from the scenario's 30 s: the fault is detected within 0.6 s): the
//!    motors must reach duty 0 within the fault suite's limit for that fault, and the
//!    summary and digest must equal host-sim's for the same fault; then the same on the
//!    gyro run's robot steering by the fused heading (its disagreement a warning, as by
//!    default: the stall check must see the silent wheel).
//! 3. `paper-circle` with the link cut 1 s after arming, [`FAULT_RUN_S`] long: the motors
//!    must reach duty 0 within the heartbeat timeout (`host_sim::pil::verdict`).
//! 4. `paper-circle` on a robot with a gyro ([`GYRO_SCENARIO`], [`GYRO_RUN_S`] long):
//!    the gyro's readings reach the firmware in the plant's step messages and go through
//!    its heading fusion (bias, fused heading, the gyro's checks), and summary and digest
//!    must equal host-sim's. It steers by the fused heading, which the station's
//!    configuration (`SetParams`) selects.
//!
//! 5. [`VELOCITY_SCENARIO`], the velocity mode driven by a timeline of (v, ω) steps and
//!    then the command timeout: the built-in station sends each command at its control
//!    step (`host_sim::pil::station`), so summary and digest must equal host-sim's, and
//!    the armed figures include the velocity mode's control steps.
//!
//! The firmware's figures, read from each run's `pil.json` (every task's runs, longest
//! run and total in instructions; the stack's high-water mark), the worst of the seven
//! runs', are printed as the CPU-load line and table and checked against the CPU-load
//! budget ([`ANY_STATE_LIMIT`], [`ARMED_MEAN_LIMIT`], [`ARMED_WORST_LIMIT`]) and
//! [`STACK_LIMIT`].
//!
//! `host-sim pil` judges each run itself and exits non-zero on a failed line; this step
//! reprints the lines CI is read by and applies the limits.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, ensure, Context as _, Result};

use crate::steps::{build_target_executables, display_command, Context};

/// The control interrupt's worst step in any state (disarmed, installing, arming,
/// arming in motion, faulting, armed), instructions: 6–7.5 % of the 1 ms period at
/// 100 MHz and 1.2–1.5 cycles per instruction.
pub const ANY_STATE_LIMIT: u64 = 5000;
/// The control interrupt's mean step in the armed steady state, instructions: 2–3 % of
/// the 1 ms period at 100 MHz and 1.2–1.5 cycles per instruction, room for the gyro's
/// fusion and the velocity mode beside path following.
pub const ARMED_MEAN_LIMIT: u64 = 2000;
/// The control interrupt's worst step in the armed steady state, instructions.
pub const ARMED_WORST_LIMIT: u64 = 2500;
/// The stack's measured high-water mark, bytes (`cargo xtask panic-check` bounds it
/// from the call graph against its own limit).
pub const STACK_LIMIT: u64 = 4096;
/// CPU cycles in one control period: the F411 at 100 MHz, a 1 ms period.
const CYCLES_PER_PERIOD: f64 = 100_000.0;
/// Cycles per instruction the load is computed with: the top of the 1.2–1.5 a
/// Cortex-M4F runs this code at from flash with its wait states (QEMU counts
/// instructions, not cycles).
const CYCLES_PER_INSTRUCTION: f64 = 1.5;
/// Simulated seconds of the fault and link-loss runs.
pub const FAULT_RUN_S: &str = "2.5";
/// Simulated seconds of the run with a gyro: a third of the circle, at a third of its
/// cost in CI's time.
pub const GYRO_RUN_S: &str = "10";

/// `paper-circle` on a robot with a gyro ([`write_gyro_scenario`]): run 4.
const GYRO_SCENARIO: &str = "paper-circle-with-gyro";
/// `paper-circle` with an encoder disconnected ([`write_fault_scenario`]): run 2.
const FAULT_SCENARIO: &str = "paper-circle-encoder-disconnect";
/// The same on the gyro run's robot, steering by the fused heading: run 2 too.
const FUSED_FAULT_SCENARIO: &str = "paper-circle-encoder-disconnect-fused";

/// The paper's scenario: run 1, and the base of runs 2 and 3.
const SCENARIO: &str = "paper-circle";
/// The longest path the firmware accepts (`MAX_SEGMENTS` segments, followed by
/// projection): run 1 too, for the control interrupt's worst case.
const LONGEST_PATH: &str = "longest-path";

/// The velocity mode's built-in scenario: run 5.
const VELOCITY_SCENARIO: &str = "velocity-steps";

/// Builds the firmware for the emulated board and `host-sim`, then runs the seven runs.
pub fn check(ctx: &Context) -> Result<()> {
    let firmware = build_target_executables(ctx, "firmware", &["--features", "qemu"])?
        .into_iter()
        .find(|p| p.file_name().is_some_and(|n| n == "firmware"))
        .context("cargo built no `firmware` executable")?;
    let host_sim = crate::steps::host_binary(ctx, "host-sim")?;
    let out = target_dir(ctx).join("pil");

    // 1. The paper's circle and the longest path the firmware accepts, each against
    //    host-sim; 2. an encoder disconnect on the circle, by odometry's heading and by the
    //    fused one, against host-sim too; 3. a link
    //    loss on the circle, which has no counterpart there; 4. the circle with a gyro,
    //    against host-sim; 5. the velocity mode, against host-sim. The figures are the
    //    worst of the seven runs.
    let fault_scenario = out.join(format!("{FAULT_SCENARIO}.toml"));
    write_fault_scenario(&host_sim, &fault_scenario, false)?;
    let fault_scenario = path_str(&fault_scenario)?;
    let fused_fault_scenario = out.join(format!("{FUSED_FAULT_SCENARIO}.toml"));
    write_fault_scenario(&host_sim, &fused_fault_scenario, true)?;
    let fused_fault_scenario = path_str(&fused_fault_scenario)?;
    let gyro_scenario = out.join(format!("{GYRO_SCENARIO}.toml"));
    write_gyro_scenario(&host_sim, &gyro_scenario)?;
    let gyro_scenario = path_str(&gyro_scenario)?;
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
            host_sim_scenario: Some(FAULT_SCENARIO),
            stop_line: Some(": encoder-disconnect at "),
        },
        PilRun {
            name: "encoder-disconnect-fused",
            args: vec![fused_fault_scenario, "--duration-s", FAULT_RUN_S],
            host_sim_scenario: Some(FUSED_FAULT_SCENARIO),
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
        PilRun {
            name: "gyro",
            args: vec![gyro_scenario, "--duration-s", GYRO_RUN_S],
            host_sim_scenario: Some(GYRO_SCENARIO),
            stop_line: None,
        },
        PilRun {
            name: "velocity",
            args: vec![VELOCITY_SCENARIO],
            host_sim_scenario: Some(VELOCITY_SCENARIO),
            stop_line: None,
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
        let figures = Figures::read(&out.join(run.name).join("pil.json"))?;
        println!(
            "  {}: control interrupt max {} instructions in any state, armed mean {:.0} max \
             {}, arming {}; steering task max {}; link service max {}; stack {} bytes",
            run.name,
            figures.control.max,
            figures.armed.mean(),
            figures.armed.max,
            figures.arming.max,
            figures.steering.max,
            figures.link.max,
            figures.stack
        );
        worst = worst.max(&figures);
    }
    print!("{}", load_report(&worst));
    failures.extend(budget_failures(&worst));

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

/// One task's runs in one run, or the worst of several runs ([`Figures::max`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Task {
    /// Runs of the task.
    runs: u64,
    /// The longest run, instructions.
    max: u64,
    /// All runs together, instructions.
    total: u64,
    /// The worst mean run seen, instructions (for one run: `total / runs`).
    worst_mean: f64,
    /// The worst mean per control period seen, instructions.
    worst_per_period: f64,
}

impl Task {
    /// The task in `json` (its `runs`, `max_instructions`, `total_instructions`), over
    /// `periods` control periods.
    fn read(json: &serde_json::Value, name: &str, periods: u64) -> Result<Self> {
        let field = |key: &str| {
            json[name][key]
                .as_u64()
                .with_context(|| format!("pil.json: no `{name}.{key}`"))
        };
        let (runs, max, total) = (
            field("runs")?,
            field("max_instructions")?,
            field("total_instructions")?,
        );
        Ok(Self {
            runs,
            max,
            total,
            worst_mean: ratio(total, runs),
            worst_per_period: ratio(total, periods),
        })
    }

    /// The mean run, instructions (the worst of the runs compared).
    fn mean(&self) -> f64 {
        self.worst_mean
    }

    fn max(self, other: Self) -> Self {
        Self {
            runs: self.runs + other.runs,
            max: self.max.max(other.max),
            total: self.total + other.total,
            worst_mean: self.worst_mean.max(other.worst_mean),
            worst_per_period: self.worst_per_period.max(other.worst_per_period),
        }
    }
}

/// `a / b`, 0 when `b` is 0.
fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}

/// The firmware's own figures from one run (or the worst of several).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Figures {
    /// The control interrupt, every step.
    control: Task,
    /// The control interrupt in the armed steady state (armed, no event).
    armed: Task,
    /// The control interrupt in the steps that arm.
    arming: Task,
    /// The steering task.
    steering: Task,
    /// The link service.
    link: Task,
    /// The link USART's interrupt.
    link_uart: Task,
    /// The stack's high-water mark after start-up, bytes.
    stack: u64,
    /// The worst total load of one run, instructions per control period.
    worst_load_per_period: f64,
}

impl Figures {
    /// The figures `host-sim pil` wrote to `pil.json`.
    fn read(path: &Path) -> Result<Self> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let json: serde_json::Value =
            serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        Self::from_json(&json)
    }

    fn from_json(json: &serde_json::Value) -> Result<Self> {
        let periods = json["control_interrupt"]["runs"]
            .as_u64()
            .context("pil.json: no `control_interrupt.runs`")?;
        let task = |name| Task::read(json, name, periods);
        let (control, steering, link, link_uart) = (
            task("control_interrupt")?,
            task("steering_task")?,
            task("link_service")?,
            task("link_usart_interrupt")?,
        );
        Ok(Self {
            control,
            armed: task("control_interrupt_armed")?,
            arming: task("control_interrupt_arming")?,
            steering,
            link,
            link_uart,
            stack: json["stack_high_water_bytes"]
                .as_u64()
                .context("pil.json: no `stack_high_water_bytes`")?,
            worst_load_per_period: ratio(
                control.total + steering.total + link.total + link_uart.total,
                periods,
            ),
        })
    }

    /// Each figure the worse of the two.
    fn max(&self, other: &Self) -> Self {
        Self {
            control: self.control.max(other.control),
            armed: self.armed.max(other.armed),
            arming: self.arming.max(other.arming),
            steering: self.steering.max(other.steering),
            link: self.link.max(other.link),
            link_uart: self.link_uart.max(other.link_uart),
            stack: self.stack.max(other.stack),
            worst_load_per_period: self.worst_load_per_period.max(other.worst_load_per_period),
        }
    }
}

/// `instructions` as a share of one control period, % (see [`CYCLES_PER_INSTRUCTION`]).
fn percent_of_period(instructions: f64) -> f64 {
    100.0 * instructions * CYCLES_PER_INSTRUCTION / CYCLES_PER_PERIOD
}

/// The CPU-load line CI is read by, and the table of every task.
fn load_report(w: &Figures) -> String {
    let row = |name: &str, priority: &str, task: &Task| {
        format!(
            "| {name} | {priority} | {} | {:.1} % | {:.0} | {:.2} % |\n",
            task.max,
            percent_of_period(task.max as f64),
            task.mean(),
            percent_of_period(task.worst_per_period),
        )
    };
    let worst_period = w.link_uart.max + w.control.max + w.steering.max;
    let mut out = format!(
        "control interrupt CPU load (PIL): worst {} instructions in any state, armed mean {:.0}, \
         armed worst {}\n",
        w.control.max,
        w.armed.mean(),
        w.armed.max
    );
    out.push_str(&format!(
        "  budgets: any state {ANY_STATE_LIMIT}, armed mean {ARMED_MEAN_LIMIT}, armed worst \
         {ARMED_WORST_LIMIT} instructions; load as a share of the 1 ms period at 100 MHz, \
         {CYCLES_PER_INSTRUCTION} cycles per instruction (the link service runs below \
         every other task and may span periods)\n"
    ));
    out.push_str(
        "| task | priority | worst run, instructions | worst run, % of period | mean run, \
         instructions | mean load per period |\n|---|---|---|---|---|---|\n",
    );
    out.push_str(&row("link USART interrupt", "4", &w.link_uart));
    out.push_str(&row("control interrupt, any state", "3", &w.control));
    out.push_str(&row("control interrupt, armed steady state", "3", &w.armed));
    out.push_str(&row(
        "control interrupt, the step that arms (in motion)",
        "3",
        &w.arming,
    ));
    out.push_str(&row("steering task (outer loop)", "2", &w.steering));
    out.push_str(&row("link service", "1", &w.link));
    out.push_str(&format!(
        "| all tasks | | {worst_period} (USART, control and steering in one period) | {:.1} % | | \
         {:.2} % |\n",
        percent_of_period(worst_period as f64),
        percent_of_period(w.worst_load_per_period),
    ));
    out.push_str(&format!(
        "stack high-water mark (PIL): {} bytes (limit {STACK_LIMIT})\n",
        w.stack
    ));
    out
}

/// The budgets `w` does not meet, as failures.
fn budget_failures(w: &Figures) -> Vec<String> {
    let mut failures = Vec::new();
    if w.control.max > ANY_STATE_LIMIT {
        failures.push(format!(
            "control interrupt {} instructions in some state > {ANY_STATE_LIMIT}",
            w.control.max
        ));
    }
    if w.armed.mean() > ARMED_MEAN_LIMIT as f64 {
        failures.push(format!(
            "control interrupt armed mean {:.0} instructions > {ARMED_MEAN_LIMIT}",
            w.armed.mean()
        ));
    }
    if w.armed.max > ARMED_WORST_LIMIT {
        failures.push(format!(
            "control interrupt armed worst {} instructions > {ARMED_WORST_LIMIT}",
            w.armed.max
        ));
    }
    if w.stack > STACK_LIMIT {
        failures.push(format!("stack {} bytes > {STACK_LIMIT}", w.stack));
    }
    failures
}

/// The workspace's target directory (`CARGO_TARGET_DIR` if set).
pub fn target_dir(ctx: &Context) -> PathBuf {
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
        let stderr = String::from_utf8_lossy(&output.stderr);
        eprint!("{stderr}");
        // The end of its standard error: host-sim prints its own error last.
        let error: Vec<&str> = stderr.lines().rev().take(4).collect();
        bail!(
            "`{shown}` failed ({}): {}",
            output.status,
            error.into_iter().rev().collect::<Vec<_>>().join("\n")
        );
    }
    Ok(stdout)
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

/// The encoder-disconnect run's fault: the left encoder disconnected 1 s after the start.
const ENCODER_DISCONNECT: &str =
    "\n[[faults]]\nat_s = 1.0\nkind = \"encoder-disconnect\"\nwheel = \"left\"\n";

/// The gyro run's robot (see [`write_gyro_scenario`]).
const WITH_GYRO: &str = "\n[gyro]\nheading = \"fused\"\nlatency_periods = 1\n";

/// `paper-circle` with the left encoder disconnected 1 s after the start, as a scenario
/// file at `path`; with `gyro`, on the gyro run's robot steering by the fused heading.
fn write_fault_scenario(host_sim: &Path, path: &Path, gyro: bool) -> Result<()> {
    let (name, extra) = if gyro {
        (
            FUSED_FAULT_SCENARIO,
            format!("{WITH_GYRO}{ENCODER_DISCONNECT}"),
        )
    } else {
        (FAULT_SCENARIO, ENCODER_DISCONNECT.to_string())
    };
    write_variant(host_sim, path, name, &extra)
}

/// `paper-circle` on a robot with a gyro, steering by odometry's heading (the firmware's
/// default), as a scenario file at `path`. Its readings are one period late (`latency_periods = 1`), so the
/// first step has none: the plant repeats that step while the station arms the firmware
/// (`host_sim::pil::firmware`), and a reading repeated there would be integrated again
/// and again by the disarmed robot, where `host-sim run` sees it once.
fn write_gyro_scenario(host_sim: &Path, path: &Path) -> Result<()> {
    write_variant(host_sim, path, GYRO_SCENARIO, WITH_GYRO)
}

/// `paper-circle` renamed `name`, with `extra` (TOML tables) appended, written to `path`.
fn write_variant(host_sim: &Path, path: &Path, name: &str, extra: &str) -> Result<()> {
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
            renamed.push_str(&format!("name = \"{name}\""));
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
    renamed.push_str(extra);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(path, renamed).with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `pil.json` with the figures of one run: `k` scales every task.
    fn json(k: u64, stack: u64) -> serde_json::Value {
        let task = |runs: u64, max: u64, total: u64| serde_json::json!({"runs": runs, "max_instructions": max * k, "total_instructions": total * k});
        serde_json::json!({
            "control_interrupt": task(1000, 3000, 1_200_000),
            "control_interrupt_armed": task(900, 1400, 1_080_000),
            "control_interrupt_arming": task(1, 2900, 2900),
            "steering_task": task(100, 700, 60_000),
            "link_service": task(50, 40_000, 800_000),
            "link_usart_interrupt": task(400, 60, 8_000),
            "stack_high_water_bytes": stack,
        })
    }

    #[test]
    fn figures_are_read_from_pil_json_and_the_worst_run_wins_each() {
        let a = Figures::from_json(&json(1, 2000)).unwrap();
        assert_eq!(
            (a.control.max, a.armed.max, a.arming.max),
            (3000, 1400, 2900)
        );
        assert_eq!(a.armed.mean(), 1200.0);
        assert_eq!(a.link.worst_per_period, 800.0);
        assert_eq!(
            a.worst_load_per_period, 2068.0,
            "(1.2 M + 60 k + 800 k + 8 k) / 1000 periods"
        );
        let b = Figures::from_json(&json(2, 1000)).unwrap();
        let worst = a.max(&b);
        assert_eq!(worst, b.max(&a));
        assert_eq!((worst.control.max, worst.stack), (6000, 2000));
        assert_eq!(worst.armed.mean(), 2400.0);
        assert!(
            Figures::from_json(&serde_json::json!({"control_interrupt": {"runs": 1}})).is_err()
        );
    }

    #[test]
    fn every_budget_is_enforced_and_the_load_line_names_them() {
        let within = Figures::from_json(&json(1, 2000)).unwrap();
        assert!(budget_failures(&within).is_empty());
        let report = load_report(&within);
        assert!(report.starts_with(
            "control interrupt CPU load (PIL): worst 3000 instructions in any state, armed mean \
             1200, armed worst 1400\n"
        ));
        assert!(
            report.contains("| control interrupt, any state | 3 | 3000 | 4.5 % | 1200 | 1.80 % |"),
            "{report}"
        );
        assert!(report.contains("| all tasks | | 3760 "), "{report}");
        assert!(
            report.contains("| link USART interrupt | 4 | 60 |"),
            "{report}"
        );
        // Twice the work: any state 6 000 > 5 000, armed mean 2 400 > 1 500, armed worst
        // 2 800 > 2 500; and a stack of 5 000 B > 4 KiB.
        let over = Figures::from_json(&json(2, 5000)).unwrap();
        assert_eq!(
            budget_failures(&over).len(),
            4,
            "{:?}",
            budget_failures(&over)
        );
        assert_eq!(percent_of_period(1000.0), 1.5);
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
}
