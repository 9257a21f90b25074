//! `cargo xtask long`: the checks too long for CI's 15 minutes, run by hand before a
//! release or after a change to what they cover. Each runs even if an earlier one failed.
//!
//! | check | what it proves |
//! |---|---|
//! | a 1 000-run sweep of `paper-circle` | the controller settles on 1 000 robots drawn from the scenario's spreads (mismatch, noise, start pose); the sweep prints its percentiles and fails when a run does not settle |
//! | the tune's spread matrix (`host-sim tune --sweep`) | the self-tune identifies 27 robots (R_a, K_t, inertia ±40 %, friction ×3, one at a time and at every corner, the supply 5–12.6 V) within 10 %, and prints each tuned loop's overshoot; it ends with `tune spread: N of 27 robots identified within 10 %, worst overshoot X %` and fails when a robot was not identified |
//! | `cargo xtask ros2` with `cmd_vel` as `geometry_msgs/TwistStamped` | the bridge started with `use_stamped_vel` takes stamped commands from the Cyclone DDS peer (CI's run sends Twist) |
//! | mutation testing (`cargo xtask mutants`) | the tests notice a wrong sign, a swapped comparison or a dropped statement in the mutated crates |
//! | every fuzz target for 10 minutes (`cargo xtask fuzz 600`) | no input of a decoder of outside bytes or text (the link's frames and messages, the parameter record, scenarios, robot files) crashes it, hangs it or breaks one of its properties (`fuzz-checks`) |

use anyhow::{ensure, Result};

use crate::steps::{run_command, Context, Step};

/// Runs of the long sweep.
const SWEEP_RUNS: &str = "1000";

/// Seconds each fuzz target runs.
const FUZZ_SECONDS: u32 = 600;

/// The long checks, in order.
pub fn steps() -> Vec<Step> {
    vec![
        Step::new("sweep: paper-circle, 1 000 runs", |ctx: &Context| {
            run_command(&mut ctx.cargo(&[
                "run",
                "--release",
                "--package",
                "host-sim",
                "--",
                "sweep",
                "paper-circle",
                "--runs",
                SWEEP_RUNS,
            ]))
        }),
        Step::new("tune spread: paper-circle, 27 robots", |ctx: &Context| {
            run_command(&mut ctx.cargo(&[
                "run",
                "--release",
                "--package",
                "host-sim",
                "--",
                "tune",
                "paper-circle",
                "--sweep",
            ]))
        }),
        Step::new("ros2: cmd_vel as TwistStamped", |ctx: &Context| {
            crate::ros2_peer::check_with(ctx, crate::ros2_peer::CmdVel::TwistStamped)
        }),
        Step::new("mutants: cargo xtask mutants", |ctx: &Context| {
            ensure!(
                crate::mutants::run(ctx, &[])?,
                "mutants were missed or timed out"
            );
            Ok(())
        }),
        Step::new("fuzz: every target, 10 minutes each", |ctx: &Context| {
            crate::fuzz::run(ctx, FUZZ_SECONDS)
        }),
    ]
}

/// Whether every long check passed.
pub fn run(ctx: &Context) -> Result<bool> {
    Ok(crate::steps::run_all(ctx, &steps(), None))
}
