//! The bridge side of the plant: duties, the driver's enable line, and what each
//! bridge applies.
//!
//! Contract: every setter that changes what a bridge applies (duties, enable line,
//! connections, supply) re-derives the bridge's constant terms (`update_bridge`) before
//! it returns, so the integrator always sees the bridge state last set, held constant
//! over the following `Plant::advance` calls (zero-order hold, as a PWM timer does).
//!
//! ## Bridge states
//!
//! Each wheel's bridge either drives (slow decay: u = d · V_s, d = 0 is a short brake) or
//! coasts (no current); see [`crate::plant::driver`]. [`Plant::set_duty`] sets the duties,
//! [`Plant::set_driver_enabled`] the driver's enable line (disabled = both coast); a
//! disconnected motor (`faults`) coasts too. While driven, a wheel's regime constants
//! follow from u: its zero-current speed u / (N K_e) and its electrical torque at rest
//! for motoring and back-driven flow.

use super::super::driver::{self, BridgeOutput};
use super::super::motor::PowerFlow;
use super::Plant;

impl Plant {
    /// Sets both PWM duties (any f32, positive forward; see
    /// [`driver::applied_duty`]) for the following [`Plant::advance`] calls. While
    /// the driver is enabled and a motor connected, its bridge drives in slow decay at
    /// u = d · V_s; a duty of 0 (or in the dead-band) is a short brake.
    pub fn set_duty(&mut self, left: f32, right: f32) {
        let bridge = &self.params.driver;
        self.applied_duty = [
            driver::applied_duty(bridge, left),
            driver::applied_duty(bridge, right),
        ];
        self.update_bridge();
    }

    /// Enables or disables the driver (TB6612 STBY, DRV8833 nSLEEP). Disabled, both
    /// bridges are high impedance and both motors coast, whatever the duties; the duties
    /// set are applied again once enabled.
    pub fn set_driver_enabled(&mut self, enabled: bool) {
        self.enabled = enabled;
        self.update_bridge();
    }

    /// Whether the driver is enabled.
    pub fn driver_enabled(&self) -> bool {
        self.enabled
    }

    /// What each bridge [left, right] applies now.
    pub fn bridge_outputs(&self) -> [BridgeOutput; 2] {
        core::array::from_fn(|i| {
            if self.coasting[i] {
                BridgeOutput::Coast
            } else {
                BridgeOutput::Drive {
                    volts: self.volts[i],
                }
            }
        })
    }

    /// Duties [left, right] the PWM applies (quantised as the firmware writes them,
    /// dead-band zeroed). They reach the motor only while its bridge drives
    /// ([`Plant::bridge_outputs`]).
    pub fn applied_duty(&self) -> [f64; 2] {
        self.applied_duty
    }

    /// Armature currents [left, right] at the present state, A (0 for a coasting motor).
    pub fn currents_a(&self) -> [f64; 2] {
        core::array::from_fn(|i| {
            if self.coasting[i] {
                0.0
            } else {
                self.drives[i].current_a(self.volts[i], self.speed[i])
            }
        })
    }

    /// Re-derives each wheel's bridge output and its constant terms from the duties,
    /// supply, enable line and connections.
    pub(super) fn update_bridge(&mut self) {
        for i in 0..2 {
            let d = &self.drives[i];
            self.coasting[i] = !(self.enabled && self.connected[i]);
            let u = if self.coasting[i] {
                0.0
            } else {
                driver::voltage_v(self.applied_duty[i], self.supply_v)
            };
            self.volts[i] = u;
            self.zero_current_speed[i] = if self.coasting[i] {
                f64::INFINITY
            } else {
                u / d.back_emf_v_s_per_rad
            };
            self.motoring_torque[i] = d.gear_factor(PowerFlow::Motoring) * d.torque_per_volt * u;
            self.back_driven_torque[i] =
                d.gear_factor(PowerFlow::BackDriven) * d.torque_per_volt * u;
        }
    }
}
