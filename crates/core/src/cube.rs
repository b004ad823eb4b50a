//! The relaxed cube: the apparent stiffness of a random lattice filling a cube whose faces
//! are held on each unit strain's affine field while its inside relaxes ([`relax_cube`]), read
//! on its inner cube. The relaxed bulk test ([`crate::moduli::relaxed_bulk_stiffness`]) and the
//! calibration of anisotropic designs ([`crate::random::anisotropic`]) both measure with it.

use crate::anisotropy::VOIGT;
use crate::body::Body;
use crate::error::{Error, Result};
use crate::law;
use crate::math::{Coords, Matrix, Real, Vector};
use crate::state::State;
use crate::statics::{self, Constraints, StaticOptions, StaticReport};

/// What [`relax_cube`] measured on one body.
#[derive(Clone, Debug)]
pub struct CubeStiffness {
    /// The apparent stiffness (faces on the affine field, the inside relaxed), Voigt order.
    pub c_measured: [[Real; 6]; 6],
    /// The affine stiffness: every node on the affine field.
    pub c_affine: [[Real; 6]; 6],
    /// The inner cube's stiffness, away from the held faces: its spring virial stress against
    /// the strain fitted to its nodes' displacements ([`interior_stress`], [`interior_strain`]).
    /// The faces' boundary layer, which makes [`CubeStiffness::c_measured`] an upper bound
    /// (a spacing-thick layer that cannot relax), is left out.
    pub c_interior: [[Real; 6]; 6],
    pub boundary_nodes: usize,
    pub solves: Vec<StaticReport>,
}

/// The inner cube `[margin, side - margin]^d` that [`relax_cube`] reads its interior tensor on:
/// a sixth of the side from each face.
pub fn interior_box(side: Real) -> (Real, Real) {
    (side / 6.0, side - side / 6.0)
}

/// The fraction of the segment from `p` to `p + d` inside the box `[lo, hi]` along the first
/// `dim` axes (Liang-Barsky clipping).
fn inside_fraction(p: Vector, d: [Real; 3], lo: Real, hi: Real, dim: usize) -> Real {
    let (mut t0, mut t1): (Real, Real) = (0.0, 1.0);
    for c in 0..dim {
        if d[c] == 0.0 {
            if p[c] < lo || p[c] > hi {
                return 0.0;
            }
            continue;
        }
        let (a, b) = ((lo - p[c]) / d[c], (hi - p[c]) / d[c]);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t1 - t0).max(0.0)
}

/// The volume-average stress of the box `[lo, hi]^d` from the springs' tensions: the virial
/// `1/V sum_s f_s T_s L_s n_s n_s` with `f_s` the part of spring s inside the box (reference
/// geometry: the strains here are 1e-6).
pub fn interior_stress(body: &Body, state: &State, lo: Real, hi: Real) -> Matrix {
    let dim = body.lattice.dim();
    let t = law::tensions(body, state);
    let lat = &body.lattice;
    let mut s = Matrix::zeros();
    for (b, &[i, j]) in lat.bonds.ends.iter().enumerate() {
        let d = lat.reference_vector(i as usize, j as usize);
        let f = inside_fraction(lat.pos.get(i as usize), d, lo, hi, dim);
        if f > 0.0 {
            let v = Vector::new(d[0], d[1], d[2]);
            s += (f * t[b] / lat.rest(b)) * v * v.transpose();
        }
    }
    s / (hi - lo).powi(dim as i32)
}

/// The uniform strain that fits the displacements of the nodes inside `[lo, hi]^d` best (least
/// squares of `u = G x + c`; the symmetric part of G).
pub fn interior_strain(body: &Body, u: &Coords, lo: Real, hi: Real) -> Matrix {
    let dim = body.lattice.dim();
    let pos = &body.lattice.pos;
    let inside: Vec<usize> = (0..body.nodes())
        .filter(|&i| {
            let p = pos.get(i);
            (0..dim).all(|c| p[c] >= lo && p[c] <= hi)
        })
        .collect();
    let m = inside.len().max(1) as Real;
    let (mut xm, mut um) = (Vector::zeros(), Vector::zeros());
    for &i in &inside {
        xm += pos.get(i) / m;
        um += u.get(i) / m;
    }
    let (mut xx, mut ux) = (Matrix::zeros(), Matrix::zeros());
    for &i in &inside {
        let (x, v) = (pos.get(i) - xm, u.get(i) - um);
        xx += x * x.transpose();
        ux += v * x.transpose();
    }
    if dim == 2 {
        // A plate's nodes share z: fit in the plane only.
        xx[(2, 2)] = 1.0;
        ux.row_mut(2).fill(0.0);
        ux.column_mut(2).fill(0.0);
    }
    let g = ux * xx.try_inverse().unwrap_or_else(Matrix::zeros);
    0.5 * (g + g.transpose())
}

/// The relaxed bulk test of [`RelaxedBulk`](crate::moduli::RelaxedBulk) on a given body: a random lattice filling the cube
/// `[0, side]^d`. Its faces are held on the affine field of each unit strain (Voigt column j,
/// engineering shear) and the inside relaxes; column j of the apparent stiffness is the
/// volume-average stress from the forces that hold the faces.
pub fn relax_cube(body: &Body, side: Real, solver: &StaticOptions) -> Result<CubeStiffness> {
    let dim = body.lattice.dim();
    let mut ext = [0.0; 3];
    for e in ext.iter_mut().take(dim) {
        *e = side;
    }
    let n = body.nodes();
    let pos = &body.lattice.pos;
    let centre = Vector::new(0.5 * ext[0], 0.5 * ext[1], 0.5 * ext[2]);
    let on_face = |i: usize| (0..dim).any(|c| pos.comp(c)[i] == 0.0 || pos.comp(c)[i] == side);
    let mut cons = Constraints::all_free(n);
    let mut boundary = Vec::new();
    for i in 0..n {
        if on_face(i) {
            boundary.push(i);
            for c in 0..3 {
                cons.fix(i, c);
            }
        } else if dim == 2 {
            cons.fix(i, 2);
        }
    }
    if boundary.is_empty() || boundary.len() == n {
        return Err(Error::InvalidInput {
            what: "size",
            why: format!(
                "{} of the {n} nodes of the cube lie on its faces: give a larger size (and a lattice filling the cube [0, side])",
                boundary.len()
            ),
        });
    }
    let volume: Real = ext.iter().take(dim).product();
    // Small enough that the geometric nonlinearity is far below the tolerances (relative
    // 1e-6), large enough that the forces are far above round-off.
    let eps = 1e-6;
    // The volume-average stress from the forces that hold `nodes`. Central forces make the
    // virial symmetric to round-off; keep its symmetric part.
    let stress = |state: &State, nodes: &mut dyn Iterator<Item = usize>| -> Matrix {
        let mut s = Matrix::zeros();
        for b in nodes {
            s -= state.f.get(b) * (pos.get(b) - centre).transpose();
        }
        0.5 * (s + s.transpose()) / volume
    };
    let mut c_measured = [[0.0; 6]; 6];
    let mut c_affine = [[0.0; 6]; 6];
    let (lo, hi) = interior_box(side);
    // Columns: the inner cube's stress and fitted strain (Voigt, engineering shears) per load.
    let active: Vec<usize> = (0..6)
        .filter(|&j| dim == 3 || (VOIGT[j].0 < 2 && VOIGT[j].1 < 2))
        .collect();
    let na = active.len();
    let mut inner_stress = nalgebra::DMatrix::<Real>::zeros(na, na);
    let mut inner_strain = nalgebra::DMatrix::<Real>::zeros(na, na);
    let mut solves = Vec::new();
    for (col, &j) in active.iter().enumerate() {
        let (r, s) = VOIGT[j];
        let mut strain = Matrix::zeros();
        let e = if r == s { eps } else { 0.5 * eps };
        strain[(r, s)] = e;
        strain[(s, r)] = e;
        let mut state = State::new(body);
        for i in 0..n {
            state.u.set(i, strain * (pos.get(i) - centre));
        }
        // The affine stress: the whole body held on the affine field, every node a support.
        law::update_forces(body, &mut state);
        let affine = stress(&state, &mut (0..n));
        solves.push(statics::solve(body, &mut state, &cons, None, solver)?);
        let relaxed = stress(&state, &mut boundary.iter().copied());
        for (i, &(p, m)) in VOIGT.iter().enumerate() {
            c_measured[i][j] = relaxed[(p, m)] / eps;
            c_affine[i][j] = affine[(p, m)] / eps;
        }
        let sig = interior_stress(body, &state, lo, hi);
        let eps_in = interior_strain(body, &state.u, lo, hi);
        for (row, &i) in active.iter().enumerate() {
            let (p, m) = VOIGT[i];
            inner_stress[(row, col)] = sig[(p, m)];
            inner_strain[(row, col)] = if p == m { 1.0 } else { 2.0 } * eps_in[(p, m)];
        }
    }
    let mut c_interior = [[0.0; 6]; 6];
    if let Some(inv) = inner_strain.try_inverse() {
        let c = inner_stress * inv;
        for (row, &i) in active.iter().enumerate() {
            for (col, &j) in active.iter().enumerate() {
                c_interior[i][j] = c[(row, col)];
            }
        }
    }
    Ok(CubeStiffness {
        c_measured,
        c_affine,
        c_interior,
        boundary_nodes: boundary.len(),
        solves,
    })
}
