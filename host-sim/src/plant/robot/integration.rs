//! The integrator: the exact solution over a whole hold of the bridge while it provably
//! stays in one regime, else RK4 at the plant rate, in closed form while a step provably
//! stays in one regime.
//!
//! Contract: with [`Integration::Rk4`] and [`Integration::Rk4Stages`], `Plant::advance`
//! gives the same numbers whichever path a step takes (the closed form is the same
//! arithmetic as RK4 stage by stage, `closed_form_step` returns a step only when it is);
//! with [`Integration::Exact`] a hold that provably stays in one regime is
//! the exact solution of the model, and any other is taken as [`Integration::Rk4`]. Every
//! step ends with the true pose moved along the step's wheel rotations (`pose`).
//!
//! ## One step per hold
//!
//! The bridge is held over a control period (zero-order hold), so away from rest and
//! from a current's sign change the period's dynamics are one affine system, whose exact
//! solution is two 2 × 2 matrix products ([`Propagator::exact`]), checked against the
//! regime boundaries with the same kind of bound as a plant step's. The pose then moves
//! along one arc for the period: its error is that of a curvature constant over 1 ms,
//! of the order v·θ̈·h³/12 per period (3e-11 m at 0.4 m/s, 1 rad/s², h = 1 ms).
//!
//! ## Integration
//!
//! The state (ω_l, ω_r, φ_l, φ_r) — wheel speeds and wheel angles — is advanced with the
//! classic fourth-order Runge–Kutta method at the plant rate (≥ 10 × the control rate),
//! the bridge held constant over the control period (zero-order hold, as a PWM timer
//! does). Each wheel's regime — its direction, and its power flow (coasting, motoring,
//! back-driven) — makes the dynamics affine, ω̇ = A ω + b, with A and b fixed by the
//! regime. When every RK4 stage point of a step provably stays in the regime of its
//! start (each wheel farther from rest and from its zero-current speed than any stage
//! of the step can have moved it, a bound derived in the `propagator` module), the step
//! is taken in closed form, which is the same arithmetic as RK4 stage by stage;
//! otherwise (a wheel at rest or reversing, a current changing sign, d ≠ 0) RK4
//! evaluates the full model at every stage. Friction is decided once per step, at its
//! start: a sliding wheel's Coulomb friction keeps its sign through the four stages (a
//! sign flip between stages would make RK4 average the friction away near rest), a
//! wheel at rest is held or breaks away (`chassis`, `friction`), and a wheel that ends
//! the step moving the way its friction pushes has passed through rest and is stopped
//! there; static friction decides at the next step whether it breaks away.

use super::super::friction::{Grip, Inertia};
use super::super::motor::{PowerFlow, WheelDrive};
use super::super::propagator::Propagator;
use super::Plant;

/// Index of a power flow in the propagator table.
const fn flow_index(flow: PowerFlow) -> usize {
    match flow {
        PowerFlow::Coasting => 0,
        PowerFlow::Motoring => 1,
        PowerFlow::BackDriven => 2,
    }
}

/// All three power flows, in [`flow_index`] order.
const FLOWS: [PowerFlow; 3] = [
    PowerFlow::Coasting,
    PowerFlow::Motoring,
    PowerFlow::BackDriven,
];

/// The affine model ω̇ = A ω + b of one regime (both wheels' directions and power
/// flows) under the present bridge state, ready for its [`Propagator`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Affine {
    /// Index into `Plant::propagators`: 3 · flow(left) + flow(right).
    pub(super) index: usize,
    /// S b and T b, with b = M⁻¹ τ₀ and τ₀ the electrical torque at ω = 0 minus the
    /// Coulomb friction [left, right]: rad/s and rad.
    pub(super) sb: [f64; 2],
    pub(super) tb: [f64; 2],
}

/// Added to the closed form's reach (rad/s) so that rounding in the stage points cannot
/// cross a regime boundary the exact arithmetic does not.
const ROUNDING_MARGIN_RAD_S: f64 = 1e-9;

/// How [`Plant::advance`] integrates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Integration {
    /// The exact solution over each `advance` call (one hold of the bridge) while it
    /// provably stays in one regime, else [`Integration::Rk4`]. Callers hold the bridge
    /// one control period per call. The default.
    #[default]
    Exact,
    /// Classic RK4 at the plant rate, in closed form where that is the same arithmetic:
    /// the fallback of [`Integration::Exact`], and on its own the baseline it is timed
    /// against.
    Rk4,
    /// Classic RK4 at the plant rate, every stage evaluated on the full model: the
    /// reference the others are held to.
    Rk4Stages,
}

/// A table of one propagator per regime pair, index 3 · flow(left) + flow(right), for
/// one step size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Propagators {
    /// Step size, s (0 before the first use).
    pub(super) h_s: f64,
    pub(super) table: [Propagator; 9],
}

impl Propagators {
    /// The table for `h_s` (s): RK4 in closed form, or the exact solution.
    pub(super) fn new(drives: &[WheelDrive; 2], inertia: &Inertia, h_s: f64, exact: bool) -> Self {
        let build = if exact {
            Propagator::exact
        } else {
            Propagator::new
        };
        Self {
            h_s,
            table: core::array::from_fn(|k| {
                let damping = [
                    drives[0].damping_nm_s_per_rad(FLOWS[k / 3]),
                    drives[1].damping_nm_s_per_rad(FLOWS[k % 3]),
                ];
                build(inertia.inv_p, inertia.inv_q, damping, h_s)
            }),
        }
    }
}

impl Plant {
    /// One classic RK4 step of `dt_s` from wheel speeds `w0`, for the speeds and angles,
    /// evaluating the full model ([`Plant::accel`]) at every stage with the friction
    /// decided at the start ([`Friction::grip`](super::super::friction::Friction::grip)). A wheel that ends the step moving the way
    /// its friction pushes has passed through rest: it is stopped at zero, and static
    /// friction decides at the next step. Returns the new speeds and the angle increments.
    pub(super) fn rk4_step(&self, w0: [f64; 2], dt_s: f64) -> ([f64; 2], [f64; 2]) {
        let grip = self
            .friction
            .grip(w0, self.blocked, || self.torques_without_friction(w0));
        let k1 = self.accel(w0, grip);
        let w1 = [w0[0] + 0.5 * dt_s * k1[0], w0[1] + 0.5 * dt_s * k1[1]];
        let k2 = self.accel(w1, grip);
        let w2 = [w0[0] + 0.5 * dt_s * k2[0], w0[1] + 0.5 * dt_s * k2[1]];
        let k3 = self.accel(w2, grip);
        let w3 = [w0[0] + dt_s * k3[0], w0[1] + dt_s * k3[1]];
        let k4 = self.accel(w3, grip);
        let mut next = [0.0; 2];
        let mut dphi = [0.0; 2];
        for i in 0..2 {
            // φ̇ = ω: the RK4 increment of φ uses the stage speeds.
            dphi[i] = dt_s / 6.0 * (w0[i] + 2.0 * w1[i] + 2.0 * w2[i] + w3[i]);
            next[i] = w0[i] + dt_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            let stops = match grip[i] {
                Grip::Held => true,
                Grip::Slides(friction) => next[i] * friction > 0.0,
            };
            if stops || self.blocked[i] {
                next[i] = 0.0;
            }
        }
        (next, dphi)
    }

    /// The affine model ω̇ = A ω + b of the regime both wheels are in at speeds `w`
    /// (both non-zero): their directions and power flows, with the forcing terms of
    /// `propagators`.
    pub(super) fn affine(&self, w: [f64; 2], propagators: &Propagators) -> Affine {
        let mut index = 0;
        let mut torque_at_rest = [0.0; 2];
        for (i, d) in self.drives.iter().enumerate() {
            let (flow, electrical) = if self.coasting[i] {
                (PowerFlow::Coasting, 0.0)
            } else {
                match d.power_flow(self.volts[i], w[i]) {
                    PowerFlow::BackDriven => (PowerFlow::BackDriven, self.back_driven_torque[i]),
                    _ => (PowerFlow::Motoring, self.motoring_torque[i]),
                }
            };
            let coulomb = if w[i] > 0.0 {
                d.coulomb_nm
            } else {
                -d.coulomb_nm
            };
            torque_at_rest[i] = electrical - coulomb;
            index = 3 * index + flow_index(flow);
        }
        let (sb, tb) = propagators
            .table
            .get(index)
            .map_or(([0.0; 2], [0.0; 2]), |p| {
                p.forcing(self.friction.inertia.solve(torque_at_rest))
            });
        Affine { index, sb, tb }
    }

    /// The closed-form step of `propagators` from `w` in the regime `affine` (which must
    /// be the regime of `w`, with forcing terms of the same table), if every stage (every
    /// point, for an exact table) stayed in it: neither wheel reaching rest, neither
    /// driven wheel reaching its zero-current speed, within the step's reach. `None`
    /// otherwise. When it returns a step, the step's end is in the same regime.
    #[inline]
    pub(super) fn closed_form_step(
        &self,
        propagators: &Propagators,
        w: [f64; 2],
        affine: &Affine,
    ) -> Option<([f64; 2], [f64; 2])> {
        let propagator = propagators.table.get(affine.index)?;
        let (next, dphi) = propagator.step(w, affine.sb, affine.tb);
        let reach = propagator.reach([next[0] - w[0], next[1] - w[1]]) + ROUNDING_MARGIN_RAD_S;
        // A coasting wheel's zero-current speed is infinite: no boundary.
        let stays =
            |i: usize| w[i].abs() > reach && (w[i] - self.zero_current_speed[i]).abs() > reach;
        if stays(0) && stays(1) {
            Some((next, dphi))
        } else {
            None
        }
    }

    /// Advances `steps` plant steps of `dt_s` seconds each with the bridge state last set,
    /// as the [`Integration`] set says (the whole call in one exact step when it can be).
    pub fn advance(&mut self, dt_s: f64, steps: u32) {
        if self.integration == Integration::Exact && self.exact_hold(dt_s * f64::from(steps)) {
            return;
        }
        self.advance_rk4(dt_s, steps);
    }

    /// The whole hold of `hold_s` seconds in one exact step, if the plant can take it in
    /// closed form (no centre-of-mass terms, both wheels turning) and it provably stays
    /// in one regime; false, nothing changed, otherwise.
    fn exact_hold(&mut self, hold_s: f64) -> bool {
        let w = self.speed;
        if self.mass_com != 0.0 || w[0] == 0.0 || w[1] == 0.0 || hold_s <= 0.0 {
            return false;
        }
        if self.exact.h_s != hold_s {
            self.exact = Propagators::new(&self.drives, &self.friction.inertia, hold_s, true);
        }
        let affine = self.affine(w, &self.exact);
        let Some((next, dphi)) = self.closed_form_step(&self.exact, w, &affine) else {
            return false;
        };
        self.speed = next;
        self.angle = [self.angle[0] + dphi[0], self.angle[1] + dphi[1]];
        self.pose.roll(
            self.ground_per_rad[0] * dphi[0],
            self.ground_per_rad[1] * dphi[1],
            1.0 / self.track_m,
        );
        self.pose.renormalise();
        true
    }

    /// `steps` RK4 steps of `dt_s` seconds, in closed form where that is the same
    /// arithmetic (unless [`Integration::Rk4Stages`]).
    fn advance_rk4(&mut self, dt_s: f64, steps: u32) {
        if self.rk4.h_s != dt_s {
            self.rk4 = Propagators::new(&self.drives, &self.friction.inertia, dt_s, false);
        }
        let closed_form = self.integration != Integration::Rk4Stages && self.mass_com == 0.0;
        // The state lives in locals for the loop (registers, not memory round trips).
        let mut pose = self.pose;
        let (mut w, mut angle) = (self.speed, self.angle);
        let inv_l = 1.0 / self.track_m;
        // The regime of the last closed-form step: still the regime of `w`, since a
        // closed-form step ends in the regime it started in.
        let mut regime: Option<Affine> = None;
        for _ in 0..steps {
            let step = if closed_form && w[0] != 0.0 && w[1] != 0.0 {
                let affine = *regime.get_or_insert_with(|| self.affine(w, &self.rk4));
                self.closed_form_step(&self.rk4, w, &affine)
            } else {
                None
            };
            let (next, dphi) = match step {
                Some(step) => step,
                None => {
                    regime = None;
                    self.rk4_step(w, dt_s)
                }
            };
            w = next;
            angle[0] += dphi[0];
            angle[1] += dphi[1];
            // Ground distances and the arc they define on the true track.
            pose.roll(
                self.ground_per_rad[0] * dphi[0],
                self.ground_per_rad[1] * dphi[1],
                inv_l,
            );
        }
        self.speed = w;
        self.angle = angle;
        pose.renormalise();
        self.pose = pose;
    }

    /// Sets how [`Plant::advance`] integrates, from the next call.
    pub fn set_integration(&mut self, integration: Integration) {
        self.integration = integration;
    }
}
