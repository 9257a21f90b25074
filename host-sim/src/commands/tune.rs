//! `host-sim tune`: the core's wheel-loop tune on the simulated robot ([`crate::tune`]),
//! on the ground or lifted (the scenario's `[plant] load`, or `--lifted`): the identified
//! model against the linearised plant, the tuned gains as robot-file sections, a
//! 0 → 15 rad/s step at 6 V tuned vs the scenario's gains (`tune_step.svg` in the output
//! folder) and the scenario's settle time with both; with `--sweep`, the spread matrix:
//! the tune on 27 robots ([`tune::sweep_variations`]) against their linearised truth, each
//! tuned loop's step, the tune's warnings and a summary line `tune spread: N of M robots
//! identified within 10 %, worst overshoot X %`. The command fails when the tune stopped
//! without a result, or with `--sweep` when a robot was not identified within 10 %
//! ([`verdict`], [`sweep_verdict`]).

use std::fmt;
use std::path::PathBuf;

use anyhow::Result;
use controller_core::law::LawKind;
use controller_core::tune::{TuneAbort, TuneConfig, TuneResult};
use robot_files::plant::Load;
use robot_files::scenario::Scenario;

use super::{create_dir, default_dir, load, ms_or, Failed, Progress, Report};
use crate::plot;
use crate::run::{run_scenario, wheel_step_response, RunResult, StepResponse};
use crate::tune::{self, SweepCase, Truth, TuneRun};

/// The step the tuned loop is compared on: set-point (rad/s), length (s), supply (V).
const STEP_RAD_S: f64 = 15.0;
const STEP_S: f64 = 0.4;
const STEP_SUPPLY_V: f64 = 6.0;

/// What `host-sim tune` was asked.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// A built-in scenario name or a path to a TOML file.
    pub scenario: String,
    /// The output folder of the plot (`None`: `host-sim-out/<scenario>/tune`).
    pub out: Option<PathBuf>,
    /// Also the identification sweep on 27 robots ([`tune::sweep_variations`]).
    pub sweep: bool,
    /// SIMC's τ_c over the loop's effective dead time (`None`: the core's).
    pub tau_c_per_dead_time: Option<f32>,
    /// The longest hold and step of the tune, s (`None`: the core's).
    pub max_hold_s: Option<f32>,
    /// Tune with the wheels lifted (the plant's load set to lifted).
    pub lifted: bool,
}

/// The line printed before the tune runs: the load, the supply and the tune's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct TuneStart {
    /// The scenario's name.
    pub scenario: String,
    /// What the wheels drive.
    pub load: Load,
    /// The supply, V.
    pub supply_v: f64,
    /// The tune's settings.
    pub config: TuneConfig,
}

impl fmt::Display for TuneStart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: tune on the {} load, {} V supply; at most {} V, holds and steps up to {} s, τ_c = {} θ_e",
            self.scenario,
            self.load.name(),
            self.supply_v,
            self.config.experiment_volts_v,
            self.config.max_hold_s,
            self.config.tau_c_per_dead_time
        )
    }
}

/// What the tune did, and, when it gave a result, the checks of that result.
#[derive(Clone, Debug)]
pub struct TuneReport {
    /// The tune's run on the simulated robot (its outcome, how long, how far).
    pub run: TuneRun,
    /// The checks of the tuned loops; `None` when the tune stopped.
    pub tuned: Option<Tuned>,
}

/// The checks of a tune that gave a result.
#[derive(Clone, Debug)]
pub struct Tuned {
    /// The scenario's name.
    pub scenario: String,
    /// The linearised truth the identification is compared with.
    pub truth: Truth,
    /// The tune's result.
    pub result: TuneResult,
    /// The step on the ground at 6 V with the scenario's gains and with the tuned ones.
    pub hand_step: StepResponse,
    /// See [`Tuned::hand_step`].
    pub tuned_step: StepResponse,
    /// The scenario's settle time on the ground (tracking law), s, with the scenario's
    /// gains and with the tuned ones (`None`: never).
    pub hand_settle_s: Option<f64>,
    /// See [`Tuned::hand_settle_s`].
    pub tuned_settle_s: Option<f64>,
    /// `tune_step.svg`.
    pub file: PathBuf,
    /// With `--sweep`: the load's name and every robot's identification.
    pub sweep: Option<(&'static str, Vec<SweepCase>)>,
}

impl fmt::Display for TuneReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let run = &self.run;
        writeln!(
            f,
            "  ran {:.2} s, robot moved up to {:.3} m from its start, wheels up to {:.1} rad/s",
            run.duration_s, run.max_distance_m, run.max_wheel_speed_rad_s
        )?;
        match &self.tuned {
            Some(tuned) => write!(f, "{tuned}"),
            None => Ok(()),
        }
    }
}

impl fmt::Display for Tuned {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let truth = &self.truth;
        writeln!(
            f,
            "  linearised truth (motoring, straight): k_V {:.5} V/(rad/s), τ {:.1} ms (ground τ {:.1} ms)",
            truth.kv_v_per_rad_s,
            truth.time_constant_s * 1e3,
            truth.ground_time_constant_s * 1e3
        )?;
        for (side, m) in ["left ", "right"].iter().zip(self.result.models) {
            writeln!(
                f,
                "  {side}: k_S {:.3} V, k_V {:.5} V/(rad/s) ({:+.1} %), K {:.3} rad/s/V, τ {:.1} ms \
({:+.1} %), θ {:.1} ms, design τ {:.1} ms",
                m.ks_v,
                m.kv_v_per_rad_s,
                tune::error_pct(f64::from(m.kv_v_per_rad_s), truth.kv_v_per_rad_s),
                m.gain_rad_s_per_v,
                m.time_constant_s * 1e3,
                tune::error_pct(f64::from(m.time_constant_s), truth.time_constant_s),
                m.dead_time_s * 1e3,
                m.design_time_constant_s * 1e3
            )?;
        }
        if self.result.warnings.any() {
            writeln!(f, "  warning: {}", self.result.warnings)?;
        }
        writeln!(
            f,
            "\nthe tuned wheel loops (SIMC PI with feed-forward), for the robot file:\n"
        )?;
        writeln!(
            f,
            "{}",
            robot_files::robot_file::tuned_wheel_sections(&self.result).trim_end()
        )?;
        let opt = |v: Option<f64>| ms_or(v, 1, "never");
        writeln!(
            f,
            "\n0 → 15 rad/s step from rest, on the ground at 6 V (aim: rise ≤ 60 ms, overshoot ≤ 5 %):"
        )?;
        for (label, r) in [("hand-tuned", &self.hand_step), ("tuned", &self.tuned_step)] {
            writeln!(
                f,
                "  {label:>10}: rise (10→90 %) {}, overshoot {:.1} %, settling (±5 %) {}",
                opt(r.rise_time_s),
                r.overshoot_pct,
                opt(r.settling_time_s)
            )?;
        }
        writeln!(
            f,
            "\n{} on the ground with the tracking law (aim: tuned settles within 10 % of hand-tuned):",
            self.scenario
        )?;
        writeln!(
            f,
            "  settle (1 cm, 1°): hand-tuned {}, tuned {}{}",
            opt(self.hand_settle_s),
            opt(self.tuned_settle_s),
            match (self.hand_settle_s, self.tuned_settle_s) {
                (Some(h), Some(t)) => format!(" ({:+.1} %)", tune::error_pct(t, h)),
                _ => String::new(),
            }
        )?;
        writeln!(f, "  wrote {}", self.file.display())?;
        if let Some((load, cases)) = &self.sweep {
            write_sweep(f, load, cases)?;
        }
        Ok(())
    }
}

/// The identification sweep's matrix: per robot its parameters, each identified
/// quantity's error against the linearised truth, the tuned loop's step and the tune's
/// warnings; then the worst figures and the summary line.
fn write_sweep(f: &mut fmt::Formatter<'_>, load: &str, cases: &[SweepCase]) -> fmt::Result {
    writeln!(
        f,
        "\nidentification sweep, {load} load: the worse wheel's errors against the linearised truth,\n  \
and the tuned loop's {} rad/s step from rest on the ground (R, K, J: R_a, K_t, inertia ±{} %; \
f+: friction ×3)",
        tune::SWEEP_STEP_RAD_S,
        tune::SWEEP_SPREAD_PCT
    )?;
    writeln!(
        f,
        "  {:<18} {:>7} {:>7} {:>7} {:>7} {:>8} {:>7} {:>9} {:>8}",
        "robot", "k_S", "k_V", "K", "τ", "τ truth", "ran", "overshoot", "settle"
    )?;
    let (mut identified, mut worst_error, mut worst_overshoot) = (0usize, 0.0f64, 0.0f64);
    for c in cases {
        let label = c.variation.short_label();
        match (c.errors_pct(), c.tuned_step) {
            (Some(e), Some(step)) => {
                if c.identified() {
                    identified += 1;
                }
                worst_error = worst_error.max(e.worst_pct());
                worst_overshoot = worst_overshoot.max(step.overshoot_pct);
                writeln!(
                    f,
                    "  {label:<18} {:>+6.1}% {:>+6.1}% {:>+6.1}% {:>+6.1}% {:>6.1}ms {:>6.1}s {:>8.1}% {:>8}{}",
                    e.ks_pct,
                    e.kv_pct,
                    e.gain_pct,
                    e.tau_pct,
                    c.truth.time_constant_s * 1e3,
                    c.run.duration_s,
                    step.overshoot_pct,
                    ms_or(step.settling_time_s, 0, "never"),
                    warnings_text(&c.run.outcome),
                )?;
            }
            _ => {
                let why = c.run.outcome.err().map_or(String::new(), |e| e.to_string());
                writeln!(f, "  {label:<18} no model: {why}")?;
            }
        }
    }
    writeln!(
        f,
        "  largest identification error {worst_error:.1} % (aim ≤ {} %)",
        tune::SWEEP_AIM_PCT
    )?;
    writeln!(
        f,
        "tune spread: {identified} of {} robots identified within {} %, worst overshoot {worst_overshoot:.1} %",
        cases.len(),
        tune::SWEEP_AIM_PCT
    )
}

/// The tune's warnings for the sweep's table: empty when none.
fn warnings_text(outcome: &Result<TuneResult, TuneAbort>) -> String {
    match outcome {
        Ok(result) if result.warnings.any() => format!("  warning: {}", result.warnings),
        _ => String::new(),
    }
}

impl Report for TuneReport {
    fn verdict(&self) -> Result<(), Failed> {
        verdict(&self.run.outcome)?;
        match self.tuned.as_ref().and_then(|t| t.sweep.as_ref()) {
            Some((_, cases)) => sweep_verdict(cases),
            None => Ok(()),
        }
    }
}

/// The sweep's rule: every robot identified within [`tune::SWEEP_AIM_PCT`]; otherwise
/// how many were not.
pub fn sweep_verdict(cases: &[SweepCase]) -> Result<(), Failed> {
    let missed = cases.iter().filter(|c| !c.identified()).count();
    if missed == 0 {
        Ok(())
    } else {
        Err(Failed(format!(
            "{missed} of {} robots were not identified within {} %",
            cases.len(),
            tune::SWEEP_AIM_PCT
        )))
    }
}

/// The rule: the tune gave a result; otherwise `the tune stopped: ` and why.
pub fn verdict(outcome: &Result<TuneResult, TuneAbort>) -> Result<(), Failed> {
    match outcome {
        Ok(_) => Ok(()),
        Err(e) => Err(Failed(format!("the tune stopped: {e}"))),
    }
}

/// Says what it starts on `progress`, runs the tune and, when it gave a result, its
/// checks; writes `tune_step.svg`.
pub fn run(options: &Options, progress: &mut Progress<'_>) -> Result<TuneReport> {
    let mut scenario = load(&options.scenario)?;
    if options.lifted {
        scenario.plant.load = Load::Lifted;
    }
    let mut config = tune::config_for(&scenario);
    if let Some(x) = options.tau_c_per_dead_time {
        config.tau_c_per_dead_time = x;
    }
    if let Some(x) = options.max_hold_s {
        config.max_hold_s = x;
    }
    config.validate(&scenario.params()?)?;
    let truth = tune::truth(&scenario)?;
    progress(&TuneStart {
        scenario: scenario.name.clone(),
        load: scenario.plant.load,
        supply_v: scenario.plant.driver.supply_v,
        config,
    })?;
    let run = tune::run_tune(&scenario, config)?;
    let tuned = match run.outcome {
        Ok(result) => Some(check(&scenario, options, config, truth, result)?),
        Err(_) => None,
    };
    Ok(TuneReport { run, tuned })
}

/// The checks of `result`, a tune of `scenario` with `config`: the step and the scenario
/// with the tuned loops against the scenario's own, the plot, and the sweep when asked.
fn check(
    scenario: &Scenario,
    options: &Options,
    config: TuneConfig,
    truth: Truth,
    result: TuneResult,
) -> Result<Tuned> {
    // The tuned loop against the scenario's own, on the ground at 6 V.
    let mut ground = scenario.clone();
    ground.plant.load = Load::Ground;
    ground.plant.driver.supply_v = STEP_SUPPLY_V;
    let tuned = tune::with_tuned_loops(&ground, &result);
    let hand_step = wheel_step_response(&ground, STEP_RAD_S, STEP_S)?;
    let tuned_step = wheel_step_response(&tuned, STEP_RAD_S, STEP_S)?;
    let mut on_scenario = scenario.clone();
    on_scenario.plant.load = Load::Ground;
    let hand_run = run_scenario(&on_scenario, LawKind::Tracking)?;
    let tuned_run = run_scenario(
        &tune::with_tuned_loops(&on_scenario, &result),
        LawKind::Tracking,
    )?;
    let settle = |r: &RunResult| r.summary.headline_error().settle_time_s;
    let dir = options
        .out
        .clone()
        .unwrap_or_else(|| default_dir(scenario, "tune"));
    create_dir(&dir)?;
    let file = dir.join("tune_step.svg");
    plot::step_comparison(
        &file,
        &format!("{}, ground, 6 V: tuned vs hand-tuned", scenario.name),
        &[("tuned", &tuned_step), ("hand-tuned", &hand_step)],
    )?;
    let sweep = if options.sweep {
        let variations = tune::sweep_variations();
        let cases = tune::identification_sweep(scenario, config, &variations)?;
        Some((scenario.plant.load.name(), cases))
    } else {
        None
    };
    Ok(Tuned {
        scenario: scenario.name.clone(),
        truth,
        result,
        hand_settle_s: settle(&hand_run),
        tuned_settle_s: settle(&tuned_run),
        hand_step,
        tuned_step,
        file,
        sweep,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tune_fails_when_it_stopped_without_a_result() {
        assert_eq!(
            verdict(&Err(TuneAbort::Stopped)),
            Err(Failed(format!("the tune stopped: {}", TuneAbort::Stopped)))
        );
        assert_eq!(
            verdict(&Err(TuneAbort::NotAtRest)),
            Err(Failed(format!(
                "the tune stopped: {}",
                TuneAbort::NotAtRest
            )))
        );
        let scenario = Scenario::load("paper-circle").expect("built in");
        let run = tune::run_tune(&scenario, tune::config_for(&scenario)).expect("runs");
        assert!(run.outcome.is_ok(), "{:?}", run.outcome);
        assert_eq!(verdict(&run.outcome), Ok(()));
    }
}
