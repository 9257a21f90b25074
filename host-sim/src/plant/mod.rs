//! The simulated robot: per-wheel DC motor and gearbox ([`motor`]) on a chassis with
//! slip and a true pose ([`robot`]).
//!
//! ## Default robot (all SI)
//!
//! | quantity | value |
//! |---|---|
//! | supply | 6 V, 1000-level PWM, 2 % driver dead-band |
//! | motor | R_a = 4 Ω, K_t = K_e = 0.005 N·m/A = V·s/rad, rotor 1e-7 kg·m² |
//! | gearbox | 1:30, η = 0.8 |
//! | friction at the wheel | viscous 2e-4 N·m·s/rad, Coulomb/static 0.01 N·m |
//! | wheel | no-load 36.2 rad/s (1.18 m/s rim) at 6 V; stall 0.18 N·m, 1.5 A |
//! | chassis | 0.5 kg, yaw inertia 1.8e-3 kg·m², wheels 2e-5 kg·m² each |
//! | geometry | R = 32.5 mm (65 mm wheels), L = 150 mm (the controller's belief unless mismatched) |
//! | encoder | 12 lines × 4 × 30 = 1440 ticks per wheel turn |
//!
//! Time constants: forward motion 80 ms, turning on the spot 60 ms (mechanical, at the
//! wheel, with the motor's electrical damping).

pub mod motor;
pub mod robot;

pub use motor::{DriverParams, MotorParams, WheelDrive};
pub use robot::{BodyParams, Plant, PlantError, PlantParams, TrueGeometry, TruePose};
