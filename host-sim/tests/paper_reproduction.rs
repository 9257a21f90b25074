//! The paper's experiments on the simulated robot, against theory-derived bounds.

use controller_core::law::LawKind;
use host_sim::{run_scenario, run_scenario_with, RunOptions};
use robot_files::faults::{Fault, FaultKind, Wheel};
use robot_files::scenario::Scenario;

fn scenario(name: &str) -> Scenario {
    Scenario::load(name).expect("built-in scenario")
}

/// Acceptance: the tracking law settles (1 cm, 1° to the end) within the paper's 6 s on
/// the paper's circle, with the rim-speed cap at 1.0 m/s.
#[test]
fn paper_circle_tracking_settles_within_six_seconds() {
    let s = scenario("paper-circle");
    let cap = s.robot.limits.max_rim_speed_m_s;
    assert!(cap <= 1.0, "rim-speed cap {cap} m/s");
    let r = run_scenario(&s, LawKind::Tracking).unwrap();
    let e = r
        .summary
        .true_error
        .expect("a simulation has the true error");
    let settle = e.settle_time_s.expect("settles");
    assert!(settle <= 6.0, "settle time {settle} s");
    assert!(!r.faulted());
    assert_eq!(r.summary.supervisor.final_state, "Armed");
    assert!(e.final_position_error_m < 0.002);
    // The wheels honour the cap up to the wheel PID's overshoot (a few %).
    let peak_rim = r.summary.max_wheel_speed_rad_s * f64::from(s.robot.wheel_radius_left_m);
    assert!(
        peak_rim <= 1.05 * f64::from(cap),
        "peak rim speed {peak_rim} m/s"
    );
}

/// The robot starts already moving at the paper's v = 0.4 m/s, ω = 0.3 rad/s.
#[test]
fn paper_circle_starts_in_motion() {
    let mut s = scenario("paper-circle");
    s.duration_s = 0.05;
    let r = run_scenario_with(&s, LawKind::Tracking, RunOptions::traced_every(1)).unwrap();
    let first = r.trace[0];
    assert!((first.true_velocity.0 - 0.4).abs() < 1e-9);
    assert!((first.true_velocity.1 - 0.3).abs() < 1e-9);
    // The arm request asserts the motion and the speed estimate is seeded with it: the
    // controller does not start from rest. The arming step's own reading covers the time
    // before the plant started (no ticks), so for one 20-step window the estimate is 1/20
    // low, to within its quantisation: one tick per wheel in the window is
    // R · (2π/1440) / (20 · 1 ms) = 0.0071 m/s of v.
    let params = s.params().unwrap();
    let window = params.config().speed_window_steps as usize;
    let window_s = window as f64 * f64::from(params.period_s());
    let one_tick_m_s =
        f64::from(params.geometry().wheel_radius_left_m() * params.rad_per_tick()) / window_s;
    let geometry = params.geometry();
    let v = |row: &robot_files::trace::TraceRow| f64::from(geometry.forward(row.measured).v_m_s);
    assert!(
        (v(&first) - 0.4 * 19.0 / 20.0).abs() <= one_tick_m_s,
        "{}",
        v(&first)
    );
}

/// The paper's law (33)–(34) trails a moving reference: its steady state on the circle
/// is a relative equilibrium in which the robot, on (almost) the same circle, chases the
/// reference at v = γ r_e cos α = v_r, so r_e = v_r / (γ cos α) (docs/paper-errata.md, item 3).
/// The line of sight is a chord of the circle, so α ≈ r_e / (2 R); with v_r = 0.25 m/s,
/// γ = 1 /s and R = 1.25 m the fixed point of r_e = (v_r/γ) / cos(r_e / 2R) is
/// r_e = 0.25125 m, 0.5 % above v_r/γ. (Solving the exact relative equilibrium of the
/// unicycle, robot on a circle of radius ρ < R, gives 0.25125 m too.)
///
/// Tolerance 3 mm about that value: the simulation adds a 10 ms zero-order hold on the
/// law, wheel dynamics and encoder quantisation; those act on a steady circular motion
/// only through the small ripple of the wheel loops (< 1 mm here), and 3 mm is 1.2 % of
/// v_r/γ — far below the 250 mm lag the test is about.
#[test]
fn paper_law_lags_by_v_r_over_gamma() {
    let s = scenario("paper-circle");
    let r = run_scenario(&s, LawKind::Paper).unwrap();
    let v_r = f64::from(s.reference_speed_m_s);
    let gamma = f64::from(s.robot.law.paper.gamma);
    let radius = 1.25;
    let mut r_e = v_r / gamma;
    for _ in 0..50 {
        r_e = v_r / gamma / (r_e / (2.0 * radius)).cos();
    }
    assert!((r_e - 0.25125).abs() < 1e-4, "{r_e}");
    let e = r.summary.true_error.unwrap();
    let final_error = e.final_position_error_m;
    assert!(
        (final_error - r_e).abs() < 0.003,
        "final error {final_error} m vs theory {r_e} m"
    );
    assert!((final_error - v_r / gamma).abs() < 0.005);
    // A lag, not a transient: the whole last 10 s sit at it, and it never settles.
    assert!((e.rms_position_error_m - r_e).abs() < 0.003);
    assert_eq!(e.settle_time_s, None);
}

/// The other built-ins settle with the tracking law, well before their end. The rounded
/// square's fillets step the reference's curvature, and at each fillet entry the heading
/// error peaks near the 1° of the settle criterion: there the test asks for the position
/// (1 cm) and for the heading to stay within 1.5°.
#[test]
fn other_scenarios_settle_with_tracking() {
    for name in ["paper-line", "square-waypoints", "figure-eight"] {
        let s = scenario(name);
        let r = run_scenario(&s, LawKind::Tracking).unwrap();
        let e = r.summary.true_error.unwrap();
        assert!(!r.faulted(), "{name}: {:?}", r.summary.supervisor);
        assert!(e.max_position_error_m < 0.01, "{name}");
        if name == "square-waypoints" {
            let worst_heading = r
                .trace
                .iter()
                .filter(|row| row.t_s > 10.0)
                .map(|row| row.true_error.1.abs())
                .fold(0.0, f64::max);
            assert!(
                worst_heading < 1.5f64.to_radians(),
                "{name}: {worst_heading} rad"
            );
        } else {
            let settle = e.settle_time_s.unwrap_or(f64::INFINITY);
            assert!(settle <= 10.0, "{name}: settle time {settle} s");
        }
    }
}

/// Same scenario, same seed: the same run.
#[test]
fn runs_are_reproducible() {
    let mut s = scenario("paper-line");
    s.duration_s = 3.0;
    s.plant.encoder_noise_ticks_rms = 0.5;
    let a = run_scenario(&s, LawKind::Kanayama).unwrap();
    let b = run_scenario(&s, LawKind::Kanayama).unwrap();
    assert_eq!(a.trace, b.trace);
}

/// A fault before the first steering update (an encoder that jumps by ~10⁶ ticks at the
/// first step): the summary carries the fault, its true errors are the trace's, and the
/// controller's own estimate says it has no sample instead of claiming zero error.
#[test]
fn a_fault_before_the_first_steering_update_is_reported_as_such() {
    let mut s = scenario("paper-circle");
    s.faults.push(Fault {
        kind: FaultKind::EncoderGlitch(Wheel::Left, 1_000_000),
        at_step: 0,
        duration_steps: None,
    });
    s.duration_s = 2.0;
    let r = run_scenario_with(&s, LawKind::Tracking, RunOptions::traced_every(1)).unwrap();
    assert_eq!(r.summary.supervisor.final_state, "Faulted");
    assert!(r
        .summary
        .supervisor
        .faults
        .contains(&"encoder_jump".to_string()));
    let truth = r
        .summary
        .true_error
        .expect("a simulation has the true error");
    let last = r.trace.last().expect("a trace").true_error.0;
    assert!(
        (truth.final_position_error_m - last).abs() < 0.01,
        "summary {} m, trace {last} m",
        truth.final_position_error_m
    );
    // The robot starts 0.31 m from the reference and never gets control.
    assert!(truth.final_position_error_m > 0.25);
    assert!(truth.samples > 0);
    assert_eq!(r.summary.estimated_error.samples, 0);
    assert!(r.summary.estimated_error.settle_time_s.is_none());
}
