//! H-bridge input states for the two supported drivers, and the order of transitions
//! that keeps every intermediate state safe.
//!
//! Both drivers run in **slow decay**: during the PWM off-time the motor's terminals are
//! shorted through the low-side switches (short brake), so the current decays slowly and
//! the speed follows the duty almost linearly. Duty 0 with the driver enabled is a short
//! brake; a disabled driver (TB6612FNG STBY low, DRV8833 nSLEEP low) leaves the motors
//! coasting.
//!
//! | command | TB6612FNG IN1 / IN2 / PWM | DRV8833 IN1 / IN2 (compare of max) |
//! |---|---|---|
//! | forward, duty d | H / L / d | 100 % / (1 − d) |
//! | reverse, duty d | L / H / d | (1 − d) / 100 % |
//! | brake (duty 0) | H / H / 0 | 100 % / 100 % |
//! | coast (driver disabled) | L / L / 0 | 0 / 0 |
//!
//! TB6612FNG datasheet, H-SW control function: IN1 = IN2 = H is short brake whatever
//! PWM is; with IN1 ≠ IN2, PWM low is short brake and PWM high drives. DRV8833 datasheet
//! (SLVSAR1), PWM control of motor speed: "1, PWM: forward, slow decay" and "PWM, 1:
//! reverse, slow decay"; with xIN1 = 1 the bridge drives forward while xIN2 is low and
//! brakes while it is high, so the drive fraction is the time IN2 is *low*.
//!
//! Neither chip can short its supply through any input pattern: both switch each
//! half-bridge with internal dead time (the TB6612FNG's datasheet gives its switching
//! characteristics with a built-in dead time; the DRV8833 inserts dead time and
//! shoot-through protection internally). What the order here prevents is a *wrong drive*
//! for up to one PWM period: the timer's compare registers are preloaded (a new compare
//! takes effect at the next update event, up to one PWM period later) while the
//! TB6612FNG's direction pins act at once. [`DriveSequencer`] therefore
//!
//! - changes direction only through one step of brake (the compare of the brake step is
//!   0, or 100 % on both DRV8833 inputs, and is latched before the next step, one control
//!   period ≥ one PWM period later), so the direction pins never flip under a latched
//!   non-zero compare;
//! - never changes both DRV8833 inputs of a motor in one step while the driver is
//!   enabled, so no mix of an old and a new compare can be latched;
//! - arms in two steps: inputs to brake with the driver still disabled, then the enable
//!   line, so the driver wakes into a latched brake.

/// The motor bridge on the board, for what its supply may be (the protocol's, since the
/// robot reports it).
pub use link::BridgeChip;

/// Direction of a driven motor, seen from the bridge (after any wiring inversion).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// OUT1 high, OUT2 low.
    Forward,
    /// OUT1 low, OUT2 high.
    Reverse,
}

/// What one bridge channel does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BridgeCommand {
    /// Both outputs off (high impedance): only used with the driver disabled.
    Coast,
    /// Both low-side switches on: short brake.
    Brake,
    /// Drive with this on-time, in timer compare counts (1…max).
    Drive {
        /// Which way.
        direction: Direction,
        /// On-time, timer compare counts.
        compare: u16,
    },
}

/// The command for a signed duty (−1…1 of the supply, positive forward) on a PWM whose
/// full period is `max_compare` counts: the magnitude rounded to counts and clamped, NaN
/// taken as 0, and 0 counts is [`BridgeCommand::Brake`].
pub fn command_for(duty: f32, max_compare: u16) -> BridgeCommand {
    let magnitude = if duty.is_nan() { 0.0 } else { duty.abs() };
    let compare = if magnitude >= 1.0 {
        max_compare
    } else {
        // `as` saturates; the product is below max + 0.5 here.
        (magnitude * f32::from(max_compare) + 0.5) as u16
    };
    if compare == 0 {
        BridgeCommand::Brake
    } else if duty > 0.0 {
        BridgeCommand::Drive {
            direction: Direction::Forward,
            compare,
        }
    } else {
        BridgeCommand::Drive {
            direction: Direction::Reverse,
            compare,
        }
    }
}

/// The input pins of one TB6612FNG channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tb6612Inputs {
    /// xIN1 level.
    pub in1: bool,
    /// xIN2 level.
    pub in2: bool,
    /// PWMx compare, counts (0 = always low).
    pub pwm_compare: u16,
}

/// The TB6612FNG inputs for `command` (table in the module doc).
pub const fn tb6612_inputs(command: BridgeCommand) -> Tb6612Inputs {
    match command {
        BridgeCommand::Coast => Tb6612Inputs {
            in1: false,
            in2: false,
            pwm_compare: 0,
        },
        BridgeCommand::Brake => Tb6612Inputs {
            in1: true,
            in2: true,
            pwm_compare: 0,
        },
        BridgeCommand::Drive {
            direction: Direction::Forward,
            compare,
        } => Tb6612Inputs {
            in1: true,
            in2: false,
            pwm_compare: compare,
        },
        BridgeCommand::Drive {
            direction: Direction::Reverse,
            compare,
        } => Tb6612Inputs {
            in1: false,
            in2: true,
            pwm_compare: compare,
        },
    }
}

/// The compares of one DRV8833 channel's two PWM inputs, counts of a `max` period
/// (`max` = always high in PWM mode 1, 0 = always low).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Drv8833Inputs {
    /// xIN1 compare.
    pub in1: u16,
    /// xIN2 compare.
    pub in2: u16,
}

impl Drv8833Inputs {
    /// Whether IN2 must be written before IN1 when going from `self` to `next`: the input
    /// that rises (towards brake, 100 %) goes first, so a write latched alone moves
    /// towards brake, never towards drive.
    pub const fn in2_first(self, next: Drv8833Inputs) -> bool {
        next.in2 > self.in2
    }
}

/// The DRV8833 inputs for `command` in slow decay (table in the module doc), `max` the
/// PWM period in counts. A drive compare above `max` is taken as `max`.
pub const fn drv8833_inputs(command: BridgeCommand, max: u16) -> Drv8833Inputs {
    match command {
        BridgeCommand::Coast => Drv8833Inputs { in1: 0, in2: 0 },
        BridgeCommand::Brake => Drv8833Inputs { in1: max, in2: max },
        BridgeCommand::Drive {
            direction: Direction::Forward,
            compare,
        } => Drv8833Inputs {
            in1: max,
            in2: max.saturating_sub(compare),
        },
        BridgeCommand::Drive {
            direction: Direction::Reverse,
            compare,
        } => Drv8833Inputs {
            in1: max.saturating_sub(compare),
            in2: max,
        },
    }
}

/// What both bridge channels and the shared enable line get in one step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DriveOutput {
    /// Level of the enable line (TB6612FNG STBY, DRV8833 nSLEEP).
    pub enable: bool,
    /// Left channel.
    pub left: BridgeCommand,
    /// Right channel.
    pub right: BridgeCommand,
}

impl DriveOutput {
    /// Disabled, both channels coasting: the state after reset.
    pub const OFF: DriveOutput = DriveOutput {
        enable: false,
        left: BridgeCommand::Coast,
        right: BridgeCommand::Coast,
    };
}

/// Orders the bridge's transitions (see the module doc). Call [`DriveSequencer::next`]
/// once per control step; consecutive calls must be at least one PWM period apart, so
/// that each step's compares are latched before the next step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DriveSequencer {
    last: DriveOutput,
}

impl Default for DriveSequencer {
    fn default() -> Self {
        Self::new()
    }
}

impl DriveSequencer {
    /// A sequencer whose bridge is disabled and coasting.
    pub const fn new() -> Self {
        Self {
            last: DriveOutput::OFF,
        }
    }

    /// The last output.
    pub const fn last(&self) -> DriveOutput {
        self.last
    }

    /// The output for this step, given whether the driver should be enabled and what each
    /// channel is asked to do. Disabling is immediate (enable low, coast). Enabling takes
    /// one step of brake with the enable line still low. A direction change takes one
    /// step of brake. A coast request while enabled brakes instead.
    pub fn next(
        &mut self,
        enabled: bool,
        left: BridgeCommand,
        right: BridgeCommand,
    ) -> DriveOutput {
        let out = if !enabled {
            DriveOutput::OFF
        } else if !self.last.enable {
            let braked =
                self.last.left == BridgeCommand::Brake && self.last.right == BridgeCommand::Brake;
            if braked {
                DriveOutput {
                    enable: true,
                    left: guarded(BridgeCommand::Brake, left),
                    right: guarded(BridgeCommand::Brake, right),
                }
            } else {
                DriveOutput {
                    enable: false,
                    left: BridgeCommand::Brake,
                    right: BridgeCommand::Brake,
                }
            }
        } else {
            DriveOutput {
                enable: true,
                left: guarded(self.last.left, left),
                right: guarded(self.last.right, right),
            }
        };
        self.last = out;
        out
    }
}

/// `want` for an enabled channel whose previous command was `last`: coast becomes brake,
/// and a drive in the other direction than the previous drive becomes brake.
const fn guarded(last: BridgeCommand, want: BridgeCommand) -> BridgeCommand {
    match (last, want) {
        (_, BridgeCommand::Coast) => BridgeCommand::Brake,
        (
            BridgeCommand::Drive {
                direction: from, ..
            },
            BridgeCommand::Drive { direction: to, .. },
        ) if !same_direction(from, to) => BridgeCommand::Brake,
        (BridgeCommand::Coast, BridgeCommand::Drive { .. }) => BridgeCommand::Brake,
        _ => want,
    }
}

const fn same_direction(a: Direction, b: Direction) -> bool {
    matches!(
        (a, b),
        (Direction::Forward, Direction::Forward) | (Direction::Reverse, Direction::Reverse)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_bridge_is_held_to_its_own_supply_rating() {
        assert_eq!(BridgeChip::Tb6612fng.max_supply_v(), 13.5);
        assert_eq!(BridgeChip::Drv8833.max_supply_v(), 10.8);
    }
    use BridgeCommand::{Brake, Coast};

    const MAX: u16 = 5000;

    fn fwd(compare: u16) -> BridgeCommand {
        BridgeCommand::Drive {
            direction: Direction::Forward,
            compare,
        }
    }
    fn rev(compare: u16) -> BridgeCommand {
        BridgeCommand::Drive {
            direction: Direction::Reverse,
            compare,
        }
    }

    #[test]
    fn duty_to_command() {
        assert_eq!(command_for(0.5, MAX), fwd(2500));
        assert_eq!(command_for(-0.25, MAX), rev(1250));
        assert_eq!(command_for(1.7, MAX), fwd(MAX));
        assert_eq!(command_for(-1.0, MAX), rev(MAX));
        assert_eq!(command_for(0.0, MAX), Brake);
        assert_eq!(command_for(-0.0, MAX), Brake);
        assert_eq!(command_for(0.00005, MAX), Brake); // rounds to 0 counts
        assert_eq!(command_for(f32::NAN, MAX), Brake);
        assert_eq!(command_for(f32::NEG_INFINITY, MAX), rev(MAX));
    }

    #[test]
    fn tb6612_truth_table() {
        let t = |c| {
            let i = tb6612_inputs(c);
            (i.in1, i.in2, i.pwm_compare)
        };
        assert_eq!(t(fwd(100)), (true, false, 100));
        assert_eq!(t(rev(100)), (false, true, 100));
        assert_eq!(t(Brake), (true, true, 0)); // short brake, PWM irrelevant
        assert_eq!(t(Coast), (false, false, 0));
    }

    #[test]
    fn drv8833_slow_decay_table() {
        let d = |c| {
            let i = drv8833_inputs(c, MAX);
            (i.in1, i.in2)
        };
        // Forward 30 %: IN1 always high, IN2 high (brake) 70 % of the period.
        assert_eq!(d(fwd(1500)), (MAX, 3500));
        assert_eq!(d(rev(1500)), (3500, MAX));
        assert_eq!(d(fwd(MAX)), (MAX, 0)); // full forward: IN2 never high
        assert_eq!(d(Brake), (MAX, MAX));
        assert_eq!(d(Coast), (0, 0));
        assert_eq!(d(fwd(MAX + 7)), (MAX, 0));
        // The rising input is written first.
        let from = drv8833_inputs(fwd(1500), MAX);
        assert!(from.in2_first(drv8833_inputs(Brake, MAX)));
        assert!(!drv8833_inputs(Brake, MAX).in2_first(drv8833_inputs(rev(10), MAX)));
    }

    #[test]
    fn arming_takes_one_brake_step_with_the_driver_disabled() {
        let mut s = DriveSequencer::new();
        let a = s.next(true, fwd(100), rev(200));
        assert_eq!(
            a,
            DriveOutput {
                enable: false,
                left: Brake,
                right: Brake
            }
        );
        let b = s.next(true, fwd(100), rev(200));
        assert_eq!(
            b,
            DriveOutput {
                enable: true,
                left: fwd(100),
                right: rev(200)
            }
        );
        // Disarming is immediate.
        assert_eq!(s.next(false, fwd(100), rev(200)), DriveOutput::OFF);
    }

    #[test]
    fn reversal_passes_through_one_brake_step() {
        let mut s = DriveSequencer::new();
        s.next(true, Brake, Brake);
        s.next(true, fwd(300), fwd(300));
        let out = s.next(true, rev(300), fwd(400));
        assert_eq!((out.left, out.right), (Brake, fwd(400)));
        let out = s.next(true, rev(300), fwd(400));
        assert_eq!((out.left, out.right), (rev(300), fwd(400)));
        // Coast while enabled brakes.
        assert_eq!(s.next(true, Coast, Coast).left, Brake);
    }

    /// Any request sequence: while enabled the direction never flips between consecutive
    /// outputs, each DRV8833 channel changes at most one input per step, and the driver
    /// is never enabled straight out of coast.
    #[test]
    fn no_unsafe_transition_for_any_request_sequence() {
        let requests = [Coast, Brake, fwd(1), fwd(2500), fwd(MAX), rev(1), rev(4000)];
        let mut seed = 0x9E37_79B9u32;
        let mut s = DriveSequencer::new();
        let mut prev = s.last();
        for _ in 0..20_000 {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            let pick = |shift: u32| requests[(seed >> shift) as usize % requests.len()];
            let enabled = (seed >> 24) % 8 != 0;
            let out = s.next(enabled, pick(0), pick(8));
            if out.enable {
                for (a, b) in [(prev.left, out.left), (prev.right, out.right)] {
                    if let (
                        BridgeCommand::Drive { direction: x, .. },
                        BridgeCommand::Drive { direction: y, .. },
                    ) = (a, b)
                    {
                        assert_eq!(x, y, "direction flipped without a brake step");
                    }
                    assert_ne!(b, Coast);
                    let (i, j) = (drv8833_inputs(a, MAX), drv8833_inputs(b, MAX));
                    assert!(i.in1 == j.in1 || i.in2 == j.in2, "{a:?} -> {b:?}");
                }
                if !prev.enable {
                    assert_eq!((prev.left, prev.right), (Brake, Brake));
                }
            } else {
                assert!(matches!(out.left, Coast | Brake) && matches!(out.right, Coast | Brake));
            }
            prev = out;
        }
    }
}
