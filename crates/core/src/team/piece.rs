//! A rank's piece of a body: its own nodes and its ghosts alone, renumbered. The first brick
//! of a distributed-memory run, in which no rank holds the whole body or state.
//!
//! A [`Share`] says which nodes a rank owns (whole chunks of [`CHUNK`] nodes) and which other
//! nodes its sweeps read (its [`Halo`]'s ghosts). [`Piece::cut`] keeps those nodes and every
//! spring with an end among the rank's own, and numbers them so that the sweeps over the piece
//! give, at the owned nodes, the bits of the sweeps over the whole body:
//!
//! - **The order of the nodes is kept.** Local index order is global index order, so a
//!   spring's lower end stays its lower end, the springs keep their order (sorted by
//!   `(lower, upper)`), and each owned node's row lists its springs in the same order: every
//!   sum over a row adds the same terms in the same order.
//! - **Owned nodes start on a chunk.** The ghosts before the owned nodes are preceded by
//!   `pad` isolated dummy nodes (no springs, unit mass), so that the owned nodes start at a
//!   multiple of [`CHUNK`] in the piece, as they do in the body: a piece's chunk `c` of owned
//!   nodes is the body's chunk `c - own.start / CHUNK + first / CHUNK`, node for node, and the
//!   kernels' windows and per-chunk partial sums fall as they fall in the body.
//!
//! Values at the ghosts are whatever their owners last sent: a piece's sweeps compute them
//! from incomplete rows (a ghost's row holds only its springs to owned nodes) and the halo
//! trades overwrite them, as in a shared run over the whole body.
//!
//! At most `CHUNK - 1` dummies (about 2 MB of a random3d piece's arrays) are the price of
//! keeping the body's chunking without an index shift inside the kernels.

use std::ops::Range;

use crate::body::Body;
use crate::error::Result;
use crate::kernel::CHUNK;
use crate::lattice::{Bonds, Cells, Lattice, Topology};
use crate::math::{Coords, Real};
use crate::state::State;
use crate::team::{Halo, Share};

/// Marks a dummy node in [`Piece::global`].
pub const PAD: u32 = u32::MAX;

/// Where a rank's piece sits in the body (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    /// The body's index of each of the piece's nodes ([`PAD`] for the dummies), ascending
    /// apart from the dummies, which come first.
    pub global: Vec<u32>,
    /// The owned nodes, in the piece's numbering: whole chunks from a multiple of [`CHUNK`].
    pub own: Range<usize>,
    /// The body's index of the first owned node.
    pub first: usize,
    /// Nodes of the whole body.
    pub total: usize,
    /// The body's index of each of the piece's springs, ascending.
    pub springs: Vec<u32>,
    /// The rank's trades in the piece's numbering: the same nodes, in the same order, as the
    /// share's halo, so that the peers' messages match.
    pub halo: Halo,
}

impl Piece {
    /// Cut rank `share.rank`'s piece out of `body`: the piece's description and its body.
    ///
    /// Every body is cut alike, but the bits of the whole body's sweeps are kept only where a
    /// kernel sweeps the piece as it sweeps the body: bodies without a grid (random lattices),
    /// whose kernels read rows. A box of a regular lattice is swept by its stencil.
    pub fn cut(body: &Body, share: &Share) -> Result<(Piece, Body)> {
        let mine = share.mine();
        let bonds = &*body.lattice.bonds;
        // The ghosts: every node the halo receives (which holds the far ends of the rank's
        // springs that cross, and the nodes every rank reads).
        let mut ghosts: Vec<u32> = share.halo.recv.iter().flatten().copied().collect();
        ghosts.sort_unstable();
        ghosts.dedup();
        let below = ghosts.partition_point(|&g| (g as usize) < mine.start);
        let pad = below.next_multiple_of(CHUNK) - below;
        let mut global = vec![PAD; pad];
        global.extend_from_slice(&ghosts[..below]);
        global.extend(mine.clone().map(|i| i as u32));
        global.extend_from_slice(&ghosts[below..]);
        let own = pad + below..pad + below + mine.len();
        let local = |g: u32| -> u32 {
            let g = g as usize;
            if mine.contains(&g) {
                (g - mine.start + own.start) as u32
            } else {
                let at = ghosts
                    .binary_search(&(g as u32))
                    .expect("a ghost of the piece");
                (if at < below {
                    pad + at
                } else {
                    own.end + at - below
                }) as u32
            }
        };
        // Every spring with an end here, in the body's order.
        let mut springs: Vec<u32> = mine
            .clone()
            .flat_map(|i| bonds.row(i).map(|e| bonds.bond[e]))
            .collect();
        springs.sort_unstable();
        springs.dedup();
        let pairs: Vec<[u32; 2]> = springs
            .iter()
            .map(|&b| bonds.ends[b as usize].map(local))
            .collect();
        let n = global.len();
        let lat = &body.lattice;
        let pick = |x: &[Real], fill: Real| -> Vec<Real> {
            global
                .iter()
                .map(|&g| if g == PAD { fill } else { x[g as usize] })
                .collect()
        };
        let p = &lat.pos;
        let pos = Coords::from_components(&pick(p.x(), 0.0), &pick(p.y(), 0.0), &pick(p.z(), 0.0));
        // The rest lengths follow from the positions by the body's own formula (the same bits:
        // `Bonds::from_pairs`); the piece's pairs are in the body's order already.
        let piece_bonds = Bonds::from_pairs(n, pairs, &pos, lat.period)?;
        debug_assert_eq!(piece_bonds.len(), springs.len());
        let per_spring = |x: &[Real]| -> Vec<Real> {
            if x.is_empty() {
                Vec::new()
            } else {
                springs.iter().map(|&b| x[b as usize]).collect()
            }
        };
        let cells = lat.cells.as_ref().map(|c| Cells {
            node: pick(&c.node, 0.0),
            spring: per_spring(&c.spring),
            surface: if c.surface.is_empty() {
                Vec::new()
            } else {
                global
                    .iter()
                    .map(|&g| {
                        if g == PAD {
                            [0.0; 3]
                        } else {
                            c.surface[g as usize]
                        }
                    })
                    .collect()
            },
            sampler: c.sampler,
        });
        let mut lattice = Lattice {
            kind: lat.kind,
            spacing: lat.spacing,
            pos,
            cell_volume: lat.cell_volume,
            thickness: lat.thickness,
            period: lat.period,
            grid: None,
            bonds: Topology::from(piece_bonds),
            cells,
        };
        if lat.bonds.stored_rest().is_none() {
            // The body sheds its rest lengths (each `|X_j - X_i|` to the bit): so does its piece.
            lattice.shed_rest();
        }
        let k = per_spring(&body.k[..]);
        let piece_body = Body {
            lattice,
            k: k.into(),
            q: body.q,
            mass: pick(&body.mass, 1.0),
            lever: body.lever.as_ref().map(|l| per_spring(l)),
            q_node: body.q_node.as_ref().map(|q| pick(q, 1.0)),
            phase: body.phase.as_ref().map(|p| {
                global
                    .iter()
                    .map(|&g| if g == PAD { 0 } else { p[g as usize] })
                    .collect()
            }),
        };
        let to_local = |list: &Vec<u32>| list.iter().map(|&g| local(g)).collect();
        let halo = Halo {
            send: share.halo.send.iter().map(to_local).collect(),
            recv: share.halo.recv.iter().map(to_local).collect(),
        };
        let piece = Piece {
            global,
            own,
            first: mine.start,
            total: body.nodes(),
            springs,
            halo,
        };
        Ok((piece, piece_body))
    }

    /// The piece's index of the body's node `g`, if the piece holds it.
    pub fn local(&self, g: usize) -> Option<usize> {
        let pad = self.global.partition_point(|&x| x == PAD);
        let real = &self.global[pad..];
        real.binary_search(&(g as u32)).ok().map(|at| pad + at)
    }

    /// Nodes of the piece, dummies and ghosts included.
    pub fn len(&self) -> usize {
        self.global.len()
    }

    /// True for a piece without nodes.
    pub fn is_empty(&self) -> bool {
        self.global.is_empty()
    }

    /// The body's chunk of the piece's chunk `c` of owned nodes.
    pub fn global_chunk(&self, c: usize) -> usize {
        c - self.own.start / CHUNK + self.first / CHUNK
    }

    /// The piece's share of its own sweeps: its owned nodes as one rank's whole chunks, with the
    /// springs that its sweep 1 computes (its owned nodes' springs from their lower ends, those
    /// whose lower end is a ghost one by one), and no halo (the piece's halo is traded with
    /// the ranks, [`Piece::halo`]).
    pub fn share(&self, body: &Body) -> Share {
        let n = self.len();
        let mut nodes = vec![0..self.own.start, self.own.clone()];
        if self.own.end < n {
            nodes.push(self.own.end..n);
        }
        Share::without_halo(body, nodes, 1)
    }

    /// The piece's state cut out of the whole body's `state` (`piece_body` as [`Piece::cut`]
    /// gave it): every value at the piece's nodes and springs.
    pub fn state(&self, piece_body: &Body, state: &State) -> State {
        state.cut(piece_body, &self.global, PAD, &self.springs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{Kernel, StepParams, SweepSums};
    use crate::team::tests::{block, strained};
    use crate::team::{trade_halo, Team, Threads};

    /// Steps of the two sweeps over a body or a rank's piece of it (with `piece`: the ghosts'
    /// pools and displacements traded between the sweeps, as a shared run trades them).
    fn sweeps(
        kernel: &Kernel,
        body: &Body,
        state: &mut State,
        steps: usize,
        p: &StepParams,
        rank: Option<(&dyn Team, &Piece, &Share)>,
    ) -> Vec<SweepSums> {
        let inv_mass: Vec<Real> = body.mass.iter().map(|m| 1.0 / m).collect();
        let mut partials = vec![SweepSums::default(); body.nodes().div_ceil(CHUNK)];
        let mut u_next = Coords::zeros(body.nodes());
        let size = rank.map_or(1, |r| r.0.size());
        let (mut out, mut inp) = (vec![Vec::new(); size], vec![Vec::new(); size]);
        for _ in 0..steps {
            kernel.pools_shared(body, state, Real::INFINITY, rank.map(|r| r.2));
            if let Some((team, piece, _)) = rank {
                trade_halo(
                    team,
                    &piece.halo,
                    &mut out,
                    &mut inp,
                    &mut [&mut state.pool],
                );
            }
            let in_place = kernel.drifts_in_place();
            kernel.force_kick_drift_shared(
                body,
                state,
                &inv_mass,
                p,
                (!in_place).then_some(&mut u_next),
                &mut partials,
                rank.map(|r| r.2),
            );
            if !in_place {
                std::mem::swap(&mut state.u, &mut u_next);
            }
            if let Some((team, piece, _)) = rank {
                let mut u = state.u.xyz_mut();
                trade_halo(team, &piece.halo, &mut out, &mut inp, &mut u[..]);
            }
            state.time += p.dt;
            state.step += 1;
        }
        partials
    }

    /// A random block that has shed its set-up arrays, with direction levers (each rest length
    /// times `1 + (b mod every) / 10`).
    pub(super) fn levered(every: usize) -> Body {
        let mut body = block([30.0, 24.0, 22.0]);
        body.lattice.shed_setup();
        let m = body.springs();
        body.lever = Some(
            (0..m)
                .map(|b| body.lattice.rest(b) * (1.0 + 0.1 * ((b % every) as Real)))
                .collect(),
        );
        body
    }

    /// Pieces of 2 and 3 ranks, stepped with their halos traded between the sweeps, end with
    /// the whole body's bits at their owned nodes: displacements, velocities and pools, and
    /// the per-chunk partial sums of damping and body-force work; with the vector paths and
    /// the portable ones, broken springs, direction levers and shed rest lengths.
    #[test]
    fn pieces_step_with_the_bits_of_the_whole() {
        let body = levered(7);
        let n = body.nodes();
        let mut start = strained(&body, 17);
        for i in 0..n {
            start.v.x_mut()[i] = 0.003 * (0.5 * body.lattice.pos.get(i).z).cos();
        }
        let p = StepParams {
            dt: 0.05,
            damping: 0.3,
            accel: [0.0, -0.2, 0.1],
            plane: false,
        };
        let bits = |x: &[Real]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for simd in [true, false] {
            let mut kernel = Kernel::for_body(&body, &start);
            kernel.set_simd(simd);
            let mut whole = start.clone();
            let sums = sweeps(&kernel, &body, &mut whole, 6, &p, None);
            for size in [2, 3] {
                std::thread::scope(|scope| {
                    for team in Threads::team(size) {
                        let (body, start, whole, sums, bits) =
                            (&body, &start, &whole, &sums, &bits);
                        scope.spawn(move || {
                            let share = Share::new(body, size, team.rank(), &[]);
                            let (piece, pb) = Piece::cut(body, &share).unwrap();
                            assert_eq!(piece.own.start % CHUNK, 0);
                            assert!(piece.len() < n, "a piece holds less than the body");
                            let mut ps = piece.state(&pb, start);
                            let mut kernel = Kernel::for_body_in(&pb, &ps, Some(piece.own.clone()));
                            kernel.set_simd(simd);
                            let pshare = piece.share(&pb);
                            let local = sweeps(
                                &kernel,
                                &pb,
                                &mut ps,
                                6,
                                &p,
                                Some((&team, &piece, &pshare)),
                            );
                            let at = format!("{size} ranks, rank {}, simd {simd}", team.rank());
                            let g: Vec<usize> = piece.global[piece.own.clone()]
                                .iter()
                                .map(|&g| g as usize)
                                .collect();
                            let pick =
                                |x: &[Real]| bits(&g.iter().map(|&i| x[i]).collect::<Vec<_>>());
                            let own = |x: &[Real]| bits(&x[piece.own.clone()]);
                            for c in 0..3 {
                                assert_eq!(own(ps.u.comp(c)), pick(whole.u.comp(c)), "u {at}");
                                assert_eq!(own(ps.v.comp(c)), pick(whole.v.comp(c)), "v {at}");
                            }
                            assert_eq!(own(&ps.pool), pick(&whole.pool), "pools {at}");
                            for c in crate::kernel::chunks_of(&piece.own) {
                                assert_eq!(
                                    local[c],
                                    sums[piece.global_chunk(c)],
                                    "chunk {c}, {at}"
                                );
                            }
                        });
                    }
                });
            }
        }
    }
}

#[cfg(test)]
mod integrator_tests {
    use std::sync::Arc;

    use super::*;
    use crate::dynamics::{EnergyBalance, Integrator, IntegratorOptions, Ledger};
    use crate::loading::{Load, Loading, Motion, Prescribed, TimeFunction};
    use crate::team::tests::{assert_own_state, block, strained};
    use crate::team::{Team, Threads};

    /// Grip the block's low-x face, pull its high-x face at a constant velocity along y, load
    /// a few nodes, with damping and gravity.
    fn loading(body: &Body) -> Loading {
        let x = body.lattice.pos.x();
        let hi = x.iter().copied().fold(Real::MIN, Real::max);
        let face = |f: &dyn Fn(Real) -> bool| -> Vec<u32> {
            (0..body.nodes() as u32)
                .filter(|&i| f(x[i as usize]))
                .collect()
        };
        let low = face(&|x| x < 0.5);
        let high = face(&|x| x > hi - 0.5);
        let n = body.nodes() as u32;
        Loading {
            prescribed: vec![
                Prescribed {
                    nodes: low.clone(),
                    axis: 0,
                    motion: Motion::Fixed,
                },
                Prescribed {
                    nodes: low,
                    axis: 1,
                    motion: Motion::Fixed,
                },
                Prescribed {
                    nodes: high,
                    axis: 1,
                    motion: Motion::Velocity(TimeFunction::Constant(0.02)),
                },
            ],
            loads: vec![Load {
                nodes: vec![n / 3, n / 2, n - 7],
                force: [0.1, -0.05, 0.2].into(),
                scale: TimeFunction::Constant(1.0),
            }],
            body_acceleration: [0.0, -0.3, 0.0].into(),
        }
    }

    /// Member `team`'s integrator for `body` from `start`, distributed, and the piece it
    /// steps from then on (the whole state dropped).
    fn pieced(
        team: Threads,
        body: &Body,
        start: &State,
        loading: Loading,
        opts: &IntegratorOptions,
    ) -> (Integrator, Body, State) {
        let team: Arc<dyn Team> = Arc::new(team);
        let mut state = start.clone();
        let mut it = Integrator::new_shared(body, &mut state, loading, opts, Some(team)).unwrap();
        let (pb, ps) = it.cut(body, &state).unwrap();
        (it, pb, ps)
    }

    fn ledger_bits(l: Ledger) -> [u64; 5] {
        [
            l.external_work,
            l.boundary_work,
            l.body_work,
            l.dissipated,
            l.released,
        ]
        .map(Real::to_bits)
    }

    /// An integrator that steps its rank's piece ([`Integrator::cut`]) keeps one process's
    /// bits at its own nodes and in the energy ledger, with prescribed motion, loads, damping
    /// and gravity, for teams of 2, 3 and 7 (the body has 5 chunks: some of 7 ranks own no
    /// node): the row kernel's vector and portable paths, and the CSR kernel (what a processor
    /// without AVX2 runs).
    #[test]
    fn a_pieced_integrator_steps_with_the_bits_of_one_process() {
        let body = block([30.0, 24.0, 22.0]);
        assert!(body.nodes() <= 5 * CHUNK, "{} nodes", body.nodes());
        let start = strained(&body, 23);
        let steps = 25;
        for (portable, force_csr) in [(false, false), (true, false), (false, true)] {
            let opts = IntegratorOptions {
                damping: 0.2,
                portable,
                force_csr,
                damage_proof: true,
                ..Default::default()
            };
            let mut alone = start.clone();
            let mut it = Integrator::new(&body, &mut alone, loading(&body), &opts).unwrap();
            for _ in 0..steps {
                it.step(&body, &mut alone);
            }
            let ledger = ledger_bits(it.ledger());
            for size in [2, 3, 7] {
                std::thread::scope(|scope| {
                    for team in Threads::team(size) {
                        let (body, start, alone, opts) = (&body, &start, &alone, &opts);
                        scope.spawn(move || {
                            let rank = team.rank();
                            let (mut it, pb, mut ps) =
                                pieced(team, body, start, loading(body), opts);
                            for _ in 0..steps {
                                it.step(&pb, &mut ps);
                            }
                            it.check_shared(&pb, &mut ps).unwrap();
                            let at = format!(
                                "{size} ranks, rank {rank}, portable {portable}, csr {force_csr}"
                            );
                            assert_eq!(ledger_bits(it.ledger()), ledger, "ledger, {at}");
                            let piece = it.piece().unwrap();
                            assert_own_state(&piece.global, piece.own.clone(), &ps, alone, &at);
                            assert_eq!(ps.step, alone.step);
                        });
                    }
                });
            }
        }
    }

    /// A blow-up on pieces stops every rank with one process's message: the first bad node
    /// of the body, named by its index there, wherever it is owned.
    #[test]
    fn an_instability_on_pieces_names_the_bodys_first_bad_node() {
        let body = block([30.0, 24.0, 22.0]);
        let mut start = strained(&body, 23);
        let bad = 2 * body.nodes() / 3;
        start.v.y_mut()[bad] = Real::NAN;
        let opts = IntegratorOptions::default();
        let mut alone = start.clone();
        let mut it = Integrator::new(&body, &mut alone, Loading::default(), &opts).unwrap();
        for _ in 0..3 {
            it.step(&body, &mut alone);
        }
        let expected = it.check_shared(&body, &mut alone).unwrap_err().to_string();
        for size in [2, 3] {
            std::thread::scope(|scope| {
                for team in Threads::team(size) {
                    let (body, start, opts, expected) = (&body, &start, &opts, &expected);
                    scope.spawn(move || {
                        let (mut it, pb, mut ps) =
                            pieced(team, body, start, Loading::default(), opts);
                        for _ in 0..3 {
                            it.step(&pb, &mut ps);
                        }
                        let found = it.check_shared(&pb, &mut ps).unwrap_err().to_string();
                        assert_eq!(&found, expected, "{size} ranks");
                    });
                }
            });
        }
    }

    /// A piece gives one process's frame bits where it owns them and one process's sums
    /// everywhere: the energy balance (of a frame and alone), the full-step velocities of its
    /// own nodes and of the loaded and prescribed ones, the reactions at a frame and between
    /// frames, and the checkpoint's integrator; teams of 2, 3 and 7.
    #[test]
    fn a_piece_gives_one_process_frames_energies_and_reactions() {
        let body = block([30.0, 24.0, 22.0]);
        let start = strained(&body, 29);
        let opts = IntegratorOptions {
            damping: 0.3,
            ..Default::default()
        };
        let steps = 9;
        let mut alone = start.clone();
        let mut it = Integrator::new(&body, &mut alone, loading(&body), &opts).unwrap();
        for _ in 0..steps {
            it.step(&body, &mut alone);
        }
        let now = it.boundary_forces_now(&body, &alone);
        let energy = it.energy(&body, &mut alone.clone());
        let (v, b, _) = it.frame_view(&body, &mut alone, false);
        let at_frame = it.boundary_forces(&body, &alone, &v);
        let ck = it.checkpoint();
        let bits = |b: &EnergyBalance| {
            [
                b.kinetic,
                b.strain.direct,
                b.strain.dispersive,
                b.error,
                b.relative_error,
            ]
            .map(Real::to_bits)
        };
        let special = crate::dynamics::special_nodes(&loading(&body));
        for size in [2, 3, 7] {
            std::thread::scope(|scope| {
                for team in Threads::team(size) {
                    let (body, start, opts) = (&body, &start, &opts);
                    let (now, energy, v, b, at_frame, ck) = (&now, &energy, &v, &b, &at_frame, &ck);
                    let special = &special;
                    scope.spawn(move || {
                        let at = format!("{size} ranks, rank {}", team.rank());
                        let (mut it, pb, mut ps) = pieced(team, body, start, loading(body), opts);
                        for _ in 0..steps {
                            it.step(&pb, &mut ps);
                        }
                        let piece = it.piece().unwrap().clone();
                        let local = |g: usize| piece.local(g).unwrap();
                        let now_p = it.boundary_forces_now(&pb, &ps);
                        let energy_p = it.energy(&pb, &mut ps.clone());
                        let (vp, bp, _) = it.frame_view(&pb, &mut ps, false);
                        let at_frame_p = it.boundary_forces(&pb, &ps, &vp);
                        assert_eq!(bits(&energy_p), bits(energy), "energy, {at}");
                        assert_eq!(bits(&bp), bits(b), "frame's balance, {at}");
                        assert_eq!(it.checkpoint(), *ck, "{at}");
                        let own = piece.own.clone().map(|i| piece.global[i] as usize);
                        for g in own.chain(special.iter().copied()) {
                            let i = local(g);
                            for c in 0..3 {
                                assert_eq!(vp.comp(c)[i].to_bits(), v.comp(c)[g].to_bits());
                            }
                        }
                        for &g in special {
                            let i = local(g);
                            for c in 0..3 {
                                let what = format!("reaction of node {g}, {at}");
                                assert_eq!(
                                    now_p.comp(c)[i].to_bits(),
                                    now.comp(c)[g].to_bits(),
                                    "{what}"
                                );
                                assert_eq!(
                                    at_frame_p.comp(c)[i].to_bits(),
                                    at_frame.comp(c)[g].to_bits(),
                                    "{what}"
                                );
                            }
                        }
                        // A second cut is an error, not a panic.
                        assert!(it.cut(&pb, &ps).is_err());
                    });
                }
            });
        }
    }
}

#[cfg(test)]
mod frame_tests {
    use super::*;
    use crate::law::{frame_fields_in, frame_fields_piece, FrameScratch, PieceFrame};
    use crate::team::tests::strained;
    use crate::team::{Team, Threads};

    /// A frame computed on pieces gives the whole body's frame at every rank's own nodes
    /// (pools, forces, energy densities, stresses) and both strain energies on every rank, bit
    /// for bit: teams of 2, 3 and 7, with broken springs, levers and shed rest lengths.
    #[test]
    fn a_frame_on_pieces_gives_the_bits_of_the_whole() {
        let body = super::tests::levered(5);
        let state = strained(&body, 11);
        let whole = frame_fields_in(
            &body,
            &state.u,
            state.springs(&body),
            state.norm(),
            &mut FrameScratch::default(),
        );
        let bits = |x: Real| x.to_bits();
        for size in [2, 3, 7] {
            std::thread::scope(|scope| {
                for team in Threads::team(size) {
                    let (body, state, whole) = (&body, &state, &whole);
                    scope.spawn(move || {
                        let share = Share::new(body, size, team.rank(), &[]);
                        let (piece, pb) = Piece::cut(body, &share).unwrap();
                        let ps = piece.state(&pb, state);
                        let f = frame_fields_piece(
                            &pb,
                            &ps.u,
                            ps.springs(&pb),
                            ps.norm(),
                            &mut FrameScratch::default(),
                            PieceFrame {
                                team: &team,
                                piece: &piece,
                                share: &share,
                            },
                        );
                        let at = format!("{size} ranks, rank {}", team.rank());
                        assert_eq!(bits(f.strain.direct), bits(whole.strain.direct), "{at}");
                        assert_eq!(
                            bits(f.strain.dispersive),
                            bits(whole.strain.dispersive),
                            "{at}"
                        );
                        let ghosts = piece.halo.recv.iter().flatten().map(|&i| i as usize);
                        for i in piece.own.clone().chain(ghosts) {
                            let g = piece.global[i] as usize;
                            assert_eq!(bits(f.pool[i]), bits(whole.pool[g]), "pool {g}, {at}");
                        }
                        for i in piece.own.clone() {
                            let g = piece.global[i] as usize;
                            for c in 0..3 {
                                assert_eq!(
                                    bits(f.force.comp(c)[i]),
                                    bits(whole.force.comp(c)[g]),
                                    "force {g}, {at}"
                                );
                            }
                            assert_eq!(bits(f.energy_density[i]), bits(whole.energy_density[g]));
                            assert_eq!(f.stress[i].map(bits), whole.stress[g].map(bits));
                        }
                    });
                }
            });
        }
    }
}
