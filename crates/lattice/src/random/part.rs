//! A part of a random lattice built alone: the nodes whose Morton keys lie in a range, with all
//! that the whole body gives them (positions, volumes, boundary shares, springs and their
//! volumes), to the bit, from the nodes sampled in and around the part only. This is what lets
//! each process of a distributed run set up its own part of a body that no one machine could
//! build whole.
//!
//! # Why a part can be built alone
//!
//! *The nodes.* The jittered grid draws each node from a stream of its own, seeded by the
//! lattice's seed and the node's grid index (`sample::JitterGrid::node`), so sampling
//! a window of the grid gives the whole grid's nodes there. (Poisson-disk sampling places each
//! node against those placed before it: a part of it cannot be drawn alone, and is refused.)
//!
//! *The simplices.* Let `P` be the body's nodes, `B` its box, `W` the window the part samples
//! (its key range's blocks, widened by a margin), `Q = P ∩ W`, and `S` the super-simplex,
//! the same for both because both are triangulated in `B`
//! ([`super::delaunay::triangulate_in`]). A simplex of `DT(Q ∪ S)` whose open circumball holds
//! no node of `P` outside `W` holds none at all, so it is a simplex of `DT(P ∪ S)`. Every node
//! lies in `B`, so it suffices that the ball's part inside `B` lies in `W`; the part checks
//! that for every simplex around an own node, those with a super-vertex included, and refuses
//! a margin too narrow. When every simplex around an own node `x` passes, `x`'s star is the
//! whole body's: both stars cover a neighbourhood of `x` without overlap, and the part's
//! simplices are simplices of the whole triangulation. (Nodes in general position, which the
//! jittered grid gives with probability one when its amplitude is not zero; at zero it is a
//! grid full of co-spherical nodes, whose triangulation depends on the order of insertion:
//! refused.)
//!
//! *The sums.* A simplex is judged, measured and its facets' normals formed from its vertices
//! in ascending order, and a node's sums run over its simplices in the ascending order of their
//! vertex lists (`random::shares`). The part numbers its nodes in the body's order (Morton key,
//! then grid index), so every sum has the body's terms in the body's order: the same bits.

use super::delaunay::{self, morton_key};
use super::sample::JitterGrid;
use super::{ascending, shares, simplices, RandomSpec, Sampler};
use crate::error::{Error, Result};
use crate::math::Real;
use rayon::prelude::*;
use std::ops::Range;

/// The largest Morton key plus one: key ranges of a body run within `0..KEY_END`.
pub const KEY_END: u64 = 1 << 63;

/// A part of a random lattice ([`Sampling::part`]): its own nodes (a range of Morton keys) and the nodes
/// their springs reach, numbered in the body's order.
#[derive(Clone, Debug)]
pub struct Part {
    /// Reference positions (m), in the body's order.
    pub pos: Vec<[Real; 3]>,
    /// Each node's Morton key in the body's box ([`key`]): the key and then the grid index
    /// order the body's nodes.
    pub key: Vec<u64>,
    /// Each node's index in the jittered grid: it names the node in every part that holds it.
    pub grid: Vec<u64>,
    /// The own nodes, a range of the above.
    pub own: Range<usize>,
    /// Volume `V_n` of each own node (m^3; area times thickness on a plate).
    pub volume: Vec<Real>,
    /// Boundary share of each own node ([`crate::lattice::Cells::surface`]).
    pub surface: Vec<[Real; 3]>,
    /// The springs with an own end, `(i, j)` with `i < j` in the part's numbering, in the
    /// body's order, each with its volume `V_s`.
    pub springs: Vec<([u32; 2], Real)>,
    /// How many nodes the part sampled and triangulated (own, ghost and margin): the size of
    /// its set-up.
    pub sampled: usize,
}

impl Part {
    /// A part without nodes, of a set-up that sampled `sampled` nodes.
    fn empty(sampled: usize) -> Part {
        Part {
            pos: Vec::new(),
            key: Vec::new(),
            grid: Vec::new(),
            own: 0..0,
            volume: Vec::new(),
            surface: Vec::new(),
            springs: Vec::new(),
            sampled,
        }
    }
}

/// The Morton key of a node at `p` in a body sampled in the box `[lo, hi]` (z ignored on a
/// plate): the order of a random lattice's nodes.
pub fn key(p: [Real; 3], lo: [Real; 3], hi: [Real; 3]) -> u64 {
    morton_key(&p, lo, hi)
}

/// A random body to be built in parts: what [`crate::lattice::Lattice::random`] takes.
#[derive(Clone, Copy)]
pub struct Sampling<'a> {
    /// 2 (a plate in the xy plane) or 3.
    pub dim: usize,
    /// The sampling box (m).
    pub lo: [Real; 3],
    pub hi: [Real; 3],
    /// The mean spacing a (m).
    pub a: Real,
    /// The plate's thickness (m; ignored in 3D).
    pub h: Real,
    pub spec: RandomSpec,
    /// Whether a point is in the body.
    pub inside: &'a (dyn Fn([Real; 3]) -> bool + Sync),
}

impl Sampling<'_> {
    /// The sampling box, flat (z = 0) on a plate.
    fn flat_box(&self) -> ([Real; 3], [Real; 3]) {
        let (lo, hi) = (self.lo, self.hi);
        if self.dim == 2 {
            ([lo[0], lo[1], 0.0], [hi[0], hi[1], 0.0])
        } else {
            (lo, hi)
        }
    }

    /// The keys of the own nodes of the part [`Sampling::part`] builds for `keys`, ascending:
    /// the nodes of the body whose key is in `keys`, sampled but not triangulated (what a
    /// split of the body between processes needs).
    pub fn own_keys(&self, keys: Range<u64>) -> Result<Vec<u64>> {
        // A spacing of margin: the blocks' boxes hold their nodes, rounding aside.
        let amp = self.amplitude(self.a)?;
        if keys.is_empty() {
            return Ok(Vec::new());
        }
        let nodes = self.window(amp, keys.clone(), self.a);
        Ok(nodes
            .iter()
            .map(|e| e.0)
            .filter(|k| keys.contains(k))
            .collect())
    }

    /// The jitter amplitude of the sampler, once the box, the sampler and the margin are
    /// checked.
    fn amplitude(&self, margin: Real) -> Result<Real> {
        let Sampling {
            dim,
            lo,
            hi,
            a,
            spec,
            ..
        } = *self;
        super::check_box(dim, lo, hi, a, spec)?;
        let amp = match spec.sampler {
            Sampler::Jitter { amplitude } if amplitude > 0.0 => amplitude,
            _ => {
                return Err(Error::InvalidInput {
                    what: "random lattice part",
                    why: format!(
                        "a part of a random lattice can be built alone only from a jittered grid \
                     with a non-zero amplitude (sampler \"{}\"): each of its nodes has a \
                     stream of its own",
                        spec.sampler.name()
                    ),
                })
            }
        };
        if !(margin.is_finite() && margin > 0.0) {
            return Err(Error::InvalidInput {
                what: "random lattice part",
                why: format!("margin = {margin} m; give a positive margin (four spacings suffice)"),
            });
        }
        Ok(amp)
    }

    /// The jittered grid's nodes inside the body (`inside`) within `margin` of the blocks of
    /// `keys`: `(key, grid index, position)`, in the body's order.
    fn window(&self, amp: Real, keys: Range<u64>, margin: Real) -> Vec<(u64, u64, [Real; 3])> {
        let (dim, a, inside) = (self.dim, self.a, self.inside);
        let (lo, hi) = self.flat_box();
        let boxes = key_boxes(keys, dim, lo, hi, margin);
        let in_window = |p: &[Real; 3]| {
            boxes
                .iter()
                .any(|(l, u)| (0..dim).all(|c| p[c] >= l[c] && p[c] <= u[c]))
        };
        let g = JitterGrid::new(dim, lo, hi, a, amp, self.spec.seed);
        let count = g.count();
        // The grid indices whose nodes can fall in a block (a node moves by up to amp h / 2).
        let mut lin: Vec<u64> = Vec::new();
        for (l, u) in &boxes {
            let mut r = [(0usize, 0usize); 3];
            let mut empty = false;
            for c in 0..dim {
                let f0 = ((l[c] - lo[c]) / g.h[c] - 0.5 * amp).floor();
                let f1 = ((u[c] - lo[c]) / g.h[c] + 0.5 * amp).ceil();
                if f1 < 0.0 || f0 > g.n[c] as Real {
                    empty = true;
                }
                r[c] = (
                    f0.max(0.0) as usize,
                    (f1.min(g.n[c] as Real)).max(0.0) as usize,
                );
            }
            if empty {
                continue;
            }
            for k in r[2].0..=r[2].1 {
                for j in r[1].0..=r[1].1 {
                    for i in r[0].0..=r[0].1 {
                        lin.push((i + count[0] * (j + count[1] * k)) as u64);
                    }
                }
            }
        }
        lin.par_sort_unstable();
        lin.dedup();
        let mut nodes: Vec<(u64, u64, [Real; 3])> = lin
            .par_iter()
            .filter_map(|&l| {
                let l0 = l as usize;
                let idx = [
                    l0 % count[0],
                    (l0 / count[0]) % count[1],
                    l0 / (count[0] * count[1]),
                ];
                let p = g.node(idx);
                (inside(p) && in_window(&p)).then(|| (morton_key(&p, lo, hi), l, p))
            })
            .collect();
        drop(lin);
        // The body's order: by key, ties by grid index (the body sorts its grid-ordered nodes by
        // key with a stable sort).
        nodes.par_sort_unstable_by_key(|e| (e.0, e.1));
        nodes
    }

    /// Build the part of the random lattice [`crate::lattice::Lattice::random`] would build
    /// whose own nodes are those with their key in `keys`, sampling the nodes within `margin`
    /// (m) of the keys' blocks. A margin of four spacings suffices for the jittered grid; a
    /// narrower one is refused with the reason.
    pub fn part(&self, keys: Range<u64>, margin: Real) -> Result<Part> {
        let amp = self.amplitude(margin)?;
        if keys.is_empty() {
            // A process that owns no nodes (more processes than the body has chunks).
            return Ok(Part::empty(0));
        }
        let (dim, a, h, inside) = (self.dim, self.a, self.h, self.inside);
        let (lo, hi) = self.flat_box();
        let nodes = self.window(amp, keys.clone(), margin);
        let boxes = key_boxes(keys.clone(), dim, lo, hi, margin);
        let pts: Vec<[Real; 3]> = nodes.iter().map(|e| e.2).collect();
        let n = pts.len();
        let first = nodes.partition_point(|e| e.0 < keys.start);
        let end = nodes.partition_point(|e| e.0 < keys.end);
        let own = |i: u32| (first..end).contains(&(i as usize));
        let pad = 1e-9 * a;
        let check = |all: &[[Real; 3]], v: &[u32]| -> Result<()> {
            if !v.iter().any(|&i| own(i)) {
                return Ok(());
            }
            let (c, r) = match *v {
                [a, b, c] => delaunay::circumsphere(all, &ascending([a, b, c]).0),
                [a, b, c, d] => delaunay::circumsphere(all, &ascending([a, b, c, d]).0),
                _ => unreachable!("simplices have 3 or 4 vertices"),
            };
            let (bl, bu) = ball_in_box(c, r, lo, hi, dim);
            let held = boxes
                .iter()
                .any(|(l, u)| (0..dim).all(|k| bl[k] - pad >= l[k] && bu[k] + pad <= u[k]));
            if held {
                Ok(())
            } else {
                Err(Error::InvalidInput {
                    what: "random lattice part",
                    why: format!(
                        "a margin of {margin} m is too narrow: a simplex around an own node has \
                     its circumball (centre {c:?} m, radius {r:e} m) reach beyond it; give a \
                     wider margin"
                    ),
                })
            }
        };
        let never = |_: u32, _: u32| false;
        let kept = if dim == 2 {
            let mesh = delaunay::triangulate_checked::<3>(&pts, lo, hi, |p, v| check(p, v))?;
            let mesh = around_own(mesh, &own);
            simplices::<3>(&pts, &mesh, a, inside, &never)?
        } else {
            let mesh = delaunay::triangulate_checked::<4>(&pts, lo, hi, |p, v| check(p, v))?;
            let mesh = around_own(mesh, &own);
            simplices::<4>(&pts, &mesh, a, inside, &never)?
        };
        let thickness = if dim == 2 { h } else { 1.0 };
        let (node_vol, edges, surface) = shares(&pts, &kept, thickness);
        drop(kept);
        // The own nodes the body keeps (those with a simplex), and every node an own spring reaches.
        let mut held = vec![false; n];
        for (i, v) in node_vol.iter().enumerate().take(end).skip(first) {
            held[i] = *v > 0.0;
        }
        let springs: Vec<([u32; 2], Real)> = edges
            .into_iter()
            .filter(|(e, _)| own(e[0]) || own(e[1]))
            .collect();
        for (e, _) in &springs {
            held[e[0] as usize] = true;
            held[e[1] as usize] = true;
        }
        let mut new_index = vec![u32::MAX; n];
        let mut part = Part::empty(n);
        let per = thickness;
        part.own.start = held[..first].iter().filter(|&&x| x).count();
        for i in 0..n {
            if !held[i] {
                continue;
            }
            new_index[i] = part.pos.len() as u32;
            part.pos.push(pts[i]);
            part.key.push(nodes[i].0);
            part.grid.push(nodes[i].1);
            if own(i as u32) {
                part.volume.push(node_vol[i]);
                part.surface.push(surface[i].map(|c| c * per));
            }
        }
        part.own.end = part.own.start + part.volume.len();
        part.springs = springs
            .into_iter()
            .map(|(e, v)| ([new_index[e[0] as usize], new_index[e[1] as usize]], v))
            .collect();
        Ok(part)
    }
}

/// The mesh's simplices with an own vertex, their neighbours among them (others become
/// `NONE`: a facet through an own node lies between two such simplices or on the hull, so the
/// facets this marks as the hull's have no own node and give an own node nothing).
fn around_own<const N: usize>(
    mesh: delaunay::Mesh<N>,
    own: &dyn Fn(u32) -> bool,
) -> delaunay::Mesh<N> {
    const NONE: u32 = u32::MAX;
    let mut new_id = vec![NONE; mesh.simplices.len()];
    let mut simplices = Vec::new();
    for (s, v) in mesh.simplices.iter().enumerate() {
        if v.iter().any(|&i| own(i)) {
            new_id[s] = simplices.len() as u32;
            simplices.push(*v);
        }
    }
    let nbr = mesh
        .nbr
        .iter()
        .enumerate()
        .filter(|&(s, _)| new_id[s] != NONE)
        .map(|(_, row)| row.map(|t| if t == NONE { NONE } else { new_id[t as usize] }))
        .collect();
    delaunay::Mesh { simplices, nbr }
}

/// The bounds of the part of the ball `(c, r)` inside the box `[lo, hi]`, axis by axis: where
/// the centre lies outside the box along other axes, by `d_b`, the ball's points inside it are
/// within `sqrt(r^2 - sum d_b^2)` of the centre along this one (a thin cap for the flat hull
/// simplices whose centres lie far outside).
fn ball_in_box(
    c: [Real; 3],
    r: Real,
    lo: [Real; 3],
    hi: [Real; 3],
    dim: usize,
) -> ([Real; 3], [Real; 3]) {
    let out: Vec<Real> = (0..dim)
        .map(|k| (lo[k] - c[k]).max(c[k] - hi[k]).max(0.0))
        .collect();
    let mut bl = lo;
    let mut bu = hi;
    for k in 0..dim {
        let others: Real = (0..dim).filter(|&b| b != k).map(|b| out[b] * out[b]).sum();
        let rk = (r * r - others).max(0.0).sqrt();
        bl[k] = (c[k] - rk).max(lo[k]);
        bu[k] = (c[k] + rk).min(hi[k]);
    }
    (bl, bu)
}

/// The boxes (m) of the aligned Morton blocks that make up the key range, widened by
/// `margin`. A block is a run of keys that share all bits above its `b` lowest; its points'
/// quantised coordinates share all bits above the block's share of `b` on each axis.
fn key_boxes(
    keys: Range<u64>,
    dim: usize,
    lo: [Real; 3],
    hi: [Real; 3],
    margin: Real,
) -> Vec<([Real; 3], [Real; 3])> {
    const M: Real = 2_097_151.0;
    let mut out = Vec::new();
    let (mut k, end) = (keys.start, keys.end.min(KEY_END));
    while k < end {
        let mut b = k.trailing_zeros().min(63);
        while b > 0 && end - k < 1u64 << b {
            b -= 1;
        }
        // De-interleave: bit t of a key is bit t / 3 of axis 2 - t % 3 (x the highest).
        let mut q = [0u64; 3];
        let mut e = [0u32; 3];
        for t in 0..63 {
            let axis = 2 - t % 3;
            q[axis] |= ((k >> t) & 1) << (t / 3);
            if (t as u32) < b {
                e[axis] += 1;
            }
        }
        k += 1u64 << b;
        // A plate's nodes all have z = 0, so a block above it holds none of them.
        if dim == 2 && q[2] != 0 {
            continue;
        }
        let mut l = [0.0; 3];
        let mut u = [0.0; 3];
        for c in 0..3 {
            let span = (hi[c] - lo[c]).max(1e-300);
            let q0 = (q[c] >> e[c] << e[c]) as Real;
            let q1 = q0 + (1u64 << e[c]) as Real;
            l[c] = lo[c] + q0 / M * span - margin;
            u[c] = lo[c] + q1 / M * span + margin;
        }
        out.push((l, u));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_blocks_cover_their_range_exactly() {
        // Every point whose key is in the range lies in one of the (unwidened) blocks, and
        // no point outside the range does.
        let (lo, hi) = ([0.0; 3], [1.0, 2.0, 3.0]);
        let mut rng = crate::random::rng::Rng::new(3);
        let pts: Vec<[Real; 3]> = (0..20_000)
            .map(|_| [rng.uniform(), 2.0 * rng.uniform(), 3.0 * rng.uniform()])
            .collect();
        let mut keys: Vec<u64> = pts.iter().map(|p| key(*p, lo, hi)).collect();
        keys.sort_unstable();
        for (a, b) in [(3000, 9000), (0, 7), (123, 19_999)] {
            let range = keys[a]..keys[b];
            let boxes = key_boxes(range.clone(), 3, lo, hi, 0.0);
            for p in &pts {
                let k = key(*p, lo, hi);
                let inb = boxes
                    .iter()
                    .any(|(l, u)| (0..3).all(|c| p[c] >= l[c] - 1e-12 && p[c] <= u[c] + 1e-12));
                if range.contains(&k) {
                    assert!(inb, "{p:?} (key {k}) is in no block of {range:?}");
                }
            }
            // The blocks' volumes add up to the range's share of the box, to quantisation.
            let vol: Real = boxes
                .iter()
                .map(|(l, u)| (0..3).map(|c| u[c] - l[c]).product::<Real>())
                .sum();
            // Each key stands for a cell of (span / (2^21 - 1))^3.
            let share = (range.end - range.start) as Real * 6.0 / 2_097_151f64.powi(3);
            assert!((vol - share).abs() <= 1e-12 * 6.0, "{vol} against {share}");
        }
    }

    /// The whole body's nodes (positions, keys), volumes, boundary shares and springs
    /// (global ends, volume).
    #[allow(clippy::type_complexity)]
    fn whole(
        dim: usize,
        hi: [Real; 3],
        a: Real,
        spec: RandomSpec,
        inside: &(dyn Fn([Real; 3]) -> bool + Sync),
    ) -> (
        Vec<[Real; 3]>,
        Vec<Real>,
        Vec<[Real; 3]>,
        Vec<([u32; 2], Real)>,
    ) {
        let l = crate::lattice::Lattice::random(dim, [0.0; 3], hi, a, 0.01, spec, inside).unwrap();
        let cells = l.cells.as_ref().unwrap();
        let pos = (0..l.pos.len()).map(|i| l.pos.get(i).into()).collect();
        let springs = l
            .bonds
            .ends
            .iter()
            .zip(&cells.spring)
            .map(|(e, v)| (*e, *v))
            .collect();
        (pos, cells.node.clone(), cells.surface.clone(), springs)
    }

    #[test]
    fn parts_built_alone_have_the_bits_of_the_whole_body() {
        // A notched block (3D) and a notched plate (2D), cut into four key ranges at the
        // quartiles of the body's nodes and into uneven ranges; each part built alone.
        // The calibrated amplitude, and the largest (neighbours may meet).
        for (dim, hi, amplitude) in [
            (3, [6.0, 5.0, 4.0], 0.6),
            (2, [20.0, 12.0, 0.0], 0.6),
            (3, [6.0, 5.0, 4.0], 1.0),
            (2, [20.0, 12.0, 0.0], 1.0),
        ] {
            let spec = RandomSpec {
                sampler: Sampler::Jitter { amplitude },
                seed: 5,
            };
            let a = 0.5;
            let notch = move |p: [Real; 3]| !(p[0] < 2.5 && (p[1] - 2.4).abs() < 0.3);
            let (pos, node, surface, springs) = whole(dim, hi, a, spec, &notch);
            let n = pos.len();
            let keys: Vec<u64> = pos.iter().map(|p| key(*p, [0.0; 3], hi)).collect();
            assert!(
                keys.windows(2).all(|w| w[0] <= w[1]),
                "the body is in key order"
            );
            let index: std::collections::HashMap<[u64; 3], usize> = pos
                .iter()
                .enumerate()
                .map(|(i, p)| (p.map(|c| c.to_bits()), i))
                .collect();
            for cuts in [vec![n / 4, n / 2, 3 * n / 4], vec![1, n / 3, n - 2]] {
                let mut bounds = vec![0u64];
                bounds.extend(cuts.iter().map(|&c| keys[c]));
                bounds.push(KEY_END);
                let mut covered = 0;
                let body = Sampling {
                    dim,
                    lo: [0.0; 3],
                    hi,
                    a,
                    h: 0.01,
                    spec,
                    inside: &notch,
                };
                for w in bounds.windows(2) {
                    let p = body.part(w[0]..w[1], 4.0 * a).unwrap();
                    let g0 = keys.partition_point(|&k| k < w[0]);
                    let g1 = keys.partition_point(|&k| k < w[1]);
                    assert_eq!(p.own.len(), g1 - g0, "dim {dim}, keys {w:?}");
                    // Sampled without triangulating: the same own nodes' keys.
                    let sampled = body.own_keys(w[0]..w[1]);
                    assert_eq!(sampled.unwrap(), keys[g0..g1], "dim {dim}, keys {w:?}");
                    covered += p.own.len();
                    // Own nodes: the body's, bit for bit, with their volumes and shares.
                    for (k, i) in p.own.clone().enumerate() {
                        let g = g0 + k;
                        assert_eq!(p.pos[i].map(|c| c.to_bits()), pos[g].map(|c| c.to_bits()));
                        assert_eq!(p.volume[k].to_bits(), node[g].to_bits(), "V_n of {g}");
                        assert_eq!(
                            p.surface[k].map(|c| c.to_bits()),
                            surface[g].map(|c| c.to_bits()),
                            "surface share of {g}"
                        );
                    }
                    // The part's nodes are in the body's order, and its springs are the
                    // body's springs with an own end, in order, with their volumes' bits.
                    let global: Vec<usize> = p
                        .pos
                        .iter()
                        .map(|q| index[&q.map(|c| c.to_bits())])
                        .collect();
                    assert!(global.windows(2).all(|w| w[0] < w[1]));
                    let mine: Vec<([u32; 2], u64)> = p
                        .springs
                        .iter()
                        .map(|(e, v)| (e.map(|i| global[i as usize] as u32), v.to_bits()))
                        .collect();
                    let want: Vec<([u32; 2], u64)> = springs
                        .iter()
                        .filter(|(e, _)| e.iter().any(|&g| (g0..g1).contains(&(g as usize))))
                        .map(|(e, v)| (*e, v.to_bits()))
                        .collect();
                    assert_eq!(mine, want, "dim {dim}, keys {w:?}");
                    assert!(p.sampled < n || w[0] == 0 && w[1] == KEY_END);
                }
                assert_eq!(covered, n);
            }
        }
    }

    #[test]
    fn a_part_refuses_a_narrow_margin_and_a_sampler_it_cannot_split() {
        let hi = [6.0, 5.0, 4.0];
        let jitter = RandomSpec {
            sampler: Sampler::Jitter { amplitude: 0.6 },
            seed: 5,
        };
        let keys = 1u64 << 60..3u64 << 60;
        let mut body = Sampling {
            dim: 3,
            lo: [0.0; 3],
            hi,
            a: 0.5,
            h: 1.0,
            spec: jitter,
            inside: &|_| true,
        };
        let e = body.part(keys.clone(), 0.05).unwrap_err().to_string();
        assert!(
            e.contains("too narrow") && e.contains("wider margin"),
            "{e}"
        );
        let poisson = RandomSpec {
            sampler: Sampler::Poisson,
            seed: 5,
        };
        body.spec = poisson;
        let e = body.part(keys, 2.0).unwrap_err().to_string();
        assert!(e.contains("jittered grid") && e.contains("poisson"), "{e}");
    }
}
