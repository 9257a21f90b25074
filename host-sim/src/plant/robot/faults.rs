//! The fault hooks a fault timeline drives: a motor lead off, a jammed wheel, a slip
//! patch, supply sag.
//!
//! Contract: each hook takes effect from the next `Plant::advance` on and stays until
//! set again; a refused value (a slip ratio outside [0, 1), a supply that is not finite
//! and positive) changes nothing.
//!
//! - [`Plant::set_motor_connected`] — a motor lead off: that wheel coasts whatever the
//!   duty;
//! - [`Plant::set_wheel_blocked`] — the wheel jammed: its speed is set to 0 and held there
//!   by unlimited static friction until released (the robot pivots about it);
//! - [`Plant::set_slip`] — a slip patch: the wheel's longitudinal slip ratio from now on;
//! - [`Plant::set_supply_v`] — supply sag (or recovery): the bridge's supply from now on.

use robot_files::plant::Wheel;

use super::{Plant, PlantError};

impl Plant {
    /// Fault hook: connects or disconnects `wheel`'s motor leads. Disconnected, that motor
    /// carries no current and its wheel coasts whatever the duty and enable line.
    pub fn set_motor_connected(&mut self, wheel: Wheel, connected: bool) {
        self.connected[wheel.index()] = connected;
        self.update_bridge();
    }

    /// Whether each motor [left, right] is connected.
    pub fn motor_connected(&self) -> [bool; 2] {
        self.connected
    }

    /// Fault hook: jams `wheel` (`true`) or releases it (`false`). Jammed, the wheel's
    /// speed is set to 0 at once (the chassis' momentum through it is lost into the jam)
    /// and held at 0 by unlimited static friction; its contact point stays put, so the
    /// robot pivots about it. Released, ordinary static friction decides again.
    pub fn set_wheel_blocked(&mut self, wheel: Wheel, blocked: bool) {
        let i = wheel.index();
        self.blocked[i] = blocked;
        if blocked {
            self.speed[i] = 0.0;
        }
    }

    /// Whether each wheel [left, right] is jammed.
    pub fn wheel_blocked(&self) -> [bool; 2] {
        self.blocked
    }

    /// Fault hook: a slip patch. `wheel`'s longitudinal slip ratio becomes `ratio`, in
    /// [0, 1), from now on (its contact point moves (1 − ratio)·R·Δφ per wheel rotation Δφ).
    /// A ratio outside [0, 1) or NaN is refused and nothing changes.
    pub fn set_slip(&mut self, wheel: Wheel, ratio: f64) -> Result<(), PlantError> {
        if !(0.0..1.0).contains(&ratio) {
            return Err(PlantError::OutOfRange("slip"));
        }
        self.slip[wheel.index()] = ratio;
        self.update_ground_per_rad();
        Ok(())
    }

    /// The present slip ratios [left, right].
    pub fn slip(&self) -> [f64; 2] {
        self.slip
    }

    /// Fault hook: supply sag (or recovery). The bridge's supply becomes `volts` (V,
    /// finite, > 0) from now on: the armature sees d · `volts`. Under-voltage lockout of
    /// the driver is not modelled. A non-positive or non-finite value is refused and
    /// nothing changes.
    pub fn set_supply_v(&mut self, volts: f64) -> Result<(), PlantError> {
        if !(volts > 0.0 && volts.is_finite()) {
            return Err(PlantError::OutOfRange("supply_v"));
        }
        self.supply_v = volts;
        self.update_bridge();
        Ok(())
    }

    /// The present supply voltage, V.
    pub fn supply_v(&self) -> f64 {
        self.supply_v
    }
}
