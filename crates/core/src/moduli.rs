//! Measuring the elastic moduli of a lattice: the paper's block test (Section 4) and an exact
//! bulk (affine) test.
//!
//! **Block test.** A box of `nx x ny x nz` nodes (3D) or `nx` nodes by `rows` rows (2D) is
//! loaded by displacing its two x-end node planes by `-/+ eps Lx/2` along x, `Lx = (nx-1) a`
//! (each end node by `eps (x - Lx/2)`: the hexagonal strip's ends are zigzag).
//! With [`Ends::Slide`] the end nodes are free across (y, z); the rigid motions that leaves free
//! (translations across, rotation about x) are projected out. With [`Ends::Clamp`] they are
//! fixed across. Then
//!
//! * `E = (F/A) / eps`, F the total reaction on one end plane and A the nominal cross-section
//!   between the outer node planes, `(ny-1)a x (nz-1)a` (3D) or `(rows-1) sqrt(3)/2 a` per unit
//!   thickness (2D). The node-cell area (`ny a x nz a`) is reported too: the true
//!   load-carrying section lies between the two.
//! * `nu = -(dW/W) / eps`, dW the change of distance between the two outer node rows of the middle
//!   cross-section (averaged over the rows in y and z in 3D) and W that distance.
//!
//! Free faces bias the measured nu by roughly `a/W` (`docs/model.md`) on a lattice whose springs
//! are all alike. With [`BlockTest::cell_weights`] each spring and node stands for its share of
//! the cells (cubes, triangles) that hold it, and a uniform strain is then an exact equilibrium
//! of the whole block, faces included: the Ladd block reads the target nu and E (on the nominal
//! section) to round-off.
//!
//! **Bulk test.** In a perfect lattice a uniform strain is an exact equilibrium (both lattices
//! are Bravais lattices: every node is a centre of symmetry, so there is no internal
//! relaxation). The stress of a node deep inside a small box under an affine displacement field,
//! computed from the law's linearised tensions ([`Tangent::tension_changes`]), is then the bulk
//! stress of the infinite lattice, exact to round-off. It gives C11, C12, C44 and with them E,
//! nu and the isotropy check `C11 - C12 = 2 C44`.

use crate::body::Body;
use crate::error::{Error, Result};
use crate::lattice::{Lattice, LatticeKind};
use crate::law;
use crate::material::{nu_from_q, q_from_nu, youngs_from_k};
use crate::math::{Coords, Matrix, Real, Vector};
use crate::random::anisotropic::Designs;
use crate::random::{calibration, RandomSpec};
use crate::state::State;
use crate::statics::{self, Constraints, StaticOptions, StaticReport};

pub use crate::cube::{interior_box, interior_strain, interior_stress, relax_cube, CubeStiffness};
use crate::tangent::Tangent;

/// How the loaded end planes are held across the load direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ends {
    /// Free to slide across (uniaxial stress; the paper's setting).
    Slide,
    /// Fixed across.
    Clamp,
}

/// The block test's set-up (lattice units unless the caller scales them).
#[derive(Clone, Debug)]
pub struct BlockTest {
    pub kind: LatticeKind,
    /// The lattice's own Poisson's ratio to build (nu_2D for the hexagonal lattice).
    pub nu: Real,
    /// Nodes per axis; `[nx, rows, 1]` for the hexagonal lattice.
    pub size: [usize; 3],
    pub ends: Ends,
    /// Applied axial strain eps (positive stretches).
    pub strain: Real,
    /// Spacing a (m) and stiffness k (N/m).
    pub spacing: Real,
    pub stiffness: Real,
    pub solver: StaticOptions,
    /// Random lattices only: how the nodes are scattered, and the load axis (0, 1, 2 = x, y, z;
    /// the box's long side lies along it). Regular lattices are loaded along x.
    pub random: RandomSpec,
    pub axis: usize,
    /// Build with this q instead of the one `nu` maps to (calibration runs).
    pub q: Option<Real>,
    /// Regular lattices: weight each spring and node by the share of the bulk's cells it stands
    /// for ([`Body::with_cell_weights`]), which removes the free-surface bias.
    pub cell_weights: bool,
    /// Build this anisotropic material ([`Body::transverse`], [`Body::orthotropic`] on the
    /// cubic lattice; the calibrated design on random ones) instead of the isotropic one (`nu`, `q` and `stiffness` are then
    /// unused). The targets are the compliance's: `E = 1/S_xx`, and the lateral ratios
    /// `-S_yx/S_xx`, `-S_zx/S_xx` ([`BlockResult::lateral_target`]).
    pub anisotropic: Option<crate::anisotropy::Anisotropic>,
    /// random3d only: test the cylinder inscribed in the box along the load axis (its diameter
    /// the smaller lateral side) instead of the box, a pillar with a curved surface.
    pub cylinder: bool,
    /// With `cylinder`: put the nodes of its wall on the surface ([`crate::random::Curved`]),
    /// as the box's faces have theirs. Off, the wall's outer nodes lie inside the surface (the
    /// box's nodes that the cylinder holds), as before curved surfaces were sampled.
    pub conform: bool,
    /// random2d with an anisotropic material: how the plate stands for it (the targets are then
    /// the plate's in-plane compliance's, [`crate::Anisotropic::plane_stiffness`]).
    pub plane: crate::material::PlaneModel,
}

impl BlockTest {
    /// The paper's block for `kind` (71 x 16 x 16 nodes, or 71 nodes x 16 rows), a = k = 1,
    /// eps = 1e-5, sliding ends.
    pub fn paper(kind: LatticeKind, nu: Real) -> Self {
        BlockTest {
            kind,
            nu,
            size: match kind.dim() {
                3 => [71, 16, 16],
                _ => [71, 16, 1],
            },
            ends: Ends::Slide,
            strain: 1e-5,
            spacing: 1.0,
            stiffness: 1.0,
            solver: StaticOptions::default(),
            random: RandomSpec::default(),
            axis: 0,
            q: None,
            cell_weights: false,
            anisotropic: None,
            cylinder: false,
            conform: true,
            plane: crate::material::PlaneModel::Stress,
        }
    }
}

/// What the block test measured.
#[derive(Clone, Debug)]
pub struct BlockResult {
    pub nu_target: Real,
    pub nu_measured: Real,
    /// Target E: Pa in 3D, N/m (per thickness) in 2D.
    pub e_target: Real,
    /// E with the nominal cross-section between the outer node planes.
    pub e_measured: Real,
    /// E with the node-cell cross-section (`ny a x nz a`; `rows sqrt(3)/2 a` in 2D).
    pub e_measured_cell: Real,
    pub q: Real,
    pub nodes: usize,
    pub springs: usize,
    pub solve: StaticReport,
    /// The cubic lattice: the lateral strain ratios `-eps_yy/eps`, `-eps_zz/eps` of the middle
    /// cross-section separately (`nu_measured` is their mean), and their targets.
    pub lateral_measured: Option<[Real; 2]>,
    pub lateral_target: Option<[Real; 2]>,
    /// Random lattices: E from the middle third's axial strain (the least-squares slope of the
    /// axial displacement there) instead of the end planes' travel, so the ends' own layer
    /// (held along the load, a layer that cannot relax) is left out.
    pub e_measured_middle: Option<Real>,
}

/// A regular block test's targets: `q`, and E and the two lateral ratios under uniaxial
/// stress along x.
fn block_targets(t: &BlockTest) -> Result<(Real, Real, [Real; 2])> {
    Ok(match &t.anisotropic {
        Some(m) => {
            let c = m.stiffness()?;
            let c = nalgebra::Matrix6::from_fn(|i, j| c[i][j]);
            let s = c.try_inverse().ok_or_else(|| Error::InvalidInput {
                what: "anisotropic material",
                why: "its stiffness is singular".into(),
            })?;
            let f = m.families(t.spacing)?;
            (
                f.q,
                1.0 / s[(0, 0)],
                [-s[(1, 0)] / s[(0, 0)], -s[(2, 0)] / s[(0, 0)]],
            )
        }
        None => {
            let q = q_from_nu(t.kind, t.nu)?;
            (
                q,
                youngs_from_k(t.kind, t.stiffness, t.spacing, q),
                [t.nu; 2],
            )
        }
    })
}

/// The regular block of a block test (`q` its dispersion), cell-weighted if asked.
fn regular_block(t: &BlockTest, q: Real) -> Result<Body> {
    let a = t.spacing;
    let lattice = match t.kind {
        LatticeKind::Random2d | LatticeKind::Random3d => unreachable!("handled above"),
        LatticeKind::Cubic => Lattice::cubic_box(t.size, a)?,
        LatticeKind::Hex => {
            if t.size[2] != 1 {
                return Err(Error::InvalidInput {
                    what: "size",
                    why: "the hexagonal lattice is 2D: give two numbers, NX,ROWS".into(),
                });
            }
            Lattice::hex_box(t.size[0], t.size[1], a, 1.0)?
        }
    };
    if t.size[0] < 3 {
        return Err(Error::InvalidInput {
            what: "size",
            why: "the bar needs at least 3 nodes along x".into(),
        });
    }
    let mut body = match &t.anisotropic {
        Some(m) => m.body(lattice)?,
        None => Body::uniform(lattice, t.stiffness, q, 1.0),
    };
    if t.cell_weights {
        body = body.with_cell_weights()?;
    }
    Ok(body)
}

/// Run the block test.
pub fn block_test(t: &BlockTest) -> Result<BlockResult> {
    if !(t.strain.is_finite() && t.strain != 0.0 && t.strain.abs() <= 0.1) {
        return Err(Error::InvalidInput {
            what: "strain",
            why: format!(
                "eps = {}: give a small non-zero strain, |eps| <= 0.1 (e.g. 1e-5)",
                t.strain
            ),
        });
    }
    if t.kind.is_random() {
        return random_block_test(t);
    }
    let (q, e_target, lateral_target) = block_targets(t)?;
    let nu_target = 0.5 * (lateral_target[0] + lateral_target[1]);
    let a = t.spacing;
    let body = regular_block(t, q)?;
    body.validate()?;
    let lat = &body.lattice;
    let n = body.nodes();
    let nx = t.size[0];
    let lx = (nx - 1) as Real * a;
    let pos = &lat.pos;
    let xc = 0.5 * lx;
    let (yc, zc) = centre(pos);

    // Ends: column 0 and column nx-1 of every row.
    let mut cons = Constraints::all_free(n);
    let mut state = State::new(&body);
    let end_of = |i: usize| -> Option<Real> {
        let ix = i % nx;
        if ix == 0 {
            Some(-1.0)
        } else if ix == nx - 1 {
            Some(1.0)
        } else {
            None
        }
    };
    // Start from the affine solution of the target material: the solver then only has to find
    // the surface corrections, which are short-ranged.
    for i in 0..n {
        let p = pos.get(i);
        let mut u = Vector::new(
            t.strain * (p.x - xc),
            -lateral_target[0] * t.strain * (p.y - yc),
            -lateral_target[1] * t.strain * (p.z - zc),
        );
        if t.kind.dim() == 2 {
            u.z = 0.0;
            cons.fix(i, 2);
        }
        if end_of(i).is_some() {
            // The affine value: a hexagonal strip's ends are zigzag (odd rows stand a/2 further
            // along x), and holding them all at -/+ eps Lx/2 would shear its end cells.
            u.x = t.strain * (p.x - xc);
            cons.fix(i, 0);
            if t.ends == Ends::Clamp {
                u.y = 0.0;
                u.z = 0.0;
                cons.fix(i, 1);
                cons.fix(i, 2);
            }
        }
        state.u.set(i, u);
    }
    if t.ends == Ends::Slide {
        slide_modes(&mut cons, pos, t.kind.dim(), yc, zc);
    }
    let solve = statics::solve(&body, &mut state, &cons, None, &t.solver)?;

    // Reaction on the +x end: minus the internal force there.
    let force: Real = (0..n)
        .filter(|&i| end_of(i) == Some(1.0))
        .map(|i| -state.f.x()[i])
        .sum();
    let (area, area_cell, w_change, lateral) = regular_lateral(t, lat, &state.u);
    Ok(BlockResult {
        nu_target,
        nu_measured: -w_change / t.strain,
        e_target,
        e_measured: force / area / t.strain,
        e_measured_cell: force / area_cell / t.strain,
        q,
        nodes: n,
        springs: body.springs(),
        solve,
        e_measured_middle: None,
        lateral_measured: lateral,
        lateral_target: (t.kind == LatticeKind::Cubic).then_some(lateral_target),
    })
}

/// A regular block's section (nominal and by node cells) and its lateral strain at the middle
/// cross-section: the mean over the lateral axes, and each axis's ratio (cubic).
fn regular_lateral(
    t: &BlockTest,
    lat: &Lattice,
    u: &Coords,
) -> (Real, Real, Real, Option<[Real; 2]>) {
    let a = t.spacing;
    let [nx, ny, nz] = t.size;
    let pos = &lat.pos;
    let xc = 0.5 * (nx - 1) as Real * a;
    match t.kind {
        LatticeKind::Cubic => {
            let w = (ny - 1) as Real * a;
            let h = (nz - 1) as Real * a;
            let mids = middle_columns(nx);
            let u = |ix: usize, iy: usize, iz: usize, c: usize| {
                let i = lat.grid_index(ix, iy, iz);
                u.comp(c)[i]
            };
            let mut dy = 0.0;
            for &ix in &mids {
                for iz in 0..nz {
                    dy += (u(ix, ny - 1, iz, 1) - u(ix, 0, iz, 1)) / w;
                }
            }
            dy /= (mids.len() * nz) as Real;
            let mut dz = 0.0;
            for &ix in &mids {
                for iy in 0..ny {
                    dz += (u(ix, iy, nz - 1, 2) - u(ix, iy, 0, 2)) / h;
                }
            }
            dz /= (mids.len() * ny) as Real;
            (
                w * h,
                (ny * nz) as Real * a * a,
                0.5 * (dy + dz),
                Some([-dy / t.strain, -dz / t.strain]),
            )
        }
        LatticeKind::Hex => {
            let dyr = a * (3.0 as Real).sqrt() / 2.0;
            let w = (ny - 1) as Real * dyr;
            // Nodes of the outer rows nearest the mid-length (one or two per row).
            let row_mean = |r: usize| {
                let idx: Vec<usize> = (0..nx).map(|c| c + nx * r).collect();
                let best = idx
                    .iter()
                    .map(|&i| (pos.x()[i] - xc).abs())
                    .fold(Real::INFINITY, Real::min);
                let sel: Vec<usize> = idx
                    .into_iter()
                    .filter(|&i| (pos.x()[i] - xc).abs() <= best + 1e-9 * a)
                    .collect();
                sel.iter().map(|&i| u.y()[i]).sum::<Real>() / sel.len() as Real
            };
            (
                w,
                ny as Real * dyr,
                (row_mean(ny - 1) - row_mean(0)) / w,
                None,
            )
        }
        LatticeKind::Random2d | LatticeKind::Random3d => unreachable!("handled above"),
    }
}

/// A regular block's free motions with sliding ends, projected out of the solve: translation
/// across the load (y, and z in 3D) and the rotation about the bar's axis (3D).
fn slide_modes(cons: &mut Constraints, pos: &Coords, dim: usize, yc: Real, zc: Real) {
    let n = pos.len();
    let mut ty = Coords::zeros(n);
    ty.y_mut().fill(1.0);
    cons.add_null_mode(ty);
    if dim == 3 {
        let mut tz = Coords::zeros(n);
        tz.z_mut().fill(1.0);
        cons.add_null_mode(tz);
        let mut rx = Coords::zeros(n);
        for i in 0..n {
            rx.y_mut()[i] = -(pos.z()[i] - zc);
            rx.z_mut()[i] = pos.y()[i] - yc;
        }
        cons.add_null_mode(rx);
    }
}

/// The random bar (or, with `t.cylinder`, the pillar inscribed in it: radius `radius` about
/// the load axis `ax` through `centre`, its curved wall conforming unless `t.conform` is off).
fn random_block_lattice(
    t: &BlockTest,
    ax: usize,
    ext: [Real; 3],
    centre: [Real; 3],
    radius: Real,
    radial: &(dyn Fn([Real; 3]) -> [Real; 3] + Sync),
) -> Result<Lattice> {
    let (dim, a) = (t.kind.dim(), t.spacing);
    Ok(if t.cylinder {
        let tol = 1e-9 * a;
        let inside = |p: [Real; 3]| {
            let d = radial(p);
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() <= radius + tol
                && p[ax] >= -tol
                && p[ax] <= ext[ax] + tol
        };
        let mut curved = Vec::new();
        if t.conform {
            curved.push(crate::random::Curved::cylinder_wall(
                centre,
                ax,
                radius,
                0.5 * ext[ax],
            ));
            for end in [0.0, ext[ax]] {
                let mut c = centre;
                c[ax] = end;
                curved.push(crate::random::Curved::circle(3, c, ax, radius));
            }
        }
        Lattice::random_conforming(dim, [0.0; 3], ext, a, 1.0, t.random, &inside, &curved)?
    } else {
        Lattice::random(dim, [0.0; 3], ext, a, 1.0, t.random, &|_| true)?
    })
}

/// The lateral strain of a random bar's middle third: for the pillar, the least-squares fit of
/// `u_r = eps_r r` over its nodes (exact for a uniform lateral strain, whatever the nodes'
/// radii); for the box, the mean over its lateral axes of the change of width between the
/// sides' nodes, and each axis's ratio to the load.
fn random_lateral_strain(
    t: &BlockTest,
    u: &Coords,
    pos: &Coords,
    (ax, lateral): (usize, &[usize]),
    (centre, ext): ([Real; 3], [Real; 3]),
    radial: &dyn Fn([Real; 3]) -> [Real; 3],
) -> (Real, [Real; 2]) {
    let n = u.len();
    let len = ext[ax];
    let mut lateral_strain = 0.0;
    let mut per_axis = [0.0; 2];
    if t.cylinder {
        // The radial strain of the middle third: the least-squares fit of u_r = eps_r r over
        // its nodes (exact for a uniform lateral strain, whatever the nodes' radii).
        let (mut ur, mut rr) = (0.0, 0.0);
        for i in 0..n {
            if (pos.comp(ax)[i] - centre[ax]).abs() > len / 6.0 {
                continue;
            }
            let d = radial([pos.x()[i], pos.y()[i], pos.z()[i]]);
            let u = u.get(i);
            ur += u.x * d[0] + u.y * d[1] + u.z * d[2];
            rr += d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        }
        lateral_strain = ur / rr;
    }
    for (m, &c) in lateral.iter().enumerate().filter(|_| !t.cylinder) {
        let side_mean = |at: Real| {
            let sel: Vec<usize> = (0..n)
                .filter(|&i| {
                    pos.comp(c)[i] == at && (pos.comp(ax)[i] - centre[ax]).abs() <= len / 6.0
                })
                .collect();
            sel.iter().map(|&i| u.comp(c)[i]).sum::<Real>() / sel.len().max(1) as Real
        };
        let e = (side_mean(ext[c]) - side_mean(0.0)) / ext[c];
        per_axis[m] = -e / t.strain;
        lateral_strain += e;
    }
    if !t.cylinder {
        lateral_strain /= lateral.len() as Real;
    }
    (lateral_strain, per_axis)
}

/// A random bar's free motions with sliding ends, projected out of the solve: the translations
/// across the load and, in 3D (two lateral axes), the rotation about the bar's axis.
fn random_slide_modes(cons: &mut Constraints, pos: &Coords, lateral: &[usize], centre: [Real; 3]) {
    let n = pos.len();
    for &c in lateral {
        let mut tr = Coords::zeros(n);
        tr.comp_mut(c).fill(1.0);
        cons.add_null_mode(tr);
    }
    if lateral.len() == 2 {
        let (b, c) = (lateral[0], lateral[1]);
        let mut rot = Coords::zeros(n);
        for i in 0..n {
            rot.comp_mut(b)[i] = -(pos.comp(c)[i] - centre[c]);
            rot.comp_mut(c)[i] = pos.comp(b)[i] - centre[b];
        }
        cons.add_null_mode(rot);
    }
}

/// The Poisson's ratio a random block is compared with, and its lateral ratios measured and
/// targeted: an anisotropic material's mean ratio (a plate's in-plane one: its second is the
/// out-of-plane ratio, not measured; the pillar's radial strain has no per-axis ratios), or the
/// isotropic target.
#[allow(clippy::type_complexity)]
fn lateral_targets(
    t: &BlockTest,
    ratios: Option<[Real; 2]>,
    per_axis: [Real; 2],
) -> (Real, Option<[Real; 2]>, Option<[Real; 2]>) {
    let dim = t.kind.dim();
    match ratios {
        Some(r) if dim == 3 && !t.cylinder => (0.5 * (r[0] + r[1]), Some(per_axis), Some(r)),
        Some(r) if dim == 2 => (r[0], None, Some(r)),
        Some(r) => (0.5 * (r[0] + r[1]), None, Some(r)),
        None => (t.nu, None, None),
    }
}

/// An anisotropic block's calibrated direction functions and its targets under uniaxial stress
/// along axis `ax`, from the compliance: E = 1 / S_aa and the lateral ratios -S_ca / S_aa (a
/// plate's: of its in-plane stiffness, xx yy xy, per thickness).
fn anisotropic_targets(
    t: &BlockTest,
    m: &crate::Anisotropic,
    dim: usize,
    ax: usize,
) -> Result<(crate::random::anisotropic::Calibrated, Real, [Real; 2])> {
    let sampler = t.random.sampler;
    let singular = || Error::InvalidInput {
        what: "anisotropic material",
        why: "its stiffness is singular".into(),
    };
    let s = if dim == 2 {
        let c = m.plane_stiffness(t.plane)?;
        let idx = [0, 1, 5];
        let s3 = nalgebra::Matrix3::from_fn(|i, j| c[idx[i]][idx[j]])
            .try_inverse()
            .ok_or_else(singular)?;
        let mut s = nalgebra::Matrix6::<Real>::zeros();
        for i in 0..3 {
            for j in 0..3 {
                s[(idx[i], idx[j])] = s3[(i, j)];
            }
        }
        s
    } else {
        let c = m.stiffness()?;
        nalgebra::Matrix6::from_fn(|i, j| c[i][j])
            .try_inverse()
            .ok_or_else(singular)?
    };
    let design = m.random_design_for(dim, sampler, t.plane)?;
    let lat: Vec<usize> = (0..3).filter(|&c| c != ax).collect();
    let ratios = [
        -s[(lat[0], ax)] / s[(ax, ax)],
        -s[(lat[1], ax)] / s[(ax, ax)],
    ];
    Ok((design, 1.0 / s[(ax, ax)], ratios))
}

/// The axial strain of the middle third of a bar along axis `ax` (centre `mid`, length `len`):
/// the least-squares slope of u_ax against the position over its nodes.
fn middle_axial_strain(u: &Coords, pos: &Coords, ax: usize, mid: Real, len: Real) -> Real {
    let (mut xu, mut xx, mut sx, mut su, mut m) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..u.len() {
        let x = pos.comp(ax)[i] - mid;
        if x.abs() <= len / 6.0 {
            let u = u.comp(ax)[i];
            xu += x * u;
            xx += x * x;
            sx += x;
            su += u;
            m += 1.0;
        }
    }
    (xu - sx * su / m) / (xx - sx * sx / m)
}

/// A random block test's box: the lateral axes in order, the extent along each axis (the
/// long side along the load axis `ax`) and the centre.
fn random_block_box(t: &BlockTest, dim: usize, ax: usize) -> (Vec<usize>, [Real; 3], [Real; 3]) {
    let a = t.spacing;
    let lateral: Vec<usize> = (0..dim).filter(|&c| c != ax).collect();
    let mut ext = [0.0; 3];
    ext[ax] = (t.size[0].max(2) - 1) as Real * a;
    for (m, &c) in lateral.iter().enumerate() {
        ext[c] = (t.size[m + 1].max(2) - 1) as Real * a;
    }
    let mut centre = [0.0; 3];
    for c in 0..dim {
        centre[c] = 0.5 * ext[c];
    }
    (lateral, ext, centre)
}

/// A random block test's body and its target E: an anisotropic material's calibrated design
/// (with its target), or `k_s = kappa V_s / L_s^2` at `q` with the calibrated E.
fn random_block_body(
    t: &BlockTest,
    lattice: Lattice,
    aniso: Option<(&crate::random::anisotropic::Calibrated, Real)>,
    q: Real,
) -> Result<(Body, Real)> {
    let sampler = t.random.sampler;
    Ok(match aniso {
        Some((cal, e)) => (cal.design.body(lattice, 1.0)?, e),
        None => {
            // k_s = kappa V_s / L_s^2 with kappa = t.stiffness (statics: the masses play no
            // part).
            let body = Body::from_cells(lattice, t.stiffness, q, 1.0);
            body.validate()?;
            (
                body,
                calibration::youngs_for(t.kind, sampler, t.stiffness, q),
            )
        }
    })
}

/// The block test on a random lattice. The box is `(size - 1) a` long per axis (the regular
/// lattices' nominal box), its long side along `t.axis`. Its faces are flat (the samplers conform
/// to the box), so the cross-section is exact: `E = F / (W H eps)`, `F` the reaction on the
/// loaded end face. `nu` is the mean lateral strain of the middle third of the bar: the mean
/// displacement of the nodes on each side face there, differenced across the bar.
fn random_block_test(t: &BlockTest) -> Result<BlockResult> {
    let dim = t.kind.dim();
    if t.axis >= dim {
        return Err(Error::InvalidInput {
            what: "load axis",
            why: format!(
                "axis {} does not exist in {dim}D: give 0 (x), 1 (y) or 2 (z)",
                t.axis
            ),
        });
    }
    let sampler = t.random.sampler;
    let ax = t.axis;
    // An anisotropic material: its calibrated direction functions and targets.
    let aniso = match &t.anisotropic {
        Some(m) => Some(anisotropic_targets(t, m, dim, ax)?),
        None => None,
    };
    let q = match (&aniso, t.q) {
        (Some((cal, ..)), _) => cal.design.q,
        (None, Some(q)) => q,
        (None, None) => calibration::q_for_nu_for(t.kind, sampler, t.nu)?,
    };
    let nu_guess = match &aniso {
        Some((.., r)) => [r[0], r[1]],
        None => [t.nu; 2],
    };
    // Lateral axes in order, the long side along the load axis.
    let (lateral, ext, centre) = random_block_box(t, dim, ax);
    if t.cylinder && dim != 3 {
        return Err(Error::InvalidInput {
            what: "cylinder",
            why: "the pillar test is for random3d lattices: give --lattice random3d".into(),
        });
    }
    // The pillar's radius, and a node's distance from its axis.
    let radius = lateral
        .iter()
        .map(|&c| ext[c])
        .fold(Real::INFINITY, Real::min)
        / 2.0;
    let radial = |p: [Real; 3]| -> [Real; 3] {
        let mut d = [0.0; 3];
        for &c in &lateral {
            d[c] = p[c] - centre[c];
        }
        d
    };
    let lattice = random_block_lattice(t, ax, ext, centre, radius, &radial)?;
    let (body, e_target) =
        random_block_body(t, lattice, aniso.as_ref().map(|(cal, e, _)| (cal, *e)), q)?;
    let lat = &body.lattice;
    let pos = &lat.pos;
    let n = body.nodes();
    let len = ext[ax];
    let coord = |c: usize, i: usize| pos.comp(c)[i];
    let mut cons = Constraints::all_free(n);
    let mut state = State::new(&body);
    let end_of = |i: usize| -> Option<Real> {
        let x = coord(ax, i);
        if x == 0.0 {
            Some(-1.0)
        } else if x == len {
            Some(1.0)
        } else {
            None
        }
    };
    for i in 0..n {
        let mut u = [0.0; 3];
        for c in 0..dim {
            let d = coord(c, i) - centre[c];
            u[c] = if c == ax {
                t.strain * d
            } else {
                let m = lateral.iter().position(|&l| l == c).unwrap_or(0);
                -nu_guess[m] * t.strain * d
            };
        }
        if dim == 2 {
            cons.fix(i, 2);
        }
        if let Some(side) = end_of(i) {
            u[ax] = side * t.strain * len / 2.0;
            cons.fix(i, ax);
            if t.ends == Ends::Clamp {
                for &c in &lateral {
                    u[c] = 0.0;
                    cons.fix(i, c);
                }
            }
        }
        state.u.set(i, Vector::new(u[0], u[1], u[2]));
    }
    if t.ends == Ends::Slide {
        random_slide_modes(&mut cons, pos, &lateral, centre);
    }
    let solve = statics::solve(&body, &mut state, &cons, None, &t.solver)?;
    let force: Real = (0..n)
        .filter(|&i| end_of(i) == Some(1.0))
        .map(|i| -state.f.comp(ax)[i])
        .sum();
    let area: Real = if t.cylinder {
        std::f64::consts::PI * radius * radius
    } else {
        lateral.iter().map(|&c| ext[c]).product()
    };
    let (lateral_strain, per_axis) =
        random_lateral_strain(t, &state.u, pos, (ax, &lateral), (centre, ext), &radial);
    let e_measured = force / area / t.strain;
    let axial_middle = middle_axial_strain(&state.u, pos, ax, centre[ax], len);
    let (nu_target, lateral_measured, lateral_target) =
        lateral_targets(t, aniso.as_ref().map(|(.., r)| *r), per_axis);
    Ok(BlockResult {
        nu_target,
        nu_measured: -lateral_strain / t.strain,
        e_target,
        e_measured,
        e_measured_cell: e_measured,
        q,
        nodes: n,
        springs: body.springs(),
        solve,
        lateral_measured,
        lateral_target,
        e_measured_middle: Some(force / area / axial_middle),
    })
}

/// x-columns of the middle cross-section: the middle one, or the two middle ones.
fn middle_columns(nx: usize) -> Vec<usize> {
    if nx % 2 == 1 {
        vec![(nx - 1) / 2]
    } else {
        vec![nx / 2 - 1, nx / 2]
    }
}

fn centre(pos: &Coords) -> (Real, Real) {
    let minmax = |v: &[Real]| {
        let lo = v.iter().cloned().fold(Real::INFINITY, Real::min);
        let hi = v.iter().cloned().fold(Real::NEG_INFINITY, Real::max);
        0.5 * (lo + hi)
    };
    (minmax(pos.y()), minmax(pos.z()))
}

/// Elastic constants of the infinite lattice, measured through the force law.
#[derive(Clone, Copy, Debug)]
pub struct BulkModuli {
    pub c11: Real,
    pub c12: Real,
    pub c44: Real,
    /// Young's modulus from C11, C12 (Pa in 3D; N/m per thickness in 2D with h = 1).
    pub youngs: Real,
    /// Poisson's ratio from C11, C12 (nu_2D in 2D).
    pub poisson: Real,
    /// Theory (MODEL.md closed forms) for the same k, a, q.
    pub youngs_theory: Real,
    pub poisson_theory: Real,
}

/// Stress of the centre node of a small box under the affine strain `eps`, from the linearised
/// law. Exact for the infinite lattice (see the module docs).
///
/// # Panics
/// For random lattices, which have no affine equilibrium: use [`relaxed_bulk_stiffness`] (or [`block_test`]).
pub fn bulk_stress(kind: LatticeKind, k: Real, a: Real, q: Real, eps: &Matrix) -> Matrix {
    bulk_stress_of(kind, a, eps, &|lattice| {
        Ok(Body::uniform(lattice, k, q, 1.0))
    })
    .expect("a uniform body on a fixed, valid box")
}

/// [`bulk_stress`] for the body that `make` builds on the test's box (e.g. a direction-weighted
/// material, [`Body::transverse`]): exact for the infinite lattice of that body.
pub fn bulk_stress_of(
    kind: LatticeKind,
    a: Real,
    eps: &Matrix,
    make: &dyn Fn(Lattice) -> crate::Result<Body>,
) -> crate::Result<Matrix> {
    // 7 nodes across: the centre node, its neighbours and their neighbours all have full stars.
    let lattice = match kind {
        LatticeKind::Cubic => Lattice::cubic_box([7, 7, 7], a),
        LatticeKind::Hex => Lattice::hex_box(7, 7, a, 1.0),
        LatticeKind::Random2d | LatticeKind::Random3d => {
            return Err(crate::Error::InvalidInput {
                what: "bulk test",
                why: "random lattices have no affine equilibrium; use the relaxed bulk test (relaxed_bulk_stiffness) or the block test"
                    .into(),
            })
        }
    }?;
    let centre = match kind.dim() {
        3 => lattice.grid_index(3, 3, 3),
        _ => lattice.grid_index(3, 3, 0),
    };
    let body = make(lattice)?;
    let state = State::new(&body);
    let mut v = Coords::zeros(body.nodes());
    for i in 0..body.nodes() {
        v.set(i, eps * body.lattice.pos.get(i));
    }
    let mut tangent = Tangent::new(&body, &state);
    let dt = tangent.tension_changes(&body, &v);
    Ok(law::node_virial(
        &body,
        &Coords::zeros(body.nodes()),
        &dt,
        centre,
    ))
}

/// Voigt order of the 6x6 stiffness: xx, yy, zz, yz, xz, xy.
pub use crate::anisotropy::VOIGT;

/// The full stiffness tensor of the infinite regular lattice, `C[i][j]` in Voigt order
/// ([`VOIGT`]; engineering shear strains), column j the bulk stress ([`bulk_stress`]) under unit
/// strain j: exact to round-off, whatever symmetry the lattice has. In 2D (hex) the entries
/// involving z are zero and the stress is per unit thickness (N/m).
///
/// # Panics
/// For random lattices (see [`bulk_stress`]).
pub fn bulk_stiffness(kind: LatticeKind, k: Real, a: Real, q: Real) -> [[Real; 6]; 6] {
    bulk_stiffness_of(kind, a, &|lattice| Ok(Body::uniform(lattice, k, q, 1.0)))
        .expect("a uniform body on a fixed, valid box")
}

/// [`bulk_stiffness`] of the body that `make` builds on the test's box ([`bulk_stress_of`]).
pub fn bulk_stiffness_of(
    kind: LatticeKind,
    a: Real,
    make: &dyn Fn(Lattice) -> crate::Result<Body>,
) -> crate::Result<[[Real; 6]; 6]> {
    let mut c = [[0.0; 6]; 6];
    for (j, &(r, s)) in VOIGT.iter().enumerate() {
        if kind.dim() == 2 && (r == 2 || s == 2) {
            continue;
        }
        // Engineering shear: gamma = 1 is eps_rs = eps_sr = 1/2.
        let mut eps = Matrix::zeros();
        let e = if r == s { 1.0 } else { 0.5 };
        eps[(r, s)] = e;
        eps[(s, r)] = e;
        let sigma = bulk_stress_of(kind, a, &eps, make)?;
        for (i, &(p, t)) in VOIGT.iter().enumerate() {
            c[i][j] = sigma[(p, t)];
        }
    }
    Ok(c)
}

/// The isotropic stiffness in Voigt order for Young's modulus `e` and Poisson's ratio `nu`: in
/// 3D from the Lame constants; in 2D the plane (membrane) stiffness of a 2D material
/// (`e / (1 - nu^2)`, entries involving z zero), as the hexagonal lattice has.
pub fn isotropic_stiffness(dim: usize, e: Real, nu: Real) -> [[Real; 6]; 6] {
    let mut c = [[0.0; 6]; 6];
    let mu = e / (2.0 * (1.0 + nu));
    if dim == 3 {
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        for i in 0..3 {
            for j in 0..3 {
                c[i][j] = if i == j { lambda + 2.0 * mu } else { lambda };
            }
            c[i + 3][i + 3] = mu;
        }
    } else {
        let d = e / (1.0 - nu * nu);
        c[0][0] = d;
        c[1][1] = d;
        c[0][1] = nu * d;
        c[1][0] = nu * d;
        c[5][5] = mu;
    }
    c
}

/// C11, C12, C44 and (E, nu) of the infinite lattice with stiffness k, spacing a and ratio q.
pub fn bulk_moduli(kind: LatticeKind, k: Real, a: Real, q: Real) -> BulkModuli {
    let mut exx = Matrix::zeros();
    exx[(0, 0)] = 1.0;
    let s = bulk_stress(kind, k, a, q, &exx);
    let (c11, c12) = (s[(0, 0)], s[(1, 1)]);
    let mut exy = Matrix::zeros();
    exy[(0, 1)] = 0.5;
    exy[(1, 0)] = 0.5;
    let c44 = bulk_stress(kind, k, a, q, &exy)[(0, 1)];
    let (youngs, poisson) = match kind.dim() {
        3 => (
            (c11 - c12) * (c11 + 2.0 * c12) / (c11 + c12),
            c12 / (c11 + c12),
        ),
        _ => ((c11 * c11 - c12 * c12) / c11, c12 / c11),
    };
    BulkModuli {
        c11,
        c12,
        c44,
        youngs,
        poisson,
        youngs_theory: youngs_from_k(kind, k, a, q),
        poisson_theory: nu_from_q(kind, q),
    }
}

/// The relaxed bulk test of a random lattice: its apparent stiffness tensor under kinematic
/// (affine) boundary conditions.
///
/// A random network has no affine equilibrium: under a uniform strain its nodes move off the
/// affine field (non-affine relaxation, which softens it by about 7 % at q = 0), so the exact
/// bulk test of the regular lattices does not apply. Random lattices are not built periodic
/// either. This test takes a cube of `size` spacings, prescribes the affine displacement
/// `u = eps x` on every node of its six faces (the samplers put nodes exactly on the faces),
/// lets every inner node relax to equilibrium ([`statics::solve`]) and reads the volume-average
/// stress from the reactions on the faces,
///
/// ```text
/// sigma_ij = (1/V) sum_{b on the faces} F_i^b x_j^b ,    F^b = -f^b (what holds node b)
/// ```
///
/// which is exact for any body in equilibrium (the divergence theorem applied to the virial).
/// Column j of `C` is the stress under unit Voigt strain j (engineering shear). The faces cannot
/// relax, so the apparent tensor bounds the effective one from above (Hill), by a boundary layer
/// about a spacing thick: the excess shrinks like `a / L`, C11 1.9 % high at `size = 16`, 1.2 %
/// at 24 and 0.8 % at 32 (random3d, nu = 0.25, 4 node sets; `hooke moduli --bulk --lattice
/// random3d --size N`). Its ensemble mean against the
/// calibrated isotropic target ([`calibration::youngs_for`], `nu`) checks the calibration by an
/// independent test: the calibration itself comes from block tests with free faces.
#[derive(Clone, Debug)]
pub struct RelaxedBulk {
    pub kind: LatticeKind,
    /// The Poisson's ratio to build (nu_2D for random2d).
    pub nu: Real,
    /// The cube's side in spacings.
    pub size: Real,
    /// Spacing a (m) and the stiffness scale kappa (Pa: `k_s = kappa V_s / L_s^2`).
    pub spacing: Real,
    pub stiffness: Real,
    pub random: RandomSpec,
    pub solver: StaticOptions,
}

/// What the relaxed bulk test measured.
#[derive(Clone, Debug)]
pub struct RelaxedBulkResult {
    /// The apparent stiffness, Voigt order ([`VOIGT`]); Pa in 3D, N/m per unit thickness in 2D.
    pub c_measured: [[Real; 6]; 6],
    /// The calibrated isotropic target ([`isotropic_stiffness`] of `youngs`, `nu`).
    pub c_target: [[Real; 6]; 6],
    /// The affine stiffness of the same body: every node on the affine field, no relaxation.
    pub c_affine: [[Real; 6]; 6],
    /// The inner cube's tensor ([`CubeStiffness::c_interior`]), free of the held faces' excess.
    pub c_interior: [[Real; 6]; 6],
    pub q: Real,
    pub youngs: Real,
    pub nodes: usize,
    pub springs: usize,
    /// Nodes on the faces (prescribed).
    pub boundary_nodes: usize,
    /// One solve per strain column.
    pub solves: Vec<StaticReport>,
}

/// Run the relaxed bulk test ([`RelaxedBulk`]).
pub fn relaxed_bulk_stiffness(t: &RelaxedBulk) -> Result<RelaxedBulkResult> {
    if !t.kind.is_random() {
        return Err(Error::InvalidInput {
            what: "relaxed bulk test",
            why: format!(
                "the {} lattice is a Bravais lattice: its exact bulk test is bulk_stiffness",
                t.kind.name()
            ),
        });
    }
    if !(t.size.is_finite() && t.size >= 4.0 && t.size <= 200.0) {
        return Err(Error::InvalidInput {
            what: "size",
            why: format!(
                "a cube of {} spacings: give 4 to 200 (32 or more keeps the faces' excess under 1 %)",
                t.size
            ),
        });
    }
    let dim = t.kind.dim();
    let a = t.spacing;
    let q = calibration::q_for_nu_for(t.kind, t.random.sampler, t.nu)?;
    let side = t.size * a;
    let mut ext = [0.0; 3];
    for e in ext.iter_mut().take(dim) {
        *e = side;
    }
    let lattice = Lattice::random(dim, [0.0; 3], ext, a, 1.0, t.random, &|_| true)?;
    let youngs = calibration::youngs_for(t.kind, t.random.sampler, t.stiffness, q);
    let body = Body::from_cells(lattice, t.stiffness, q, 1.0);
    body.validate()?;
    let cube = relax_cube(&body, side, &t.solver)?;
    Ok(RelaxedBulkResult {
        c_measured: cube.c_measured,
        c_target: isotropic_stiffness(dim, youngs, t.nu),
        c_affine: cube.c_affine,
        c_interior: cube.c_interior,
        q,
        youngs,
        nodes: body.nodes(),
        springs: body.springs(),
        boundary_nodes: cube.boundary_nodes,
        solves: cube.solves,
    })
}
