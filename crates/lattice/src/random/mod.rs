//! Random lattices: the paper's "random MSM". Nodes are scattered with a given mean spacing `a`
//! (blue noise or a jittered grid, [`sample`]), springs are the edges of their Delaunay
//! triangulation (2D) or tetrahedralisation (3D, [`delaunay`]), and each spring's stiffness comes
//! from the volume it stands for.
//!
//! # Spring stiffness from the volume a spring stands for
//!
//! Under a uniform small strain `eps` a central spring of rest length `L` along the unit vector
//! `n` stretches by `dL = L n.eps.n` and stores `1/2 k L^2 (n.eps.n)^2`. The stored energy per
//! unit volume of a network whose springs stand for volumes `V_s` is therefore
//!
//! ```text
//! W = 1/(2V) sum_s k_s L_s^2 (n_s.eps.n_s)^2,   C_ijkl = 1/V sum_s k_s L_s^2 n_i n_j n_k n_l.
//! ```
//!
//! Choosing `k_s = kappa V_s / L_s^2` (Kot, Nagahashi and Szymczak 2014 assign spring stiffness
//! by the volume a spring represents; this is that choice for central springs) makes every spring
//! contribute `kappa V_s n n n n`: when the directions are isotropic on average, `<n_i n_j n_k
//! n_l> = (d_ij d_kl + d_ik d_jl + d_il d_jk)/(d (d + 2))`, so with `sum_s V_s = V`
//!
//! ```text
//! lambda = mu = kappa / (d (d + 2)):  3D mu = kappa/15, E = kappa/6;  2D mu = kappa/8, E_2D = kappa/3.
//! ```
//!
//! This is the Cauchy solid (nu = 1/4 in 3D, 1/3 in 2D), the plain random model of the paper.
//! `V_s` is the measure of the simplices around the spring shared evenly among their edges (a
//! tetrahedron gives 1/6 of its volume to each of its 6 edges, a triangle 1/3 of its area to each
//! of its 3), so `sum_s V_s` is exactly the volume of the body; a node's mass is the density times
//! its share `V_n` (1/(d+1) of each simplex around it). On the hexagonal lattice this choice gives
//! back `k` for every spring (each edge gets `2 (sqrt(3)/4 a^2)/3`), so the formulas below match
//! the regular ones.
//!
//! # Dispersion on a random lattice (`docs/model.md` applies unchanged)
//!
//! A node's pool under uniform strain is `Pi_n = A_n : eps` with `A_n = sum_t k_t L_t^2 n_t n_t`
//! and `S_n = tr A_n`. If every star were isotropic (`A_n = S_n/d I`) the dispersive energy
//! `q/2 sum_n Pi_n^2 / S_n` would add `B = 2 q kappa / d^2` to lambda only:
//!
//! ```text
//! 3D: B/mu = 10 q / 3,  nu = (1 + 10q/3) / (2 (2 + 10q/3)),  E = kappa (1 + 2q) / (6 + 10q);
//! 2D: B/mu = 4 q,       nu_2D = (1 + 4q) / (3 + 4q),        E_2D = kappa (1 + 2q) / (3 + 4q),
//! ```
//!
//! the same relations as Ladd's and the hexagonal lattice. A random star is isotropic only on
//! average; its deviatoric part `D_n` adds `q D_n (x) D_n / S_n` (a shear stiffening growing
//! with q), and a random network also relaxes non-affinely under load (a softening, mostly of
//! shear). Both are calibrated numerically (`hooke_core::random::calibration`); the residual error is stated there.
//!
//! # Boundaries
//!
//! Nodes are sampled in the shape's bounding box with its faces, edges and corners sampled first
//! ([`sample`]), then kept if the shape contains them. The Delaunay triangulation spans the
//! convex hull of the kept nodes, which bridges concave parts of the shape (notches, holes): a
//! simplex is dropped when its centroid or a point at 1/4, 1/2 or 3/4 of one of its edges lies
//! outside the shape. Degenerate simplices (zero measure to round-off) are dropped, and nodes left
//! without a spring are removed.

pub mod delaunay;
pub mod part;
pub mod rng;
pub mod sample;

use crate::error::{Error, Result};
use crate::lattice::{Bonds, Cells, Lattice, LatticeKind};
use crate::math::{Coords, Real};
use rayon::prelude::*;
pub use sample::{Curved, Sampler};

/// How to scatter the nodes of a random lattice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RandomSpec {
    pub sampler: Sampler,
    pub seed: u64,
}

impl Default for RandomSpec {
    fn default() -> Self {
        RandomSpec {
            sampler: Sampler::Poisson,
            seed: 1,
        }
    }
}

impl Lattice {
    /// A random lattice of mean spacing `a` filling the part of the box `[lo, hi]` where
    /// `inside` holds. `dim` is 2 or 3; 2D lattices are plates of thickness `h` in the x-y plane
    /// (give `lo[2] = hi[2] = 0`).
    pub fn random(
        dim: usize,
        lo: [Real; 3],
        hi: [Real; 3],
        a: Real,
        h: Real,
        spec: RandomSpec,
        inside: &(dyn Fn([Real; 3]) -> bool + Sync),
    ) -> Result<Lattice> {
        Self::random_conforming(dim, lo, hi, a, h, spec, inside, &[])
    }

    /// [`Lattice::random`] with nodes on the curved pieces of the body's boundary (see
    /// [`sample::Curved`]), so that a cylinder or a sphere has its outer nodes on its surface
    /// as a box has them on its faces: its springs and nodes then stand for the volume up to
    /// the surface, not to a hull inside it.
    #[allow(clippy::too_many_arguments)]
    pub fn random_conforming(
        dim: usize,
        lo: [Real; 3],
        hi: [Real; 3],
        a: Real,
        h: Real,
        spec: RandomSpec,
        inside: &(dyn Fn([Real; 3]) -> bool + Sync),
        curved: &[sample::Curved],
    ) -> Result<Lattice> {
        check_box(dim, lo, hi, a, spec)?;
        let (lo, hi) = if dim == 2 {
            ([lo[0], lo[1], 0.0], [hi[0], hi[1], 0.0])
        } else {
            (lo, hi)
        };
        let (mut pts, on_curved) =
            sample::sample_conforming(dim, lo, hi, a, spec.sampler, spec.seed, inside, curved);
        let mut curved_node = vec![false; pts.len()];
        curved_node[..on_curved].fill(true);
        // Number the nodes along a Morton curve: neighbours in space are near in memory, which
        // the CSR kernel's gathers need (sampling order scatters them: 2.5x slower steps).
        morton_sort(&mut pts, &mut curved_node, lo, hi);
        let r = sample::poisson_radius(dim, a);
        // A simplex edge between two neighbours on a curved surface is a chord: on a concave
        // surface (a hole) it runs just outside the body, by a / 8 R of its length, and must not
        // drop the simplex for that.
        let chord = |i: u32, j: u32| {
            let (p, q) = (pts[i as usize], pts[j as usize]);
            curved_node[i as usize]
                && curved_node[j as usize]
                && (0..3).map(|c| (p[c] - q[c]).powi(2)).sum::<Real>() < 4.0 * r * r
        };
        let (kind, thickness) = if dim == 2 {
            (LatticeKind::Random2d, h)
        } else {
            (LatticeKind::Random3d, 1.0)
        };
        let kept = if dim == 2 {
            let mesh = delaunay::triangulate_in::<3>(&pts, lo, hi)?;
            simplices::<3>(&pts, &mesh, a, inside, &chord)?
        } else {
            let mesh = delaunay::triangulate_in::<4>(&pts, lo, hi)?;
            simplices::<4>(&pts, &mesh, a, inside, &chord)?
        };
        let (node_vol, merged, surface) = shares(&pts, &kept, thickness);
        drop(kept);
        // Drop nodes without springs and renumber.
        let mut new_index = vec![u32::MAX; pts.len()];
        let (mut x, mut y, mut z) = (Vec::new(), Vec::new(), Vec::new());
        for (i, p) in pts.iter().enumerate() {
            if node_vol[i] > 0.0 {
                new_index[i] = x.len() as u32;
                x.push(p[0]);
                y.push(p[1]);
                z.push(p[2]);
            }
        }
        let pos = Coords::from_components(&x, &y, &z);
        if pos.is_empty() {
            return Err(Error::InvalidInput {
                what: "geometry",
                why: "the shape holds no simplex of the random lattice: make it larger or the \
                      spacing smaller"
                    .into(),
            });
        }
        let node: Vec<Real> = node_vol.iter().cloned().filter(|&v| v > 0.0).collect();
        let per = if dim == 2 { thickness } else { 1.0 };
        let surface: Vec<[Real; 3]> = (0..pts.len())
            .filter(|&i| node_vol[i] > 0.0)
            .map(|i| surface[i].map(|c| c * per))
            .collect();
        let pairs: Vec<[u32; 2]> = merged
            .iter()
            .map(|(e, _)| [new_index[e[0] as usize], new_index[e[1] as usize]])
            .collect();
        let spring: Vec<Real> = merged.iter().map(|m| m.1).collect();
        let bonds = Bonds::from_pairs(pos.len(), pairs, &pos, [0.0; 3])?;
        debug_assert_eq!(bonds.len(), spring.len());
        // Per chunk of nodes, chunks in order: the sum that ranks holding parts of the body
        // form alike (`team::parts`).
        let total: Real = node
            .chunks(crate::CHUNK)
            .map(|c| c.iter().sum::<Real>())
            .sum();
        let n = pos.len();
        Ok(Lattice {
            kind,
            spacing: a,
            pos,
            cell_volume: total / n as Real,
            thickness,
            period: [0.0; 3],
            grid: None,
            bonds: bonds.into(),
            cells: Some(Cells {
                node,
                spring,
                surface,
                sampler: spec.sampler,
            }),
        })
    }
}

/// Refuse a spacing, box or jitter amplitude a random lattice cannot be built with.
fn check_box(dim: usize, lo: [Real; 3], hi: [Real; 3], a: Real, spec: RandomSpec) -> Result<()> {
    if !(a.is_finite() && a > 0.0) {
        return Err(Error::InvalidInput {
            what: "lattice spacing",
            why: format!("a = {a} m; give a positive spacing"),
        });
    }
    for c in 0..dim {
        if !(lo[c].is_finite() && hi[c].is_finite() && hi[c] - lo[c] >= a) {
            return Err(Error::InvalidInput {
                what: "random lattice",
                why: format!(
                    "the box spans {} m along axis {c}, less than the spacing {a} m: make it \
                     larger or the spacing smaller",
                    hi[c] - lo[c]
                ),
            });
        }
    }
    if let Sampler::Jitter { amplitude } = spec.sampler {
        if !(0.0..=1.0).contains(&amplitude) {
            return Err(Error::OutOfRange {
                what: "jitter amplitude",
                value: amplitude,
                why: "give a fraction of the spacing in [0, 1]; 1 lets neighbours meet".into(),
            });
        }
    }
    Ok(())
}

/// The simplices a random lattice keeps, in a canonical form: each simplex's vertices ascending
/// (the nodes' Morton order), each measure computed from the vertices in that order, and which
/// facets lie on the body's boundary. Everything derived from them is
/// then summed in an order that depends only on the nodes, not on how the triangulation was
/// built: a part of a body triangulated alone gives its nodes the bits the whole body gives
/// them (`random::part`).
pub(crate) struct Kept {
    /// Vertices per simplex (3 or 4).
    pub nodes_per: usize,
    /// `nodes_per` vertices per simplex, ascending within each ([`shares`] visits a node's
    /// simplices in the ascending order of their vertex lists).
    pub verts: Vec<u32>,
    pub measures: Vec<Real>,
    /// Bit `k` set: the facet opposite the simplex's `k`-th vertex is on the boundary.
    pub facets: Vec<u8>,
}

/// Node and edge shares of each simplex's measure (times `thickness`): a node gets
/// `1/nodes_per` of every simplex around it, an edge `1/edges_per` of every simplex along it.
/// Returns the nodes' volumes, the edges `(i < j)` sorted by their ends with their volumes, and
/// each node's share of the boundary: the sum over the boundary facets around it of
/// `area / d` times the outward unit normal (the facet's length in 2D, to be multiplied by the
/// thickness).
///
/// Node by node through the simplices around it (ascending, so every sum is formed in one fixed
/// order) rather than by sorting the list of every simplex's edges: that list has six entries
/// per tetrahedron, about 40 per node, and sorting it was a tenth of a random body's set-up
/// and most of its peak memory.
#[allow(clippy::type_complexity)]
fn shares(
    pts: &[[Real; 3]],
    kept: &Kept,
    thickness: Real,
) -> (Vec<Real>, Vec<([u32; 2], Real)>, Vec<[Real; 3]>) {
    let n = pts.len();
    let Kept {
        nodes_per,
        ref verts,
        ref measures,
        ref facets,
    } = *kept;
    let edges_per = nodes_per * (nodes_per - 1) / 2;
    let mut offsets = vec![0usize; n + 1];
    for &v in verts {
        offsets[v as usize + 1] += 1;
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut around = vec![0u32; verts.len()];
    let mut fill = offsets.clone();
    for (s, v) in verts.chunks(nodes_per).enumerate() {
        for &x in v {
            around[fill[x as usize]] = s as u32;
            fill[x as usize] += 1;
        }
    }
    drop(fill);
    // Node by node, each node's sums in the order of its simplices: in parallel over blocks of
    // nodes whose results are joined in node order, so the same bits for any thread count.
    const BLOCK: usize = 4096;
    const AHEAD: usize = 4;
    type Shares = (Vec<Real>, Vec<([u32; 2], Real)>, Vec<[Real; 3]>);
    let blocks: Vec<Shares> = (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .map(|b| {
            let nodes = b * BLOCK..((b + 1) * BLOCK).min(n);
            let mut node_vol = vec![0.0; nodes.len()];
            let mut surface = vec![[0.0; 3]; nodes.len()];
            let mut edges = Vec::new();
            let mut row: Vec<(u32, Real)> = Vec::new();
            let mut mine: Vec<u32> = Vec::new();
            for i in nodes.clone() {
                // The simplices around a node are scattered through the list: load those of a
                // node a few ahead while this one's are summed.
                if let Some(ahead) = offsets.get(i + AHEAD + 1) {
                    for &s in &around[offsets[i + AHEAD]..*ahead] {
                        hooke_sys::prefetch(&verts[s as usize * nodes_per]);
                        hooke_sys::prefetch(&measures[s as usize]);
                    }
                }
                row.clear();
                // The node's simplices in the order of their vertex lists, which does not
                // depend on the order the triangulation made them in.
                mine.clear();
                mine.extend_from_slice(&around[offsets[i]..offsets[i + 1]]);
                let of = |s: u32| &verts[s as usize * nodes_per..(s as usize + 1) * nodes_per];
                mine.sort_unstable_by(|&s, &t| of(s).cmp(of(t)));
                let vi = &mut node_vol[i - nodes.start];
                let si = &mut surface[i - nodes.start];
                for &s in &mine {
                    let vol = measures[s as usize] * thickness;
                    *vi += vol / nodes_per as Real;
                    let v = &verts[s as usize * nodes_per..(s as usize + 1) * nodes_per];
                    for &j in v.iter().filter(|&&j| j > i as u32) {
                        match row.iter_mut().find(|e| e.0 == j) {
                            Some(e) => e.1 += vol / edges_per as Real,
                            None => row.push((j, vol / edges_per as Real)),
                        }
                    }
                    let mask = facets[s as usize];
                    for k in (0..nodes_per).filter(|&k| mask >> k & 1 == 1 && v[k] != i as u32) {
                        let n = facet_normal(pts, v, k);
                        let share = 1.0 / (nodes_per - 1) as Real;
                        for c in 0..3 {
                            si[c] += share * n[c];
                        }
                    }
                }
                row.sort_unstable_by_key(|e| e.0);
                edges.extend(row.iter().map(|&(j, v)| ([i as u32, j], v)));
            }
            (node_vol, edges, surface)
        })
        .collect();
    let mut node_vol = Vec::with_capacity(n);
    let mut surface = Vec::with_capacity(n);
    let mut edges: Vec<([u32; 2], Real)> = Vec::with_capacity(verts.len() * (nodes_per - 1) / 2);
    for (v, e, f) in blocks {
        node_vol.extend(v);
        edges.extend(e);
        surface.extend(f);
    }
    (node_vol, edges, surface)
}

/// The area vector of a simplex's facet opposite its `k`-th vertex, pointing away from that
/// vertex: half the cross product in 3D, the edge turned by a right angle in 2D (a length, to
/// be multiplied by the thickness). From the facet's vertices in the simplex's (ascending)
/// order, so the same bits from every simplex and every part that holds the facet.
fn facet_normal(pts: &[[Real; 3]], v: &[u32], k: usize) -> [Real; 3] {
    let at = |i: u32| pts[i as usize];
    let mut f = [[0.0; 3]; 3];
    let mut m = 0;
    for (x, &i) in v.iter().enumerate() {
        if x != k {
            f[m] = at(i);
            m += 1;
        }
    }
    let sub = |p: [Real; 3], q: [Real; 3]| [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
    let mut n = if v.len() == 3 {
        let e = sub(f[1], f[0]);
        [e[1], -e[0], 0.0]
    } else {
        let (e1, e2) = (sub(f[1], f[0]), sub(f[2], f[0]));
        [
            0.5 * (e1[1] * e2[2] - e1[2] * e2[1]),
            0.5 * (e1[2] * e2[0] - e1[0] * e2[2]),
            0.5 * (e1[0] * e2[1] - e1[1] * e2[0]),
        ]
    };
    let to_k = sub(at(v[k]), f[0]);
    if n[0] * to_k[0] + n[1] * to_k[1] + n[2] * to_k[2] > 0.0 {
        n = [-n[0], -n[1], -n[2]];
    }
    n
}

/// Sort points, and a flag with each, by the Morton (Z-order) key of their coordinates
/// quantised in the box.
fn morton_sort(pts: &mut [[Real; 3]], flag: &mut [bool], lo: [Real; 3], hi: [Real; 3]) {
    if !flag.iter().any(|&f| f) {
        pts.sort_by_cached_key(|p| delaunay::morton_key(p, lo, hi));
        return;
    }
    let mut both: Vec<([Real; 3], bool)> = pts.iter().cloned().zip(flag.iter().cloned()).collect();
    both.sort_by_cached_key(|p| delaunay::morton_key(&p.0, lo, hi));
    for (k, (p, f)) in both.into_iter().enumerate() {
        pts[k] = p;
        flag[k] = f;
    }
}

/// Drop the simplices of `mesh` outside the shape and put the rest in canonical form
/// ([`Kept`]). Degenerate simplices (measure below `1e-12 a^d`) are dropped too.
fn simplices<const N: usize>(
    pts: &[[Real; 3]],
    mesh: &delaunay::Mesh<N>,
    a: Real,
    inside: &(dyn Fn([Real; 3]) -> bool + Sync),
    chord: &(dyn Fn(u32, u32) -> bool + Sync),
) -> Result<Kept> {
    let tiny = 1e-12 * a.powi(N as i32 - 1);
    let at = |i: u32| pts[i as usize];
    // Each simplex's measure, or NaN for one the shape drops: a simplex is judged on its own,
    // so in parallel. Judged from its vertices in ascending order, so that it is judged alike
    // wherever it was built.
    let kept: Vec<Real> = mesh
        .simplices
        .par_iter()
        .with_min_len(1 << 14)
        .map(|v| {
            let (v, even) = ascending(*v);
            let m = delaunay::measure(pts, &v);
            let m = if even { m } else { -m };
            if m <= 0.0 {
                // Exact orientation: the triangulation gives none of these (delaunay.rs).
                return Real::NEG_INFINITY;
            }
            if m <= tiny {
                return Real::NAN;
            }
            let mut c = [0.0; 3];
            for &i in &v {
                for k in 0..3 {
                    c[k] += at(i)[k] / N as Real;
                }
            }
            let mut ok = inside(c);
            for x in 0..N {
                for y in x + 1..N {
                    if chord(v[x], v[y]) {
                        continue;
                    }
                    let (p, q) = (at(v[x]), at(v[y]));
                    for t in [0.25, 0.5, 0.75] {
                        ok = ok
                            && inside([
                                p[0] + t * (q[0] - p[0]),
                                p[1] + t * (q[1] - p[1]),
                                p[2] + t * (q[2] - p[2]),
                            ]);
                    }
                }
            }
            if ok {
                m
            } else {
                Real::NAN
            }
        })
        .collect();
    if kept.contains(&Real::NEG_INFINITY) {
        return Err(Error::InvalidInput {
            what: "random lattice",
            why: "the Delaunay triangulation of the nodes holds an inverted simplex, which it \
                  should never do: please report the case (a different random seed may avoid it)"
                .into(),
        });
    }
    let keep = |s: usize| !kept[s].is_nan();
    let count = kept.iter().filter(|m| !m.is_nan()).count();
    let mut out = Kept {
        nodes_per: N,
        verts: Vec::with_capacity(count * N),
        measures: Vec::with_capacity(count),
        facets: Vec::with_capacity(count),
    };
    for (s, v) in mesh.simplices.iter().enumerate() {
        if !keep(s) {
            continue;
        }
        // The facet opposite v[k] is the one opposite the same vertex in ascending order.
        let (sorted, _) = ascending(*v);
        let mut mask = 0u8;
        for k in 0..N {
            let t = mesh.nbr[s][k];
            if t == u32::MAX || !keep(t as usize) {
                let at = sorted.iter().position(|&x| x == v[k]).expect("a vertex");
                mask |= 1 << at;
            }
        }
        out.verts.extend_from_slice(&sorted);
        out.measures.push(kept[s]);
        out.facets.push(mask);
    }
    Ok(out)
}

/// A simplex's vertices in ascending order, and whether that order is an even permutation of
/// the given one (the measure keeps its sign).
pub(crate) fn ascending<const N: usize>(mut v: [u32; N]) -> ([u32; N], bool) {
    let mut even = true;
    for i in 1..N {
        let mut j = i;
        while j > 0 && v[j - 1] > v[j] {
            v.swap(j - 1, j);
            even = !even;
            j -= 1;
        }
    }
    (v, even)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_are_those_of_the_sorted_edge_list() {
        // The node-by-node shares against the plain way: every simplex's edges listed, sorted
        // and merged. Same edges, the same node and edge volumes to round-off (the terms of a
        // sum in another order).
        let pts = sample::sample_box(
            3,
            [0.0; 3],
            [5.0, 4.0, 3.0],
            1.0,
            Sampler::Poisson,
            2,
            &|_| true,
        );
        let mesh = delaunay::triangulate::<4>(&pts).unwrap();
        let kept = simplices::<4>(&pts, &mesh, 1.0, &|_| true, &|_, _| false).unwrap();
        let measures = kept.measures.clone();
        let (node, edges, _) = shares(&pts, &kept, 1.0);
        let mesh = delaunay::Mesh::<4> {
            simplices: kept
                .verts
                .chunks(4)
                .map(|v| [v[0], v[1], v[2], v[3]])
                .collect(),
            nbr: Vec::new(),
        };
        let mut node_ref = vec![0.0; pts.len()];
        let mut list = Vec::new();
        for (s, v) in mesh.simplices.iter().enumerate() {
            for x in 0..4 {
                node_ref[v[x] as usize] += measures[s] / 4.0;
                for y in x + 1..4 {
                    list.push(([v[x].min(v[y]), v[x].max(v[y])], measures[s] / 6.0));
                }
            }
        }
        list.sort_by_key(|e| e.0);
        let mut merged: Vec<([u32; 2], Real)> = Vec::new();
        for (e, v) in list {
            match merged.last_mut() {
                Some(last) if last.0 == e => last.1 += v,
                _ => merged.push((e, v)),
            }
        }
        for (a, b) in node.iter().zip(&node_ref) {
            assert!((a - b).abs() <= 1e-14 * b, "{a} against {b}");
        }
        assert_eq!(edges.len(), merged.len());
        for (a, b) in edges.iter().zip(&merged) {
            assert_eq!(a.0, b.0);
            assert!((a.1 - b.1).abs() <= 1e-14 * b.1, "{a:?} against {b:?}");
        }
        let total: Real = measures.iter().sum();
        let spread: Real = edges.iter().map(|e| e.1).sum();
        assert!((spread - total).abs() <= 1e-12 * total);
    }
}
