//! Bodies of several materials: each node belongs to one phase, and a phase is a material's
//! constants on the whole lattice (its springs' stiffnesses, its nodes' masses, its dispersion
//! ratio), as [`Body::from_cells`] or a material's own set-up gives them.
//!
//! **The combination.** A node takes its phase's mass and dispersion ratio `q_n`. A spring
//! between two nodes of one phase takes that phase's stiffness. A spring between nodes of two
//! phases `a` and `b` is split at its midpoint, each half in its end's material: two springs in
//! series, `k = 2 k_a k_b / (k_a + k_b)` (the harmonic mean of the stiffnesses it would have in
//! each material). Under a strain normal to a bonded interface the two halves carry the same
//! tension, as the materials on each side carry the same traction, which is what makes a layered
//! body's stiffness across its layers the series (Reuss) average.
//!
//! **The law** (`docs/model.md`) is
//!
//! ```text
//! U   = 1/2 sum_s k_s dL_s^2 + 1/2 sum_n q_n Pi_n^2 / S_n
//! T_s = dU/d(dL_s) = k_s dL_s + k_s L_s (q_i p_i + q_j p_j)
//! ```
//!
//! symmetric and variational as the one-material law, and stable for every `q_n > -1/2` after
//! any pattern of broken springs: Cauchy-Schwarz bounds each node's term below by
//! `min(q_n, 0) sum_{t at n} k_t dL_t^2`, so the energy is at least
//! `1/2 sum_s k_s dL_s^2 (1 + min(q_i, 0) + min(q_j, 0)) >= 0`. The body carries the ratios in
//! [`Body::q_node`] and every solver reads them through the normalisers `S_n / q_n`.

use crate::body::{Body, Stiffnesses};
use crate::error::{Error, Result};
use crate::lattice::Lattice;
use crate::math::Real;

/// One material's constants on the whole lattice: what a body of that material alone would
/// have.
#[derive(Clone, Debug)]
pub struct Phase {
    /// Each spring's stiffness `k_s` (N/m) were both its ends of this material.
    pub k: Stiffnesses,
    /// Each node's mass (kg) were it of this material.
    pub mass: Vec<Real>,
    /// The material's dispersion ratio `q`.
    pub q: Real,
}

impl Phase {
    /// A one-material body's constants (its lattice dropped). Refused for an anisotropic body
    /// (its dispersion levers belong to one material's design, and a spring between two
    /// designs would need its own).
    pub fn of(body: Body) -> Result<Phase> {
        if body.lever.is_some() || body.q_node.is_some() {
            return Err(Error::InvalidInput {
                what: "a phase of a body of several materials",
                why: "an anisotropic material (dispersion levers) or a body already of several \
                      materials cannot be a phase yet: give an isotropic material"
                    .into(),
            });
        }
        Ok(Phase {
            k: body.k,
            mass: body.mass,
            q: body.q,
        })
    }
}

/// The stiffness of a spring whose halves are of stiffnesses `ka` and `kb` (each the whole
/// spring's in that material): two springs of half the length in series, `2 ka kb / (ka + kb)`;
/// `ka` itself where the two are equal (exactly, so a body of two identical phases has the
/// one-material body's stiffnesses).
pub fn series(ka: Real, kb: Real) -> Real {
    if ka == kb {
        ka
    } else {
        2.0 * ka * kb / (ka + kb)
    }
}

/// The body of `lattice` whose node `n` is of phase `phases[node_phase[n]]` (see the module's
/// docs). A body all of one phase is that phase's one-material body, bit for bit. Refused with
/// the reason where the counts do not match the lattice, or a node names no phase.
pub fn assemble(lattice: Lattice, phases: Vec<Phase>, node_phase: &[u8]) -> Result<Body> {
    let (n, springs) = (lattice.len(), lattice.bonds.len());
    if node_phase.len() != n {
        return Err(Error::InvalidInput {
            what: "the phase of each node",
            why: format!("{} phases given for {n} nodes", node_phase.len()),
        });
    }
    if let Some(i) = node_phase.iter().position(|&p| p as usize >= phases.len()) {
        return Err(Error::InvalidInput {
            what: "the phase of each node",
            why: format!(
                "node {i} is of phase {}, but there are {} phases",
                node_phase[i],
                phases.len()
            ),
        });
    }
    if let Some(p) = phases
        .iter()
        .position(|p| p.k.len() != springs || p.mass.len() != n)
    {
        return Err(Error::InvalidInput {
            what: "a phase of a body of several materials",
            why: format!(
                "phase {p} has {} stiffnesses and {} masses for {springs} springs and {n} nodes \
                 (build every phase on the same lattice)",
                phases[p].k.len(),
                phases[p].mass.len()
            ),
        });
    }
    let first = node_phase.first().copied().unwrap_or(0);
    if node_phase.iter().all(|&p| p == first) {
        let p = phases
            .into_iter()
            .nth(first as usize)
            .expect("checked above");
        return Ok(Body {
            lattice,
            k: p.k,
            q: p.q,
            mass: p.mass,
            lever: None,
            q_node: None,
            // (Read only for names and strengths: a body all of one phase steps as that
            // material's.)
            phase: (first != 0).then(|| node_phase.to_vec()),
        });
    }
    let k: Vec<Real> = (0..springs)
        .map(|b| {
            let [i, j] = lattice.bonds.ends[b].map(|v| node_phase[v as usize] as usize);
            series(phases[i].k[b], phases[j].k[b])
        })
        .collect();
    let mass = (0..n)
        .map(|i| phases[node_phase[i] as usize].mass[i])
        .collect();
    let q_node = node_phase.iter().map(|&p| phases[p as usize].q).collect();
    Body {
        lattice,
        k: k.into(),
        q: 0.0,
        mass,
        lever: None,
        q_node: None,
        phase: Some(node_phase.to_vec()),
    }
    .with_node_q(q_node)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::law;
    use crate::math::Coords;
    use crate::random::RandomSpec;
    use crate::state::State;

    fn random(dim: usize, seed: u64) -> Lattice {
        let hi = if dim == 2 {
            [7.0, 6.0, 0.0]
        } else {
            [4.0, 4.0, 3.0]
        };
        let spec = RandomSpec {
            seed,
            ..RandomSpec::default()
        };
        Lattice::random(dim, [0.0; 3], hi, 1.0, 1.0, spec, &|_| true).unwrap()
    }

    /// Three phases by x: an auxetic one (q < 0), a plain one (q = 0) and a strongly
    /// dispersive one, with different stiffnesses and densities.
    fn three_phases(lattice: Lattice) -> Body {
        let x = lattice.pos.x().to_vec();
        let hi = x.iter().cloned().fold(0.0, Real::max);
        let phase: Vec<u8> = x.iter().map(|&x| (3.0 * x / (hi + 1e-9)) as u8).collect();
        let ph = |k: Real, q: Real, m: Real| {
            Phase::of(Body::from_cells(lattice.clone(), k, q, m)).unwrap()
        };
        let phases = vec![ph(1.0, -0.4, 1.0), ph(10.0, 0.0, 2.5), ph(3.0, 2.0, 0.7)];
        assemble(lattice, phases, &phase).unwrap()
    }

    fn wavy(body: &Body, state: &mut State, amp: Real) {
        let pos = body.lattice.pos.clone();
        for c in 0..body.lattice.dim() {
            for (i, u) in state.u.comp_mut(c).iter_mut().enumerate() {
                let (x, y, z) = (pos.x()[i], pos.y()[i], pos.z()[i]);
                *u = amp * ((1.3 * x + c as Real).sin() * (0.7 * y).cos() + 0.3 * (0.9 * z).sin());
            }
        }
    }

    fn energy(body: &Body, state: &State, u: &Coords) -> Real {
        law::energy(body, u, state.springs(body), &state.norm).total()
    }

    /// The law of a body of three phases (q = -0.4, 0 and 2, stiffnesses 1:10:3), with broken
    /// springs, is the gradient of its energy: every force component at a sample of nodes
    /// matches a central difference of `U` to 1e-6 of the largest force, in 2D and 3D.
    #[test]
    fn a_body_of_several_materials_is_the_gradient_of_its_energy() {
        for dim in [2, 3] {
            let body = three_phases(random(dim, 7));
            assert!(body.q_node.is_some());
            let mut state = State::new(&body);
            for b in (0..body.springs()).step_by(9) {
                state.kill_bond(&body, b);
            }
            wavy(&body, &mut state, 2e-3);
            // The energy from its definition, `1/2 sum k dL^2 + 1/2 sum q_n Pi_n^2 / S_n`, with
            // each node's own q_n and its plain normaliser.
            let lat = &body.lattice;
            let dl: Vec<Real> = (0..body.springs())
                .map(|b| {
                    let [i, j] = lat.bonds.ends[b].map(|v| v as usize);
                    let (x, y, z) = law::spring_vector(lat, &state.u, i, j);
                    (x * x + y * y + z * z).sqrt() - lat.rest(b)
                })
                .collect();
            let alive = |b: usize| state.alive()[b];
            let mut direct = 0.0;
            let (mut pi, mut s) = (vec![0.0; body.nodes()], vec![0.0; body.nodes()]);
            for b in (0..body.springs()).filter(|&b| alive(b)) {
                direct += 0.5 * body.k[b] * dl[b] * dl[b];
                for v in lat.bonds.ends[b] {
                    pi[v as usize] += body.k[b] * lat.rest(b) * dl[b];
                    s[v as usize] += body.k[b] * lat.rest(b) * lat.rest(b);
                }
            }
            let dispersive: Real = (0..body.nodes())
                .filter(|&n| s[n] > 0.0)
                .map(|n| 0.5 * body.q_at(n) * pi[n] * pi[n] / s[n])
                .sum();
            let want = direct + dispersive;
            let got = energy(&body, &state, &state.u.clone());
            assert!(
                (got - want).abs() < 1e-12 * want.abs(),
                "{dim}D: energy {got}, from its definition {want}"
            );
            assert!(
                dispersive.abs() > 1e-3 * direct,
                "the dispersive part is tested"
            );
            law::update_forces(&body, &mut state);
            let scale = state
                .f
                .as_flat()
                .iter()
                .fold(0.0, |m: Real, &f| m.max(f.abs()));
            assert!(scale > 0.0);
            let h = 1e-7;
            for i in (0..body.nodes()).step_by(5) {
                for c in 0..dim {
                    let mut u = state.u.clone();
                    u.comp_mut(c)[i] += h;
                    let up = energy(&body, &state, &u);
                    u.comp_mut(c)[i] -= 2.0 * h;
                    let down = energy(&body, &state, &u);
                    let fd = -(up - down) / (2.0 * h);
                    let f = state.f.comp(c)[i];
                    assert!(
                        (f - fd).abs() < 1e-6 * scale,
                        "{dim}D node {i} component {c}: force {f}, -dU/du {fd}"
                    );
                }
            }
        }
    }

    /// The stability theorem, numerically: the stiffness of a body of phases with `q_n` down
    /// to -0.45 (and up to 3), intact and after random patterns of broken springs, has no
    /// negative eigenvalue (beyond round-off), in 2D and 3D.
    #[test]
    fn a_body_of_several_materials_is_stable_after_any_breaks() {
        for (dim, seed) in [(2, 3), (3, 5)] {
            let lattice = random(dim, seed);
            let phase: Vec<u8> = (0..lattice.len())
                .map(|i| ((i * 7 + 3) % 3) as u8)
                .collect();
            let ph = |k: Real, q: Real| Phase::of(Body::from_cells(lattice.clone(), k, q, 1.0));
            let phases = vec![
                ph(1.0, -0.45).unwrap(),
                ph(4.0, 3.0).unwrap(),
                ph(2.0, 0.1).unwrap(),
            ];
            let body = assemble(lattice, phases, &phase).unwrap();
            for pattern in 0..4 {
                let mut state = State::new(&body);
                for b in 0..body.springs() {
                    if pattern > 0 && ((b * 2654435761usize) >> 7).is_multiple_of(2 + pattern) {
                        state.kill_bond(&body, b);
                    }
                }
                let nd = dim * body.nodes();
                let mut tangent = crate::tangent::Tangent::new(&body, &state);
                let mut k = nalgebra::DMatrix::<Real>::zeros(nd, nd);
                let mut e = Coords::zeros(body.nodes());
                let mut out = Coords::zeros(body.nodes());
                for col in 0..nd {
                    e.comp_mut(col % dim)[col / dim] = 1.0;
                    tangent.apply(&body, &e, &mut out);
                    for row in 0..nd {
                        k[(row, col)] = out.comp(row % dim)[row / dim];
                    }
                    e.comp_mut(col % dim)[col / dim] = 0.0;
                }
                let sym = 0.5 * (&k + k.transpose());
                let eig = sym.symmetric_eigenvalues();
                let (lo, hi) = eig
                    .iter()
                    .fold((Real::MAX, 0.0), |(lo, hi): (Real, Real), &x| {
                        (lo.min(x), hi.max(x.abs()))
                    });
                assert!(
                    lo > -1e-9 * hi,
                    "{dim}D, pattern {pattern}: smallest eigenvalue {lo}, largest {hi}"
                );
            }
        }
    }

    /// A body of two identical phases is the one-material body, bit for bit (stiffnesses,
    /// masses, forces): the interface rule leaves equal stiffnesses as they are.
    #[test]
    fn two_identical_phases_are_one_material() {
        let lattice = random(3, 11);
        let one = Body::from_cells(lattice.clone(), 2.0, 0.3, 1.5);
        let phases = vec![
            Phase::of(one.clone()).unwrap(),
            Phase::of(one.clone()).unwrap(),
        ];
        let split: Vec<u8> = (0..lattice.len()).map(|i| (i % 2) as u8).collect();
        let two = assemble(lattice, phases, &split).unwrap();
        assert_eq!(two.k[..], one.k[..]);
        assert_eq!(two.mass, one.mass);
        let (mut a, mut b) = (State::new(&one), State::new(&two));
        wavy(&one, &mut a, 1e-3);
        wavy(&two, &mut b, 1e-3);
        law::update_forces(&one, &mut a);
        law::update_forces(&two, &mut b);
        // The normaliser S_n / q_n with q = 1 rounds as S_n does, but the pools are then q p
        // formed as Pi / (S / q): within round-off of the one-material law.
        for (x, y) in a.f.as_flat().iter().zip(b.f.as_flat()) {
            assert!((x - y).abs() <= 1e-12 * x.abs().max(1e-9), "{x} vs {y}");
        }
    }

    /// Mistakes are refused with the reason: counts, a node of no phase, an anisotropic phase.
    #[test]
    fn bad_phases_are_refused() {
        let lattice = random(2, 1);
        let n = lattice.len();
        let ph = || Phase::of(Body::from_cells(lattice.clone(), 1.0, 0.2, 1.0)).unwrap();
        let e = assemble(lattice.clone(), vec![ph(), ph()], &vec![0; n - 1]).unwrap_err();
        assert!(e.to_string().contains("phases given for"), "{e}");
        let e = assemble(lattice.clone(), vec![ph(), ph()], &vec![2; n]).unwrap_err();
        assert!(e.to_string().contains("there are 2 phases"), "{e}");
        let mut aniso = Body::from_cells(lattice.clone(), 1.0, 0.2, 1.0);
        aniso.lever = Some(vec![1.0; aniso.springs()]);
        let e = Phase::of(aniso).unwrap_err();
        assert!(e.to_string().contains("anisotropic"), "{e}");
        let e = Body::from_cells(lattice, 1.0, 0.2, 1.0)
            .with_node_q(vec![-0.5; n])
            .unwrap_err();
        assert!(e.to_string().contains("q > -1/2"), "{e}");
    }
}
