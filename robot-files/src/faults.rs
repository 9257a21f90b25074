//! Faults injected into a simulated run, on a timeline: the scenario's `[[faults]]` array.
//!
//! ```toml
//! [[faults]]
//! at_s = 12.0                  # when, s from the start
//! kind = "encoder-disconnect"  # see FaultKind
//! wheel = "left"               # for the per-wheel kinds
//! duration_s = 1.0             # for the kinds that end (slip-patch, supply-sag, …)
//! ```
//!
//! | `kind` | what happens | extra keys |
//! |---|---|---|
//! | `encoder-disconnect` | the wheel's counts freeze | `wheel` |
//! | `encoder-glitch` | one read jumps by `ticks` | `wheel`, `ticks` (default 1000) |
//! | `encoders-swapped` | the two encoder cables are exchanged | |
//! | `motor-disconnect` | the wheel's motor lead opens (it coasts) | `wheel` |
//! | `wheel-blocked` | the wheel is held (`duration_s`, default to the end) | `wheel`, `duration_s` |
//! | `slip-patch` | the wheel slips for `duration_s` | `wheel`, `slip` (0…1), `duration_s` |
//! | `supply-sag` | the battery sags to `supply_v` for `duration_s` | `supply_v`, `duration_s` |
//! | `late-steps` | `count` control steps start `late_periods` − 1 periods late | `count`, `late_periods` |
//! | `button-press` | the arm button is held for `duration_s` | `duration_s` (default 0.1) |
//! | `track-width-error` | the true track differs by `error_pct` (odometry cannot see it) | `error_pct` |
//! | `both-inverted` | a wheel's motor and encoder are both inverted (odometry cannot see it) | `wheel` |
//! | `ticks-lost` | the wheel's encoder loses `fraction` of its ticks (odometry cannot see it) | `wheel`, `fraction` (0…1, default 0.1) |
//! | `gyro-stuck` | the gyro repeats the reading it gave when the fault began | `duration_s` (default to the end) |
//! | `gyro-absent` | the gyro stops answering | `duration_s` (default to the end) |
//! | `gyro-saturated` | the gyro reads its full scale | `duration_s` (default to the end) |
//!
//! Every detector the supervisor runs sees only what the firmware sees (ticks, voltages,
//! the step count, the supply measurement, the gyro's readings); the simulator's truth is
//! used only to report what the fault did.

use serde::Deserialize;

pub use crate::plant::Wheel;

/// How a scenario names a wheel.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum WheelName {
    Left,
    Right,
}

impl From<WheelName> for Wheel {
    fn from(name: WheelName) -> Self {
        match name {
            WheelName::Left => Wheel::Left,
            WheelName::Right => Wheel::Right,
        }
    }
}

/// What goes wrong (see the module doc's table).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FaultKind {
    /// The wheel's encoder counts freeze.
    EncoderDisconnect(Wheel),
    /// One encoder read jumps by this many ticks.
    EncoderGlitch(Wheel, i32),
    /// The left and right encoder cables are exchanged.
    EncodersSwapped,
    /// The wheel's motor lead opens.
    MotorDisconnect(Wheel),
    /// The wheel is held still.
    WheelBlocked(Wheel),
    /// The wheel slips with this slip ratio (0…1).
    SlipPatch(Wheel, f64),
    /// The battery sags to this voltage, V.
    SupplySag(f64),
    /// This many control steps each start late and cover this many periods.
    LateSteps {
        /// Late steps.
        count: u32,
        /// Periods each covers (≥ 2).
        periods: u32,
    },
    /// The arm button is held.
    ButtonPress,
    /// The true track width differs from the believed one by this many percent.
    TrackWidthError(f64),
    /// The wheel's motor and encoder are both inverted.
    BothInverted(Wheel),
    /// The wheel's encoder loses this fraction (0…1) of its ticks.
    TicksLost(Wheel, f64),
    /// The gyro repeats the reading it gave when the fault began.
    GyroStuck,
    /// The gyro gives no reading.
    GyroAbsent,
    /// The gyro reads its full scale.
    GyroSaturated,
}

impl FaultKind {
    /// The kind's name as written in a scenario (`encoder-disconnect`, …).
    pub const fn name(&self) -> &'static str {
        match self {
            FaultKind::EncoderDisconnect(_) => "encoder-disconnect",
            FaultKind::EncoderGlitch(..) => "encoder-glitch",
            FaultKind::EncodersSwapped => "encoders-swapped",
            FaultKind::MotorDisconnect(_) => "motor-disconnect",
            FaultKind::WheelBlocked(_) => "wheel-blocked",
            FaultKind::SlipPatch(..) => "slip-patch",
            FaultKind::SupplySag(_) => "supply-sag",
            FaultKind::LateSteps { .. } => "late-steps",
            FaultKind::ButtonPress => "button-press",
            FaultKind::TrackWidthError(_) => "track-width-error",
            FaultKind::BothInverted(_) => "both-inverted",
            FaultKind::TicksLost(..) => "ticks-lost",
            FaultKind::GyroStuck => "gyro-stuck",
            FaultKind::GyroAbsent => "gyro-absent",
            FaultKind::GyroSaturated => "gyro-saturated",
        }
    }
}

/// One injected fault.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fault {
    /// What goes wrong.
    pub kind: FaultKind,
    /// When it starts, control steps from the start of the run.
    pub at_step: u64,
    /// How long it lasts, control steps (`None`: to the end).
    pub duration_steps: Option<u64>,
}

impl Fault {
    /// True while the fault is in effect at control step `step`.
    pub fn active_at(&self, step: u64) -> bool {
        step >= self.at_step
            && self
                .duration_steps
                .is_none_or(|d| step < self.at_step.saturating_add(d))
    }
}

/// A `[[faults]]` entry as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct FaultEntry {
    at_s: f64,
    kind: String,
    wheel: Option<WheelName>,
    duration_s: Option<f64>,
    ticks: Option<i32>,
    slip: Option<f64>,
    supply_v: Option<f64>,
    count: Option<u32>,
    late_periods: Option<u32>,
    error_pct: Option<f64>,
    fraction: Option<f64>,
}

/// Why a `[[faults]]` entry was rejected: the key (`faults[2].wheel`) and the problem.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct FaultError {
    pub(crate) key: String,
    pub(crate) problem: String,
}

impl FaultEntry {
    /// The fault at `index` of the array, for a loop at `rate_hz`.
    pub(crate) fn build(&self, index: usize, rate_hz: u32) -> Result<Fault, FaultError> {
        let key = |k: &str| format!("faults[{index}].{k}");
        let err = |k: &str, problem: String| FaultError {
            key: key(k),
            problem,
        };
        let steps = |k: &str, s: f64| -> Result<u64, FaultError> {
            if (0.0..1e7).contains(&s) {
                Ok((s * f64::from(rate_hz)).round() as u64)
            } else {
                Err(err(k, format!("must be a time ≥ 0 s, got {s}")))
            }
        };
        let wheel = || {
            self.wheel
                .map(Wheel::from)
                .ok_or_else(|| err("wheel", format!("is required for kind = \"{}\"", self.kind)))
        };
        let at_step = steps("at_s", self.at_s)?;
        let mut duration_steps = match self.duration_s {
            Some(d) => Some(steps("duration_s", d)?.max(1)),
            None => None,
        };
        let kind = match self.kind.as_str() {
            "encoder-disconnect" => FaultKind::EncoderDisconnect(wheel()?),
            "encoder-glitch" => {
                duration_steps = Some(1);
                FaultKind::EncoderGlitch(wheel()?, self.ticks.unwrap_or(1000))
            }
            "encoders-swapped" => FaultKind::EncodersSwapped,
            "motor-disconnect" => FaultKind::MotorDisconnect(wheel()?),
            "wheel-blocked" => FaultKind::WheelBlocked(wheel()?),
            "slip-patch" => {
                let slip = self.slip.unwrap_or(0.3);
                if !(0.0..1.0).contains(&slip) {
                    return Err(err("slip", format!("must be in [0, 1), got {slip}")));
                }
                FaultKind::SlipPatch(wheel()?, slip)
            }
            "supply-sag" => {
                let v = self.supply_v.ok_or_else(|| {
                    err("supply_v", "is required for kind = \"supply-sag\"".into())
                })?;
                if !(v.is_finite() && v > 0.0) {
                    return Err(err("supply_v", format!("must be > 0 V, got {v}")));
                }
                FaultKind::SupplySag(v)
            }
            "late-steps" => {
                let periods = self.late_periods.unwrap_or(2);
                if periods < 2 {
                    return Err(err("late_periods", format!("must be ≥ 2, got {periods}")));
                }
                FaultKind::LateSteps {
                    count: self.count.unwrap_or(1).max(1),
                    periods,
                }
            }
            "button-press" => {
                duration_steps = Some(duration_steps.unwrap_or(u64::from(rate_hz) / 10).max(1));
                FaultKind::ButtonPress
            }
            "track-width-error" => {
                let pct = self.error_pct.unwrap_or(2.0);
                if !(pct.is_finite() && pct > -50.0 && pct < 100.0) {
                    return Err(err(
                        "error_pct",
                        format!("must be in (−50, 100) %, got {pct}"),
                    ));
                }
                FaultKind::TrackWidthError(pct)
            }
            "both-inverted" => FaultKind::BothInverted(wheel()?),
            "ticks-lost" => {
                let fraction = self.fraction.unwrap_or(0.1);
                if !(0.0..=1.0).contains(&fraction) {
                    return Err(err(
                        "fraction",
                        format!("must be in [0, 1], got {fraction}"),
                    ));
                }
                FaultKind::TicksLost(wheel()?, fraction)
            }
            "gyro-stuck" => FaultKind::GyroStuck,
            "gyro-absent" => FaultKind::GyroAbsent,
            "gyro-saturated" => FaultKind::GyroSaturated,
            other => {
                return Err(err(
                    "kind",
                    format!(
                        "must be one of encoder-disconnect, encoder-glitch, encoders-swapped, \
                         motor-disconnect, wheel-blocked, slip-patch, supply-sag, late-steps, \
                         button-press, track-width-error, both-inverted, ticks-lost, \
                         gyro-stuck, gyro-absent, gyro-saturated; got \"{other}\""
                    ),
                ))
            }
        };
        Ok(Fault {
            kind,
            at_step,
            duration_steps,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(toml_text: &str) -> FaultEntry {
        toml::from_str(toml_text).unwrap()
    }

    #[test]
    fn entries_become_faults_in_control_steps() {
        let f = entry("at_s = 2.5\nkind = \"slip-patch\"\nwheel = \"right\"\nduration_s = 0.2\n")
            .build(0, 1000)
            .unwrap();
        assert_eq!(f.kind, FaultKind::SlipPatch(Wheel::Right, 0.3));
        assert_eq!(f.at_step, 2500);
        assert_eq!(f.duration_steps, Some(200));
        assert!(!f.active_at(2499) && f.active_at(2500) && f.active_at(2699));
        assert!(!f.active_at(2700));
        let forever = entry("at_s = 1\nkind = \"encoder-disconnect\"\nwheel = \"left\"\n")
            .build(0, 1000)
            .unwrap();
        assert!(forever.active_at(u64::MAX));
        let glitch = entry("at_s = 1\nkind = \"encoder-glitch\"\nwheel = \"left\"\n")
            .build(0, 1000)
            .unwrap();
        assert_eq!(glitch.duration_steps, Some(1));
        let lost = entry("at_s = 1\nkind = \"ticks-lost\"\nwheel = \"right\"\n")
            .build(0, 1000)
            .unwrap();
        assert_eq!(lost.kind, FaultKind::TicksLost(Wheel::Right, 0.1));
        let stuck = entry("at_s = 1\nkind = \"gyro-stuck\"\nduration_s = 2\n")
            .build(0, 1000)
            .unwrap();
        assert_eq!(stuck.kind, FaultKind::GyroStuck);
        assert_eq!(stuck.duration_steps, Some(2000));
    }

    #[test]
    fn errors_name_the_entry_and_key() {
        let e = entry("at_s = 1\nkind = \"motor-disconnect\"\n")
            .build(3, 1000)
            .unwrap_err();
        assert_eq!(e.key, "faults[3].wheel");
        let e = entry("at_s = -1\nkind = \"encoders-swapped\"\n")
            .build(0, 1000)
            .unwrap_err();
        assert_eq!(e.key, "faults[0].at_s");
        let e = entry("at_s = 1\nkind = \"gremlins\"\n")
            .build(1, 1000)
            .unwrap_err();
        assert_eq!(e.key, "faults[1].kind");
        assert!(e.problem.contains("\"gremlins\""));
        let e = entry("at_s = 1\nkind = \"late-steps\"\nlate_periods = 1\n")
            .build(0, 1000)
            .unwrap_err();
        assert_eq!(e.key, "faults[0].late_periods");
        let e = entry("at_s = 1\nkind = \"ticks-lost\"\nwheel = \"left\"\nfraction = 1.5\n")
            .build(2, 1000)
            .unwrap_err();
        assert_eq!(e.key, "faults[2].fraction");
        assert!(toml::from_str::<FaultEntry>("at_s = 1\nkind = \"x\"\nwhen = 2\n").is_err());
    }
}
