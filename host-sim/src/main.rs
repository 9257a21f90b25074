//! `host-sim`: run the paper's experiments and your own scenarios against a simulated
//! robot. `host-sim --help` lists the commands.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use controller_core::law::LawKind;
use host_sim::output;
use host_sim::run::{run_scenario, wheel_step_response, RunResult};
use host_sim::{plot, sweep};
use indicatif::{ProgressBar, ProgressStyle};
use robot_files::cli::Law;
use robot_files::output::settle_text;
use robot_files::scenario::{Scenario, ScenarioError, BUILTIN};
use robot_files::trace::TraceRow;

/// Differential-drive robot simulator for the Jin & Tack (2011) path-following stack.
#[derive(Parser)]
#[command(name = "host-sim", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run one scenario: writes trace.csv, summary.json and Figs. 5–7 (SVG) into --out.
    Run {
        /// Built-in scenario name (see `list`) or a path to a .toml file.
        scenario: String,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
        /// Output directory [default: host-sim-out/<scenario>/<law>].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Trace row every N control steps (1 = every step) [default: every steering
        /// update, the scenario's robot.steering_divider].
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        trace_every: Option<u32>,
        /// Simulated time, s, instead of the scenario's sim.duration_s (up to 86 400: a
        /// 24 h soak is `--duration-s 86400`).
        #[arg(long)]
        duration_s: Option<f64>,
    },
    /// Reproduce the paper: its circle and line experiments with every law, Figs. 5–7 and
    /// summary.json for each run, an overlay per experiment, a table and the verdict.
    Paper {
        /// Output directory [default: host-sim-out/paper].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Every law on the same plant: a table on stdout and compare.svg in --out.
    Compare {
        /// Built-in scenario name or a path to a .toml file.
        scenario: String,
        /// Output directory [default: host-sim-out/<scenario>/compare].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Monte-Carlo over mismatch, noise and start pose (the scenario's [sweep] spreads),
    /// on every core.
    Sweep {
        /// Built-in scenario name or a path to a .toml file.
        scenario: String,
        /// Number of runs.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        runs: u32,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
        /// Seed of the draws.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Also write sweep.json (every run's draws and results) into this directory.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Wheel-speed loop alone: a set-point step from rest, to tune the wheel PID.
    StepResponse {
        /// Built-in scenario name or a path to a .toml file (its robot and plant are used).
        #[arg(default_value = "paper-circle")]
        scenario: String,
        /// Set-point, rad/s (wheel).
        #[arg(long, default_value_t = 15.0, allow_negative_numbers = true)]
        setpoint_rad_s: f64,
        /// Duration, s.
        #[arg(long, default_value_t = 1.0)]
        duration_s: f64,
        /// Output directory for step_response.svg [default: host-sim-out/<scenario>/step].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Every kind of fault, one at a time, on a built-in scenario: what the supervisor did,
    /// how fast, against its detector's limit. Prints a table, writes faults.json, and
    /// fails if a case did not behave as stated.
    Faults {
        /// Built-in scenario name or a path to a .toml file.
        #[arg(default_value = "paper-circle")]
        scenario: String,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
        /// Output directory for faults.json [default: host-sim-out/<scenario>/faults].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Processor in the loop: the firmware, built for the Cortex-M4F with its `qemu` board,
    /// runs under qemu-system-arm against this simulator's plant in lockstep, and a ground
    /// station drives it over its link (the station port). Prints the firmware's figures,
    /// compares the run with `host-sim run`, writes summary.json and pil.json into --out.
    Pil {
        /// Built-in scenario name or a path to a .toml file.
        scenario: String,
        #[arg(long, value_enum, default_value_t = Law::Tracking)]
        law: Law,
        /// The firmware ELF [default: target/thumbv7em-none-eabihf/firmware/firmware, as
        /// built by `cargo build --profile firmware -p firmware --target
        /// thumbv7em-none-eabihf --features qemu`].
        #[arg(long)]
        firmware: Option<PathBuf>,
        /// The QEMU binary.
        #[arg(long, default_value = "qemu-system-arm")]
        qemu: PathBuf,
        /// TCP port of the firmware's link for a ground station (0: any free port, printed).
        #[arg(long, default_value_t = 0)]
        station_port: u16,
        /// Who drives the link: the built-in minimal station, or none (connect your own to
        /// the station port).
        #[arg(long, value_enum, default_value_t = Client::Builtin)]
        client: Client,
        /// Simulated time, s, instead of the scenario's sim.duration_s.
        #[arg(long)]
        duration_s: Option<f64>,
        /// Cut the link this many seconds after arming (a link-loss test).
        #[arg(long)]
        link_loss_at_s: Option<f64>,
        /// How long the station may take to arm the robot, s (wall clock).
        #[arg(long, default_value_t = 300)]
        arm_timeout_s: u64,
        /// Output directory [default: host-sim-out/<scenario>/pil].
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// The wheel loop's gain and phase margins in every load case (ground straight and
    /// turning, lifted; motoring and braking), from the linearised loop; `--measure`
    /// cross-checks them with a frequency sweep on the simulated robot.
    Margins {
        /// Built-in scenario name or a path to a .toml file (its robot and plant are used).
        #[arg(default_value = "paper-circle")]
        scenario: String,
        /// Also measure the loop by injecting sines on the simulated robot.
        #[arg(long)]
        measure: bool,
        /// Amplitude of the injected sine, V.
        #[arg(long, default_value_t = 0.5)]
        amplitude_v: f64,
    },
    /// The wheel loop with its gains fixed against supplies from 4.8 to 12.6 V and motors
    /// with R_a, K_t, friction and inertia ±30 %: margins, a step, the scenario; a table.
    ParamSweep {
        /// Built-in scenario name or a path to a .toml file.
        #[arg(default_value = "paper-circle")]
        scenario: String,
        /// Also every combination of the four parameters at ±30 % at 4.8 and 12.6 V.
        #[arg(long)]
        corners: bool,
    },
    /// The virtual robot: the robot's own application logic (supervisor, controller, link
    /// service) against the simulated hardware, speaking the runtime link on a TCP port,
    /// with ground truth. Drive it with `station --connect ADDRESS …`.
    Serve {
        /// Built-in scenario name or a path to a .toml file (robot, plant, initial path).
        #[arg(default_value = "paper-circle")]
        scenario: String,
        /// Address to listen on.
        #[arg(long, default_value = "127.0.0.1:5760")]
        listen: String,
        /// Simulated time per wall-clock time (1 = real time).
        #[arg(long, default_value_t = 1.0)]
        speed: f64,
    },
    /// The core's wheel-loop tune on the simulated robot (ground or lifted, the scenario's
    /// `[plant] load`): the identified model against the linearised plant, the gains (as
    /// robot-file sections), a 0 → 15 rad/s step at 6 V tuned vs the scenario's gains
    /// (SVG) and the scenario's settle time with both.
    Tune {
        /// Built-in scenario name or a path to a .toml file.
        #[arg(default_value = "paper-circle")]
        scenario: String,
        /// Output directory for the plot (default: out/<scenario>/tune).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Also the acceptance sweep: the identification on 36 robots (supply 5–12.6 V,
        /// each motor parameter ±30 %) against their linearised truth.
        #[arg(long)]
        sweep: bool,
        /// SIMC's τ_c over the loop's effective dead time (default: the core's).
        #[arg(long)]
        tau_c_per_dead_time: Option<f32>,
        /// Length of the tune's hold and step, s (default: the core's).
        #[arg(long)]
        hold_s: Option<f32>,
        /// Tune with the wheels lifted (the plant's load set to `lifted`): τ is corrected
        /// for the chassis before the PI is set.
        #[arg(long)]
        lifted: bool,
    },
    /// List the built-in scenarios.
    List,
    /// Print a built-in scenario's TOML (a starting point for your own).
    Show {
        /// Built-in scenario name.
        name: String,
    },
}

/// Who drives the link of a processor-in-the-loop run.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum Client {
    /// The built-in minimal station (host_sim::pil::station).
    Builtin,
    /// Nobody: connect a station to the station port.
    None,
}

/// `println!` that returns an error instead of panicking when stdout is closed (for
/// example `host-sim list | head -1`); `main` treats a broken pipe as a normal exit.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout(), $($arg)*)?
    }};
}

fn default_dir(scenario: &Scenario, leaf: &str) -> PathBuf {
    // A file path as scenario name would nest oddly: keep only safe characters.
    let name: String = scenario
        .name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    PathBuf::from("host-sim-out").join(name).join(leaf)
}

fn load(name: &str) -> Result<Scenario> {
    Scenario::load(name).map_err(|e| match e {
        // Say which file a value error is in (syntax errors already do).
        ScenarioError::Invalid { .. } => anyhow::Error::new(e).context(name.to_string()),
        other => other.into(),
    })
}

fn cmd_run(
    scenario: &str,
    law: Law,
    out: Option<PathBuf>,
    trace_every: Option<u32>,
    duration_s: Option<f64>,
) -> Result<()> {
    let mut scenario = load(scenario)?;
    if let Some(duration_s) = duration_s {
        scenario = scenario.with_duration_s(duration_s)?;
    }
    let law = LawKind::from(law);
    let options = host_sim::RunOptions {
        trace_every_steps: trace_every.unwrap_or(scenario.robot.steering_divider),
    };
    let result = host_sim::run_scenario_with(&scenario, law, options)?;
    let dir = out.unwrap_or_else(|| default_dir(&scenario, law.name()));
    let files = output::write_run(&dir, &scenario, &result)?;
    say!("{}", output::human_summary(&scenario, &result).trim_end());
    say!("  wrote {} files to {}", files.len(), dir.display());
    Ok(())
}

/// Every law on `scenario` with the default trace options.
fn run_every_law(scenario: &Scenario) -> Result<Vec<(LawKind, RunResult)>> {
    LawKind::ALL
        .into_iter()
        .map(|law| Ok((law, run_scenario(scenario, law)?)))
        .collect()
}

/// The comparison table of `results` on stdout.
fn print_table(scenario: &Scenario, results: &[(LawKind, RunResult)]) -> Result<()> {
    say!(
        "{}: every law on the same plant ({} s)\n",
        scenario.name,
        scenario.duration_s
    );
    say!(
        "{:<9} {:>12} {:>11} {:>12} {:>11} {:>11} {:>10} {:>6} {:>10}",
        "law",
        "settle",
        "final e/m",
        "final θe/°",
        "rms10 e/m",
        "max10 e/m",
        "ω_w max",
        "duty",
        "driven/m"
    );
    for (law, r) in results {
        let s = &r.summary;
        let e = s.headline_error();
        say!(
            "{:<9} {:>12} {:>11.4} {:>12.2} {:>11.4} {:>11.4} {:>10.1} {:>6.2} {:>10.2}",
            law.name(),
            settle_text(e.settle_time_s),
            e.final_position_error_m,
            e.final_heading_error_rad.to_degrees(),
            e.rms_position_error_m,
            e.max_position_error_m,
            s.max_wheel_speed_rad_s,
            s.max_duty,
            r.distance_travelled_m
        );
    }
    let expected = f64::from(scenario.reference_speed_m_s) * scenario.duration_s;
    say!(
        "\n(e: true position error — to the reference point, or to the path when \
path-following; rms10/max10: last 10 s; the reference covers {expected:.2} m; {})",
        if scenario.start.v_m_s != 0.0 || scenario.start.omega_rad_s != 0.0 {
            "armed in motion at t = 0"
        } else {
            "armed at rest at t = 0"
        }
    );
    if let controller_core::reference::ReferenceMode::PathFollowing { lookahead_m } =
        scenario.reference_mode
    {
        say!(
            "note: path-following with lookahead {lookahead_m} m. The paper's law is a \
regulation law (docs/paper-errata.md, item 3): it drives to the reference point and stops there, so \
with the reference at the robot's own projection it stalls on the path (see driven/m)."
        );
    }
    Ok(())
}

/// The overlay of every law's path and error, `compare.svg` in `dir`.
fn write_overlay(
    dir: &std::path::Path,
    scenario: &Scenario,
    results: &[(LawKind, RunResult)],
) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let file = dir.join("compare.svg");
    let runs: Vec<(&str, &[TraceRow])> = results
        .iter()
        .map(|(law, r)| (law.name(), r.trace.as_slice()))
        .collect();
    robot_files::figures::compare(&file, &scenario.name, &scenario.path, &runs)?;
    Ok(file)
}

fn cmd_compare(scenario: &str, out: Option<PathBuf>) -> Result<()> {
    let scenario = load(scenario)?;
    let results = run_every_law(&scenario)?;
    print_table(&scenario, &results)?;
    let dir = out.unwrap_or_else(|| default_dir(&scenario, "compare"));
    let file = write_overlay(&dir, &scenario, &results)?;
    say!("\nwrote {}", file.display());
    Ok(())
}

/// The paper's experiments (section 4) with every law, and what they show.
fn cmd_paper(out: Option<PathBuf>) -> Result<()> {
    let root = out.unwrap_or_else(|| PathBuf::from("host-sim-out").join("paper"));
    for name in ["paper-circle", "paper-line"] {
        let scenario = load(name)?;
        let results = run_every_law(&scenario)?;
        print_table(&scenario, &results)?;
        let dir = root.join(name);
        for (law, result) in &results {
            output::write_run(&dir.join(law.name()), &scenario, result)?;
        }
        write_overlay(&dir, &scenario, &results)?;
        say!("wrote {}/{{paper,tracking,kanayama}}/ (Figs. 5–7, summary.json, trace.csv) and compare.svg\n", dir.display());

        let gamma = f64::from(scenario.robot.law.paper.gamma);
        let lag = f64::from(scenario.reference_speed_m_s) / gamma;
        for (law, r) in &results {
            let s = r.summary.headline_error();
            match law {
                LawKind::Paper => say!(
                    "  paper law (33)–(34): trails the moving reference by {:.4} m; a regulation \
law settles where v = v_r, at r_e ≈ v_r/γ = {lag:.4} m (docs/paper-errata.md, item 3)",
                    s.final_position_error_m
                ),
                LawKind::Tracking => say!(
                    "  tracking law: {} to |e| < 1 cm and |θ_e| < 1° (the paper reports 5–6 s), \
final error {:.4} m",
                    settle_text(s.settle_time_s),
                    s.final_position_error_m
                ),
                LawKind::Kanayama => {}
            }
        }
        say!("");
    }
    say!("figures and summaries: {}", root.display());
    Ok(())
}

fn cmd_sweep(scenario: &str, runs: u32, law: Law, seed: u64, out: Option<PathBuf>) -> Result<()> {
    let scenario = load(scenario)?;
    let law = LawKind::from(law);
    let bar = ProgressBar::new(u64::from(runs));
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let progress = || bar.inc(1);
    let report = sweep::sweep(&scenario, law, runs, seed, &progress)?;
    bar.finish_and_clear();
    let s = scenario.sweep;
    say!(
        "{} with the {} law: {} runs on {} threads in {:.1} s",
        report.scenario,
        report.law,
        report.runs,
        rayon::current_num_threads(),
        report.wall_time_s
    );
    say!(
        "  spreads: radius ±{}%, left/right ±{}%, track ±{}%, supply ±{}%, Coulomb ±{}%, \
slip 0…{}, encoder jitter 0…{} ticks, start ±{} m / ±{} rad",
        s.wheel_radius_pct,
        s.wheel_radius_left_right_pct,
        s.track_width_pct,
        s.supply_pct,
        s.coulomb_friction_pct,
        s.slip_max,
        s.encoder_noise_ticks_rms_max,
        s.start_position_m,
        s.start_heading_rad
    );
    say!(
        "  success (the controller's own error settles to 1 cm / 1°, no fault): {:.1} %",
        report.success_rate * 100.0
    );
    if report.invalid_draws > 0 {
        say!(
            "  {} draws gave an invalid robot or plant and did not run (counted as failures); \
narrow the scenario's [sweep] spreads",
            report.invalid_draws
        );
    }
    match report.settle_time_s {
        Some(p) => say!(
            "  settle time: p50 {:.2} s, p90 {:.2} s, p95 {:.2} s, max {:.2} s",
            p.p50,
            p.p90,
            p.p95,
            p.max
        ),
        None => say!("  settle time: no run settled"),
    }
    if let Some(p) = report.final_true_position_error_m {
        say!(
            "  true final position error (odometry drift included): p50 {:.3} m, p90 {:.3} m, \
max {:.3} m; true error settled in {:.1} % of runs",
            p.p50,
            p.p90,
            p.max,
            report.true_settle_rate * 100.0
        );
    }
    if let Some(dir) = out {
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let file = dir.join("sweep.json");
        let json = serde_json::to_string_pretty(&report).context("serialising the sweep")?;
        std::fs::write(&file, json).with_context(|| format!("writing {}", file.display()))?;
        say!("  wrote {}", file.display());
    }
    Ok(())
}

fn cmd_faults(scenario: &str, law: Law, out: Option<PathBuf>) -> Result<()> {
    use host_sim::fault_suite::{run_suite, Expectation, INJECT_AT_S};
    let scenario = load(scenario)?;
    let results = run_suite(&scenario, LawKind::from(law))?;
    say!(
        "{} with the {} law, armed in motion, each fault injected at {INJECT_AT_S} s:\n",
        scenario.name,
        LawKind::from(law).name()
    );
    say!(
        "{:<38} {:>8} {:>9} {:>8} {:>8} {:>9}  {}",
        "fault",
        "detected",
        "latency",
        "limit",
        "after/m",
        "stopped",
        "by / would be seen by"
    );
    let ms = |v: Option<f64>| v.map_or("—".to_string(), |t| format!("{:.0} ms", t * 1e3));
    for r in &results {
        let by = match r.expect {
            Expectation::Undetectable { sensor } => sensor.to_string(),
            _ => r.report.detected_by.join(", "),
        };
        let stopped = r.report.wheels_stopped_s.map(|t| t - r.report.injected_s);
        say!(
            "{:<38} {:>8} {:>9} {:>8} {:>8.3} {:>9}  {}{}",
            r.case,
            if r.detected { "yes" } else { "no" },
            ms(r.latency_s),
            ms(r.limit_s),
            r.report.distance_after_m,
            ms(stopped),
            by,
            if r.passed {
                ""
            } else {
                "   <-- NOT AS EXPECTED"
            }
        );
    }
    let dir = out.unwrap_or_else(|| default_dir(&scenario, "faults"));
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let file = dir.join("faults.json");
    let json = serde_json::to_string_pretty(&results).context("serialising the faults")?;
    std::fs::write(&file, json + "\n").with_context(|| format!("writing {}", file.display()))?;
    say!(
        "\n(latency: from injection to the supervisor stopping the robot; after/m: true distance \
driven from the injection to the end; stopped: until both wheels turn < 0.1 rad/s)\nwrote {}",
        file.display()
    );
    let failed: Vec<_> = results
        .iter()
        .filter(|r| !r.passed)
        .map(|r| r.case)
        .collect();
    if !failed.is_empty() {
        anyhow::bail!("not as expected: {}", failed.join(", "));
    }
    Ok(())
}

fn cmd_step(scenario: &str, setpoint: f64, duration: f64, out: Option<PathBuf>) -> Result<()> {
    let scenario = load(scenario)?;
    if !(setpoint.is_finite() && duration > 0.0 && duration <= 60.0) {
        anyhow::bail!("--setpoint-rad-s must be finite and --duration-s in (0, 60]");
    }
    let r = wheel_step_response(&scenario, setpoint, duration)?;
    let w = scenario.robot.left_wheel;
    say!(
        "wheel-speed step 0 → {setpoint} rad/s from rest on {} V, K_p = {} V/(rad/s), \
T_i = {} s, T_d = {} s, feed-forward k_S = {} V, k_V = {} V/(rad/s):",
        scenario.plant.driver.supply_v,
        w.kp_v_per_rad_s,
        w.ti_s,
        w.td_s,
        w.ks_v,
        w.kv_v_per_rad_s
    );
    let opt = |v: Option<f64>| v.map_or("never".to_string(), |t| format!("{:.0} ms", t * 1e3));
    say!(
        "  rise (10→90 %) {}, overshoot {:.1} %, settling (±5 %) {}, steady-state error {:+.3} rad/s",
        opt(r.rise_time_s),
        r.overshoot_pct,
        opt(r.settling_time_s),
        r.steady_state_error_rad_s
    );
    let dir = out.unwrap_or_else(|| default_dir(&scenario, "step"));
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let file = dir.join("step_response.svg");
    plot::step_response(&file, &scenario.name, &r)?;
    say!("  wrote {}", file.display());
    Ok(())
}

fn cmd_pil(
    scenario: &str,
    law: Law,
    options: host_sim::pil::PilOptions,
    duration_s: Option<f64>,
    out: Option<PathBuf>,
) -> Result<()> {
    let mut scenario = load(scenario)?;
    if let Some(duration_s) = duration_s {
        scenario = scenario.with_duration_s(duration_s)?;
    }
    let law = LawKind::from(law);
    say!(
        "PIL {}: {} law, {:.1} s, firmware {}",
        scenario.name,
        law.name(),
        scenario.duration_s,
        options.firmware.display()
    );
    let outcome = host_sim::pil::run(&scenario, law, &options)?;
    // The same scenario with the supervisor and controller run here, unless the link
    // was cut (no counterpart without a link).
    let host = match options.link_loss_at_s {
        Some(_) => None,
        None => Some(host_sim::run_scenario_with(
            &scenario,
            law,
            host_sim::RunOptions {
                trace_every_steps: 0,
            },
        )?),
    };
    let lines = host_sim::pil::verdict::judge(&scenario, &outcome, host.as_ref());
    for line in &lines {
        say!("{}", line.text);
    }
    if let Some(station) = &outcome.station {
        say!(
            "station: {} answered {} requests ({} re-sent), {} telemetry frames, {} heartbeats",
            station.robot,
            station.replies,
            station.resent,
            station.telemetry_frames,
            station.heartbeats
        );
    }
    say!(
        "PIL {}: {} steps in {:.1} s wall ({:.2} ms a step), {} control steps before arming",
        scenario.name,
        outcome.result.summary.steps,
        outcome.wall_time_s,
        1e3 * outcome.wall_time_s / outcome.result.summary.steps.max(1) as f64,
        outcome.held_steps
    );
    let dir = out.unwrap_or_else(|| default_dir(&scenario, "pil"));
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut summary = outcome.result.summary.clone();
    summary.wall_time_s = outcome.wall_time_s;
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(&summary)? + "\n",
    )?;
    let task = |t: &lockstep::TaskFigures| {
        serde_json::json!({
            "runs": t.runs,
            "max_instructions": t.max_instructions,
            "total_instructions": t.total_instructions,
        })
    };
    let board = &outcome.board;
    let pil = serde_json::json!({
        "control_interrupt": task(&board.control),
        "control_interrupt_armed": task(&board.control_armed),
        "control_interrupt_arming": task(&board.control_arming),
        "steering_task": task(&board.steering),
        "link_service": task(&board.link),
        "stack_high_water_bytes": board.stack_high_water_bytes,
        "start_stack_bytes": board.start_stack_bytes,
        "steps_before_arming": outcome.held_steps,
        "digest": outcome.result.digest.as_ref().map(ToString::to_string),
        "verdict": lines.iter().map(|l| serde_json::json!({"line": l.text, "passed": l.passed})).collect::<Vec<_>>(),
    });
    std::fs::write(
        dir.join("pil.json"),
        serde_json::to_string_pretty(&pil)? + "\n",
    )?;
    say!("  wrote summary.json and pil.json to {}", dir.display());
    let failed: Vec<&str> = lines
        .iter()
        .filter(|l| !l.passed)
        .map(|l| l.text.as_str())
        .collect();
    if !failed.is_empty() {
        anyhow::bail!("{}", failed.join("; "));
    }
    Ok(())
}

/// The options of `host-sim tune`.
struct TuneOptions {
    out: Option<PathBuf>,
    sweep: bool,
    tau_c_per_dead_time: Option<f32>,
    hold_s: Option<f32>,
    lifted: bool,
}

fn cmd_tune(scenario: &str, options: TuneOptions) -> Result<()> {
    use host_sim::tune;
    let TuneOptions {
        out,
        sweep,
        tau_c_per_dead_time,
        hold_s,
        lifted,
    } = options;
    let mut scenario = load(scenario)?;
    if lifted {
        scenario.plant.load = robot_files::plant::Load::Lifted;
    }
    let mut config = tune::config_for(&scenario);
    if let Some(x) = tau_c_per_dead_time {
        config.tau_c_per_dead_time = x;
    }
    if let Some(x) = hold_s {
        config.hold_s = x;
    }
    config
        .validate(&scenario.params()?)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let truth = tune::truth(&scenario)?;
    say!(
        "{}: tune on the {} load, {} V supply; u_hi {} V, holds {} s, τ_c = {} θ_e",
        scenario.name,
        scenario.plant.load.name(),
        scenario.plant.driver.supply_v,
        config.experiment_volts_v,
        config.hold_s,
        config.tau_c_per_dead_time
    );
    let run = tune::run_tune(&scenario, config)?;
    say!(
        "  ran {:.2} s, robot moved up to {:.3} m from its start, wheels up to {:.1} rad/s",
        run.duration_s,
        run.max_distance_m,
        run.max_wheel_speed_rad_s
    );
    let result = match run.outcome {
        Ok(r) => r,
        Err(e) => anyhow::bail!("the tune stopped: {e}"),
    };
    say!(
        "  linearised truth (motoring, straight): k_V {:.5} V/(rad/s), τ {:.1} ms (ground τ {:.1} ms)",
        truth.kv_v_per_rad_s,
        truth.time_constant_s * 1e3,
        truth.ground_time_constant_s * 1e3
    );
    for (side, m) in ["left ", "right"].iter().zip(result.models) {
        say!(
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
        );
    }
    say!("\nthe tuned wheel loops (SIMC PI with feed-forward), for the robot file:\n");
    say!(
        "{}",
        robot_files::robot_file::tuned_wheel_sections(&result).trim_end()
    );

    // The tuned loop against the scenario's own, on the ground at 6 V.
    let mut ground = scenario.clone();
    ground.plant.load = robot_files::plant::Load::Ground;
    ground.plant.driver.supply_v = 6.0;
    let tuned = tune::with_tuned_loops(&ground, &result);
    let hand_step = wheel_step_response(&ground, 15.0, 0.4)?;
    let tuned_step = wheel_step_response(&tuned, 15.0, 0.4)?;
    let opt = |v: Option<f64>| v.map_or("never".to_string(), |t| format!("{:.1} ms", t * 1e3));
    say!(
        "\n0 → 15 rad/s step from rest, on the ground at 6 V (aim: rise ≤ 60 ms, overshoot ≤ 5 %):"
    );
    for (label, r) in [("hand-tuned", &hand_step), ("tuned", &tuned_step)] {
        say!(
            "  {label:>10}: rise (10→90 %) {}, overshoot {:.1} %, settling (±5 %) {}",
            opt(r.rise_time_s),
            r.overshoot_pct,
            opt(r.settling_time_s)
        );
    }
    let mut on_scenario = scenario.clone();
    on_scenario.plant.load = robot_files::plant::Load::Ground;
    let hand_run = run_scenario(&on_scenario, LawKind::Tracking)?;
    let tuned_run = run_scenario(
        &tune::with_tuned_loops(&on_scenario, &result),
        LawKind::Tracking,
    )?;
    let settle = |r: &RunResult| r.summary.headline_error().settle_time_s;
    let (hand_settle, tuned_settle) = (settle(&hand_run), settle(&tuned_run));
    say!(
        "\n{} on the ground with the tracking law (aim: tuned settles within 10 % of hand-tuned):",
        scenario.name
    );
    say!(
        "  settle (1 cm, 1°): hand-tuned {}, tuned {}{}",
        opt(hand_settle),
        opt(tuned_settle),
        match (hand_settle, tuned_settle) {
            (Some(h), Some(t)) => format!(" ({:+.1} %)", tune::error_pct(t, h)),
            _ => String::new(),
        }
    );
    let dir = out.unwrap_or_else(|| default_dir(&scenario, "tune"));
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let file = dir.join("tune_step.svg");
    plot::step_comparison(
        &file,
        &format!("{}, ground, 6 V: tuned vs hand-tuned", scenario.name),
        &[("tuned", &tuned_step), ("hand-tuned", &hand_step)],
    )?;
    say!("  wrote {}", file.display());

    if sweep {
        let variations = tune::sweep_variations();
        let cases = tune::identification_sweep(&scenario, config, &variations)?;
        say!(
            "\nidentification sweep, {} load: k_V and τ of the worse wheel against the linearised truth",
            scenario.plant.load.name()
        );
        say!(
            "  {:<24} {:>10} {:>8} {:>9} {:>8}",
            "robot",
            "k_V truth",
            "k_V err",
            "τ truth",
            "τ err"
        );
        let (mut worst_kv, mut worst_tau, mut failed) = (0.0f64, 0.0f64, 0usize);
        for c in &cases {
            match c.errors_pct() {
                Some((kv, tau)) => {
                    worst_kv = worst_kv.max(kv.abs());
                    worst_tau = worst_tau.max(tau.abs());
                    say!(
                        "  {:<24} {:>10.5} {:>+7.1}% {:>7.1}ms {:>+7.1}%",
                        c.variation.label(),
                        c.truth.kv_v_per_rad_s,
                        kv,
                        c.truth.time_constant_s * 1e3,
                        tau
                    );
                }
                None => {
                    failed += 1;
                    let why = c.run.outcome.err().map_or(String::new(), |e| e.to_string());
                    say!("  {:<24} no model: {why}", c.variation.label());
                }
            }
        }
        say!(
            "  {} robots, {} without a model; largest error: k_V {:.1} %, τ {:.1} % (aim ≤ 10 %)",
            cases.len(),
            failed,
            worst_kv,
            worst_tau
        );
    }
    Ok(())
}

fn cmd_margins(scenario: &str, measure: bool, amplitude_v: f64) -> Result<()> {
    use host_sim::margins;
    let scenario = load(scenario)?;
    if !(amplitude_v > 0.0 && amplitude_v <= 2.0) {
        anyhow::bail!("--amplitude-v must be in (0, 2]");
    }
    let w = scenario.robot.left_wheel;
    say!(
        "{}: wheel loop K_p = {} V/(rad/s), T_i = {} s, T_d = {} s; speed window {} steps at {} Hz \
(left wheel, linearised; aim GM ≥ {} ({:.0} dB), PM ≥ {}°)\n",
        scenario.name,
        w.kp_v_per_rad_s,
        w.ti_s,
        w.td_s,
        scenario.robot.speed_window_steps,
        scenario.robot.control_rate_hz,
        margins::GAIN_MARGIN_AIM,
        20.0 * margins::GAIN_MARGIN_AIM.log10(),
        margins::PHASE_MARGIN_AIM_DEG
    );
    let cases = margins::model_cases(&scenario)?;
    say!("{}", margins::table(&cases).trim_end());
    let short: Vec<String> = cases
        .iter()
        .filter(|c| !(c.stable && margins::meets_aim(&c.margins)))
        .map(|c| c.case.name())
        .collect();
    if short.is_empty() {
        say!("\nevery case meets the aim");
    } else {
        say!("\nshort of the aim: {}", short.join("; "));
    }
    if measure {
        let settings = margins::SweepSettings {
            amplitude_v,
            ..margins::SweepSettings::default_for(&scenario)
        };
        let measured = margins::measure_cases(&scenario, settings)?;
        say!(
            "\n{}",
            margins::measured_table(&measured, settings).trim_end()
        );
    }
    Ok(())
}

fn cmd_param_sweep(scenario: &str, corners: bool) -> Result<()> {
    use host_sim::robustness::{self, OSCILLATION_RMS_RAD_S};
    let scenario = load(scenario)?;
    let w = scenario.robot.left_wheel;
    say!(
        "{}: the controller's wheel loop fixed (K_p = {} V/(rad/s), T_i = {} s, k_S = {} V, \
k_V = {} V/(rad/s)), the simulated robot varied; tracking law, {} s\n",
        scenario.name,
        w.kp_v_per_rad_s,
        w.ti_s,
        w.ks_v,
        w.kv_v_per_rad_s,
        scenario.duration_s
    );
    let rows = robustness::one_at_a_time();
    let results = robustness::run_all(&scenario, &rows)?;
    let Some(nominal) = results.first() else {
        anyhow::bail!("no nominal case");
    };
    say!("{}", robustness::table(&results, nominal).trim_end());
    say!(
        "\n(GM, PM: the linearised loop, the smaller of ground straight and turning; rise, over: \
0 → 15 rad/s step from rest; settle: true error < 1 cm and 1° to the end; RMS: set-point − true \
wheel speed, both wheels, every step; final10: the same over the last 10 s, above \
{OSCILLATION_RMS_RAD_S} rad/s counts as oscillating; ok: no oscillation or fault, settled, RMS \
≤ 2 × nominal)"
    );
    let failed = results
        .iter()
        .filter(|r| !robustness::passes(r, nominal))
        .count();
    if corners {
        let corner_results = robustness::run_all(&scenario, &robustness::corners())?;
        let passed = corner_results
            .iter()
            .filter(|r| robustness::passes(r, nominal))
            .count();
        say!(
            "\ncorners: R_a (R), K_t (K), friction (f), inertia (J) each −30 % or +30 %, at 4.8 and \
12.6 V: {passed} of {} pass (not part of the verdict: a motor 30 % off in several ways at once \
can be too weak for the path)\n",
            corner_results.len()
        );
        say!("{}", robustness::table(&corner_results, nominal).trim_end());
    }
    if failed > 0 {
        anyhow::bail!("{failed} of {} robots did not pass", results.len());
    }
    Ok(())
}

fn cmd_serve(scenario: &str, listen: &str, speed: f64) -> Result<()> {
    use host_sim::serve::{serve, ServeOptions, VirtualRobot};
    if !(speed.is_finite() && speed > 0.0 && speed <= 1000.0) {
        anyhow::bail!("--speed must be in (0, 1000], got {speed}");
    }
    let scenario = load(scenario)?;
    let listener =
        std::net::TcpListener::bind(listen).with_context(|| format!("listening on {listen}"))?;
    let mut channels = robot_app::Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario)?;
    let rate = f64::from(scenario.robot.control_rate_hz);
    say!(
        "virtual robot ({}) listening on {listen}, {speed}× real time; heartbeat timeout {} steps",
        scenario.name,
        scenario.supervisor.heartbeat_timeout_steps
    );
    let mut log = |r: &host_sim::serve::StepReport| {
        use std::io::Write as _;
        let _ = writeln!(
            std::io::stdout(),
            "step {} (t {:.3} s): {:?}, {} steps since the last heartbeat",
            r.step,
            f64::from(r.step) / rate,
            r.event.map_or_else(String::new, |e| format!("{e:?}")),
            r.steps_since_heartbeat
        );
        let _ = std::io::stdout().flush();
    };
    serve(
        &mut robot,
        &listener,
        ServeOptions {
            speed,
            max_steps: None,
        },
        &mut log,
    )?;
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run {
            scenario,
            law,
            out,
            trace_every,
            duration_s,
        } => cmd_run(&scenario, law, out, trace_every, duration_s),
        Command::Paper { out } => cmd_paper(out),
        Command::Compare { scenario, out } => cmd_compare(&scenario, out),
        Command::Sweep {
            scenario,
            runs,
            law,
            seed,
            out,
        } => cmd_sweep(&scenario, runs, law, seed, out),
        Command::StepResponse {
            scenario,
            setpoint_rad_s,
            duration_s,
            out,
        } => cmd_step(&scenario, setpoint_rad_s, duration_s, out),
        Command::Faults { scenario, law, out } => cmd_faults(&scenario, law, out),
        Command::Pil {
            scenario,
            law,
            firmware,
            qemu,
            station_port,
            client,
            duration_s,
            link_loss_at_s,
            arm_timeout_s,
            out,
        } => cmd_pil(
            &scenario,
            law,
            host_sim::pil::PilOptions {
                firmware: firmware.unwrap_or_else(|| {
                    host_sim::pil::default_firmware(&PathBuf::from(concat!(
                        env!("CARGO_MANIFEST_DIR"),
                        "/../target"
                    )))
                }),
                qemu,
                station_port,
                builtin_station: matches!(client, Client::Builtin),
                link_loss_at_s,
                arm_timeout: std::time::Duration::from_secs(arm_timeout_s),
            },
            duration_s,
            out,
        ),
        Command::ParamSweep { scenario, corners } => cmd_param_sweep(&scenario, corners),
        Command::Margins {
            scenario,
            measure,
            amplitude_v,
        } => cmd_margins(&scenario, measure, amplitude_v),
        Command::Serve {
            scenario,
            listen,
            speed,
        } => cmd_serve(&scenario, &listen, speed),
        Command::Tune {
            scenario,
            out,
            sweep,
            tau_c_per_dead_time,
            hold_s,
            lifted,
        } => cmd_tune(
            &scenario,
            TuneOptions {
                out,
                sweep,
                tau_c_per_dead_time,
                hold_s,
                lifted,
            },
        ),
        Command::List => (|| {
            for (name, text) in BUILTIN {
                let description = Scenario::from_toml(text, name)
                    .map(|s| s.description)
                    .unwrap_or_default();
                say!("{name:<18} {description}");
            }
            Ok(())
        })(),
        Command::Show { name } => match BUILTIN.iter().find(|(n, _)| *n == name) {
            Some((_, text)) => (|| {
                say!("{}", text.trim_end());
                Ok(())
            })(),
            None => Err(anyhow::anyhow!(ScenarioError::Unknown(name))),
        },
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let broken_pipe = e
                .downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe);
            if broken_pipe {
                // The reader went away (`| head`): not an error of ours.
                return ExitCode::SUCCESS;
            }
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
