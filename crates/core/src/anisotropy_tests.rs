//! Tests of the anisotropic materials (`hooke_model::anisotropy`) that measure: the bulk
//! stiffness of their bodies against their targets, and their plates.

use crate::anisotropy::*;
use crate::body::Body;
use crate::lattice::{Lattice, LatticeKind};
use crate::math::Real;
use crate::moduli::bulk_stiffness_of;

/// A plate's in-plane stiffness: plane stress gives the engineering form `Q11 = E1 / (1 -
/// nu12 nu21)`, `Q12 = nu12 E2 / (1 - nu12 nu21)`, `Q66 = G12` (fibre as axis 1), plane
/// strain the 3D entries; the same bits for every fibre direction in the plane;
/// orthotropic axes with none along z are refused (a fibre out of the plane: the test
/// below).
#[test]
fn plate_stiffness_is_the_engineering_one_for_any_fibre_in_the_plane() {
    use crate::material::PlaneModel;
    let t = |fibre| material(10e9, 25e9, 0.35, 0.28, 4e9, fibre);
    let m = Anisotropic::Transverse(t([1.0, 0.0, 0.0]));
    let q = m.plane_local_stiffness(PlaneModel::Stress).unwrap();
    let (e1, e2, nu12) = (25e9, 10e9, 0.28);
    let nu21 = nu12 * e2 / e1;
    let d = 1.0 - nu12 * nu21;
    for (got, want) in [
        (q[0][0], e1 / d),
        (q[1][1], e2 / d),
        (q[0][1], nu12 * e2 / d),
        (q[5][5], 4e9),
    ] {
        assert!((got / want - 1.0).abs() < 1e-12, "{got:e} vs {want:e}");
    }
    let own = t([0.0, 0.0, 1.0]).local_stiffness();
    let strain = m.plane_local_stiffness(PlaneModel::Strain).unwrap();
    // Fibre (own axis 3) first, a plane axis second: C33, C11, C13, C55 of its own axes.
    assert_eq!(
        [strain[0][0], strain[1][1], strain[0][1], strain[5][5]],
        [own[2][2], own[0][0], own[0][2], own[4][4]]
    );
    for f in [[0.6, 0.8, 0.0], [-1.0, 1.0, 0.0], [0.0, -2.0, 0.0]] {
        let other = Anisotropic::Transverse(t(f));
        assert_eq!(other.plane_local_stiffness(PlaneModel::Stress).unwrap(), q);
        let (axes, _) = other.plane_axes().unwrap();
        let n = (f[0] * f[0] + f[1] * f[1]).sqrt();
        assert!((axes[0][0] - f[0] / n).abs() < 1e-15 && (axes[0][1] - f[1] / n).abs() < 1e-15);
    }
    let o = Orthotropic {
        youngs: [20e9, 15e9, 10e9],
        poisson: [0.2, 0.25, 0.3],
        shear: [4e9, 5e9, 6e9],
        density: 1500.0,
        axes: Orthotropic::axes_from([1.0, 1.0, 0.0], [-1.0, 1.0, 1.0]).unwrap(),
    };
    let e = Anisotropic::Orthotropic(o).plane_axes().unwrap_err();
    assert!(e.to_string().contains("along z"), "{e}");
    // Turned about z only: the plate's axes are the material's x and y.
    let o = Orthotropic {
        axes: Orthotropic::axes_from([1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]).unwrap(),
        ..o
    };
    let q = Anisotropic::Orthotropic(o)
        .plane_local_stiffness(PlaneModel::Strain)
        .unwrap();
    let own = o.local_stiffness().unwrap();
    assert_eq!(
        [q[0][0], q[1][1], q[0][1], q[5][5]],
        [own[0][0], own[1][1], own[0][1], own[5][5]]
    );
}

/// A fibre out of the plate's plane, at theta to x in the x-z plane: the plate's axes are
/// the body's, its in-plane compliance (plane stress) the engineering one of a direction at
/// theta to the fibre, `1/E_x = c^4/E_t + s^4/E_p + c^2 s^2 (1/G_t - 2 nu_tp/E_t)`,
/// `S_xy = -(c^2 nu_tp/E_t + s^2 nu_p/E_p)`, `1/E_y = 1/E_p`, `1/G_xy = c^2/G_t + s^2/G_p`,
/// to 1e-12; plane strain (out-of-plane shear stresses free) the compliance's route to
/// 1e-12; the mirror's zeros are exact.
#[test]
fn plate_stiffness_of_a_fibre_out_of_the_plane_is_the_engineering_one() {
    use crate::material::PlaneModel;
    let (ep, et, np, ntp, gt) = (10e9, 25e9, 0.35, 0.28, 4e9);
    let gp = ep / (2.0 * (1.0 + np));
    for fibre in [[1.0, 0.0, 0.5], [2.0, 0.0, -1.0], [0.3, 0.0, 1.0]] {
        let t = material(ep, et, np, ntp, gt, fibre);
        let m = Anisotropic::Transverse(t);
        let (axes, sym) = m.plane_axes().unwrap();
        assert_eq!(axes[1], [0.0, 1.0, 0.0]);
        assert!((axes[0][0] - 1.0).abs() < 1e-15 && axes[0][1].abs() < 1e-15);
        assert_eq!(sym, Symmetry::Orthotropic);
        let q = m.plane_local_stiffness(PlaneModel::Stress).unwrap();
        let idx = [0, 1, 5];
        let s = nalgebra::Matrix3::<Real>::from_fn(|a, b| q[idx[a]][idx[b]])
            .try_inverse()
            .unwrap();
        let c2 = fibre[0] * fibre[0] / (fibre[0] * fibre[0] + fibre[2] * fibre[2]);
        let s2 = 1.0 - c2;
        for (got, want) in [
            (
                s[(0, 0)],
                c2 * c2 / et + s2 * s2 / ep + c2 * s2 * (1.0 / gt - 2.0 * ntp / et),
            ),
            (s[(0, 1)], -(c2 * ntp / et + s2 * np / ep)),
            (s[(1, 1)], 1.0 / ep),
            (s[(2, 2)], c2 / gt + s2 / gp),
        ] {
            assert!((got / want - 1.0).abs() < 1e-12, "{got:e} vs {want:e}");
        }
        // Plane strain (eps_zz = 0, out-of-plane shear stresses free), from the compliance
        // in the body's axes (the plate's here): invert S on (xx, yy, zz, xy), then keep
        // the in-plane block of that stiffness.
        let strain = m.plane_local_stiffness(PlaneModel::Strain).unwrap();
        let body = nalgebra::SMatrix::<Real, 6, 6>::from_fn(|a, b| t.stiffness().unwrap()[a][b]);
        let compliance = body.try_inverse().unwrap();
        let four = [0, 1, 2, 5];
        let k = nalgebra::Matrix4::<Real>::from_fn(|a, b| compliance[(four[a], four[b])])
            .try_inverse()
            .unwrap();
        for (a, &i) in [0usize, 1, 3].iter().zip(&idx) {
            for (b, &j) in [0usize, 1, 3].iter().zip(&idx) {
                let scale = k[(*a, *a)].abs().max(k[(*b, *b)].abs());
                let got = strain[i][j];
                assert!(
                    (got - k[(*a, *b)]).abs() < 1e-12 * scale,
                    "{got:e} vs {:e}",
                    k[(*a, *b)]
                );
            }
        }
        for qq in [q, strain] {
            assert_eq!([qq[0][5], qq[1][5], qq[5][0], qq[5][1]], [0.0; 4]);
        }
    }
}

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
            let c = bulk_stiffness_of(LatticeKind::Cubic, a, &|l| Body::transverse(l, &t)).unwrap();
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

/// Any fibre direction: a Ladd lattice laid along the fibre ([`lattice_rotation`],
/// [`Lattice::rotated`]) has the target's bulk tensor in the global axes to round-off.
#[test]
fn a_lattice_laid_along_any_fibre_has_the_target_tensor() {
    for fibre in [
        [1.0, 2.0, 0.5],
        [0.3, -0.2, 1.0],
        [1.0, 0.577, 0.0],
        [-1.0, 1.0, 1.0],
    ] {
        let t = material(10e9, 25e9, 0.35, 0.28, 4e9, fibre);
        let a = 1e-3;
        let r = lattice_rotation(fibre).unwrap();
        // The rotation takes a lattice axis onto the fibre.
        let m = t.axis().unwrap();
        let cols: Vec<Real> = (0..3)
            .map(|k| (0..3).map(|i| r[(i, k)] * m[i]).sum::<Real>().abs())
            .collect();
        assert!(
            cols.iter().any(|c| (c - 1.0).abs() < 1e-12),
            "{fibre:?}: {cols:?}"
        );
        let centre = crate::math::Vector::repeat(3.0 * a);
        let c = bulk_stiffness_of(LatticeKind::Cubic, a, &|l| {
            Body::transverse(l.rotated(&r, centre)?, &t)
        })
        .unwrap();
        let target = t.stiffness().unwrap();
        let err = worst(&c, &target);
        assert!(err < 1e-9, "fibre {fibre:?}: differs by {err:e}");
    }
}

/// The isotropic material is the paper's lattice: every family has k = mu a, w = 1, and q
/// is `0.3 (4 nu - 1)/(1 - 2 nu)` (`docs/model.md`).
#[test]
fn isotropic_targets_give_the_papers_lattice() {
    for nu in [-0.8, 0.0, 0.25, 0.45] {
        let (e, a) = (70e9, 1e-3);
        let f = cubic_families(&Transverse::isotropic(e, nu, 2500.0, [0.0, 0.0, 1.0]), a).unwrap();
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

/// Orthotropic targets with their axes on the lattice's: the bulk tensor is the target to
/// round-off (q of both signs, and the case of one coupled plane).
#[test]
fn orthotropic_bulk_tensors_are_the_target() {
    let cases = [
        // wood-like (L = x, R = y, T = z) with shear moduli the lattice reaches (real
        // spruce's G_LR, G_LT are not: see the next test)
        Orthotropic {
            youngs: [12e9, 1.2e9, 0.8e9],
            poisson: [0.42, 0.45, 0.5],
            shear: [0.08e9, 0.3e9, 0.35e9],
            density: 500.0,
            axes: Orthotropic::AXES,
        },
        // a cross-ply laminate-like block
        Orthotropic {
            youngs: [60e9, 50e9, 10e9],
            poisson: [0.05, 0.3, 0.32],
            shear: [4e9, 4.5e9, 5e9],
            density: 1600.0,
            axes: Orthotropic::AXES,
        },
        // auxetic couplings (q < 0)
        Orthotropic {
            youngs: [5e9, 7e9, 9e9],
            poisson: [-0.2, -0.1, -0.15],
            shear: [3.5e9, 3e9, 2.5e9],
            density: 1000.0,
            axes: Orthotropic::AXES,
        },
    ];
    for o in cases {
        let a = 1e-3;
        let f = ladd_families(&o.stiffness().unwrap(), a)
            .unwrap_or_else(|e| panic!("{o:?}: {}", e.why()));
        let c = bulk_stiffness_of(LatticeKind::Cubic, a, &|l| Body::orthotropic(l, &o)).unwrap();
        let target = o.stiffness().unwrap();
        let err = worst(&c, &target);
        assert!(err < 1e-9, "{o:?} (q {}): differs by {err:e}", f.q);
    }
    // One coupled plane: only C12 != C66 (C13 = C55, C23 = C44), built from the stiffness.
    let mut c = [[0.0; 6]; 6];
    c[0][0] = 10e9;
    c[1][1] = 10e9;
    c[2][2] = 14e9;
    c[0][1] = 4e9;
    c[1][0] = 4e9;
    c[0][2] = 3e9;
    c[2][0] = 3e9;
    c[1][2] = 2.5e9;
    c[2][1] = 2.5e9;
    c[3][3] = 2.5e9;
    c[4][4] = 3e9;
    c[5][5] = 2e9;
    let f = ladd_families(&c, 1e-3).unwrap();
    assert!(f.q > 0.0, "{f:?}");
    let built = |l: Lattice| {
        let mut b = Body::ladd(l, &f, 1.0, &Orthotropic::AXES)?;
        b.q = f.q;
        Ok(b)
    };
    let m = bulk_stiffness_of(LatticeKind::Cubic, 1e-3, &built).unwrap();
    assert!(worst(&m, &c) < 1e-9, "{:e}", worst(&m, &c));
}

/// Orthotropic materials whose axes are turned against the body, on a cubic lattice laid
/// along them: the bulk tensor is the target turned by the axes, to round-off, for a turn
/// about z, one about an oblique axis, and a frame with its axes swapped. A lattice left
/// along the body's axes is refused with the fix, and axes that are not at right angles are
/// refused with the angle between them.
#[test]
fn turned_orthotropic_bulk_tensors_are_the_turned_target() {
    let (c30, s30) = (
        (30.0 as Real).to_radians().cos(),
        (30.0 as Real).to_radians().sin(),
    );
    let frames = [
        Orthotropic::axes_from([c30, s30, 0.0], [-s30, c30, 0.0]).unwrap(),
        Orthotropic::axes_from([1.0, 2.0, 0.5], [2.0, -1.0, 0.0]).unwrap(),
        Orthotropic::axes_from([0.0, 0.0, 1.0], [1.0, 0.0, 0.0]).unwrap(),
    ];
    let local = Orthotropic {
        youngs: [60e9, 50e9, 10e9],
        poisson: [0.05, 0.3, 0.32],
        shear: [4e9, 4.5e9, 5e9],
        density: 1600.0,
        axes: Orthotropic::AXES,
    };
    let a = 1e-3;
    for (k, axes) in frames.into_iter().enumerate() {
        let o = Orthotropic { axes, ..local };
        let r = o.lattice_rotation();
        // Right-handed and orthonormal.
        assert!((r.determinant() - 1.0).abs() < 1e-12);
        assert!((r.transpose() * r - crate::math::Matrix::identity()).norm() < 1e-12);
        let centre = crate::math::Vector::repeat(3.0 * a);
        let c = bulk_stiffness_of(LatticeKind::Cubic, a, &|l| {
            Body::orthotropic(l.rotated(&r, centre)?, &o)
        })
        .unwrap();
        let target = o.stiffness().unwrap();
        assert!(
            worst(&c, &target) < 1e-9,
            "{axes:?}: {:e}",
            worst(&c, &target)
        );
        // The turn really moved the tensor: it is not the unturned one.
        assert!(worst(&target, &local.stiffness().unwrap()) > 1e-3);
        // Off the lattice's axes the unturned lattice cannot hold it (a permutation of the
        // axes, the third frame, it can).
        let unturned = Body::orthotropic(Lattice::cubic_box([3, 3, 3], a).unwrap(), &o);
        match unturned {
            Err(e) => assert!(k < 2 && e.to_string().contains("material.axes"), "{e}"),
            Ok(_) => assert_eq!(k, 2),
        }
    }
    let e = Orthotropic::axes_from([1.0, 0.0, 0.0], [0.1, 1.0, 0.0]).unwrap_err();
    assert!(e.to_string().contains("not perpendicular"), "{e}");
    assert!(Orthotropic::axes_from([0.0; 3], [0.0, 1.0, 0.0]).is_err());
}

#[test]
fn unreachable_orthotropic_stiffnesses_say_why() {
    let base = Orthotropic {
        youngs: [60e9, 50e9, 10e9],
        poisson: [0.05, 0.3, 0.32],
        shear: [4e9, 4.5e9, 5e9],
        density: 1600.0,
        axes: Orthotropic::AXES,
    };
    let mut c = base.stiffness().unwrap();
    // Two planes coupled, one not.
    c[1][2] = c[3][3];
    c[2][1] = c[3][3];
    assert!(matches!(
        ladd_families(&c, 1e-3),
        Err(Unreachable::Coupling(_))
    ));
    // Shear moduli too large for the soft axis: spruce-like wood (G_LT = 0.7 GPa, G_LR =
    // 0.9 GPa against E_T = 0.8 GPa) would need z springs of negative stiffness.
    let wood = Orthotropic {
        youngs: [12e9, 1.2e9, 0.8e9],
        poisson: [0.42, 0.45, 0.5],
        shear: [0.1e9, 0.7e9, 0.9e9],
        density: 500.0,
        axes: Orthotropic::AXES,
    };
    let e = ladd_families(&wood.stiffness().unwrap(), 1e-3).unwrap_err();
    assert!(matches!(e, Unreachable::Axis { .. }), "{e:?}");
    assert!(e.why().contains("negative stiffness"));
    // Not a material.
    let mut o = base;
    o.poisson = [0.9, 0.9, 0.9];
    assert!(o
        .stiffness()
        .unwrap_err()
        .to_string()
        .contains("positive definite"));
    let hex = Lattice::hex_box(4, 4, 1e-3, 1e-3).unwrap();
    assert!(Body::orthotropic(hex, &base)
        .unwrap_err()
        .to_string()
        .contains("cubic"));
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
    // Off a lattice axis: the body says how to lay the lattice along the fibre.
    let off = material(10e9, 20e9, 0.25, 0.2, 3e9, [1.0, 1.0, 0.0]);
    let cube = Lattice::cubic_box([3, 3, 3], 1e-3).unwrap();
    let msg = format!("{}", Body::transverse(cube, &off).unwrap_err());
    assert!(
        msg.contains("lattice axis") && msg.contains("rotate_to"),
        "{msg}"
    );
    // No direction.
    assert!(why(material(10e9, 20e9, 0.25, 0.2, 3e9, [0.0; 3])).contains("non-zero"));
    // Other lattices are refused.
    let hex = Lattice::hex_box(4, 4, 1e-3, 1e-3).unwrap();
    let t = material(10e9, 20e9, 0.25, 0.2, 3e9, z);
    assert!(format!("{}", Body::transverse(hex, &t).unwrap_err()).contains("cubic"));
}
