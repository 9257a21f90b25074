//! Classic RK4 for the wheels' affine dynamics, in closed form.
//!
//! Away from rest and from the points where a wheel's current changes sign, the wheel
//! speeds obey ω̇ = A ω + b with A = −M⁻¹ diag(D_l, D_r) (D the damping of each wheel's
//! power-flow regime) and b constant. With z = A ω + b (= k₁, the acceleration at the
//! start of the step), the four RK4 stages collapse to
//!
//! - ω⁺ = ω + S z,  S = h (I + hA/2 + (hA)²/6 + (hA)³/24),
//! - Δφ = h ω + T z, T = (h²/6) (3I + hA + (hA)²/4),
//!
//! that is ω⁺ = (I + SA) ω + S b and Δφ = (hI + TA) ω + T b: the same arithmetic as four
//! stage evaluations, in 2 × 2 matrices computed once per step size and regime (and S b,
//! T b once per regime and bridge state). [`Propagator::reach`] bounds how far any RK4
//! stage point of the step can have been from ω, from the step's own speed change, so the
//! caller can check that the whole step stayed in one regime.
//!
//! The exact solution has the same shape with the series summed to the end:
//! S = Φ(h) = ∫₀ʰ e^{As} ds = h Σₖ (hA)ᵏ/(k+1)! and T = Ψ(h) = ∫₀ʰ Φ(s) ds =
//! h² Σₖ (hA)ᵏ/(k+2)! ([`Propagator::exact`]), so one step covers a whole control period
//! without error while it stays in one regime.

/// A 2 × 2 matrix, row-major.
pub(crate) type Mat2 = [[f64; 2]; 2];

fn mat_mul(a: &Mat2, b: &Mat2) -> Mat2 {
    [
        [
            a[0][0] * b[0][0] + a[0][1] * b[1][0],
            a[0][0] * b[0][1] + a[0][1] * b[1][1],
        ],
        [
            a[1][0] * b[0][0] + a[1][1] * b[1][0],
            a[1][0] * b[0][1] + a[1][1] * b[1][1],
        ],
    ]
}

fn mat_lin(terms: &[(f64, &Mat2)]) -> Mat2 {
    let mut out = [[0.0; 2]; 2];
    for (k, m) in terms {
        for (out_row, m_row) in out.iter_mut().zip(m.iter()) {
            for (o, x) in out_row.iter_mut().zip(m_row.iter()) {
                *o += k * x;
            }
        }
    }
    out
}

#[inline]
pub(crate) fn mat_vec(m: &Mat2, v: [f64; 2]) -> [f64; 2] {
    [
        m[0][0] * v[0] + m[0][1] * v[1],
        m[1][0] * v[0] + m[1][1] * v[1],
    ]
}

/// The closed-form RK4 step of one regime (one pair of wheel dampings) and step size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Propagator {
    /// I + S A: ω⁺ = (I + SA) ω + S b.
    p_w: Mat2,
    /// S.
    s: Mat2,
    /// h I + T A: Δφ = (hI + TA) ω + T b.
    q_w: Mat2,
    /// T.
    t: Mat2,
    /// How far the step's path can have strayed from ω per unit of its speed change:
    /// see [`Propagator::reach`] (∞ when the bound does not hold).
    reach_per_change: f64,
}

/// Terms of the exact series summed: with α = h‖A‖∞ ≤ 1.25 (beyond, [`Propagator::exact`]
/// refuses every step) the first term left out is below α²⁰/21! < 1e-16 of the first.
const EXACT_TERMS: i32 = 20;

/// The identity.
const IDENTITY: Mat2 = [[1.0, 0.0], [0.0, 1.0]];

/// hA = −h M⁻¹ diag(D) for M⁻¹ = [[p, q], [q, p]] and dampings D: column j scaled by D_j.
fn scaled_a(inv_p: f64, inv_q: f64, damping: [f64; 2], h: f64) -> Mat2 {
    [
        [-h * inv_p * damping[0], -h * inv_q * damping[1]],
        [-h * inv_q * damping[0], -h * inv_p * damping[1]],
    ]
}

/// ‖m‖∞, the largest row sum of absolute values.
fn norm_inf(m: &Mat2) -> f64 {
    m.iter()
        .map(|row| row[0].abs() + row[1].abs())
        .fold(0.0, f64::max)
}

impl Propagator {
    /// For M⁻¹ = [[p, q], [q, p]] (1/(kg·m²)), wheel dampings `damping` [left, right]
    /// (N·m·s/rad) and step `h` (s).
    pub(crate) fn new(inv_p: f64, inv_q: f64, damping: [f64; 2], h: f64) -> Self {
        let i = IDENTITY;
        let ha = scaled_a(inv_p, inv_q, damping, h);
        let ha2 = mat_mul(&ha, &ha);
        let ha3 = mat_mul(&ha2, &ha);
        let s = mat_lin(&[(h, &i), (h / 2.0, &ha), (h / 6.0, &ha2), (h / 24.0, &ha3)]);
        let t = mat_lin(&[(h * h / 2.0, &i), (h * h / 6.0, &ha), (h * h / 24.0, &ha2)]);
        let alpha = norm_inf(&ha);
        let e = alpha / 2.0 + alpha * alpha / 6.0 + alpha * alpha * alpha / 24.0;
        let reach_per_change = if alpha < 1.0 {
            1.0 / ((1.0 - e) * (1.0 - alpha))
        } else {
            f64::INFINITY
        };
        Self::from_integrals(h, &ha, s, t, reach_per_change)
    }

    /// The exact step of `h` (s) for M⁻¹ = [[p, q], [q, p]] and wheel dampings `damping`,
    /// as [`Propagator::new`] (module doc); its [`Propagator::reach`] bounds the exact
    /// path over the whole step.
    ///
    /// For 0 ≤ t ≤ h, ω(t) − ω = Φ(t) z with ‖Φ(t)‖∞ ≤ h e^α; and ω⁺ − ω = Φ(h) z =
    /// h (I + E) z with ‖E‖∞ ≤ e = (e^α − 1)/α − 1, so with e < 1 every point of the path
    /// lies within e^α ‖ω⁺ − ω‖∞ / (1 − e) of ω.
    pub(crate) fn exact(inv_p: f64, inv_q: f64, damping: [f64; 2], h: f64) -> Self {
        let ha = scaled_a(inv_p, inv_q, damping, h);
        // Φ/h = Σ (hA)ᵏ/(k+1)!, Ψ/h² = Σ (hA)ᵏ/(k+2)!, summed from the smallest terms up.
        let mut powers = [IDENTITY; EXACT_TERMS as usize];
        for k in 1..powers.len() {
            powers[k] = mat_mul(&powers[k - 1], &ha);
        }
        let factorial = |n: i32| (1..=n).map(f64::from).product::<f64>();
        let (mut phi, mut psi) = ([[0.0; 2]; 2], [[0.0; 2]; 2]);
        for (k, power) in (0..EXACT_TERMS).zip(powers.iter()).rev() {
            phi = mat_lin(&[(1.0, &phi), (h / factorial(k + 1), power)]);
            psi = mat_lin(&[(1.0, &psi), (h * h / factorial(k + 2), power)]);
        }
        let alpha = norm_inf(&ha);
        let e = if alpha > 0.0 {
            alpha.exp_m1() / alpha - 1.0
        } else {
            0.0
        };
        let reach_per_change = if e < 1.0 && alpha <= 1.25 {
            alpha.exp() / (1.0 - e)
        } else {
            f64::INFINITY
        };
        Self::from_integrals(h, &ha, phi, psi, reach_per_change)
    }

    /// The step from its integrals S and T of step `h` (s) and hA: ω⁺ = (I + SA) ω + S b,
    /// Δφ = (hI + TA) ω + T b.
    fn from_integrals(h: f64, ha: &Mat2, s: Mat2, t: Mat2, reach_per_change: f64) -> Self {
        // S A = S (hA) / h, T A likewise (h = 0 gives the identity and zeros).
        let (sa, ta) = if h > 0.0 {
            (
                mat_lin(&[(1.0 / h, &mat_mul(&s, ha))]),
                mat_lin(&[(1.0 / h, &mat_mul(&t, ha))]),
            )
        } else {
            ([[0.0; 2]; 2], [[0.0; 2]; 2])
        };
        Self {
            p_w: mat_lin(&[(1.0, &IDENTITY), (1.0, &sa)]),
            s,
            q_w: mat_lin(&[(h, &IDENTITY), (1.0, &ta)]),
            t,
            reach_per_change,
        }
    }

    /// The forcing terms (S b, T b) for the constant part b of ω̇ = A ω + b, rad/s and rad.
    pub(crate) fn forcing(&self, b: [f64; 2]) -> ([f64; 2], [f64; 2]) {
        (mat_vec(&self.s, b), mat_vec(&self.t, b))
    }

    /// (ω⁺, Δφ) from ω and the forcing terms S b, T b of [`Propagator::forcing`].
    #[inline]
    pub(crate) fn step(&self, w: [f64; 2], sb: [f64; 2], tb: [f64; 2]) -> ([f64; 2], [f64; 2]) {
        let pw = mat_vec(&self.p_w, w);
        let qw = mat_vec(&self.q_w, w);
        (
            [pw[0] + sb[0], pw[1] + sb[1]],
            [qw[0] + tb[0], qw[1] + tb[1]],
        )
    }

    /// The farthest (rad/s, per component) that any RK4 stage point or the end point of a
    /// step can have been from its start ω, given the step's speed change `change` = ω⁺ − ω
    /// (for an [`Propagator::exact`] step: any point of the exact path).
    ///
    /// With z = A ω + b, K = ‖z‖∞ and α = h‖A‖∞ < 1, every stage acceleration is
    /// k_j = z + A(ω_j − ω); if ‖ω_j − ω‖∞ ≤ Δ then ‖k_j‖∞ ≤ K + ‖A‖∞Δ, and the next stage
    /// point (at most a full step h along k_j) is within h(K + ‖A‖∞Δ) = hK + αΔ of ω:
    /// Δ = hK / (1 − α) is the fixed point, so by induction every stage stays within Δ.
    /// K itself follows from the change: ω⁺ − ω = S z = h (I + E) z with ‖E‖∞ ≤ e < 1, so
    /// K ≤ ‖ω⁺ − ω‖∞ / (h (1 − e)).
    #[inline]
    pub(crate) fn reach(&self, change: [f64; 2]) -> f64 {
        self.reach_per_change * change[0].abs().max(change[1].abs())
    }
}
