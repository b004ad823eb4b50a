//! Transversely isotropic materials by non-uniform dispersion (beyond the paper: its closing
//! section names direction-dependent dispersion as the way to anisotropy).
//!
//! # The law
//! Each spring `s` gets a direction weight `w_s = w(n_s)` and the isotropic law's rest length is
//! replaced, wherever the law pools or disperses, by the *lever* `lambda_s = w_s L_s`
//! ([`Body::lever`]):
//!
//! ```text
//! Pi_n = sum_t w_t k_t L_t dL_t      S_n = sum_t w_t^2 k_t L_t^2      p_n = Pi_n / S_n
//! U    = 1/2 sum_s k_s dL_s^2 + q/2 sum_n Pi_n^2 / S_n
//! T_s  = dU/d(dL_s) = k_s dL_s + q k_s w_s L_s (p_i + p_j)
//! ```
//!
//! The law is still the gradient of an energy (momentum and energy are conserved as for the
//! isotropic law), and Cauchy-Schwarz with the factors `(w_t sqrt(k_t) L_t)(sqrt(k_t) dL_t)`
//! gives `Pi_n^2 <= S_n sum_t k_t dL_t^2` for *any* real weights and any damage state, so the
//! isotropic law's stability bounds and its damage-proof step hold unchanged
//! (`docs/anisotropy.md`).
//!
//! # The bulk stiffness
//! Under a uniform strain `e`, `dL_t = L_t n_t.e.n_t`, so `Pi_n = A : e` with the node's
//! weighted fabric `A = sum_t w_t k_t L_t^2 n_t n_t` (over its 18 springs) and
//!
//! ```text
//! C = (1/V) sum_{unique s} k_s L_s^2 n n n n   +   q/(S V) A (x) A          (V = a^3)
//! ```
//!
//! The spring part is totally symmetric (Cauchy's relations of central forces); the rank-one
//! dispersive part is what breaks them, as the isotropic `B` does.
//!
//! # On the Ladd lattice with the fibre `m` along a lattice axis
//! The 9 spring directions fall in four families: the axis along `m` (k_1), the two axes across
//! it (k_2), the two face diagonals across it (k_3), the four diagonals with a component along
//! it (k_4). With fibre axis 3 and engineering constants `C_11, C_12, C_13, C_33, C_44`
//! (`C_66 = (C_11 - C_12)/2`):
//!
//! ```text
//! C_44 = k_4/a                        C_66 = k_3/a                 in-plane isotropy: k_2 + k_4 = 2 k_3
//! C_11 = (k_2 + k_3 + k_4)/a + R      C_12 = k_3/a + R             R = q A_11^2 / (S V)
//! C_13 = k_4/a + R rho                C_33 = (k_1 + 2 k_4)/a + R rho^2,   rho = A_33 / A_11
//! ```
//!
//! so `k_4 = a C_44`, `k_3 = a C_66`, `k_2 = a (2 C_66 - C_44)`, `R = (3 C_12 - C_11)/2`,
//! `rho = (C_13 - C_44)/R` and `k_1 = a (C_33 - 2 C_44 - (C_13 - C_44)^2 / R)`. The weights
//! `w(n) = alpha (1 - c) + gamma c`, `c = (n.m)^2`, a quadratic form with the material's symmetry
//! (the form that makes `A_11` largest for a given `rho`, so `|q|` smallest), are set by `rho`,
//! and `q = R S V / A_11^2`. The isotropic material is the case `k_1 = ... = k_4 = mu a`,
//! `w = 1`, and gives the paper's `q = 0.3 (4 nu - 1)/(1 - 2 nu)`.
//!
//! # What it reaches
//! A target is reachable on this lattice exactly when
//! - `G_t < 2 G_p` (`k_2 > 0`; `G_p = E_p / (2 (1 + nu_p))` the in-plane shear modulus);
//! - `3 C_12 != C_11` unless `C_13 = C_44` (no dispersion at all, `q = 0`: a plain lattice);
//! - `C_33 - 2 C_44 > (C_13 - C_44)^2 / R` (`k_1 > 0`);
//! - `q > -1/2` (the stability limit; `q < 0` exactly when `3 C_12 < C_11`).
//!
//! Anything else is refused with the condition it breaks.

use crate::body::Body;
use crate::error::{Error, Result};
use crate::lattice::{Lattice, LatticeKind};
use crate::math::Real;

/// Lowest `q` accepted (the stability limit is `-1/2`; this keeps the margin `1 + 2q` above
/// about 1e-3, as [`crate::material::NU_MIN`] does for isotropic materials).
pub const Q_MIN: Real = -0.4995;

/// A transversely isotropic linear elastic material in SI units, in the engineering notation
/// where `p` is the plane of isotropy and `t` the fibre (symmetry) axis:
///
/// ```text
/// eps_p1 =  s_p1/E_p - nu_p s_p2/E_p - nu_tp s_t/E_t
/// eps_t  = -nu_tp (s_p1 + s_p2)/E_t  + s_t/E_t
/// gamma_pt = tau_pt / G_t              gamma_p12 = 2 (1 + nu_p) tau_p12 / E_p
/// ```
///
/// so `nu_tp` is the contraction across the fibre under tension along it (a fibre composite's
/// major Poisson's ratio, `nu_12`), and `nu_pt = nu_tp E_p / E_t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transverse {
    /// Young's modulus in the plane of isotropy, `E_p` (Pa).
    pub youngs_plane: Real,
    /// Young's modulus along the fibre, `E_t` (Pa).
    pub youngs_fibre: Real,
    /// Poisson's ratio in the plane of isotropy, `nu_p`.
    pub poisson_plane: Real,
    /// Contraction across the fibre under tension along it, `nu_tp`.
    pub poisson_fibre: Real,
    /// Shear modulus of planes that hold the fibre, `G_t` (Pa).
    pub shear_fibre: Real,
    /// Mass density (kg/m^3).
    pub density: Real,
    /// Fibre direction (any length; normalised where used).
    pub fibre: [Real; 3],
}

fn out_of_range(what: &'static str, value: Real, why: impl Into<String>) -> Error {
    Error::OutOfRange {
        what,
        value,
        why: why.into(),
    }
}

impl Transverse {
    /// The same material isotropic: `E_p = E_t = E`, `nu_p = nu_tp = nu`, `G_t = E/(2(1+nu))`.
    pub fn isotropic(youngs: Real, poisson: Real, density: Real, fibre: [Real; 3]) -> Self {
        Transverse {
            youngs_plane: youngs,
            youngs_fibre: youngs,
            poisson_plane: poisson,
            poisson_fibre: poisson,
            shear_fibre: youngs / (2.0 * (1.0 + poisson)),
            density,
            fibre,
        }
    }

    /// The unit fibre direction.
    pub fn axis(&self) -> Result<[Real; 3]> {
        let m = self.fibre;
        let n = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        if !(n.is_finite() && n > 0.0) {
            return Err(Error::InvalidInput {
                what: "fibre direction",
                why: format!("{m:?} has no direction: give a non-zero vector"),
            });
        }
        Ok([m[0] / n, m[1] / n, m[2] / n])
    }

    /// Check that the constants describe a material at all (a positive definite stiffness):
    /// positive moduli and density, `-1 < nu_p < 1` and `1 - nu_p - 2 nu_tp^2 E_p / E_t > 0`.
    pub fn validate(&self) -> Result<()> {
        for (what, v) in [
            ("youngs_plane", self.youngs_plane),
            ("youngs_fibre", self.youngs_fibre),
            ("shear_fibre", self.shear_fibre),
            ("density", self.density),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(out_of_range(what, v, "must be a positive number"));
            }
        }
        let nu = self.poisson_plane;
        if !(nu.is_finite() && nu > -1.0 && nu < 1.0) {
            return Err(out_of_range(
                "poisson_plane",
                nu,
                "the in-plane Poisson's ratio must lie in (-1, 1)",
            ));
        }
        let nt = self.poisson_fibre;
        let d = 1.0 - nu - 2.0 * nt * nt * self.youngs_plane / self.youngs_fibre;
        if !(nt.is_finite() && d > 0.0) {
            let bound = ((1.0 - nu) * self.youngs_fibre / (2.0 * self.youngs_plane)).sqrt();
            return Err(out_of_range(
                "poisson_fibre",
                nt,
                format!(
                    "no material has |nu_tp| >= sqrt((1 - nu_p) E_t / (2 E_p)) = {bound:.4} (its stiffness would not be positive definite)"
                ),
            ));
        }
        self.axis().map(|_| ())
    }

    /// The stiffness in the material's own axes (fibre along axis 3), Voigt order xx, yy, zz,
    /// yz, xz, xy with engineering shears: the inverse of the compliance above.
    pub fn local_stiffness(&self) -> [[Real; 6]; 6] {
        let (ep, et) = (self.youngs_plane, self.youngs_fibre);
        let (np, ntp) = (self.poisson_plane, self.poisson_fibre);
        // The normal block of the compliance, inverted (positive definite when `validate`
        // passes).
        let s11 = 1.0 / ep;
        let s12 = -np / ep;
        let s13 = -ntp / et;
        let s33 = 1.0 / et;
        let block = crate::math::Matrix::new(s11, s12, s13, s12, s11, s13, s13, s13, s33);
        let inv = block
            .try_inverse()
            .unwrap_or_else(|| crate::math::Matrix::from_element(Real::NAN));
        let (c11, c12, c13, c33) = (inv[(0, 0)], inv[(0, 1)], inv[(0, 2)], inv[(2, 2)]);
        let mut c = [[0.0; 6]; 6];
        c[0][0] = c11;
        c[1][1] = c11;
        c[0][1] = c12;
        c[1][0] = c12;
        c[0][2] = c13;
        c[2][0] = c13;
        c[1][2] = c13;
        c[2][1] = c13;
        c[2][2] = c33;
        c[3][3] = self.shear_fibre;
        c[4][4] = self.shear_fibre;
        c[5][5] = ep / (2.0 * (1.0 + np));
        c
    }

    /// The stiffness in the global axes, the fibre along [`Transverse::fibre`] (Voigt order,
    /// engineering shears, Pa).
    pub fn stiffness(&self) -> Result<[[Real; 6]; 6]> {
        Ok(rotate(&self.local_stiffness(), &self.frame()?))
    }

    /// A right-handed frame whose third axis is the fibre (rows: the axes in the body's
    /// frame); any one will do (isotropy in the plane).
    pub fn frame(&self) -> Result<[[Real; 3]; 3]> {
        let m = self.axis()?;
        let helper = if m[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let e1 = normalise(cross(helper, m));
        let e2 = cross(m, e1);
        Ok([e1, e2, m])
    }
}

/// An orthotropic linear elastic material in SI units, in the engineering notation
/// `nu_ij = -eps_j / eps_i` under uniaxial stress along i of its material axes x, y, z:
///
/// ```text
/// S_11 = 1/E_x   S_12 = -nu_xy/E_x   S_13 = -nu_xz/E_x   S_44 = 1/G_yz
/// S_22 = 1/E_y   S_23 = -nu_yz/E_y   S_33 = 1/E_z        S_55 = 1/G_xz   S_66 = 1/G_xy
/// ```
///
/// (the minor ratios follow from symmetry, `nu_ji = nu_ij E_j / E_i`).
///
/// The material axes are `axes` in the body's frame: the body's own x, y, z
/// ([`Orthotropic::AXES`]), or any right-handed orthonormal frame, on a cubic lattice laid along
/// them ([`Orthotropic::lattice_rotation`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orthotropic {
    /// Young's moduli E_x, E_y, E_z (Pa).
    pub youngs: [Real; 3],
    /// Poisson's ratios nu_xy, nu_xz, nu_yz.
    pub poisson: [Real; 3],
    /// Shear moduli G_yz, G_xz, G_xy (Pa).
    pub shear: [Real; 3],
    /// Mass density (kg/m^3).
    pub density: Real,
    /// The material axes x, y, z as rows, each in the body's frame.
    pub axes: [[Real; 3]; 3],
}

impl Orthotropic {
    /// The body's own axes.
    pub const AXES: [[Real; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

    /// The material frame whose x axis is along `x` and whose y axis is `y` (which must be
    /// perpendicular to `x`, to 1e-6 of a radian: the pair is then made orthonormal), z their
    /// cross product.
    pub fn axes_from(x: [Real; 3], y: [Real; 3]) -> Result<[[Real; 3]; 3]> {
        let len = |v: [Real; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let (lx, ly) = (len(x), len(y));
        if !(lx.is_finite() && lx > 0.0 && ly.is_finite() && ly > 0.0) {
            return Err(Error::InvalidInput {
                what: "material axes",
                why: format!(
                    "{x:?}, {y:?}: give two non-zero directions, the material x and y axes"
                ),
            });
        }
        let ex = x.map(|v| v / lx);
        let cos = (ex[0] * y[0] + ex[1] * y[1] + ex[2] * y[2]) / ly;
        if cos.abs() > 1e-6 {
            return Err(Error::InvalidInput {
                what: "material axes",
                why: format!(
                    "{x:?} and {y:?} are not perpendicular (they are {:.6} degrees apart): the material y axis must be at right angles to x",
                    cos.clamp(-1.0, 1.0).acos().to_degrees()
                ),
            });
        }
        let ey = normalise([
            y[0] - cos * ly * ex[0],
            y[1] - cos * ly * ex[1],
            y[2] - cos * ly * ex[2],
        ]);
        Ok([ex, ey, cross(ex, ey)])
    }

    /// Whether the material axes are the body's own.
    pub fn along_body_axes(&self) -> bool {
        self.axes == Self::AXES
    }

    /// The rotation that lays a cubic lattice along the material axes (its columns are the
    /// axes): a lattice vector `v` becomes `R v` in the body.
    pub fn lattice_rotation(&self) -> crate::math::Matrix {
        let a = self.axes;
        crate::math::Matrix::new(
            a[0][0], a[1][0], a[2][0], a[0][1], a[1][1], a[2][1], a[0][2], a[1][2], a[2][2],
        )
    }

    /// The stiffness in the body's frame (Voigt order xx, yy, zz, yz, xz, xy, engineering
    /// shears, Pa): [`Orthotropic::local_stiffness`] turned by the axes.
    pub fn stiffness(&self) -> Result<[[Real; 6]; 6]> {
        let c = self.local_stiffness()?;
        if self.along_body_axes() {
            return Ok(c);
        }
        Ok(rotate(&c, &self.axes))
    }

    /// The stiffness in the material's axes: the inverse of the compliance, or why the
    /// constants describe no material (it must be positive definite).
    pub fn local_stiffness(&self) -> Result<[[Real; 6]; 6]> {
        let names = ["youngs_x", "youngs_y", "youngs_z"];
        for (name, &e) in names.iter().zip(&self.youngs) {
            if !(e.is_finite() && e > 0.0) {
                return Err(out_of_range(name, e, "must be a positive number"));
            }
        }
        for (name, &g) in ["shear_yz", "shear_xz", "shear_xy"].iter().zip(&self.shear) {
            if !(g.is_finite() && g > 0.0) {
                return Err(out_of_range(name, g, "must be a positive number"));
            }
        }
        if !(self.density.is_finite() && self.density > 0.0) {
            return Err(out_of_range(
                "density",
                self.density,
                "must be a positive number",
            ));
        }
        let [ex, ey, ez] = self.youngs;
        let [nxy, nxz, nyz] = self.poisson;
        let block = crate::math::Matrix::new(
            1.0 / ex,
            -nxy / ex,
            -nxz / ex,
            -nxy / ex,
            1.0 / ey,
            -nyz / ey,
            -nxz / ex,
            -nyz / ey,
            1.0 / ez,
        );
        let eig = block.symmetric_eigen().eigenvalues;
        if !(self.poisson.iter().all(|v| v.is_finite()) && eig.min() > 0.0) {
            return Err(out_of_range(
                "poisson_xy",
                nxy,
                "these Poisson's ratios describe no material: the compliance is not positive definite (each nu_ij^2 must stay below E_i / E_j, and together 1 - nu_xy nu_yx - nu_yz nu_zy - nu_xz nu_zx - 2 nu_yx nu_zy nu_xz > 0)",
            ));
        }
        let inv = block
            .try_inverse()
            .ok_or_else(|| out_of_range("poisson_xy", nxy, "the compliance is singular"))?;
        let mut c = [[0.0; 6]; 6];
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] = inv[(i, j)];
            }
            c[3 + i][3 + i] = self.shear[i];
        }
        Ok(c)
    }
}

/// The springs of the Ladd lattice for an orthotropic stiffness whose axes are the lattice's
/// (`docs/anisotropy.md`): the axis springs along x, y, z, the face diagonals in the yz, xz and
/// xy planes, their weights `w(n) = alpha . (n_x^2, n_y^2, n_z^2)`, and q.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaddFamilies {
    /// Stiffness of the axis springs along x, y, z (N/m).
    pub axis_k: [Real; 3],
    /// Stiffness of the face diagonals in the yz, xz, xy planes (N/m).
    pub diagonal_k: [Real; 3],
    /// Direction weights of the same springs (largest magnitude 1).
    pub axis_w: [Real; 3],
    pub diagonal_w: [Real; 3],
    /// Dispersion ratio.
    pub q: Real,
}

/// Why a stiffness is out of the Ladd lattice's reach ([`ladd_families`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Unreachable {
    /// The face diagonals of a plane (0: yz, 1: xz, 2: xy) would need `k <= 0` (its shear
    /// modulus is not positive).
    Diagonal(usize),
    /// The axis springs along an axis would need `k <= 0`: `C_ii - C_jj_shears - R_i^2 <= 0`.
    Axis { axis: usize, excess: Real },
    /// The Cauchy defects `D_yz = C_23 - C_44`, `D_xz = C_13 - C_55`, `D_xy = C_12 - C_66`
    /// must be those of a rank-one term `s R R^T`: all three non-zero with the same sign of
    /// their product, or only one non-zero (or none).
    Coupling([Real; 3]),
    /// The dispersion would need `q` at or below the stability limit.
    Stability(Real),
}

impl Unreachable {
    /// The reason in words.
    pub fn why(&self) -> String {
        const AX: [&str; 3] = ["x", "y", "z"];
        const PL: [&str; 3] = ["yz", "xz", "xy"];
        match *self {
            Unreachable::Diagonal(p) => format!(
                "the diagonal springs of the {} plane would need a non-positive stiffness (its shear modulus must be positive)",
                PL[p]
            ),
            Unreachable::Axis { axis, excess } => format!(
                "the springs along {} would need a negative stiffness (C_ii minus its two shear moduli minus the dispersive part is {excess:.4e} Pa): stiffen that axis, or lower its shear moduli or its coupling to the other axes",
                AX[axis]
            ),
            Unreachable::Coupling(d) => format!(
                "the Cauchy defects C23 - C44, C13 - C55, C12 - C66 = {:.4e}, {:.4e}, {:.4e} Pa are not those of one dispersive term (all three non-zero with their product's sign shared, or only one non-zero)",
                d[0], d[1], d[2]
            ),
            Unreachable::Stability(q) => format!(
                "this target needs a dispersion ratio q = {q:.4}, below the stability limit -1/2 (the dispersion would take more than the springs give)"
            ),
        }
    }
}

/// The Ladd lattice of spacing `a` whose bulk stiffness is `c` (axes along the lattice's), or
/// why there is none. With `D_1 = C23 - C44`, `D_2 = C13 - C55`, `D_3 = C12 - C66` (the Cauchy
/// defects) and `s` the sign of q, the dispersion's `s R_i R_j` must give `D_k` for each pair:
/// `s R_1^2 = D_2 D_3 / D_1` and so on. Then
///
/// ```text
/// d_yz = a C44   d_xz = a C55   d_xy = a C66          (face diagonals)
/// k_x  = a (C11 - C55 - C66 - s R_1^2)   ...          (axes)
/// ```
///
/// and the weights `alpha` solve `A = M alpha = R` (`M` from the springs' fabric), with
/// `q = s S V |R|^2 / |A|^2`.
pub fn ladd_families(
    c: &[[Real; 6]; 6],
    a: Real,
) -> std::result::Result<LaddFamilies, Unreachable> {
    let shears = [c[3][3], c[4][4], c[5][5]];
    if let Some(p) = (0..3).find(|&p| !(shears[p] > 0.0)) {
        return Err(Unreachable::Diagonal(p));
    }
    let d_k = shears.map(|g| a * g);
    let (s, r) = rank_one(c)?;
    let scale = (0..3).fold(0.0 as Real, |m, i| m.max(c[i][i].abs()));
    let defect = cauchy_defects(c);
    // Axis springs: C_ii = (k_i + the two diagonals through i)/a + s R_i^2.
    let through = [[2, 1], [2, 0], [1, 0]]; // diagonal planes holding axis i (yz=0, xz=1, xy=2)
    let mut axis_k = [0.0; 3];
    for i in 0..3 {
        let excess = c[i][i] - shears[through[i][0]] - shears[through[i][1]] - s * r[i] * r[i];
        if !(excess > 1e-12 * scale) {
            return Err(Unreachable::Axis { axis: i, excess });
        }
        axis_k[i] = a * excess;
    }
    if s == 0.0 {
        return Ok(LaddFamilies {
            axis_k,
            diagonal_k: d_k,
            axis_w: [1.0; 3],
            diagonal_w: [1.0; 3],
            q: 0.0,
        });
    }
    // The fabric of the full star, A_i = sum_t w_t k_t L_t^2 n_ti^2, is linear in alpha:
    // 2 a^2 (alpha_i k_i + sum over the two planes through i of (alpha_i + alpha_j) d_p).
    let mut m = crate::math::Matrix::zeros();
    for i in 0..3 {
        m[(i, i)] += 2.0 * a * a * axis_k[i];
        // The planes through i: with axis j, the plane normal to the third axis.
        for (j, p) in (0..3).filter(|&j| j != i).map(|j| (j, 3 - i - j)) {
            m[(i, i)] += 2.0 * a * a * d_k[p];
            m[(i, j)] += 2.0 * a * a * d_k[p];
        }
    }
    let rv = crate::math::Vector::new(r[0], r[1], r[2]);
    let alpha = m
        .try_inverse()
        .map(|mi| mi * rv)
        .ok_or(Unreachable::Coupling(defect))?;
    let big = alpha.iter().fold(0.0 as Real, |x, v| x.max(v.abs()));
    let alpha = alpha / big;
    let axis_w = [alpha[0], alpha[1], alpha[2]];
    let diagonal_w = [
        0.5 * (alpha[1] + alpha[2]),
        0.5 * (alpha[0] + alpha[2]),
        0.5 * (alpha[0] + alpha[1]),
    ];
    let fabric = m * alpha;
    // S = sum over the 18 springs of w^2 k L^2: each axis twice (L = a), each diagonal pair
    // four times (L^2 = 2 a^2).
    let sn: Real = (0..3)
        .map(|i| {
            2.0 * axis_w[i] * axis_w[i] * axis_k[i] * a * a
                + 8.0 * diagonal_w[i] * diagonal_w[i] * d_k[i] * a * a
        })
        .sum();
    let q = s * sn * a * a * a * rv.norm_squared() / fabric.norm_squared();
    if !(q.is_finite() && q > Q_MIN) {
        return Err(Unreachable::Stability(q));
    }
    Ok(LaddFamilies {
        axis_k,
        diagonal_k: d_k,
        axis_w,
        diagonal_w,
        q,
    })
}

/// The Cauchy defects `D_yz = C23 - C44`, `D_xz = C13 - C55`, `D_xy = C12 - C66` of an
/// orthotropic stiffness in its axes: what central springs alone cannot give.
pub fn cauchy_defects(c: &[[Real; 6]; 6]) -> [Real; 3] {
    [c[1][2] - c[3][3], c[0][2] - c[4][4], c[0][1] - c[5][5]]
}

/// The rank-one dispersive part `s R R^T` (normal block) that carries an orthotropic
/// stiffness's Cauchy defects: `s R_i R_j = D_k` for `{i, j, k} = {0, 1, 2}`, so
/// `s R_1^2 = D_2 D_3 / D_1` and so on, `s` the sign of the product of the defects (of the one
/// non-zero defect, or 0 when there is none). Returns `(s, R)` or why no rank-one term fits.
pub fn rank_one(c: &[[Real; 6]; 6]) -> std::result::Result<(Real, [Real; 3]), Unreachable> {
    let defect = cauchy_defects(c);
    let scale = (0..3).fold(0.0 as Real, |m, i| m.max(c[i][i].abs()));
    let tiny = |x: Real| x.abs() <= 1e-12 * scale;
    let nonzero: Vec<usize> = (0..3).filter(|&i| !tiny(defect[i])).collect();
    // r[i]: R_i (stress units), with s R_i R_j = D_k for {i, j, k} = {0, 1, 2}.
    Ok(match nonzero.len() {
        0 => (0.0, [0.0; 3]),
        1 => {
            // One plane coupled (say xy): R_x = R_y = sqrt(|D|), R_z = 0.
            let k = nonzero[0];
            let s = defect[k].signum();
            let mut r = [defect[k].abs().sqrt(); 3];
            r[k] = 0.0;
            (s, r)
        }
        2 => return Err(Unreachable::Coupling(defect)),
        _ => {
            let s = (defect[0] * defect[1] * defect[2]).signum();
            let r0 = (defect[1] * defect[2] / defect[0]).abs().sqrt();
            // s R_0 R_2 = D_1, s R_0 R_1 = D_2.
            let r1 = defect[2] / (s * r0);
            let r2 = defect[1] / (s * r0);
            (s, [r0, r1, r2])
        }
    })
}

/// What [`Body::transverse`] puts on the springs of the Ladd lattice, in the four families of a
/// fibre along a lattice axis, for output (`hooke check`, `hooke moduli --bulk`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubicFamilies {
    /// Stiffness (N/m) of the four families: the axis along the fibre, the axes across it, the
    /// diagonals across it, the diagonals with a component along it.
    pub k: [Real; 4],
    /// Direction weights `w` of the same four families (largest magnitude 1).
    pub w: [Real; 4],
    /// Dispersion ratio.
    pub q: Real,
    /// The same springs by axis and plane, in the fibre's frame (the fibre along z).
    pub ladd: LaddFamilies,
}

/// The spring constants that give a Ladd lattice of spacing `a`, one of whose axes lies along
/// the fibre, the material `t`, or why they do not exist (see the module docs for the
/// reachable set). Solved in the fibre's frame (the fibre along its z axis).
pub fn cubic_families(t: &Transverse, a: Real) -> Result<CubicFamilies> {
    t.validate()?;
    let local = t.local_stiffness();
    let (c44, c66) = (local[3][3], local[5][5]);
    let ladd = ladd_families(&local, a).map_err(|e| match e {
        // In the engineering constants: the axes across the fibre need G_t < 2 G_p.
        Unreachable::Axis { axis: i, .. } if i != 2 && !(c44 < 2.0 * c66) => out_of_range(
            "shear_fibre",
            c44,
            format!(
                "on the cubic lattice G_t must be below 2 G_p = E_p / (1 + nu_p) = {:.6e} Pa: the springs across the fibre would need a negative stiffness",
                2.0 * c66
            ),
        ),
        Unreachable::Axis { .. } => out_of_range(
            "youngs_fibre",
            t.youngs_fibre,
            format!("{}; here: raise E_t, or bring nu_tp closer to nu_p", e.why()),
        ),
        Unreachable::Coupling(_) => out_of_range(
            "poisson_fibre",
            t.poisson_fibre,
            format!(
                "{}; this target has 3 C12 = C11, which leaves no dispersion in the plane of isotropy, but C13 != C44, which needs some: move nu_p away from this value",
                e.why()
            ),
        ),
        Unreachable::Stability(_) => out_of_range(
            "poisson_plane",
            t.poisson_plane,
            format!("{}: raise nu_p, or bring C13 closer to C44", e.why()),
        ),
        Unreachable::Diagonal(_) => out_of_range("shear_fibre", c44, e.why()),
    })?;
    // In the fibre's frame: along = z, across = x, diagonals across = the xy plane (index 2),
    // diagonals along = the yz plane (index 0).
    Ok(CubicFamilies {
        k: [
            ladd.axis_k[2],
            ladd.axis_k[0],
            ladd.diagonal_k[2],
            ladd.diagonal_k[0],
        ],
        w: [
            ladd.axis_w[2],
            ladd.axis_w[0],
            ladd.diagonal_w[2],
            ladd.diagonal_w[0],
        ],
        q: ladd.q,
        ladd,
    })
}

/// The rotation that lays a Ladd lattice along the fibre `m`: the smallest turn taking the
/// lattice axis nearest to `m` (either sense) onto it. A fibre at 30 degrees in the xy plane
/// turns the lattice about z by 30 degrees, so a plate's faces stay node planes.
pub fn lattice_rotation(m: [Real; 3]) -> Result<crate::math::Matrix> {
    use crate::math::{Matrix, Vector};
    let n = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
    if !(n.is_finite() && n > 0.0) {
        return Err(Error::InvalidInput {
            what: "lattice rotation",
            why: format!("{m:?} has no direction: give a non-zero vector"),
        });
    }
    let to = Vector::new(m[0] / n, m[1] / n, m[2] / n);
    let k = (0..3)
        .max_by(|&i, &j| to[i].abs().total_cmp(&to[j].abs()))
        .unwrap_or(2);
    let mut from = Vector::zeros();
    from[k] = to[k].signum();
    // Rodrigues: the turn about from x to by the angle between them.
    let axis = from.cross(&to);
    let (sin, cos) = (axis.norm(), from.dot(&to));
    if sin < 1e-15 {
        return Ok(Matrix::identity());
    }
    let u = axis / sin;
    let cross = Matrix::new(0.0, -u.z, u.y, u.z, 0.0, -u.x, -u.y, u.x, 0.0);
    Ok(Matrix::identity() + cross * sin + cross * cross * (1.0 - cos))
}

impl Body {
    /// A body of the transversely isotropic material `t` on a Ladd (cubic) lattice, its fibre
    /// along a lattice axis ([`cubic_families`]). Refused on other lattices (with the reason)
    /// and for targets the lattice cannot reach.
    pub fn transverse(lattice: Lattice, t: &Transverse) -> Result<Body> {
        check_ladd(&lattice, "transversely isotropic")?;
        let f = cubic_families(t, lattice.spacing)?;
        let m = t.axis()?;
        let a = lattice.spacing;
        Body::by_family(lattice, f.q, t.density, |d, l| {
            // The family from the spring's length and c = (n.m)^2: 1, 0 (axes), 0, 1/2
            // (diagonals). Anything else means the fibre is not along a lattice axis.
            let c = ((d[0] * m[0] + d[1] * m[1] + d[2] * m[2]) / l).powi(2);
            let family = match (l > 1.2 * a, c) {
                (false, c) if (c - 1.0).abs() < 1e-6 => 0,
                (false, c) if c < 1e-6 => 1,
                (true, c) if c < 1e-6 => 2,
                (true, c) if (c - 0.5).abs() < 1e-6 => 3,
                _ => {
                    return Err(Error::InvalidInput {
                        what: "fibre direction",
                        why: format!(
                            "{:?}: on the cubic lattice the fibre must lie along a lattice axis; for another direction lay the lattice along the fibre (case key lattice.rotate_to = the fibre, `Lattice::rotated`): off-axis fibres would meet the lattice's own cubic anisotropy",
                            t.fibre
                        ),
                    })
                }
            };
            Ok((f.k[family], f.w[family]))
        })
    }

    /// A body of the orthotropic material `o` on a Ladd lattice along its material axes (the
    /// body's axes, or a lattice laid along `o.axes`: [`Orthotropic::lattice_rotation`]), from
    /// [`ladd_families`] in the material's frame.
    pub fn orthotropic(lattice: Lattice, o: &Orthotropic) -> Result<Body> {
        check_ladd(&lattice, "orthotropic")?;
        let f = ladd_families(&o.local_stiffness()?, lattice.spacing).map_err(|e| {
            Error::InvalidInput {
                what: "orthotropic material",
                why: e.why(),
            }
        })?;
        Body::ladd(lattice, &f, o.density, &o.axes)
    }

    /// Each spring's stiffness and lever from its family (axis or face diagonal, by its
    /// direction in the material axes `axes`), each node's mass `rho a^3`.
    pub fn ladd(
        lattice: Lattice,
        f: &LaddFamilies,
        density: Real,
        axes: &[[Real; 3]; 3],
    ) -> Result<Body> {
        let a = lattice.spacing;
        Body::by_family(lattice, f.q, density, |w, _| {
            let d = axes.map(|e| e[0] * w[0] + e[1] * w[1] + e[2] * w[2]);
            // An axis spring has one non-zero component; a face diagonal two, and the plane it
            // lies in is normal to the zero one.
            let zero: Vec<usize> = (0..3).filter(|&c| d[c].abs() < 0.25 * a).collect();
            match *zero.as_slice() {
                [p, q] => {
                    let axis = 3 - p - q;
                    Ok((f.axis_k[axis], f.axis_w[axis]))
                }
                [p] => Ok((f.diagonal_k[p], f.diagonal_w[p])),
                _ => Err(Error::InvalidInput {
                    what: "anisotropic material",
                    why: format!("a spring along {w:?} is neither along a material axis nor a face diagonal of two: an orthotropic material needs the lattice laid along its material axes (the body's, or material.axes, which turn the lattice with them)"),
                }),
            }
        })
    }

    /// A regular lattice's body whose springs take the stiffness and direction weight
    /// `family(d, L)` gives for their reference vector `d` and rest length `L` (lever `w L`),
    /// every node `rho a^3`.
    fn by_family(
        lattice: Lattice,
        q: Real,
        density: Real,
        family: impl Fn([Real; 3], Real) -> Result<(Real, Real)>,
    ) -> Result<Body> {
        let bonds = &*lattice.bonds;
        let (mut k, mut lever) = (
            Vec::with_capacity(bonds.len()),
            Vec::with_capacity(bonds.len()),
        );
        for b in 0..bonds.len() {
            let [i, j] = bonds.ends[b].map(|v| v as usize);
            let l = lattice.rest(b);
            let (kb, w) = family(lattice.reference_vector(i, j), l)?;
            k.push(kb);
            lever.push(w * l);
        }
        let mass = vec![density * lattice.cell_volume; lattice.len()];
        let body = Body {
            lattice,
            k: k.into(),
            q,
            mass,
            lever: Some(lever),
            q_node: None,
            phase: None,
        };
        body.validate()?;
        Ok(body)
    }
}

/// Either anisotropic material, as a case or a builder holds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Anisotropic {
    Transverse(Transverse),
    Orthotropic(Orthotropic),
}

/// Voigt order of the 6x6 stiffness: xx, yy, zz, yz, xz, xy.
pub const VOIGT: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];

/// Which entries of a stiffness in the material axes are tied by the material's symmetry
/// (averaged when the calibration corrects the design, to halve the ensemble's noise).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Symmetry {
    /// Nine independent entries.
    Orthotropic,
    /// Fibre along the third axis: C11 = C22, C13 = C23, C44 = C55.
    Transverse,
}

impl Anisotropic {
    /// The target stiffness in the lattice's axes (Voigt, Pa).
    pub fn stiffness(&self) -> Result<[[Real; 6]; 6]> {
        match self {
            Anisotropic::Transverse(t) => t.stiffness(),
            Anisotropic::Orthotropic(o) => o.stiffness(),
        }
    }

    /// The axes of a plate of this material (rows, body frame), the plate's normal z third, and
    /// the symmetry of its in-plane stiffness. A fibre along z leaves the plate isotropic in its
    /// plane. Any other fibre makes it orthotropic in the axes `e1` (the fibre's projection on
    /// the plane) and `e2 = z x e1`: the reflection `e2 -> -e2` keeps the fibre, so it keeps the
    /// material, and the in-plane entries odd in `e2` (`Q16`, `Q26`) vanish. An orthotropic
    /// material needs one of its axes along z (otherwise the plate has no in-plane symmetry
    /// axes, and the calibration of random2d designs has none to work in).
    pub fn plane_axes(&self) -> Result<([[Real; 3]; 3], Symmetry)> {
        self.plane_frame().map(|(axes, _, sym)| (axes, sym))
    }

    /// [`Anisotropic::plane_axes`], and how the material's own axes (those of its
    /// `local_stiffness`) map onto them.
    fn plane_frame(&self) -> Result<([[Real; 3]; 3], PlateMap, Symmetry)> {
        let refuse = |why: String| Error::InvalidInput {
            what: "anisotropic material",
            why,
        };
        let rows = match self {
            Anisotropic::Transverse(t) => {
                let m = t.axis()?;
                // Within the tolerance the plane test below uses (a unit fibre).
                if m[0].hypot(m[1]) <= 1e-9 {
                    return Ok((
                        Orthotropic::AXES,
                        PlateMap::Permute([0, 1, 2]),
                        Symmetry::Transverse,
                    ));
                }
                let own = t.frame()?;
                if m[2].abs() > 1e-9 {
                    let e1 = normalise([m[0], m[1], 0.0]);
                    let axes = [e1, cross([0.0, 0.0, 1.0], e1), [0.0, 0.0, 1.0]];
                    let dot = |a: [Real; 3], b: [Real; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
                    let turn = own.map(|r| axes.map(|e| dot(r, e)));
                    return Ok((axes, PlateMap::Rotate(turn), Symmetry::Orthotropic));
                }
                own
            }
            Anisotropic::Orthotropic(o) => o.axes,
        };
        let Some(normal) = rows.iter().position(|r| r[2].abs() > 1.0 - 1e-9) else {
            return Err(refuse(format!(
                "a plate (2D lattice) needs one material axis along z, the plate's normal; the axes are {rows:?}: turn them about z only"
            )));
        };
        // The in-plane axes: the fibre (or the material's first in-plane axis) first, exactly
        // in the plane; the second from the right hand, so the frame stays right-handed (an
        // orthotropic stiffness does not change when an axis flips).
        let first = match self {
            Anisotropic::Transverse(_) => 2,
            Anisotropic::Orthotropic(_) => (0..3).find(|&a| a != normal).unwrap_or(0),
        };
        let second = 3 - first - normal;
        let e1 = normalise([rows[first][0], rows[first][1], 0.0]);
        let z = if rows[normal][2] > 0.0 { 1.0 } else { -1.0 };
        let e3 = [0.0, 0.0, z];
        let e2 = cross(e3, e1);
        Ok((
            [e1, e2, e3],
            PlateMap::Permute([first, second, normal]),
            Symmetry::Orthotropic,
        ))
    }

    /// The stiffness a plate of this material has in its plane (Pa, per unit thickness),
    /// Voigt order with only xx, yy and xy filled, in the material axes of
    /// [`Anisotropic::plane_axes`]: plane strain keeps those entries of the 3D stiffness (with
    /// a fibre out of the plane, less what the freed out-of-plane shears relax), plane stress
    /// inverts those of the compliance (the out-of-plane stresses vanish). It is found
    /// from the material's own stiffness by relabelling axes, with no rotation: the same
    /// material gives the same bits (and one calibration) for any direction in the plane. A
    /// fibre out of the plane is turned into the plate's axes ([`rotate`]), and the entries
    /// that the plate's mirror symmetry makes zero are set to exactly zero.
    pub fn plane_local_stiffness(
        &self,
        plane: crate::material::PlaneModel,
    ) -> Result<[[Real; 6]; 6]> {
        let (_, map, _) = self.plane_frame()?;
        let own = match self {
            Anisotropic::Transverse(t) => t.local_stiffness(),
            Anisotropic::Orthotropic(o) => o.local_stiffness()?,
        };
        let pairs = VOIGT;
        let c: [[Real; 6]; 6] = match map {
            PlateMap::Permute(perm) => std::array::from_fn(|p| {
                std::array::from_fn(|q| {
                    let ((i, j), (k, l)) = (pairs[p], pairs[q]);
                    tensor_component(&own, perm[i], perm[j], perm[k], perm[l])
                })
            }),
            PlateMap::Rotate(turn) => {
                let mut c = rotate(&own, &turn);
                // Odd in e2 (index 1): zero by the mirror e2 -> -e2, round-off otherwise.
                let odd = |(i, j): (usize, usize)| usize::from(i == 1) + usize::from(j == 1);
                for p in 0..6 {
                    for q in 0..6 {
                        if (odd(pairs[p]) + odd(pairs[q])) % 2 == 1 {
                            c[p][q] = 0.0;
                        }
                    }
                }
                c
            }
        };
        let idx = [0, 1, 5];
        let sub = match plane {
            crate::material::PlaneModel::Strain => {
                // eps_zz = 0 and the out-of-plane shears free (sigma_yz = sigma_xz = 0, the
                // generalized plane strain of a long body): Q = C_pp - C_ps C_ss^-1 C_sp. A
                // material axis along z has C_ps = 0 exactly, and then Q is C_pp bit for bit.
                let pp = nalgebra::Matrix3::<Real>::from_fn(|a, b| c[idx[a]][idx[b]]);
                let ps = nalgebra::Matrix3x2::<Real>::from_fn(|a, b| c[idx[a]][3 + b]);
                let ss = nalgebra::Matrix2::<Real>::from_fn(|a, b| c[3 + a][3 + b]);
                if ps.iter().all(|&v| v == 0.0) {
                    pp
                } else {
                    let inv = ss.try_inverse().ok_or_else(|| Error::InvalidInput {
                        what: "anisotropic material",
                        why: "its out-of-plane shear stiffness is singular".into(),
                    })?;
                    pp - ps * inv * ps.transpose()
                }
            }
            crate::material::PlaneModel::Stress => {
                let full = nalgebra::SMatrix::<Real, 6, 6>::from_fn(|a, b| c[a][b]);
                let s = full.try_inverse().ok_or_else(|| Error::InvalidInput {
                    what: "anisotropic material",
                    why: "its stiffness is singular".into(),
                })?;
                nalgebra::Matrix3::<Real>::from_fn(|a, b| s[(idx[a], idx[b])])
                    .try_inverse()
                    .ok_or_else(|| Error::InvalidInput {
                        what: "anisotropic material",
                        why: "its in-plane compliance is singular".into(),
                    })?
            }
        };
        let mut out = [[0.0; 6]; 6];
        for a in 0..3 {
            for b in 0..3 {
                // Symmetric to round-off; keep it exactly so.
                out[idx[a]][idx[b]] = 0.5 * (sub[(a, b)] + sub[(b, a)]);
            }
        }
        Ok(out)
    }

    /// [`Anisotropic::plane_local_stiffness`] in the body's frame.
    pub fn plane_stiffness(&self, plane: crate::material::PlaneModel) -> Result<[[Real; 6]; 6]> {
        let (axes, _) = self.plane_axes()?;
        Ok(rotate(&self.plane_local_stiffness(plane)?, &axes))
    }

    /// The springs' families at spacing `a`.
    pub fn families(&self, a: Real) -> Result<LaddFamilies> {
        match self {
            Anisotropic::Transverse(t) => Ok(cubic_families(t, a)?.ladd),
            Anisotropic::Orthotropic(o) => {
                ladd_families(&o.local_stiffness()?, a).map_err(|e| Error::InvalidInput {
                    what: "orthotropic material",
                    why: e.why(),
                })
            }
        }
    }

    /// Mass density (kg/m^3).
    pub fn density(&self) -> Real {
        match self {
            Anisotropic::Transverse(t) => t.density,
            Anisotropic::Orthotropic(o) => o.density,
        }
    }
}

/// How a plate's axes ([`Anisotropic::plane_axes`]) relate to the material's own: a
/// relabelling of them (the same bits for any direction in the plane), or a rotation (rows: the
/// material's own axes in the plate's axes) when the fibre leaves the plane.
#[derive(Clone, Copy, Debug)]
enum PlateMap {
    Permute([usize; 3]),
    Rotate([[Real; 3]; 3]),
}

fn check_ladd(lattice: &Lattice, what: &str) -> Result<()> {
    if lattice.kind != LatticeKind::Cubic || lattice.cells.is_some() {
        return Err(Error::InvalidInput {
            what: "anisotropic material",
            why: format!(
                "{what} materials are built on the cubic lattice (material axes along the lattice axes); the {} lattice is not supported yet",
                lattice.kind.name()
            ),
        });
    }
    Ok(())
}

fn cross(a: [Real; 3], b: [Real; 3]) -> [Real; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalise(a: [Real; 3]) -> [Real; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / n, a[1] / n, a[2] / n]
}

/// `C_ijkl` of a Voigt stiffness (engineering shears: its entries are the tensor's).
pub fn tensor_component(c: &[[Real; 6]; 6], i: usize, j: usize, k: usize, l: usize) -> Real {
    c[voigt(i, j)][voigt(k, l)]
}

/// Voigt index of the tensor pair (i, j).
fn voigt(i: usize, j: usize) -> usize {
    match (i.min(j), i.max(j)) {
        (0, 0) => 0,
        (1, 1) => 1,
        (2, 2) => 2,
        (1, 2) => 3,
        (0, 2) => 4,
        _ => 5,
    }
}

/// `C'_ijkl = r_ai r_bj r_ck r_dl C_abcd` with `r[a]` the global components of local axis `a`
/// (Voigt stiffness with engineering shears holds the tensor's components directly).
pub fn rotate(c: &[[Real; 6]; 6], r: &[[Real; 3]; 3]) -> [[Real; 6]; 6] {
    let t = |i: usize, j: usize, k: usize, l: usize| tensor_component(c, i, j, k, l);
    let mut out = [[0.0; 6]; 6];
    let pairs = VOIGT;
    for (p, &(i, j)) in pairs.iter().enumerate() {
        for (s, &(k, l)) in pairs.iter().enumerate() {
            let mut v = 0.0;
            for a in 0..3 {
                for b in 0..3 {
                    for cc in 0..3 {
                        for d in 0..3 {
                            v += r[a][i] * r[b][j] * r[cc][k] * r[d][l] * t(a, b, cc, d);
                        }
                    }
                }
            }
            out[p][s] = v;
        }
    }
    out
}
