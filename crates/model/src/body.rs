//! A body: a lattice with its material constants (spring stiffnesses, q, node masses).
//! Immutable during a run; everything that changes lives in [`crate::State`].

use std::sync::OnceLock;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::lattice::Lattice;
use crate::material::{self, Elastic, PlaneModel};
use crate::math::Real;

/// Each spring's dispersion lever `lambda_s` ([`Body::levers`]): the direction-weighted
/// material's, or the rest length `L_s` (stored, or computed once the lattice shed them).
#[derive(Clone, Copy, Debug)]
pub struct Levers<'a> {
    stored: Option<&'a [Real]>,
    lattice: &'a Lattice,
}

impl<'a> Levers<'a> {
    /// Spring `b`'s lever (m).
    #[inline(always)]
    pub fn get(&self, b: usize) -> Real {
        match self.stored {
            Some(l) => l[b],
            None => self.lattice.rest(b),
        }
    }

    /// Every lever as a slice, where they are stored (not for the rest lengths of a lattice
    /// that shed them).
    #[inline]
    pub fn stored(&self) -> Option<&'a [Real]> {
        self.stored
    }
}

/// Each spring's stiffness `k_b` (N/m), read as a slice (`Deref`). A body of one stiffness
/// (`Body::uniform`), or a box of Ladd's lattice of one stiffness weighted by its cubes
/// (`Body::with_cell_weights`), keeps the rule and the count ([`GridStiffness`]), and fills the
/// slice only when something asks for it (the general kernels, a frame): the stencils, the
/// normalisers and the stable step read the rule along the grid, so a box they run holds no
/// per-spring stiffness (8 bytes per spring). Changing them (`DerefMut`) stores them for good.
#[derive(Clone, Debug)]
pub struct Stiffnesses {
    each: OnceLock<Vec<Real>>,
    /// The rule and the count, while every spring follows it.
    rule: Option<(GridStiffness, usize)>,
}

/// Stiffnesses that follow from a rule rather than a list (see [`Stiffnesses`]).
#[derive(Clone, Copy, Debug)]
pub enum GridStiffness {
    /// Every spring has this stiffness.
    One(Real),
    /// A box of Ladd's lattice: the bulk stiffness times each spring's share of its cubes that
    /// lie in the box ([`crate::lattice::GridSprings::cube_share`]), as
    /// [`Body::with_cell_weights`] weights a built box.
    Cubes(Real, crate::lattice::GridSprings),
}

impl GridStiffness {
    /// The stiffness of the spring between nodes `i` and `j` (of the rule's box, for `Cubes`):
    /// the bits the stored list holds.
    #[inline]
    pub fn between(&self, i: usize, j: usize) -> Real {
        match self {
            GridStiffness::One(k) => *k,
            GridStiffness::Cubes(k, g) => k * g.cube_share(i, j),
        }
    }
}

impl Stiffnesses {
    /// `len` springs of stiffness `k`.
    pub fn uniform(k: Real, len: usize) -> Self {
        Stiffnesses {
            each: OnceLock::new(),
            rule: Some((GridStiffness::One(k), len)),
        }
    }

    /// The springs of the box `grid` (Ladd's lattice), of bulk stiffness `k` weighted by their
    /// cubes ([`GridStiffness::Cubes`]).
    pub fn cubes(k: Real, grid: crate::lattice::GridSprings) -> Self {
        debug_assert!(grid.is_cubic());
        Stiffnesses {
            each: OnceLock::new(),
            rule: Some((GridStiffness::Cubes(k, grid), grid.springs())),
        }
    }

    /// The stiffness of every spring, while they share one.
    #[inline]
    pub fn uniform_value(&self) -> Option<Real> {
        match self.rule {
            Some((GridStiffness::One(k), _)) => Some(k),
            _ => None,
        }
    }

    /// The rule the stiffnesses follow, while no list is stored. A `Cubes` rule belongs to the
    /// body's own grid (the lattice's [`crate::lattice::Topology::grid`]).
    #[inline]
    pub fn rule(&self) -> Option<GridStiffness> {
        self.rule.map(|(r, _)| r)
    }

    /// How many springs.
    pub fn len(&self) -> usize {
        match self.rule {
            Some((_, n)) => n,
            None => self.each.get().map_or(0, |v| v.len()),
        }
    }

    /// True for a body without springs.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Heap bytes held (none while a rule stands for all).
    pub fn bytes(&self) -> usize {
        self.each.get().map_or(0, crate::memory::bytes)
    }
}

impl From<Vec<Real>> for Stiffnesses {
    fn from(v: Vec<Real>) -> Self {
        Stiffnesses {
            each: OnceLock::from(v),
            rule: None,
        }
    }
}

impl std::ops::Deref for Stiffnesses {
    type Target = [Real];

    #[inline]
    fn deref(&self) -> &[Real] {
        self.each.get_or_init(|| {
            // On one thread: the first read may come from a task of a parallel loop, where a
            // rayon join could take up another task that waits for this very initialisation.
            match self.rule.expect("stiffnesses are given or follow a rule") {
                (GridStiffness::One(k), n) => vec![k; n],
                // In the springs' order: each node's forward links in row order, as the
                // grid's rows are built.
                (GridStiffness::Cubes(k, g), n) => {
                    let mut out = Vec::with_capacity(n);
                    let star = g.star();
                    for i in 0..g.n.iter().product() {
                        g.links(&star, i, |j, _| {
                            if j > i {
                                out.push(k * g.cube_share(i, j));
                            }
                        });
                    }
                    debug_assert_eq!(out.len(), n);
                    out
                }
            }
        })
    }
}

impl std::ops::DerefMut for Stiffnesses {
    fn deref_mut(&mut self) -> &mut [Real] {
        let _ = &**self;
        self.rule = None;
        self.each.get_mut().expect("filled just above")
    }
}

/// A lattice with its spring constants and node masses.
#[derive(Clone, Debug)]
pub struct Body {
    pub lattice: Lattice,
    /// Stiffness `k_b` of each spring (N/m), read as a slice ([`Stiffnesses`]).
    pub k: Stiffnesses,
    /// Dispersion ratio q of the material (0: plain spring lattice).
    pub q: Real,
    /// Lumped mass of each node (kg): density times the node's cell volume.
    pub mass: Vec<Real>,
    /// Dispersion levers `lambda_s = w_s L_s` of a direction-weighted (anisotropic) material
    /// (`docs/anisotropy.md`), or `None` for the isotropic law, where every lever is the rest
    /// length. A spring's lever replaces its rest length wherever the law pools or disperses:
    /// `Pi_n = sum_t k_t lambda_t dL_t`, `S_n = sum_t k_t lambda_t^2` and
    /// `T_s = k_s dL_s + q k_s lambda_s (p_i + p_j)`; its extension still runs from `L_s`.
    pub lever: Option<Vec<Real>>,
    /// Each node's own dispersion ratio `q_n`, in a body of several materials (`None`: every
    /// node's is `q`). The law is then `U = 1/2 sum_s k_s dL_s^2 + 1/2 sum_n q_n Pi_n^2 / S_n`
    /// and `T_s = k_s dL_s + k_s L_s (q_i p_i + q_j p_j)` (`docs/model.md`). Everything reads it
    /// through the normalisers: the state keeps each node's as `S_n / q_n` and `q` is 1, so a
    /// pool holds `q_n p_n` and every solver's law is the one-material law with `q = 1` (see
    /// [`Body::with_node_q`]).
    pub q_node: Option<Vec<Real>>,
    /// Each node's phase in a body of several materials (0: the body's own material, `p + 1`:
    /// the builder's phase `p`; `None`: all of one material), as [`crate::phases::assemble`]
    /// numbered them. Nothing in the step reads it: it names the materials in frames
    /// (`material`), in reports and in the fracture set-up (each spring's strength by the
    /// materials it joins).
    pub phase: Option<Vec<u8>>,
}

impl Body {
    /// The body's heap memory by part (see [`crate::memory::Footprint`]).
    pub fn footprint(&self) -> crate::memory::Footprint {
        use crate::memory::bytes;
        let lat = &self.lattice;
        let b = &lat.bonds;
        let mut parts = vec![
            ("positions", lat.pos.heap_bytes()),
            ("rows (offsets, springs; neighbours if kept)", b.row_bytes()),
            ("spring ends", b.ends_bytes()),
            ("rest lengths", b.rest_bytes()),
            ("stiffnesses", self.k.bytes()),
            ("masses", bytes(&self.mass)),
        ];
        if let Some(c) = &lat.cells {
            parts.push(("node volumes", bytes(&c.node)));
            parts.push(("spring volumes", bytes(&c.spring)));
            parts.push(("boundary areas", bytes(&c.surface)));
        }
        if let Some(l) = &self.lever {
            parts.push(("levers", bytes(l)));
        }
        if let Some(q) = &self.q_node {
            parts.push(("dispersion ratios", bytes(q)));
        }
        if let Some(p) = &self.phase {
            parts.push(("phases", bytes(p)));
        }
        parts
    }

    /// A body of one material. For 2D lattices the plate thickness is the lattice's and `plane`
    /// says how the plate stands for the 3D material.
    pub fn new(lattice: Lattice, m: &Elastic, plane: PlaneModel) -> Result<Self> {
        let c = material::constants_for_lattice(&lattice, m, plane)?;
        // On a random lattice c.k is kappa, which `from_cells` spreads over the springs.
        Ok(Self::from_cells(lattice, c.k, c.q, m.density))
    }

    /// A body whose springs and nodes follow the lattice's cells: on a random lattice
    /// (`crate::random`) each spring gets `kappa V_s / L_s^2` (its volume over the plate
    /// thickness in 2D, i.e. its area) and each node `density` times its cell volume; on a
    /// regular lattice every spring gets `kappa` (the stiffness k) and every node `density`
    /// times the cell volume.
    pub fn from_cells(lattice: Lattice, kappa: Real, q: Real, density: Real) -> Self {
        let Some(cells) = &lattice.cells else {
            let mass = density * lattice.cell_volume;
            return Self::uniform(lattice, kappa, q, mass);
        };
        assert!(
            !lattice.is_shed(),
            "a body built from a lattice whose spring volumes were shed (Lattice::shed_setup): build bodies before shedding"
        );
        let per = if lattice.dim() == 2 {
            lattice.thickness
        } else {
            1.0
        };
        let k: Vec<Real> = cells
            .spring
            .iter()
            .zip(lattice.rest_lengths().iter())
            .map(|(&v, &l)| kappa * v / (per * l * l))
            .collect();
        let mass = cells.node.iter().map(|&v| density * v).collect();
        Body {
            lattice,
            k: k.into(),
            q,
            mass,
            lever: None,
            q_node: None,
            phase: None,
        }
    }

    /// A body with the same stiffness `k` on every spring and the same mass on every node (lattice
    /// units, or constants already derived).
    pub fn uniform(lattice: Lattice, k: Real, q: Real, node_mass: Real) -> Self {
        let nb = lattice.bonds.len();
        let nn = lattice.len();
        // Filled in parallel: first writes to a large body's fresh memory share the cores.
        let fill = |len: usize, v: Real| {
            let mut out = Vec::with_capacity(len);
            out.par_extend(rayon::iter::repeat_n(v, len));
            out
        };
        Body {
            lattice,
            k: Stiffnesses::uniform(k, nb),
            q,
            mass: fill(nn, node_mass),
            lever: None,
            q_node: None,
            phase: None,
        }
    }

    /// Weight each spring's stiffness and each node's mass by the share of the bulk's cells
    /// that hold it and lie in the body ([`Lattice::cell_fractions`]: cubes of the Ladd lattice,
    /// triangles of the hexagonal one). A face spring of the Ladd lattice then stands for half
    /// the material of a bulk one, an edge spring for a quarter, as a random lattice's springs
    /// stand for their volumes; the dispersion normalisers `S_n = sum k_t L_t^2` follow from the
    /// weighted `k`. The body's material is then exactly the box between its outer node planes,
    /// and a uniform strain is an exact equilibrium of the whole body (no surface layer).
    /// Refused for random and periodic lattices (nothing to weight) and where a spring or node
    /// lies in no cell (a body one cell thin).
    pub fn with_cell_weights(mut self) -> Result<Self> {
        self.weigh_by_cells()?;
        Ok(self)
    }

    /// [`Body::with_cell_weights`] in place; on an error the body is left as it was.
    pub fn weigh_by_cells(&mut self) -> Result<()> {
        if self.weigh_grid_by_cubes() {
            return Ok(());
        }
        let Some((springs, nodes)) = self.lattice.cell_fractions() else {
            return Err(Error::InvalidInput {
                what: "cell weights",
                why: "only regular, non-periodic lattices are weighted by cells (random lattices already are)".into(),
            });
        };
        if let Some(s) = springs.iter().position(|&f| f <= 0.0) {
            return Err(Error::InvalidInput {
                what: "cell weights",
                why: format!("spring {s} lies in no cell of the lattice: the body is too thin to weight by cells (two node planes at least along each axis)"),
            });
        }
        if let Some(n) = nodes.iter().position(|&f| f <= 0.0) {
            return Err(Error::InvalidInput {
                what: "cell weights",
                why: format!("node {n} lies in no cell of the lattice: the body is too thin to weight by cells"),
            });
        }
        for (k, f) in self.k.iter_mut().zip(springs) {
            *k *= f;
        }
        for (m, f) in self.mass.iter_mut().zip(nodes) {
            *m *= f;
        }
        Ok(())
    }

    /// [`Body::weigh_by_cells`] for a box of Ladd's lattice of one stiffness, held as its grid:
    /// the stiffnesses become the rule [`GridStiffness::Cubes`] (no per-spring list, no rows),
    /// the masses are weighted in place by the nodes' cube shares. The same values, bit for
    /// bit, as weighting the built box. False (and nothing changed) for any other body, or
    /// where some spring or node lies in no cube (the general path gives the error).
    fn weigh_grid_by_cubes(&mut self) -> bool {
        let (Some(&g), Some(k)) = (self.lattice.bonds.grid(), self.k.uniform_value()) else {
            return false;
        };
        if !g.is_cubic() || self.lattice.kind != crate::lattice::LatticeKind::Cubic {
            return false;
        }
        // A box two node planes thick along every axis has every spring and node in a cube;
        // a thinner one is refused by the general path, with the spring or node named.
        if g.n.iter().any(|&v| v < 2) {
            return false;
        }
        self.k = Stiffnesses::cubes(k, g);
        self.mass
            .par_iter_mut()
            .with_min_len(1 << 12)
            .enumerate()
            .for_each(|(i, m)| *m *= g.cube_share(i, i));
        true
    }

    /// This body with its own dispersion ratio `q_n` at each node (a body of several
    /// materials): `q` becomes 1, and the normalisers a state keeps are `S_n / q_n`
    /// ([`crate::state::node_norm`]). Refused with the reason where a ratio is not finite or
    /// not above -1/2, or the count is not the body's.
    pub fn with_node_q(mut self, q_node: Vec<Real>) -> Result<Self> {
        if q_node.len() != self.nodes() {
            return Err(Error::InvalidInput {
                what: "dispersion ratios per node",
                why: format!("{} ratios for {} nodes", q_node.len(), self.nodes()),
            });
        }
        if let Some(n) = q_node.iter().position(|&q| !(q.is_finite() && q > -0.5)) {
            return Err(Error::OutOfRange {
                what: "dispersion ratio q of a node",
                value: q_node[n],
                why: format!("node {n}: the lattice is stable only for q > -1/2 (nu > -1)"),
            });
        }
        self.q = 1.0;
        self.q_node = Some(q_node);
        Ok(self)
    }

    /// Node `n`'s dispersion ratio `q_n`.
    pub fn q_at(&self, n: usize) -> Real {
        self.q_node.as_ref().map_or(self.q, |q| q[n])
    }

    /// `max(q_n, 0)` over the nodes: the stability bound's `max(q, 0)` (a spring's stiffness
    /// in spring space is at most `(1 + max(q_i, 0) + max(q_j, 0)) k_s`, `stability.rs`).
    pub fn q_bound(&self) -> Real {
        match &self.q_node {
            None => self.q.max(0.0),
            Some(q) => q.iter().fold(0.0, |m: Real, &x| m.max(x)),
        }
    }

    /// `max |q_n|` over the nodes.
    pub fn q_abs_max(&self) -> Real {
        match &self.q_node {
            None => self.q.abs(),
            Some(q) => q.iter().fold(0.0, |m: Real, &x| m.max(x.abs())),
        }
    }

    /// Check the constants are usable (positive stiffness and mass, q above the stability limit).
    pub fn validate(&self) -> Result<()> {
        if let Some(q) = &self.q_node {
            if q.len() != self.nodes() || self.q != 1.0 {
                return Err(Error::InvalidInput {
                    what: "dispersion ratios per node",
                    why: format!(
                        "{} ratios for {} nodes with q = {} (Body::with_node_q sets q = 1)",
                        q.len(),
                        self.nodes(),
                        self.q
                    ),
                });
            }
        }
        if !(self.q.is_finite() && self.q > -0.5) {
            return Err(Error::OutOfRange {
                what: "dispersion ratio q",
                value: self.q,
                why: "the lattice is stable only for q > -1/2 (nu > -1)".into(),
            });
        }
        let bad = |k: Real| !(k.is_finite() && k > 0.0);
        let first_bad = match self.k.rule() {
            // The cube shares of a box at least two planes thick are positive.
            Some(GridStiffness::One(k) | GridStiffness::Cubes(k, _)) => {
                (bad(k) && self.springs() > 0).then_some(0)
            }
            None => self.k.iter().position(|&k| bad(k)),
        };
        if let Some(b) = first_bad {
            return Err(Error::InvalidInput {
                what: "spring stiffness",
                why: format!("spring {b} has k = {}", self.k[b]),
            });
        }
        if let Some(lever) = &self.lever {
            if lever.len() != self.springs() {
                return Err(Error::InvalidInput {
                    what: "dispersion levers",
                    why: format!("{} levers for {} springs", lever.len(), self.springs()),
                });
            }
            // Any real lever keeps the law stable (Cauchy-Schwarz holds for signed weights).
            if let Some(b) = lever.iter().position(|&v| !v.is_finite()) {
                return Err(Error::InvalidInput {
                    what: "dispersion lever",
                    why: format!("spring {b} has lever {}", lever[b]),
                });
            }
        }
        if let Some(n) = self.mass.iter().position(|&m| !(m.is_finite() && m > 0.0)) {
            return Err(Error::InvalidInput {
                what: "node mass",
                why: format!("node {n} has mass {}", self.mass[n]),
            });
        }
        Ok(())
    }

    /// Each spring's dispersion lever: [`Body::lever`] for a direction-weighted material, the
    /// rest lengths otherwise.
    #[inline]
    pub fn levers(&self) -> Levers<'_> {
        Levers {
            stored: self
                .lever
                .as_deref()
                .or_else(|| self.lattice.bonds.stored_rest()),
            lattice: &self.lattice,
        }
    }

    /// Number of nodes.
    pub fn nodes(&self) -> usize {
        self.lattice.len()
    }

    /// Number of springs (intact or not).
    pub fn springs(&self) -> usize {
        self.lattice.bonds.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box weighted by its cubes as a rule gives, bit for bit, the stiffnesses and masses of
    /// the same box weighted through its built rows, thin boxes too (two node planes along an
    /// axis: every node at a face).
    #[test]
    fn cube_weights_as_a_rule_are_the_built_rows_weights() {
        let bits = |v: &[Real]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for n in [[2, 2, 2], [2, 3, 5], [6, 2, 3], [4, 5, 2], [7, 6, 5]] {
            let lattice = || Lattice::cubic_box(n, 0.3).unwrap();
            let rule = Body::uniform(lattice(), 2.5, 0.2, 1.5)
                .with_cell_weights()
                .unwrap();
            assert!(rule.k.rule().is_some() && !rule.lattice.bonds.is_built());
            let mut built = lattice();
            let _ = &mut *built.bonds;
            let rows = Body::uniform(built, 2.5, 0.2, 1.5)
                .with_cell_weights()
                .unwrap();
            assert!(rows.k.rule().is_none());
            assert_eq!(bits(&rule.k), bits(&rows.k), "{n:?}: stiffnesses");
            assert_eq!(bits(&rule.mass), bits(&rows.mass), "{n:?}: masses");
            assert!(rule.validate().is_ok());
            // Not all alike: the faces' springs stand for less.
            assert!(rule.k.iter().any(|&k| k < 2.5));
        }
    }
}
