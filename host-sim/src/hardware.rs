//! The simulated robot's hardware, as the firmware sees it: encoder counts, the supply
//! measurement and the button going in; duties and the bridge's state coming out.
//!
//! [`SimHardware`] wraps the [`Plant`] with the encoders, the supply sensor and the
//! injected [`faults`](robot_files::faults). Whatever runs the robot's logic — the
//! simulator's own loop ([`crate::run`]), the virtual robot, or the real firmware
//! under QEMU — calls it the same way, once per control step:
//!
//! 1. [`SimHardware::periods_until_next_step`]: how many control periods the next step
//!    covers (1, or more when a `late-steps` fault makes the firmware start late);
//! 2. [`SimHardware::sense`]: the ticks counted since the last reading, the supply
//!    measurement and the button level;
//! 3. the robot's logic decides;
//! 4. [`SimHardware::actuate`] with the duties and the bridge state;
//! 5. [`SimHardware::advance`] by one period (the first `periods − 1` of a late step
//!    were advanced before sensing, with the previous outputs held).

use controller_core::controller::{MotorCommand, TickDeltas};
use controller_core::gyro::GyroSample;
use controller_core::supervisor::Bridge;
use robot_files::faults::{Fault, FaultKind};
use robot_files::plant::Wheel;
use robot_files::rng::Rng;
use robot_files::scenario::Scenario;
use robot_files::truth::TruePose;

use crate::encoder::Encoder;
use crate::gyro::SimGyro;
use crate::plant::{Integration, Plant, PlantError};

/// What the firmware reads in one control step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensors {
    /// Encoder ticks since the last reading, forward positive.
    pub ticks: TickDeltas,
    /// Control periods since the last reading (≥ 1).
    pub periods: u32,
    /// The supply measurement, V (with the sensor's noise).
    pub supply_v: f32,
    /// The arm button's raw level, true while pressed.
    pub button_pressed: bool,
    /// The gyro's reading (`None`: no gyro, or none handed over this step).
    pub gyro: Option<GyroSample>,
}

/// What the firmware writes in one control step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Actuation {
    /// Duties, −1…1, positive forward.
    pub duty: MotorCommand,
    /// The bridge: drive, brake (enabled, duty 0) or coast (standby).
    pub bridge: Bridge,
}

impl Actuation {
    /// Bridge in standby, duties 0.
    pub const OFF: Actuation = Actuation {
        duty: MotorCommand::STOP,
        bridge: Bridge::Coast,
    };
}

/// RMS noise of the simulated supply measurement, V (an ADC through a divider and RC
/// filter: a few LSB).
pub const SUPPLY_NOISE_RMS_V: f64 = 0.01;

/// The robot's hardware in the simulator (see the module doc).
#[derive(Clone, Debug)]
pub struct SimHardware {
    plant: Plant,
    encoders: [Encoder; 2],
    rng: Rng,
    faults: Vec<Fault>,
    /// Plant steps per control period (RK4's, where the plant cannot take the period in
    /// one exact step), and their length, s.
    substeps: u32,
    dt_s: f64,
    /// Control periods simulated so far (the time).
    period: u64,
    /// Late steps still to come from a `late-steps` fault, and the periods each covers.
    late: (u32, u32),
    /// Counts frozen by an encoder disconnect [left, right].
    frozen: [bool; 2],
    /// Nominal supply, V (what a sag returns to).
    nominal_supply_v: f64,
    actuation: Actuation,
    /// The gyro, if the scenario's robot has one.
    gyro: Option<SimGyro>,
    /// Fractions of a tick lost but not yet dropped [left, right] × [forward, backward]
    /// (`ticks-lost`; one per direction, so a wheel dithering about a tick boundary
    /// loses as many ticks each way).
    tick_loss: [[f64; 2]; 2],
    /// The reading a stuck gyro repeats (`gyro-stuck`, while it lasts).
    stuck_gyro: Option<GyroSample>,
}

impl SimHardware {
    /// The hardware of `scenario`'s robot with `faults` injected on its timeline, at the
    /// start pose and with the wheels still (a start in motion is the plant's
    /// [`SimHardware::start_moving`]).
    pub fn new(scenario: &Scenario, faults: &[Fault]) -> Result<Self, PlantError> {
        let mut params = crate::run::plant_params(scenario);
        for f in faults {
            if let FaultKind::TrackWidthError(pct) = f.kind {
                params.geometry.track_width_m *= 1.0 + pct / 100.0;
            }
        }
        let mut plant = Plant::new(params)?;
        let s = scenario.start;
        plant.reset(
            TruePose {
                x_m: s.x_m,
                y_m: s.y_m,
                theta_rad: robot_files::truth::wrap_angle(s.theta_rad),
            },
            [0.0; 2],
        );
        plant.set_driver_enabled(false);
        let c = &scenario.robot;
        let ticks_per_rev =
            f64::from(c.encoder_lines_per_motor_rev) * 4.0 * f64::from(c.gear_ratio);
        let noise = scenario.plant.encoder_noise_ticks_rms;
        let control_hz = c.control_rate_hz;
        let gyro = scenario
            .gyro
            .map(|setup| SimGyro::new(&setup, control_hz, scenario.seed, plant.pose().theta_rad));
        Ok(Self {
            gyro,
            nominal_supply_v: plant.supply_v(),
            plant,
            // Each encoder's edges laid out by a seed of its own, derived from the
            // scenario's: the run's random stream is not drawn from.
            encoders: [1, 2].map(|wheel| {
                Encoder::new(ticks_per_rev, noise, 0.0, scenario.seed.wrapping_add(wheel))
            }),
            rng: Rng::new(scenario.seed),
            faults: faults.to_vec(),
            substeps: scenario.plant_rate_hz / control_hz,
            dt_s: 1.0 / f64::from(scenario.plant_rate_hz),
            period: 0,
            late: (0, 1),
            frozen: [false; 2],
            actuation: Actuation::OFF,
            tick_loss: [[0.0; 2]; 2],
            stuck_gyro: None,
        })
    }

    /// Spins the wheels up to the scenario's start motion (v m/s, ω rad/s, true
    /// geometry and slip), for a run that starts in motion; refused, the wheels left as
    /// they are, when a wheel would exceed its motor's no-load speed
    /// ([`Plant::start_in_motion`]).
    pub fn start_moving(&mut self, v_m_s: f64, omega_rad_s: f64) -> Result<(), PlantError> {
        self.plant.start_in_motion(v_m_s, omega_rad_s)
    }

    /// Sets how the plant integrates ([`Plant::set_integration`]).
    pub fn set_integration(&mut self, integration: Integration) {
        self.plant.set_integration(integration);
    }

    /// The plant (for its true state).
    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    /// Control periods simulated so far.
    pub const fn period(&self) -> u64 {
        self.period
    }

    /// The last actuation applied.
    pub const fn actuation(&self) -> Actuation {
        self.actuation
    }

    /// How many control periods the next control step covers: 1, or more while a
    /// `late-steps` fault is in effect. Advances the plant by the extra periods, with the
    /// outputs held, as the firmware's late start lets them run.
    pub fn periods_until_next_step(&mut self) -> u32 {
        for f in &self.faults {
            if let FaultKind::LateSteps { count, periods } = f.kind {
                if f.at_step == self.period {
                    self.late = (count, periods);
                }
            }
        }
        if self.late.0 == 0 {
            return 1;
        }
        self.late.0 -= 1;
        let periods = self.late.1.max(1);
        for _ in 1..periods {
            self.advance();
        }
        periods
    }

    /// What the firmware reads now (see the module doc), with the faults in effect.
    pub fn sense(&mut self, periods: u32) -> Sensors {
        self.apply_state_faults();
        let angles = self.plant.wheel_angles();
        let mut ticks = [0i32; 2];
        for i in 0..2 {
            let delta = self.encoders[i].read_delta(angles[i]);
            ticks[i] = if self.frozen[i] { 0 } else { delta };
        }
        let mut button_pressed = false;
        let mut losing = [false; 2];
        for f in self.faults.iter().filter(|f| f.active_at(self.period)) {
            match f.kind {
                FaultKind::EncoderGlitch(wheel, jump) if f.at_step == self.period => {
                    ticks[wheel.index()] = ticks[wheel.index()].saturating_add(jump);
                }
                FaultKind::EncodersSwapped => ticks.swap(0, 1),
                FaultKind::BothInverted(wheel) => {
                    ticks[wheel.index()] = ticks[wheel.index()].saturating_neg();
                }
                FaultKind::ButtonPress => button_pressed = true,
                FaultKind::TicksLost(wheel, fraction) => {
                    let i = wheel.index();
                    losing[i] = true;
                    ticks[i] = lose_ticks(ticks[i], fraction, &mut self.tick_loss[i]);
                }
                _ => {}
            }
        }
        for (owed, losing) in self.tick_loss.iter_mut().zip(losing) {
            if !losing {
                *owed = [0.0; 2];
            }
        }
        let gyro = self.read_gyro(periods);
        let noise = SUPPLY_NOISE_RMS_V * self.rng.normal();
        Sensors {
            ticks: TickDeltas {
                left: ticks[0],
                right: ticks[1],
            },
            periods,
            supply_v: (self.plant.supply_v() + noise) as f32,
            button_pressed,
            gyro,
        }
    }

    /// Turns the robot on the spot by `yaw_rad` (rad, counter-clockwise positive), by
    /// hand ([`Plant::rotate_by_hand`]).
    pub fn rotate_by_hand(&mut self, yaw_rad: f64) {
        self.plant.rotate_by_hand(yaw_rad);
    }

    /// Takes the gyro's state from `other` (its noise stream, bias, latency and the
    /// heading it last read): a copy's sensors were read while this hardware held still,
    /// and the gyro reads on, as a real IMU does while its robot waits.
    pub fn keep_gyro_of(&mut self, other: &SimHardware) {
        self.gyro.clone_from(&other.gyro);
        self.stuck_gyro = other.stuck_gyro;
    }

    /// The gyro's reading for a step of `periods` periods, with the gyro faults in
    /// effect: absent (none), stuck (the first reading of the fault, repeated),
    /// saturated (full scale, positive unless the reading is negative). The sensor is
    /// read every step whatever the faults, so its latency and noise stream go on.
    fn read_gyro(&mut self, periods: u32) -> Option<GyroSample> {
        let gyro = self.gyro.as_mut()?;
        let full_scale = gyro.full_scale_rad_s() as f32;
        let mut reading = gyro.read(self.plant.pose().theta_rad, periods);
        let mut stuck = false;
        for f in self.faults.iter().filter(|f| f.active_at(self.period)) {
            match f.kind {
                FaultKind::GyroAbsent => reading = None,
                FaultKind::GyroStuck => stuck = true,
                FaultKind::GyroSaturated => {
                    if let Some(r) = reading.as_mut() {
                        r.yaw_rate_radps = saturated(r.yaw_rate_radps, full_scale);
                    }
                }
                _ => {}
            }
        }
        if !stuck {
            self.stuck_gyro = None;
            return reading;
        }
        if self.stuck_gyro.is_none() {
            self.stuck_gyro = reading;
        }
        self.stuck_gyro
    }

    /// Applies the firmware's outputs (held until the next call).
    pub fn actuate(&mut self, actuation: Actuation) {
        self.actuation = actuation;
        let mut duty = [actuation.duty.left, actuation.duty.right];
        for f in self.faults.iter().filter(|f| f.active_at(self.period)) {
            if let FaultKind::BothInverted(wheel) = f.kind {
                duty[wheel.index()] = -duty[wheel.index()];
            }
        }
        self.plant.set_duty(duty[0], duty[1]);
        self.plant.set_driver_enabled(actuation.bridge.enabled());
    }

    /// Advances the plant by one control period.
    pub fn advance(&mut self) {
        self.plant.advance(self.dt_s, self.substeps);
        self.period += 1;
    }

    /// Puts the plant in the state the faults active now ask for (motor leads, a blocked
    /// wheel, slip, the supply), and undoes those that ended.
    fn apply_state_faults(&mut self) {
        let now = self.period;
        let mut connected = [true; 2];
        let mut blocked = [false; 2];
        let mut slip = self.plant.params().slip;
        let mut supply = self.nominal_supply_v;
        self.frozen = [false; 2];
        for f in self.faults.iter().filter(|f| f.active_at(now)) {
            match f.kind {
                FaultKind::EncoderDisconnect(w) => self.frozen[w.index()] = true,
                FaultKind::MotorDisconnect(w) => connected[w.index()] = false,
                FaultKind::WheelBlocked(w) => blocked[w.index()] = true,
                FaultKind::SlipPatch(w, ratio) => slip[w.index()] = ratio,
                FaultKind::SupplySag(v) => supply = v,
                _ => {}
            }
        }
        for wheel in [Wheel::Left, Wheel::Right] {
            let i = wheel.index();
            if self.plant.motor_connected()[i] != connected[i] {
                self.plant.set_motor_connected(wheel, connected[i]);
            }
            if self.plant.wheel_blocked()[i] != blocked[i] {
                self.plant.set_wheel_blocked(wheel, blocked[i]);
            }
            if self.plant.slip()[i] != slip[i] {
                // Validated when the scenario was loaded.
                let _ = self.plant.set_slip(wheel, slip[i]);
            }
        }
        if self.plant.supply_v() != supply && supply > 0.0 {
            let _ = self.plant.set_supply_v(supply);
        }
    }
}

/// A saturated gyro's reading of `rate_radps`: the full scale `full_scale_radps`,
/// negative for a negative reading, positive otherwise (a reading of 0 too).
fn saturated(rate_radps: f32, full_scale_radps: f32) -> f32 {
    if rate_radps < 0.0 {
        -full_scale_radps
    } else {
        full_scale_radps
    }
}

/// `ticks` (one reading's delta) with `fraction` (0…1) of them lost: whole ticks dropped
/// as the lost fraction accumulates in `owed` [forward, backward], one remainder per
/// direction so that a wheel dithering about a tick boundary loses as many each way.
/// The count the firmware sees falls behind the wheel for good; never past zero.
fn lose_ticks(ticks: i32, fraction: f64, owed: &mut [f64; 2]) -> i32 {
    let owed = &mut owed[usize::from(ticks < 0)];
    *owed += f64::from(ticks.unsigned_abs()) * fraction;
    // At most the reading's own ticks: a remainder carried in cannot reverse it.
    let lost = owed.floor().min(f64::from(ticks.unsigned_abs()));
    *owed -= lost;
    ticks - ticks.signum() * lost as i32
}

#[cfg(test)]
mod tests {
    use super::{lose_ticks, saturated};

    #[test]
    fn a_saturated_gyro_reads_full_scale_with_the_readings_sign() {
        assert_eq!(saturated(-0.1, 34.9), -34.9);
        assert_eq!(saturated(0.0, 34.9), 34.9);
        assert_eq!(saturated(0.2, 34.9), 34.9);
    }

    #[test]
    fn a_tenth_of_the_ticks_lost_is_one_in_ten_either_way() {
        let mut owed = [0.0; 2];
        // Within a tick: the remainder is a binary fraction, and 0.1 is not one.
        let forward: i32 = (0..100).map(|_| lose_ticks(1, 0.1, &mut owed)).sum();
        assert!((90..=91).contains(&forward), "{forward}");
        let backward: i32 = (0..10).map(|_| lose_ticks(-10, 0.1, &mut owed)).sum();
        assert!((-91..=-90).contains(&backward), "{backward}");
        assert_eq!(lose_ticks(0, 0.1, &mut owed), 0);
        assert_eq!(
            lose_ticks(7, 1.0, &mut owed),
            0,
            "all lost, never past zero"
        );
    }

    #[test]
    fn a_wheel_dithering_about_a_tick_loses_as_much_each_way() {
        let mut owed = [0.0; 2];
        let net: i32 = (0..100)
            .map(|_| lose_ticks(1, 0.5, &mut owed) + lose_ticks(-1, 0.5, &mut owed))
            .sum();
        assert_eq!(net, 0);
    }
}
