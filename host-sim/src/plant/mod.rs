//! The simulated robot: per-wheel H-bridge ([`driver`]), DC motor and gearbox
//! ([`motor`]) on a chassis with slip, faults and a true pose ([`robot`]). Its parameters
//! (the bridge chip and supply, the motor, the body, the load) are the types a scenario
//! names, in [`robot_files::plant`]; the true pose is [`robot_files::truth::TruePose`].
//!
//! ## Default robot (all SI)
//!
//! | quantity | value |
//! |---|---|
//! | driver | TB6612FNG: slow decay (duty 0 = short brake), 0.5 Ω bridge on-resistance, coasts when disabled |
//! | supply, PWM | 6 V; 5 000 levels (TIM3: 100 MHz / 20 kHz), rounded as the firmware does; 2 % dead-band |
//! | motor | R_a = 4 Ω, K_t = K_e = 0.005 N·m/A = V·s/rad, rotor 1e-7 kg·m²; both wheels alike unless `[plant.motor_mismatch]` splits R_a, K_t = K_e or the frictions between them |
//! | gearbox | 1:30, η = 0.8 (× η motoring, ÷ η back-driven) |
//! | friction at the wheel | viscous 2e-4 N·m·s/rad, Coulomb/static 0.01 N·m |
//! | wheel at 6 V supply | no-load 35.7 rad/s (1.16 m/s rim); stall 0.16 N·m, 1.33 A |
//! | chassis | 0.5 kg, yaw inertia 1.8e-3 kg·m² about the axle midpoint, centre of mass on the axle, wheels 2e-5 kg·m² each |
//! | geometry | R = 32.5 mm (65 mm wheels), L = 150 mm (the controller's belief unless mismatched) |
//! | encoder | 12 lines × 4 × 30 = 1440 ticks per wheel turn |
//!
//! Time constants (mechanical, at the wheel, with the motor's electrical damping while
//! driven): forward motion 89 ms, turning on the spot 66 ms, lifted wheels
//! ([`Load::Lifted`](robot_files::plant::Load::Lifted), on a stand) 26 ms. A short brake from 30 rad/s
//! decelerates the robot 12.7 × harder than coasting.

pub mod driver;
mod friction;
pub mod motor;
mod propagator;
pub mod robot;

pub use driver::BridgeOutput;
pub use motor::{PowerFlow, WheelDrive};
pub use robot::{Integration, Plant, PlantError, PlantParams, TrueGeometry};
