//! `host-sim run`: one scenario with one law; writes `trace.csv`, `summary.json` and Figs.
//! 5–7 into the output folder and prints the run's human summary.

use std::fmt;
use std::path::PathBuf;

use anyhow::Result;
use controller_core::law::LawKind;
use robot_files::scenario::Scenario;

use super::{default_dir, load, Report};
use crate::output;
use crate::run::{run_scenario_with, RunOptions, RunResult};

/// What `host-sim run` was asked.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// A built-in scenario name or a path to a TOML file.
    pub scenario: String,
    /// The steering law.
    pub law: LawKind,
    /// The output folder (`None`: `host-sim-out/<scenario>/<law>`).
    pub out: Option<PathBuf>,
    /// A trace row every this many control steps (`None`: every steering update, the
    /// scenario's `robot.steering_divider`).
    pub trace_every: Option<u32>,
    /// Simulated time, s, instead of the scenario's `sim.duration_s`.
    pub duration_s: Option<f64>,
    /// Also write the run as an MCAP file here (Foxglove).
    pub mcap: Option<PathBuf>,
}

/// A finished run and where its files went.
#[derive(Clone, Debug)]
pub struct RunReport {
    /// The scenario as run (its duration possibly replaced).
    pub scenario: Scenario,
    /// The run.
    pub result: RunResult,
    /// The files written.
    pub files: Vec<PathBuf>,
    /// The folder they are in.
    pub dir: PathBuf,
}

impl fmt::Display for RunReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let summary = output::human_summary(&self.scenario, &self.result);
        writeln!(f, "{}", summary.trim_end())?;
        writeln!(
            f,
            "  wrote {} files to {}",
            self.files.len(),
            self.dir.display()
        )
    }
}

impl Report for RunReport {}

/// Runs the scenario and writes its files.
pub fn run(options: &Options) -> Result<RunReport> {
    let mut scenario = load(&options.scenario)?;
    if let Some(duration_s) = options.duration_s {
        scenario = scenario.with_duration_s(duration_s)?;
    }
    let law = options.law;
    let run_options = RunOptions::traced_every(
        options
            .trace_every
            .unwrap_or(scenario.robot.steering_divider),
    );
    let result = run_scenario_with(&scenario, law, run_options)?;
    let dir = options
        .out
        .clone()
        .unwrap_or_else(|| default_dir(&scenario, law.name()));
    let mut files = output::write_run(&dir, &scenario, &result)?;
    if let Some(file) = &options.mcap {
        files.push(crate::mcap::write_run_mcap(file, &scenario, &result)?.file);
    }
    Ok(RunReport {
        scenario,
        result,
        files,
        dir,
    })
}
