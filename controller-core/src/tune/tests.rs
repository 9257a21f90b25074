//! The tune against a synthetic robot: two first-order wheels with static and Coulomb
//! friction behind the real controller (open-loop volts, encoder ticks, speed estimate).

use super::*;
use crate::controller::{Controller, Mode, StepInput, TickDeltas};
use crate::kinematics::Point;
use crate::params::RobotConfig;

/// One synthetic wheel: τ ω̇ = K (u − k_S sgn ω) − ω while turning; held at rest while
/// |u| ≤ k_S. Turning backwards, K and τ may differ (`backward`).
#[derive(Clone, Copy, Debug)]
struct SyntheticWheel {
    gain: f32,
    tau: f32,
    /// (K, τ) turning backwards.
    backward: (f32, f32),
    ks: f32,
    speed: f32,
    angle: f32,
}

impl SyntheticWheel {
    fn new(gain: f32, tau: f32, ks: f32) -> Self {
        Self {
            gain,
            tau,
            backward: (gain, tau),
            ks,
            speed: 0.0,
            angle: 0.0,
        }
    }

    /// Advances `dt` (s) with `volts` held, in 20 Euler substeps.
    fn advance(&mut self, volts: f32, dt: f32) {
        let h = dt / 20.0;
        for _ in 0..20 {
            if self.speed == 0.0 && math::abs(volts) <= self.ks {
                continue;
            }
            let direction = if self.speed != 0.0 {
                self.speed.signum()
            } else {
                volts.signum()
            };
            let (gain, tau) = if direction > 0.0 {
                (self.gain, self.tau)
            } else {
                self.backward
            };
            let next = self.speed + h * (gain * (volts - self.ks * direction) - self.speed) / tau;
            // Friction stops a wheel; it does not reverse it.
            self.speed = if next * direction < 0.0 { 0.0 } else { next };
            self.angle += h * self.speed;
        }
    }
}

/// The synthetic robot and what happened during a tune.
struct Bench {
    controller: Controller,
    wheels: [SyntheticWheel; 2],
    /// Encoder: +1 or −1 (an encoder wired the wrong way round).
    encoder_sign: [f32; 2],
    ticks_seen: [i32; 2],
    /// Over these steps a wheel's static friction is raised (a blocked wheel): (the
    /// wheel, steps, static friction); it is restored after them.
    block: Option<(Side, core::ops::Range<usize>, f32)>,
    /// Every voltage the tune asked for, and the true speeds after each step.
    asked: Vec<WheelVolts>,
    speeds: Vec<[f32; 2]>,
    /// Dead time of both wheels, control periods: the voltages reach them this much later.
    dead_steps: usize,
    in_flight: std::collections::VecDeque<WheelVolts>,
}

impl Bench {
    fn new(wheel: SyntheticWheel) -> Self {
        Self {
            controller: crate::controller::tests::on_a_line(5.0),
            wheels: [wheel; 2],
            encoder_sign: [1.0; 2],
            ticks_seen: [0; 2],
            block: None,
            asked: Vec::new(),
            speeds: Vec::new(),
            dead_steps: 0,
            in_flight: std::collections::VecDeque::new(),
        }
    }

    fn params(&self) -> Params {
        *self.controller.params()
    }

    /// Runs `tuner` to its end (at most 60 s), `late_at` making one step late.
    fn run(&mut self, tuner: &mut Tuner, late_at: Option<usize>) -> Result<TuneResult, TuneAbort> {
        let rad_per_tick = self.params().rad_per_tick();
        tuner.start(self.controller.pose());
        let mut volts = WheelVolts::default();
        for k in 0..60_000 {
            let mut ticks = [0i32; 2];
            for (i, t) in ticks.iter_mut().enumerate() {
                let total = (self.encoder_sign[i] * self.wheels[i].angle / rad_per_tick) as i32;
                *t = total - self.ticks_seen[i];
                self.ticks_seen[i] = total;
            }
            self.controller.set_mode(Mode::ApplyVolts(volts));
            self.controller.step(StepInput::on_time(
                TickDeltas {
                    left: ticks[0],
                    right: ticks[1],
                },
                6.0,
            ));
            if let Some((side, steps, ks)) = &self.block {
                let (blocked, other) = match side {
                    Side::Left => (0, 1),
                    Side::Right => (1, 0),
                };
                if k == steps.start {
                    self.wheels[blocked].ks = *ks;
                } else if k == steps.end {
                    self.wheels[blocked].ks = self.wheels[other].ks;
                }
            }
            self.in_flight
                .push_back(self.controller.telemetry().wheel_loop.volts);
            let applied = if self.in_flight.len() > self.dead_steps {
                self.in_flight.pop_front().unwrap_or_default()
            } else {
                WheelVolts::default()
            };
            self.wheels[0].advance(applied.left_v, 0.001);
            self.wheels[1].advance(applied.right_v, 0.001);
            self.speeds
                .push([self.wheels[0].speed, self.wheels[1].speed]);
            let periods = if Some(k) == late_at { 2 } else { 1 };
            match tuner.step(self.controller.telemetry(), periods) {
                TuneStep::Drive(v) => {
                    self.asked.push(v);
                    volts = v;
                }
                TuneStep::Finished(outcome) => return outcome,
            }
        }
        panic!("the tune did not end");
    }
}

/// The reference wheel on the ground: K = 6.35 rad/s per V, τ = 89 ms, k_S = 0.375 V.
fn ground_wheel() -> SyntheticWheel {
    SyntheticWheel::new(6.35, 0.089, 0.375)
}

fn config(bench: &Bench) -> TuneConfig {
    TuneConfig::for_robot(bench.params().config())
}

fn close(x: f32, truth: f32, tolerance: f32) -> bool {
    math::abs(x - truth) <= tolerance * math::abs(truth)
}

#[test]
fn the_tune_recovers_the_model_of_a_synthetic_wheel() {
    let mut bench = Bench::new(ground_wheel());
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    let result = bench.run(&mut tuner, None).unwrap();
    assert_eq!(tuner.outcome(), Some(Ok(result)));
    for m in result.models {
        assert!(close(m.gain_rad_s_per_v, 6.35, 0.03), "{m:?}");
        assert!(close(m.kv_v_per_rad_s, 1.0 / 6.35, 0.03), "{m:?}");
        assert!(close(m.time_constant_s, 0.089, 0.05), "{m:?}");
        // The truth is k_S = 0.375 V and θ = 1 ms: none in the wheel, one period between
        // the tune asking for a voltage and the controller applying it (measured 0.379 V
        // and 1.08 ms).
        assert!(math::abs(m.dead_time_s - 0.001) < 5e-4, "{m:?}");
        assert!(close(m.ks_v, 0.375, 0.02), "{m:?}");
        assert_eq!(m.design_time_constant_s, m.time_constant_s);
    }
    // SIMC with τ_c = 2 θ_e, θ_e = the identified θ (up to a millisecond of the encoder's
    // quantisation) + 10.5 ms (the speed window and the sampling):
    // K_c = τ/(K · 3 θ_e), T_i = max(τ, 12 θ_e), from the identified model exactly…
    let (l, m) = (result.loops[0], result.models[0]);
    let theta_e = m.dead_time_s.max(0.0) + 0.0105;
    let kc = m.time_constant_s / (m.gain_rad_s_per_v * 3.0 * theta_e);
    assert!(close(l.kp_v_per_rad_s, kc, 1e-4), "{l:?} vs {kc}");
    assert!(
        close(l.ti_s, m.time_constant_s.max(12.0 * theta_e), 1e-5),
        "{l:?}"
    );
    // … and near the truth's (θ = 0).
    assert!(
        close(l.kp_v_per_rad_s, 0.089 / (6.35 * 3.0 * 0.0105), 0.12),
        "{l:?}"
    );
    assert!(close(l.ti_s, 12.0 * 0.0105, 0.1), "{l:?}");
    assert!(!result.warnings.any(), "{:?}", result.warnings);
    assert_eq!((l.td_s, l.d_filter_tau_s), (0.0, 0.0));
    // The tuned loops make a valid robot, with the tuned loops and nothing else changed.
    let robot = *bench.params().config();
    let tuned = result.apply_to(&robot);
    assert!(Params::new(tuned).is_ok());
    assert_eq!(
        (tuned.left_wheel, tuned.right_wheel),
        (result.loops[0], result.loops[1])
    );
    assert_eq!(
        RobotConfig {
            left_wheel: robot.left_wheel,
            right_wheel: robot.right_wheel,
            ..tuned
        },
        robot
    );
}

#[test]
fn lifted_wheels_are_corrected_for_the_chassis() {
    // Lifted, the reference wheel turns 1.1e-4 kg·m² only: τ = 26 ms. The chassis' 0.5 kg
    // on 32.5 mm wheels makes it 89 ms on the ground.
    let mut bench = Bench::new(SyntheticWheel::new(6.35, 0.0262, 0.375));
    let mut c = config(&bench);
    c.load = TuneLoad::lifted(0.5, 0.0325, 1.1e-4);
    let mut tuner = Tuner::new(c, &bench.params());
    let result = bench.run(&mut tuner, None).unwrap();
    for m in result.models {
        assert!(close(m.time_constant_s, 0.0262, 0.06), "{m:?}");
        assert!(close(m.design_time_constant_s, 0.089, 0.06), "{m:?}");
    }
    // The PI is the ground one, not the stand's (about 3× higher).
    let kc = 0.089 / (6.35 * 3.0 * 0.0105);
    assert!(
        close(result.loops[1].kp_v_per_rad_s, kc, 0.12),
        "{:?}",
        result.loops
    );
}

#[test]
fn volts_stay_bounded_and_no_wheel_crosses_zero_speed() {
    let mut bench = Bench::new(ground_wheel());
    let c = config(&bench);
    let mut tuner = Tuner::new(c, &bench.params());
    bench.run(&mut tuner, None).unwrap();
    let limit = c.experiment_volts_v;
    assert!((limit - 4.8).abs() < 1e-6);
    // Both directions ran; every voltage within ±the largest, both wheels alike.
    assert!(bench.asked.iter().any(|v| v.left_v > 2.0));
    assert!(bench.asked.iter().any(|v| v.left_v < -2.0));
    assert!(bench
        .asked
        .iter()
        .all(|v| math::abs(v.left_v) <= limit && v.left_v == v.right_v));
    // Forward (until the first negative voltage) the wheels never turn backwards, and
    // backwards never forwards: the brake stops them at rest.
    let split = bench.asked.iter().position(|v| v.left_v < 0.0).unwrap();
    let (forward, backward) = bench.speeds.split_at(split);
    assert!(forward.iter().flatten().all(|w| *w >= 0.0));
    assert!(backward.iter().flatten().all(|w| *w <= 0.0));
    // And the voltage never goes from one sign to the other without 0 V between.
    for pair in bench.asked.windows(2) {
        assert!(pair[0].left_v * pair[1].left_v >= 0.0, "{pair:?}");
    }
}

#[test]
fn an_inverted_encoder_stops_the_tune_at_once() {
    let mut bench = Bench::new(ground_wheel());
    bench.encoder_sign[1] = -1.0;
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    assert_eq!(
        bench.run(&mut tuner, None),
        Err(TuneAbort::WrongDirection(Side::Right))
    );
    // Within the breakaway: the wheel barely moved.
    assert!(bench.asked.len() < 1_500, "{}", bench.asked.len());
    assert!(bench.asked.iter().all(|v| math::abs(v.left_v) < 1.0));
}

#[test]
fn a_wheel_that_does_not_turn_is_reported_and_the_voltage_stays_bounded() {
    // Static friction beyond u_hi: a blocked wheel.
    let mut bench = Bench::new(SyntheticWheel::new(6.35, 0.089, 5.0));
    let c = config(&bench);
    let mut tuner = Tuner::new(c, &bench.params());
    assert_eq!(
        bench.run(&mut tuner, None),
        Err(TuneAbort::NoBreakaway(Side::Left))
    );
    assert!(bench
        .asked
        .iter()
        .all(|v| math::abs(v.left_v) <= c.experiment_volts_v));
}

#[test]
fn a_late_step_a_speed_limit_or_a_short_leash_stops_the_tune() {
    let mut bench = Bench::new(ground_wheel());
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    assert_eq!(bench.run(&mut tuner, Some(1500)), Err(TuneAbort::LateStep));

    let mut bench = Bench::new(ground_wheel());
    let mut c = config(&bench);
    // The plan keeps the step's speed within half the limit…
    c.max_speed_rad_s = 8.0;
    let mut tuner = Tuner::new(c, &bench.params());
    assert!(bench.run(&mut tuner, None).is_ok());
    assert!(bench.speeds.iter().flatten().all(|w| *w < 8.0));
    // … and a limit the breakaway already passes stops it.
    let mut bench = Bench::new(ground_wheel());
    c.max_speed_rad_s = 1.2;
    let mut tuner = Tuner::new(c, &bench.params());
    assert!(matches!(
        bench.run(&mut tuner, None),
        Err(TuneAbort::TooFast(_))
    ));
    assert!(bench.speeds.iter().flatten().all(|w| *w < 2.0));

    let mut bench = Bench::new(ground_wheel());
    let mut c = config(&bench);
    c.max_distance_m = 0.02;
    let mut tuner = Tuner::new(c, &bench.params());
    assert_eq!(bench.run(&mut tuner, None), Err(TuneAbort::TooFar));
    // Lifted, the odometry's distance means nothing and is not checked.
    let mut bench = Bench::new(ground_wheel());
    c.load = TuneLoad::Lifted {
        ground_inertia_factor: 1.0,
    };
    let mut tuner = Tuner::new(c, &bench.params());
    assert!(bench.run(&mut tuner, None).is_ok());
}

#[test]
fn an_aborted_tune_reports_why_and_asks_for_nothing_more() {
    let bench = Bench::new(ground_wheel());
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    assert!(!tuner.running());
    tuner.start(Pose::default());
    assert!(tuner.running());
    tuner.abort(TuneAbort::Stopped);
    assert!(!tuner.running());
    assert_eq!(tuner.outcome(), Some(Err(TuneAbort::Stopped)));
    assert_eq!(
        tuner.step(bench.controller.telemetry(), 1),
        TuneStep::Finished(Err(TuneAbort::Stopped))
    );
}

#[test]
fn config_bounds_are_where_the_doc_says() {
    let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
    let good = TuneConfig::for_robot(params.config());
    let check = |f: fn(&mut TuneConfig), params: &Params| {
        let mut c = good;
        f(&mut c);
        c.validate(params).map_err(|e| e.field)
    };
    // Up to the rated 6 V, but something.
    assert_eq!(check(|c| c.experiment_volts_v = 6.0, &params), Ok(()));
    assert_eq!(
        check(|c| c.experiment_volts_v = 0.0, &params),
        Err("experiment_volts_v")
    );
    assert_eq!(
        check(|c| c.breakaway_ramp_v_per_s = 0.0, &params),
        Err("breakaway_ramp_v_per_s")
    );
    assert_eq!(
        check(|c| c.max_speed_rad_s = 0.0, &params),
        Err("max_speed_rad_s")
    );
    assert_eq!(
        check(|c| c.tau_c_per_dead_time = 0.0, &params),
        Err("tau_c_per_dead_time")
    );
    // A hold of 0.1 s is 100 steps at 1 kHz, enough; at 400 Hz it is 40, too few.
    assert_eq!(check(|c| c.max_hold_s = 0.1, &params), Ok(()));
    let mut slow = RobotConfig::REFERENCE_ROBOT;
    slow.control_rate_hz = 400;
    let slow = Params::new(slow).unwrap();
    assert_eq!(check(|c| c.max_hold_s = 0.1, &slow), Err("max_hold_s"));
    assert_eq!(check(|c| c.max_hold_s = 0.2, &slow), Ok(()));
    assert_eq!(check(|c| c.max_hold_s = 10.0, &params), Ok(()));
    assert_eq!(check(|c| c.max_hold_s = 10.5, &params), Err("max_hold_s"));
    // The upper bounds are open: the bound itself is refused, just under it is not.
    assert_eq!(
        check(|c| c.breakaway_ramp_v_per_s = 1e3, &params),
        Err("breakaway_ramp_v_per_s")
    );
    assert_eq!(check(|c| c.breakaway_ramp_v_per_s = 999.0, &params), Ok(()));
    assert_eq!(
        check(|c| c.max_speed_rad_s = 1e4, &params),
        Err("max_speed_rad_s")
    );
    assert_eq!(check(|c| c.max_speed_rad_s = 9_999.0, &params), Ok(()));
    assert_eq!(
        check(|c| c.max_distance_m = 1e3, &params),
        Err("max_distance_m")
    );
    assert_eq!(check(|c| c.max_distance_m = 999.0, &params), Ok(()));
    assert_eq!(
        check(|c| c.tau_c_per_dead_time = 100.0, &params),
        Err("tau_c_per_dead_time")
    );
    assert_eq!(check(|c| c.tau_c_per_dead_time = 99.0, &params), Ok(()));
    // Lifted: a factor from 1 up to (not including) 1 000.
    let lifted = |f: f32, params: &Params| {
        let mut c = good;
        c.load = TuneLoad::Lifted {
            ground_inertia_factor: f,
        };
        c.validate(params).map_err(|e| e.field)
    };
    assert_eq!(lifted(1.0, &params), Ok(()));
    assert_eq!(lifted(3.4, &params), Ok(()));
    assert_eq!(lifted(1e3, &params), Err("load.ground_inertia_factor"));
}

#[test]
fn the_leash_is_counted_from_where_the_tune_began() {
    // A tune begun 21 m from the origin, on the ground with a 1.5 m leash: it runs to its
    // end (the leash is measured from the start pose, not from the origin).
    let mut bench = Bench::new(ground_wheel());
    bench.controller = crate::controller::tests::on_a_line_from(Point::new(20.0, -7.0), 5.0);
    assert_eq!(bench.controller.pose(), Pose::new(20.0, -7.0, 0.0));
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    assert!(bench.run(&mut tuner, None).is_ok());
}

#[test]
fn abort_messages_say_what_to_check() {
    let cases = [
        (
            TuneAbort::Stopped,
            "stopped by the supervisor (fault, button, link)",
        ),
        (TuneAbort::NotAtRest, "a wheel was turning at the start"),
        (
            TuneAbort::NoBreakaway(Side::Left),
            "Left wheel did not turn at the largest voltage",
        ),
        (
            TuneAbort::BreakawayTooHigh(Side::Right),
            "Right wheel needs over 70 % of the largest voltage to break away",
        ),
        (
            TuneAbort::WrongDirection(Side::Left),
            "Left wheel turned against its voltage (wiring)",
        ),
        (
            TuneAbort::Stalled(Side::Right),
            "Right wheel stopped while driven",
        ),
        (
            TuneAbort::TooFast(Side::Left),
            "Left wheel exceeded the speed limit",
        ),
        (TuneAbort::TooFar, "the robot left the allowed distance"),
        (TuneAbort::LateStep, "a control step came late"),
        (
            TuneAbort::NotStopped,
            "the wheels did not stop under the brake",
        ),
        (
            TuneAbort::NoFit(Side::Right),
            "Right wheel's response did not fit",
        ),
        (
            TuneAbort::Inconsistent(Side::Left),
            "Left wheel's measurements disagree by over 30 %",
        ),
    ];
    for (abort, text) in cases {
        assert_eq!(abort.to_string(), text);
    }
}

#[test]
fn config_errors_name_the_field() {
    let params = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
    let good = TuneConfig::for_robot(params.config());
    assert_eq!(good.validate(&params), Ok(()));
    let bad = |f: fn(&mut TuneConfig)| {
        let mut c = good;
        f(&mut c);
        c.validate(&params).unwrap_err()
    };
    assert_eq!(
        bad(|c| c.experiment_volts_v = 7.0).field,
        "experiment_volts_v"
    );
    assert_eq!(bad(|c| c.max_hold_s = f32::NAN).field, "max_hold_s");
    assert_eq!(bad(|c| c.max_distance_m = 0.0).field, "max_distance_m");
    let e = bad(|c| {
        c.load = TuneLoad::Lifted {
            ground_inertia_factor: 0.5,
        }
    });
    assert_eq!(e.field, "load.ground_inertia_factor");
    assert_eq!(
        format!("{e}"),
        "tune.load.ground_inertia_factor is out of range, got 0.5"
    );
    // The reference robot's lifted factor.
    let TuneLoad::Lifted {
        ground_inertia_factor,
    } = TuneLoad::lifted(0.5, 0.0325, 1.1e-4)
    else {
        panic!()
    };
    assert!((ground_inertia_factor - 3.4006).abs() < 1e-3);
}

#[test]
fn once_turning_the_voltage_stays_well_above_breakaway_until_the_brake() {
    let mut bench = Bench::new(ground_wheel());
    let c = config(&bench);
    let mut tuner = Tuner::new(c, &bench.params());
    bench.run(&mut tuner, None).unwrap();
    // The forward half: after the breakaway ramp's peak, every voltage is 0 (the brake)
    // or at least u_lo = k_S + 0.07 (u_max − k_S), well above the static friction k_S.
    let split = bench.asked.iter().position(|v| v.left_v < 0.0).unwrap();
    let forward = &bench.asked[..split];
    let moved = bench
        .speeds
        .iter()
        .position(|w| w[0] >= MOVING_RAD_S)
        .unwrap();
    let ks = ground_wheel().ks;
    let floor = ks + 0.07 * (c.experiment_volts_v - ks);
    let after = &forward[moved + 1..];
    let experiment: Vec<f32> = after
        .iter()
        .map(|v| v.left_v)
        .take_while(|v| *v != 0.0)
        .collect();
    assert!(experiment.len() > 2000, "{}", experiment.len());
    assert!(
        experiment.iter().all(|v| *v >= 0.97 * floor),
        "min {:?} floor {floor}",
        experiment.iter().copied().reduce(f32::min)
    );
    // And the wheels kept turning all along (the speed never fell to rest before the
    // brake).
    let stopped_at = moved + 1 + experiment.len();
    assert!(bench.speeds[moved + 50..stopped_at]
        .iter()
        .all(|w| w[0] > 1.0 && w[1] > 1.0));
}

#[test]
fn a_wheel_that_stops_while_driven_stops_the_tune() {
    for side in Side::BOTH {
        let mut bench = Bench::new(ground_wheel());
        // Blocked in the middle of the forward experiment (the hold or the step).
        bench.block = Some((side, 2000..usize::MAX, 10.0));
        let mut tuner = Tuner::new(config(&bench), &bench.params());
        assert_eq!(bench.run(&mut tuner, None), Err(TuneAbort::Stalled(side)));
        // Within the speed window and its grace of the block, not at the end of the phase.
        assert!(bench.asked.len() < 2000 + 300, "{}", bench.asked.len());
    }
}

#[test]
fn directions_that_disagree_are_refused_and_small_differences_averaged() {
    // 10 % more gain backwards: one motor, averaged.
    let mut wheel = ground_wheel();
    wheel.backward = (1.1 * wheel.gain, wheel.tau);
    let mut bench = Bench::new(wheel);
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    let result = bench.run(&mut tuner, None).unwrap();
    for m in result.models {
        assert!(close(m.gain_rad_s_per_v, 1.05 * 6.35, 0.03), "{m:?}");
    }
    // 50 % more gain, or a 60 % longer time constant, backwards: more than the 30 %
    // accepted as one motor.
    for backward in [(1.5 * wheel.gain, wheel.tau), (wheel.gain, 1.6 * wheel.tau)] {
        let mut odd = ground_wheel();
        odd.backward = backward;
        let mut bench = Bench::new(ground_wheel());
        bench.wheels[1] = odd;
        let mut tuner = Tuner::new(config(&bench), &bench.params());
        assert_eq!(
            bench.run(&mut tuner, None),
            Err(TuneAbort::Inconsistent(Side::Right)),
            "{backward:?}"
        );
    }
}

#[test]
fn the_defaults_follow_the_robot() {
    // u_hi is 40 % of the rated voltage and the speed limit 75 % of the top speed at the
    // rated voltage, for any motor; the rest are fixed.
    let mut robot = RobotConfig::REFERENCE_ROBOT;
    for rated in [6.0, 12.0] {
        robot.motor.rated_voltage_v = rated;
        let c = TuneConfig::for_robot(&robot);
        assert!(close(c.experiment_volts_v, 0.8 * rated, 1e-6), "{c:?}");
        let top = robot.left_wheel.speed_at_volts(rated);
        assert!(top > 5.0 * rated, "{top}");
        assert!(close(c.max_speed_rad_s, 0.75 * top, 1e-6), "{c:?}");
        assert_eq!(
            (c.breakaway_ramp_v_per_s, c.max_hold_s, c.max_distance_m),
            (0.5, 4.0, 1.5)
        );
        assert_eq!((c.tau_c_per_dead_time, c.load), (2.0, TuneLoad::Ground));
    }
}

/// Where the hold begins in `asked`: the jump from the breakaway ramp (1 mV a step) to
/// u_lo.
fn hold_start(asked: &[WheelVolts]) -> usize {
    1 + asked
        .windows(2)
        .position(|pair| pair[1].left_v - pair[0].left_v > 0.05)
        .unwrap()
}

#[test]
fn the_hold_lies_seven_hundredths_of_the_way_from_the_breakaway_to_the_largest_voltage() {
    let mut bench = Bench::new(ground_wheel());
    let c = config(&bench);
    let mut tuner = Tuner::new(c, &bench.params());
    bench.run(&mut tuner, None).unwrap();
    let at = hold_start(&bench.asked);
    // The last voltage of the ramp is the one both wheels were seen turning at.
    let breakaway = bench.asked[at - 1].left_v;
    assert!(
        breakaway > ground_wheel().ks && breakaway < 1.0,
        "{breakaway}"
    );
    let low = breakaway + 0.07 * (c.experiment_volts_v - breakaway);
    assert!(
        math::abs(bench.asked[at].left_v - low) < 2e-3,
        "{:?} vs {low}",
        bench.asked[at]
    );
}

#[test]
fn a_breakaway_above_seven_tenths_of_the_largest_voltage_is_refused_and_names_its_wheel() {
    // At most 4.8 V: a wheel that needs more than 3.36 V to turn leaves too little room
    // between u_lo and the largest voltage for a clean step.
    for (stiff, side) in [(0, Side::Left), (1, Side::Right)] {
        let mut bench = Bench::new(ground_wheel());
        bench.wheels[stiff].ks = 3.5;
        let mut tuner = Tuner::new(config(&bench), &bench.params());
        assert_eq!(
            bench.run(&mut tuner, None),
            Err(TuneAbort::BreakawayTooHigh(side))
        );
        // Refused as soon as it is known: at about 3.5 V of the 0.5 V/s ramp, plus the
        // time to reach 1 rad/s.
        assert!(bench.asked.len() < 7_500, "{}", bench.asked.len());
    }
    // A stiff wheel under the limit is tuned.
    let mut bench = Bench::new(ground_wheel());
    bench.wheels[1].ks = 1.0;
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    assert!(bench.run(&mut tuner, None).is_ok());
}

#[test]
fn a_wheel_that_sticks_for_a_moment_as_the_hold_begins_is_given_time() {
    let mut bench = Bench::new(ground_wheel());
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    bench.run(&mut tuner, None).unwrap();
    let at = hold_start(&bench.asked);
    // Stuck for 50 ms early in the hold (a stone, cogging): within the hold's first
    // 100 ms a stopped wheel is waited for, the hold's fit starts again after it, and
    // the tune ends normally.
    let mut bench = Bench::new(ground_wheel());
    bench.block = Some((Side::Left, at + 10..at + 60, 10.0));
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    let outcome = bench.run(&mut tuner, None);
    assert!(outcome.is_ok_and(|r| !r.warnings.any()), "{outcome:?}");
    assert!(bench.speeds[at + 30..at + 60].iter().all(|w| w[0] == 0.0));
    // The same 80 ms later in the hold stops it.
    let mut bench = Bench::new(ground_wheel());
    bench.block = Some((Side::Left, at + 300..at + 380, 10.0));
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    assert_eq!(
        bench.run(&mut tuner, None),
        Err(TuneAbort::Stalled(Side::Left))
    );
}

/// The forward half's phases in `asked` after the breakaway: (volts at u_lo, volts at
/// u_hi, the ramp from u_hi down to its last voltage above 0).
fn forward_phases(asked: &[WheelVolts]) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let forward: Vec<f32> = asked.iter().map(|v| v.left_v).collect();
    let at = hold_start(asked);
    let low = forward[at];
    let hold: Vec<f32> = forward[at..]
        .iter()
        .copied()
        .take_while(|u| *u == low)
        .collect();
    let high = forward[at + hold.len()];
    let step: Vec<f32> = forward[at + hold.len()..]
        .iter()
        .copied()
        .take_while(|u| *u == high)
        .collect();
    let ramp: Vec<f32> = core::iter::once(high)
        .chain(
            forward[at + hold.len() + step.len()..]
                .iter()
                .copied()
                .take_while(|u| *u > 0.0),
        )
        .collect();
    (hold, step, ramp)
}

#[test]
fn the_hold_settles_and_the_step_and_the_ramp_follow_the_wheels_time_constant() {
    for tau in [0.089, 0.25] {
        let mut bench = Bench::new(SyntheticWheel::new(6.35, tau, 0.375));
        let c = config(&bench);
        let mut tuner = Tuner::new(c, &bench.params());
        let result = bench.run(&mut tuner, None).unwrap();
        assert!(!result.warnings.any(), "{:?}", result.warnings);
        let m = result.models[0];
        assert!(close(m.time_constant_s, tau, 0.05), "{m:?} vs τ {tau}");
        let (hold, step, ramp) = forward_phases(&bench.asked);
        let taus = |n: usize| n as f32 * 0.001 / tau;
        // The hold ends at a checkpoint (0.1 s × 1.5^k) past 5 τ; the step lasts 7 of the
        // hold's τ + θ (a rough estimate: within a fifth).
        assert!(
            taus(hold.len()) >= 5.0 && taus(hold.len()) < 9.0,
            "{}",
            hold.len()
        );
        assert!(
            taus(step.len()) > 5.6 && taus(step.len()) < 8.4,
            "{} steps at u_hi",
            step.len()
        );
        // The ramp falls by the same amount every step, from u_hi to u_lo, over 12 τ
        // where the distance budget allows it (the faster wheel), at least 5 τ.
        let fall = ramp[0] - ramp[1];
        assert!(fall > 1e-5, "{fall}");
        for pair in ramp.windows(2) {
            assert!(
                math::abs(pair[0] - pair[1] - fall) < 1e-5,
                "{pair:?} vs {fall}"
            );
        }
        assert!(*ramp.last().unwrap() <= hold[0] + fall, "{:?}", ramp.last());
        let twelve = 12.0 * m.time_constant_s / 0.001;
        let ramp_steps = ramp.len() as f32 - 1.0;
        if tau < 0.1 {
            assert!(close(ramp_steps, twelve, 0.01), "{ramp_steps} vs {twelve}");
        } else {
            assert!(
                ramp_steps >= 0.49 * twelve && ramp_steps <= twelve,
                "{ramp_steps}"
            );
        }
    }
}

#[test]
fn a_step_cut_short_by_the_longest_hold_is_reported_unsettled() {
    // τ = 250 ms with holds and steps of at most 0.5 s (2 τ): the tune ends, but says
    // that its steps had not settled; with 4 s they had.
    let wheel = SyntheticWheel::new(6.35, 0.25, 0.375);
    let mut bench = Bench::new(wheel);
    let mut c = config(&bench);
    c.max_hold_s = 0.5;
    let mut tuner = Tuner::new(c, &bench.params());
    let result = bench.run(&mut tuner, None).unwrap();
    let w = result.warnings;
    assert_eq!(w.step_not_settled, [true, true], "{w:?}");
    assert_eq!(w.hold_not_settled, [true, true], "{w:?}");
    assert_eq!(
        w.to_string(),
        "Left wheel's hold had not settled (K may be off); Right wheel's hold had not \
settled (K may be off); Left wheel's step had not settled (τ likely low); Right \
wheel's step had not settled (τ likely low)"
    );
    let mut bench = Bench::new(wheel);
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    let result = bench.run(&mut tuner, None).unwrap();
    assert_eq!(result.warnings, TuneWarnings::default());
    assert_eq!(result.warnings.to_string(), "");
}

#[test]
fn a_wheel_with_dead_time_is_identified_with_it() {
    // 15 ms between the bridge and the wheel: θ is that plus the tune's own period, and
    // k_S, which the ramp's lag (τ + θ + the speed window) corrects, stays right
    // (measured: θ 16.05 ms, k_S 0.379 V).
    let mut bench = Bench::new(ground_wheel());
    bench.dead_steps = 15;
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    let result = bench.run(&mut tuner, None).unwrap();
    for m in result.models {
        assert!(math::abs(m.dead_time_s - 0.016) < 1e-3, "{m:?}");
        assert!(close(m.time_constant_s, 0.089, 0.05), "{m:?}");
        assert!(close(m.ks_v, 0.375, 0.03), "{m:?}");
    }
}

#[test]
fn the_bank_follows_the_control_period_across_new_settings_and_starts() {
    let fast = Params::new(RobotConfig::REFERENCE_ROBOT).unwrap();
    let mut slow = RobotConfig::REFERENCE_ROBOT;
    slow.control_rate_hz = 400;
    let slow = Params::new(slow).unwrap();
    let config = TuneConfig::for_robot(&RobotConfig::REFERENCE_ROBOT);
    let fresh = |p: &Params| Bank::new(p.period_s());
    let mut tuner = Tuner::new(config, &fast);
    assert_eq!(tuner.bank, fresh(&fast));
    // A new period computes new decay factors; the same one keeps them, and a start
    // restarts the bank.
    tuner.set_config(config, &slow);
    assert_eq!(tuner.bank, fresh(&slow), "400 Hz");
    tuner.bank.advance();
    assert_ne!(tuner.bank, fresh(&slow), "a stepped bank has moved on");
    let moved = tuner.bank;
    tuner.set_config(config, &slow);
    assert_eq!(tuner.bank, moved, "same period: left as it is");
    tuner.start(Pose::default());
    assert_eq!(tuner.bank, fresh(&slow), "a start restarts it");
    tuner.set_config(config, &fast);
    assert_eq!(tuner.bank, fresh(&fast), "back to 1 kHz");
}

#[test]
fn a_fast_wheel_whose_hold_is_too_small_to_fit_is_planned_from_its_bounds() {
    // τ = 17.6 ms, K = 4.54 rad/s per V: the hold's change, about 1.2 rad/s (five quanta
    // of the speed estimate), does not fit; steady after 0.15 s, it bounds τ + θ by
    // 30 ms and gives K from its tails, and the step is planned from those.
    let mut bench = Bench::new(SyntheticWheel::new(4.54, 0.0176, 0.52));
    let mut tuner = Tuner::new(config(&bench), &bench.params());
    let result = bench.run(&mut tuner, None).unwrap();
    assert!(!result.warnings.any(), "{:?}", result.warnings);
    for m in result.models {
        assert!(close(m.time_constant_s, 0.0176, 0.05), "{m:?}");
        assert!(close(m.gain_rad_s_per_v, 4.54, 0.03), "{m:?}");
        assert!(close(m.ks_v, 0.52, 0.1), "{m:?}");
    }
}
