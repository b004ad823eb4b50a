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
        let m = self.axis()?;
        // A right-handed frame whose third axis is the fibre; any one will do (isotropy in the
        // plane).
        let helper = if m[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let e1 = normalise(cross(helper, m));
        let e2 = cross(m, e1);
        let r = [e1, e2, m]; // r[a][i]: component i of local axis a
        Ok(rotate(&self.local_stiffness(), &r))
    }
}

/// What [`Body::transverse`] puts on the springs of the Ladd lattice, in one place for output
/// (`hooke check`, `hooke moduli --bulk`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubicFamilies {
    /// Index of the lattice axis along the fibre.
    pub axis: usize,
    /// Stiffness (N/m) of the four families: the axis along the fibre, the axes across it, the
    /// diagonals across it, the diagonals with a component along it.
    pub k: [Real; 4],
    /// Direction weights `w` of the same four families (largest magnitude 1).
    pub w: [Real; 4],
    /// Dispersion ratio.
    pub q: Real,
}

/// The spring constants that give the Ladd lattice of spacing `a` the material `t`, or why they
/// do not exist (see the module docs for the reachable set).
pub fn cubic_families(t: &Transverse, a: Real) -> Result<CubicFamilies> {
    t.validate()?;
    let m = t.axis()?;
    let axis = (0..3).find(|&c| (m[c].abs() - 1.0).abs() < 1e-12).ok_or_else(|| Error::InvalidInput {
        what: "fibre direction",
        why: format!(
            "{:?}: on the cubic lattice the fibre must lie along a lattice axis ([1,0,0], [0,1,0] or [0,0,1]); off-axis fibres would meet the lattice's own cubic anisotropy",
            t.fibre
        ),
    })?;
    let c = t.local_stiffness();
    let (c11, c12, c13, c33, c44, c66) = (c[0][0], c[0][1], c[0][2], c[2][2], c[3][3], c[5][5]);
    let scale = c11.abs().max(c33.abs());
    let g_p = c66;
    if !(c44 < 2.0 * g_p) {
        return Err(out_of_range(
            "shear_fibre",
            c44,
            format!(
                "on the cubic lattice G_t must be below 2 G_p = E_p / (1 + nu_p) = {:.6e} Pa: the springs across the fibre would need a negative stiffness",
                2.0 * g_p
            ),
        ));
    }
    let k4 = a * c44;
    let k3 = a * c66;
    let k2 = a * (2.0 * c66 - c44);
    let r = 0.5 * (3.0 * c12 - c11);
    let d = c13 - c44;
    if r.abs() <= 1e-12 * scale {
        if d.abs() > 1e-9 * scale {
            return Err(out_of_range(
                "poisson_fibre",
                t.poisson_fibre,
                "this target has 3 C12 = C11, which leaves no dispersion in the plane of isotropy, but C13 != C44, which needs some: unreachable on the cubic lattice (move nu_p away from this value)",
            ));
        }
        let k1 = a * (c33 - 2.0 * c44);
        if !(k1 > 0.0) {
            return Err(out_of_range(
                "youngs_fibre",
                t.youngs_fibre,
                "the spring along the fibre would need a negative stiffness (C33 <= 2 C44): raise E_t or lower G_t",
            ));
        }
        return Ok(CubicFamilies {
            axis,
            k: [k1, k2, k3, k4],
            w: [1.0; 4],
            q: 0.0,
        });
    }
    let k1 = a * (c33 - 2.0 * c44 - d * d / r);
    if !(k1 > 0.0) {
        return Err(out_of_range(
            "youngs_fibre",
            t.youngs_fibre,
            format!(
                "on the cubic lattice C33 - 2 C44 must exceed (C13 - C44)^2 / R (here {:.6e} against {:.6e} Pa, R = (3 C12 - C11)/2): the spring along the fibre would need a negative stiffness; raise E_t, or bring nu_tp closer to nu_p",
                c33 - 2.0 * c44,
                d * d / r
            ),
        ));
    }
    let rho = d / r;
    // w = alpha (1 - c) + gamma c over the families' c = (n.m)^2 = 1, 0, 0, 1/2, with
    // A_33 / A_11 = rho.
    let den = rho * k4 - k1 - 2.0 * k4;
    let (alpha, gamma) = if den.abs() <= 1e-12 * (k1 + k4) {
        (0.0, 1.0)
    } else {
        (1.0, (2.0 * k4 - rho * (k2 + 2.0 * k3 + k4)) / den)
    };
    let mut w = [gamma, alpha, alpha, 0.5 * (alpha + gamma)];
    let big = w.iter().fold(0.0 as Real, |x, v| x.max(v.abs()));
    for v in &mut w {
        *v /= big;
    }
    let k = [k1, k2, k3, k4];
    // The node's full star (18 springs: each family's unique directions twice).
    let count = [2.0, 4.0, 4.0, 8.0];
    let l2 = [a * a, a * a, 2.0 * a * a, 2.0 * a * a];
    // A_11: the in-plane component of the fabric (axis across: c_11 share 1 of 2 axes, etc.).
    let a11 = 2.0 * (w[1] * k2 * a * a + 2.0 * w[2] * k3 * a * a + 2.0 * w[3] * k4 * a * a);
    let s: Real = (0..4).map(|f| count[f] * w[f] * w[f] * k[f] * l2[f]).sum();
    let q = r * s * a * a * a / (a11 * a11);
    if !(q.is_finite() && q > Q_MIN) {
        return Err(out_of_range(
            "poisson_plane",
            t.poisson_plane,
            format!(
                "this target needs a dispersion ratio q = {q:.4}, below the stability limit -1/2 (the dispersion would take more than the springs give): raise nu_p, or bring C13 closer to C44"
            ),
        ));
    }
    Ok(CubicFamilies { axis, k, w, q })
}

impl Body {
    /// A body of the transversely isotropic material `t` on a Ladd (cubic) lattice, its fibre
    /// along a lattice axis: each spring's stiffness and lever from its family
    /// ([`cubic_families`]), each node's mass `rho a^3`. Refused on other lattices (with the
    /// reason) and for targets the lattice cannot reach.
    pub fn transverse(lattice: Lattice, t: &Transverse) -> Result<Body> {
        if lattice.kind != LatticeKind::Cubic || lattice.cells.is_some() {
            return Err(Error::InvalidInput {
                what: "transverse material",
                why: format!(
                    "transversely isotropic materials are built on the cubic lattice (fibre along a lattice axis); the {} lattice is not supported yet",
                    lattice.kind.name()
                ),
            });
        }
        let a = lattice.spacing;
        let f = cubic_families(t, a)?;
        let bonds = &lattice.bonds;
        let mut k = Vec::with_capacity(bonds.len());
        let mut lever = Vec::with_capacity(bonds.len());
        for b in 0..bonds.len() {
            let [i, j] = bonds.ends[b].map(|v| v as usize);
            let d = lattice.reference_vector(i, j);
            let l = bonds.rest[b];
            let along = d[f.axis].abs() / l;
            let diagonal = l > 1.2 * a;
            let family = match (diagonal, along > 0.5) {
                (false, true) => 0,
                (false, false) => 1,
                (true, false) if along < 0.1 => 2,
                _ => 3,
            };
            k.push(f.k[family]);
            lever.push(f.w[family] * l);
        }
        let mass = t.density * lattice.cell_volume;
        let nodes = lattice.len();
        let body = Body {
            lattice,
            k,
            q: f.q,
            mass: vec![mass; nodes],
            lever: Some(lever),
        };
        body.validate()?;
        Ok(body)
    }
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
    let t = |i: usize, j: usize, k: usize, l: usize| c[voigt(i, j)][voigt(k, l)];
    let mut out = [[0.0; 6]; 6];
    let pairs = crate::moduli::VOIGT;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::moduli::bulk_stiffness_of;

    fn material(ep: Real, et: Real, np: Real, ntp: Real, gt: Real, fibre: [Real; 3]) -> Transverse {
        Transverse {
            youngs_plane: ep,
            youngs_fibre: et,
            poisson_plane: np,
            poisson_fibre: ntp,
            shear_fibre: gt,
            density: 1000.0,
            fibre,
        }
    }

    fn worst(a: &[[Real; 6]; 6], b: &[[Real; 6]; 6]) -> Real {
        let scale = b.iter().flatten().fold(0.0 as Real, |m, x| m.max(x.abs()));
        a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .fold(0.0 as Real, |m, (x, y)| m.max((x - y).abs()))
            / scale
    }

    /// The bulk (affine) tensor of the weighted Ladd lattice is the target, to round-off, for
    /// stiff and soft fibres, q of both signs and every fibre axis.
    #[test]
    fn the_bulk_tensor_is_the_target() {
        let cases = [
            // carbon-fibre-like (E_t / E_p = 2.5)
            (10e9, 25e9, 0.35, 0.28, 4e9),
            // a soft fibre (E_t < E_p)
            (20e9, 8e9, 0.2, 0.1, 5e9),
            // wood-like: stiff grain, weak shear across it
            (1.0e9, 12e9, 0.45, 0.4, 0.6e9),
            // auxetic in the plane (q < 0)
            (5e9, 9e9, -0.3, -0.1, 2.5e9),
            // nearly incompressible in the plane
            (3e9, 6e9, 0.45, 0.3, 1.2e9),
        ];
        for (ep, et, np, ntp, gt) in cases {
            for fibre in [[1.0, 0.0, 0.0], [0.0, -2.0, 0.0], [0.0, 0.0, 1.0]] {
                let t = material(ep, et, np, ntp, gt, fibre);
                let a = 2e-3;
                let f = cubic_families(&t, a).unwrap();
                let c =
                    bulk_stiffness_of(LatticeKind::Cubic, a, &|l| Body::transverse(l, &t)).unwrap();
                let target = t.stiffness().unwrap();
                let err = worst(&c, &target);
                assert!(
                    err < 1e-9,
                    "{t:?}: q {} differs by {err:e}\n{c:?}\n{target:?}",
                    f.q
                );
            }
        }
    }

    /// The isotropic material is the paper's lattice: every family has k = mu a, w = 1, and q
    /// is `0.3 (4 nu - 1)/(1 - 2 nu)` (`docs/model.md`).
    #[test]
    fn isotropic_targets_give_the_papers_lattice() {
        for nu in [-0.8, 0.0, 0.25, 0.45] {
            let (e, a) = (70e9, 1e-3);
            let f =
                cubic_families(&Transverse::isotropic(e, nu, 2500.0, [0.0, 0.0, 1.0]), a).unwrap();
            let mu = e / (2.0 * (1.0 + nu));
            for k in f.k {
                assert!((k / (mu * a) - 1.0).abs() < 1e-12, "nu {nu}: {f:?}");
            }
            if nu != 0.25 {
                for w in f.w {
                    assert!((w - 1.0).abs() < 1e-12, "nu {nu}: {f:?}");
                }
            }
            let q = 0.3 * (4.0 * nu - 1.0) / (1.0 - 2.0 * nu);
            assert!((f.q - q).abs() < 1e-12, "nu {nu}: q {} against {q}", f.q);
        }
    }

    /// Targets outside the reachable set are refused with the condition they break.
    #[test]
    fn unreachable_targets_are_refused_with_the_reason() {
        let why = |t: Transverse| format!("{}", cubic_families(&t, 1e-3).unwrap_err());
        let z = [0.0, 0.0, 1.0];
        // G_t above 2 G_p.
        assert!(why(material(10e9, 20e9, 0.25, 0.2, 9e9, z)).contains("2 G_p"));
        // Not a material: nu_tp too large for E_p / E_t.
        assert!(why(material(10e9, 1e9, 0.25, 0.9, 1e9, z)).contains("positive definite"));
        // The spring along the fibre would be negative: E_t too low for the coupling.
        assert!(why(material(10e9, 3e9, 0.4, 0.1, 2e9, z)).contains("negative stiffness"));
        // q below the stability limit: strongly auxetic in the plane, stiff coupling.
        let msg = why(material(10e9, 10e9, -0.999, -0.5, 1e9, z));
        assert!(msg.contains("stability limit"), "{msg}");
        // Off a lattice axis.
        assert!(why(material(10e9, 20e9, 0.25, 0.2, 3e9, [1.0, 1.0, 0.0])).contains("lattice axis"));
        // No direction.
        assert!(why(material(10e9, 20e9, 0.25, 0.2, 3e9, [0.0; 3])).contains("non-zero"));
        // Other lattices are refused.
        let hex = Lattice::hex_box(4, 4, 1e-3, 1e-3).unwrap();
        let t = material(10e9, 20e9, 0.25, 0.2, 3e9, z);
        assert!(format!("{}", Body::transverse(hex, &t).unwrap_err()).contains("cubic"));
    }
}
