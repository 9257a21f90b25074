//! The arithmetic of the first-flash programs (the firmware's `examples/`: `encoders`,
//! `motors`, `supply`), here so that the host tests it: how far a motor test pulse may
//! go, what the encoder's answer to it means, a wheel's speed from its counts, and the
//! supply divider's scale corrected by a multimeter.
//!
//! The `motors` pulse is bounded twice over: at most [`PULSE_MAX_V`] across the motor,
//! as a duty of the supply measured just before it ([`pulse_duty`]), and at most
//! [`PULSE_MAX_MS`] long ([`pulse_steps`]). No pulse is planned on a supply that is
//! unmeasured, below [`PULSE_MIN_SUPPLY_V`] or above the bridge's rating.

use core::f32::consts::TAU;
use core::fmt;

/// The most a test pulse puts across a motor, V.
pub const PULSE_MAX_V: f32 = 2.0;
/// The longest test pulse, ms.
pub const PULSE_MAX_MS: u32 = 300;
/// The lowest measured supply a pulse is planned on, V: below it the bridge is probably
/// unpowered or the divider unwired, and the duty for [`PULSE_MAX_V`] would be large.
pub const PULSE_MIN_SUPPLY_V: f32 = 3.0;
/// A wheel that moved less than this share of a turn during a pulse did not answer.
pub const NO_MOTION_TURNS: f32 = 0.01;

/// Why no pulse is planned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PulseError {
    /// The supply reading is not a number (no conversion yet, or the ADC failed).
    SupplyNotMeasured,
    /// The measured supply, V, is below [`PULSE_MIN_SUPPLY_V`].
    SupplyTooLow(f32),
    /// The measured supply, V, is above the bridge's rating (the second field, V).
    SupplyAboveBridge(f32, f32),
}

impl fmt::Display for PulseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            PulseError::SupplyNotMeasured => write!(f, "the supply is not measured"),
            PulseError::SupplyTooLow(v) => write!(
                f,
                "the supply reads {v:.2} V, below {PULSE_MIN_SUPPLY_V} V: is the bridge powered?"
            ),
            PulseError::SupplyAboveBridge(v, max) => write!(
                f,
                "the supply reads {v:.2} V, above the bridge's {max:.1} V rating"
            ),
        }
    }
}

impl core::error::Error for PulseError {}

/// The duty (0…1) that puts `volts` across a motor on the measured `supply_v`, with
/// `volts` capped to [`PULSE_MAX_V`] (negative taken as 0) and the result to 1.
/// `bridge_max_v` is the bridge's supply rating, V.
pub fn pulse_duty(supply_v: f32, volts: f32, bridge_max_v: f32) -> Result<f32, PulseError> {
    if !supply_v.is_finite() {
        return Err(PulseError::SupplyNotMeasured);
    }
    if supply_v < PULSE_MIN_SUPPLY_V {
        return Err(PulseError::SupplyTooLow(supply_v));
    }
    if supply_v > bridge_max_v {
        return Err(PulseError::SupplyAboveBridge(supply_v, bridge_max_v));
    }
    let volts = if volts.is_finite() {
        volts.clamp(0.0, PULSE_MAX_V)
    } else {
        0.0
    };
    Ok((volts / supply_v).min(1.0))
}

/// Control steps a pulse of `duration_ms` lasts at `control_rate_hz`, with the duration
/// capped to [`PULSE_MAX_MS`] (rounded down: never longer than asked).
pub const fn pulse_steps(duration_ms: u32, control_rate_hz: u32) -> u32 {
    let ms = if duration_ms < PULSE_MAX_MS {
        duration_ms
    } else {
        PULSE_MAX_MS
    };
    (ms as u64 * control_rate_hz as u64 / 1000) as u32
}

/// What a wheel's encoder did during a pulse that should have turned it forward.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncoderAnswer {
    /// It counted forward: motor and encoder agree with the configured polarity.
    Forward,
    /// It counted backward: the motor or the encoder is inverted (not both).
    Backward,
    /// It moved less than [`NO_MOTION_TURNS`] of a turn: motor, bridge or encoder not
    /// wired, or the wheel blocked.
    NoMotion,
}

impl EncoderAnswer {
    /// The answer of `counts` (forward positive) to a pulse commanded in the direction
    /// `forward`, for an encoder of `ticks_per_turn` counts per wheel turn.
    pub fn of(counts: i32, forward: bool, ticks_per_turn: f32) -> EncoderAnswer {
        let moved = if forward { counts } else { -counts };
        if (moved.unsigned_abs() as f32) < NO_MOTION_TURNS * ticks_per_turn {
            EncoderAnswer::NoMotion
        } else if moved > 0 {
            EncoderAnswer::Forward
        } else {
            EncoderAnswer::Backward
        }
    }

    /// A short name for logs.
    pub const fn name(self) -> &'static str {
        match self {
            EncoderAnswer::Forward => "as commanded",
            EncoderAnswer::Backward => "REVERSED",
            EncoderAnswer::NoMotion => "NO MOTION",
        }
    }
}

/// A wheel's speed, rad/s, from `counts` (forward positive) over `window_s` seconds, for
/// `ticks_per_turn` counts per wheel turn; 0 for an empty window.
pub fn wheel_speed_rad_s(counts: i32, ticks_per_turn: f32, window_s: f32) -> f32 {
    if window_s > 0.0 && ticks_per_turn > 0.0 {
        counts as f32 / ticks_per_turn * TAU / window_s
    } else {
        0.0
    }
}

/// Why no corrected scale is computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScaleError {
    /// The measured voltage, V, is not a positive number.
    Measured(f32),
    /// The multimeter's figure, V, is not a positive number.
    Multimeter(f32),
}

impl fmt::Display for ScaleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ScaleError::Measured(v) => write!(f, "the measured supply {v} V is not positive"),
            ScaleError::Multimeter(v) => write!(f, "the multimeter figure {v} V is not positive"),
        }
    }
}

impl core::error::Error for ScaleError {}

/// The supply divider's scale (supply volts per volt at the ADC pin) that makes the
/// reading agree with a multimeter: `scale` × `multimeter_v` / `measured_v`.
pub fn corrected_scale(scale: f32, measured_v: f32, multimeter_v: f32) -> Result<f32, ScaleError> {
    if !(measured_v.is_finite() && measured_v > 0.0) {
        return Err(ScaleError::Measured(measured_v));
    }
    if !(multimeter_v.is_finite() && multimeter_v > 0.0) {
        return Err(ScaleError::Multimeter(multimeter_v));
    }
    Ok(scale * multimeter_v / measured_v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The TB6612FNG's rating, V.
    const TB6612_V: f32 = 13.5;

    #[test]
    fn a_pulse_never_exceeds_its_voltage_on_any_supply() {
        for supply in [3.0f32, 4.8, 7.4, 8.4, 11.1, 12.6, 13.5] {
            for asked in [0.5f32, 2.0, 3.0, 100.0, f32::INFINITY] {
                let duty = pulse_duty(supply, asked, TB6612_V).unwrap();
                assert!((0.0..=1.0).contains(&duty));
                assert!(duty * supply <= PULSE_MAX_V + 1e-5, "{supply} V, {asked} V");
            }
        }
        // 2 V on a 8 V pack is a quarter duty; 1 V an eighth.
        assert!((pulse_duty(8.0, 2.0, TB6612_V).unwrap() - 0.25).abs() < 1e-6);
        assert!((pulse_duty(8.0, 1.0, TB6612_V).unwrap() - 0.125).abs() < 1e-6);
        // A negative or NaN request is no pulse, not a reverse one.
        assert_eq!(pulse_duty(8.0, -2.0, TB6612_V), Ok(0.0));
        assert_eq!(pulse_duty(8.0, f32::NAN, TB6612_V), Ok(0.0));
    }

    #[test]
    fn no_pulse_on_an_unmeasured_low_or_excessive_supply() {
        assert_eq!(
            pulse_duty(f32::NAN, 2.0, TB6612_V),
            Err(PulseError::SupplyNotMeasured)
        );
        assert_eq!(
            pulse_duty(0.4, 2.0, TB6612_V),
            Err(PulseError::SupplyTooLow(0.4))
        );
        // A 3S pack at full charge on a DRV8833 (10.8 V).
        assert_eq!(
            pulse_duty(12.6, 2.0, 10.8),
            Err(PulseError::SupplyAboveBridge(12.6, 10.8))
        );
    }

    #[test]
    fn a_pulse_lasts_at_most_its_bound() {
        assert_eq!(pulse_steps(200, 1000), 200);
        assert_eq!(pulse_steps(300, 1000), 300);
        assert_eq!(pulse_steps(5_000, 1000), 300);
        assert_eq!(pulse_steps(u32::MAX, 1000), 300);
        assert_eq!(pulse_steps(300, 500), 150);
    }

    #[test]
    fn the_encoder_answer_tells_sign_and_silence() {
        let turn = 1440.0;
        assert_eq!(EncoderAnswer::of(200, true, turn), EncoderAnswer::Forward);
        assert_eq!(EncoderAnswer::of(-200, true, turn), EncoderAnswer::Backward);
        // A reverse pulse that counts down is as commanded.
        assert_eq!(EncoderAnswer::of(-200, false, turn), EncoderAnswer::Forward);
        assert_eq!(EncoderAnswer::of(200, false, turn), EncoderAnswer::Backward);
        // 14.4 counts is 1 % of the turn: 14 is no motion, 15 is.
        assert_eq!(EncoderAnswer::of(14, true, turn), EncoderAnswer::NoMotion);
        assert_eq!(EncoderAnswer::of(-14, true, turn), EncoderAnswer::NoMotion);
        assert_eq!(EncoderAnswer::of(15, true, turn), EncoderAnswer::Forward);
        assert_eq!(
            EncoderAnswer::of(i32::MIN, true, turn),
            EncoderAnswer::Backward
        );
    }

    #[test]
    fn wheel_speed_from_counts() {
        // One turn in one second is 2π rad/s; half a turn backwards in 0.25 s is −4π.
        assert!((wheel_speed_rad_s(1440, 1440.0, 1.0) - TAU).abs() < 1e-5);
        assert!((wheel_speed_rad_s(-720, 1440.0, 0.25) + 2.0 * TAU).abs() < 1e-4);
        assert_eq!(wheel_speed_rad_s(100, 1440.0, 0.0), 0.0);
        assert_eq!(wheel_speed_rad_s(100, 0.0, 1.0), 0.0);
    }

    #[test]
    fn the_corrected_scale_makes_the_reading_the_multimeters() {
        // The reference divider (39 k over 10 k): 4.9 V per V. It reads 7.8 V where the
        // multimeter shows 8.0 V: the scale grows by 8.0 / 7.8.
        let scale = 4.9;
        let corrected = corrected_scale(scale, 7.8, 8.0).unwrap();
        assert!((corrected - 4.9 * 8.0 / 7.8).abs() < 1e-5);
        // The same pin voltage read with the corrected scale is the multimeter's.
        let pin_v = 7.8 / scale;
        assert!((pin_v * corrected - 8.0).abs() < 1e-5);
        assert_eq!(
            corrected_scale(scale, 0.0, 8.0),
            Err(ScaleError::Measured(0.0))
        );
        assert_eq!(
            corrected_scale(scale, 7.8, -1.0),
            Err(ScaleError::Multimeter(-1.0))
        );
    }
}
