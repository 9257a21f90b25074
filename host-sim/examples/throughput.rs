//! Simulation speed: simulated seconds per wall second for the paper's circle with the
//! tracking law and 1 kHz control on one core, no trace, with the plant's exact hold and
//! with RK4 at the plant rate side by side; and where a step's time goes.
//!
//! ```text
//! cargo run --release -p host-sim --example throughput
//! ```
//!
//! The parts are timed alone on what one run of the whole loop recorded (every step's
//! sensor readings and actuation), so each does the work it did there:
//! - the supervisor around the controller (the firmware's logic), fed the sensors;
//! - the controller alone, fed the same ticks and supply;
//! - the simulated hardware (encoders, supply noise, faults, bridge, plant), fed the
//!   actuations, and the plant alone within it;
//! - the rest of the loop (true error, metrics, digest) is the whole loop minus the
//!   logic and the hardware.
//!
//! Best of five runs each, to keep other processes on the machine out of the figure.

use std::time::Instant;

use controller_core::prelude::*;
use controller_core::supervisor::{ArmRequest, RunMode};
use host_sim::hardware::{Actuation, Sensors, SimHardware};
use host_sim::plant::{Integration, Plant};
use host_sim::run::{LocalRobot, RobotLogic};
use host_sim::{run_scenario_with, RunOptions};
use robot_files::scenario::Scenario;
use robot_files::truth::TruePose;

/// The shortest of `runs` timings by `f`, s; the first error, if one fails.
fn best_of<F: FnMut() -> anyhow::Result<f64>>(runs: usize, mut f: F) -> anyhow::Result<f64> {
    (0..runs).try_fold(f64::INFINITY, |best, _| Ok(best.min(f()?)))
}

/// Seconds `f` took.
fn timed<F: FnOnce()>(f: F) -> f64 {
    let t = Instant::now();
    f();
    t.elapsed().as_secs_f64()
}

/// The robot's logic at the scenario's start, told its pose and armed as the run loop
/// does (in motion if the scenario starts moving).
fn armed_robot(scenario: &Scenario) -> anyhow::Result<LocalRobot> {
    let mut robot = LocalRobot::new(scenario, LawKind::Tracking)?;
    let s = scenario.start;
    robot.set_pose_locally(Pose::new(s.x_m as f32, s.y_m as f32, s.theta_rad as f32));
    let moving = s.v_m_s != 0.0 || s.omega_rad_s != 0.0;
    let armed = robot.arm_locally(ArmRequest {
        mode: RunMode::FollowPath,
        hold_speeds: None,
        initial_motion: moving.then(|| BodyVelocity::new(s.v_m_s as f32, s.omega_rad_s as f32)),
        max_armed_steps: None,
    });
    anyhow::ensure!(armed, "the robot refused to arm");
    Ok(robot)
}

/// The simulated hardware at the scenario's start (in motion if it starts moving).
fn started_hardware(scenario: &Scenario) -> anyhow::Result<SimHardware> {
    let mut hardware = SimHardware::new(scenario, &scenario.faults)?;
    let s = scenario.start;
    if s.v_m_s != 0.0 || s.omega_rad_s != 0.0 {
        hardware.start_moving(s.v_m_s, s.omega_rad_s)?;
    }
    Ok(hardware)
}

/// One closed-loop run of the logic against the hardware, as the run loop steps them:
/// every step's sensor readings and actuation, and the true pose at the end.
fn record(
    scenario: &Scenario,
    steps: u64,
) -> anyhow::Result<(Vec<Sensors>, Vec<Actuation>, TruePose)> {
    let mut robot = armed_robot(scenario)?;
    let mut hardware = started_hardware(scenario)?;
    let (mut sensors, mut actuations) = (Vec::new(), Vec::new());
    while hardware.period() < steps {
        let periods = hardware.periods_until_next_step();
        let read = hardware.sense(periods);
        let out = robot.step(&read)?.out;
        let actuation = Actuation {
            duty: out.duty,
            bridge: out.bridge,
        };
        hardware.actuate(actuation);
        hardware.advance();
        sensors.push(read);
        actuations.push(actuation);
    }
    Ok((sensors, actuations, hardware.plant().pose()))
}

fn main() -> anyhow::Result<()> {
    let mut scenario = Scenario::load("paper-circle")?;
    scenario.duration_s = 60.0;
    let control_hz = scenario.robot.control_rate_hz;
    let substeps = scenario.plant_rate_hz / control_hz;
    let steps = (scenario.duration_s * f64::from(control_hz)).round() as u64;

    // The whole loop: encoders, supervisor and controller, PWM, plant, metrics; with the
    // plant's exact hold and with RK4 at the plant rate (the baseline).
    let exact = RunOptions::default();
    let rk4 = RunOptions {
        integration: Integration::Rk4,
        ..exact
    };
    let whole_loop = |options: RunOptions| -> anyhow::Result<(f64, Option<[u32; 3]>)> {
        let first = run_scenario_with(&scenario, LawKind::Tracking, options)?;
        let best = best_of(5, || {
            Ok(run_scenario_with(&scenario, LawKind::Tracking, options)?
                .summary
                .wall_time_s)
        })?;
        Ok((best, first.digest.map(|d| d.true_pose_bits)))
    };
    let (full_rk4, _) = whole_loop(rk4)?;
    let (full, final_pose) = whole_loop(exact)?;

    // What the parts are fed: the same steps as the whole loop, which must end where it
    // ended (else the recording is not of the same run).
    let (sensors, actuations, recorded_pose) = record(&scenario, steps)?;
    let recorded_bits = [
        recorded_pose.x_m,
        recorded_pose.y_m,
        recorded_pose.theta_rad,
    ]
    .map(|v| (v as f32).to_bits());
    anyhow::ensure!(
        final_pose == Some(recorded_bits),
        "the recording ended at {recorded_pose:?}, not where the run ended"
    );

    let logic = best_of(5, || {
        let mut robot = armed_robot(&scenario)?;
        Ok(timed(|| {
            for read in &sensors {
                if let Ok(decision) = robot.step(read) {
                    std::hint::black_box(decision.out.duty);
                }
            }
        }))
    })?;

    let params = scenario.params()?;
    let controller = best_of(5, || {
        let reference = Reference::new(
            scenario.path.clone(),
            scenario.reference_speed_m_s,
            scenario.reference_mode,
        )
        .map_err(|e| anyhow::anyhow!("reference: {e}"))?;
        let s = scenario.start;
        let start = Pose::new(s.x_m as f32, s.y_m as f32, s.theta_rad as f32);
        let mut c = Controller::new(params, reference, LawKind::Tracking, start);
        c.set_mode(Mode::FollowPath);
        Ok(timed(|| {
            for read in &sensors {
                let out = c.step(StepInput::on_time(read.ticks, read.supply_v));
                std::hint::black_box(out.left);
            }
        }))
    })?;

    let hardware = best_of(5, || {
        let mut hardware = started_hardware(&scenario)?;
        Ok(timed(|| {
            for actuation in &actuations {
                let periods = hardware.periods_until_next_step();
                std::hint::black_box(hardware.sense(periods));
                hardware.actuate(*actuation);
                hardware.advance();
            }
        }))
    })?;

    // The plant alone, on the recorded bridge states.
    let dt = 1.0 / f64::from(scenario.plant_rate_hz);
    let start = started_hardware(&scenario)?;
    let plant_alone = |integration: Integration| -> anyhow::Result<f64> {
        let mut plant: Plant = start.plant().clone();
        plant.set_integration(integration);
        best_of(5, || {
            let mut plant = plant.clone();
            Ok(timed(|| {
                for a in &actuations {
                    plant.set_driver_enabled(a.bridge.enabled());
                    plant.set_duty(a.duty.left, a.duty.right);
                    plant.advance(dt, substeps);
                }
                std::hint::black_box(plant.pose());
            }))
        })
    };
    let plant_rk4 = plant_alone(Integration::Rk4)?;
    let plant_exact = plant_alone(Integration::Exact)?;

    let per_step = |s: f64| s / steps as f64 * 1e9;
    let share = |s: f64| 100.0 * s / full;
    println!(
        "scenario {}: {steps} control steps at {control_hz} Hz, plant rate {} Hz ({substeps} RK4 substeps per step)",
        scenario.name, scenario.plant_rate_hz
    );
    println!(
        "whole loop: {:.0} ns/step with the exact plant, {:.0} ns/step with the RK4 plant: {:.2}x",
        per_step(full),
        per_step(full_rk4),
        full_rk4 / full
    );
    println!(
        "simulated seconds per wall second: {:.0} (exact plant), {:.0} (RK4 plant)",
        scenario.duration_s / full,
        scenario.duration_s / full_rk4
    );
    println!("where a step goes, with the exact plant (each part timed alone):");
    println!(
        "  supervisor and controller {:>5.0} ns ({:>2.0} %), of which the controller {:.0} ns ({:.0} %)",
        per_step(logic),
        share(logic),
        per_step(controller),
        share(controller)
    );
    println!(
        "  hardware                  {:>5.0} ns ({:>2.0} %), of which the plant {:.0} ns ({:.0} %; RK4 plant {:.0} ns, {:.1}x)",
        per_step(hardware),
        share(hardware),
        per_step(plant_exact),
        share(plant_exact),
        per_step(plant_rk4),
        plant_rk4 / plant_exact
    );
    let rest = full - logic - hardware;
    println!(
        "  metrics, digest, loop     {:>5.0} ns ({:>2.0} %)",
        per_step(rest),
        share(rest)
    );
    Ok(())
}
