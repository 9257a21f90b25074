//! Step 3: the supply. First the battery against the robot's motor bridge: one above the
//! bridge's rating stops the bring-up with the word to unplug it (the bridge's supply pin
//! is the battery, armed or not). Then the robot's reading against the user's multimeter
//! gives the divider's scale (`wiring.supply_scale`), which the robot multiplies its
//! board's reading by.

use link::BridgeChip;

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

/// Why a battery of `meter_v` (V, the multimeter's reading) must not stay connected to
/// `bridge`, if it must not: above the bridge's operating rating.
pub fn over_rating(bridge: BridgeChip, meter_v: f64) -> Option<String> {
    (meter_v > f64::from(bridge.max_supply_v())).then(|| {
        format!(
            "the battery reads {meter_v:.2} V, above the {}'s {} V rating ({} V absolute \
             maximum): unplug the battery now. The bridge's supply pin is the battery whether \
             or not the robot arms, so refusing to arm does not protect it. {bridge}.",
            bridge.name(),
            bridge.max_supply_v(),
            bridge.absolute_max_v(),
        )
    })
}

/// Runs the step.
pub fn run<T: Transport>(s: &mut Session<'_, T>) -> Result<Finding, BringupError> {
    let bridge = ops::info(s.client)?.bridge;
    let current = ops::get_params(s.client)?;
    let meter_v = s.answers.number(
        s.out,
        "measure the battery's voltage at the robot with a multimeter: what does it read, V?",
    )?;
    if !(meter_v > 0.5 && meter_v < 30.0) {
        return Err(BringupError::Answers(format!(
            "{meter_v} V is not a battery's voltage"
        )));
    }
    if let Some(why) = over_rating(bridge, meter_v) {
        return Err(BringupError::Found(why));
    }
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
    fn a_battery_above_the_bridges_rating_is_to_be_unplugged() {
        // A full 3S pack (12.6 V) on a DRV8833 is above even its 11.8 V absolute maximum.
        let why = over_rating(BridgeChip::Drv8833, 12.6).expect("refused");
        assert!(why.starts_with("the battery reads 12.60 V, above the DRV8833's 10.8 V rating (11.8 V absolute maximum): unplug the battery now."), "{why}");
        assert!(
            why.ends_with("DRV8833: 2S Li-ion (8.4 V full) at most."),
            "{why}"
        );
        // Just above the rating, below the absolute maximum: refused all the same.
        assert!(over_rating(BridgeChip::Drv8833, 10.81).is_some());
        // At the rating, a full 2S pack, and a full 3S pack on the TB6612FNG: fine.
        assert_eq!(over_rating(BridgeChip::Drv8833, 10.8), None);
        assert_eq!(over_rating(BridgeChip::Drv8833, 8.4), None);
        assert_eq!(over_rating(BridgeChip::Tb6612fng, 12.6), None);
        assert!(over_rating(BridgeChip::Tb6612fng, 14.0).is_some());
    }

    #[test]
    fn the_hardware_pages_say_which_batteries_each_bridge_takes() {
        // The sentence `BridgeChip` prints, on every page that lists bridges or batteries.
        let pages = [
            (
                "docs/hardware.md",
                include_str!("../../../docs/hardware.md"),
            ),
            (
                "docs/first-flash.md",
                include_str!("../../../docs/first-flash.md"),
            ),
            (
                "docs/bring-up.md",
                include_str!("../../../docs/bring-up.md"),
            ),
        ];
        for (name, page) in pages {
            for bridge in BridgeChip::ALL {
                let sentence = bridge.to_string();
                assert!(
                    page.contains(&sentence),
                    "{name} does not say \"{sentence}\""
                );
            }
        }
    }

    #[test]
    fn a_board_that_reads_high_gets_a_scale_below_one() {
        // A divider reading 10 % high: 8.14 V for 7.4 V.
        let scale = corrected_scale(1.0, 8.14, 7.4);
        assert!((scale - 1.0 / 1.1).abs() < 1e-6, "{scale}");
        // Measured again with that scale, the reading matches: the scale stays.
        assert!((corrected_scale(scale, 7.4, 7.4) - scale).abs() < 1e-12);
    }
}
