//! A miswired robot: what stands between the plant's true wheels and gyro and what the
//! board sees
//! (`host-sim serve --miswire`). The robot's own wiring corrections
//! (`controller_core::wiring`) are the robot's business; this is the truth they must
//! undo.
//!
//! Each flag says what is true of the wiring, in the words of the robot's corrections:
//! `left-encoder-inverted` is a left encoder that counts down when its wheel turns
//! forward, `encoders-swapped` the left wheel's encoder on the board's right input. So a
//! bring-up that finds a miswiring right sets the same flags in the robot's parameters.

use std::fmt;
use std::str::FromStr;

use controller_core::controller::{MotorCommand, TickDeltas};
use controller_core::gyro::GyroSample;

/// Why a miswiring list was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MiswireError {
    /// A word that names no miswiring.
    #[error(
        "unknown miswiring `{0}` (known: left-motor-inverted, right-motor-inverted, \
         left-encoder-inverted, right-encoder-inverted, encoders-swapped, motors-swapped, \
         gyro-inverted, cpr=xK, supply-scale=F)"
    )]
    Unknown(String),
    /// `cpr=` or `supply-scale=` with a value that is not a number in its range.
    #[error("miswiring `{key}`: {value:?} is not {expected}")]
    BadValue {
        /// `cpr` or `supply-scale`.
        key: &'static str,
        /// What was written.
        value: String,
        /// What it must be.
        expected: &'static str,
    },
}

/// How the robot is miswired (module doc). The default is wired as labelled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Miswiring {
    /// The left motor turns its wheel backward for a positive duty.
    pub left_motor_inverted: bool,
    /// The right motor turns its wheel backward for a positive duty.
    pub right_motor_inverted: bool,
    /// The left wheel's motor is on the board's right output, and the right's on the left.
    pub motors_swapped: bool,
    /// The left wheel's encoder counts down when the wheel turns forward.
    pub left_encoder_inverted: bool,
    /// The right wheel's encoder counts down when the wheel turns forward.
    pub right_encoder_inverted: bool,
    /// The left wheel's encoder is on the board's right input, and the right's on the left.
    pub encoders_swapped: bool,
    /// The IMU is mounted upside down: its z axis points down, so its yaw rate is the
    /// robot's negated.
    pub gyro_inverted: bool,
    /// The encoders' true counts per turn over what the robot is configured with
    /// (`cpr=x2`: twice as many), in [1/8, 8].
    pub cpr_factor: f64,
    /// The board's supply reading over the true supply (`supply-scale=1.1`: it reads
    /// 10 % high), in [0.5, 2].
    pub supply_scale: f64,
}

impl Default for Miswiring {
    fn default() -> Self {
        Self {
            left_motor_inverted: false,
            right_motor_inverted: false,
            motors_swapped: false,
            left_encoder_inverted: false,
            right_encoder_inverted: false,
            encoders_swapped: false,
            gyro_inverted: false,
            cpr_factor: 1.0,
            supply_scale: 1.0,
        }
    }
}

impl Miswiring {
    /// True when nothing is miswired.
    pub fn is_none(&self) -> bool {
        *self == Self::default()
    }
}

fn number(
    key: &'static str,
    value: &str,
    range: (f64, f64),
    expected: &'static str,
) -> Result<f64, MiswireError> {
    let bad = || MiswireError::BadValue {
        key,
        value: value.to_string(),
        expected,
    };
    let v: f64 = value.parse().map_err(|_| bad())?;
    if v.is_finite() && v >= range.0 && v <= range.1 {
        Ok(v)
    } else {
        Err(bad())
    }
}

impl FromStr for Miswiring {
    type Err = MiswireError;

    /// A comma-separated list of the words in [`MiswireError::Unknown`]'s message; an
    /// empty list is a robot wired as labelled.
    fn from_str(list: &str) -> Result<Self, Self::Err> {
        let mut m = Miswiring::default();
        for word in list.split(',').map(str::trim).filter(|w| !w.is_empty()) {
            match word {
                "left-motor-inverted" => m.left_motor_inverted = true,
                "right-motor-inverted" => m.right_motor_inverted = true,
                "motors-swapped" => m.motors_swapped = true,
                "left-encoder-inverted" => m.left_encoder_inverted = true,
                "right-encoder-inverted" => m.right_encoder_inverted = true,
                "encoders-swapped" => m.encoders_swapped = true,
                "gyro-inverted" => m.gyro_inverted = true,
                _ => {
                    if let Some(value) = word.strip_prefix("cpr=") {
                        let factor = value.strip_prefix('x').unwrap_or(value);
                        m.cpr_factor =
                            number("cpr", factor, (0.125, 8.0), "a factor xK with K in 1/8…8")?;
                    } else if let Some(value) = word.strip_prefix("supply-scale=") {
                        m.supply_scale =
                            number("supply-scale", value, (0.5, 2.0), "a scale in 0.5…2")?;
                    } else {
                        return Err(MiswireError::Unknown(word.to_string()));
                    }
                }
            }
        }
        Ok(m)
    }
}

impl fmt::Display for Miswiring {
    /// The list [`Miswiring::from_str`] reads back; `none` when wired as labelled.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut words: Vec<String> = [
            (self.left_motor_inverted, "left-motor-inverted"),
            (self.right_motor_inverted, "right-motor-inverted"),
            (self.left_encoder_inverted, "left-encoder-inverted"),
            (self.right_encoder_inverted, "right-encoder-inverted"),
            (self.encoders_swapped, "encoders-swapped"),
            (self.motors_swapped, "motors-swapped"),
            (self.gyro_inverted, "gyro-inverted"),
        ]
        .iter()
        .filter(|(on, _)| *on)
        .map(|(_, w)| w.to_string())
        .collect();
        if self.cpr_factor != 1.0 {
            words.push(format!("cpr=x{}", self.cpr_factor));
        }
        if self.supply_scale != 1.0 {
            words.push(format!("supply-scale={}", self.supply_scale));
        }
        if words.is_empty() {
            f.write_str("none")
        } else {
            f.write_str(&words.join(","))
        }
    }
}

/// The miswired wires themselves: a [`Miswiring`] with the fractions of counts it has not
/// yet passed on (an encoder of another resolution).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Wires {
    miswiring: Miswiring,
    /// Each wheel's true encoder position scaled by the CPR factor, counts, and what
    /// of it was passed on.
    scaled: [f64; 2],
    passed: [i64; 2],
}

impl Wires {
    /// Wires miswired as `miswiring` says.
    pub fn new(miswiring: Miswiring) -> Self {
        Self {
            miswiring,
            scaled: [0.0; 2],
            passed: [0; 2],
        }
    }

    /// The miswiring.
    pub fn miswiring(&self) -> &Miswiring {
        &self.miswiring
    }

    /// The board's encoder inputs (left, right) for each wheel's true ticks `wheels`
    /// (forward positive, at the configured resolution).
    pub fn board_ticks(&mut self, wheels: TickDeltas) -> TickDeltas {
        let m = &self.miswiring;
        let mut counts = [0i32; 2];
        for (i, (ticks, inverted)) in [
            (wheels.left, m.left_encoder_inverted),
            (wheels.right, m.right_encoder_inverted),
        ]
        .into_iter()
        .enumerate()
        {
            self.scaled[i] += f64::from(ticks) * m.cpr_factor;
            let whole = self.scaled[i].floor() as i64;
            let delta = (whole - self.passed[i]) as i32;
            self.passed[i] = whole;
            counts[i] = if inverted { -delta } else { delta };
        }
        if m.encoders_swapped {
            counts.swap(0, 1);
        }
        TickDeltas {
            left: counts[0],
            right: counts[1],
        }
    }

    /// Each wheel's motor duty for the board's output duties `board` (left, right).
    pub fn wheel_duties(&self, board: MotorCommand) -> MotorCommand {
        let m = &self.miswiring;
        let (left, right) = if m.motors_swapped {
            (board.right, board.left)
        } else {
            (board.left, board.right)
        };
        MotorCommand {
            left: if m.left_motor_inverted { -left } else { left },
            right: if m.right_motor_inverted {
                -right
            } else {
                right
            },
        }
    }

    /// The board's reading of the gyro's `reading` (the sensor's yaw rate about the
    /// robot's upward axis).
    pub fn board_gyro(&self, reading: Option<GyroSample>) -> Option<GyroSample> {
        reading.map(|r| GyroSample {
            yaw_rate_radps: if self.miswiring.gyro_inverted {
                -r.yaw_rate_radps
            } else {
                r.yaw_rate_radps
            },
            ..r
        })
    }

    /// The board's reading of the true supply `true_v`, V.
    pub fn board_supply(&self, true_v: f32) -> f32 {
        (f64::from(true_v) * self.miswiring.supply_scale) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::wiring::WiringConfig;

    #[test]
    fn a_list_reads_back_as_written() {
        let text = "left-motor-inverted,right-encoder-inverted,encoders-swapped,motors-swapped,gyro-inverted,cpr=x2,supply-scale=1.1";
        let m: Miswiring = text.parse().expect("valid");
        assert!(m.left_motor_inverted && m.right_encoder_inverted && m.encoders_swapped);
        assert!(m.gyro_inverted);
        assert!(m.motors_swapped && !m.right_motor_inverted && !m.left_encoder_inverted);
        assert_eq!((m.cpr_factor, m.supply_scale), (2.0, 1.1));
        assert_eq!(m.to_string().parse::<Miswiring>(), Ok(m));
        assert_eq!("".parse::<Miswiring>(), Ok(Miswiring::default()));
        assert_eq!(Miswiring::default().to_string(), "none");
    }

    #[test]
    fn bad_words_and_values_are_named() {
        assert_eq!(
            "motor-upside-down".parse::<Miswiring>(),
            Err(MiswireError::Unknown("motor-upside-down".into()))
        );
        for bad in ["cpr=x0", "cpr=xfast", "supply-scale=3", "supply-scale=NaN"] {
            let e = bad.parse::<Miswiring>().expect_err(bad);
            assert!(matches!(e, MiswireError::BadValue { .. }), "{bad}: {e}");
        }
    }

    #[test]
    fn the_robot_s_same_flags_undo_the_miswiring() {
        // Every flag at once: the robot's corrections with the same flags give back the
        // wheels' ticks and duties.
        let m: Miswiring =
            "left-motor-inverted,right-encoder-inverted,encoders-swapped,motors-swapped"
                .parse()
                .expect("valid");
        let mut wires = Wires::new(m);
        let robot = WiringConfig {
            left_motor_inverted: true,
            right_encoder_inverted: true,
            encoders_swapped: true,
            motors_swapped: true,
            ..WiringConfig::AS_BUILT
        };
        let wheels = TickDeltas { left: 5, right: -9 };
        assert_eq!(robot.ticks_from_board(wires.board_ticks(wheels)), wheels);
        let duty = MotorCommand {
            left: 0.3,
            right: -0.7,
        };
        assert_eq!(wires.wheel_duties(robot.duties_to_board(duty)), duty);
    }

    #[test]
    fn an_upside_down_imu_reads_the_yaw_rate_negated() {
        let reading = Some(GyroSample {
            yaw_rate_radps: 0.25,
            age_periods: 2,
        });
        let upright = Wires::new(Miswiring::default());
        assert_eq!(upright.board_gyro(reading), reading);
        let upside_down = Wires::new("gyro-inverted".parse().expect("valid"));
        let read = upside_down.board_gyro(reading).expect("a reading");
        assert_eq!((read.yaw_rate_radps, read.age_periods), (-0.25, 2));
        assert_eq!(upside_down.board_gyro(None), None);
    }

    #[test]
    fn an_encoder_of_another_resolution_passes_every_count_on() {
        let mut wires = Wires::new("cpr=x0.5".parse().expect("valid"));
        let total: i32 = (0..10)
            .map(|_| wires.board_ticks(TickDeltas { left: 3, right: -3 }).left)
            .sum();
        assert_eq!(total, 15, "half of 30, no count lost to rounding");
    }
}
