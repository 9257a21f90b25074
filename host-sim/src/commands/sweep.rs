//! `host-sim sweep`: Monte-Carlo over mismatch, noise and start pose (the scenario's
//! `[sweep]` spreads) on every core, with a progress bar on stderr; optionally every
//! run's draws and results as `sweep.json`.

use std::fmt;
use std::path::PathBuf;

use anyhow::{ensure, Context, Result};
use controller_core::law::LawKind;
use indicatif::{ProgressBar, ProgressStyle};
use robot_files::scenario::{GyroSweep, HeadingChoice, SweepSpec};

use super::{create_dir, load, Report};
use crate::sweep::{sweep, SweepReport};

/// What `host-sim sweep` was asked.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// A built-in scenario name or a path to a TOML file.
    pub scenario: String,
    /// Number of runs (≥ 1).
    pub runs: u32,
    /// The steering law.
    pub law: LawKind,
    /// Seed of the draws.
    pub seed: u64,
    /// Also write `sweep.json` into this folder.
    pub out: Option<PathBuf>,
    /// The heading steered by, for a scenario with a gyro (`None`: the scenario's).
    pub heading: Option<HeadingChoice>,
    /// Also write each run as an MCAP file into this folder.
    pub mcap_dir: Option<PathBuf>,
}

/// The sweep's statistics and where `sweep.json` went.
#[derive(Clone, Debug)]
pub struct SweepCommandReport {
    /// Every run and the statistics over them.
    pub report: SweepReport,
    /// The spreads drawn from.
    pub spreads: SweepSpec,
    /// The gyro's spreads and the slip patches and tick loss drawn with them, for a
    /// scenario with a gyro.
    pub gyro_spreads: Option<GyroSweep>,
    /// Worker threads the runs were spread over.
    pub threads: usize,
    /// `sweep.json`, when asked for.
    pub file: Option<PathBuf>,
}

impl fmt::Display for SweepCommandReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let report = &self.report;
        let s = &self.spreads;
        writeln!(
            f,
            "{} with the {} law: {} runs on {} threads in {:.1} s",
            report.scenario, report.law, report.runs, self.threads, report.wall_time_s
        )?;
        writeln!(
            f,
            "  spreads: radius ±{}%, left/right ±{}%, track ±{}%, supply ±{}%, Coulomb ±{}%, \
motor left/right ±{}%, slip 0…{}, encoder jitter 0…{} ticks, start ±{} m / ±{} rad",
            s.wheel_radius_pct,
            s.wheel_radius_left_right_pct,
            s.track_width_pct,
            s.supply_pct,
            s.coulomb_friction_pct,
            s.motor_left_right_pct,
            s.slip_max,
            s.encoder_noise_ticks_rms_max,
            s.start_position_m,
            s.start_heading_rad
        )?;
        if let Some(g) = &self.gyro_spreads {
            writeln!(
                f,
                "  gyro spreads: turn-on bias ±{:.2}°/s, scale ±{}%, {} slip patches of 0…{} \
for up to {} s, ticks lost 0…{}% per encoder",
                g.turn_on_bias_rad_s.to_degrees(),
                g.scale_error_pct,
                g.slip_patches,
                g.slip_patch_max,
                g.slip_patch_s,
                g.ticks_lost_max * 100.0
            )?;
        }
        writeln!(
            f,
            "  success (the controller's own error settles to 1 cm / 1°, no fault): {:.1} %",
            report.success_rate * 100.0
        )?;
        if report.invalid_draws > 0 {
            writeln!(
                f,
                "  {} draws gave an invalid robot or plant and did not run (counted as failures); \
narrow the scenario's [sweep] spreads",
                report.invalid_draws
            )?;
        }
        match report.settle_time_s {
            Some(p) => writeln!(
                f,
                "  settle time: p50 {:.2} s, p90 {:.2} s, p95 {:.2} s, max {:.2} s",
                p.p50, p.p90, p.p95, p.max
            )?,
            None => writeln!(f, "  settle time: no run settled")?,
        }
        if let Some(p) = report.final_true_position_error_m {
            writeln!(
                f,
                "  true final position error (odometry drift included): p50 {:.3} m, p90 {:.3} m, \
max {:.3} m; true error settled in {:.1} % of runs",
                p.p50,
                p.p90,
                p.max,
                report.true_settle_rate * 100.0
            )?;
        }
        if let Some(heading) = &report.heading {
            writeln!(
                f,
                "  heading {}: final heading error |estimate − true|: p50 {:.3}°, p90 {:.3}°, \
max {:.3}°; gyro and odometry disagreed in {} runs (largest running mean of \
|gyro − odometry| per run: p50 {:.4}, p90 {:.4}, max {:.4} rad/s)",
                heading.source,
                heading.final_error_deg.p50,
                heading.final_error_deg.p90,
                heading.final_error_deg.max,
                heading.disagreeing_runs,
                heading.max_disagreement_radps.p50,
                heading.max_disagreement_radps.p90,
                heading.max_disagreement_radps.max,
            )?;
        }
        if let Some(file) = &self.file {
            writeln!(f, "  wrote {}", file.display())?;
        }
        Ok(())
    }
}

impl Report for SweepCommandReport {}

/// Runs the sweep (a progress bar on stderr while it runs) and writes `sweep.json` when
/// asked.
pub fn run(options: &Options) -> Result<SweepCommandReport> {
    let mut scenario = load(&options.scenario)?;
    if let Some(heading) = options.heading {
        ensure!(
            scenario.steer_by(heading),
            "--heading {} needs a scenario with a [gyro] table; {} has none",
            heading.name(),
            scenario.name
        );
    }
    let bar = ProgressBar::new(u64::from(options.runs));
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let progress = || bar.inc(1);
    if let Some(dir) = &options.mcap_dir {
        create_dir(dir)?;
    }
    let report = sweep(
        &scenario,
        options.law,
        options.runs,
        options.seed,
        options.mcap_dir.as_deref(),
        &progress,
    )?;
    bar.finish_and_clear();
    let file = match &options.out {
        Some(dir) => {
            create_dir(dir)?;
            let file = dir.join("sweep.json");
            let json = serde_json::to_string_pretty(&report).context("serialising the sweep")?;
            std::fs::write(&file, json).with_context(|| format!("writing {}", file.display()))?;
            Some(file)
        }
        None => None,
    };
    Ok(SweepCommandReport {
        report,
        spreads: scenario.sweep,
        gyro_spreads: scenario.gyro.map(|g| g.sweep),
        threads: rayon::current_num_threads(),
        file,
    })
}
