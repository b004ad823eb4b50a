//! [`Builder::parts`]: a simulation that no process builds whole. Each process of a team
//! builds its part of a random body ([`hooke_core::random::part`]), the parts become pieces
//! ([`hooke_core::team::parts::assemble`]), and the case is set up on each piece: the
//! material (isotropic, or anisotropic from its calibrated direction functions, which every
//! process calibrates alike), pre-cracks, boundary conditions, loads, no-fail regions and
//! initial velocities, every node's values the bits that the whole body's set-up gives it.
//!
//! What needs the whole body is found collectively: a face's extreme coordinate (a minimum
//! or maximum over the processes), whether a region holds a node anywhere, the list of a
//! boundary's nodes for its reaction history, the springs that pre-cracks cut, the shortest
//! spring and a rigid body's nearest node (contact's options and start gaps). The loaded and
//! prescribed nodes are added to every process's piece ([`hooke_core::team::parts::everyone`]):
//! a shared run's bookkeeping reads them everywhere.

use std::sync::Arc;

use hooke_core::random::part::Sampling;
use hooke_core::random::Sampler;
use hooke_core::team::parts::{assemble, everyone, gather_ids, sum_counts};
use hooke_core::team::{Piece, Team, PAD};
use hooke_core::{Lattice, Real, State, Vector};

use super::{BuildError, Builder, Selector};
use crate::geometry::{Face, Region};
use crate::rigid::Nearest;
use crate::simulation::{FromParts, Held, Simulation};

/// The margin around a part's key range that it samples and triangulates, in spacings
/// (four suffice for the jittered grid's simplices; a narrower one is refused by the part).
const MARGIN: Real = 4.0;

impl Builder {
    /// What a set-up from parts does not support, as the error that says so.
    fn parts_refuse(&self) -> Result<(), BuildError> {
        let no = |key: &str, why: &str| {
            Err(BuildError::new(
                key,
                format!("{why}; set the body up whole (run without --parts)"),
            ))
        };
        if !self.kind.is_random() {
            return no(
                "lattice.kind",
                "a set-up from parts builds random lattices (a regular lattice's box is swept whole by its stencil kernel)",
            );
        }
        match self.random.sampler {
            Sampler::Jitter { amplitude } if amplitude > 0.0 => {}
            s => {
                return no(
                    "lattice.sampler",
                    &format!(
                        "a part of a random lattice is built alone only from a jittered grid (sampler = \"jitter\"; \"{}\" places each node against those before it)",
                        s.name()
                    ),
                )
            }
        }
        if !self.geometry.curved(self.kind.dim()).is_empty() {
            return no(
                "geometry",
                "nodes grown on curved surfaces (spheres, cylinders) are not split into parts yet",
            );
        }
        if self.quasi_static.is_some() {
            return no("solver", "quasi-static runs hold the whole body");
        }
        if self.formats.1 {
            return no("output.format", "HDF5 frames are written whole");
        }
        if self.cell_weights == Some(true) {
            return no(
                "lattice.cell_weights",
                "a random lattice weights its springs and nodes by their volumes already; remove it",
            );
        }
        Ok(())
    }

    /// [`Builder::build`] on `team`'s processes, each holding its piece (see the module docs).
    pub(super) fn build_parts(self, team: Arc<dyn Team>) -> Result<Simulation, BuildError> {
        self.parts_refuse()?;
        let dim = self.kind.dim();
        let (a, h) = self.spacing_thickness()?;
        let (lo, hi) = self.geometry.bounds(dim)?;
        let tol = 1e-9 * a;
        let geometry = &self.geometry;
        let inside = |p: [Real; 3]| geometry.contains(Vector::new(p[0], p[1], p[2]), tol, dim);
        let body = Sampling {
            dim,
            lo: lo.into(),
            hi: hi.into(),
            a,
            h,
            spec: self.random,
            inside: &inside,
        };
        let geo = |e: hooke_core::Error| BuildError::new("geometry", e.to_string());
        let (piece, lattice, share) = assemble(&*team, &body, MARGIN * a).map_err(geo)?;
        let extremes = face_extremes(&*team, &lattice, piece.own.clone());
        let extreme = |f: Face| extremes[f.axis][usize::from(f.high)];
        // The loaded and prescribed nodes this process owns, then every process's in every
        // piece.
        let mine = self.loaded_owned(&piece, &lattice, &extreme);
        let (piece, lattice, share, _) = everyone(&*team, piece, lattice, share, &mine)
            .map_err(|e| BuildError::new("boundary", e.to_string()))?;
        let (body, k, design, mut held) = self.material_body(lattice)?;
        // A phase may hold nodes of other parts only: refused where it holds none of any.
        // (Every process has the same phases, so all take the collective or none.)
        if !held.is_empty() {
            team.any(&mut held);
        }
        self.phases_hold(&held)?;
        let mut state = State::new(&body);
        let cuts_nothing = |cut: bool| {
            let mut any = [cut];
            team.any(&mut any);
            !any[0]
        };
        let in_body = |i: usize| piece.global[i] as u64;
        let (mut fracture, _) = self.fracture(&body, &mut state, k, h, &cuts_nothing, &in_body)?;
        let global = |i: u32| Some(piece.global[i as usize]).filter(|&g| g != PAD);
        let own = piece.own.clone();
        let owned = |nodes: &[u32]| -> Vec<u32> {
            nodes
                .iter()
                .filter(|&&i| own.contains(&(i as usize)))
                .map(|&i| piece.global[i as usize])
                .collect()
        };
        let select = |r: &Region| r.select_where(&body.lattice, &extreme, &global);
        let none = |nodes: &[u32]| {
            let mut any = [!nodes.is_empty()];
            team.any(&mut any);
            !any[0]
        };
        let listed = |nodes: &[u32]| gather_ids(&*team, &owned(nodes));
        let pick = Selector {
            select: &select,
            none: &none,
            listed: &listed,
        };
        let (loading, regions, boundaries) =
            self.loading(&body, false, &mut state, &mut fracture, &pick)?;
        let contact = self.contact_on_piece(&*team, &body, &piece)?;
        // The springs pre-cracks cut, each counted by the owner of its lower end.
        let cut = state
            .alive()
            .iter()
            .zip(&body.lattice.bonds.ends)
            .filter(|(&alive, e)| !alive && own.contains(&(e[0] as usize)))
            .count();
        let precracked = sum_counts(&*team, cut);
        let springs = sum_counts(&*team, share.springs.len());
        let mut sim = self.simulation(body, state, loading, fracture, (regions, boundaries), k)?;
        sim.precracked = precracked;
        sim.random_design = design;
        sim.contact = contact;
        sim.held = Some(Held {
            own: piece.own.clone(),
            first: piece.first,
            nodes: piece.total,
            springs,
            extent: (0..3)
                .map(|c| extremes[c][1] - extremes[c][0])
                .fold(0.0, Real::max),
        });
        sim.from_parts = Some(FromParts { piece, share });
        Ok(sim)
    }

    /// This process's own nodes that a boundary loads or moves, in the body's numbering,
    /// ascending (`extreme`: the body's extreme coordinate of a face).
    fn loaded_owned(
        &self,
        piece: &Piece,
        lattice: &Lattice,
        extreme: &dyn Fn(Face) -> Real,
    ) -> Vec<u32> {
        let global = |i: u32| Some(piece.global[i as usize]).filter(|&g| g != PAD);
        let own = piece.own.clone();
        let surface = &lattice.cells.as_ref().expect("a random lattice").surface;
        let mut mine = Vec::new();
        for bc in &self.bcs {
            let moved = !bc.fixed.is_empty() || !bc.motions.is_empty();
            if !moved && bc.tractions.is_empty() {
                continue;
            }
            for i in bc.region.select_where(lattice, &extreme, &global) {
                let i = i as usize;
                // A traction loads the nodes with a share of the face (`traction_loads`).
                let loaded = bc
                    .tractions
                    .iter()
                    .any(|&(_, normal, _)| normal < 3 && surface[i][normal].abs() > 0.0);
                if own.contains(&i) && (moved || loaded) {
                    mine.push(piece.global[i]);
                }
            }
        }
        mine.sort_unstable();
        mine.dedup();
        mine
    }

    /// The contact of a simulation on pieces: rigid bodies placed against the whole body,
    /// which every process scans on its own nodes.
    fn contact_on_piece(
        &self,
        team: &dyn Team,
        body: &hooke_core::Body,
        piece: &Piece,
    ) -> Result<Option<hooke_contact::Contact>, BuildError> {
        Ok(match &self.contact {
            None => None,
            Some((spec, bodies)) => {
                let shortest = min_over(team, body.lattice.shortest());
                let global = |i: usize| piece.global[i] as usize;
                let nearest = |n| nearest_over(team, n);
                let whole = crate::rigid::Across {
                    shortest,
                    nodes: piece.total,
                    scan: piece.own.clone(),
                    global: &global,
                    nearest: &nearest,
                };
                Some(crate::rigid::contact_across(body, spec, bodies, &whole)?)
            }
        })
    }
}

/// The body's extreme coordinate along each axis, `[min, max]`, over every process's own
/// nodes (a minimum and a maximum do not depend on the order they are taken in). Collective.
fn face_extremes(
    team: &dyn Team,
    lattice: &Lattice,
    own: std::ops::Range<usize>,
) -> [[Real; 2]; 3] {
    let size = team.size();
    let mut all = vec![0.0; 6 * size];
    let at = 6 * team.rank();
    for c in 0..3 {
        let x = &lattice.pos.comp(c)[own.clone()];
        all[at + 2 * c] = x.iter().cloned().fold(Real::INFINITY, Real::min);
        all[at + 2 * c + 1] = x.iter().cloned().fold(Real::NEG_INFINITY, Real::max);
    }
    let parts: Vec<_> = (0..size).map(|r| 6 * r..6 * r + 6).collect();
    team.gather(&mut all, &parts);
    let mut out = [[Real::INFINITY, Real::NEG_INFINITY]; 3];
    for r in all.chunks_exact(6) {
        for c in 0..3 {
            out[c][0] = out[c][0].min(r[2 * c]);
            out[c][1] = out[c][1].max(r[2 * c + 1]);
        }
    }
    out
}

/// The least of every process's `x` (exact in any order). Collective.
fn min_over(team: &dyn Team, x: Real) -> Real {
    let size = team.size();
    let mut all = vec![0.0; size];
    all[team.rank()] = x;
    let parts: Vec<_> = (0..size).map(|r| r..r + 1).collect();
    team.gather(&mut all, &parts);
    all.into_iter().fold(Real::INFINITY, Real::min)
}

/// The nearest of every process's nearest node to a rigid body, `(body index, gap, position)`:
/// the smallest gap, the first process's among equal ones (processes own ascending nodes, so
/// this is the lowest index, as one process's scan finds it). Collective.
fn nearest_over(team: &dyn Team, mine: Option<Nearest>) -> Option<Nearest> {
    let size = team.size();
    let mut all = vec![0.0; 6 * size];
    if let Some((i, gap, p)) = mine {
        let at = 6 * team.rank();
        all[at..at + 6].copy_from_slice(&[1.0, gap, i as Real, p[0], p[1], p[2]]);
    }
    let parts: Vec<_> = (0..size).map(|r| 6 * r..6 * r + 6).collect();
    team.gather(&mut all, &parts);
    let mut best: Option<Nearest> = None;
    for x in all.chunks_exact(6).filter(|x| x[0] == 1.0) {
        if best.is_none_or(|b| x[1] < b.1) {
            best = Some((x[2] as usize, x[1], [x[3], x[4], x[5]]));
        }
    }
    best
}
