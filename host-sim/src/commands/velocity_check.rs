//! `host-sim velocity-check`: the velocity mode's figures on a scenario with a
//! `[velocity]` timeline (the built-in `velocity-steps` by default), as one line, and a
//! failure when they break its contract (see [`crate::velocity_check`]).

use std::fmt;

use anyhow::Result;

use super::{load, Failed, Report};
use crate::velocity_check::{measure, VelocityFigures};

/// The figures of the run.
#[derive(Clone, Debug)]
pub struct VelocityCheckReport {
    /// What was measured.
    pub figures: VelocityFigures,
}

impl fmt::Display for VelocityCheckReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{}", self.figures)
    }
}

impl Report for VelocityCheckReport {
    fn verdict(&self) -> Result<(), Failed> {
        let problems = self.figures.problems();
        if problems.is_empty() {
            Ok(())
        } else {
            Err(Failed(problems.join("; ")))
        }
    }
}

/// Runs `scenario` (a built-in name or a TOML file with a `[velocity]` timeline).
pub fn run(scenario: &str) -> Result<VelocityCheckReport> {
    let scenario = load(scenario)?;
    Ok(VelocityCheckReport {
        figures: measure(&scenario)?,
    })
}
