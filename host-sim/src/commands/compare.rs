//! `host-sim compare`: every law on the same plant — a table on stdout and the overlay of
//! their paths and errors, `compare.svg`, in the output folder. The table and the
//! overlay are also [`super::paper`]'s.

use std::fmt;
use std::path::{Path, PathBuf};

use anyhow::Result;
use controller_core::law::LawKind;
use controller_core::reference::ReferenceMode;
use robot_files::output::settle_text;
use robot_files::scenario::Scenario;
use robot_files::trace::TraceRow;

use super::{create_dir, default_dir, load, Report};
use crate::run::{run_scenario, RunResult};

/// Every law's run of one scenario, with the default trace options; its `Display` is the
/// comparison table (settle time, final and last-10-s errors, peaks, distance driven)
/// and the notes under it.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// The scenario.
    pub scenario: Scenario,
    /// One run per law, in [`LawKind::ALL`] order.
    pub results: Vec<(LawKind, RunResult)>,
}

impl Comparison {
    /// Runs every law on `scenario`.
    pub fn run(scenario: &Scenario) -> Result<Self> {
        let results = LawKind::ALL
            .into_iter()
            .map(|law| Ok((law, run_scenario(scenario, law)?)))
            .collect::<Result<_>>()?;
        Ok(Self {
            scenario: scenario.clone(),
            results,
        })
    }

    /// Writes the overlay of every law's path and error as `compare.svg` in `dir`
    /// (created if needed); the file.
    pub fn write_overlay(&self, dir: &Path) -> Result<PathBuf> {
        create_dir(dir)?;
        let file = dir.join("compare.svg");
        let runs: Vec<(&str, &[TraceRow])> = self
            .results
            .iter()
            .map(|(law, r)| (law.name(), r.trace.as_slice()))
            .collect();
        let s = &self.scenario;
        robot_files::figures::compare(&file, &s.name, &s.path, &runs)?;
        Ok(file)
    }
}

impl fmt::Display for Comparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let scenario = &self.scenario;
        writeln!(
            f,
            "{}: every law on the same plant ({} s)\n",
            scenario.name, scenario.duration_s
        )?;
        writeln!(
            f,
            "{:<9} {:>12} {:>11} {:>12} {:>11} {:>11} {:>10} {:>6} {:>10}",
            "law",
            "settle",
            "final e/m",
            "final θe/°",
            "rms10 e/m",
            "max10 e/m",
            "ω_w max",
            "duty",
            "driven/m"
        )?;
        for (law, r) in &self.results {
            let s = &r.summary;
            let e = s.headline_error();
            writeln!(
                f,
                "{:<9} {:>12} {:>11.4} {:>12.2} {:>11.4} {:>11.4} {:>10.1} {:>6.2} {:>10.2}",
                law.name(),
                settle_text(e.settle_time_s),
                e.final_position_error_m,
                e.final_heading_error_rad.to_degrees(),
                e.rms_position_error_m,
                e.max_position_error_m,
                s.max_wheel_speed_rad_s,
                s.max_duty,
                r.distance_travelled_m
            )?;
        }
        let expected = f64::from(scenario.reference_speed_m_s) * scenario.duration_s;
        writeln!(
            f,
            "\n(e: true position error — to the reference point, or to the path when \
path-following; rms10/max10: last 10 s; the reference covers {expected:.2} m; {})",
            if scenario.start.v_m_s != 0.0 || scenario.start.omega_rad_s != 0.0 {
                "armed in motion at t = 0"
            } else {
                "armed at rest at t = 0"
            }
        )?;
        if let ReferenceMode::PathFollowing { lookahead_m } = scenario.reference_mode {
            writeln!(
                f,
                "note: path-following with lookahead {lookahead_m} m. The paper's law is a \
regulation law (docs/paper-errata.md, item 3): it drives to the reference point and stops there, so \
with the reference at the robot's own projection it stalls on the path (see driven/m)."
            )?;
        }
        Ok(())
    }
}

/// The comparison and where its overlay went.
#[derive(Clone, Debug)]
pub struct CompareReport {
    /// Every law's run.
    pub comparison: Comparison,
    /// `compare.svg`.
    pub file: PathBuf,
}

impl fmt::Display for CompareReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.comparison)?;
        writeln!(f, "\nwrote {}", self.file.display())
    }
}

impl Report for CompareReport {}

/// Runs every law on `scenario` and writes the overlay into `out` (`None`:
/// `host-sim-out/<scenario>/compare`).
pub fn run(scenario: &str, out: Option<PathBuf>) -> Result<CompareReport> {
    let scenario = load(scenario)?;
    let comparison = Comparison::run(&scenario)?;
    let dir = out.unwrap_or_else(|| default_dir(&scenario, "compare"));
    let file = comparison.write_overlay(&dir)?;
    Ok(CompareReport { comparison, file })
}
