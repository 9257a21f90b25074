//! The wheel loop against the batteries people use and against motors that are not the
//! one it was tuned for: a supply and parameter sweep with the controller's gains fixed.
//!
//! Each case changes the simulated robot only (the controller keeps its configuration,
//! feed-forward included, so a motor 30 % off is a feed-forward 30 % off): the supply
//! (4.8 V, four AA cells, to 12.6 V, a full 3S pack), and the motor's armature resistance
//! R_a, torque constant K_t (with the back-EMF constant K_e, which equals it in SI
//! units), friction (Coulomb and viscous together) and inertia (the chassis' mass and yaw
//! inertia, the wheels' and the rotors' inertia together), each ±30 %. Every case runs:
//!
//! - the linearised loop's margins ([`crate::margins`]) on the ground, straight and
//!   turning, motoring (the smaller of the two);
//! - a 0 → 15 rad/s step of the wheel loop from rest (rise 10→90 %, overshoot);
//! - the scenario (the paper's circle by default) with the tracking law: settle time and
//!   the wheel-speed error, set-point − true wheel speed of both wheels at every control
//!   step, as an RMS over the whole run (its ratio to the nominal case is the issue's
//!   criterion) and over the final 10 s, where a loop that oscillates shows.
//!
//! **Oscillation** is declared when the final-10 s RMS exceeds [`OSCILLATION_RMS_RAD_S`]
//! or the linearised loop is unstable.
//!
//! [`corners`] adds every combination of the four motor parameters at ±30 % at both ends
//! of the supply range (32 robots).

use controller_core::law::LawKind;
use rayon::prelude::*;
use robot_files::plant::Load;
use robot_files::scenario::Scenario;
use serde::Serialize;

use crate::margins::{self, LoadCase, Motion};
use crate::plant::PowerFlow;
use crate::run::{run_scenario_with, wheel_step_response, RunError, RunOptions};

/// A final-10 s wheel-speed error RMS above this is an oscillation, rad/s. The nominal
/// loop holds 0.03 rad/s on the circle (`host-sim param-sweep`); one tick of the speed
/// estimate is 0.22 rad/s.
pub const OSCILLATION_RMS_RAD_S: f64 = 0.3;

/// The supplies of the sweep, V: four AA cells (4.8), the reference 6 V, a 2S LiPo
/// (7.4 nominal, 8.4 full), a 3S pack (11.1 nominal, 12.6 full).
pub const SUPPLIES_V: [f64; 6] = [4.8, 6.0, 7.4, 8.4, 11.1, 12.6];

/// How far each motor parameter is moved, %.
pub const PARAMETER_PCT: f64 = 30.0;

/// One simulated robot of the sweep: the scenario's with these changes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Variation {
    /// Supply, V (`None`: the scenario's).
    pub supply_v: Option<f64>,
    /// Armature resistance change, %.
    pub resistance_pct: f64,
    /// Torque and back-EMF constant change, %.
    pub torque_constant_pct: f64,
    /// Coulomb and viscous friction change, %.
    pub friction_pct: f64,
    /// Every inertia's change, %.
    pub inertia_pct: f64,
}

impl Variation {
    /// A short label, e.g. `12.6 V`, `R_a −30 %`, `nominal`.
    pub fn label(&self) -> String {
        let mut parts = Vec::new();
        if let Some(v) = self.supply_v {
            parts.push(format!("{v} V"));
        }
        let pct = |name: &str, p: f64| {
            format!("{name} {}{:.0} %", if p < 0.0 { "−" } else { "+" }, p.abs())
        };
        for (name, p) in [
            ("R_a", self.resistance_pct),
            ("K_t", self.torque_constant_pct),
            ("friction", self.friction_pct),
            ("inertia", self.inertia_pct),
        ] {
            if p != 0.0 {
                parts.push(pct(name, p));
            }
        }
        if parts.is_empty() {
            "nominal".to_string()
        } else {
            parts.join(", ")
        }
    }

    /// A compact label for corner cases, e.g. `12.6 V R− K+ f− J+` (R_a, K_t, friction,
    /// inertia: − for −30 %, + for +30 %); [`Variation::label`] for the others.
    pub fn short_label(&self) -> String {
        let changed = [
            self.resistance_pct,
            self.torque_constant_pct,
            self.friction_pct,
            self.inertia_pct,
        ];
        if changed.iter().filter(|p| **p != 0.0).count() < 2 {
            return self.label();
        }
        let sign = |p: f64| {
            if p < 0.0 {
                "−"
            } else if p > 0.0 {
                "+"
            } else {
                "0"
            }
        };
        let supply = self.supply_v.map_or(String::new(), |v| format!("{v} V "));
        format!(
            "{supply}R{} K{} f{} J{}",
            sign(changed[0]),
            sign(changed[1]),
            sign(changed[2]),
            sign(changed[3])
        )
    }

    /// `scenario` with this variation applied to its plant.
    pub fn apply(&self, scenario: &Scenario) -> Scenario {
        let mut s = scenario.clone();
        let scale = |pct: f64| 1.0 + pct / 100.0;
        let p = &mut s.plant;
        if let Some(v) = self.supply_v {
            p.driver.supply_v = v;
        }
        p.motor.resistance_ohm *= scale(self.resistance_pct);
        p.motor.torque_constant_nm_per_a *= scale(self.torque_constant_pct);
        p.motor.back_emf_v_s_per_rad *= scale(self.torque_constant_pct);
        p.motor.coulomb_friction_nm *= scale(self.friction_pct);
        p.motor.viscous_friction_nm_s_per_rad *= scale(self.friction_pct);
        let j = scale(self.inertia_pct);
        p.motor.rotor_inertia_kg_m2 *= j;
        p.body.mass_kg *= j;
        p.body.yaw_inertia_kg_m2 *= j;
        p.body.wheel_inertia_kg_m2 *= j;
        s
    }
}

/// The table's rows: nominal, each supply, then each motor parameter at ±30 % on the
/// scenario's supply.
pub fn one_at_a_time() -> Vec<Variation> {
    let mut rows = vec![Variation::default()];
    for v in SUPPLIES_V {
        rows.push(Variation {
            supply_v: Some(v),
            ..Variation::default()
        });
    }
    for sign in [-1.0, 1.0] {
        let p = sign * PARAMETER_PCT;
        rows.push(Variation {
            resistance_pct: p,
            ..Variation::default()
        });
        rows.push(Variation {
            torque_constant_pct: p,
            ..Variation::default()
        });
        rows.push(Variation {
            friction_pct: p,
            ..Variation::default()
        });
        rows.push(Variation {
            inertia_pct: p,
            ..Variation::default()
        });
    }
    rows
}

/// Every combination of the four motor parameters at ±30 %, on the lowest and the
/// highest supply of [`SUPPLIES_V`] (32 robots).
pub fn corners() -> Vec<Variation> {
    let mut rows = Vec::new();
    for supply in [SUPPLIES_V[0], SUPPLIES_V[SUPPLIES_V.len() - 1]] {
        for bits in 0..16u32 {
            let p = |bit: u32| {
                if bits & (1 << bit) == 0 {
                    -PARAMETER_PCT
                } else {
                    PARAMETER_PCT
                }
            };
            rows.push(Variation {
                supply_v: Some(supply),
                resistance_pct: p(0),
                torque_constant_pct: p(1),
                friction_pct: p(2),
                inertia_pct: p(3),
            });
        }
    }
    rows
}

/// What one robot of the sweep did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CaseResult {
    /// The robot.
    pub variation: Variation,
    /// The smaller gain margin of the linearised loop, ground straight and turning.
    pub gain_margin: Option<f64>,
    /// The smaller phase margin, degrees.
    pub phase_margin_deg: Option<f64>,
    /// The linearised loop is stable in both modes.
    pub stable: bool,
    /// 0 → 15 rad/s step: rise 10→90 %, s.
    pub step_rise_s: Option<f64>,
    /// 0 → 15 rad/s step: overshoot, %.
    pub step_overshoot_pct: f64,
    /// The scenario's settle time, s (`None`: did not settle).
    pub settle_s: Option<f64>,
    /// Wheel-speed error RMS over the whole run, rad/s.
    pub wheel_error_rms_rad_s: f64,
    /// Wheel-speed error RMS over the final 10 s, rad/s.
    pub wheel_error_final_rms_rad_s: f64,
    /// A fault stopped the run.
    pub faulted: bool,
    /// The faults that stopped it, by name.
    pub faults: Vec<String>,
}

impl CaseResult {
    /// The loop oscillates (module doc).
    pub fn oscillates(&self) -> bool {
        !self.stable || self.wheel_error_final_rms_rad_s > OSCILLATION_RMS_RAD_S
    }
}

/// Runs `scenario` (tracking law) on the robot `variation` describes.
pub fn run_case(scenario: &Scenario, variation: Variation) -> Result<CaseResult, RunError> {
    let s = variation.apply(scenario);
    let (mut gm, mut pm, mut stable) = (None::<f64>, None::<f64>, true);
    for motion in [Motion::Straight, Motion::Turning] {
        let case = LoadCase {
            load: Load::Ground,
            motion,
            flow: PowerFlow::Motoring,
        };
        let model = margins::case_model(&s, case)?;
        let m = model.margins();
        stable &= model.is_stable();
        gm = match (gm, m.gain_margin) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        pm = match (pm, m.phase_margin_deg) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
    }
    let step = wheel_step_response(&s, 15.0, 1.0)?;
    let run = run_scenario_with(&s, LawKind::Tracking, RunOptions::traced_every(1))?;
    let rate = f64::from(s.robot.control_rate_hz);
    let final_from = s.duration_s - robot_files::metrics::FINAL_WINDOW_S;
    let (mut all, mut all_n, mut last, mut last_n) = (0.0, 0u64, 0.0, 0u64);
    for row in &run.trace {
        let e = [
            f64::from(row.setpoint.left_rad_s) - row.true_wheel[0],
            f64::from(row.setpoint.right_rad_s) - row.true_wheel[1],
        ];
        let sq = e[0] * e[0] + e[1] * e[1];
        all += sq;
        all_n += 2;
        if row.t_s >= final_from - 0.5 / rate {
            last += sq;
            last_n += 2;
        }
    }
    let rms = |sum: f64, n: u64| if n > 0 { (sum / n as f64).sqrt() } else { 0.0 };
    Ok(CaseResult {
        variation,
        gain_margin: gm,
        phase_margin_deg: pm,
        stable,
        step_rise_s: step.rise_time_s,
        step_overshoot_pct: step.overshoot_pct,
        settle_s: run.summary.headline_error().settle_time_s,
        wheel_error_rms_rad_s: rms(all, all_n),
        wheel_error_final_rms_rad_s: rms(last, last_n),
        faulted: run.faulted(),
        faults: run.summary.supervisor.faults.clone(),
    })
}

/// Runs every variation of `rows` on every core, in order.
pub fn run_all(scenario: &Scenario, rows: &[Variation]) -> Result<Vec<CaseResult>, RunError> {
    rows.par_iter().map(|v| run_case(scenario, *v)).collect()
}

/// The verdict of one case against the nominal one (the first of [`one_at_a_time`]):
/// no oscillation, no fault, settled, wheel-speed error RMS ≤ 2 × nominal.
pub fn passes(case: &CaseResult, nominal: &CaseResult) -> bool {
    !case.oscillates()
        && !case.faulted
        && case.settle_s.is_some()
        && case.wheel_error_rms_rad_s <= 2.0 * nominal.wheel_error_rms_rad_s
}

/// `yes`, or what failed: `oscillates`, `fault: …`, `unsettled`, `RMS`.
fn verdict(case: &CaseResult, nominal: &CaseResult) -> String {
    if passes(case, nominal) {
        "yes".to_string()
    } else if case.oscillates() {
        "NO: oscillates".to_string()
    } else if case.faulted {
        format!("NO: fault {}", case.faults.join(", "))
    } else if case.settle_s.is_none() {
        "NO: unsettled".to_string()
    } else {
        "NO: RMS".to_string()
    }
}

/// The results as a text table, with each case's error ratio to `nominal`.
pub fn table(results: &[CaseResult], nominal: &CaseResult) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{:<28} {:>5} {:>5} {:>7} {:>7} {:>8} {:>9} {:>6} {:>9}  ok",
        "robot", "GM", "PM °", "rise ms", "over %", "settle s", "RMS rad/s", "× nom", "final10"
    );
    for r in results {
        let opt = |v: Option<f64>, scale: f64, d: usize| {
            v.map_or("—".to_string(), |x| format!("{:.d$}", x * scale))
        };
        let _ = writeln!(
            out,
            "{:<28} {:>5} {:>5} {:>7} {:>7.1} {:>8} {:>9.3} {:>6.2} {:>9.3}  {}",
            r.variation.short_label(),
            opt(r.gain_margin, 1.0, 2),
            opt(r.phase_margin_deg, 1.0, 0),
            opt(r.step_rise_s, 1e3, 0),
            r.step_overshoot_pct,
            opt(r.settle_s, 1.0, 2),
            r.wheel_error_rms_rad_s,
            r.wheel_error_rms_rad_s / nominal.wheel_error_rms_rad_s,
            r.wheel_error_final_rms_rad_s,
            verdict(r, nominal)
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variations_change_only_what_they_name() {
        let s = Scenario::load("paper-circle").unwrap();
        let v = Variation {
            supply_v: Some(12.6),
            resistance_pct: -30.0,
            inertia_pct: 30.0,
            ..Variation::default()
        };
        let t = v.apply(&s);
        assert_eq!(t.plant.driver.supply_v, 12.6);
        assert!((t.plant.motor.resistance_ohm - 2.8).abs() < 1e-12);
        assert!((t.plant.body.mass_kg - 0.65).abs() < 1e-12);
        assert_eq!(t.plant.motor.torque_constant_nm_per_a, 0.005);
        assert_eq!(t.robot, s.robot, "the controller is not told");
        assert_eq!(v.label(), "12.6 V, R_a −30 %, inertia +30 %");
        assert_eq!(Variation::default().label(), "nominal");
        assert_eq!(one_at_a_time().len(), 1 + 6 + 8);
        assert_eq!(corners().len(), 32);
    }
}
