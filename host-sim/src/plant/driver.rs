//! The H-bridge between the PWM timer and the motor: which chip, how a duty becomes an
//! armature voltage, and what the bridge does when it is not driving.
//!
//! ## Slow decay, averaged
//!
//! Both supported drivers run in slow decay (drive/brake PWM). For a forward duty d the
//! bridge alternates between *drive* (supply across the armature through one high-side
//! and one low-side switch) for a fraction d of each PWM period and *short brake* (both
//! armature leads on the low-side switches) for the rest:
//!
//! - TB6612FNG: IN1/IN2 set the direction, PWMx low = short brake;
//! - DRV8833: forward IN1 = 1 with IN2 = PWM (IN2 high = both high = brake), reverse
//!   mirrored.
//!
//! At 20 kHz the PWM period (50 µs) is far below the armature's electrical time constant
//! (L/R ≈ 0.25 ms) and the mechanics (60–80 ms), so the bridge is modelled by its
//! average: the armature sees u = d · V_s through the bridge's switch resistance, which is
//! the same in both phases (one high-side + one low-side switch while driving, two
//! low-side switches while braking; the datasheets quote high + low side, and the two
//! sides are close). d = 0 is therefore a full-time short brake (u = 0, current −e/R),
//! not a coast. This average is exact for slow decay; fast decay (the other half-bridge
//! held low, current recirculating through the supply) would not be linear in d.
//!
//! ## Coast
//!
//! With the driver disabled (TB6612 STBY low, DRV8833 nSLEEP low) or a motor lead
//! disconnected, the bridge is high impedance and no armature current flows: only
//! friction slows the wheel. (The switches' body diodes would conduct if the back-EMF
//! exceeded V_s plus two diode drops, about V_s + 1.4 V; the default motor's back-EMF at
//! its no-load speed is 5.4 V on a 6 V supply, so this regeneration is not modelled.)
//!
//! ## PWM quantisation
//!
//! The firmware's TIM3 runs from the 100 MHz APB1 timer clock (APB1 = 50 MHz, doubled for
//! the timers) at 20 kHz: stm32f4xx-hal 0.23's `pwm_hz` sets prescaler 0 and auto-reload
//! 4 999, and `max_duty_cycle()` returns ARR + 1 = 5 000, the compare value of a 100 %
//! duty. The firmware writes `(|d| · 5000 + 0.5) as u16` computed in `f32` (0 for
//! |d| ≤ 0 or NaN, 5 000 for |d| ≥ 1), and [`compare_value`] does the same
//! arithmetic, so the simulated duty is exactly the one the timer produces. (On an
//! STM32F401 at 84 MHz the same code gives 4 200 levels.)

use robot_files::plant::DriverParams;

/// The compare value the firmware writes for a commanded `duty` (any f32) on `driver`:
/// |duty| scaled to its `pwm_levels`, rounded half up in `f32` exactly as the firmware's
/// `motor::compare_value` does; 0 for |duty| = 0 or NaN, `pwm_levels` for |duty| ≥ 1.
pub fn compare_value(driver: &DriverParams, duty: f32) -> u32 {
    let magnitude = if duty >= 0.0 { duty } else { -duty };
    let levels = driver.pwm_levels.max(1);
    if magnitude >= 1.0 {
        levels
    } else if magnitude > 0.0 {
        // f32 arithmetic as on the target; `as` saturates, and the product is below
        // `levels` + 0.5 here.
        (magnitude * levels as f32 + 0.5) as u32
    } else {
        0
    }
}

/// The duty `driver` actually applies for a commanded `duty` (any f32, even NaN): the
/// firmware's compare value ([`compare_value`]) over `pwm_levels`, with the command's
/// sign, zeroed in the dead-band. In [−1, 1].
pub fn applied_duty(driver: &DriverParams, duty: f32) -> f64 {
    let q = f64::from(compare_value(driver, duty)) / f64::from(driver.pwm_levels.max(1));
    if q < driver.dead_band_duty || q == 0.0 {
        0.0
    } else if duty < 0.0 {
        -q
    } else {
        q
    }
}

/// Averaged armature voltage (before the bridge's resistance) for an applied duty (from
/// [`applied_duty`]) at supply `supply_v`, V.
pub fn voltage_v(applied_duty: f64, supply_v: f64) -> f64 {
    applied_duty * supply_v
}

/// What one wheel's bridge applies to its motor for the next plant steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BridgeOutput {
    /// Driven in slow decay: averaged armature voltage u = d · V_s, V, behind the bridge's
    /// on-resistance. 0 V is a short brake.
    Drive {
        /// u, V.
        volts: f64,
    },
    /// High impedance (driver disabled or motor disconnected): no armature current.
    Coast,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The firmware's `compare_value` (firmware/src/motor.rs), restated for a `u32`
    /// maximum: the reference the plant must match.
    fn firmware_compare(duty: f32, max: u32) -> u32 {
        let magnitude = if duty >= 0.0 { duty } else { -duty };
        if magnitude >= 1.0 {
            max
        } else if magnitude > 0.0 {
            (magnitude * max as f32 + 0.5) as u32
        } else {
            0
        }
    }

    #[test]
    fn quantisation_matches_the_firmware_rounding() {
        let drv = DriverParams {
            dead_band_duty: 0.0,
            ..DriverParams::DEFAULT
        };
        let levels = drv.pwm_levels;
        // Every level's own duty maps back to it, and the half-way points round up.
        for k in 0..=levels {
            let exact = k as f32 / levels as f32;
            assert_eq!(compare_value(&drv, exact), k, "{k}");
            assert_eq!(compare_value(&drv, -exact), k, "-{k}");
            let below_half = (k as f32 + 0.45) / levels as f32;
            let above_half = (k as f32 + 0.55) / levels as f32;
            if k < levels {
                assert_eq!(compare_value(&drv, below_half), k, "{k} + 0.45");
                assert_eq!(compare_value(&drv, above_half), k + 1, "{k} + 0.55");
            }
            assert_eq!(
                applied_duty(&drv, -exact),
                -f64::from(k) / f64::from(levels),
                "{k}"
            );
        }
        // The rounding happens in f32, as on the target: just below a half-way point the
        // f32 product can round up to it where f64 arithmetic would not. Find such duties
        // and check the plant follows f32.
        let mut differing = 0;
        for k in 0..levels {
            let mut d = (k as f32 + 0.5) / levels as f32;
            for _ in 0..4 {
                d = f32::from_bits(d.to_bits() - 1);
                let f64_round = (f64::from(d) * f64::from(levels) + 0.5).floor() as u32;
                let firmware = firmware_compare(d, levels);
                assert_eq!(compare_value(&drv, d), firmware, "{d}");
                if firmware != f64_round {
                    differing += 1;
                }
            }
        }
        assert!(differing > 0, "no duty where f32 and f64 rounding differ");
        // Saturation, zero and NaN.
        assert_eq!(compare_value(&drv, 1.7), levels);
        assert_eq!(compare_value(&drv, -1.0), levels);
        assert_eq!(compare_value(&drv, 0.0), 0);
        assert_eq!(compare_value(&drv, f32::NAN), 0);
        assert_eq!(applied_duty(&drv, f32::NAN), 0.0);
        assert_eq!(applied_duty(&drv, f32::INFINITY), 1.0);
        assert_eq!(applied_duty(&drv, f32::NEG_INFINITY), -1.0);
    }

    #[test]
    fn dead_band_gives_zero_volts() {
        let drv = DriverParams::DEFAULT;
        // 0.015 → 75 / 5000 = 1.5 % < 2 %: braked.
        assert_eq!(applied_duty(&drv, -0.015), 0.0);
        assert_eq!(applied_duty(&drv, 0.019), 0.0);
        assert_eq!(applied_duty(&drv, 0.02), 0.02);
        assert_eq!(applied_duty(&drv, 0.12345), 617.0 / 5000.0);
        assert_eq!(voltage_v(-0.5, 6.0), -3.0);
    }
}
