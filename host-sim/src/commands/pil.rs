//! `host-sim pil`: processor in the loop ([`crate::pil`]). Says what it starts, runs the
//! firmware under QEMU against this plant, compares the run with `host-sim run`'s (unless
//! the link was cut), prints the verdict lines and the firmware's figures, writes
//! `summary.json` and `pil.json` into the output folder, and fails when a verdict line
//! failed ([`verdict`]). `cargo xtask pil` reads the `PIL <scenario>: summary …` and
//! `PIL <scenario>: trajectory digest …` lines and `pil.json`.

use std::fmt;
use std::path::PathBuf;

use anyhow::Result;
use controller_core::law::LawKind;
use serde_json::{json, Value};

use super::{create_dir, default_dir, load, Failed, Progress, Report};
use crate::pil::station::StationReport;
use crate::pil::verdict::{judge, Line};
use crate::pil::{PilOptions, PilOutcome};
use crate::run::{run_scenario_with, RunOptions};

/// What `host-sim pil` was asked.
#[derive(Clone, Debug)]
pub struct Options {
    /// A built-in scenario name or a path to a TOML file.
    pub scenario: String,
    /// The steering law.
    pub law: LawKind,
    /// How the run is set up (firmware, QEMU, station, link loss).
    pub pil: PilOptions,
    /// Simulated time, s, instead of the scenario's `sim.duration_s`.
    pub duration_s: Option<f64>,
    /// The output folder (`None`: `host-sim-out/<scenario>/pil`).
    pub out: Option<PathBuf>,
}

/// The line printed before the run starts.
#[derive(Clone, Debug, PartialEq)]
pub struct PilStart {
    /// The scenario's name.
    pub scenario: String,
    /// The steering law.
    pub law: LawKind,
    /// Simulated time, s.
    pub duration_s: f64,
    /// The firmware ELF.
    pub firmware: PathBuf,
}

impl fmt::Display for PilStart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "PIL {}: {} law, {:.1} s, firmware {}",
            self.scenario,
            self.law.name(),
            self.duration_s,
            self.firmware.display()
        )
    }
}

/// The judged run and where its files went.
#[derive(Clone, Debug)]
pub struct PilReport {
    /// The scenario's name.
    pub scenario: String,
    /// Every verdict line, in order.
    pub lines: Vec<Line>,
    /// What the built-in station saw, if it ran.
    pub station: Option<StationReport>,
    /// Control steps simulated.
    pub steps: u64,
    /// Wall-clock time of the run, s.
    pub wall_time_s: f64,
    /// Control steps the firmware ran before it was armed.
    pub held_steps: u64,
    /// The folder of `summary.json` and `pil.json`.
    pub dir: PathBuf,
}

impl fmt::Display for PilReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for line in &self.lines {
            writeln!(f, "{}", line.text)?;
        }
        if let Some(station) = &self.station {
            writeln!(
                f,
                "station: {} answered {} requests ({} re-sent), {} telemetry frames, {} heartbeats, \
                 {} velocity commands ({} refused after the robot stopped)",
                station.robot,
                station.replies,
                station.resent,
                station.telemetry_frames,
                station.heartbeats,
                station.velocity_commands,
                station.velocity_refused_after_stop
            )?;
        }
        writeln!(
            f,
            "PIL {}: {} steps in {:.1} s wall ({:.2} ms a step), {} control steps before arming",
            self.scenario,
            self.steps,
            self.wall_time_s,
            1e3 * self.wall_time_s / self.steps.max(1) as f64,
            self.held_steps
        )?;
        writeln!(
            f,
            "  wrote summary.json and pil.json to {}",
            self.dir.display()
        )
    }
}

impl Report for PilReport {
    fn verdict(&self) -> Result<(), Failed> {
        verdict(&self.lines)
    }
}

/// The rule: every verdict line passed; otherwise the failed lines' text, joined by
/// `; `, in order.
pub fn verdict(lines: &[Line]) -> Result<(), Failed> {
    let failed: Vec<&str> = lines
        .iter()
        .filter(|l| !l.passed)
        .map(|l| l.text.as_str())
        .collect();
    if failed.is_empty() {
        Ok(())
    } else {
        Err(Failed(failed.join("; ")))
    }
}

/// `pil.json`: each task's runs and instructions (largest and total), the stack's
/// high-water mark and start-up use (bytes), the steps before arming, the trajectory
/// digest and every verdict line with whether it passed.
pub fn pil_json(outcome: &PilOutcome, lines: &[Line]) -> Value {
    let task = |t: &lockstep::TaskFigures| {
        json!({
            "runs": t.runs,
            "max_instructions": t.max_instructions,
            "total_instructions": t.total_instructions,
        })
    };
    let board = &outcome.board;
    json!({
        "control_interrupt": task(&board.control),
        "control_interrupt_armed": task(&board.control_armed),
        "control_interrupt_arming": task(&board.control_arming),
        "steering_task": task(&board.steering),
        "link_service": task(&board.link),
        "link_usart_interrupt": task(&board.link_uart),
        "stack_high_water_bytes": board.stack_high_water_bytes,
        "start_stack_bytes": board.start_stack_bytes,
        "steps_before_arming": outcome.held_steps,
        "digest": outcome.result.digest.as_ref().map(ToString::to_string),
        "verdict": lines.iter().map(|l| json!({"line": l.text, "passed": l.passed})).collect::<Vec<_>>(),
    })
}

/// A `[velocity]` timeline runs under processor in the loop only through the built-in
/// station, which sends its commands in step (`crate::pil::station`), and only from the
/// step after arming: the plant holds still at the first step while the station arms.
fn velocity_runnable(
    scenario: &str,
    timeline: &robot_files::scenario::VelocityTimeline,
    builtin_station: bool,
) -> Result<(), Failed> {
    if !builtin_station {
        return Err(Failed(format!(
            "{scenario}: a [velocity] timeline needs the built-in station (`--client builtin`), \
             which sends its commands at their control steps"
        )));
    }
    if timeline.command_period_steps < 2 {
        return Err(Failed(format!(
            "{scenario}: velocity.command_period_s is one control period: the station sends \
             one request a step, so no heartbeat would reach the firmware while commands \
             stream; give it two periods or more"
        )));
    }
    if timeline.entries.first().is_some_and(|e| e.at_step == 0) {
        return Err(Failed(format!(
            "{scenario}: velocity.commands[0] is at 0 s, the step at which the station arms \
             the firmware over the link: give it a time of one control period or more"
        )));
    }
    Ok(())
}

/// Says what it starts on `progress`, runs the firmware in the loop, judges the run and
/// writes `summary.json` (the run's summary with the wall-clock time of the whole PIL
/// run) and `pil.json`.
pub fn run(options: &Options, progress: &mut Progress<'_>) -> Result<PilReport> {
    let mut scenario = load(&options.scenario)?;
    if let Some(timeline) = &scenario.velocity {
        velocity_runnable(&scenario.name, timeline, options.pil.builtin_station)?;
    }
    // The link-loss verdict counts on the built-in station's heartbeats going in step:
    // none is in flight at the cut.
    if options.pil.link_loss_at_s.is_some() && !options.pil.builtin_station {
        return Err(Failed(
            "--link-loss-at-s needs the built-in station (`--client builtin`), whose \
             heartbeats reach the firmware at known steps"
                .into(),
        )
        .into());
    }
    if let Some(duration_s) = options.duration_s {
        scenario = scenario.with_duration_s(duration_s)?;
    }
    let law = options.law;
    progress(&PilStart {
        scenario: scenario.name.clone(),
        law,
        duration_s: scenario.duration_s,
        firmware: options.pil.firmware.clone(),
    })?;
    let outcome = crate::pil::run(&scenario, law, &options.pil)?;
    // The same scenario with the supervisor and controller run here, unless the link
    // was cut (no counterpart without a link).
    let host = match options.pil.link_loss_at_s {
        Some(_) => None,
        None => Some(run_scenario_with(&scenario, law, RunOptions::default())?),
    };
    let lines = judge(&scenario, &outcome, host.as_ref());
    let dir = options
        .out
        .clone()
        .unwrap_or_else(|| default_dir(&scenario, "pil"));
    create_dir(&dir)?;
    let mut summary = outcome.result.summary.clone();
    summary.wall_time_s = outcome.wall_time_s;
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(&summary)? + "\n",
    )?;
    std::fs::write(
        dir.join("pil.json"),
        serde_json::to_string_pretty(&pil_json(&outcome, &lines))? + "\n",
    )?;
    Ok(PilReport {
        scenario: scenario.name,
        station: outcome.station,
        steps: outcome.result.summary.steps,
        wall_time_s: outcome.wall_time_s,
        held_steps: outcome.held_steps,
        lines,
        dir,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(text: &str, passed: bool) -> Line {
        Line {
            text: text.into(),
            passed,
        }
    }

    #[test]
    fn a_velocity_timeline_needs_the_builtin_station_and_no_command_at_arming() {
        let scenario = load("velocity-steps").expect("built in");
        let timeline = scenario.velocity.expect("a timeline");
        assert_eq!(velocity_runnable("v", &timeline, true), Ok(()));
        let without = velocity_runnable("v", &timeline, false).expect_err("refused");
        assert!(without.0.contains("--client builtin"), "{}", without.0);
        let mut at_arming = timeline;
        at_arming.entries[0].at_step = 0;
        let refused = velocity_runnable("v", &at_arming, true).expect_err("refused");
        assert!(refused.0.contains("velocity.commands[0]"), "{}", refused.0);
        let mut every_step = at_arming;
        every_step.entries[0].at_step = 500;
        every_step.command_period_steps = 1;
        let refused = velocity_runnable("v", &every_step, true).expect_err("refused");
        assert!(refused.0.contains("command_period_s"), "{}", refused.0);
    }

    #[test]
    fn the_run_fails_with_every_failed_verdict_line() {
        assert_eq!(
            verdict(&[
                line("PIL s: summary identical to host-sim", true),
                line("PIL s: stack 1200 bytes", true)
            ]),
            Ok(())
        );
        assert_eq!(
            verdict(&[
                line("PIL s: summary differs", false),
                line("PIL s: stack 1200 bytes", true),
                line("PIL s: trajectory digest differs", false)
            ]),
            Err(Failed(
                "PIL s: summary differs; PIL s: trajectory digest differs".into()
            ))
        );
    }
}
