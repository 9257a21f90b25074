//! The plant against closed-form solutions, conservation laws and its own stage-by-stage
//! integrator.

use super::integration::Propagators;
use super::*;
use crate::plant::{BridgeOutput, PowerFlow};
use core::f64::consts::PI;
use robot_files::plant::{BodyParams, DriverParams, MotorMismatch, MotorParams, Wheel};
use robot_files::rng::Rng;
use robot_files::truth::TruePose;

const H: f64 = 1e-4;

fn params() -> PlantParams {
    PlantParams {
        motor: MotorParams::DEFAULT,
        motor_mismatch: MotorMismatch::NONE,
        driver: DriverParams::DEFAULT,
        gear_ratio: 30.0,
        body: BodyParams::DEFAULT,
        geometry: TrueGeometry {
            wheel_radius_left_m: 0.0325,
            wheel_radius_right_m: 0.0325,
            track_width_m: 0.15,
        },
        slip: [0.0; 2],
        load: Load::Ground,
    }
}

/// No Coulomb or viscous friction: what is left is inertia, the bridge and the
/// centre-of-mass terms.
fn frictionless() -> PlantParams {
    let mut pp = params();
    pp.motor.coulomb_friction_nm = 0.0;
    pp.motor.viscous_friction_nm_s_per_rad = 0.0;
    pp
}

/// Steps of `H` until `done` holds (at most `max` steps); the count.
fn steps_until(p: &mut Plant, max: u32, done: impl Fn(&Plant) -> bool) -> u32 {
    let mut n = 0;
    while !done(p) && n < max {
        p.advance(H, 1);
        n += 1;
    }
    n
}

#[test]
fn full_duty_reaches_the_no_load_speed() {
    let mut p = Plant::new(params()).unwrap();
    p.set_duty(1.0, 1.0);
    for _ in 0..2000 {
        p.advance(H, 10);
    }
    let expected = p.drive(Wheel::Left).steady_speed_rad_s(6.0);
    let w = p.wheel_speeds();
    assert!((w[0] - expected).abs() < 1e-6 && (w[1] - expected).abs() < 1e-6);
    // Straight line: no yaw, moved along x.
    let pose = p.pose();
    assert!(pose.theta_rad.abs() < 1e-12 && pose.y_m.abs() < 1e-12 && pose.x_m > 1.0);
}

#[test]
fn each_wheel_has_its_own_motor() {
    // The left motor's K_t = K_e 10 % above the right's, its Coulomb friction 20 % below.
    let mut pp = params();
    pp.motor_mismatch = MotorMismatch {
        torque_constant_left_right_pct: 10.0,
        coulomb_friction_left_right_pct: -20.0,
        ..MotorMismatch::NONE
    };
    let (left, right) = {
        let p = Plant::new(pp).unwrap();
        (*p.drive(Wheel::Left), *p.drive(Wheel::Right))
    };
    assert!(left.coulomb_nm < right.coulomb_nm);
    // Lifted, the wheels are not coupled: each settles at its own motor's speed.
    let mut lifted = Plant::new(PlantParams {
        load: Load::Lifted,
        ..pp
    })
    .unwrap();
    lifted.set_duty(0.5, 0.5);
    lifted.advance(H, 20_000);
    let w = lifted.wheel_speeds();
    assert!((w[0] - left.steady_speed_rad_s(3.0)).abs() < 1e-6, "{w:?}");
    assert!((w[1] - right.steady_speed_rad_s(3.0)).abs() < 1e-6, "{w:?}");
    assert!(w[0] != w[1]);
    // On the ground the same duties turn the robot: the left motor's larger back-EMF
    // constant gives it the lower speed per volt, so the robot turns left (heading
    // increasing).
    let mut ground = Plant::new(pp).unwrap();
    ground.set_duty(0.5, 0.5);
    ground.advance(H, 10_000);
    let pose = ground.pose();
    assert!(w[0] < w[1]);
    assert!(pose.theta_rad > 0.01 && pose.x_m > 0.1, "{pose:?}");
    // With no mismatch the same robot drives straight.
    let mut nominal = Plant::new(params()).unwrap();
    nominal.set_duty(0.5, 0.5);
    nominal.advance(H, 10_000);
    assert_eq!(nominal.pose().theta_rad, 0.0);
}

#[test]
fn rk4_matches_the_first_order_solution() {
    // Both wheels equal: ω(t) = ω∞ (1 − e^{−t/τ}) with τ = (a + b) / damping.
    let pp = params();
    let mut p = Plant::new(pp).unwrap();
    p.set_duty(0.5, 0.5);
    p.advance(H, 500); // 50 ms
    let d = *p.drive(Wheel::Left);
    let r = 0.0325;
    let j = pp.body.wheel_inertia_kg_m2
        + pp.motor.rotor_inertia_kg_m2 * 900.0
        + pp.body.mass_kg * r * r / 2.0;
    let tau = j / d.damping_nm_s_per_rad(PowerFlow::Motoring);
    let w_inf = d.steady_speed_rad_s(3.0);
    let exact = w_inf * (1.0 - (-0.05 / tau).exp());
    assert!(
        (p.wheel_speeds()[0] - exact).abs() < 1e-9,
        "{:?} {exact}",
        p.wheel_speeds()
    );
}

#[test]
fn lifted_wheels_see_only_their_own_inertia_and_the_robot_stays_put() {
    let mut pp = params();
    pp.load = Load::Lifted;
    let mut p = Plant::new(pp).unwrap();
    let j_w = pp.body.wheel_inertia_kg_m2 + pp.motor.rotor_inertia_kg_m2 * 900.0;
    assert_eq!(p.inertia_kg_m2(), [j_w, 0.0]);
    // Only the left wheel driven: the right one is not dragged along (no coupling).
    p.set_duty(0.5, 0.0);
    p.advance(H, 100); // 10 ms
    let d = *p.drive(Wheel::Left);
    let tau = j_w / d.damping_nm_s_per_rad(PowerFlow::Motoring);
    assert!((tau - 0.0262).abs() < 1e-3, "{tau}");
    let w_inf = d.steady_speed_rad_s(3.0);
    let exact = w_inf * (1.0 - (-0.01 / tau).exp());
    let w = p.wheel_speeds();
    assert!((w[0] - exact).abs() < 1e-6, "{} vs {exact}", w[0]);
    assert_eq!(w[1], 0.0);
    assert_eq!(p.pose(), TruePose::default());
    assert_eq!(p.body_velocity(), (0.0, 0.0));
    // On the ground the same duty meets the chassis: slower, and the robot moves.
    let mut ground = Plant::new(params()).unwrap();
    ground.set_duty(0.5, 0.0);
    ground.advance(H, 100);
    assert!(ground.wheel_speeds()[0] < 0.7 * w[0]);
    assert!(ground.pose().x_m != 0.0);
}

#[test]
fn spinning_on_the_spot_turns_by_the_wheel_arc() {
    let mut p = Plant::new(params()).unwrap();
    p.reset(TruePose::default(), [-10.0, 10.0]);
    p.set_duty(0.0, 0.0);
    p.advance(H, 1);
    // Braked spin: position stays at the origin, heading follows the wheels.
    let [al, ar] = p.wheel_angles();
    let pose = p.pose();
    assert!(pose.x_m.abs() < 1e-12 && pose.y_m.abs() < 1e-12);
    assert!((pose.theta_rad - 0.0325 * (ar - al) / 0.15).abs() < 1e-12);
}

#[test]
fn constant_arc_closes_a_circle() {
    // No Coulomb friction, a fine PWM and no dead-band: the steady voltage for each
    // wheel's speed holds it exactly, so the robot drives a circle of radius v/ω and
    // comes back to its start after 2π/ω.
    let mut pp = params();
    pp.motor.coulomb_friction_nm = 0.0;
    pp.driver.pwm_levels = u32::MAX;
    pp.driver.dead_band_duty = 0.0;
    let mut p = Plant::new(pp).unwrap();
    let speeds = p.wheel_speeds_for(0.25, 0.2);
    p.reset(TruePose::default(), speeds);
    let d = *p.drive(Wheel::Left);
    let duty = |w: f64| (d.steady_volts(w) / 6.0) as f32;
    p.set_duty(duty(speeds[0]), duty(speeds[1]));
    let period_steps = (2.0 * PI / 0.2 / H).round() as u32;
    p.advance(H, period_steps);
    let pose = p.pose();
    // f32 duty resolution limits the speed balance to ~1e-7 relative.
    assert!(pose.x_m.abs() < 2e-3 && pose.y_m.abs() < 2e-3, "{pose:?}");
}

#[test]
fn closed_form_rk4_equals_stage_by_stage_rk4_in_every_regime() {
    let mut p = Plant::new(params()).unwrap();
    let rk4 = Propagators::new(&p.drives, &p.friction.inertia, H, false);
    let mut rng = Rng::new(5);
    // Regime pair × direction pattern: how often each was compared.
    let mut seen = [[0u32; 4]; 9];
    let mut taken = 0;
    for _ in 0..40_000 {
        p.set_motor_connected(Wheel::Left, rng.uniform() > 0.3);
        p.set_motor_connected(Wheel::Right, rng.uniform() > 0.3);
        p.set_duty(rng.symmetric(1.0) as f32, rng.symmetric(1.0) as f32);
        let w = [rng.symmetric(40.0), rng.symmetric(40.0)];
        let affine = p.affine(w, &rk4);
        let Some((w_fast, phi_fast)) = p.closed_form_step(&rk4, w, &affine) else {
            continue;
        };
        taken += 1;
        let (w_ref, phi_ref) = p.rk4_step(w, H);
        for i in 0..2 {
            assert!((w_fast[i] - w_ref[i]).abs() < 1e-11, "{w_fast:?} {w_ref:?}");
            assert!(
                (phi_fast[i] - phi_ref[i]).abs() < 1e-15,
                "{phi_fast:?} {phi_ref:?}"
            );
        }
        // The end of the step is in the same regime (what lets `advance` keep it).
        assert_eq!(p.affine(w_fast, &rk4), affine);
        let signs = usize::from(w[0] > 0.0) * 2 + usize::from(w[1] > 0.0);
        seen[affine.index][signs] += 1;
    }
    // Every regime pair in every direction was exercised, and the guard lets almost
    // every random state through.
    for (index, counts) in seen.iter().enumerate() {
        for (signs, n) in counts.iter().enumerate() {
            assert!(*n >= 20, "regime {index}, directions {signs}: {n}");
        }
    }
    assert!(taken > 38_000, "{taken}");

    // The guard matters: a back-driven wheel just above its zero-current speed crosses
    // into motoring within the step; the closed form of the starting regime would then
    // be wrong, and it is not used.
    p.set_motor_connected(Wheel::Left, true);
    p.set_motor_connected(Wheel::Right, true);
    p.set_duty(0.5, 0.5);
    let w = [p.zero_current_speed[0] + 1e-3, 10.0];
    let affine = p.affine(w, &rk4);
    assert!(p.closed_form_step(&rk4, w, &affine).is_none());
    let (w_naive, _) = rk4.table[affine.index].step(w, affine.sb, affine.tb);
    let (w_ref, _) = p.rk4_step(w, H);
    assert!(w_ref[0] < p.zero_current_speed[0], "the step crosses");
    assert!(
        (w_naive[0] - w_ref[0]).abs() > 1e-9,
        "{w_naive:?} {w_ref:?}"
    );

    // At rest, stage by stage (static friction): a small duty does not move the wheel.
    p.reset(TruePose::default(), [0.0, 0.0]);
    p.set_duty(0.03, 0.03);
    p.advance(H, 10);
    assert_eq!(p.wheel_speeds(), [0.0, 0.0]);
}

#[test]
fn closed_form_and_stage_by_stage_runs_agree() {
    // A second of random duties, changed every millisecond, through rest, reversals
    // and current sign changes: RK4's closed form and the full model stay together.
    let mut fast = Plant::new(params()).unwrap();
    fast.set_integration(Integration::Rk4);
    let mut full = fast.clone();
    full.set_integration(Integration::Rk4Stages);
    let mut rng = Rng::new(11);
    for _ in 0..1000 {
        let (l, r) = (rng.symmetric(1.0) as f32, rng.symmetric(1.0) as f32);
        fast.set_duty(l, r);
        full.set_duty(l, r);
        fast.advance(H, 10);
        full.advance(H, 10);
    }
    let (a, b) = (fast.pose(), full.pose());
    assert!(fast.wheel_speeds()[0] != 0.0);
    for i in 0..2 {
        assert!((fast.wheel_speeds()[i] - full.wheel_speeds()[i]).abs() < 1e-9);
        assert!((fast.wheel_angles()[i] - full.wheel_angles()[i]).abs() < 1e-9);
    }
    assert!((a.x_m - b.x_m).abs() < 1e-9 && (a.y_m - b.y_m).abs() < 1e-9);
    assert!((a.theta_rad - b.theta_rad).abs() < 1e-9);
}

#[test]
fn a_braked_wheel_stops_much_sooner_than_a_coasting_one() {
    // Both wheels from ω₀ with duty 0: each obeys J ω̇ = −D ω − τ_c (J = a + b), so it
    // stops after (J/D) ln(1 + D ω₀ / τ_c). Braked (enabled, short brake), the wheel
    // back-drives the motor: D = N² K_t K_e / (η (R_a + R_bridge)) + b. Coasting
    // (disabled), no current: D = b.
    let w0 = 30.0;
    let mut stop_s = [0.0; 2];
    let mut initial_decel = [0.0; 2];
    for (k, enabled) in [true, false].into_iter().enumerate() {
        let mut p = Plant::new(params()).unwrap();
        p.reset(TruePose::default(), [w0, w0]);
        p.set_duty(0.0, 0.0);
        p.set_driver_enabled(enabled);
        let d = *p.drive(Wheel::Left);
        let flow = if enabled {
            PowerFlow::BackDriven
        } else {
            PowerFlow::Coasting
        };
        let damping = d.damping_nm_s_per_rad(flow);
        let j = p.friction.inertia.a + p.friction.inertia.b;
        p.advance(H, 1);
        // One step against the exact solution (ω₀ + τ_c/D) e^{−D t / J} − τ_c/D.
        let offset = d.coulomb_nm / damping;
        let exact = (w0 + offset) * (-damping * H / j).exp() - offset;
        assert!((p.wheel_speeds()[0] - exact).abs() < 1e-9, "{exact}");
        initial_decel[k] = (w0 - p.wheel_speeds()[0]) / H;
        let steps = 1 + steps_until(&mut p, 100_000, |p| p.wheel_speeds()[0] == 0.0);
        stop_s[k] = f64::from(steps) * H;
        let expected = j / damping * (damping * w0 / d.coulomb_nm).ln_1p();
        assert!(
            stop_s[k] >= expected - 1e-9 && stop_s[k] <= expected + H + 1e-9,
            "{stop_s:?} {expected}"
        );
        // Stopped, it stays stopped (braked or not, nothing drives it).
        p.advance(H, 100);
        assert_eq!(p.wheel_speeds(), [0.0, 0.0]);
    }
    // The default robot at 30 rad/s: the brake decelerates 12.7 × harder.
    let d = *Plant::new(params()).unwrap().drive(Wheel::Left);
    let ratio = (d.damping_nm_s_per_rad(PowerFlow::BackDriven) * w0 + d.coulomb_nm)
        / (d.viscous_nm_s_per_rad * w0 + d.coulomb_nm);
    assert!((initial_decel[0] / initial_decel[1] / ratio - 1.0).abs() < 2e-3);
    assert!(ratio > 12.0, "{ratio}");
    assert!(stop_s[1] > 4.0 * stop_s[0], "{stop_s:?}");
}

#[test]
fn disabled_driver_and_disconnected_motor_coast() {
    let mut p = Plant::new(params()).unwrap();
    p.reset(TruePose::default(), [15.0, 15.0]);
    p.set_duty(0.5, 0.5);
    assert_eq!(p.bridge_outputs(), [BridgeOutput::Drive { volts: 3.0 }; 2]);
    assert!(p.currents_a().iter().all(|i| i.abs() > 0.01));
    // Disabled: both coast, no current; enabling again restores the duties.
    p.set_driver_enabled(false);
    assert!(!p.driver_enabled());
    assert_eq!(p.bridge_outputs(), [BridgeOutput::Coast; 2]);
    assert_eq!(p.currents_a(), [0.0, 0.0]);
    let mut coasting = p.clone();
    coasting.advance(H, 1);
    let d = *p.drive(Wheel::Left);
    let j = p.friction.inertia.a + p.friction.inertia.b;
    let decel = (15.0 - coasting.wheel_speeds()[0]) / H;
    let expected = (d.viscous_nm_s_per_rad * 15.0 + d.coulomb_nm) / j;
    assert!((decel / expected - 1.0).abs() < 1e-3, "{decel} {expected}");
    p.set_driver_enabled(true);
    assert_eq!(p.bridge_outputs(), [BridgeOutput::Drive { volts: 3.0 }; 2]);

    // The left motor's leads off: it coasts whatever the duty, the right one drives.
    p.set_motor_connected(Wheel::Left, false);
    assert_eq!(p.motor_connected(), [false, true]);
    assert_eq!(
        p.bridge_outputs(),
        [BridgeOutput::Coast, BridgeOutput::Drive { volts: 3.0 }]
    );
    p.set_duty(1.0, 0.5);
    assert_eq!(p.currents_a()[0], 0.0);
    p.advance(H, 10_000);
    let [wl, wr] = p.wheel_speeds();
    assert!(wr > 15.0 && wl < wr - 10.0, "{wl} {wr}");
    // Reconnected, full duty takes the left wheel past the right one.
    p.set_motor_connected(Wheel::Left, true);
    p.advance(H, 5000);
    let [wl, wr] = p.wheel_speeds();
    assert!(wl > wr + 5.0, "{wl} {wr}");
}

/// The right motor disconnected (coasting) and the left one driven from rest at
/// `duty`: the largest |right speed| seen over 0.3 s, and whether the left moved.
fn drag(pp: PlantParams, duty: f32) -> (f64, bool) {
    let mut p = Plant::new(pp).unwrap();
    p.set_motor_connected(Wheel::Right, false);
    p.set_duty(duty, 0.0);
    let mut biggest = 0.0_f64;
    for _ in 0..3000 {
        p.advance(H, 1);
        let w = p.wheel_speeds()[1];
        if w.abs() > biggest.abs() {
            biggest = w;
        }
    }
    (biggest, p.wheel_speeds()[0] > 1.0)
}

#[test]
fn a_wheel_at_rest_is_dragged_only_when_the_coupling_beats_static_friction() {
    // Holding the right wheel while the left breaks away with net torque τ_l − τ_c
    // takes f = b (τ_l − τ_c) / a of static friction on the right. Duties giving 1.5 τ_c
    // and 0.5 τ_c of pull, for the default body (b > 0: turning is the cheaper motion,
    // a − b < a + b, so the right wheel is pulled backward as the robot yaws) and a
    // body with a large yaw inertia (b < 0: translating is cheaper, pulled forward).
    let mut heavy_yaw = params();
    heavy_yaw.body.yaw_inertia_kg_m2 = 5e-3;
    for pp in [params(), heavy_yaw] {
        let p = Plant::new(pp).unwrap();
        let d = *p.drive(Wheel::Left);
        let (a, b) = (p.friction.inertia.a, p.friction.inertia.b);
        let stall_per_duty = d.efficiency * d.torque_per_volt * pp.driver.supply_v;
        let duty_for_pull = |pull: f64| {
            let torque = d.coulomb_nm + pull * d.coulomb_nm * a / b.abs();
            (torque / stall_per_duty) as f32
        };
        let (strong, weak) = (duty_for_pull(1.5), duty_for_pull(0.5));
        assert!(strong < 1.0 && weak > 0.0, "{strong} {weak}");
        let (dragged, left_moved) = drag(pp, strong);
        assert!(left_moved);
        assert!(dragged * b.signum() < -0.05, "b = {b}: {dragged}");
        let (held, left_moved) = drag(pp, weak);
        assert!(left_moved);
        assert_eq!(held, 0.0, "b = {b}");
    }
}

#[test]
fn a_blocked_wheel_stays_at_zero_and_the_robot_pivots_about_it() {
    let mut p = Plant::new(params()).unwrap();
    p.set_wheel_blocked(Wheel::Left, true);
    assert_eq!(p.wheel_blocked(), [true, false]);
    p.set_duty(1.0, 0.6);
    p.advance(H, 15_000);
    assert_eq!(p.wheel_speeds()[0], 0.0);
    assert_eq!(p.wheel_angles()[0], 0.0);
    // Held, the right wheel alone sees inertia a: it settles at its own steady speed.
    let steady = p.drive(Wheel::Left).steady_speed_rad_s(0.6 * 6.0);
    assert!((p.wheel_speeds()[1] - steady).abs() < 1e-6);
    // The left contact point (0, L/2) has not moved.
    let pose = p.pose();
    let left_x = pose.x_m - 0.075 * pose.theta_rad.sin();
    let left_y = pose.y_m + 0.075 * pose.theta_rad.cos();
    assert!(
        left_x.abs() < 1e-12 && (left_y - 0.075).abs() < 1e-12,
        "{pose:?}"
    );
    assert!(p.wheel_angles()[1] > 10.0);
    // Released, the full duty breaks it away.
    p.set_wheel_blocked(Wheel::Left, false);
    p.advance(H, 100);
    assert!(p.wheel_speeds()[0] > 1.0);
    // Blocking a turning wheel stops it at once.
    p.set_wheel_blocked(Wheel::Right, true);
    assert_eq!(p.wheel_speeds()[1], 0.0);
    p.reset(TruePose::default(), [5.0, 5.0]);
    assert_eq!(p.wheel_speeds(), [5.0, 0.0]);
}

#[test]
fn a_start_in_motion_is_refused_beyond_the_motors_no_load_speed() {
    let pose = TruePose {
        x_m: 1.0,
        y_m: -2.0,
        theta_rad: 0.5,
    };
    // The paper's start (0.4 m/s, 0.3 rad/s) on a floor where the wheels slip 99 %: the
    // wheels would have to turn 100 × faster than they roll, (0.4 + 0.3 · 0.075) /
    // (0.01 · 0.0325) = 1 300 rad/s, 36 × the motor's 35.7 rad/s no-load speed on 6 V.
    let mut pp = params();
    pp.slip = [0.99, 0.99];
    let mut p = Plant::new(pp).unwrap();
    p.reset(pose, [0.0; 2]);
    let Err(PlantError::BeyondNoLoadSpeed {
        wheel,
        needed_rad_s,
        no_load_rad_s,
        ..
    }) = p.start_in_motion(0.4, 0.3)
    else {
        panic!("a start 36 × faster than the motor can turn was accepted");
    };
    assert_eq!(wheel, "right");
    assert!((needed_rad_s - 1300.0).abs() < 1e-6, "{needed_rad_s}");
    assert!((no_load_rad_s - 35.71).abs() < 0.01, "{no_load_rad_s}");
    // Refused: nothing changed.
    assert_eq!(p.wheel_speeds(), [0.0; 2]);
    assert_eq!(p.pose(), pose);
    // Half the slip: the wheels turn twice as fast as they roll, within the motor's
    // reach, and the body moves as asked.
    let mut pp = params();
    pp.slip = [0.5, 0.5];
    let mut p = Plant::new(pp).unwrap();
    p.reset(pose, [0.0; 2]);
    p.start_in_motion(0.4, 0.3).unwrap();
    let [l, r] = p.wheel_speeds();
    assert!((l - 2.0 * (0.4 - 0.0225) / 0.0325).abs() < 1e-9, "{l}");
    assert!((r - 2.0 * (0.4 + 0.0225) / 0.0325).abs() < 1e-9, "{r}");
    let (v, omega) = p.body_velocity();
    assert!((v - 0.4).abs() < 1e-12 && (omega - 0.3).abs() < 1e-12);
    assert_eq!(p.pose(), pose);
    // A NaN motion is refused too.
    assert!(p.start_in_motion(f64::NAN, 0.0).is_err());
}

#[test]
fn a_slip_patch_shortens_that_wheels_ground_distance() {
    let mut p = Plant::new(frictionless()).unwrap();
    p.set_driver_enabled(false);
    p.reset(TruePose::default(), [10.0, 10.0]);
    p.set_slip(Wheel::Right, 0.5).unwrap();
    assert_eq!(p.slip(), [0.0, 0.5]);
    let (v, yaw) = p.body_velocity();
    assert!((v - 0.75 * 0.325).abs() < 1e-12 && (yaw + 0.5 * 0.325 / 0.15).abs() < 1e-12);
    p.advance(H, 1000);
    let [al, ar] = p.wheel_angles();
    let expected = (0.5 * 0.0325 * ar - 0.0325 * al) / 0.15;
    assert!((p.pose().theta_rad - expected).abs() < 1e-12);
    assert!(expected < -0.1);
    // Out of range: refused, nothing changes.
    assert!(p.set_slip(Wheel::Left, 1.0).is_err());
    assert!(p.set_slip(Wheel::Left, f64::NAN).is_err());
    assert!(p.set_slip(Wheel::Left, -0.1).is_err());
    assert_eq!(p.slip(), [0.0, 0.5]);
}

#[test]
fn supply_sag_lowers_the_voltage_and_the_speed() {
    let mut p = Plant::new(params()).unwrap();
    p.set_duty(1.0, 1.0);
    p.advance(H, 10_000);
    let full = p.wheel_speeds()[0];
    p.set_supply_v(4.0).unwrap();
    assert_eq!(p.supply_v(), 4.0);
    assert_eq!(p.bridge_outputs(), [BridgeOutput::Drive { volts: 4.0 }; 2]);
    p.advance(H, 30_000);
    let sagged = p.wheel_speeds()[0];
    assert!((sagged - p.drive(Wheel::Left).steady_speed_rad_s(4.0)).abs() < 1e-6);
    assert!(sagged < 0.7 * full, "{sagged} {full}");
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(p.set_supply_v(bad).is_err());
    }
    assert_eq!(p.supply_v(), 4.0);
}

#[test]
fn centre_of_mass_terms_conserve_energy_and_push_the_right_way() {
    let kinetic = |p: &Plant| {
        let [l, r] = p.wheel_speeds();
        0.5 * (p.friction.inertia.a * (l * l + r * r) + 2.0 * p.friction.inertia.b * l * r)
    };
    for d in [0.05, -0.05] {
        let mut pp = frictionless();
        pp.body.com_ahead_of_axle_m = d;
        let mut p = Plant::new(pp).unwrap();
        p.set_driver_enabled(false);
        // Turning on the spot: v̇ = m d Ω² / (m + 2 J_w / R²) at the start.
        p.reset(TruePose::default(), [-10.0, 10.0]);
        let energy = kinetic(&p);
        p.advance(H, 1);
        let (v, _) = p.body_velocity();
        let yaw: f64 = 0.0325 * 20.0 / 0.15;
        let j_w = pp.body.wheel_inertia_kg_m2 + pp.motor.rotor_inertia_kg_m2 * 900.0;
        let expected =
            pp.body.mass_kg * d * yaw * yaw / (pp.body.mass_kg + 2.0 * j_w / (0.0325 * 0.0325));
        assert!((v / H / expected - 1.0).abs() < 1e-3, "{v} {expected}");
        // The robot pulls forward if the centre of mass is ahead, back if behind, and
        // the terms do no work: the energy stays while v and Ω trade.
        p.advance(H, 20_000);
        let (v, _) = p.body_velocity();
        assert!(v * d > 0.0 && v.abs() > 0.01, "{d}: {v}");
        assert!((kinetic(&p) / energy - 1.0).abs() < 1e-9, "{d}");
    }
    // Centred: no push.
    let mut p = Plant::new(frictionless()).unwrap();
    p.set_driver_enabled(false);
    p.reset(TruePose::default(), [-10.0, 10.0]);
    p.advance(H, 1000);
    assert_eq!(p.body_velocity().0, 0.0);
}

#[test]
fn invalid_parameters_are_refused_with_their_name() {
    let mut pp = params();
    pp.body.com_ahead_of_axle_m = 0.1; // m d² = 5e-3 > I = 1.8e-3
    assert_eq!(
        Plant::new(pp).unwrap_err(),
        PlantError::OutOfRange("body.com_ahead_of_axle_m")
    );
    let mut pp = params();
    pp.driver.pwm_levels = 0;
    assert_eq!(
        Plant::new(pp).unwrap_err(),
        PlantError::OutOfRange("driver.pwm_levels")
    );
    let mut pp = params();
    pp.body.mass_kg = 0.0;
    pp.body.yaw_inertia_kg_m2 = 0.0;
    pp.body.wheel_inertia_kg_m2 = 0.0;
    pp.motor.rotor_inertia_kg_m2 = 0.0;
    assert_eq!(Plant::new(pp).unwrap_err(), PlantError::SingularInertia);
}

/// Replays duties, changed every millisecond, into `fast` (one hold per call) and
/// `reference_duties` into a reference: RK4 at 100 kHz, every stage on the full model. The largest
/// pose difference (m) and wheel-speed difference relative to the largest speed seen.
fn replay_against_reference(
    mut fast: Plant,
    duties: &[(f32, f32)],
    reference_duties: &[(f32, f32)],
) -> (f64, f64) {
    let mut reference = fast.clone();
    reference.set_integration(Integration::Rk4Stages);
    let (mut pose_m, mut speed, mut top) = (0.0f64, 0.0f64, 0.0f64);
    for (&(l, r), &(lr, rr)) in duties.iter().zip(reference_duties) {
        fast.set_duty(l, r);
        reference.set_duty(lr, rr);
        fast.advance(H, 10);
        reference.advance(H / 10.0, 100);
        let (a, b) = (fast.pose(), reference.pose());
        pose_m = pose_m.max((a.x_m - b.x_m).hypot(a.y_m - b.y_m));
        for i in 0..2 {
            let (wa, wb) = (fast.wheel_speeds()[i], reference.wheel_speeds()[i]);
            speed = speed.max((wa - wb).abs());
            top = top.max(wb.abs());
        }
    }
    (pose_m, speed / top)
}

#[test]
fn the_exact_hold_matches_a_100_khz_reference_over_30_s() {
    // A circle-like drive with a slowly varying turn, as the paper's experiment holds
    // its duties: 30 s, open loop.
    let duties: Vec<(f32, f32)> = (0..30_000)
        .map(|k| {
            let turn = 0.05 * (k as f32 * 1e-3).sin();
            (0.35 - turn, 0.35 + turn)
        })
        .collect();
    let (pose_m, speed) = replay_against_reference(exact_plant(), &duties, &duties);
    assert!(pose_m < 1e-4, "pose {pose_m} m");
    assert!(speed < 1e-3, "speed {speed}");
    // The bound can fail: the reference given the duties one millisecond late is off.
    let late: Vec<(f32, f32)> = duties.iter().skip(1).copied().collect();
    let (late_pose_m, _) = replay_against_reference(exact_plant(), &duties, &late);
    assert!(late_pose_m > 1e-4, "{late_pose_m}");
}

fn exact_plant() -> Plant {
    let mut p = Plant::new(params()).unwrap();
    p.set_integration(Integration::Exact);
    p
}

#[test]
fn through_starts_stops_and_reversals_the_exact_hold_is_as_close_to_the_reference_as_rk4() {
    // Random duties every millisecond for 5 s: through rest, reversals and current sign
    // changes, where the hold falls back to RK4 at the plant rate. Friction's stick and
    // slip are decided per plant step (0.1 ms) here and per 10 µs in the reference, so
    // neither is within 0.1 % there; the exact hold must not be worse than RK4.
    let mut rng = Rng::new(17);
    let duties: Vec<(f32, f32)> = (0..5000)
        .map(|_| (rng.symmetric(1.0) as f32, rng.symmetric(1.0) as f32))
        .collect();
    let (exact_pose_m, exact_speed) = replay_against_reference(exact_plant(), &duties, &duties);
    let mut rk4 = Plant::new(params()).unwrap();
    rk4.set_integration(Integration::Rk4);
    let (rk4_pose_m, rk4_speed) = replay_against_reference(rk4, &duties, &duties);
    assert!(
        exact_pose_m <= 1.01 * rk4_pose_m,
        "{exact_pose_m} vs {rk4_pose_m} m"
    );
    assert!(
        exact_speed <= 1.01 * rk4_speed,
        "{exact_speed} vs {rk4_speed}"
    );
    assert!(exact_pose_m < 1e-3, "pose {exact_pose_m} m");
}
