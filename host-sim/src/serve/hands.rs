//! The operator's hands at the virtual robot, for tests only: turning a wheel by hand,
//! pressing the button, looking at the LED and measuring where the robot stands with a
//! tape, so that what a guided bring-up finds comes from the robot's own signals, as on a
//! real robot. A test holds the [`HandsRemote`]; `host-sim serve --hands` reads the same
//! commands from its standard input, one a line (`turn left 1`, `press 2000`, `led`,
//! `measure`), and answers each on its standard output with a line that starts `hands: `.
//!
//! A wheel turned by hand turns the plant's encoder, not the plant: the robot stands
//! lifted while its wheels are turned, and its pose is not the simulator's truth.

use std::collections::VecDeque;
use std::fmt;
use std::sync::mpsc::{channel, Receiver, Sender};

use controller_core::controller::TickDeltas;
use controller_core::supervisor::Wheel;
use robot_files::truth::TruePose;

/// How fast a hand turns a wheel, turns per second.
pub const HAND_TURNS_PER_S: f64 = 2.0;
/// Control steps the LED is watched over for [`HandAnswer::Led`].
pub const LED_WINDOW_STEPS: usize = 1000;

/// What the hands are asked to do.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HandCommand {
    /// Turn `wheel` by `turns` (forward positive) at [`HAND_TURNS_PER_S`].
    Turn {
        /// The wheel.
        wheel: Wheel,
        /// Turns, forward positive.
        turns: f64,
    },
    /// Hold the button down for `ms` of the robot's time.
    Press {
        /// How long, ms.
        ms: u32,
    },
    /// Look at the LED.
    ReadLed,
    /// Measure the robot's pose on the floor (the plant's true pose, world frame).
    MeasurePose,
}

/// What the hands did, once done.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HandAnswer {
    /// The wheel was turned.
    Turned {
        /// The wheel.
        wheel: Wheel,
        /// Turns, forward positive.
        turns: f64,
    },
    /// The button was released after its press.
    Released,
    /// The LED was on for `on_steps` of the last `of_steps` control steps.
    Led {
        /// Steps lit.
        on_steps: u32,
        /// Steps watched.
        of_steps: u32,
    },
    /// Where the robot stands on the floor.
    Pose(TruePose),
}

impl fmt::Display for HandAnswer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HandAnswer::Turned { wheel, turns } => {
                write!(f, "hands: turned {} {turns}", wheel_word(*wheel))
            }
            HandAnswer::Released => f.write_str("hands: released"),
            HandAnswer::Led { on_steps, of_steps } => {
                write!(f, "hands: led on {on_steps} of {of_steps} steps")
            }
            HandAnswer::Pose(p) => write!(
                f,
                "hands: pose x {:.4} m, y {:.4} m, heading {:.3} deg",
                p.x_m,
                p.y_m,
                p.theta_rad.to_degrees()
            ),
        }
    }
}

fn wheel_word(wheel: Wheel) -> &'static str {
    match wheel {
        Wheel::Left => "left",
        Wheel::Right => "right",
    }
}

impl std::str::FromStr for HandCommand {
    type Err = String;

    /// `turn left|right TURNS`, `press MS`, `led` or `measure`.
    fn from_str(line: &str) -> Result<Self, Self::Err> {
        let words: Vec<&str> = line.split_whitespace().collect();
        let bad = || {
            format!("hands: cannot read {line:?} (turn left|right TURNS, press MS, led, measure)")
        };
        match words.as_slice() {
            ["turn", side, turns] => {
                let wheel = match *side {
                    "left" => Wheel::Left,
                    "right" => Wheel::Right,
                    _ => return Err(bad()),
                };
                let turns: f64 = turns.parse().map_err(|_| bad())?;
                if !turns.is_finite() || turns.abs() > 100.0 {
                    return Err(bad());
                }
                Ok(HandCommand::Turn { wheel, turns })
            }
            ["press", ms] => Ok(HandCommand::Press {
                ms: ms.parse().map_err(|_| bad())?,
            }),
            ["led"] => Ok(HandCommand::ReadLed),
            ["measure"] => Ok(HandCommand::MeasurePose),
            _ => Err(bad()),
        }
    }
}

/// The test's end: send commands, wait for answers.
pub struct HandsRemote {
    /// Commands to the hands.
    pub commands: Sender<HandCommand>,
    /// Their answers, in order.
    pub answers: Receiver<HandAnswer>,
}

/// A turn in progress: `total` ticks spread evenly over `steps` steps, `done` of them
/// taken.
#[derive(Clone, Copy, Debug)]
struct Turning {
    wheel: Wheel,
    turns: f64,
    total: i64,
    steps: i64,
    done: i64,
}

impl Turning {
    /// The ticks of the next step (whole ticks, none lost to rounding over the turn).
    fn next_ticks(&mut self) -> i32 {
        let at = |k: i64| (self.total * k).div_euclid(self.steps);
        let ticks = at(self.done + 1) - at(self.done);
        self.done += 1;
        ticks as i32
    }
}

/// The hands, held by the virtual robot.
pub struct Hands {
    commands: Receiver<HandCommand>,
    answers: Sender<HandAnswer>,
    turning: Option<Turning>,
    press_steps_left: u32,
    led: VecDeque<bool>,
}

/// A pair of hands and the remote that moves them.
pub fn hands() -> (HandsRemote, Hands) {
    let (commands, command_rx) = channel();
    let (answer_tx, answers) = channel();
    (
        HandsRemote { commands, answers },
        Hands {
            commands: command_rx,
            answers: answer_tx,
            turning: None,
            press_steps_left: 0,
            led: VecDeque::with_capacity(LED_WINDOW_STEPS),
        },
    )
}

impl Hands {
    /// One control step at `rate_hz` of an encoder of `ticks_per_turn`, the robot standing
    /// at `pose` (world frame): takes new commands (one at a time: a turn or press in
    /// progress finishes first), and returns the ticks the hand turned each wheel by in
    /// this step and whether the button is held.
    pub fn step(
        &mut self,
        rate_hz: f64,
        ticks_per_turn: f64,
        pose: &TruePose,
    ) -> (TickDeltas, bool) {
        if self.turning.is_none() && self.press_steps_left == 0 {
            if let Ok(command) = self.commands.try_recv() {
                match command {
                    HandCommand::Turn { wheel, turns } => {
                        let steps = (turns.abs() / HAND_TURNS_PER_S * rate_hz).round().max(1.0);
                        self.turning = Some(Turning {
                            wheel,
                            turns,
                            total: (turns * ticks_per_turn).round() as i64,
                            steps: steps as i64,
                            done: 0,
                        });
                    }
                    HandCommand::Press { ms } => {
                        self.press_steps_left =
                            ((f64::from(ms) * rate_hz / 1000.0).round() as u32).max(1);
                    }
                    HandCommand::ReadLed => {
                        let on = self.led.iter().filter(|&&on| on).count() as u32;
                        let _ = self.answers.send(HandAnswer::Led {
                            on_steps: on,
                            of_steps: self.led.len() as u32,
                        });
                    }
                    HandCommand::MeasurePose => {
                        let _ = self.answers.send(HandAnswer::Pose(*pose));
                    }
                }
            }
        }
        let mut ticks = TickDeltas::default();
        if let Some(t) = &mut self.turning {
            let whole = t.next_ticks();
            match t.wheel {
                Wheel::Left => ticks.left = whole,
                Wheel::Right => ticks.right = whole,
            }
            if t.done >= t.steps {
                let _ = self.answers.send(HandAnswer::Turned {
                    wheel: t.wheel,
                    turns: t.turns,
                });
                self.turning = None;
            }
        }
        let pressed = self.press_steps_left > 0;
        if pressed {
            self.press_steps_left -= 1;
            if self.press_steps_left == 0 {
                let _ = self.answers.send(HandAnswer::Released);
            }
        }
        (ticks, pressed)
    }

    /// The LED's level after a step.
    pub fn see_led(&mut self, on: bool) {
        if self.led.len() == LED_WINDOW_STEPS {
            self.led.pop_front();
        }
        self.led.push_back(on);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_turn_gives_its_ticks_over_half_a_second_and_answers() {
        let (remote, mut hands) = hands();
        remote
            .commands
            .send(HandCommand::Turn {
                wheel: Wheel::Right,
                turns: -1.0,
            })
            .expect("open");
        let mut total = 0;
        let mut steps = 0;
        while remote.answers.try_recv().is_err() {
            let (ticks, pressed) = hands.step(1000.0, 1440.0, &TruePose::default());
            assert_eq!(ticks.left, 0);
            assert!(!pressed);
            total += ticks.right;
            steps += 1;
            assert!(steps < 10_000);
        }
        assert_eq!(total, -1440);
        assert_eq!(steps, 500);
    }

    #[test]
    fn a_press_holds_the_button_for_its_time() {
        let (remote, mut hands) = hands();
        remote
            .commands
            .send(HandCommand::Press { ms: 30 })
            .expect("open");
        let held = (0..100)
            .filter(|_| hands.step(1000.0, 1440.0, &TruePose::default()).1)
            .count();
        assert_eq!(held, 30);
        assert_eq!(remote.answers.try_recv(), Ok(HandAnswer::Released));
    }

    #[test]
    fn a_tape_measures_where_the_robot_stands() {
        let (remote, mut hands) = hands();
        remote
            .commands
            .send(HandCommand::MeasurePose)
            .expect("open");
        let at = TruePose {
            x_m: 1.25,
            y_m: -0.5,
            theta_rad: 0.1,
        };
        let _ = hands.step(1000.0, 1440.0, &at);
        assert_eq!(remote.answers.try_recv(), Ok(HandAnswer::Pose(at)));
    }

    #[test]
    fn commands_read_from_lines() {
        assert_eq!(
            "turn left 1".parse::<HandCommand>(),
            Ok(HandCommand::Turn {
                wheel: Wheel::Left,
                turns: 1.0
            })
        );
        assert_eq!("press 2000".parse(), Ok(HandCommand::Press { ms: 2000 }));
        assert_eq!("led".parse(), Ok(HandCommand::ReadLed));
        assert_eq!("measure".parse(), Ok(HandCommand::MeasurePose));
        assert!("turn up 1".parse::<HandCommand>().is_err());
        assert!("wave".parse::<HandCommand>().is_err());
    }
}
