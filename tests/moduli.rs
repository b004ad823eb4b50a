//! Regression tests of the intact material's elastic moduli against the closed forms of
//! `design/MODEL.md` (paper eqs. 1, 2, 7, 8).

use hooke_core::material::{nu_from_q, q_from_nu, youngs_from_k};
use hooke_core::moduli::{block_test, bulk_moduli, bulk_stress, BlockTest, Ends};
use hooke_core::{law, Body, Coords, LatticeKind, Matrix, Real, State};

fn nu_grid(lo: Real, hi: Real, n: usize) -> Vec<Real> {
    (0..=n)
        .map(|i| lo + (hi - lo) * i as Real / n as Real)
        .collect()
}

/// The bulk (affine) test: E and nu of the infinite lattice equal the closed forms to 1e-9, and
/// the lattice is isotropic (C11 - C12 = 2 C44), over the whole admissible range.
#[test]
fn bulk_moduli_match_closed_forms_3d_and_2d() {
    let cases = [
        (LatticeKind::Cubic, nu_grid(-0.99, 0.499, 60)),
        (LatticeKind::Hex, nu_grid(-0.99, 0.99, 60)),
    ];
    for (kind, nus) in cases {
        for nu in nus {
            let q = q_from_nu(kind, nu).unwrap();
            // Non-unit k and a: the formulas must carry the units, not just the numbers.
            let (k, a) = (3.7e4, 2.5e-3);
            let m = bulk_moduli(kind, k, a, q);
            let e = youngs_from_k(kind, k, a, q);
            assert!(
                (m.youngs / e - 1.0).abs() < 1e-9,
                "{kind:?} nu={nu}: E {} vs {e}",
                m.youngs
            );
            assert!(
                (m.poisson - nu).abs() < 1e-9 * nu.abs().max(1.0),
                "{kind:?} nu={nu}: {}",
                m.poisson
            );
            let iso = (m.c11 - m.c12 - 2.0 * m.c44) / m.c11.abs().max(m.c44.abs());
            assert!(iso.abs() < 1e-9, "{kind:?} nu={nu}: C11-C12-2C44 = {iso}");
        }
    }
}

/// The plain lattices reproduce the paper's eqs. (1) and (2) exactly.
#[test]
fn plain_lattices_reproduce_paper_eqs_1_and_2() {
    let c = bulk_moduli(LatticeKind::Cubic, 1.0, 1.0, 0.0);
    assert!((c.youngs - 2.5).abs() < 1e-12 && (c.poisson - 0.25).abs() < 1e-12);
    assert!(
        (c.c12 - 1.0).abs() < 1e-12 && (c.c44 - 1.0).abs() < 1e-12,
        "lambda = mu = k/a"
    );
    let h = bulk_moduli(LatticeKind::Hex, 1.0, 1.0, 0.0);
    let lame = 3.0 / (4.0 * 3f64.sqrt());
    assert!(
        (h.c12 - lame).abs() < 1e-12 && (h.c44 - lame).abs() < 1e-12,
        "lambda = mu = 3/(4 sqrt 3) k"
    );
    assert!((h.poisson - 1.0 / 3.0).abs() < 1e-12 && (h.youngs - 2.0 / 3f64.sqrt()).abs() < 1e-12);
}

/// The nonlinear law agrees with the linearised one at small strain: the virial stress of the
/// centre node under a finite affine strain of 1e-7 matches the linear stress to 1e-5 relative
/// (the difference is the O(eps) geometric nonlinearity).
#[test]
fn nonlinear_law_reduces_to_linear_at_small_strain() {
    for (kind, nu) in [
        (LatticeKind::Cubic, -0.7),
        (LatticeKind::Cubic, 0.45),
        (LatticeKind::Hex, 0.8),
    ] {
        let q = q_from_nu(kind, nu).unwrap();
        let n = 7;
        let body = tests_body(kind, q, n);
        let centre = match kind.dim() {
            3 => body.lattice.grid_index(3, 3, 3),
            _ => body.lattice.grid_index(3, 3, 0),
        };
        let mut eps = Matrix::zeros();
        eps[(0, 0)] = 1e-7;
        eps[(1, 1)] = -0.3e-7;
        eps[(0, 1)] = 0.2e-7;
        eps[(1, 0)] = 0.2e-7;
        if kind == LatticeKind::Cubic {
            eps[(2, 2)] = 0.5e-7;
        }
        let mut state = State::new(&body);
        for i in 0..body.nodes() {
            state.u.set(i, eps * body.lattice.pos.get(i));
        }
        law::update_forces(&body, &mut state);
        let t = law::tensions(&body, &state);
        let nonlinear = law::node_virial(&body, &state.u, &t, centre);
        let linear = bulk_stress(kind, 1.0, 1.0, q, &eps);
        let err = (nonlinear - linear).norm() / linear.norm();
        assert!(err < 1e-5, "{kind:?} nu={nu}: relative difference {err}");
        // The centre node of an affinely strained perfect lattice is in equilibrium.
        let f = state.f.get(centre).norm();
        assert!(f < 1e-12 * linear.norm(), "{kind:?}: residual force {f}");
    }
}

fn tests_body(kind: LatticeKind, q: Real, n: usize) -> Body {
    hooke_tests::small_body(kind, q, n)
}

/// The paper's block (70a x 15a x 15a, sliding ends): measured nu within 0.03 of the target,
/// with the surface bias of the expected sign and size.
#[test]
fn paper_block_reproduces_target_nu() {
    for nu in [-0.9, -0.5, 0.0, 0.25, 0.3, 0.45] {
        let r = block_test(&BlockTest::paper(LatticeKind::Cubic, nu)).unwrap();
        let err = r.nu_measured - nu;
        assert!(
            err.abs() < 0.03,
            "nu={nu}: measured {} (error {err:+.4})",
            r.nu_measured
        );
        assert!(r.solve.residual <= 1e-9, "residual {}", r.solve.residual);
        // E with the nominal area overestimates (the true section is wider than the outer node
        // planes), with the node-cell area it underestimates: the target lies between them.
        assert!(
            r.e_measured > r.e_target && r.e_measured_cell < r.e_target * 1.01,
            "nu={nu}: {r:?}"
        );
    }
}

/// The 2D block (71 nodes x 16 rows) reaches in-plane ratios up to 0.95.
#[test]
fn hex_block_reproduces_target_nu() {
    for nu in [-0.9, -0.5, 0.0, 1.0 / 3.0, 0.6, 0.9, 0.95] {
        let r = block_test(&BlockTest::paper(LatticeKind::Hex, nu)).unwrap();
        let err = r.nu_measured - nu;
        assert!(
            err.abs() < 0.05,
            "nu_2D={nu}: measured {} (error {err:+.4})",
            r.nu_measured
        );
    }
}

/// The surface bias shrinks like a/W: doubling the resolution (the whole bar, so that the end
/// zones scale too) roughly halves the nu error. At a fixed length the ratio is lower (about 1.5
/// at nu = -0.5), because the end zones then reach further into the middle section.
fn bias_halves(kind: LatticeKind, nu: Real, small: [usize; 3], large: [usize; 3]) -> (Real, Real) {
    let run = |size| {
        let mut t = BlockTest::paper(kind, nu);
        t.size = size;
        let r = block_test(&t).unwrap();
        r.nu_measured - nu
    };
    (run(small), run(large))
}

#[test]
fn surface_bias_halves_when_the_section_doubles() {
    for nu in [0.45, 0.25, -0.5] {
        let (e1, e2) = bias_halves(LatticeKind::Cubic, nu, [41, 11, 11], [81, 21, 21]);
        let ratio = e1 / e2;
        assert!(
            (1.5..2.7).contains(&ratio),
            "nu={nu}: errors {e1:+.5} (W=10a) and {e2:+.5} (W=20a, twice as long), ratio {ratio}"
        );
    }
    let (e1, e2) = bias_halves(LatticeKind::Hex, 0.8, [61, 12, 1], [121, 23, 1]);
    let ratio = e1 / e2;
    assert!(
        (1.5..2.7).contains(&ratio),
        "hex: errors {e1:+.5} and {e2:+.5}, ratio {ratio}"
    );
}

/// The paper's size against the doubled resolution (slow: 141 x 31 x 31 nodes).
#[test]
#[ignore = "fine resolution: run with --ignored before resolving moduli changes"]
fn paper_block_bias_halves_at_full_size() {
    for nu in [-0.9, 0.0, 0.25, 0.45, 0.49] {
        let (e1, e2) = bias_halves(LatticeKind::Cubic, nu, [71, 16, 16], [141, 31, 31]);
        eprintln!(
            "nu={nu}: W=15a error {e1:+.5}, W=30a error {e2:+.5}, ratio {:.3}",
            e1 / e2
        );
        assert!((1.6..2.5).contains(&(e1 / e2)), "nu={nu}");
    }
}

/// Clamped ends stiffen the block (lateral contraction is prevented near the ends) but the test
/// still runs and converges.
#[test]
fn clamped_ends_are_stiffer_than_sliding_ends() {
    for nu in [-0.5, 0.3] {
        let mut t = BlockTest::paper(LatticeKind::Cubic, nu);
        t.size = [31, 8, 8];
        let slide = block_test(&t).unwrap();
        t.ends = Ends::Clamp;
        let clamp = block_test(&t).unwrap();
        if nu > 0.0 {
            assert!(clamp.e_measured > slide.e_measured);
        } else {
            // An auxetic block wants to contract laterally in compression as well: clamping
            // still adds constraint, so it is still stiffer.
            assert!(clamp.e_measured > slide.e_measured * 0.999);
        }
    }
}

/// nu, E are the same whether the block is stretched or compressed (linear regime).
#[test]
fn tension_and_compression_agree_at_small_strain() {
    let mut t = BlockTest::paper(LatticeKind::Cubic, 0.1);
    t.size = [31, 8, 8];
    let a = block_test(&t).unwrap();
    t.strain = -1e-5;
    let b = block_test(&t).unwrap();
    assert!((a.nu_measured - b.nu_measured).abs() < 1e-4);
    assert!((a.e_measured / b.e_measured - 1.0).abs() < 1e-4);
}

/// Inverse mapping sanity: theory curve endpoints.
#[test]
fn q_range_covers_the_admissible_nu() {
    assert!((nu_from_q(LatticeKind::Cubic, -0.5) + 1.0).abs() < 1e-12);
    assert!((nu_from_q(LatticeKind::Cubic, 1e9) - 0.5).abs() < 1e-8);
    assert!((nu_from_q(LatticeKind::Hex, -0.5) + 1.0).abs() < 1e-12);
    assert!((nu_from_q(LatticeKind::Hex, 1e9) - 1.0).abs() < 1e-8);
    let _ = Coords::zeros(0);
}

/// With each spring and node weighted by the share of the bulk's cells it stands for
/// (`BlockTest::cell_weights`), the paper's Ladd block has no surface layer: a uniform strain is
/// an exact equilibrium, and the block reads the target nu and E (nominal section) to the
/// solver's tolerance over the whole admissible range, where the unweighted block is off by up
/// to +0.025 in nu and +13 % in E. The hexagonal strip comes within 0.0013 in nu and 0.14 % in
/// E from nu = -0.9 to 0.9 (measured: largest at +-0.9). It is not exact, as the Ladd block is:
/// its ends are zigzag (odd rows stand a/2 further out), and the weighted star of an end node
/// has an anisotropic second moment, so its pool is not the volume change; the end zones'
/// error fades before the middle section. (Until the ends were held on the affine field, they
/// sheared their end cells and nu read 0.018 too negative at -0.9.)
#[test]
fn cell_weights_remove_the_surface_bias() {
    for nu in [-0.9, -0.5, 0.0, 0.25, 0.45, 0.49] {
        let mut t = BlockTest::paper(LatticeKind::Cubic, nu);
        t.cell_weights = true;
        let r = block_test(&t).unwrap();
        let (dnu, de) = (r.nu_measured - nu, r.e_measured / r.e_target - 1.0);
        println!("cubic nu {nu}: nu error {dnu:+.2e}, E error {de:+.2e}");
        assert!(
            dnu.abs() < 1e-5 && de.abs() < 1e-4,
            "cubic nu {nu}: {dnu:e}, {de:e}"
        );
    }
    for nu in [-0.9, -0.5, 0.0, 0.3, 0.45, 0.9] {
        let mut t = BlockTest::paper(LatticeKind::Hex, nu);
        t.cell_weights = true;
        let r = block_test(&t).unwrap();
        let (dnu, de) = (r.nu_measured - nu, r.e_measured / r.e_target - 1.0);
        println!("hex nu {nu}: nu error {dnu:+.2e}, E error {de:+.2e}");
        assert!(
            dnu.abs() < 2e-3 && de.abs() < 2e-3,
            "hex nu {nu}: {dnu:e}, {de:e}"
        );
    }
    // Random lattices are weighted by volume already. A cube's corner node stands for 1/8 of a
    // bulk node, its edge springs for 1/4 of a bulk spring, its face diagonals for 1/2.
    let e = tests_body(LatticeKind::Random3d, 0.0, 6)
        .with_cell_weights()
        .unwrap_err();
    assert!(e.to_string().contains("random lattices already are"), "{e}");
    let cube = tests_body(LatticeKind::Cubic, 0.0, 4)
        .with_cell_weights()
        .unwrap();
    assert_eq!(cube.mass[0], 1.0 / 8.0);
    let (x, y) = (cube.lattice.pos.x(), cube.lattice.pos.y());
    let z = cube.lattice.pos.z();
    for (s, e) in cube.lattice.bonds.ends.iter().enumerate() {
        let (i, j) = (e[0] as usize, e[1] as usize);
        let d = [x[j] - x[i], y[j] - y[i], z[j] - z[i]];
        let on_edge = |p: [Real; 3]| p.iter().filter(|&&c| c == 0.0 || c == 3.0).count() >= 2;
        let (pi, pj) = ([x[i], y[i], z[i]], [x[j], y[j], z[j]]);
        let axis = d.iter().filter(|&&c| c != 0.0).count() == 1;
        // An axis spring along a cube edge of the body: one of its four cubes.
        if axis
            && on_edge(pi)
            && on_edge(pj)
            && (0..3).all(|c| d[c] != 0.0 || pi[c] == 0.0 || pi[c] == 3.0)
        {
            assert_eq!(cube.k[s], 0.25, "spring {s}");
        }
    }
    assert!(cube.k.iter().all(|&k| k == 1.0 || k == 0.5 || k == 0.25));
}
