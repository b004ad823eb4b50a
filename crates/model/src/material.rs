//! From engineering moduli (E, nu, density) to lattice constants (spring stiffness k, dispersion
//! ratio q), and back.
//!
//! The dispersive lattice is a Cauchy solid (lambda = mu) plus a pressure-like part B that only
//! sees the volume change (paper eqs. 5-6). Under a uniform strain every node's pool ratio is
//! `Pi_n / S_n = tr(eps) / d` (the star is isotropic: `sum_t L_t^2 e_t e_t = S_n / (k d) I`), so
//! the dispersive tensions add `2 q k L tr(eps)/d` to every spring and
//!
//! * 3D Ladd: `mu = k/a`, `B = (10/3) q mu` (so the paper's `Q = 2q`, eq. 8),
//!   `nu = (1 + 10q/3) / (2 (2 + 10q/3))`, `E = (k/a) 15 (1 + 2q) / (6 + 10q)`;
//! * 2D hexagonal: `mu = sqrt(3)/4 k`, `B = 4 q mu`,
//!   `nu_2D = (1 + 4q) / (3 + 4q)`, `E_2D = sqrt(3) k (2 + 4q) / (3 + 4q)` (per unit thickness:
//!   `E_2D` has units N/m, and the plate's springs carry `k = k_2D`).
//!
//! `q = 0` is the plain lattice (eqs. 1-2: nu = 1/4 in 3D, 1/3 in 2D). The stiffness is
//! positive definite for `q > -1/2` (margin `1 + 2q`, see `docs/model.md`), which maps onto
//! nu in (-1, 1/2) in 3D and nu_2D in (-1, 1) in 2D. We keep a margin: nu >= -0.99.
//!
//! A 2D lattice is a plate of thickness `h` of a 3D material. In plane stress (the default, a
//! thin plate) the in-plane constants are `E_2D = E h`, `nu_2D = nu`; in plane strain (a thick
//! body, no out-of-plane strain) `E_2D = E h / (1 - nu^2)`, `nu_2D = nu / (1 - nu)`.

use crate::error::{Error, Result};
use crate::lattice::LatticeKind;
use crate::math::Real;
use crate::random::calibration;

/// Lowest Poisson's ratio accepted: keeps `1 + 2q` (the stability margin) above about 1e-3.
pub const NU_MIN: Real = -0.99;
/// Largest in-plane Poisson's ratio of the 2D lattice (exclusive bound is 1).
pub const NU2D_MAX: Real = 0.99;

/// An isotropic linear elastic material in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Elastic {
    /// Young's modulus E (Pa).
    pub youngs: Real,
    /// Poisson's ratio nu (-).
    pub poisson: Real,
    /// Mass density rho (kg/m^3).
    pub density: Real,
}

/// How a 2D lattice stands for a 3D material.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PlaneModel {
    /// Thin plate, no out-of-plane stress (default).
    #[default]
    Stress,
    /// Thick body, no out-of-plane strain.
    Strain,
}

impl PlaneModel {
    /// `"stress"` or `"strain"`, as `lattice.plane` and `--plane` spell it.
    pub fn name(&self) -> &'static str {
        match self {
            PlaneModel::Stress => "stress",
            PlaneModel::Strain => "strain",
        }
    }
}

/// The constants the force law needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringConstants {
    /// Spring stiffness k (N/m), the same for every spring of a regular lattice.
    pub k: Real,
    /// Dispersion ratio q (-): dispersed over direct momentum flow per node.
    pub q: Real,
}

/// q that gives the lattice its own Poisson's ratio `nu` (3D: nu; 2D: the in-plane nu_2D).
pub fn q_from_nu(kind: LatticeKind, nu: Real) -> Result<Real> {
    check_lattice_nu(kind, nu)?;
    Ok(match kind {
        LatticeKind::Cubic => 0.3 * (4.0 * nu - 1.0) / (1.0 - 2.0 * nu),
        LatticeKind::Hex => (3.0 * nu - 1.0) / (4.0 * (1.0 - nu)),
        LatticeKind::Random2d | LatticeKind::Random3d => calibration::q_for_nu(kind, nu)?,
    })
}

/// The lattice's Poisson's ratio for a given q (inverse of [`q_from_nu`]).
pub fn nu_from_q(kind: LatticeKind, q: Real) -> Real {
    match kind {
        LatticeKind::Cubic => {
            let t = 10.0 * q / 3.0;
            (1.0 + t) / (2.0 * (2.0 + t))
        }
        LatticeKind::Hex => (1.0 + 4.0 * q) / (3.0 + 4.0 * q),
        LatticeKind::Random2d | LatticeKind::Random3d => calibration::nu_of_q(kind, q),
    }
}

/// Young's modulus of the lattice for stiffness `k`, spacing `a` and ratio `q`: E in Pa (3D) or
/// the per-thickness E_2D in N/m (2D; multiply by nothing, it is independent of a).
///
/// For random lattices `k` stands for kappa, the stiffness per unit volume of
/// `k_s = kappa V_s / L_s^2` (Pa in 3D; N/m in 2D with areas), see [`crate::random`]; `a` is
/// not used.
pub fn youngs_from_k(kind: LatticeKind, k: Real, a: Real, q: Real) -> Real {
    match kind {
        LatticeKind::Cubic => k / a * 15.0 * (1.0 + 2.0 * q) / (6.0 + 10.0 * q),
        LatticeKind::Hex => (3.0 as Real).sqrt() * k * (2.0 + 4.0 * q) / (3.0 + 4.0 * q),
        LatticeKind::Random3d => {
            k * (1.0 + 2.0 * q) / (6.0 + 10.0 * q) * calibration::youngs_factor(kind, q)
        }
        LatticeKind::Random2d => {
            k * (1.0 + 2.0 * q) / (3.0 + 4.0 * q) * calibration::youngs_factor(kind, q)
        }
    }
}

/// Shear modulus of the lattice (`k/a` in 3D, `sqrt(3)/4 k` per thickness in 2D); q does not
/// change it.
pub fn shear_from_k(kind: LatticeKind, k: Real, a: Real) -> Real {
    match kind {
        LatticeKind::Cubic => k / a,
        LatticeKind::Hex => (3.0 as Real).sqrt() / 4.0 * k,
        // Affine value (kappa/15, kappa/8); the calibrated E and nu are what random lattices
        // promise.
        LatticeKind::Random3d => k / 15.0,
        LatticeKind::Random2d => k / 8.0,
    }
}

/// Spring constants from lattice-level moduli: `nu` is the lattice's own ratio, `e_lattice` is
/// E (Pa) in 3D or E_2D (N/m) in 2D.
pub fn constants_from_lattice_moduli(
    kind: LatticeKind,
    a: Real,
    e_lattice: Real,
    nu: Real,
) -> Result<SpringConstants> {
    check_positive("Young's modulus", e_lattice)?;
    let q = q_from_nu(kind, nu)?;
    let k = e_lattice / youngs_from_k(kind, 1.0, a, q);
    Ok(SpringConstants { k, q })
}

/// In-plane (E_2D in N/m, nu_2D) of a plate of thickness `h` of `m`.
pub fn plate_moduli(m: &Elastic, h: Real, plane: PlaneModel) -> (Real, Real) {
    let (e, nu) = (m.youngs, m.poisson);
    match plane {
        PlaneModel::Stress => (e * h, nu),
        PlaneModel::Strain => (e * h / (1.0 - nu * nu), nu / (1.0 - nu)),
    }
}

/// Spring constants and node mass for a lattice of spacing `a` made of `m`. For 2D lattices `h`
/// is the plate thickness and `plane` the plate model; both are ignored in 3D.
pub fn constants_for(
    kind: LatticeKind,
    a: Real,
    m: &Elastic,
    h: Real,
    plane: PlaneModel,
) -> Result<SpringConstants> {
    check_elastic(m)?;
    match kind {
        LatticeKind::Cubic | LatticeKind::Random3d => {
            constants_from_lattice_moduli(kind, a, m.youngs, m.poisson)
        }
        LatticeKind::Hex | LatticeKind::Random2d => {
            check_positive("plate thickness h", h)?;
            let (e2, nu2) = plate_moduli(m, h, plane);
            constants_from_lattice_moduli(kind, a, e2, nu2)
        }
    }
}

/// Spring constants for a lattice: as [`constants_for`], and for random lattices with the
/// calibration of the sampler that scattered their nodes (`k` is then kappa).
pub fn constants_for_lattice(
    lattice: &crate::lattice::Lattice,
    m: &Elastic,
    plane: PlaneModel,
) -> Result<SpringConstants> {
    let Some(cells) = &lattice.cells else {
        return constants_for(lattice.kind, lattice.spacing, m, lattice.thickness, plane);
    };
    check_elastic(m)?;
    let (e, nu) = if lattice.dim() == 2 {
        check_positive("plate thickness h", lattice.thickness)?;
        plate_moduli(m, lattice.thickness, plane)
    } else {
        (m.youngs, m.poisson)
    };
    check_lattice_nu(lattice.kind, nu)?;
    let (k, q) = calibration::constants(lattice.kind, cells.sampler, e, nu)?;
    Ok(SpringConstants { k, q })
}

/// Refuse a material the model cannot represent, with the reason and the fix.
pub fn check_elastic(m: &Elastic) -> Result<()> {
    check_positive("Young's modulus E (Pa)", m.youngs)?;
    check_positive("density (kg/m^3)", m.density)?;
    if !(m.poisson.is_finite() && (NU_MIN..0.5).contains(&m.poisson)) {
        return Err(Error::OutOfRange {
            what: "Poisson's ratio nu",
            value: m.poisson,
            why: format!(
                "an isotropic solid is stable only for -1 < nu < 1/2 (nu = 1/2 is incompressible, \
                 with an infinite bulk modulus); hooke accepts {NU_MIN} <= nu < 0.5, keeping the \
                 lattice's stability margin 1 + 2q away from zero"
            ),
        });
    }
    Ok(())
}

fn check_lattice_nu(kind: LatticeKind, nu: Real) -> Result<()> {
    let (ok, why) = match kind {
        LatticeKind::Cubic | LatticeKind::Random3d => (
            (NU_MIN..0.5).contains(&nu),
            format!(
                "the 3D lattice reaches -1 < nu < 1/2 (q from -1/2 to infinity); hooke accepts \
                 {NU_MIN} <= nu < 0.5 so that the stability margin 1 + 2q stays positive"
            ),
        ),
        LatticeKind::Hex | LatticeKind::Random2d => (
            (NU_MIN..=NU2D_MAX).contains(&nu),
            format!(
                "the 2D lattice's in-plane ratio nu_2D spans -1 < nu_2D < 1 (q from -1/2 to \
                 infinity); hooke accepts {NU_MIN} <= nu_2D <= {NU2D_MAX}. In plane stress nu_2D \
                 = nu, in plane strain nu_2D = nu/(1-nu)"
            ),
        ),
    };
    if nu.is_finite() && ok {
        Ok(())
    } else {
        Err(Error::OutOfRange {
            what: "Poisson's ratio nu",
            value: nu,
            why,
        })
    }
}

fn check_positive(what: &'static str, v: Real) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::OutOfRange {
            what,
            value: v,
            why: "it must be a positive, finite number".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_lattices_have_cauchy_ratios() {
        assert_eq!(q_from_nu(LatticeKind::Cubic, 0.25).unwrap(), 0.0);
        assert!((q_from_nu(LatticeKind::Hex, 1.0 / 3.0).unwrap()).abs() < 1e-15);
        assert!((youngs_from_k(LatticeKind::Cubic, 1.0, 1.0, 0.0) - 2.5).abs() < 1e-15);
        assert!((youngs_from_k(LatticeKind::Hex, 1.0, 1.0, 0.0) - 2.0 / 3f64.sqrt()).abs() < 1e-15);
    }

    #[test]
    fn q_and_nu_are_inverse() {
        for kind in [LatticeKind::Cubic, LatticeKind::Hex] {
            for i in 0..=100 {
                let nu = -0.99 + i as Real * (0.489 + 0.99) / 100.0;
                let q = q_from_nu(kind, nu).unwrap();
                assert!(q > -0.5);
                assert!((nu_from_q(kind, q) - nu).abs() < 1e-13, "{kind:?} {nu}");
            }
        }
    }

    #[test]
    fn out_of_range_is_refused_with_the_range() {
        for nu in [0.5, 0.6, -1.0, Real::NAN] {
            let e = q_from_nu(LatticeKind::Cubic, nu).unwrap_err();
            assert!(e.to_string().contains("-0.99 <= nu < 0.5"), "{e}");
            assert!(e.is_input_error());
        }
        assert!(q_from_nu(LatticeKind::Hex, 0.9).is_ok());
        assert!(q_from_nu(LatticeKind::Hex, 1.0).is_err());
        let bad = Elastic {
            youngs: -1.0,
            poisson: 0.2,
            density: 1.0,
        };
        assert!(check_elastic(&bad).is_err());
        let bad = Elastic {
            youngs: 1.0,
            poisson: 0.2,
            density: 0.0,
        };
        assert!(check_elastic(&bad).is_err());
    }

    #[test]
    fn plane_strain_maps_to_a_larger_in_plane_ratio() {
        let m = Elastic {
            youngs: 72e9,
            poisson: 0.22,
            density: 2440.0,
        };
        let (e2, nu2) = plate_moduli(&m, 1e-3, PlaneModel::Strain);
        assert!((nu2 - 0.22 / 0.78).abs() < 1e-15);
        assert!((e2 - 72e6 / (1.0 - 0.22 * 0.22)).abs() < 1e-3);
        let c = constants_for(LatticeKind::Hex, 1e-3, &m, 1e-3, PlaneModel::Stress).unwrap();
        assert!((youngs_from_k(LatticeKind::Hex, c.k, 1e-3, c.q) - 72e6).abs() < 1e-3);
        assert!((nu_from_q(LatticeKind::Hex, c.q) - 0.22).abs() < 1e-14);
    }
}
