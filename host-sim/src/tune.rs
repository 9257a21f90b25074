//! The core's wheel-loop tune ([`controller_core::tune`]) on the simulated robot, and the
//! checks that it works: the identified model against the linearised plant, the tuned
//! loop's step response and the scenario with the tuned gains.
//!
//! The tune runs exactly as on the robot: the supervisor, armed in
//! [`RunMode::Tune`], drives the wheels open loop in volts through the simulated bridge
//! and encoders until the tune disarms it.
//!
//! ## Load cases
//!
//! - **On the ground** (`[plant] load = "ground"`, the default): the robot drives about
//!   0.7 m forward and back (up to 1.35 m for slow motors); the identified plant is the
//!   driving-straight plant.
//! - **Lifted** (`load = "lifted"`): the wheels turn their own inertia only; the tune is
//!   told the factor (J_w + m R²/2) / J_w from the plant's own mass and inertia (what a
//!   user states from a scale and the wheel's data), and corrects τ by it.
//!
//! The truth each identification is compared with is the linearised plant of
//! [`crate::margins::WheelPlant`] in the same load case, motoring, driving straight:
//! k_V = 1/K (V per rad/s), τ.

use controller_core::law::LawKind;
use controller_core::supervisor::{ArmRequest, RunMode, State};
use controller_core::tune::{TuneAbort, TuneConfig, TuneLoad, TuneResult};

use rayon::prelude::*;
use robot_files::plant::{Load, Wheel};
use robot_files::scenario::Scenario;

use crate::margins::{Motion, WheelPlant};
use crate::plant::{Plant, PowerFlow};
use crate::robustness::Variation;
use crate::run::{plant_params, wheel_step_response, Robot, RunError};

/// Longest a tune may run on the simulated robot, s.
pub const MAX_TUNE_S: f64 = 60.0;

/// What a tune did on the simulated robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TuneRun {
    /// The tune's result, or why it stopped.
    pub outcome: Result<TuneResult, TuneAbort>,
    /// Simulated time from arming to the disarm, s.
    pub duration_s: f64,
    /// Largest true distance of the robot from where it started, m.
    pub max_distance_m: f64,
    /// Largest |true wheel speed| during the tune, rad/s.
    pub max_wheel_speed_rad_s: f64,
}

/// The linearised truth of one wheel in the scenario's load case (motoring, straight).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truth {
    /// The voltage that just overcomes the Coulomb friction through the gearbox, V.
    pub ks_v: f64,
    /// 1/K, V per rad/s.
    pub kv_v_per_rad_s: f64,
    /// τ in the scenario's load case, s.
    pub time_constant_s: f64,
    /// τ on the ground driving straight (what the PI is designed for), s.
    pub ground_time_constant_s: f64,
}

/// The tune's settings for `scenario`: the robot's defaults, and lifted with the
/// chassis correction when the scenario's plant is lifted.
pub fn config_for(scenario: &Scenario) -> TuneConfig {
    let mut config = TuneConfig::for_robot(&scenario.robot);
    if scenario.plant.load == Load::Lifted {
        let body = scenario.plant.body;
        // The wheel's own inertia with the rotor reflected through the gearbox.
        let n = f64::from(scenario.robot.gear_ratio);
        let wheel = body.wheel_inertia_kg_m2 + n * n * scenario.plant.motor.rotor_inertia_kg_m2;
        config.load = TuneLoad::lifted(
            body.mass_kg as f32,
            scenario.robot.wheel_radius_left_m,
            wheel as f32,
        );
    }
    config
}

/// The linearised truth of `scenario`'s left wheel ([`Truth`]).
pub fn truth(scenario: &Scenario) -> Result<Truth, RunError> {
    let mut params = plant_params(scenario);
    let here = WheelPlant::linearise(&params, Motion::Straight, PowerFlow::Motoring)?;
    let ks_v = Plant::new(params)?.drive(Wheel::Left).steady_volts(0.0);
    params.load = Load::Ground;
    let ground = WheelPlant::linearise(&params, Motion::Straight, PowerFlow::Motoring)?;
    Ok(Truth {
        ks_v,
        kv_v_per_rad_s: 1.0 / here.gain_rad_s_per_v,
        time_constant_s: here.time_constant_s,
        ground_time_constant_s: ground.time_constant_s,
    })
}

/// Runs the core's tune with `config` on `scenario`'s simulated robot, from rest.
pub fn run_tune(scenario: &Scenario, config: TuneConfig) -> Result<TuneRun, RunError> {
    let params = scenario.params()?;
    let mut robot = Robot::new(scenario, LawKind::Tracking, &[])?;
    robot
        .supervisor
        .set_tune_config(config, &params)
        .map_err(|_| RunError::Argument {
            name: "tune config",
            rule: "must be valid for the robot",
            value: 0.0,
        })?;
    // Warm the supply filter up first, as on a robot that has been on for a while.
    for _ in 0..50 {
        robot.step();
    }
    let request = ArmRequest {
        mode: RunMode::Tune,
        hold_speeds: None,
        initial_motion: None,
        max_armed_steps: None,
    };
    robot
        .supervisor
        .arm_locally(&mut robot.controller, request)
        .map_err(|_| RunError::Argument {
            name: "scenario",
            rule: "must let the robot arm",
            value: 0.0,
        })?;
    let rate = f64::from(scenario.robot.control_rate_hz);
    let start = robot.hardware.period();
    let origin = robot.hardware.plant().pose();
    let limit = (MAX_TUNE_S * rate) as u64;
    let (mut max_distance, mut max_speed) = (0.0f64, 0.0f64);
    loop {
        let out = robot.step();
        let plant: &Plant = robot.hardware.plant();
        let pose = plant.pose();
        max_distance = max_distance.max((pose.x_m - origin.x_m).hypot(pose.y_m - origin.y_m));
        for w in plant.wheel_speeds() {
            max_speed = max_speed.max(w.abs());
        }
        let elapsed = robot.hardware.period() - start;
        if out.state != State::Armed || elapsed >= limit {
            let outcome = robot
                .supervisor
                .tune_outcome()
                .unwrap_or(Err(TuneAbort::Stopped));
            return Ok(TuneRun {
                outcome,
                duration_s: elapsed as f64 / rate,
                max_distance_m: max_distance,
                max_wheel_speed_rad_s: max_speed,
            });
        }
    }
}

/// `scenario` with the wheel loops of `result` (and its own plant).
pub fn with_tuned_loops(scenario: &Scenario, result: &TuneResult) -> Scenario {
    let mut s = scenario.clone();
    s.robot = result.apply_to(&scenario.robot);
    s
}

/// Relative error of `x` against `truth`, %.
pub fn error_pct(x: f64, truth: f64) -> f64 {
    (x - truth) / truth * 100.0
}

/// The supplies of the identification sweep, V: from a weak 4×AA pack to a full 3S.
pub const SWEEP_SUPPLIES_V: [f64; 4] = [5.0, 6.0, 8.4, 12.6];

/// How far the sweep moves R_a, K_t and the inertias, %.
pub const SWEEP_SPREAD_PCT: f64 = 40.0;

/// The sweep's high friction, % change: Coulomb and viscous friction ×3.
pub const SWEEP_HIGH_FRICTION_PCT: f64 = 200.0;

/// The robots of the identification sweep (27): the nominal motor at each of
/// [`SWEEP_SUPPLIES_V`]; on the scenario's supply each of R_a, K_t and the inertias at
/// ±[`SWEEP_SPREAD_PCT`] and the friction ×3; and every corner of R_a, K_t and the
/// inertias at ±[`SWEEP_SPREAD_PCT`], with the nominal friction and with it ×3 (the
/// slowest, weakest motor is R_a +40 %, K_t −40 %, inertia +40 %, friction ×3; the
/// fastest R_a −40 %, K_t +40 %, inertia −40 %).
pub fn sweep_variations() -> Vec<Variation> {
    let mut rows: Vec<Variation> = SWEEP_SUPPLIES_V
        .iter()
        .map(|v| Variation {
            supply_v: Some(*v),
            ..Variation::default()
        })
        .collect();
    for p in [-SWEEP_SPREAD_PCT, SWEEP_SPREAD_PCT] {
        rows.push(Variation {
            resistance_pct: p,
            ..Variation::default()
        });
        rows.push(Variation {
            torque_constant_pct: p,
            ..Variation::default()
        });
        rows.push(Variation {
            inertia_pct: p,
            ..Variation::default()
        });
    }
    rows.push(Variation {
        friction_pct: SWEEP_HIGH_FRICTION_PCT,
        ..Variation::default()
    });
    for friction_pct in [0.0, SWEEP_HIGH_FRICTION_PCT] {
        for bits in 0..8u32 {
            let p = |bit: u32| {
                if bits & (1 << bit) == 0 {
                    -SWEEP_SPREAD_PCT
                } else {
                    SWEEP_SPREAD_PCT
                }
            };
            rows.push(Variation {
                supply_v: None,
                resistance_pct: p(0),
                torque_constant_pct: p(1),
                friction_pct,
                inertia_pct: p(2),
            });
        }
    }
    rows
}

/// The step the sweep checks each tuned loop on, from rest on the ground at the robot's
/// own supply: set-point (rad/s) and length (s).
pub const SWEEP_STEP_RAD_S: f64 = 15.0;
/// See [`SWEEP_STEP_RAD_S`].
pub const SWEEP_STEP_S: f64 = 0.4;

/// The identification's aim: every identified quantity within this of the truth, %.
pub const SWEEP_AIM_PCT: f64 = 10.0;

/// The tuned loop's response to the sweep's step ([`SWEEP_STEP_RAD_S`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopCheck {
    /// Peak overshoot, % of the set-point.
    pub overshoot_pct: f64,
    /// Time after which the speed stays within ±5 % of the set-point, s (`None`: never).
    pub settling_time_s: Option<f64>,
}

/// The identified quantities' errors against the truth, of the wheel with the larger
/// error of each, %.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Errors {
    /// k_S.
    pub ks_pct: f64,
    /// k_V (the ramp's slope).
    pub kv_pct: f64,
    /// K (the step's gain) against 1/k_V's truth.
    pub gain_pct: f64,
    /// τ.
    pub tau_pct: f64,
}

impl Errors {
    /// The largest |error|, %.
    pub fn worst_pct(&self) -> f64 {
        [self.ks_pct, self.kv_pct, self.gain_pct, self.tau_pct]
            .iter()
            .fold(0.0f64, |a, e| a.max(e.abs()))
    }
}

/// One robot of the identification sweep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepCase {
    /// The robot.
    pub variation: Variation,
    /// Its linearised truth.
    pub truth: Truth,
    /// The tune on it.
    pub run: TuneRun,
    /// The tuned loop's step on the ground (`None`: the tune found no model).
    pub tuned_step: Option<LoopCheck>,
}

impl SweepCase {
    /// The identified model's errors against the truth ([`Errors`]); `None` if the tune
    /// found no model.
    pub fn errors_pct(&self) -> Option<Errors> {
        let result = self.run.outcome.ok()?;
        let worst = |f: &dyn Fn(&controller_core::tune::WheelModel) -> f64, truth: f64| {
            result
                .models
                .iter()
                .map(|m| error_pct(f(m), truth))
                .fold(0.0f64, |a, e| if e.abs() > a.abs() { e } else { a })
        };
        Some(Errors {
            ks_pct: worst(&|m| f64::from(m.ks_v), self.truth.ks_v),
            kv_pct: worst(&|m| f64::from(m.kv_v_per_rad_s), self.truth.kv_v_per_rad_s),
            gain_pct: worst(
                &|m| f64::from(m.gain_rad_s_per_v),
                1.0 / self.truth.kv_v_per_rad_s,
            ),
            tau_pct: worst(
                &|m| f64::from(m.time_constant_s),
                self.truth.time_constant_s,
            ),
        })
    }

    /// True when the tune gave a model with every error within [`SWEEP_AIM_PCT`].
    pub fn identified(&self) -> bool {
        self.errors_pct()
            .is_some_and(|e| e.worst_pct() <= SWEEP_AIM_PCT)
    }
}

/// The tune on every robot of `variations` (applied to `scenario`), in parallel, with
/// `config`'s settings (its load replaced by each robot's, [`config_for`]), and each
/// tuned loop's step on the ground.
pub fn identification_sweep(
    scenario: &Scenario,
    config: TuneConfig,
    variations: &[Variation],
) -> Result<Vec<SweepCase>, RunError> {
    variations
        .par_iter()
        .map(|v| {
            let s = v.apply(scenario);
            let run = run_tune(
                &s,
                TuneConfig {
                    load: config_for(&s).load,
                    ..config
                },
            )?;
            let tuned_step = match &run.outcome {
                Ok(result) => {
                    let mut ground = with_tuned_loops(&s, result);
                    ground.plant.load = Load::Ground;
                    let r = wheel_step_response(&ground, SWEEP_STEP_RAD_S, SWEEP_STEP_S)?;
                    Some(LoopCheck {
                        overshoot_pct: r.overshoot_pct,
                        settling_time_s: r.settling_time_s,
                    })
                }
                Err(_) => None,
            };
            Ok(SweepCase {
                variation: *v,
                truth: truth(&s)?,
                run,
                tuned_step,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scenario() -> Scenario {
        Scenario::load("paper-circle").unwrap()
    }

    #[test]
    fn the_tune_identifies_the_reference_wheel_on_the_ground() {
        let s = scenario();
        let truth = truth(&s).unwrap();
        let run = run_tune(&s, config_for(&s)).unwrap();
        let result = run.outcome.unwrap();
        for m in result.models {
            let kv = f64::from(m.kv_v_per_rad_s);
            let tau = f64::from(m.time_constant_s);
            assert!(
                error_pct(kv, truth.kv_v_per_rad_s).abs() < 10.0,
                "{m:?} {truth:?}"
            );
            assert!(
                error_pct(tau, truth.time_constant_s).abs() < 10.0,
                "{m:?} {truth:?}"
            );
        }
        // On the ground the robot moved, within the tune's leash.
        assert!(
            run.max_distance_m > 0.1 && run.max_distance_m < 1.5,
            "{run:?}"
        );
        assert!(run.max_wheel_speed_rad_s < f64::from(config_for(&s).max_speed_rad_s));
    }

    /// The tune on `variation` of paper-circle: the sweep's one case.
    fn sweep_case(variation: Variation) -> SweepCase {
        let s = scenario();
        identification_sweep(&s, config_for(&s), &[variation])
            .unwrap()
            .remove(0)
    }

    #[test]
    fn a_weak_motor_is_identified_within_its_leash() {
        // K_t −40 %: τ 228 ms and 9.8 rad/s per V. Holds and steps of fixed length left
        // the allowed distance; planned from the hold, the tune finishes, settled.
        let case = sweep_case(Variation {
            torque_constant_pct: -SWEEP_SPREAD_PCT,
            ..Variation::default()
        });
        let result = case.run.outcome.unwrap();
        assert!(!result.warnings.any(), "{:?}", result.warnings);
        let e = case.errors_pct().unwrap();
        assert!(e.worst_pct() <= SWEEP_AIM_PCT, "{e:?}");
        assert!(case.run.max_distance_m < 1.5, "{:?}", case.run);
    }

    #[test]
    fn a_slow_motor_with_three_times_the_friction_breaks_away_and_is_identified() {
        // R_a +40 %, K_t −40 %, inertia +40 %, friction ×3: it needs 2.5 V to turn, more
        // than the 2.4 V step of fixed level the tune had.
        let case = sweep_case(Variation {
            supply_v: None,
            resistance_pct: SWEEP_SPREAD_PCT,
            torque_constant_pct: -SWEEP_SPREAD_PCT,
            friction_pct: SWEEP_HIGH_FRICTION_PCT,
            inertia_pct: SWEEP_SPREAD_PCT,
        });
        assert!(case.truth.ks_v > 2.4, "{:?}", case.truth);
        let e = case.errors_pct().expect("a model");
        assert!(e.worst_pct() <= SWEEP_AIM_PCT, "{e:?}");
    }

    #[test]
    fn the_fastest_motor_is_tuned_without_overshoot() {
        // R_a −40 %, K_t +40 %, inertia −40 %: τ 18 ms, under twice the loop's delay.
        // SIMC's T_i = τ overshot 0 → 15 rad/s by 22 %.
        let case = sweep_case(Variation {
            supply_v: None,
            resistance_pct: -SWEEP_SPREAD_PCT,
            torque_constant_pct: SWEEP_SPREAD_PCT,
            friction_pct: 0.0,
            inertia_pct: -SWEEP_SPREAD_PCT,
        });
        assert!(case.identified(), "{:?}", case.errors_pct());
        let step = case.tuned_step.unwrap();
        assert!(step.overshoot_pct <= 5.0, "{step:?}");
        assert!(step.settling_time_s.is_some_and(|t| t < 0.1), "{step:?}");
    }

    #[test]
    fn the_sweep_covers_the_spread_and_its_corners() {
        let rows = sweep_variations();
        assert_eq!(rows.len(), 27);
        let has = |f: &dyn Fn(&Variation) -> bool| rows.iter().any(f);
        for p in [-SWEEP_SPREAD_PCT, SWEEP_SPREAD_PCT] {
            assert!(has(
                &|v| v.resistance_pct == p && v.torque_constant_pct == 0.0
            ));
            assert!(has(&|v| v.torque_constant_pct == p && v.inertia_pct == 0.0));
            assert!(has(&|v| v.inertia_pct == p && v.resistance_pct == 0.0));
        }
        // Every corner of R_a, K_t, inertia, with the nominal friction and with it ×3.
        let corners = rows
            .iter()
            .filter(|v| {
                [v.resistance_pct, v.torque_constant_pct, v.inertia_pct]
                    .iter()
                    .all(|p| p.abs() == SWEEP_SPREAD_PCT)
            })
            .count();
        assert_eq!(corners, 16);
        assert!(has(
            &|v| v.friction_pct == SWEEP_HIGH_FRICTION_PCT && v.resistance_pct == 0.0
        ));
        for supply in SWEEP_SUPPLIES_V {
            assert!(has(&|v| v.supply_v == Some(supply)));
        }
    }

    #[test]
    fn lifted_the_tune_designs_for_the_ground() {
        let mut s = scenario();
        s.plant.load = Load::Lifted;
        let truth = truth(&s).unwrap();
        assert!(truth.ground_time_constant_s > 2.5 * truth.time_constant_s);
        let run = run_tune(&s, config_for(&s)).unwrap();
        let result = run.outcome.unwrap();
        for m in result.models {
            let tau = f64::from(m.time_constant_s);
            let design = f64::from(m.design_time_constant_s);
            assert!(
                error_pct(tau, truth.time_constant_s).abs() < 10.0,
                "{m:?} {truth:?}"
            );
            assert!(
                error_pct(design, truth.ground_time_constant_s).abs() < 10.0,
                "{m:?} {truth:?}"
            );
        }
        // The robot stayed put.
        assert!(run.max_distance_m < 1e-9, "{run:?}");
    }
}
