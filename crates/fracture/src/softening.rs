//! Softening (cohesive) springs: quasi-brittle materials with a process zone.
//!
//! # The law
//!
//! A softening spring carries its elastic force up to a peak stretch `s_p`, then loses
//! stiffness as it is stretched further, and carries nothing past a final stretch `s_f`. Its
//! state is a damage weight `w` in `[0, 1]`: it acts with stiffness `w k` everywhere, in its own
//! force and in the dispersion (its pool share `w k L dL`, its nodes' normalisers
//! `S_n = sum_t w_t k_t L_t^2`; [`hooke_core::state::Springs`]). With `kappa` the largest stretch
//! the spring has seen, the envelope of its direct force per `k L` is `s_p g(kappa)`, and
//!
//! ```text
//! w(kappa) = 1                          kappa <= s_p
//! w(kappa) = s_p g(kappa) / kappa       s_p < kappa < s_f
//! w(kappa) = 0                          kappa >= s_f   (the spring is broken)
//!
//! linear:    g = (s_f - kappa) / (s_f - s_p)
//! bilinear:  g falls linearly from 1 at s_p to 1/3 at s_k = s_p + 2/9 (s_f - s_p), then to 0 at
//!            s_f (Petersson's concrete curve: the knee at f_t/3, 0.8 G_f/f_t of an opening of
//!            3.6 G_f/f_t)
//! ```
//!
//! Damage is irreversible (`w` only falls), so unloading goes back to the origin on the damaged
//! stiffness `w k`, and at `w = 0` the spring is removed exactly as a broken one
//! ([`hooke_core::State::soften`]): a fully softened spring *is* a broken spring.
//!
//! # Energy
//!
//! For fixed weights the law is the gradient of `U = 1/2 sum w k dL^2 + q/2 sum Pi^2/S` with
//! the weighted pools and normalisers, so between damage events energy is conserved as in the
//! intact material. A damage event at fixed displacements lowers U; [`crate::Fracture`] books
//! that drop, `U(w) - U(w')` over the touched springs and nodes, as released energy, exactly,
//! the way it books a break. A spring taken from 0 to `s_f` under its own stretch dissipates its
//! direct work
//!
//! ```text
//! E_s = k L^2 (s_p^2 / 2 + c s_p (s_f - s_p)),      c = 1/2 (linear), 5/18 (bilinear)
//! ```
//!
//! # Stability for any damage state
//!
//! The stiffness at weights `w` is `K(w) = K_direct(w) + K_disp(w)`. By Cauchy-Schwarz,
//! `Pi_n^2 = (sum w k L dL)^2 <= (sum w k L^2)(sum w k dL^2) = S_n sum_t w k dL^2`, so
//! `q/2 sum_n Pi_n^2/S_n <= q sum_s w_s k_s dL_s^2` (each spring has two ends) and, for `q >= 0`,
//! `U(w) <= (1 + 2q) U_plain(w) <= (1 + 2q) U_plain(1)`: every weight lowers the plain energy,
//! a sum of non-negative terms. For `q < 0`, `U(w) <= U_plain(w) <= U_plain(1)`. The largest
//! eigenvalue of `M^-1 K(w)` is therefore bounded by `(1 + 2 max(q, 0)) lambda_plain` of the
//! undamaged body, the bound the damage-proof stable step already uses for broken springs
//! ([`hooke_core::stability`]): a softening run is stable in every damage state with the step it
//! starts with (tested with eigenvalues in `tests/softening.rs`).
//!
//! # Calibration from G_f and f_t
//!
//! In an affinely strained body an axial spring of a uniaxially stressed bar stretches by
//! exactly `sigma / E`, so `s_p = f_t / E` would be the natural peak stretch. A lattice body is
//! not that: its springs soften one by one, and a bar whose springs peak at `s_p` carries a
//! peak stress `S E s_p`, with `S` from 1.6 (long softening tails: damage spreads while the bar
//! still hardens) to 0.8 (nearly brittle springs: the first to fail, stretched past the affine
//! value by the network's scatter, start a crack). Where `S` is measured ([`strength_factor`]:
//! random3d and random2d) the springs peak at `s_p = f_t / (E S)` and the body's strength is
//! f_t; elsewhere `S = 1`. The final stretch
//! comes from the fracture energy. A spring taken through its whole curve dissipates what a
//! brittle spring breaking at the *equivalent stretch* `s_eq` takes with it,
//! `s_eq^2 = s_p^2 + 2 c s_p (s_f - s_p)`. A brittle crack dissipates
//! `G_brittle(s_eq) = Gamma k s_eq^2` ([`crate::stretch`], lattice trapping included); a
//! softening crack dissipates a measured fraction of that,
//!
//! ```text
//! G = F(nu, rho) G_brittle(s_eq),      rho = s_p / s_eq      (the peak fraction)
//! ```
//!
//! measured on the strip ([`crate::toughness`], `hooke toughness --criterion softening`) and
//! tabulated below ([`toughness_factor`]). F is about 1 for nearly brittle springs (`rho` near
//! 1; the jumps between equilibria still trap) and falls to 0.3-0.7 for `rho` <= 0.7, where the
//! softening springs release their energy gradually and the lattice no longer traps: a softening
//! crack dissipates 1.2-1.4 times the uniform-stretch count of the springs across it at nu >= 0,
//! more on auxetic lattices. The builder solves `F(nu, rho) G_brittle(s_eq) = G_f` with
//! `s_eq = f_t / (E S(nu, rho) rho)` for the peak fraction `rho` (bisection), and sets
//! `s_f = s_p + (s_eq^2 - s_p^2) / (2 c s_p)`.
//!
//! **Range.** The tables span nu (nu_2D in 2D) in [-0.5, 0.25] and `rho` in [0.35, 0.9].
//! Longer tails (`rho` < 0.35, a characteristic length many spacings long) have process zones
//! longer than the measuring strips, and hex lattices above nu_2D = 0.4 grow their softening
//! cracks off the plane; outside the tables the edge values are used and `hooke check` says so.
//! The bilinear curve's value at `rho` = 0.35 did not reach steady growth in the strips and is
//! held at its `rho` = 0.5 value.
//!
//! A strength too high for the toughness at this lattice spacing (`s_p >= s_eq`: the spring
//! would have to snap back) is refused with the fix: a lower f_t, a higher G_f or a finer
//! lattice (the characteristic length `l_ch = E G_f / f_t^2` must be resolved by the spacing).

use hooke_core::material::nu_from_q;
use hooke_core::{LatticeKind, Real};

use crate::criterion::{Criterion, SpringState};
use crate::error::FractureError;
use crate::stretch::CriticalStretch;

/// Shape of the softening branch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SofteningShape {
    Linear,
    Bilinear,
}

impl SofteningShape {
    /// Area of the softening branch over `s_p (s_f - s_p)`: the `c` of the module docs.
    pub fn area_factor(self) -> Real {
        match self {
            SofteningShape::Linear => 0.5,
            SofteningShape::Bilinear => 5.0 / 18.0,
        }
    }

    /// Name used in case files.
    pub fn name(self) -> &'static str {
        match self {
            SofteningShape::Linear => "linear",
            SofteningShape::Bilinear => "bilinear",
        }
    }
}

/// The refusal of a strength too high for the toughness at the lattice spacing.
fn snap_back(f_t: Real) -> FractureError {
    FractureError::BadParameter {
        what: "tensile strength f_t (Pa)",
        value: f_t,
        fix: "it is too high for the fracture energy at this lattice spacing (the springs \
              would snap back: the peak stretch f_t/E reaches the stretch that alone \
              dissipates G_f); lower f_t, raise G_f, or refine the lattice until the spacing \
              is well below the characteristic length E G_f / f_t^2",
    }
}

/// Where the bilinear curve's knee lies along the softening branch, and its height.
const KNEE_AT: Real = 2.0 / 9.0;
const KNEE_HEIGHT: Real = 1.0 / 3.0;

/// A softening spring law (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Softening {
    /// Peak stretch `s_p`: the spring is elastic below it.
    pub peak: Real,
    /// Final stretch `s_f`: the spring is broken at it.
    pub last: Real,
    pub shape: SofteningShape,
}

impl Softening {
    /// The law for given peak and final stretches (`0 < s_p < s_f`).
    pub fn new(peak: Real, last: Real, shape: SofteningShape) -> Result<Self, FractureError> {
        if !(peak.is_finite() && peak > 0.0) {
            return Err(FractureError::BadParameter {
                what: "peak stretch s_p",
                value: peak,
                fix: "give a positive number, e.g. 1e-4",
            });
        }
        if !(last.is_finite() && last > peak) {
            return Err(FractureError::BadParameter {
                what: "final stretch s_f",
                value: last,
                fix: "the final stretch must exceed the peak stretch (a spring cannot snap back)",
            });
        }
        Ok(Softening { peak, last, shape })
    }

    /// The law for a tensile strength `f_t` (Pa) and fracture energy `g_f` (J/m^2) on a material
    /// of Young's modulus `e` whose brittle springs would break at `s_eq` for the same `g_f`
    /// ([`crate::CriticalStretch::stretch_for`]).
    pub fn from_strength(
        e: Real,
        f_t: Real,
        s_eq: Real,
        shape: SofteningShape,
    ) -> Result<Self, FractureError> {
        if !(f_t.is_finite() && f_t > 0.0) {
            return Err(FractureError::BadParameter {
                what: "tensile strength f_t (Pa)",
                value: f_t,
                fix: "give a positive number",
            });
        }
        let peak = f_t / e;
        if s_eq.is_nan() || s_eq <= peak {
            return Err(snap_back(f_t));
        }
        let c = shape.area_factor();
        let last = peak + (s_eq * s_eq - peak * peak) / (2.0 * c * peak);
        Self::new(peak, last, shape)
    }

    /// The law whose cracks dissipate `g_f` (J/m^2) on a lattice of kind `kind`, stiffness `k`,
    /// spacing `a`, dispersion ratio `q` and (2D) thickness `h`, for a material of Young's
    /// modulus `e` and tensile strength `f_t` (see the module docs: the peak fraction `rho`
    /// solves `G(s_eq) F(nu, rho) = g_f` with `s_eq = f_t / (E S(nu, rho) rho)`, `G` the brittle
    /// calibration, `F` the measured [`toughness_factor`] and `S` the measured
    /// [`strength_factor`], by bisection).
    #[allow(clippy::too_many_arguments)]
    pub fn from_fracture_energy(
        kind: LatticeKind,
        k: Real,
        a: Real,
        q: Real,
        h: Real,
        g_f: Real,
        e: Real,
        f_t: Real,
        shape: SofteningShape,
    ) -> Result<Self, FractureError> {
        // Validates G_f and gives the brittle stretch: s_eq when F = 1.
        let s0 = CriticalStretch::from_fracture_energy(kind, k, a, q, h, g_f)?.s_c;
        if !(f_t.is_finite() && f_t > 0.0) {
            return Err(FractureError::BadParameter {
                what: "tensile strength f_t (Pa)",
                value: f_t,
                fix: "give a positive number",
            });
        }
        let (sigma, nu) = (f_t / e, nu_from_q(kind, q));
        let strength = |rho: Real| strength_factor(kind, nu, rho, shape).unwrap_or(1.0);
        // The springs peak at s_p = sigma / S(rho), and s_eq = s_p / rho must be the stretch
        // that dissipates G_f, s0 / sqrt(F(rho)) (G scales as s^2 at a fixed peak fraction).
        // The excess falls from +inf at rho -> 0; a root below rho = 1 exists unless the
        // springs would snap back.
        let excess = |rho: Real| {
            sigma / (strength(rho) * rho) - s0 / toughness_factor(kind, nu, rho, shape).sqrt()
        };
        if !(excess(1.0) < 0.0) {
            return Err(snap_back(f_t));
        }
        let (mut lo, mut hi): (Real, Real) = (1e-6, 1.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if excess(mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let rho = 0.5 * (lo + hi);
        let f_spring = f_t / strength(rho);
        Self::from_strength(e, f_spring, f_spring / e / rho, shape).map_err(|_| snap_back(f_t))
    }

    /// The envelope `g(kappa)` of the module docs (1 at the peak, 0 at the end).
    fn envelope(&self, kappa: Real) -> Real {
        let (p, f) = (self.peak, self.last);
        match self.shape {
            SofteningShape::Linear => (f - kappa) / (f - p),
            SofteningShape::Bilinear => {
                let knee = p + KNEE_AT * (f - p);
                if kappa <= knee {
                    1.0 - (1.0 - KNEE_HEIGHT) * (kappa - p) / (knee - p)
                } else {
                    KNEE_HEIGHT * (f - kappa) / (f - knee)
                }
            }
        }
    }

    /// Damage weight after the largest stretch `kappa` (1 below the peak, 0 at the end).
    pub fn weight_at(&self, kappa: Real) -> Real {
        if kappa <= self.peak {
            1.0
        } else if kappa >= self.last {
            0.0
        } else {
            (self.peak * self.envelope(kappa) / kappa).clamp(0.0, 1.0)
        }
    }

    /// Direct work to take one spring of stiffness `k` and rest length `l` to its end (J).
    pub fn spring_energy(&self, k: Real, l: Real) -> Real {
        k * l
            * l
            * (0.5 * self.peak * self.peak
                + self.shape.area_factor() * self.peak * (self.last - self.peak))
    }

    /// The brittle stretch that dissipates what this law does per spring: `s_eq` of the module
    /// docs.
    pub fn equivalent_stretch(&self) -> Real {
        (self.peak * self.peak
            + 2.0 * self.shape.area_factor() * self.peak * (self.last - self.peak))
            .sqrt()
    }
}

/// The peak fractions `rho = s_p / s_eq` and Poisson's ratios (nu_2D for hex and random2d) of
/// the measured tables: [`TABLE_RHO`] for random2d; the regular lattices' tables have a column
/// at 0.6 as well ([`REGULAR_RHO`]).
pub const TABLE_RHO: [Real; 4] = [0.35, 0.5, 0.7, 0.9];
pub const TABLE_NU: [Real; 3] = [-0.5, 0.0, 0.25];
/// The peak fractions of the hexagonal and cubic tables: F is not monotone in `rho` between 0.5
/// and 0.7 (it dips by 4-10 % at 0.6 on the hexagonal strip, and on the cubic one rises by 5-10 %
/// at 0.6 and falls by 12 % to 0.7 at nu = 0.25), so these tables resolve it.
pub const REGULAR_RHO: [Real; 5] = [0.35, 0.5, 0.6, 0.7, 0.9];

/// Measured `F = G_measured / G_brittle(s_eq)` per lattice and shape: rows over [`TABLE_NU`],
/// columns over [`REGULAR_RHO`] (hex, cubic) or [`TABLE_RHO`] (random2d). From `hooke toughness
/// --lattice L --nu NU --criterion softening --softening S --peak-fraction RHO --height H
/// --window 6 --json` (cubic also `--depth 3`), whose `ratio` times the table's present value
/// is F: hex 16 rows; cubic 16 planes 3 deep (12 planes before: F at 14 to 20 planes agrees with
/// 16 within 2 % where 12 planes was up to 12 % off, e.g. linear nu = 0.25, rho = 0.7: 0.626 at
/// 12 planes, 0.563, 0.553, 0.551 and 0.550 at 14, 16, 18 and 20), except at rho = 0.9, where
/// the nearly brittle springs' crack leaves the plane of a 16-plane strip (7 to 78 breaks off
/// it) and the 12-plane values are kept; random2d 16 rows, a 10-spacing window (6 at some
/// points), the mean of 3 node sets, which scatter by 10-30 % at this size. Where the strip did
/// not reach steady growth (the bilinear curve at rho = 0.35, whose process zone outgrows the
/// strip) the rho = 0.5 value is held; random2d bilinear at nu_2D = 0.25 reached it only at rho
/// 0.7 and above (its rho <= 0.5 values are the nu_2D = 0 ones), and its rho = 0.9 value is the mean of
/// 6 node sets (1.21 and 0.53 for seeds 1-3 and 4-6).
const HEX_LINEAR: [[Real; 5]; 3] = [
    [0.6934, 0.6188, 0.6003, 0.6316, 0.9440],
    [0.4330, 0.3986, 0.4190, 0.5271, 0.8352],
    [0.3490, 0.3293, 0.3765, 0.4965, 0.8286],
];
const HEX_BILINEAR: [[Real; 5]; 3] = [
    [0.7125, 0.6044, 0.5809, 0.6026, 0.9455],
    [0.4143, 0.4143, 0.4379, 0.5329, 0.8722],
    [0.3529, 0.3529, 0.4135, 0.5148, 0.8034],
];
const CUBIC_LINEAR: [[Real; 5]; 3] = [
    [0.7736, 0.6740, 0.6649, 0.6500, 1.0793],
    [0.6594, 0.6453, 0.6654, 0.6323, 1.0904],
    [0.5946, 0.6405, 0.6878, 0.5527, 1.0612],
];
const CUBIC_BILINEAR: [[Real; 5]; 3] = [
    [0.7156, 0.7156, 0.7104, 0.7815, 0.9096],
    [0.6686, 0.6686, 0.6963, 0.7701, 1.0627],
    [0.6210, 0.6210, 0.6864, 0.8490, 1.0530],
];
const RANDOM2D_LINEAR: [[Real; 4]; 3] = [
    [0.4516, 0.5379, 0.5522, 0.8317],
    [0.3725, 0.2960, 0.3810, 0.6069],
    [0.3941, 0.3189, 0.3989, 0.6287],
];
const RANDOM2D_BILINEAR: [[Real; 4]; 3] = [
    [0.4029, 0.4029, 0.5069, 0.7240],
    [0.4437, 0.4437, 0.3297, 0.5320],
    [0.4437, 0.4437, 0.6498, 0.8686],
];

/// The measured toughness of softening springs over the brittle calibration at the same
/// equivalent stretch, `F(nu, rho)` (see the module docs): bilinear in nu and `rho` between the
/// table's points, held at its edges. Random3d lattices take the cubic table (their strip
/// experiment is not run), referred to the dissipation-based random3d factor
/// ([`crate::stretch::random3d_softening_reference`]).
pub fn toughness_factor(kind: LatticeKind, nu: Real, rho: Real, shape: SofteningShape) -> Real {
    use SofteningShape::{Bilinear, Linear};
    match (kind, shape) {
        (LatticeKind::Hex, Linear) => interpolate(&HEX_LINEAR, &TABLE_NU, &REGULAR_RHO, nu, rho),
        (LatticeKind::Hex, Bilinear) => {
            interpolate(&HEX_BILINEAR, &TABLE_NU, &REGULAR_RHO, nu, rho)
        }
        (LatticeKind::Random2d, Linear) => {
            interpolate(&RANDOM2D_LINEAR, &TABLE_NU, &TABLE_RHO, nu, rho)
        }
        (LatticeKind::Random2d, Bilinear) => {
            interpolate(&RANDOM2D_BILINEAR, &TABLE_NU, &TABLE_RHO, nu, rho)
        }
        (LatticeKind::Random3d, _) => {
            toughness_factor(LatticeKind::Cubic, nu, rho, shape)
                * crate::stretch::random3d_softening_reference(nu)
        }
        (_, Linear) => interpolate(&CUBIC_LINEAR, &TABLE_NU, &REGULAR_RHO, nu, rho),
        (_, Bilinear) => interpolate(&CUBIC_BILINEAR, &TABLE_NU, &REGULAR_RHO, nu, rho),
    }
}

/// Bilinear interpolation in a table over sorted axes `nus` (rows) and `rhos` (columns), held at
/// the edges.
fn interpolate<const N: usize, const M: usize>(
    t: &[[Real; M]; N],
    nus: &[Real; N],
    rhos: &[Real; M],
    nu: Real,
    rho: Real,
) -> Real {
    // Position in a sorted axis: the cell's first index and the weight of the next point.
    let locate = |axis: &[Real], x: Real| -> (usize, Real) {
        if x.is_nan() || x <= axis[0] {
            return (0, 0.0);
        }
        let n = axis.len();
        if x >= axis[n - 1] {
            return (n - 2, 1.0);
        }
        let i = axis.partition_point(|&v| v <= x) - 1;
        (i, (x - axis[i]) / (axis[i + 1] - axis[i]))
    };
    let (i, u) = locate(nus, nu);
    let (j, v) = locate(rhos, rho);
    let row = |r: &[Real; M]| r[j] + v * (r[j + 1] - r[j]);
    row(&t[i]) + u * (row(&t[i + 1]) - row(&t[i]))
}

/// Whether `F` was measured at this nu and peak fraction (inside the tables), so G_f is met
/// within the calibration's accuracy; outside, the edge values are used and `hooke check` says
/// so. Random3d is never measured.
pub fn calibrated(kind: LatticeKind, nu: Real, rho: Real) -> bool {
    kind != LatticeKind::Random3d
        && (TABLE_NU[0] - 1e-9..=TABLE_NU[2] + 1e-9).contains(&nu)
        && (TABLE_RHO[0] - 1e-9..=TABLE_RHO[3] + 1e-9).contains(&rho)
}

/// The peak fractions of the strength tables.
pub const STRENGTH_RHO: [Real; 6] = [0.1, 0.2, 0.35, 0.5, 0.7, 0.9];

/// Measured strength factor `S = sigma_max / (E s_p)`: the peak stress of a bar in uniaxial
/// tension whose springs peak at the stretch `s_p`, over the stress at which an axial spring of
/// an affinely strained body would reach it. Rows over [`TABLE_NU`], columns over
/// [`STRENGTH_RHO`]. A bar 10 spacings square and 40 long, grips on its ends (axial motion and
/// the lateral ones held), pulled at a strain rate of 0.1/s with damping 2000/s (halving the
/// rate moves S by 0.5 %); one node set, a second one within 0.5 %. S > 1 where the springs
/// soften gradually (`rho` small: the bar keeps hardening while damage spreads), S < 1 for
/// nearly brittle springs (the first springs to fail, stretched beyond the affine value by the
/// network's non-affine scatter, start a crack that runs). The values are those of a bar of this
/// size: for nearly brittle springs strength falls with the stressed volume (weakest link).
const RANDOM3D_STRENGTH_LINEAR: [[Real; 6]; 3] = [
    [1.509, 1.482, 1.411, 1.259, 1.031, 0.904],
    [1.760, 1.524, 1.289, 1.110, 0.932, 0.832],
    [1.566, 1.406, 1.208, 1.048, 0.905, 0.824],
];
const RANDOM3D_STRENGTH_BILINEAR: [[Real; 6]; 3] = [
    [1.502, 1.461, 1.337, 1.170, 1.013, 0.919],
    [1.681, 1.427, 1.184, 1.032, 0.919, 0.818],
    [1.517, 1.328, 1.116, 0.977, 0.893, 0.827],
];

/// Random2d (nu_2D rows; the default sampler, plane stress): a bar 10 spacings wide and 40
/// long, otherwise as random3d; the mean of two node sets, which differ by up to 5 %.
const RANDOM2D_STRENGTH_LINEAR: [[Real; 6]; 3] = [
    [1.344, 1.315, 1.241, 1.102, 0.960, 0.893],
    [1.254, 1.130, 1.008, 0.903, 0.817, 0.805],
    [1.083, 1.013, 0.917, 0.821, 0.792, 0.785],
];
const RANDOM2D_STRENGTH_BILINEAR: [[Real; 6]; 3] = [
    [1.337, 1.292, 1.166, 1.040, 0.922, 0.887],
    [1.212, 1.082, 0.947, 0.859, 0.810, 0.803],
    [1.060, 0.986, 0.862, 0.809, 0.783, 0.786],
];

/// The measured strength factor `S(nu, rho)` of softening springs (`None` where it has not been
/// measured: the regular hex and cubic lattices, whose strength also depends on the load's
/// direction; their springs peak at f_t / E), bilinear in
/// nu and `rho` between the table's points and held at its edges. Given a tensile strength f_t,
/// [`Softening::from_fracture_energy`] sets `s_p = f_t / (E S)`, so that a body's tensile
/// strength is f_t.
pub fn strength_factor(
    kind: LatticeKind,
    nu: Real,
    rho: Real,
    shape: SofteningShape,
) -> Option<Real> {
    let t = match (kind, shape) {
        (LatticeKind::Random3d, SofteningShape::Linear) => &RANDOM3D_STRENGTH_LINEAR,
        (LatticeKind::Random3d, SofteningShape::Bilinear) => &RANDOM3D_STRENGTH_BILINEAR,
        (LatticeKind::Random2d, SofteningShape::Linear) => &RANDOM2D_STRENGTH_LINEAR,
        (LatticeKind::Random2d, SofteningShape::Bilinear) => &RANDOM2D_STRENGTH_BILINEAR,
        _ => return None,
    };
    Some(interpolate(t, &TABLE_NU, &STRENGTH_RHO, nu, rho))
}

impl Criterion for Softening {
    fn name(&self) -> &'static str {
        "softening"
    }

    fn breaks(&self, s: &SpringState) -> bool {
        s.stretch() >= self.last * s.strength
    }

    fn screen(&self) -> Option<Real> {
        Some(self.peak)
    }

    fn weight(&self, s: &SpringState, w: Real) -> Real {
        // (x / 1 is x: a spring of factor 1 keeps the bits of the law without factors.)
        w.min(self.weight_at(s.stretch() / s.strength))
    }

    fn as_softening(&self) -> Option<&Softening> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_curves_have_the_stated_areas_and_are_monotone() {
        for shape in [SofteningShape::Linear, SofteningShape::Bilinear] {
            let s = Softening::new(1e-4, 1e-3, shape).unwrap();
            // Integrate the force envelope w(e) e by the trapezoid rule.
            let n = 200_000;
            let h = 1.2e-3 / n as Real;
            let mut area = 0.0;
            let mut last_w = 1.0;
            for i in 0..n {
                let (a, b) = (i as Real * h, (i + 1) as Real * h);
                area += 0.5 * h * (s.weight_at(a) * a + s.weight_at(b) * b);
                let w = s.weight_at(b);
                assert!(w <= last_w, "weight rises at {b}");
                last_w = w;
            }
            let exact = s.spring_energy(1.0, 1.0);
            assert!(
                (area - exact).abs() < 1e-6 * exact,
                "{shape:?}: {area} vs {exact}"
            );
            // The force is continuous at the peak and zero at the end.
            assert!((s.weight_at(1e-4 * (1.0 + 1e-12)) - 1.0).abs() < 1e-9);
            assert_eq!(s.weight_at(1e-3), 0.0);
        }
        let b = Softening::new(1e-4, 1e-3, SofteningShape::Bilinear).unwrap();
        let knee = 1e-4 + KNEE_AT * 9e-4;
        assert!((b.weight_at(knee) * knee / 1e-4 - 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn calibration_keeps_the_equivalent_energy_and_refuses_snap_back() {
        let e = 30e9;
        for shape in [SofteningShape::Linear, SofteningShape::Bilinear] {
            let s = Softening::from_strength(e, 3e6, 5e-4, shape).unwrap();
            assert!((s.peak - 1e-4).abs() < 1e-18);
            assert!((s.equivalent_stretch() - 5e-4).abs() < 1e-15);
        }
        let err = Softening::from_strength(e, 3e7, 5e-4, SofteningShape::Linear).unwrap_err();
        assert!(err.to_string().contains("snap back"), "{err}");
        assert!(Softening::new(2e-4, 1e-4, SofteningShape::Linear).is_err());
        assert!(Softening::new(0.0, 1e-4, SofteningShape::Linear).is_err());
    }

    /// The law built from G_f and f_t satisfies both equations it solves: the body's strength
    /// `E S(rho) s_p = f_t` and `F(rho) G_brittle(s_eq) = G_f`, at the peak fraction it lands
    /// on; a lattice without a strength table peaks at f_t / E.
    #[test]
    fn calibration_meets_strength_and_fracture_energy() {
        use hooke_core::material::q_from_nu;
        let (e, f_t, g_f, a) = (25.85e9, 2.7e6, 65.0, 5e-3);
        for (kind, nu) in [
            (LatticeKind::Random3d, 0.18),
            (LatticeKind::Random2d, -0.2),
            (LatticeKind::Cubic, 0.1),
        ] {
            let q = q_from_nu(kind, nu).unwrap();
            // A spring stiffness of the right order (k ~ E a); the equations hold for any.
            let k = e * a;
            for shape in [SofteningShape::Linear, SofteningShape::Bilinear] {
                let law = Softening::from_fracture_energy(kind, k, a, q, 1.0, g_f, e, f_t, shape)
                    .unwrap();
                let rho = law.peak / law.equivalent_stretch();
                let s = strength_factor(kind, nu, rho, shape);
                assert_eq!(s.is_some(), kind != LatticeKind::Cubic);
                let strength = e * s.unwrap_or(1.0) * law.peak;
                assert!(
                    (strength / f_t - 1.0).abs() < 1e-9,
                    "{kind:?} {shape:?}: {strength}"
                );
                let g = toughness_factor(kind, nu, rho, shape)
                    * CriticalStretch::fracture_energy(
                        kind,
                        k,
                        a,
                        q,
                        1.0,
                        law.equivalent_stretch(),
                    );
                assert!((g / g_f - 1.0).abs() < 1e-6, "{kind:?} {shape:?}: G = {g}");
            }
        }
        // Snap-back is still refused, naming the user's f_t.
        let q = q_from_nu(LatticeKind::Random3d, 0.18).unwrap();
        let err = Softening::from_fracture_energy(
            LatticeKind::Random3d,
            25.85e9 * 5e-3,
            5e-3,
            q,
            1.0,
            0.01,
            25.85e9,
            2e9,
            SofteningShape::Linear,
        )
        .unwrap_err();
        assert!(err.to_string().contains("snap back") && err.to_string().contains("2000000000"));
    }

    #[test]
    fn damage_is_irreversible() {
        let s = Softening::new(1e-4, 1e-3, SofteningShape::Linear).unwrap();
        let at = |stretch: Real| SpringState {
            k: 1.0,
            rest: 1.0,
            lever: 1.0,
            dir: [1.0, 0.0, 0.0],
            dl: stretch,
            pool: [0.0; 2],
            q: 0.0,
            strength: 1.0,
        };
        let w1 = s.weight(&at(4e-4), 1.0);
        assert!(w1 < 1.0 && w1 > 0.0);
        // Unloading keeps the weight; reloading past the old maximum lowers it further.
        assert_eq!(s.weight(&at(1e-4), w1), w1);
        assert_eq!(s.weight(&at(-1e-3), w1), w1);
        assert!(s.weight(&at(5e-4), w1) < w1);
        assert_eq!(s.weight(&at(2e-3), w1), 0.0);
    }
}
