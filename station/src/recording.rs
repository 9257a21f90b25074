//! `record` and `run`: telemetry to files, and a scenario run on the robot with the
//! simulator's outputs.

use std::io::Write as _;
use std::path::{Path as FsPath, PathBuf};
use std::sync::atomic::Ordering;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use link::Uplink;
use robot_files::cli::Law;
use robot_files::metrics::{fault_names, ErrorReport};
use robot_files::output::settle_text;
use robot_files::scenario::Scenario;
use station::record::{self, Recording, RunPlan};
use station::{ops, NotAsAsked};

use crate::{interrupt_flag, load, open, LinkArgs};

/// Records telemetry (and the virtual robot's ground truth) at `hz` into
/// `out/telemetry.csv` (and `mcap`, if given) until Ctrl-C or `duration_s` of the robot's
/// time.
pub(crate) fn cmd_record(
    link: &LinkArgs,
    out: &FsPath,
    hz: u8,
    duration_s: Option<f64>,
    mcap: Option<&FsPath>,
) -> Result<()> {
    if let Some(d) = duration_s.filter(|d| !(d.is_finite() && *d > 0.0)) {
        bail!("--duration-s must be a positive number of seconds, got {d}");
    }
    let interrupt = interrupt_flag();
    let mut client = open(link)?;
    let robot = ops::get_params(&mut client)?;
    let params = controller_core::params::Params::new(robot.robot).ok();
    let rate = f64::from(robot.robot.control_rate_hz);
    // The MCAP file's samples: every row of telemetry.csv, as trace rows.
    let mut samples: Vec<robot_files::trace::TraceRow> = Vec::new();
    let hz = record::set_telemetry_rate(&mut client, hz)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let file = out.join("telemetry.csv");
    let mut csv = String::from(
        "step,t_s,state,x_est_m,y_est_m,theta_est_rad,x_e_m,y_e_m,theta_e_rad,\
setpoint_left_rad_s,setpoint_right_rad_s,speed_left_rad_s,speed_right_rad_s,duty_left,duty_right,\
supply_v,faults,x_true_m,y_true_m,theta_true_rad\n",
    );
    let mut pending: Option<link::TelemetryFrame> = None;
    let mut first: Option<u32> = None;
    let mut rows = 0u64;
    let period = (rate as u32 / u32::from(hz.max(1))).max(1);
    let mut frames = record::GapCounter::default();
    let mut last_k = 0u64;
    let mut push = |csv: &mut String,
                    first: u32,
                    f: &link::TelemetryFrame,
                    g: Option<&link::GroundTruth>| {
        use std::fmt::Write as _;
        let t = f64::from(f.step.wrapping_sub(first)) / rate;
        if mcap.is_some() {
            samples.push(record::trace_row(f, g, t, None, params.as_ref()));
        }
        let (gx, gy, gt) = g.map_or((f32::NAN, f32::NAN, f32::NAN), |g| {
            (g.pose.x_m, g.pose.y_m, g.pose.theta_rad)
        });
        let _ = writeln!(
            csv,
            "{},{t:.3},{:?},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.3},{},{gx:.6},{gy:.6},{gt:.6}",
            f.step,
            f.state,
            f.pose.x_m,
            f.pose.y_m,
            f.pose.theta_rad,
            f.tracking_error.x_e_m,
            f.tracking_error.y_e_m,
            f.tracking_error.theta_e_rad,
            f.wheel_setpoint.left_rad_s,
            f.wheel_setpoint.right_rad_s,
            f.wheel_speed.left_rad_s,
            f.wheel_speed.right_rad_s,
            f.duty.left,
            f.duty.right,
            f.supply_v,
            fault_names(&f.faults).join("|"),
        );
    };
    eprintln!(
        "recording at {hz} Hz to {} (Ctrl-C to stop)",
        file.display()
    );
    let limit = duration_s.map(|d| (d * rate) as u64);
    // Why the recording stopped before its duration, if it did.
    let mut cut_short = None;
    let mut reached = false;
    loop {
        if interrupt.load(Ordering::Relaxed) {
            break;
        }
        let message = match client.next_message(Duration::from_millis(50)) {
            Ok(Some(message)) => message,
            Ok(None) => continue,
            Err(e) => {
                cut_short = Some(format!("the link failed: {}", station::error_text(&e)));
                break;
            }
        };
        match message {
            Uplink::Telemetry(f) => {
                let start = *first.get_or_insert(f.step);
                let k = u64::from(f.step.wrapping_sub(start));
                // Steps 0 ≤ k < limit are the recording's: the frame at the limit is not.
                if limit.is_some_and(|limit| k >= limit) {
                    reached = true;
                    break;
                }
                last_k = k;
                frames.push(k, period);
                if let Some(p) = pending.replace(f) {
                    push(&mut csv, start, &p, None);
                    rows += 1;
                }
            }
            Uplink::GroundTruth(g) => {
                if let Some(p) = pending.take() {
                    let start = first.unwrap_or(p.step);
                    push(&mut csv, start, &p, Some(&g).filter(|g| g.step == p.step));
                    rows += 1;
                }
            }
            Uplink::Event { step, event } => eprintln!("step {step}: {event:?}"),
            _ => {}
        }
    }
    if let Some(p) = pending.take() {
        push(&mut csv, first.unwrap_or(p.step), &p, None);
        rows += 1;
    }
    std::fs::write(&file, csv).with_context(|| format!("writing {}", file.display()))?;
    say!("wrote {rows} rows to {}", file.display());
    if let Some(mcap) = mcap {
        let written = robot_foxglove::write_run_mcap(
            mcap,
            &robot_foxglove::RunRecord {
                path: None,
                trace: &samples,
                end: Some("recording ended"),
            },
        )?;
        say!(
            "wrote {} samples to {} ({} bytes)",
            written.samples,
            mcap.display(),
            written.bytes
        );
    }
    let steps = match limit {
        Some(limit) if reached => limit,
        _ => last_k + 1,
    };
    let (received, missing) = frames.count(steps, period);
    say!(
        "telemetry: {received} of {} frames at {hz} Hz ({missing} missing)",
        received + missing
    );
    if received + missing > 0
        && missing as f64 > record::MISSING_TELEMETRY_WARNING * (received + missing) as f64
    {
        eprintln!(
            "warning: {missing} of {} telemetry frames are missing: the recording has gaps",
            received + missing
        );
    }
    match (duration_s, cut_short) {
        (_, Some(why)) => Err(NotAsAsked(format!(
            "the recording was cut short: {why}; what was recorded is in {}",
            file.display()
        ))
        .into()),
        (Some(d), None) if !reached => Err(NotAsAsked(format!(
            "the recording was interrupted (Ctrl-C) before its {d} s; what was recorded is in {}",
            file.display()
        ))
        .into()),
        _ => Ok(()),
    }
}

/// Runs `scenario` with `law` on the robot and writes the simulator's outputs into `out`
/// (and the run as `mcap`, if given).
pub(crate) fn cmd_run(
    link: &LinkArgs,
    scenario: &str,
    law: Law,
    out: &FsPath,
    hz: u8,
    mcap: Option<&FsPath>,
) -> Result<()> {
    let interrupt = interrupt_flag();
    let scenario = load(scenario)?;
    let mut client = open(link)?;
    let robot = ops::get_params(&mut client)?;
    if robot.robot != scenario.robot {
        eprintln!(
            "note: the robot's [robot] parameters differ from the scenario's; the run uses \
the robot's (`station params set` sends a robot file)"
        );
    }
    let bar =
        ProgressBar::new((scenario.duration_s * f64::from(robot.robot.control_rate_hz)) as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {msg} ({elapsed})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let rate = f64::from(robot.robot.control_rate_hz);
    let mut progress = |done: u64, total: u64| {
        bar.set_position(done.min(total));
        bar.set_message(format!(
            "{:.1} / {:.1} s",
            done as f64 / rate,
            total as f64 / rate
        ));
    };
    let mut plan = RunPlan {
        scenario: &scenario,
        law: law.into(),
        telemetry_hz: hz,
        interrupt: &interrupt,
        progress: &mut progress,
    };
    let outcome = record::run(&mut client, &mut plan);
    bar.finish_and_clear();
    let recording = outcome?;
    let mut files = recording.write(out)?;
    let mcap_written = match mcap {
        Some(file) => Some(recording.write_mcap(file, &scenario.path)?),
        None => None,
    };
    // Figures of a run cut short are drawn as far as it went, if they can be.
    if recording.complete() {
        files.extend(write_figures(out, &scenario, &recording)?);
    } else if !recording.trace.is_empty() {
        match write_figures(out, &scenario, &recording) {
            Ok(figures) => files.extend(figures),
            Err(e) => eprintln!(
                "note: no figures of the part recorded: {}",
                station::causes_text(e.chain())
            ),
        }
    }
    let s = &recording.summary;
    say!(
        "{} with the {} law on {}: {:.1} s recorded in {:.1} s ({} trace rows), ended by {}",
        s.scenario,
        s.law,
        s.source,
        s.sim_time_s,
        s.wall_time_s,
        recording.trace.len(),
        recording.ended_by
    );
    let window = record::final_window_text(s.sim_time_s);
    let line = |which: &str, e: &ErrorReport| {
        format!(
            "  {which}: settle {}, final {:.4} m / {:+.2}°, {window}: RMS {:.4} m, max {:.4} m",
            settle_text(e.settle_time_s),
            e.final_position_error_m,
            e.final_heading_error_rad.to_degrees(),
            e.rms_position_error_m,
            e.max_position_error_m
        )
    };
    if recording.report.is_some() {
        if let Some(t) = &s.true_error {
            say!("{}", line("true error (ground truth)", t));
        }
        say!(
            "{}",
            line("estimated error (robot's odometry)", &s.estimated_error)
        );
    } else {
        say!("  errors: none, the robot's run report did not come");
    }
    say!(
        "  supervisor: {}{}",
        s.supervisor.final_state,
        if s.supervisor.faults.is_empty() {
            String::new()
        } else {
            format!(", faults {}", s.supervisor.faults.join(", "))
        }
    );
    say!("  {}", recording.telemetry.text());
    if let Some(warning) = recording.telemetry.warning() {
        eprintln!("warning: {warning}");
    }
    let names: Vec<String> = files
        .iter()
        .filter_map(|f| f.file_name())
        .map(|n| n.to_string_lossy().into_owned())
        .collect();
    say!("  wrote {} to {}", names.join(", "), out.display());
    if let Some(written) = mcap_written {
        say!(
            "  wrote {} ({} samples, {} bytes)",
            written.file.display(),
            written.samples,
            written.bytes
        );
    }
    if !recording.complete() {
        return Err(NotAsAsked(format!(
            "the run did not end at its time limit: it ended by {}; what was recorded is in \
{} (summary.json: \"complete\": false)",
            recording.ended_by,
            out.display()
        ))
        .into());
    }
    if let Some(e) = &recording.after_run_error {
        bail!("the link failed after the run: {e}");
    }
    Ok(())
}

/// Writes Figs. 5–7 of `recording`, a run of `scenario`, into `out` (which exists): from
/// the ground truth when the robot sent it, else from its odometry, titled so (its
/// `trace.csv` keeps the true columns empty). Returns the files written.
#[cfg(feature = "figures")]
fn write_figures(out: &FsPath, scenario: &Scenario, recording: &Recording) -> Result<Vec<PathBuf>> {
    use robot_files::figures::write_run_figures;
    let summary = &recording.summary;
    if recording.has_truth {
        return Ok(write_run_figures(out, scenario, summary, &recording.trace)?);
    }
    let mut shown = scenario.clone();
    shown.name = format!("{} (robot's odometry, no ground truth)", scenario.name);
    let as_truth = record::estimate_as_truth(&recording.trace);
    Ok(write_run_figures(out, &shown, summary, &as_truth)?)
}

/// A station built without its `figures` feature draws no figures; it says so.
#[cfg(not(feature = "figures"))]
fn write_figures(_: &FsPath, _: &Scenario, _: &Recording) -> Result<Vec<PathBuf>> {
    eprintln!("note: no figures (this station was built without its `figures` feature)");
    Ok(Vec::new())
}
