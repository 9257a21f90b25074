//! `station bringup`: a new robot from flashed to driving, over the link, one step at a
//! time (`docs/bring-up.md`). Each step reads the robot's own signals, asks the user only
//! for what a person sees or measures (a multimeter reading, `done` once a wheel is
//! turned), and what it learns goes into the robot's parameters: shown as a robot-file
//! diff, then sent and persisted once confirmed. The steps, each runnable alone
//! (`station bringup encoders`):
//!
//! 1. [`link_check`]: the link, who the robot is, its clock, brown-out level, reset
//!    cause and panic record;
//! 2. [`button`]: the button and the LED;
//! 3. [`supply`]: the supply against the multimeter gives the divider's scale;
//! 4. [`encoders`]: each wheel turned one turn by hand gives its encoder's input, sign and
//!    counts per turn;
//! 5. [`motors`]: a short pulse per motor and direction, the wheels lifted, gives each
//!    motor's output and sign, and any that does not respond;
//! 6. [`gyro`]: the robot turned one turn on the spot by hand gives the gyro's axis sign
//!    and scale (skipped without a gyro);
//! 7. [`tune`]: the wheel-loop self-tune, on the ground;
//! 8. [`calibration`]: the UMBmark odometry calibration.
//!
//! Where it stands is kept in the output directory ([`state`]): run again, it resumes
//! with the first step not yet done.

pub mod answers;
pub mod button;
pub mod calibration;
pub mod diff;
pub mod encoders;
pub mod gyro;
pub mod link_check;
pub mod motors;
pub mod signals;
pub mod state;
pub mod supply;
pub mod tune;

use std::fmt;
use std::io::Write;
use std::path::PathBuf;

use clap::{Args, ValueEnum};
use link::ParamSet;
use serde::{Deserialize, Serialize};

use crate::client::{Client, StationError};
use crate::transport::Transport;

use self::answers::Answers;
use self::state::State;

/// A step of the bring-up, in the order they are done.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize, ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Step {
    /// The link, info, chip, clock, brown-out level, reset cause, panic record.
    Link,
    /// The button and the LED.
    Button,
    /// The supply reading against a multimeter.
    Supply,
    /// The encoders, each wheel turned by hand.
    Encoders,
    /// The motors, pulsed with the wheels lifted.
    Motors,
    /// The gyro's axis sign and scale, the robot turned one turn by hand.
    Gyro,
    /// The wheel-loop self-tune, on the ground.
    Tune,
    /// The odometry calibration.
    Calibrate,
}

impl Step {
    /// Every step, in order.
    pub const ALL: [Step; 8] = [
        Step::Link,
        Step::Button,
        Step::Supply,
        Step::Encoders,
        Step::Motors,
        Step::Gyro,
        Step::Tune,
        Step::Calibrate,
    ];

    /// The step's number, 1…8.
    pub fn number(self) -> usize {
        Self::ALL.iter().position(|s| *s == self).unwrap_or(0) + 1
    }
}

impl fmt::Display for Step {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Step::Link => "link",
            Step::Button => "button",
            Step::Supply => "supply",
            Step::Encoders => "encoders",
            Step::Motors => "motors",
            Step::Gyro => "gyro",
            Step::Tune => "tune",
            Step::Calibrate => "calibrate",
        })
    }
}

/// Why a bring-up stopped.
#[derive(Debug, thiserror::Error)]
pub enum BringupError {
    /// The link failed or the robot refused.
    #[error(transparent)]
    Link(#[from] StationError),
    /// Writing to the terminal or the output directory failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// An answer is missing or does not answer its question.
    #[error("answers: {0}")]
    Answers(String),
    /// A signal the step needs did not come.
    #[error("{0}")]
    Silent(String),
    /// The step found something it cannot correct with a parameter: the text says what
    /// to check.
    #[error("{0}")]
    Found(String),
}

/// `station bringup`'s arguments.
#[derive(Args, Debug)]
pub struct BringupArgs {
    /// The steps to run (default: every step not yet done, in order).
    #[arg(value_enum)]
    pub steps: Vec<Step>,
    /// Read what you would type (a multimeter reading, `done`, `yes`) from this file, a
    /// line per question, instead of the terminal.
    #[arg(long)]
    pub answers: Option<PathBuf>,
    /// Send and persist what a step learned without asking.
    #[arg(long)]
    pub yes: bool,
    /// Directory of the bring-up's state (`bringup-state.json`), from which it resumes.
    #[arg(long, default_value = "out/bringup")]
    pub out: PathBuf,
    /// Forget the steps done before and start again.
    #[arg(long)]
    pub restart: bool,
}

/// What a step found, and the configuration it learned if any.
pub struct Finding {
    /// One line for the user and the state file.
    pub summary: String,
    /// The robot's configuration with what the step learned (`None`: nothing to change).
    pub learned: Option<ParamSet>,
}

impl Finding {
    /// A finding with nothing to change.
    pub fn only(summary: impl Into<String>) -> Self {
        Self {
            summary: summary.into(),
            learned: None,
        }
    }
}

/// What every step works with.
pub struct Session<'a, T: Transport> {
    /// The robot.
    pub client: &'a mut Client<T>,
    /// What the user types.
    pub answers: &'a mut Answers,
    /// The terminal.
    pub out: &'a mut dyn Write,
}

/// Runs the bring-up `args` asks for against `client`, printing to `out`.
pub fn run<T: Transport>(
    client: &mut Client<T>,
    args: &BringupArgs,
    out: &mut dyn Write,
) -> Result<(), BringupError> {
    let mut answers = match &args.answers {
        Some(path) => Answers::file(path)?,
        None => Answers::terminal(),
    };
    let mut state = if args.restart {
        State::default()
    } else {
        State::load(&args.out)?
    };
    let steps: Vec<Step> = if args.steps.is_empty() {
        Step::ALL.into_iter().filter(|s| !state.has(*s)).collect()
    } else {
        args.steps.clone()
    };
    if steps.is_empty() {
        writeln!(
            out,
            "every step is done (see {}; --restart to begin again)",
            args.out.join(state::STATE_FILE).display()
        )?;
        return Ok(());
    }
    crate::record::set_telemetry_rate(client, 50)?;
    let mut session = Session {
        client,
        answers: &mut answers,
        out,
    };
    for step in steps {
        writeln!(
            session.out,
            "step {} of {}, {step}:",
            step.number(),
            Step::ALL.len()
        )?;
        let finding = match step {
            Step::Link => link_check::run(&mut session)?,
            Step::Button => button::run(&mut session)?,
            Step::Supply => supply::run(&mut session)?,
            Step::Encoders => encoders::run(&mut session)?,
            Step::Motors => motors::run(&mut session)?,
            Step::Gyro => gyro::run(&mut session)?,
            Step::Tune => tune::run(&mut session)?,
            Step::Calibrate => calibration::run(&mut session)?,
        };
        writeln!(session.out, "  {}", finding.summary)?;
        if let Some(learned) = finding.learned {
            if !apply(&mut session, &learned, args.yes)? {
                writeln!(
                    session.out,
                    "  not sent: step {step} stays to do (`station bringup {step}`)"
                )?;
                state.save(&args.out)?;
                return Ok(());
            }
        }
        state.record(step, finding.summary);
        state.save(&args.out)?;
    }
    crate::record::set_telemetry_rate(session.client, 1)?;
    writeln!(session.out, "bring-up: {} step(s) done", state.done.len())?;
    Ok(())
}

/// Shows what changes from the robot's configuration to `learned` as a robot-file diff;
/// once confirmed (or with `yes`), sends and persists it. False when declined.
fn apply<T: Transport>(
    session: &mut Session<'_, T>,
    learned: &ParamSet,
    yes: bool,
) -> Result<bool, BringupError> {
    let current = crate::ops::get_params(session.client)?;
    let diff = diff::robot_file_diff(&current, learned);
    if diff.is_empty() {
        writeln!(session.out, "  the robot's parameters already say so")?;
        return Ok(true);
    }
    write!(session.out, "{diff}")?;
    let confirmed = yes
        || session
            .answers
            .yes_no(session.out, "send these to the robot and persist them?")?;
    if !confirmed {
        return Ok(false);
    }
    crate::ops::set_params(session.client, *learned)?;
    crate::ops::persist_params(session.client)?;
    writeln!(session.out, "  sent and persisted")?;
    Ok(true)
}
