//! Simulation speed: simulated seconds per wall second for the paper's circle with the
//! tracking law, 1 kHz control and a 10 kHz RK4 plant, on one core, no trace; and where
//! the time goes (the plant alone, the controller alone).
//!
//! ```text
//! cargo run --release -p host-sim --example throughput
//! ```
//!
//! Best of five runs each, to keep other processes on the machine out of the figure.

use std::time::Instant;

use controller_core::prelude::*;
use host_sim::plant::{Integration, Plant};
use host_sim::run::plant_params;
use host_sim::{run_scenario_with, RunOptions};
use robot_files::scenario::Scenario;
use robot_files::truth::TruePose;

fn best_of<F: FnMut() -> f64>(runs: usize, mut f: F) -> f64 {
    (0..runs).map(|_| f()).fold(f64::INFINITY, f64::min)
}

fn main() -> anyhow::Result<()> {
    let mut scenario = Scenario::load("paper-circle")?;
    scenario.duration_s = 60.0;
    let options = RunOptions {
        trace_every_steps: 0,
    };
    let control_hz = scenario.robot.control_rate_hz;
    let substeps = scenario.plant_rate_hz / control_hz;
    let steps = (scenario.duration_s * f64::from(control_hz)) as u32;

    // The whole loop: encoders, supervisor and controller, PWM, plant, metrics.
    run_scenario_with(&scenario, LawKind::Tracking, options)?;
    let mut failed = None;
    let full = best_of(5, || {
        match run_scenario_with(&scenario, LawKind::Tracking, options) {
            Ok(r) => r.summary.wall_time_s,
            Err(e) => {
                failed = Some(e);
                f64::INFINITY
            }
        }
    });
    if let Some(e) = failed {
        return Err(e.into());
    }

    // The plant alone: the same number of control periods, with the simulator's RK4 at
    // the plant rate and with the exact solution over each period, side by side.
    let dt = 1.0 / f64::from(scenario.plant_rate_hz);
    let plant_alone = |integration: Integration| -> anyhow::Result<f64> {
        let mut plant = Plant::new(plant_params(&scenario))?;
        plant.set_integration(integration);
        Ok(best_of(5, || {
            plant.reset(TruePose::default(), [7.0, 8.0]);
            let t = Instant::now();
            for k in 0..steps {
                plant.set_driver_enabled(true);
                plant.set_duty(0.25 + 0.001 * (k % 7) as f32, 0.28);
                plant.advance(dt, substeps);
            }
            std::hint::black_box(plant.pose());
            t.elapsed().as_secs_f64()
        }))
    };
    let plant_only = plant_alone(Integration::Rk4)?;
    let plant_exact = plant_alone(Integration::Exact)?;

    // The controller alone, fed plausible tick deltas.
    let params = scenario.params()?;
    let controller_only = best_of(5, || {
        let reference = match Reference::new(
            scenario.path.clone(),
            scenario.reference_speed_m_s,
            scenario.reference_mode,
        ) {
            Ok(r) => r,
            Err(_) => return f64::INFINITY,
        };
        let mut c = Controller::new(params, reference, LawKind::Tracking, Pose::default());
        c.set_mode(Mode::FollowPath);
        let t = Instant::now();
        let mut sink = 0.0f32;
        for k in 0..steps {
            let ticks = TickDeltas {
                left: 1 + (k % 3) as i32,
                right: 2,
            };
            sink += c.step(StepInput::on_time(ticks, 6.0)).left;
        }
        std::hint::black_box(sink);
        t.elapsed().as_secs_f64()
    });

    let per_step = |s: f64| s / f64::from(steps) * 1e9;
    println!(
        "scenario {}: {steps} control steps at {control_hz} Hz, plant RK4 at {} Hz ({substeps} substeps per step)",
        scenario.name, scenario.plant_rate_hz
    );
    println!(
        "whole loop {:.0} ns/step = plant {:.0} ns ({:.1} ns per RK4 substep with the pose) \
+ controller {:.0} ns + the rest",
        per_step(full),
        per_step(plant_only),
        per_step(plant_only) / f64::from(substeps),
        per_step(controller_only)
    );
    println!(
        "the plant with the exact solution over each period: {:.0} ns/step, {:.1}x the RK4 plant",
        per_step(plant_exact),
        plant_only / plant_exact
    );
    println!(
        "simulated seconds per wall second: {:.0}",
        scenario.duration_s / full
    );
    Ok(())
}
