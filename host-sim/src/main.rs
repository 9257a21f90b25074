//! `host-sim`: run the paper's experiments and your own scenarios against a simulated
//! robot. `host-sim --help` lists the commands.
//!
//! This file only dispatches: the command line is [`cli_args`], each command is a module
//! of [`host_sim::commands`] that returns a report; this prints the report, and exits
//! with 1 (after `error: …` on stderr) when the command or its verdict failed. A closed
//! stdout (`host-sim list | head -1`) is a normal exit.

mod cli_args;

use std::fmt;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Result;
use clap::Parser;
use controller_core::law::LawKind;
use host_sim::commands::{self, Report};

use cli_args::{Cli, Client, Command};

/// Writes `text` to stdout (an error when stdout is closed).
fn say(text: &dyn fmt::Display) -> std::io::Result<()> {
    write!(std::io::stdout().lock(), "{text}")
}

/// Prints `report`, then applies its verdict.
fn finish(report: &impl Report) -> Result<()> {
    say(report)?;
    report.verdict()?;
    Ok(())
}

fn dispatch(command: Command) -> Result<()> {
    match command {
        Command::Run {
            scenario,
            law,
            out,
            trace_every,
            duration_s,
            mcap,
        } => finish(&commands::run::run(&commands::run::Options {
            scenario,
            law: LawKind::from(law),
            out,
            trace_every,
            duration_s,
            mcap,
        })?),
        Command::Paper { out } => finish(&commands::paper::run(out)?),
        Command::Compare { scenario, out } => finish(&commands::compare::run(&scenario, out)?),
        Command::Sweep {
            scenario,
            runs,
            law,
            seed,
            out,
            heading,
            mcap_dir,
        } => finish(&commands::sweep::run(&commands::sweep::Options {
            scenario,
            runs,
            law: LawKind::from(law),
            seed,
            out,
            heading: heading.map(Into::into),
            mcap_dir,
        })?),
        Command::VelocityCheck { scenario } => finish(&commands::velocity_check::run(&scenario)?),
        Command::StepResponse {
            scenario,
            setpoint_rad_s,
            duration_s,
            out,
        } => finish(&commands::step_response::run(
            &commands::step_response::Options {
                scenario,
                setpoint_rad_s,
                duration_s,
                out,
            },
        )?),
        Command::Faults {
            scenario,
            law,
            out,
            matrix: true,
            ..
        } => finish(&commands::faults::run_matrix(
            &scenario,
            LawKind::from(law),
            out,
        )?),
        Command::Faults {
            scenario,
            law,
            out,
            mcap_dir,
            matrix: false,
        } => finish(&commands::faults::run(
            &scenario,
            LawKind::from(law),
            out,
            mcap_dir,
        )?),
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
        } => {
            let options = commands::pil::Options {
                scenario,
                law: LawKind::from(law),
                pil: host_sim::pil::PilOptions {
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
            };
            finish(&commands::pil::run(&options, &mut say)?)
        }
        Command::ParamSweep { scenario, corners } => {
            finish(&commands::param_sweep::run(&scenario, corners)?)
        }
        Command::Margins {
            scenario,
            measure,
            amplitude_v,
        } => finish(&commands::margins::run(&scenario, measure, amplitude_v)?),
        Command::Serve {
            scenario,
            listen,
            speed,
            miswire,
            hands,
            foxglove,
            foxglove_hz,
        } => {
            let foxglove = foxglove.map(|address| commands::serve::FoxgloveOptions {
                address,
                hz: foxglove_hz,
            });
            // An event line that cannot be written is dropped: the robot keeps serving.
            let mut event = |line: &commands::serve::EventLine| {
                let mut out = std::io::stdout().lock();
                let _ = write!(out, "{line}");
                let _ = out.flush();
            };
            let mut listening = |line: &commands::serve::Listening| say(line);
            let bench = commands::serve::Bench { miswire, hands };
            finish(&commands::serve::run(
                &scenario,
                &listen,
                speed,
                &bench,
                foxglove.as_ref(),
                &mut listening,
                &mut event,
            )?)
        }
        Command::Tune {
            scenario,
            out,
            sweep,
            tau_c_per_dead_time,
            max_hold_s,
            lifted,
        } => {
            let options = commands::tune::Options {
                scenario,
                out,
                sweep,
                tau_c_per_dead_time,
                max_hold_s,
                lifted,
            };
            finish(&commands::tune::run(&options, &mut say)?)
        }
        Command::List => finish(&commands::list::run()),
        Command::Show { name } => finish(&commands::show::run(&name)?),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match dispatch(cli.command) {
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
