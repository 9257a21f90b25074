//! `host-sim serve`: the virtual robot ([`crate::serve`]) — the robot's own application
//! logic against the simulated hardware, speaking the runtime link on a TCP port, with
//! ground truth. Says where it listens (and, with `--foxglove`, where its Foxglove stream
//! does: [`crate::serve::LiveStream`]), then prints every supervisor event as it comes,
//! until killed.

use std::fmt;
use std::net::TcpListener;

use anyhow::{Context, Result};

use super::{load, Failed, Report};
use crate::serve::{serve, LiveStream, ServeOptions, StepReport, VirtualRobot};

/// The fastest `--speed`: simulated time per wall-clock time.
pub const MAX_SPEED: f64 = 1000.0;

/// The rule on `--speed`: finite, in (0, [`MAX_SPEED`]].
pub fn check_speed(speed: f64) -> Result<(), Failed> {
    if speed.is_finite() && speed > 0.0 && speed <= MAX_SPEED {
        Ok(())
    } else {
        Err(Failed(format!("--speed must be in (0, 1000], got {speed}")))
    }
}

/// The line printed once the robot listens.
#[derive(Clone, Debug, PartialEq)]
pub struct Listening {
    /// The scenario's name.
    pub scenario: String,
    /// The address it listens on: the one asked for, with the port the system chose
    /// when port 0 was asked.
    pub listen: String,
    /// Simulated time per wall-clock time.
    pub speed: f64,
    /// The supervisor's heartbeat timeout, control steps.
    pub heartbeat_timeout_steps: u32,
    /// Where the Foxglove stream listens (`host:port`, the port the system chose for
    /// port 0) and its rate, Hz; `None` without `--foxglove`.
    pub foxglove: Option<(String, f64)>,
}

impl fmt::Display for Listening {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "virtual robot ({}) listening on {}, {}× real time; heartbeat timeout {} steps",
            self.scenario, self.listen, self.speed, self.heartbeat_timeout_steps
        )?;
        if let Some((address, hz)) = &self.foxglove {
            writeln!(
                f,
                "foxglove live on ws://{address} (subprotocol foxglove.sdk.v1), {hz} Hz of robot time"
            )?;
        }
        Ok(())
    }
}

/// The Foxglove stream `host-sim serve --foxglove` asks for.
#[derive(Clone, Debug, PartialEq)]
pub struct FoxgloveOptions {
    /// `HOST:PORT` to listen on (port 0: any free port, announced).
    pub address: String,
    /// Samples per second of robot time, Hz (1 to the control rate).
    pub hz: u32,
}

/// One supervisor event, as printed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EventLine {
    /// The step that changed the supervisor's state.
    pub report: StepReport,
    /// The control rate, Hz (for the time).
    pub rate_hz: f64,
}

impl fmt::Display for EventLine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.report;
        writeln!(
            f,
            "step {} (t {:.3} s): {:?}, {} steps since the last heartbeat",
            r.step,
            f64::from(r.step) / self.rate_hz,
            r.event.map_or_else(String::new, |e| format!("{e:?}")),
            r.steps_since_heartbeat
        )
    }
}

/// What is left when the virtual robot stops (its listener failed): nothing to print.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stopped;

impl fmt::Display for Stopped {
    fn fmt(&self, _: &mut fmt::Formatter<'_>) -> fmt::Result {
        Ok(())
    }
}

impl Report for Stopped {}

/// Listens on `listen`, announces it through `listening` (an error there stops the
/// command), then runs the virtual robot at `speed` × real time, giving every event to
/// `event` (which cannot stop it). Returns when the listener fails; otherwise runs until
/// killed.
pub fn run(
    scenario: &str,
    listen: &str,
    speed: f64,
    foxglove: Option<&FoxgloveOptions>,
    listening: &mut dyn FnMut(&Listening) -> std::io::Result<()>,
    event: &mut dyn FnMut(&EventLine),
) -> Result<Stopped> {
    check_speed(speed)?;
    let scenario = load(scenario)?;
    let listener = TcpListener::bind(listen).with_context(|| format!("listening on {listen}"))?;
    let mut channels = robot_app::Channels::new();
    let mut robot = VirtualRobot::new(&mut channels, &scenario)?;
    let rate = scenario.robot.control_rate_hz;
    let rate_hz = f64::from(rate);
    let mut live = match foxglove {
        Some(options) => {
            if options.hz == 0 || options.hz > rate {
                return Err(Failed(format!(
                    "--foxglove-hz must be in 1..={rate} (the control rate), got {}",
                    options.hz
                ))
                .into());
            }
            Some(LiveStream::start(
                &options.address,
                &robot,
                rate / options.hz,
            )?)
        }
        None => None,
    };
    let foxglove_line = match (&live, foxglove) {
        (Some(live), Some(options)) => {
            let host = options
                .address
                .rsplit_once(':')
                .map_or(options.address.as_str(), |(h, _)| h);
            let every = rate / options.hz;
            Some((
                format!("{host}:{}", live.port()),
                rate_hz / f64::from(every),
            ))
        }
        _ => None,
    };
    listening(&Listening {
        scenario: scenario.name.clone(),
        listen: listener
            .local_addr()
            .map_or_else(|_| listen.to_string(), |address| address.to_string()),
        speed,
        heartbeat_timeout_steps: scenario.supervisor.heartbeat_timeout_steps,
        foxglove: foxglove_line,
    })?;
    let mut log = |report: &StepReport| {
        event(&EventLine {
            report: *report,
            rate_hz,
        })
    };
    serve(
        &mut robot,
        &listener,
        ServeOptions {
            speed,
            max_steps: None,
        },
        &mut log,
        live.as_mut(),
    )?;
    Ok(Stopped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn port_zero_is_announced_as_the_port_the_system_chose() {
        let mut announced = None;
        let mut listening = |line: &Listening| {
            announced = Some(line.listen.clone());
            // Stops the command once it has said where it listens.
            Err(std::io::Error::other("enough"))
        };
        let result = run(
            "paper-circle",
            "127.0.0.1:0",
            1.0,
            None,
            &mut listening,
            &mut |_| {},
        );
        assert!(result.is_err());
        let address: std::net::SocketAddr = announced
            .expect("announced")
            .parse()
            .expect("a socket address");
        assert_eq!(address.ip().to_string(), "127.0.0.1");
        assert_ne!(address.port(), 0);
    }

    #[test]
    fn the_foxglove_rate_must_be_within_the_control_rate() {
        for hz in [0, 1001] {
            let options = FoxgloveOptions {
                address: "127.0.0.1:0".into(),
                hz,
            };
            let error = run(
                "paper-circle",
                "127.0.0.1:0",
                1.0,
                Some(&options),
                &mut |_| Ok(()),
                &mut |_| {},
            )
            .expect_err("refused before anything starts");
            assert!(error.to_string().contains("--foxglove-hz"), "{error}");
        }
    }

    #[test]
    fn the_speed_must_be_positive_finite_and_at_most_a_thousand() {
        assert_eq!(check_speed(1.0), Ok(()));
        assert_eq!(check_speed(MAX_SPEED), Ok(()));
        assert_eq!(
            check_speed(0.0),
            Err(Failed("--speed must be in (0, 1000], got 0".into()))
        );
        assert_eq!(
            check_speed(1000.5),
            Err(Failed("--speed must be in (0, 1000], got 1000.5".into()))
        );
        assert!(check_speed(f64::NAN).is_err());
        assert!(check_speed(f64::INFINITY).is_err());
    }
}
