//! `host-sim margins`: the wheel loop's gain and phase margins in every load case (ground
//! straight and turning, lifted; motoring and braking) from the linearised loop
//! ([`crate::margins`]); with `--measure`, also measured by injecting sines on the
//! simulated robot. A case short of the aim is reported, not a failure.

use std::fmt;

use anyhow::Result;
use robot_files::scenario::Scenario;

use super::{load, Failed, Report};
use crate::margins::{
    measure_cases, measured_table, meets_aim, model_cases, table, CaseMargins, MeasuredCase,
    SweepSettings, GAIN_MARGIN_AIM, PHASE_MARGIN_AIM_DEG,
};

/// The largest sine `--amplitude-v` may inject, V.
pub const MAX_AMPLITUDE_V: f64 = 2.0;

/// The rule on `--amplitude-v`: in (0, [`MAX_AMPLITUDE_V`]] V.
pub fn check_amplitude(amplitude_v: f64) -> Result<(), Failed> {
    if amplitude_v > 0.0 && amplitude_v <= MAX_AMPLITUDE_V {
        Ok(())
    } else {
        Err(Failed("--amplitude-v must be in (0, 2]".into()))
    }
}

/// The margins of every case, and the measured ones when asked.
#[derive(Clone, Debug)]
pub struct MarginsReport {
    /// The scenario (its left wheel's gains and speed window are printed).
    pub scenario: Scenario,
    /// Every load case from the model.
    pub cases: Vec<CaseMargins>,
    /// The measured cases and the sweep's settings, with `--measure`.
    pub measured: Option<(Vec<MeasuredCase>, SweepSettings)>,
}

impl MarginsReport {
    /// The names of the cases that are unstable or short of the aim ([`meets_aim`]).
    pub fn short_of_aim(&self) -> Vec<String> {
        self.cases
            .iter()
            .filter(|c| !(c.stable && meets_aim(&c.margins)))
            .map(|c| c.case.name())
            .collect()
    }
}

impl fmt::Display for MarginsReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let scenario = &self.scenario;
        let w = scenario.robot.left_wheel;
        writeln!(
            f,
            "{}: wheel loop K_p = {} V/(rad/s), T_i = {} s, T_d = {} s; speed window {} steps at {} Hz \
(left wheel, linearised; aim GM ≥ {} ({:.0} dB), PM ≥ {}°)\n",
            scenario.name,
            w.kp_v_per_rad_s,
            w.ti_s,
            w.td_s,
            scenario.robot.speed_window_steps,
            scenario.robot.control_rate_hz,
            GAIN_MARGIN_AIM,
            20.0 * GAIN_MARGIN_AIM.log10(),
            PHASE_MARGIN_AIM_DEG
        )?;
        writeln!(f, "{}", table(&self.cases).trim_end())?;
        let short = self.short_of_aim();
        if short.is_empty() {
            writeln!(f, "\nevery case meets the aim")?;
        } else {
            writeln!(f, "\nshort of the aim: {}", short.join("; "))?;
        }
        if let Some((measured, settings)) = &self.measured {
            writeln!(f, "\n{}", measured_table(measured, *settings).trim_end())?;
        }
        Ok(())
    }
}

impl Report for MarginsReport {}

/// The margins of `scenario`'s wheel loop; with `measure`, also measured with sines of
/// `amplitude_v` (V).
pub fn run(scenario: &str, measure: bool, amplitude_v: f64) -> Result<MarginsReport> {
    let scenario = load(scenario)?;
    check_amplitude(amplitude_v)?;
    let cases = model_cases(&scenario)?;
    let measured = if measure {
        let settings = SweepSettings {
            amplitude_v,
            ..SweepSettings::default_for(&scenario)
        };
        Some((measure_cases(&scenario, settings)?, settings))
    } else {
        None
    };
    Ok(MarginsReport {
        scenario,
        cases,
        measured,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_amplitude_must_be_positive_and_at_most_two_volts() {
        assert_eq!(check_amplitude(0.5), Ok(()));
        assert_eq!(check_amplitude(MAX_AMPLITUDE_V), Ok(()));
        let refused = Err(Failed("--amplitude-v must be in (0, 2]".into()));
        assert_eq!(check_amplitude(0.0), refused);
        assert_eq!(check_amplitude(-0.5), refused);
        assert_eq!(check_amplitude(2.01), refused);
        assert_eq!(check_amplitude(f64::NAN), refused);
    }
}
