//! Step 3: the supply. The robot's reading against the user's multimeter gives the
//! divider's scale (`wiring.supply_scale`), which the robot multiplies its board's
//! reading by.

use super::signals::{next_frame, Heard};
use super::{BringupError, Finding, Session};
use crate::ops;
use crate::transport::Transport;

/// Telemetry frames averaged for the robot's reading.
const FRAMES: usize = 25;
/// A scale within this of the present one is left alone (the multimeter's own error).
const TOLERANCE: f64 = 0.005;

/// The scale that makes a robot reading `robot_v` (V, at scale `scale_now`) read
/// `meter_v` (V).
pub fn corrected_scale(scale_now: f64, robot_v: f64, meter_v: f64) -> f64 {
    scale_now * meter_v / robot_v
}

/// Runs the step.
pub fn run<T: Transport>(s: &mut Session<'_, T>) -> Result<Finding, BringupError> {
    let current = ops::get_params(s.client)?;
    let meter_v = s.answers.number(
        s.out,
        "measure the battery's voltage at the robot with a multimeter: what does it read, V?",
    )?;
    let mut heard = Heard::default();
    let mut sum = 0.0;
    for _ in 0..FRAMES {
        sum += f64::from(next_frame(s.client, &mut heard)?.supply_v);
    }
    let robot_v = sum / FRAMES as f64;
    if !(robot_v.is_finite() && robot_v > 0.5) {
        return Err(BringupError::Found(format!(
            "the robot reads {robot_v:.2} V: check the divider's wiring to the ADC pin"
        )));
    }
    if !(meter_v > 0.5 && meter_v < 30.0) {
        return Err(BringupError::Answers(format!(
            "{meter_v} V is not a battery's voltage"
        )));
    }
    let now = f64::from(current.robot.wiring.supply_scale);
    let scale = corrected_scale(now, robot_v, meter_v);
    let text = format!("the robot reads {robot_v:.3} V, the multimeter {meter_v:.3} V");
    if (scale / now - 1.0).abs() <= TOLERANCE {
        return Ok(Finding::only(format!("{text}: the scale {now} stays")));
    }
    let mut learned = current;
    learned.robot.wiring.supply_scale = ((scale * 10_000.0).round() / 10_000.0) as f32;
    Ok(Finding {
        summary: format!(
            "{text}: supply scale {} (was {now})",
            learned.robot.wiring.supply_scale
        ),
        learned: Some(learned),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_board_that_reads_high_gets_a_scale_below_one() {
        // A divider reading 10 % high: 8.14 V for 7.4 V.
        let scale = corrected_scale(1.0, 8.14, 7.4);
        assert!((scale - 1.0 / 1.1).abs() < 1e-6, "{scale}");
        // Measured again with that scale, the reading matches: the scale stays.
        assert!((corrected_scale(scale, 7.4, 7.4) - scale).abs() < 1e-12);
    }
}
