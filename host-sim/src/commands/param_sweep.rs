//! `host-sim param-sweep`: the wheel loop with the controller's gains fixed against
//! supplies from 4.8 to 12.6 V and motors with R_a, K_t, friction and inertia ±30 %, one at
//! a time ([`crate::robustness`]): margins, a step, the scenario, a table. Optionally the
//! corners (every combination at once), which are reported but not judged. The command
//! fails when a one-at-a-time robot does not pass ([`verdict`]).

use std::fmt;

use anyhow::Result;
use robot_files::scenario::Scenario;

use super::{load, Failed, Report};
use crate::robustness::{self, CaseResult, OSCILLATION_RMS_RAD_S};

/// The one-at-a-time robots (the nominal one first) and, when asked, the corners.
#[derive(Clone, Debug)]
pub struct ParamSweepReport {
    /// The scenario (its left wheel's gains and its duration are printed).
    pub scenario: Scenario,
    /// [`robustness::one_at_a_time`]'s robots; the first is the nominal one.
    pub results: Vec<CaseResult>,
    /// [`robustness::corners`]' robots, with `--corners`.
    pub corners: Option<Vec<CaseResult>>,
}

impl fmt::Display for ParamSweepReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let scenario = &self.scenario;
        let w = scenario.robot.left_wheel;
        writeln!(
            f,
            "{}: the controller's wheel loop fixed (K_p = {} V/(rad/s), T_i = {} s, k_S = {} V, \
k_V = {} V/(rad/s)), the simulated robot varied; tracking law, {} s\n",
            scenario.name, w.kp_v_per_rad_s, w.ti_s, w.ks_v, w.kv_v_per_rad_s, scenario.duration_s
        )?;
        // `run` refuses an empty list: there is always a nominal robot.
        let Some(nominal) = self.results.first() else {
            return Ok(());
        };
        writeln!(
            f,
            "{}",
            robustness::table(&self.results, nominal).trim_end()
        )?;
        writeln!(
            f,
            "\n(GM, PM: the linearised loop, the smaller of ground straight and turning; rise, over: \
0 → 15 rad/s step from rest; settle: true error < 1 cm and 1° to the end; RMS: set-point − true \
wheel speed, both wheels, every step; final10: the same over the last 10 s, above \
{OSCILLATION_RMS_RAD_S} rad/s counts as oscillating; ok: no oscillation or fault, settled, RMS \
≤ 2 × nominal)"
        )?;
        if let Some(corners) = &self.corners {
            let passed = corners
                .iter()
                .filter(|r| robustness::passes(r, nominal))
                .count();
            writeln!(
                f,
                "\ncorners: R_a (R), K_t (K), friction (f), inertia (J) each −30 % or +30 %, at 4.8 and \
12.6 V: {passed} of {} pass (not part of the verdict: a motor 30 % off in several ways at once \
can be too weak for the path)\n",
                corners.len()
            )?;
            writeln!(f, "{}", robustness::table(corners, nominal).trim_end())?;
        }
        Ok(())
    }
}

impl Report for ParamSweepReport {
    fn verdict(&self) -> Result<(), Failed> {
        verdict(&self.results)
    }
}

/// The rule: every one-at-a-time robot passes against the nominal one, the first
/// ([`robustness::passes`]); otherwise `N of M robots did not pass`. The corners are not
/// judged. An empty list passes.
pub fn verdict(results: &[CaseResult]) -> Result<(), Failed> {
    let Some(nominal) = results.first() else {
        return Ok(());
    };
    let failed = results
        .iter()
        .filter(|r| !robustness::passes(r, nominal))
        .count();
    if failed > 0 {
        Err(Failed(format!(
            "{failed} of {} robots did not pass",
            results.len()
        )))
    } else {
        Ok(())
    }
}

/// Runs the one-at-a-time robots on `scenario`, and the corners with `corners`.
pub fn run(scenario: &str, corners: bool) -> Result<ParamSweepReport> {
    let scenario = load(scenario)?;
    let results = robustness::run_all(&scenario, &robustness::one_at_a_time())?;
    if results.is_empty() {
        anyhow::bail!("no nominal case");
    }
    let corners = if corners {
        Some(robustness::run_all(&scenario, &robustness::corners())?)
    } else {
        None
    };
    Ok(ParamSweepReport {
        scenario,
        results,
        corners,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robustness::Variation;

    fn robot(settled: bool, rms: f64) -> CaseResult {
        CaseResult {
            variation: Variation::default(),
            gain_margin: Some(4.0),
            phase_margin_deg: Some(60.0),
            stable: true,
            step_rise_s: Some(0.04),
            step_overshoot_pct: 4.0,
            settle_s: settled.then_some(2.3),
            wheel_error_rms_rad_s: rms,
            wheel_error_final_rms_rad_s: 0.0,
            faulted: false,
            faults: Vec::new(),
        }
    }

    #[test]
    fn every_robot_must_pass_against_the_nominal_one() {
        let nominal = robot(true, 0.1);
        assert_eq!(verdict(&[nominal.clone(), robot(true, 0.2)]), Ok(()));
        assert_eq!(
            verdict(&[
                nominal.clone(),
                robot(true, 0.21),
                robot(false, 0.1),
                robot(true, 0.1)
            ]),
            Err(Failed("2 of 4 robots did not pass".into()))
        );
        assert_eq!(verdict(&[]), Ok(()));
    }
}
