//! The operator's hands at the virtual robot, for tests only: turning a wheel by hand,
//! pressing the button, looking at the LED, turning the whole robot on the spot and
//! measuring where the robot stands with a tape, so that what a guided bring-up finds
//! comes from the robot's own signals, as on a real robot. A test holds the
//! [`HandsRemote`]; `host-sim serve --hands` reads the same commands from its standard
//! input, one a line (`turn left 1`, `rotate 1`, `press 2000`, `led`, `measure`), and
//! answers each on its standard output with a line that starts `hands: `.
//!
//! A wheel turned by hand turns the plant's encoder, not the plant: the robot stands
//! lifted while its wheels are turned, and its pose is not the simulator's truth. A robot
//! rotated by hand on the floor turns the plant's heading (what its gyro reads) about the
//! middle of its axle, and its wheels roll: each encoder counts its wheel's share of the
//! turn, on the true track width and wheel radii, without slip.

use std::collections::VecDeque;
use std::f64::consts::TAU;
use std::fmt;
use std::sync::mpsc::{channel, Receiver, Sender};

use controller_core::controller::TickDeltas;
use controller_core::supervisor::Wheel;
use robot_files::truth::TruePose;

/// How fast a hand turns a wheel, turns per second.
pub const HAND_TURNS_PER_S: f64 = 2.0;
/// How fast hands rotate the robot on the spot, turns per second on average: the rate
/// rises and falls as a raised cosine (a smooth start and stop, as a hand's).
pub const HAND_ROBOT_TURNS_PER_S: f64 = 0.5;
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
    /// Rotate the robot on the spot by `turns`, counter-clockwise seen from above
    /// positive, at [`HAND_ROBOT_TURNS_PER_S`].
    Rotate {
        /// Turns of the robot, counter-clockwise positive.
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
    /// The robot was rotated.
    Rotated {
        /// Turns of the robot, counter-clockwise positive.
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
            HandAnswer::Rotated { turns } => write!(f, "hands: rotated {turns}"),
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

    /// `turn left|right TURNS`, `rotate TURNS`, `press MS`, `led` or `measure`.
    fn from_str(line: &str) -> Result<Self, Self::Err> {
        let words: Vec<&str> = line.split_whitespace().collect();
        let bad = || {
            format!(
                "hands: cannot read {line:?} (turn left|right TURNS, rotate TURNS, press MS, \
                 led, measure)"
            )
        };
        let count = |word: &str| match word.parse::<f64>() {
            Ok(t) if t.is_finite() && t.abs() <= 100.0 => Ok(t),
            _ => Err(bad()),
        };
        match words.as_slice() {
            ["turn", side, n] => {
                let wheel = match *side {
                    "left" => Wheel::Left,
                    "right" => Wheel::Right,
                    _ => return Err(bad()),
                };
                Ok(HandCommand::Turn {
                    wheel,
                    turns: count(n)?,
                })
            }
            ["rotate", n] => Ok(HandCommand::Rotate { turns: count(n)? }),
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

/// What the hands need to know of the robot for a control step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bench {
    /// Control rate, Hz.
    pub rate_hz: f64,
    /// Encoder counts per wheel turn, as the plant's encoders count them.
    pub ticks_per_turn: f64,
    /// Wheel turns [left, right] per turn of the robot on the spot: half the true track
    /// width over each wheel's true radius.
    pub wheel_turns_per_robot_turn: [f64; 2],
}

/// What the hands did in one control step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HandStep {
    /// Ticks each wheel's encoder counted from the hands, forward positive.
    pub ticks: TickDeltas,
    /// The button is held.
    pub pressed: bool,
    /// The robot's turn on the spot in this step, counter-clockwise positive, rad.
    pub yaw_rad: f64,
}

/// What is being moved by hand.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Moved {
    /// One wheel, the robot lifted.
    Wheel(Wheel),
    /// The whole robot, on the spot.
    Robot,
}

/// A motion in progress over `steps` control steps, `done` of them taken: `ticks` whole
/// encoder counts [left, right] and `turns` of the wheel or the robot in all.
#[derive(Clone, Copy, Debug)]
struct Motion {
    moved: Moved,
    turns: f64,
    ticks: [i64; 2],
    steps: i64,
    done: i64,
}

impl Motion {
    fn new(moved: Moved, turns: f64, bench: &Bench) -> Self {
        let (turns_per_s, wheel_turns) = match moved {
            Moved::Wheel(Wheel::Left) => (HAND_TURNS_PER_S, [turns, 0.0]),
            Moved::Wheel(Wheel::Right) => (HAND_TURNS_PER_S, [0.0, turns]),
            // Counter-clockwise, the right wheel rolls forward and the left back.
            Moved::Robot => {
                let [l, r] = bench.wheel_turns_per_robot_turn;
                (HAND_ROBOT_TURNS_PER_S, [-turns * l, turns * r])
            }
        };
        let steps = (turns.abs() / turns_per_s * bench.rate_hz).round().max(1.0);
        Self {
            moved,
            turns,
            ticks: wheel_turns.map(|t| (t * bench.ticks_per_turn).round() as i64),
            steps: steps as i64,
            done: 0,
        }
    }

    /// The fraction of the motion done after `k` of its steps: even for a wheel, a raised
    /// cosine for the robot (no rate at either end); exactly 1 at the end.
    fn progress(&self, k: i64) -> f64 {
        if k >= self.steps {
            return 1.0;
        }
        let x = k as f64 / self.steps as f64;
        match self.moved {
            Moved::Wheel(_) => x,
            Moved::Robot => x - (TAU * x).sin() / TAU,
        }
    }

    /// The next step's whole ticks and turn (turns of what is moved): no count lost to
    /// rounding over the motion.
    fn next(&mut self) -> (TickDeltas, f64) {
        let (before, after) = (self.progress(self.done), self.progress(self.done + 1));
        let whole = |total: i64, p: f64| {
            if p >= 1.0 {
                total
            } else {
                (total as f64 * p).floor() as i64
            }
        };
        let [l, r] = self
            .ticks
            .map(|t| (whole(t, after) - whole(t, before)) as i32);
        self.done += 1;
        (
            TickDeltas { left: l, right: r },
            self.turns * (after - before),
        )
    }

    fn finished(&self) -> bool {
        self.done >= self.steps
    }

    fn answer(&self) -> HandAnswer {
        match self.moved {
            Moved::Wheel(wheel) => HandAnswer::Turned {
                wheel,
                turns: self.turns,
            },
            Moved::Robot => HandAnswer::Rotated { turns: self.turns },
        }
    }
}

/// The hands, held by the virtual robot.
pub struct Hands {
    commands: Receiver<HandCommand>,
    answers: Sender<HandAnswer>,
    moving: Option<Motion>,
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
            moving: None,
            press_steps_left: 0,
            led: VecDeque::with_capacity(LED_WINDOW_STEPS),
        },
    )
}

impl Hands {
    /// One control step of the robot `bench` describes, standing at `pose` (world
    /// frame): takes new commands (one at a time: a motion or press in progress finishes
    /// first), and returns what the hands did in the step.
    pub fn step(&mut self, bench: &Bench, pose: &TruePose) -> HandStep {
        if self.moving.is_none() && self.press_steps_left == 0 {
            if let Ok(command) = self.commands.try_recv() {
                match command {
                    HandCommand::Turn { wheel, turns } => {
                        self.moving = Some(Motion::new(Moved::Wheel(wheel), turns, bench));
                    }
                    HandCommand::Rotate { turns } => {
                        self.moving = Some(Motion::new(Moved::Robot, turns, bench));
                    }
                    HandCommand::Press { ms } => {
                        self.press_steps_left =
                            ((f64::from(ms) * bench.rate_hz / 1000.0).round() as u32).max(1);
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
        let mut done = HandStep::default();
        if let Some(motion) = &mut self.moving {
            let (ticks, turns) = motion.next();
            done.ticks = ticks;
            if motion.moved == Moved::Robot {
                done.yaw_rad = TAU * turns;
            }
            if motion.finished() {
                let _ = self.answers.send(motion.answer());
                self.moving = None;
            }
        }
        done.pressed = self.press_steps_left > 0;
        if done.pressed {
            self.press_steps_left -= 1;
            if self.press_steps_left == 0 {
                let _ = self.answers.send(HandAnswer::Released);
            }
        }
        done
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

    /// A 1 kHz robot of 1440 counts a turn whose wheels turn 1.5 times (left) and 1.6
    /// times (right) per turn of the robot on the spot.
    const BENCH: Bench = Bench {
        rate_hz: 1000.0,
        ticks_per_turn: 1440.0,
        wheel_turns_per_robot_turn: [1.5, 1.6],
    };

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
            let done = hands.step(&BENCH, &TruePose::default());
            assert_eq!(done.ticks.left, 0);
            assert!(!done.pressed);
            assert_eq!(done.yaw_rad, 0.0, "lifted: the robot does not turn");
            total += done.ticks.right;
            steps += 1;
            assert!(steps < 10_000);
        }
        assert_eq!(total, -1440);
        assert_eq!(steps, 500);
    }

    #[test]
    fn a_rotation_on_the_spot_rolls_both_wheels_and_turns_smoothly() {
        let (remote, mut hands) = hands();
        remote
            .commands
            .send(HandCommand::Rotate { turns: 1.0 })
            .expect("open");
        let (mut left, mut right, mut yaw) = (0, 0, 0.0);
        let mut rates = Vec::new();
        while remote.answers.try_recv().is_err() {
            let done = hands.step(&BENCH, &TruePose::default());
            left += done.ticks.left;
            right += done.ticks.right;
            yaw += done.yaw_rad;
            rates.push(done.yaw_rad * BENCH.rate_hz);
            assert!(rates.len() < 10_000);
        }
        // Counter-clockwise: the left wheel back 1.5 turns, the right forward 1.6.
        assert_eq!((left, right), (-2160, 2304));
        assert!((yaw - TAU).abs() < 1e-12, "{yaw}");
        assert_eq!(rates.len(), 2000, "one turn at 0.5 turns per second");
        // Still at both ends, fastest (twice the mean) half-way.
        let peak = rates.iter().copied().fold(0.0, f64::max);
        assert!(
            rates[0] < 0.01 && rates[1999] < 0.01,
            "{} {}",
            rates[0],
            rates[1999]
        );
        assert!(
            (peak - 2.0 * TAU * HAND_ROBOT_TURNS_PER_S).abs() < 1e-3,
            "{peak}"
        );
        assert!((rates[1000] - peak).abs() < 1e-3);
    }

    #[test]
    fn a_press_holds_the_button_for_its_time() {
        let (remote, mut hands) = hands();
        remote
            .commands
            .send(HandCommand::Press { ms: 30 })
            .expect("open");
        let held = (0..100)
            .filter(|_| hands.step(&BENCH, &TruePose::default()).pressed)
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
        let _ = hands.step(&BENCH, &at);
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
        assert_eq!(
            "rotate -0.5".parse(),
            Ok(HandCommand::Rotate { turns: -0.5 })
        );
        assert_eq!("press 2000".parse(), Ok(HandCommand::Press { ms: 2000 }));
        assert_eq!("led".parse(), Ok(HandCommand::ReadLed));
        assert_eq!("measure".parse(), Ok(HandCommand::MeasurePose));
        assert!("turn up 1".parse::<HandCommand>().is_err());
        assert!("wave".parse::<HandCommand>().is_err());
        assert!("rotate 1e9".parse::<HandCommand>().is_err());
    }
}
