//! Coulomb and static friction on two wheels coupled through the chassis (Karnopp's
//! stick–slip model, with the coupling).
//!
//! The wheel speeds obey M ω̇ = τ + f, with M = [[a, b], [b, a]] the chassis' inertia
//! matrix on (ω_l, ω_r) ([`super::robot`]), τ every torque but friction and f the friction
//! torques, |f_i| ≤ τ_c. A turning wheel sees kinetic friction −τ_c sgn ω_i. A wheel at
//! rest stays at rest only if static friction can supply the torque that holds it there:
//!
//! - wheel i at rest, wheel j turning with net torque t_j: holding i (ω̇_i = 0) gives
//!   ω̇_j = t_j / a from row j and, from row i, the friction i must supply,
//!   f_i = b t_j / a − τ_i. If |f_i| ≤ τ_c it stays; otherwise it breaks away towards
//!   −f_i with kinetic friction opposing that motion;
//! - both at rest: both stay if |τ_i| ≤ τ_c for each. Otherwise a wheel whose torque
//!   exceeds τ_c breaks away alone if the other's static friction can then take the pull
//!   (f_j = b (τ_i − τ_c sgn τ_i) / a − τ_j), the one with the larger excess first; else
//!   both break away, friction opposing each wheel's frictionless acceleration M⁻¹ τ.
//!
//! So a strongly driven wheel drags an unpowered one along once |b| (τ_i − τ_c) / a
//! exceeds τ_c: backwards if b > 0 (yawing, with inertia a − b, is then the cheaper
//! motion), forwards if b < 0. A jammed wheel is held whatever the torque.
//!
//! The decision is made once per plant step, at its start, and holds for the four RK4
//! stages: a sliding wheel's friction keeps its sign (a sign flip between stages near rest
//! would make RK4 average the friction away), and a held wheel's acceleration is 0.

/// How Coulomb and static friction act on one wheel over one plant step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Grip {
    /// Held at rest by static friction (or a jam): its acceleration is 0.
    Held,
    /// Sliding, with this friction torque, N·m (−τ_c · direction of motion).
    Slides(f64),
}

/// The chassis' inertia matrix on the wheel speeds, M = [[a, b], [b, a]] (kg·m²), and
/// its inverse [[p, q], [q, p]] (1/(kg·m²)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Inertia {
    /// Diagonal a, kg·m².
    pub(crate) a: f64,
    /// Off-diagonal b, kg·m².
    pub(crate) b: f64,
    /// Diagonal of M⁻¹, 1/(kg·m²).
    pub(crate) inv_p: f64,
    /// Off-diagonal of M⁻¹, 1/(kg·m²).
    pub(crate) inv_q: f64,
}

impl Inertia {
    /// M = [[a, b], [b, a]], or `None` if it is not positive definite.
    pub(crate) fn new(a: f64, b: f64) -> Option<Self> {
        let det = a * a - b * b;
        if a > 0.0 && det > 0.0 && det.is_finite() {
            Some(Self {
                a,
                b,
                inv_p: a / det,
                inv_q: -b / det,
            })
        } else {
            None
        }
    }

    /// M⁻¹ τ: accelerations (rad/s²) for torques `tau` (N·m).
    #[inline]
    pub(crate) fn solve(&self, tau: [f64; 2]) -> [f64; 2] {
        [
            self.inv_p * tau[0] + self.inv_q * tau[1],
            self.inv_q * tau[0] + self.inv_p * tau[1],
        ]
    }

    /// Wheel accelerations (rad/s²) for torques `tau` without friction (N·m) and friction
    /// `grip`: a held wheel's friction takes up its row of M ω̇ = τ + f, so the other wheel
    /// sees inertia a alone.
    #[inline]
    pub(crate) fn accel(&self, tau: [f64; 2], grip: [Grip; 2]) -> [f64; 2] {
        match grip {
            [Grip::Held, Grip::Held] => [0.0; 2],
            [Grip::Held, Grip::Slides(f)] => [0.0, (tau[1] + f) / self.a],
            [Grip::Slides(f), Grip::Held] => [(tau[0] + f) / self.a, 0.0],
            [Grip::Slides(f0), Grip::Slides(f1)] => self.solve([tau[0] + f0, tau[1] + f1]),
        }
    }
}

/// Coulomb and static friction of both wheels, for deciding each step's [`Grip`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Friction {
    /// The chassis' inertia matrix.
    pub(crate) inertia: Inertia,
    /// Coulomb (= static) friction τ_c of each wheel [left, right], N·m.
    pub(crate) coulomb_nm: [f64; 2],
}

impl Friction {
    /// The grip of each wheel over a step from speeds `w0` (rad/s), with jammed wheels
    /// `blocked`; `torques` gives the torques without friction at `w0` (N·m), asked for
    /// only when a wheel is at rest.
    pub(crate) fn grip(
        &self,
        w0: [f64; 2],
        blocked: [bool; 2],
        torques: impl FnOnce() -> [f64; 2],
    ) -> [Grip; 2] {
        let c = self.coulomb_nm;
        let sliding = |i: usize| Grip::Slides(-c[i] * w0[i].signum());
        match (w0[0] == 0.0, w0[1] == 0.0) {
            (false, false) => [sliding(0), sliding(1)],
            (true, false) => {
                let tau = torques();
                let t1 = tau[1] - c[1] * w0[1].signum();
                [self.one_at_rest(tau[0], c[0], t1, blocked[0]), sliding(1)]
            }
            (false, true) => {
                let tau = torques();
                let t0 = tau[0] - c[0] * w0[0].signum();
                [sliding(0), self.one_at_rest(tau[1], c[1], t0, blocked[1])]
            }
            (true, true) => self.both_at_rest(torques(), blocked),
        }
    }

    /// A wheel at rest with torque `tau_i` and static friction `c` (its τ_c), the other
    /// turning with net torque `t_j` (kinetic friction included), N·m.
    fn one_at_rest(&self, tau_i: f64, c: f64, t_j: f64, blocked: bool) -> Grip {
        let m = &self.inertia;
        // Held: ω̇_i = 0, so ω̇_j = t_j / a, and its friction must supply b ω̇_j − τ_i.
        let needed = m.b * t_j / m.a - tau_i;
        if blocked || needed.abs() <= c {
            Grip::Held
        } else {
            // It breaks away towards −needed; kinetic friction opposes that.
            Grip::Slides(c * needed.signum())
        }
    }

    /// Both wheels at rest with torques `tau` (N·m).
    fn both_at_rest(&self, tau: [f64; 2], blocked: [bool; 2]) -> [Grip; 2] {
        let c = self.coulomb_nm;
        let m = &self.inertia;
        let holds = |i: usize| blocked[i] || tau[i].abs() <= c[i];
        if holds(0) && holds(1) {
            return [Grip::Held; 2];
        }
        // One wheel breaks away while the other stays held, if its static friction can
        // take the pull; the wheel with the larger excess torque first.
        let mut best: Option<(f64, [Grip; 2])> = None;
        for i in 0..2 {
            if holds(i) {
                continue;
            }
            let j = 1 - i;
            let friction_i = -c[i] * tau[i].signum();
            let needed_j = m.b * (tau[i] + friction_i) / m.a - tau[j];
            let excess = tau[i].abs() - c[i];
            if (blocked[j] || needed_j.abs() <= c[j]) && best.is_none_or(|(e, _)| excess > e) {
                let mut grip = [Grip::Held; 2];
                grip[i] = Grip::Slides(friction_i);
                best = Some((excess, grip));
            }
        }
        if let Some((_, grip)) = best {
            return grip;
        }
        // Both break away: each one's friction opposes its frictionless acceleration.
        let free = m.solve(tau);
        [
            Grip::Slides(-c[0] * sign(free[0])),
            Grip::Slides(-c[1] * sign(free[1])),
        ]
    }
}

/// The sign of `x`: −1, 0 or 1 (unlike `f64::signum`, 0 for ±0).
fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default robot's inertia matrix (a > b > 0) and Coulomb friction.
    fn friction(b: f64) -> Friction {
        Friction {
            inertia: Inertia::new(3.27e-4, b).unwrap(),
            coulomb_nm: [0.01; 2],
        }
    }

    #[test]
    fn one_wheel_at_rest_holds_exactly_up_to_static_friction() {
        for b in [4.75e-5, -1.0e-4] {
            let f = friction(b);
            let a = f.inertia.a;
            // The other wheel turning forward with net torque t: the pull b t / a.
            let t_at_limit = 0.01 * a / b.abs();
            for (t, held) in [(0.99 * t_at_limit, true), (1.01 * t_at_limit, false)] {
                let grip = f.grip([0.0, 5.0], [false; 2], || [0.0, t + 0.01]);
                assert_eq!(grip[1], Grip::Slides(-0.01));
                assert_eq!(grip[0] == Grip::Held, held, "b = {b}, t = {t}");
                if !held {
                    // It slides the way the pull goes: sgn(−b t) (M⁻¹'s off-diagonal is −b).
                    let accel = f.inertia.accel([0.0, t + 0.01], grip);
                    assert!(accel[0] * b < 0.0, "{accel:?}");
                    assert_eq!(grip[0], Grip::Slides(0.01 * b.signum()));
                }
            }
            // Jammed, it holds against any pull.
            let grip = f.grip([0.0, 5.0], [true, false], || [0.0, 100.0]);
            assert_eq!(grip[0], Grip::Held);
            // Its own torque beyond τ_c breaks it away even with no pull.
            let grip = f.grip([0.0, 5.0], [false; 2], || [0.02, 0.01]);
            assert_eq!(grip[0], Grip::Slides(-0.01));
        }
    }

    #[test]
    fn both_at_rest_break_away_one_or_both() {
        let f = friction(4.75e-5);
        let a = f.inertia.a;
        let b = f.inertia.b;
        // Within static friction: held.
        assert_eq!(
            f.grip([0.0; 2], [false; 2], || [0.01, -0.01]),
            [Grip::Held; 2]
        );
        // One strong wheel, the other unpowered: alone while the pull is below τ_c.
        let weak = 0.01 + 0.5 * 0.01 * a / b;
        assert_eq!(
            f.grip([0.0; 2], [false; 2], || [weak, 0.0]),
            [Grip::Slides(-0.01), Grip::Held]
        );
        // Strong enough to drag the other one: both go, the other backwards (b > 0).
        let strong = 0.01 + 1.5 * 0.01 * a / b;
        let grip = f.grip([0.0; 2], [false; 2], || [strong, 0.0]);
        assert_eq!(grip, [Grip::Slides(-0.01), Grip::Slides(0.01)]);
        // Unless that one is jammed.
        assert_eq!(
            f.grip([0.0; 2], [false, true], || [strong, 0.0]),
            [Grip::Slides(-0.01), Grip::Held]
        );
        // Both driven forward hard: both slide forward.
        assert_eq!(
            f.grip([0.0; 2], [false; 2], || [0.1, 0.1]),
            [Grip::Slides(-0.01); 2]
        );
    }
}
