//! `host-sim faults`: every kind of fault, one at a time ([`crate::fault_suite`]), on a
//! scenario: what the supervisor did and how fast, against its detector's limit. A table
//! on stdout, `faults.json` in the output folder; the command fails when a case did not
//! behave as its expectation says ([`verdict`]).

use std::fmt;
use std::path::PathBuf;

use anyhow::{Context, Result};
use controller_core::law::LawKind;

use super::{create_dir, default_dir, load, ms_or, Failed, Report};
use crate::fault_matrix::{self, summary_line, Cell, Configuration};
use crate::fault_suite::{cases, run_suite, CaseResult, Expectation, INJECT_AT_S};

/// The suite's results and where `faults.json` went.
#[derive(Clone, Debug)]
pub struct FaultsReport {
    /// The scenario's name.
    pub scenario: String,
    /// The steering law.
    pub law: LawKind,
    /// The scenario's own configuration (a row stated for the other heading source, or a
    /// re-arm row, runs in the nearest one where it applies).
    pub configuration: Configuration,
    /// One result per case, in [`crate::fault_suite::cases`] order.
    pub results: Vec<CaseResult>,
    /// `faults.json`.
    pub file: PathBuf,
}

impl fmt::Display for FaultsReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} with the {} law, {}, each fault injected {INJECT_AT_S} s after arming:\n",
            self.scenario,
            self.law.name(),
            self.configuration
        )?;
        writeln!(
            f,
            "{:<38} {:>8} {:>9} {:>8} {:>8} {:>9}  by / would be seen by",
            "fault", "detected", "latency", "limit", "after/m", "stopped"
        )?;
        let ms = |v: Option<f64>| ms_or(v, 0, "—");
        for r in &self.results {
            let by = match r.expect {
                Expectation::Undetectable { sensor } => sensor.to_string(),
                Expectation::Warn { .. } => {
                    format!("warned: {}", r.report.warning.as_deref().unwrap_or("—"))
                }
                _ => r.report.detected_by.join(", "),
            };
            let by = match (r.max_gyro_disagreement_radps, r.expect) {
                (_, Expectation::Warn { .. }) | (None, _) => by,
                (Some(d), _) => format!("{by}; mean |gyro − odometry| up to {d:.3} rad/s"),
            };
            let stopped = r.report.wheels_stopped_s.map(|t| t - r.report.injected_s);
            writeln!(
                f,
                "{:<38} {:>8} {:>9} {:>8} {:>8.3} {:>9}  {}{}",
                r.case,
                if r.detected { "yes" } else { "no" },
                ms(r.latency_s),
                ms(r.limit_s),
                r.report.distance_after_m,
                ms(stopped),
                by,
                if r.passed {
                    ""
                } else {
                    "   <-- NOT AS EXPECTED"
                }
            )?;
        }
        writeln!(
            f,
            "\n(latency: from injection to the supervisor stopping the robot, or to its warning for a \
case it drives on through; after/m: true distance \
driven from the injection to the end; stopped: until both wheels turn < 0.1 rad/s)\nwrote {}",
            self.file.display()
        )
    }
}

impl Report for FaultsReport {
    fn verdict(&self) -> Result<(), Failed> {
        verdict(&self.results)
    }
}

/// The rule: every case passed; otherwise `not as expected: ` and the failed cases'
/// names, comma-separated, in suite order.
pub fn verdict(results: &[CaseResult]) -> Result<(), Failed> {
    let failed: Vec<&str> = results
        .iter()
        .filter(|r| !r.passed)
        .map(|r| r.case)
        .collect();
    if failed.is_empty() {
        Ok(())
    } else {
        Err(Failed(format!("not as expected: {}", failed.join(", "))))
    }
}

/// Runs the suite on `scenario` with `law` and writes `faults.json` into `out` (`None`:
/// `host-sim-out/<scenario>/faults`), and each case's run as an MCAP file into `mcap_dir`
/// if given.
pub fn run(
    scenario: &str,
    law: LawKind,
    out: Option<PathBuf>,
    mcap_dir: Option<PathBuf>,
) -> Result<FaultsReport> {
    let scenario = load(scenario)?;
    if let Some(dir) = &mcap_dir {
        create_dir(dir)?;
    }
    let results = run_suite(&scenario, law, mcap_dir.as_deref())?;
    let dir = out.unwrap_or_else(|| default_dir(&scenario, "faults"));
    create_dir(&dir)?;
    let file = dir.join("faults.json");
    let json = serde_json::to_string_pretty(&results).context("serialising the faults")?;
    std::fs::write(&file, json + "\n").with_context(|| format!("writing {}", file.display()))?;
    Ok(FaultsReport {
        configuration: Configuration::of(&scenario),
        scenario: scenario.name,
        law,
        results,
        file,
    })
}

/// The matrix's cells and where its files went.
#[derive(Clone, Debug)]
pub struct MatrixReport {
    /// The base scenario's name.
    pub scenario: String,
    /// Every cell, in configuration order, then row order.
    pub cells: Vec<Cell>,
    /// `matrix.json` (every cell) and `matrix.md` (the table).
    pub files: [PathBuf; 2],
}

impl fmt::Display for MatrixReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for cell in self.cells.iter().filter(|c| !c.result.passed) {
            writeln!(
                f,
                "not as expected: {} ({}, expected {})",
                cell.name(),
                outcome(&cell.result),
                expected(&cell.result.expect)
            )?;
        }
        writeln!(
            f,
            "{} on {}, {} configurations",
            summary_line(&self.cells),
            self.scenario,
            Configuration::all().len()
        )?;
        write!(
            f,
            "wrote {} and {}",
            self.files[0].display(),
            self.files[1].display()
        )
    }
}

impl Report for MatrixReport {
    fn verdict(&self) -> Result<(), Failed> {
        let failed = self.cells.iter().filter(|c| !c.result.passed).count();
        if failed == 0 {
            Ok(())
        } else {
            Err(Failed(format!(
                "{failed} cells of the fault matrix not as expected"
            )))
        }
    }
}

/// What a cell did, in a few words: `stopped in 416 ms`, `warned in 200 ms`, `tripped
/// nothing`, and for a re-arm row whether the second press re-armed.
fn outcome(r: &CaseResult) -> String {
    let ms = |v: Option<f64>| ms_or(v, 0, "—");
    let done = match (r.expect, r.detected) {
        (Expectation::Warn { .. }, true) => format!("warned in {}", ms(r.latency_s)),
        (_, true) => format!("stopped in {}", ms(r.latency_s)),
        (_, false) => "tripped nothing".to_string(),
    };
    match r.expect {
        Expectation::Rearm { .. } if r.final_state == "Armed" => format!("{done}, re-armed"),
        Expectation::Rearm { .. } => format!("{done}, not re-armed"),
        _ => done,
    }
}

/// A row's expectation, in a few words.
fn expected(e: &Expectation) -> String {
    let ms = |s: f64| ms_or(Some(s), 0, "—");
    match *e {
        Expectation::Detect { limit_s, .. } => format!("stopped within {}", ms(limit_s)),
        Expectation::Warn { limit_s, .. } => format!("warned within {}", ms(limit_s)),
        Expectation::Harmless => "harmless".into(),
        Expectation::Undetectable { .. } => "undetectable".into(),
        Expectation::Rearm {
            limit_s,
            armed_again,
            ..
        } => format!(
            "stopped within {}, {}",
            ms(limit_s),
            if armed_again {
                "re-armed"
            } else {
                "not re-armed"
            }
        ),
    }
}

/// The matrix as a Markdown table: a row per fault with its expectation, a column per
/// configuration, each cell what it did (`✗` before a cell not as expected; `·` where the
/// row does not apply).
pub fn matrix_table(cells: &[Cell]) -> String {
    let configurations = Configuration::all();
    let mut out = String::from("| fault | expected |");
    for c in &configurations {
        out += &format!(" {c} |");
    }
    out += "\n|---|---|";
    out += &"---|".repeat(configurations.len());
    out += "\n";
    for case in cases() {
        let expect = cells
            .iter()
            .find(|c| c.result.case == case.name)
            .map_or_else(|| expected(&case.expect), |c| expected(&c.result.expect));
        out += &format!("| {} | {expect} |", case.name);
        for configuration in &configurations {
            let cell = cells
                .iter()
                .find(|c| c.configuration == *configuration && c.result.case == case.name);
            out += &match cell {
                Some(c) if c.result.passed => format!(" {} |", outcome(&c.result)),
                Some(c) => format!(" ✗ {} |", outcome(&c.result)),
                None => " · |".to_string(),
            };
        }
        out += "\n";
    }
    out
}

/// Runs the matrix on `scenario` with `law` and writes `matrix.json` and `matrix.md`
/// into `out` (`None`: `host-sim-out/<scenario>/fault-matrix`).
pub fn run_matrix(scenario: &str, law: LawKind, out: Option<PathBuf>) -> Result<MatrixReport> {
    let scenario = load(scenario)?;
    let cells = fault_matrix::run_matrix(&scenario, law, &Configuration::all())?;
    let dir = out.unwrap_or_else(|| default_dir(&scenario, "fault-matrix"));
    create_dir(&dir)?;
    let json_file = dir.join("matrix.json");
    let json = serde_json::to_string_pretty(&cells).context("serialising the matrix")?;
    std::fs::write(&json_file, json + "\n")
        .with_context(|| format!("writing {}", json_file.display()))?;
    let table_file = dir.join("matrix.md");
    std::fs::write(&table_file, matrix_table(&cells))
        .with_context(|| format!("writing {}", table_file.display()))?;
    Ok(MatrixReport {
        scenario: scenario.name,
        cells,
        files: [json_file, table_file],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use robot_files::metrics::FaultReport;

    fn case(name: &'static str, passed: bool) -> CaseResult {
        CaseResult {
            case: name,
            fault: "encoder-disconnect".into(),
            detected: passed,
            latency_s: passed.then_some(0.05),
            limit_s: Some(0.1),
            expect: Expectation::Detect {
                limit_s: 0.1,
                because: "test",
            },
            passed,
            report: FaultReport {
                fault: "encoder-disconnect".into(),
                injected_s: INJECT_AT_S,
                detected: passed,
                detected_s: passed.then_some(INJECT_AT_S + 0.05),
                latency_s: passed.then_some(0.05),
                detected_by: Vec::new(),
                motors_zero_s: None,
                wheels_stopped_s: None,
                distance_after_m: 0.0,
                warning: None,
                warning_latency_s: None,
            },
            final_state: "Faulted".into(),
            final_true_error_m: None,
            max_gyro_disagreement_radps: None,
        }
    }

    #[test]
    fn the_suite_fails_naming_every_case_that_did_not_behave() {
        assert_eq!(verdict(&[case("a", true), case("b", true)]), Ok(()));
        assert_eq!(verdict(&[]), Ok(()));
        assert_eq!(
            verdict(&[case("a", false), case("b", true), case("c", false)]),
            Err(Failed("not as expected: a, c".into()))
        );
    }
}
