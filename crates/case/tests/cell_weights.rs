//! Regular-lattice bodies are cell-weighted by default (`lattice.cell_weights`): face and edge
//! springs and nodes stand for their share of the bulk's cells, so a uniform stress is an exact
//! equilibrium of the body with its face tractions (no surface layer), and the old equal
//! weights stay one key away.

use std::path::Path;

use hooke_core::{Coords, Real};

fn load(text: &str) -> Result<hooke_case::Simulation, hooke_case::CaseError> {
    hooke_case::load_str(Path::new("case.toml"), text, 1.0)
}

const E: Real = 70e9;
const NU: Real = 0.3;
/// A stress of strain 1e-7: the law is geometrically exact, so an affine field balances the
/// tractions only to O(strain) (the springs turn as they stretch); that is the tolerance.
const SIGMA: Real = 7e3;

/// A 3D Ladd block of 11 x 7 x 6 nodes, pulled along x by tractions -/+ SIGMA on its x faces.
fn block(extra_lattice: &str) -> String {
    format!(
        r#"
[lattice]
kind = "cubic"
spacing = 1.0e-3
{extra_lattice}

[material]
youngs = {E:e}
poisson = {NU}
density = 2440

[geometry]
box = {{ min = [0.0, 0.0, 0.0], max = [10e-3, 6e-3, 5e-3] }}

[[boundary]]
region = {{ face = "x+" }}
traction = [{{ value = [{SIGMA:e}, 0.0, 0.0], normal = "x" }}]

[[boundary]]
region = {{ face = "x-" }}
traction = [{{ value = [{m:e}, 0.0, 0.0], normal = "x" }}]

[solver]
end_time = 1e-6
"#,
        m = -SIGMA
    )
}

/// Internal forces of the affine field of uniaxial stress SIGMA along x, plus the external
/// loads: the largest residual over the nodes, and the largest external load.
fn residual_of_uniaxial_stress(sim: &mut hooke_case::Simulation) -> (Real, Real) {
    let (body, state) = (&sim.body, &mut sim.state);
    let n = body.nodes();
    let eps = SIGMA / E;
    let pos = &body.lattice.pos;
    let (x, y, z): (Vec<Real>, Vec<Real>, Vec<Real>) = (0..n)
        .map(|i| {
            let p = pos.get(i);
            (eps * p.x, -NU * eps * p.y, -NU * eps * p.z)
        })
        .fold(
            (vec![], vec![], vec![]),
            |(mut a, mut b, mut c), (u, v, w)| {
                a.push(u);
                b.push(v);
                c.push(w);
                (a, b, c)
            },
        );
    state.u = Coords::from_components(&x, &y, &z);
    hooke_core::law::update_forces(body, state);
    let mut ext = Coords::zeros(n);
    for l in &sim.loading.loads {
        let s = l.scale.value(0.0);
        for &i in &l.nodes {
            let i = i as usize;
            ext.set(i, ext.get(i) + l.force * s);
        }
    }
    let fmax = (0..n).map(|i| ext.get(i).norm()).fold(0.0, Real::max);
    let r = (0..n)
        .map(|i| (state.f.get(i) + ext.get(i)).norm())
        .fold(0.0, Real::max);
    (r, fmax)
}

/// By default the block is weighted (a face spring at half the bulk stiffness, an edge spring
/// at a quarter), and the affine field of a uniform uniaxial stress balances the tractions at
/// every node to round-off. With `cell_weights = false` every spring is a bulk spring and the
/// same field leaves the faces out of balance by a sizeable fraction of the load.
#[test]
fn a_uniform_stress_balances_the_tractions_of_a_weighted_block_exactly() {
    let mut sim = load(&block("")).unwrap();
    assert!(sim.cell_weighted);
    let kmax = sim.body.k.iter().cloned().fold(0.0, Real::max);
    let kmin = sim.body.k.iter().cloned().fold(Real::INFINITY, Real::min);
    assert_eq!(
        kmin,
        kmax / 4.0,
        "edge springs stand for a quarter of a bulk one"
    );
    assert_eq!(sim.k, kmax, "the calibrations take the bulk stiffness");
    // The loads add up to the traction on the face between the outer node planes.
    let total: Real = sim
        .loading
        .loads
        .iter()
        .filter(|l| l.force.x > 0.0)
        .map(|l| l.force.x * l.nodes.len() as Real)
        .sum();
    assert!(
        (total - SIGMA * 6e-3 * 5e-3).abs() < 1e-9 * total,
        "{total}"
    );
    let (r, f) = residual_of_uniaxial_stress(&mut sim);
    assert!(
        r < 10.0 * (SIGMA / E) * f,
        "weighted: residual {r:e} of {f:e}"
    );

    let mut plain = load(&block("cell_weights = false")).unwrap();
    assert!(!plain.cell_weighted);
    assert!(plain.body.k.iter().all(|&k| k == plain.body.k[0]));
    let (r, f) = residual_of_uniaxial_stress(&mut plain);
    assert!(r > 1e-2 * f, "equal weights: residual {r:e} of {f:e}");
}

/// The hexagonal plate's tractions on its rows add up to the traction times the row's length
/// between its end nodes (the trapezoid rule), as the weighted body's material spans.
#[test]
fn a_weighted_hexagonal_plate_takes_its_traction_on_the_rows_length() {
    let text = |extra: &str| {
        format!(
            r#"
[lattice]
kind = "hex"
spacing = 1.0e-3
thickness = 2.0e-3
{extra}

[material]
youngs = 72e9
poisson = 0.22
density = 2440

[geometry]
box = {{ min = [0.0, 0.0], max = [20e-3, 10e-3] }}

[[boundary]]
region = {{ face = "y+" }}
traction = [{{ value = [0.0, 2e6], normal = "y" }}]

[solver]
end_time = 1e-6
"#
        )
    };
    for (extra, weighted) in [("", true), ("cell_weights = false", false)] {
        let sim = load(&text(extra)).unwrap();
        assert_eq!(sim.cell_weighted, weighted);
        let loads = &sim.loading.loads;
        let nodes: usize = loads.iter().map(|l| l.nodes.len()).sum();
        let total: Real = loads
            .iter()
            .map(|l| l.force.y * l.nodes.len() as Real)
            .sum();
        let a = 1e-3;
        // Weighted: the row's length between its end nodes; equal weights: a per node.
        let length = if weighted {
            (nodes - 1) as Real * a
        } else {
            nodes as Real * a
        };
        assert!(
            (total - 2e6 * length * 2e-3).abs() < 1e-9 * total,
            "{extra}: {total} over {nodes} nodes"
        );
    }
}

/// `cell_weights = true` where the lattice cannot be weighted names the file, the line, the key
/// and the fix; so does a body too thin to weight.
#[test]
fn cell_weights_where_they_cannot_be_are_refused_with_the_key() {
    let random = block("cell_weights = true").replace("kind = \"cubic\"", "kind = \"random3d\"");
    let turned = block("cell_weights = true\nrotate_to = [1.0, 1.0, 0.0]").replace(
        "traction = [{ value = [7e3, 0.0, 0.0], normal = \"x\" }]",
        "fixed = [\"x\"]",
    );
    // The block with a fin one node plane thin: the fin's springs lie in no cube.
    let rod = |text: String| {
        text.replace(
            "box = { min = [0.0, 0.0, 0.0], max = [10e-3, 6e-3, 5e-3] }",
            "add = [{ box = { min = [0.0, 0.0, 0.0], max = [10e-3, 6e-3, 5e-3] } }, { box = { min = [0.0, 0.0, 0.0], max = [10e-3, 9e-3, 0.5e-3] } }]",
        )
    };
    let thin = rod(block("cell_weights = true"));
    for (text, why) in [
        (random, "by the volumes"),
        (turned, "stepped faces"),
        (thin, "too thin"),
    ] {
        let Err(e) = load(&text) else {
            panic!("not refused: {why}")
        };
        let e = e.to_string();
        // Line 5 holds the key.
        assert!(
            e.starts_with("case.toml:5:") && e.contains("lattice.cell_weights") && e.contains(why),
            "{e}"
        );
    }
    // By default, a body one node plane thin keeps equal weights rather than failing.
    let thin = load(&rod(block(""))).unwrap();
    assert!(!thin.cell_weighted);
}
