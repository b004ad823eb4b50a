//! Random lattices from case files: a body cut from a closed triangle mesh (STL), tractions
//! spread by each node's share of the face, and clear errors for bad meshes and bad keys.

use std::path::{Path, PathBuf};

/// A box [0, sx] x [0, sy] x [0, sz] as an ASCII STL with outward triangles.
fn box_stl(s: [f64; 3]) -> String {
    let v: Vec<[f64; 3]> = (0..8)
        .map(|i| {
            [
                (i & 1) as f64 * s[0],
                ((i >> 1) & 1) as f64 * s[1],
                ((i >> 2) & 1) as f64 * s[2],
            ]
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut out = String::from("solid box\n");
    for q in quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            out.push_str("facet normal 0 0 0\nouter loop\n");
            for i in t {
                let p = v[i];
                out.push_str(&format!("vertex {} {} {}\n", p[0], p[1], p[2]));
            }
            out.push_str("endloop\nendfacet\n");
        }
    }
    out + "endsolid box\n"
}

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hooke-case-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

const CASE: &str = r#"
[lattice]
kind = "random3d"
spacing = 1.0e-3
seed = 3

[material]
youngs = 200e9
poisson = 0.3
density = 7800

[geometry]
[[geometry.add]]
mesh = { file = "part.stl", scale = 1e-3 }
[[geometry.subtract]]
sphere = { center = [10e-3, 4e-3, 3e-3], radius = 2e-3 }

[[boundary]]
region = { face = "x-" }
fixed = ["x", "y", "z"]

[[boundary]]
region = { face = "x+" }
traction = [{ value = [1e6, 0.0, 0.0], normal = "x" }]

[solver]
end_time = 1e-6
"#;

#[test]
fn a_random_body_fills_a_mesh_minus_a_hole_and_spreads_its_traction() {
    let d = dir("mesh");
    std::fs::write(d.join("part.stl"), box_stl([20.0, 8.0, 6.0])).unwrap();
    let case = d.join("case.toml");
    std::fs::write(&case, CASE).unwrap();
    let sim = hooke_case::load(&case, 1.0).unwrap();
    let lat = &sim.body.lattice;
    let c = lat.cells.as_ref().unwrap();
    let volume: f64 = c.node.iter().sum();
    let hole = 4.0 / 3.0 * std::f64::consts::PI * 8e-9;
    let expect = 20e-3 * 8e-3 * 6e-3 - hole;
    // The sphere's faceted surface takes a little more than the exact ball.
    assert!(
        (volume / expect - 1.0).abs() < 0.02,
        "volume {volume} of {expect}"
    );
    for i in 0..lat.len() {
        let p = lat.pos.get(i);
        assert!(
            p.x >= 0.0 && p.x <= 20e-3 && p.y >= 0.0 && p.y <= 8e-3 && p.z >= 0.0 && p.z <= 6e-3
        );
        let r = ((p.x - 10e-3).powi(2) + (p.y - 4e-3).powi(2) + (p.z - 3e-3).powi(2)).sqrt();
        assert!(r >= 2e-3 * (1.0 - 1e-9), "node {i} inside the hole");
    }
    // Total traction force = pressure x face area, exactly.
    let total: f64 = sim
        .loading
        .loads
        .iter()
        .map(|l| l.force.x * l.nodes.len() as f64)
        .sum();
    assert!(
        (total / (1e6 * 8e-3 * 6e-3) - 1.0).abs() < 1e-9,
        "total force {total}"
    );
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn bad_meshes_and_keys_are_named() {
    let d = dir("bad");
    let mut open = box_stl([20.0, 8.0, 6.0]);
    // Drop the last facet: the mesh is open.
    let cut = open[..open.len() - "endsolid box\n".len()]
        .rfind("facet normal")
        .unwrap();
    open.truncate(cut);
    open.push_str("endsolid box\n");
    std::fs::write(d.join("part.stl"), open).unwrap();
    let case = d.join("case.toml");
    std::fs::write(&case, CASE).unwrap();
    let e = hooke_case::load(&case, 1.0).unwrap_err().to_string();
    assert!(
        e.contains("geometry.add[0].mesh.file") && e.contains("the mesh is open"),
        "{e}"
    );
    assert!(e.contains("case.toml:14:"), "{e}");
    std::fs::remove_file(d.join("part.stl")).unwrap();
    let e = hooke_case::load(&case, 1.0).unwrap_err().to_string();
    assert!(e.contains("part.stl"), "{e}");
    for (from, to, key) in [
        ("seed = 3", "seed = -3", "lattice.seed"),
        (
            "seed = 3",
            "seed = 3\nsampler = \"grid\"",
            "lattice.sampler",
        ),
        ("seed = 3", "seed = 3\njitter = 0.5", "lattice.jitter"),
        ("kind = \"random3d\"", "kind = \"cubic\"", "lattice.seed"),
    ] {
        std::fs::write(d.join("part.stl"), box_stl([20.0, 8.0, 6.0])).unwrap();
        let text = CASE.replace(from, to);
        let e = hooke_case::load_str(Path::new("c.toml"), &text, 1.0)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.contains(key), "{to}: {e}");
    }
    std::fs::remove_dir_all(&d).ok();
}
