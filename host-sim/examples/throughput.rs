//! Simulation speed: simulated seconds per wall second for the paper's circle with the
//! tracking law, 1 kHz control and a 10 kHz RK4 plant, on one core, no trace.
//!
//! ```text
//! cargo run --release -p host-sim --example throughput
//! ```

use controller_core::law::LawKind;
use host_sim::{run_scenario_with, RunOptions, Scenario};

fn main() -> anyhow::Result<()> {
    let mut scenario = Scenario::load("paper-circle")?;
    scenario.duration_s = 60.0;
    let options = RunOptions {
        trace_every_steps: 0,
    };
    // Warm up caches and the branch predictor, then take the best of five runs.
    run_scenario_with(&scenario, LawKind::Tracking, options)?;
    let mut best = f64::INFINITY;
    let mut steps = 0;
    for _ in 0..5 {
        let r = run_scenario_with(&scenario, LawKind::Tracking, options)?;
        best = best.min(r.summary.wall_time_s);
        steps = r.summary.steps;
    }
    let control_hz = scenario.robot.control_rate_hz;
    println!(
        "scenario {}: {} control steps at {} Hz, plant RK4 at {} Hz ({} substeps per step)",
        scenario.name,
        steps,
        control_hz,
        scenario.plant_rate_hz,
        scenario.plant_rate_hz / control_hz
    );
    println!(
        "wall time {:.4} s for {:.0} simulated s ({:.0} ns per control step)",
        best,
        scenario.duration_s,
        best / steps as f64 * 1e9
    );
    println!(
        "simulated seconds per wall second: {:.0}",
        scenario.duration_s / best
    );
    Ok(())
}
