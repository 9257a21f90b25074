//! Monte-Carlo: the same scenario many times over a spread of robots and starts.
//!
//! Each run draws, uniformly within the scenario's [`SweepSpec`](robot_files::scenario::SweepSpec) and on top of its own
//! values: wheel-radius and track-width mismatch, a left/right radius difference, supply
//! voltage, Coulomb friction, wheel slip, encoder jitter, an offset of the start pose,
//! and a left/right difference of the motors' torque constant.
//! Runs are independent (each has its own random stream, derived from the sweep seed and
//! the run index), so the result does not depend on how many cores run them.
//!
//! **Success** means the control loop closes: the controller's own error — odometry
//! against the reference — settles (1 cm, 1°) before the end, with no fault. The *true*
//! error is reported beside it: with mismatch and slip, odometry drifts from the truth by
//! an amount that grows with distance travelled, and no feedback on odometry alone can
//! see it (that takes an external position fix).

use controller_core::law::LawKind;
use rayon::prelude::*;
use robot_files::faults::{Fault, FaultKind, Wheel};
use robot_files::metrics::ErrorReport;
use robot_files::metrics::Summary;
use robot_files::rng::Rng;
use robot_files::scenario::{Scenario, MAX_EDGE_JITTER_TICKS_RMS};
use serde::Serialize;

use crate::run::{run_scenario_with, RunError, RunOptions};

/// What one run drew (offsets from the scenario's own values).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Draws {
    /// Wheel radius mismatch, both wheels, %.
    pub wheel_radius_pct: f64,
    /// Left/right radius difference, %.
    pub wheel_radius_left_right_pct: f64,
    /// Track width mismatch, %.
    pub track_width_pct: f64,
    /// Supply voltage change, %.
    pub supply_pct: f64,
    /// Coulomb friction change, %.
    pub coulomb_friction_pct: f64,
    /// Slip ratio of the left wheel.
    pub slip_left: f64,
    /// Slip ratio of the right wheel.
    pub slip_right: f64,
    /// Encoder jitter, ticks RMS.
    pub encoder_noise_ticks_rms: f64,
    /// Start offset in x, m.
    pub start_dx_m: f64,
    /// Start offset in y, m.
    pub start_dy_m: f64,
    /// Start heading offset, rad.
    pub start_dtheta_rad: f64,
    /// Gyro turn-on bias offset, rad/s (0 without a gyro).
    pub gyro_bias_rad_s: f64,
    /// Gyro scale error offset, % (0 without a gyro).
    pub gyro_scale_error_pct: f64,
    /// Left − right motor torque constant (K_t and K_e), % of nominal.
    pub motor_left_right_pct: f64,
    /// Fraction of its ticks each encoder loses [left, right] (0 without a gyro).
    pub ticks_lost: [f64; 2],
}

/// One Monte-Carlo run.
#[derive(Clone, Debug, Serialize)]
pub struct SweepRun {
    /// Run index, 0-based.
    pub index: u32,
    /// What was drawn.
    pub draws: Draws,
    /// True-pose summary.
    pub summary: Summary,
    /// The controller's own (odometry) error statistics.
    pub estimated: ErrorReport,
    /// A fault was latched.
    pub fault: bool,
    /// |heading estimate − true heading| at the last steering update, rad.
    pub final_heading_error_rad: Option<f64>,
    /// The gyro and odometry disagreed at some step (a warning the robot would raise).
    pub gyro_disagreed: bool,
    /// The largest |gyro − odometry yaw rate| running mean while armed, rad/s.
    pub max_gyro_disagreement_radps: f64,
}

impl SweepRun {
    /// The loop closed: the estimate settled, and no fault.
    pub fn success(&self) -> bool {
        self.estimated.settle_time_s.is_some() && !self.fault
    }
}

/// Percentiles (nearest rank) of a set of values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Percentiles {
    /// Median.
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest.
    pub max: f64,
}

impl Percentiles {
    /// Nearest-rank percentiles of `values` (`None` if empty or any is NaN).
    pub fn of(values: &[f64]) -> Option<Self> {
        if values.is_empty() || values.iter().any(|v| v.is_nan()) {
            return None;
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let rank = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        Some(Self {
            p50: rank(0.50),
            p90: rank(0.90),
            p95: rank(0.95),
            max: v[v.len() - 1],
        })
    }
}

/// The result of a sweep.
#[derive(Clone, Debug, Serialize)]
pub struct SweepReport {
    /// Scenario name.
    pub scenario: String,
    /// Law name.
    pub law: String,
    /// Number of runs.
    pub runs: u32,
    /// Runs whose perturbed robot or plant was invalid, so they did not run (counted as
    /// failures).
    pub invalid_draws: u32,
    /// Fraction of all runs whose loop closed ([`SweepRun::success`]).
    pub success_rate: f64,
    /// Settle times of the successful runs (controller's estimate), s.
    pub settle_time_s: Option<Percentiles>,
    /// Fraction of runs whose *true* error settled (1 cm, 1°).
    pub true_settle_rate: f64,
    /// Final true position error of every run that armed (odometry drift included), m.
    pub final_true_position_error_m: Option<Percentiles>,
    /// The heading estimate's final error, for a scenario with a gyro.
    pub heading: Option<HeadingReport>,
    /// Wall-clock time of the whole sweep, s.
    pub wall_time_s: f64,
    /// Every run.
    pub details: Vec<SweepRun>,
}

/// The heading statistics of a sweep with a gyro.
#[derive(Clone, Debug, Serialize)]
pub struct HeadingReport {
    /// The heading steered by (`fused`, `odometry`, `oracle`).
    pub source: &'static str,
    /// |heading estimate − true heading| at the end, degrees.
    pub final_error_deg: Percentiles,
    /// Runs in which the gyro and odometry disagreed at some step.
    pub disagreeing_runs: u32,
    /// The largest |gyro − odometry yaw rate| running mean of each run, rad/s.
    pub max_disagreement_radps: Percentiles,
}

/// `base` perturbed by one draw from its [`SweepSpec`](robot_files::scenario::SweepSpec).
pub fn perturb(base: &Scenario, rng: &mut Rng) -> (Scenario, Draws) {
    let s = base.sweep;
    let d = Draws {
        wheel_radius_pct: rng.symmetric(s.wheel_radius_pct),
        wheel_radius_left_right_pct: rng.symmetric(s.wheel_radius_left_right_pct),
        track_width_pct: rng.symmetric(s.track_width_pct),
        supply_pct: rng.symmetric(s.supply_pct),
        coulomb_friction_pct: rng.symmetric(s.coulomb_friction_pct),
        slip_left: rng.uniform_in(0.0, s.slip_max),
        slip_right: rng.uniform_in(0.0, s.slip_max),
        encoder_noise_ticks_rms: rng.uniform_in(0.0, s.encoder_noise_ticks_rms_max),
        start_dx_m: rng.symmetric(s.start_position_m),
        start_dy_m: rng.symmetric(s.start_position_m),
        start_dtheta_rad: rng.symmetric(s.start_heading_rad),
        gyro_bias_rad_s: 0.0,
        gyro_scale_error_pct: 0.0,
        motor_left_right_pct: 0.0,
        ticks_lost: [0.0; 2],
    };
    let mut d = d;
    let mut out = base.clone();
    let p = &mut out.plant;
    p.mismatch.wheel_radius_pct += d.wheel_radius_pct;
    p.mismatch.wheel_radius_left_right_pct += d.wheel_radius_left_right_pct;
    p.mismatch.track_width_pct += d.track_width_pct;
    p.driver.supply_v *= 1.0 + d.supply_pct / 100.0;
    p.motor.coulomb_friction_nm *= 1.0 + d.coulomb_friction_pct / 100.0;
    // Slip stays below 1 whatever the base scenario had.
    p.slip[0] = (p.slip[0] + d.slip_left).min(0.95);
    p.slip[1] = (p.slip[1] + d.slip_right).min(0.95);
    // The jitter stays within the model's range whatever the base scenario had; the draw
    // recorded is the one applied.
    let jitter =
        (p.encoder_noise_ticks_rms + d.encoder_noise_ticks_rms).min(MAX_EDGE_JITTER_TICKS_RMS);
    d.encoder_noise_ticks_rms = jitter - p.encoder_noise_ticks_rms;
    p.encoder_noise_ticks_rms = jitter;
    out.start.x_m += d.start_dx_m;
    out.start.y_m += d.start_dy_m;
    out.start.theta_rad += d.start_dtheta_rad;
    if let Some(gyro) = &mut out.gyro {
        let g = gyro.sweep;
        d.gyro_bias_rad_s = rng.symmetric(g.turn_on_bias_rad_s);
        d.gyro_scale_error_pct = rng.symmetric(g.scale_error_pct);
        gyro.sensor.turn_on_bias_rad_s += d.gyro_bias_rad_s;
        gyro.sensor.scale_error_pct += d.gyro_scale_error_pct;
        // Slip patches, each on a random wheel at a random time of the run.
        let rate = f64::from(out.robot.control_rate_hz);
        let total_steps = (out.duration_s * rate) as u64;
        for _ in 0..g.slip_patches {
            let wheel = if rng.uniform() < 0.5 {
                Wheel::Left
            } else {
                Wheel::Right
            };
            let ratio = rng.uniform_in(0.0, g.slip_patch_max);
            let at_step = (rng.uniform() * total_steps as f64) as u64;
            let duration_steps = (rng.uniform_in(0.0, g.slip_patch_s) * rate) as u64;
            out.faults.push(Fault {
                kind: FaultKind::SlipPatch(wheel, ratio),
                at_step,
                duration_steps: Some(duration_steps.max(1)),
            });
        }
    }
    // Drawn last, so that the draws above are those of a sweep without it.
    d.motor_left_right_pct = rng.symmetric(s.motor_left_right_pct);
    out.plant.motor_mismatch.torque_constant_left_right_pct += d.motor_left_right_pct;
    // After every other draw, and only when asked for: the other draws do not depend on
    // whether tick loss is drawn.
    let ticks_lost_max = out.gyro.map_or(0.0, |g| g.sweep.ticks_lost_max);
    if ticks_lost_max > 0.0 {
        for wheel in [Wheel::Left, Wheel::Right] {
            let fraction = rng.uniform_in(0.0, ticks_lost_max);
            d.ticks_lost[wheel.index()] = fraction;
            out.faults.push(Fault {
                kind: FaultKind::TicksLost(wheel, fraction),
                at_step: 0,
                duration_steps: None,
            });
        }
    }
    (out, d)
}

/// Runs `runs` perturbed copies of `base` with `law` on every core, calling `progress`
/// after each run (from any thread); with `mcap_dir`, each run is also written there as
/// `run-NNNN.mcap` (N its index), traced at the steering rate, one file (and one
/// Foxglove context) per run.
pub fn sweep(
    base: &Scenario,
    law: LawKind,
    runs: u32,
    seed: u64,
    mcap_dir: Option<&std::path::Path>,
    progress: &(dyn Fn() + Sync),
) -> Result<SweepReport, RunError> {
    let start = std::time::Instant::now();
    let options = RunOptions::traced_every(if mcap_dir.is_some() {
        base.robot.steering_divider
    } else {
        0
    });
    let details = (0..runs)
        .into_par_iter()
        .map(|index| {
            let mut rng = Rng::new(seed ^ u64::from(index).wrapping_mul(0x9E37_79B9_7F4A_7C15));
            let (mut scenario, draws) = perturb(base, &mut rng);
            scenario.seed = rng.next_u64();
            let result = run_scenario_with(&scenario, law, options);
            progress();
            if let (Some(dir), Ok(run)) = (mcap_dir, &result) {
                let file = dir.join(format!("run-{index:04}.mcap"));
                crate::mcap::write_run_mcap(&file, &scenario, run)?;
            }
            // A draw whose robot or plant is invalid (the spreads pushed a value out of
            // range) is a failed run, not the end of the sweep.
            Ok(result.ok().map(|r| SweepRun {
                index,
                draws,
                final_heading_error_rad: r.final_heading_estimate_error_rad.map(f64::abs),
                gyro_disagreed: r.gyro_disagreed,
                max_gyro_disagreement_radps: r.max_gyro_disagreement_radps,
                fault: r.faulted(),
                estimated: r.summary.estimated_error,
                summary: r.summary,
            }))
        })
        .collect::<Result<Vec<_>, RunError>>()?;
    let invalid_draws = details.iter().filter(|r| r.is_none()).count() as u32;
    let details: Vec<SweepRun> = details.into_iter().flatten().collect();
    // Invalid draws count as failures: rates are over every run asked for.
    let n = f64::from(runs.max(1));
    let settle: Vec<f64> = details
        .iter()
        .filter(|r| r.success())
        .filter_map(|r| r.estimated.settle_time_s)
        .collect();
    // A run that never armed has no final error (its report's zero is no sample); it
    // counts against the success rate instead.
    let finals: Vec<f64> = details
        .iter()
        .map(|r| r.summary.headline_error())
        .filter(|e| e.samples > 0)
        .map(|e| e.final_position_error_m)
        .collect();
    Ok(SweepReport {
        scenario: base.name.clone(),
        law: law.name().to_string(),
        runs,
        invalid_draws,
        success_rate: details.iter().filter(|r| r.success()).count() as f64 / n,
        settle_time_s: Percentiles::of(&settle),
        true_settle_rate: details
            .iter()
            .filter(|r| r.summary.headline_error().settle_time_s.is_some())
            .count() as f64
            / n,
        final_true_position_error_m: Percentiles::of(&finals),
        heading: base.gyro.and_then(|g| {
            let errors: Vec<f64> = details
                .iter()
                .filter_map(|r| r.final_heading_error_rad)
                .map(f64::to_degrees)
                .collect();
            Some(HeadingReport {
                source: g.heading.name(),
                final_error_deg: Percentiles::of(&errors)?,
                disagreeing_runs: details.iter().filter(|r| r.gyro_disagreed).count() as u32,
                max_disagreement_radps: Percentiles::of(
                    &details
                        .iter()
                        .map(|r| r.max_gyro_disagreement_radps)
                        .collect::<Vec<_>>(),
                )?,
            })
        }),
        wall_time_s: start.elapsed().as_secs_f64(),
        details,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let v: Vec<f64> = (1..=20).map(f64::from).collect();
        let p = Percentiles::of(&v).unwrap();
        assert_eq!((p.p50, p.p90, p.p95, p.max), (10.0, 18.0, 19.0, 20.0));
        assert!(Percentiles::of(&[]).is_none());
        assert_eq!(Percentiles::of(&[3.0]).unwrap().p50, 3.0);
    }

    #[test]
    fn perturbation_is_reproducible_and_bounded() {
        let base = Scenario::builtin("paper-circle").unwrap().unwrap();
        let (a, da) = perturb(&base, &mut Rng::new(9));
        let (_, db) = perturb(&base, &mut Rng::new(9));
        assert_eq!(da, db);
        assert!(da.track_width_pct.abs() <= base.sweep.track_width_pct);
        assert!((0.0..=base.sweep.slip_max).contains(&da.slip_left));
        assert!(da.motor_left_right_pct.abs() <= base.sweep.motor_left_right_pct);
        assert_eq!(
            a.plant.motor_mismatch.torque_constant_left_right_pct,
            base.plant.motor_mismatch.torque_constant_left_right_pct + da.motor_left_right_pct
        );
        assert!((a.start.x_m - base.start.x_m).abs() <= base.sweep.start_position_m);
        assert_eq!(da.ticks_lost, [0.0; 2], "no gyro: no tick loss drawn");
        assert!(a.faults.is_empty());
    }

    #[test]
    fn a_gyro_sweep_draws_slip_patches_and_each_encoders_tick_loss_last() {
        let base = Scenario::builtin("paper-circle-gyro").unwrap().unwrap();
        let g = base.gyro.expect("a gyro").sweep;
        assert!(g.ticks_lost_max > 0.0);
        let (a, da) = perturb(&base, &mut Rng::new(9));
        let patches = a
            .faults
            .iter()
            .filter(|f| matches!(f.kind, FaultKind::SlipPatch(..)))
            .count();
        assert_eq!(patches, g.slip_patches as usize);
        for wheel in [Wheel::Left, Wheel::Right] {
            let fraction = da.ticks_lost[wheel.index()];
            assert!((0.0..=g.ticks_lost_max).contains(&fraction), "{fraction}");
            assert!(a.faults.contains(&Fault {
                kind: FaultKind::TicksLost(wheel, fraction),
                at_step: 0,
                duration_steps: None,
            }));
        }
        // Drawn last: without it, every other draw is the same.
        let mut without = base.clone();
        if let Some(gyro) = &mut without.gyro {
            gyro.sweep.ticks_lost_max = 0.0;
        }
        let (_, d0) = perturb(&without, &mut Rng::new(9));
        assert_eq!(
            Draws {
                ticks_lost: [0.0; 2],
                ..da
            },
            d0
        );
    }

    #[test]
    fn a_run_that_never_armed_has_no_final_error_and_fails() {
        let mut base = Scenario::builtin("paper-line").unwrap().unwrap();
        base.duration_s = 0.5;
        base.arm_at_start = false;
        let report = sweep(&base, LawKind::Tracking, 3, 1, None, &|| {}).unwrap();
        assert_eq!(report.success_rate, 0.0);
        assert!(report.final_true_position_error_m.is_none());
        base.arm_at_start = true;
        let report = sweep(&base, LawKind::Tracking, 3, 1, None, &|| {}).unwrap();
        assert!(report
            .final_true_position_error_m
            .is_some_and(|p| p.p50 > 0.0));
    }

    #[test]
    fn the_drawn_edge_jitter_stays_within_the_model() {
        let mut base = Scenario::builtin("paper-circle").unwrap().unwrap();
        base.plant.encoder_noise_ticks_rms = MAX_EDGE_JITTER_TICKS_RMS;
        let (a, da) = perturb(&base, &mut Rng::new(9));
        assert_eq!(a.plant.encoder_noise_ticks_rms, MAX_EDGE_JITTER_TICKS_RMS);
        assert_eq!(da.encoder_noise_ticks_rms, 0.0, "what was applied");
        base.plant.encoder_noise_ticks_rms = 0.1;
        let (a, da) = perturb(&base, &mut Rng::new(9));
        assert!(da.encoder_noise_ticks_rms > 0.0);
        assert_eq!(
            a.plant.encoder_noise_ticks_rms,
            0.1 + da.encoder_noise_ticks_rms
        );
    }
}
