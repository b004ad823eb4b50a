//! Case files never panic: broken files give their specific error at the right line and
//! column, and random mutations of a valid file give a result or an error, never a panic.

use std::path::Path;

const BASE: &str = r#"
[lattice]
kind = "hex"
spacing = 1.0e-3
thickness = 1.0e-3

[material]
youngs = 72e9
poisson = 0.22
density = 2440
fracture_energy = 3.8

[geometry]
box = { min = [0.0, 0.0], max = [10e-3, 6e-3] }

[[precrack]]
segment = [[-1e-3, 3.03e-3], [4e-3, 3.03e-3]]

[[boundary]]
region = { face = "y+" }
velocity = [{ axis = "y", value = 0.5, ramp = 1e-6 }]
no_fail = true

[[boundary]]
region = { box = { min = [-1.0, -1.0], max = [1.0, 0.5e-3] } }
fixed = ["x", "y"]

[solver]
end_time = 1e-5
"#;

fn load(text: &str) -> Result<hooke_case::Simulation, hooke_case::CaseError> {
    hooke_case::load_str(Path::new("case.toml"), text, 1.0)
}

#[test]
fn the_base_case_is_valid() {
    let sim = load(BASE).unwrap();
    assert!(sim.precracked > 0 && sim.fracture.is_some() && sim.loading.prescribed.len() == 3);
    assert_eq!(sim.fields, hooke_io::FieldSet::ALL);
    let chosen = BASE.replacen(
        "end_time = 1e-5",
        "end_time = 1e-5\n\n[output]\nfields = [\"damage\", \"displacement\"]",
        1,
    );
    let sim = load(&chosen).unwrap();
    assert_eq!(
        sim.fields.names().collect::<Vec<_>>(),
        ["displacement", "damage"]
    );
}

/// Each broken file: (what is replaced, by what, the line of the error, text the message must
/// contain).
#[test]
fn broken_case_files_name_line_column_and_key() {
    let cases: &[(&str, &str, usize, &str)] = &[
        (
            "density = 2440",
            "density = 2440\ncolour = \"red\"",
            11,
            "unknown field",
        ),
        ("youngs = 72e9", "youngs = \"72 GPa\"", 8, "invalid type"),
        ("youngs = 72e9", "youngs = -72e9", 8, "material.youngs"),
        ("poisson = 0.22", "poisson = 0.5", 9, "material.poisson"),
        ("poisson = 0.22", "poisson = 0.5", 9, "-0.99 <= nu < 0.5"),
        (
            "max = [10e-3, 6e-3]",
            "max = [0.0, 6e-3]",
            14,
            "geometry.box",
        ),
        (
            "region = { face = \"y+\" }",
            "region = { box = { min = [1.0, 1.0], max = [2.0, 2.0] } }",
            20,
            "selects no node",
        ),
        (
            "segment = [[-1e-3, 3.03e-3], [4e-3, 3.03e-3]]",
            "segment = [[20e-3, 3.03e-3], [30e-3, 3.03e-3]]",
            17,
            "cuts no spring",
        ),
        ("kind = \"hex\"", "kind = \"square\"", 3, "lattice.kind"),
        ("end_time = 1e-5", "end_time = 0", 29, "solver.end_time"),
        ("[solver]\nend_time = 1e-5", "[solver]", 28, "missing field"),
        (
            "axis = \"y\", value",
            "axis = \"w\", value",
            21,
            "unknown axis",
        ),
        ("spacing = 1.0e-3", "spacing = 1.0e-12", 4, "would not fit"),
        (
            "end_time = 1e-5",
            "end_time = 1e-5\n\n[output]\nfields = [\"displacement\", \"strain\"]",
            32,
            "output.fields: unknown field \"strain\"; choose from \"displacement\"",
        ),
        (
            "end_time = 1e-5",
            "end_time = 1e-5\n\n[output]\nfields = [\"stress\", \"stress\"]",
            32,
            "listed twice",
        ),
    ];
    for (from, to, line, needle) in cases {
        assert!(BASE.contains(from), "test table: {from}");
        let text = BASE.replacen(from, to, 1);
        let e = load(&text).expect_err(&format!("{to} should be refused"));
        let msg = e.to_string();
        eprintln!("{to:?} -> {msg}");
        assert!(
            msg.starts_with(&format!("case.toml:{line}:")),
            "{to}: expected line {line}: {msg}"
        );
        assert!(msg.contains(needle), "{to}: expected '{needle}' in: {msg}");
    }
}

/// Random mutations of a valid case: deletions, duplications, swapped characters and numbers.
/// Every one gives a simulation or an error; none panics.
#[test]
fn random_mutations_never_panic() {
    let mut x: u64 = 0x1234_5678_9abc_def1;
    let mut rnd = |n: usize| {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x % n.max(1) as u64) as usize
    };
    let junk = [
        "",
        "0",
        "-1",
        "1e308",
        "nan",
        "\"",
        "[",
        "]",
        "{",
        "}",
        "=",
        ",",
        "\n",
        "[[boundary]]\n",
        "x",
        "1e-12",
        "inf",
    ];
    let (mut ok, mut err) = (0, 0);
    for _ in 0..1500 {
        let mut t: Vec<char> = BASE.chars().collect();
        for _ in 0..1 + rnd(3) {
            let at = rnd(t.len());
            match rnd(3) {
                0 => {
                    let len = rnd(8).min(t.len() - at);
                    t.drain(at..at + len);
                }
                1 => {
                    let j = junk[rnd(junk.len())];
                    for (k, c) in j.chars().enumerate() {
                        t.insert(at + k, c);
                    }
                }
                _ => {
                    let b = rnd(t.len());
                    t.swap(at, b);
                }
            }
        }
        let text: String = t.into_iter().collect();
        let r = std::panic::catch_unwind(|| load(&text).map(|_| ()));
        match r {
            Ok(Ok(())) => ok += 1,
            Ok(Err(_)) => err += 1,
            Err(_) => panic!("panicked on:\n{text}"),
        }
    }
    assert!(
        ok > 0 && err > 0,
        "mutations should give both valid and invalid files ({ok} ok, {err} errors)"
    );
}

fn with_geometry(geometry: &str) -> String {
    let start = BASE.find("[geometry]").unwrap();
    let end = BASE.find("[[precrack]]").unwrap();
    let boundary = BASE.find("[[boundary]]").unwrap();
    // Keep lattice and material; replace geometry; drop the pre-crack and the second boundary.
    format!("{}{}\n{}", &BASE[..start], geometry, &BASE[boundary..]).replace("[[boundary]]\nregion = { box = { min = [-1.0, -1.0], max = [1.0, 0.5e-3] } }\nfixed = [\"x\", \"y\"]\n", "").replace(&BASE[end..boundary], "")
}

/// A plate with a circular hole: the nodes fill the plate but not the hole, and their number
/// matches the area to within the lattice's staircase error.
#[test]
fn geometry_with_a_hole() {
    let text = with_geometry("[geometry]\nadd = [{ box = { min = [0.0, 0.0], max = [20e-3, 12e-3] } }]\nsubtract = [{ circle = { center = [10e-3, 6e-3], radius = 3e-3 } }]\n");
    let sim = load(&text).unwrap_or_else(|e| panic!("{e}\n{text}"));
    let lat = &sim.body.lattice;
    for i in 0..lat.len() {
        let p = lat.pos.get(i);
        assert!(
            ((p.x - 10e-3).powi(2) + (p.y - 6e-3).powi(2)).sqrt() >= 3e-3 - 1e-12,
            "node {i} in the hole"
        );
    }
    let a = 1e-3;
    let cell = 3f64.sqrt() / 2.0 * a * a;
    let expected = (20e-3 * 12e-3 - std::f64::consts::PI * 9e-6) / cell;
    let n = lat.len() as f64;
    assert!(
        (n / expected - 1.0).abs() < 0.15,
        "{n} nodes, about {expected} expected"
    );
    assert!(
        lat.grid.is_none(),
        "a body with a hole runs on the CSR kernel"
    );
}

/// 3D: an L-shaped union of two boxes, and an extruded triangle.
#[test]
fn geometry_unions_and_polygons_3d() {
    let base = BASE
        .replace("kind = \"hex\"", "kind = \"cubic\"")
        .replace("thickness = 1.0e-3\n", "");
    let cube = |geom: &str| {
        let start = base.find("[geometry]").unwrap();
        let end = base.find("[solver]").unwrap();
        format!("{}{}\n{}", &base[..start], geom, &base[end..])
    };
    let l = cube("[geometry]\nadd = [{ box = { min = [0.0, 0.0, 0.0], max = [4e-3, 1e-3, 1e-3] } }, { box = { min = [0.0, 0.0, 0.0], max = [1e-3, 4e-3, 1e-3] } }]\n");
    let sim = load(&l).unwrap_or_else(|e| panic!("{e}\n{l}"));
    assert_eq!(sim.body.nodes(), 5 * 2 * 2 + 5 * 2 * 2 - 2 * 2 * 2);
    let tri = cube("[geometry]\nadd = [{ polygon = { points = [[0.0, 0.0], [6e-3, 0.0], [0.0, 6e-3]], z = [0.0, 2e-3] } }]\n");
    let sim = load(&tri).unwrap_or_else(|e| panic!("{e}\n{tri}"));
    for i in 0..sim.body.nodes() {
        let p = sim.body.lattice.pos.get(i);
        assert!(p.x + p.y <= 6e-3 + 1e-12 && p.z <= 2e-3 + 1e-12);
    }
    // 7 nodes on the diagonal row x + y = 6 mm, 28 in the triangle, 3 layers in z.
    assert_eq!(sim.body.nodes(), 28 * 3);
}

/// Geometry mistakes are refused at their location.
#[test]
fn geometry_errors_name_the_shape() {
    for (geom, needle) in [
        ("[geometry]\nbox = { min = [0.0, 0.0], max = [1e-2, 1e-2] }\nadd = [{ circle = { center = [0.0, 0.0], radius = 1e-3 } }]\n", "not both"),
        ("[geometry]\nadd = [{ circle = { center = [0.0, 0.0], radius = 1e-3 }, box = { min = [0.0, 0.0], max = [1e-2, 1e-2] } }]\n", "exactly one"),
        ("[geometry]\nadd = [{ box = { min = [0.0, 0.0], max = [1e-2, 1e-2] } }]\nsubtract = [{ box = { min = [-1.0, -1.0], max = [1.0, 1.0] } }]\n", "contains no lattice node"),
        ("[geometry]\nadd = [{ circle = { center = [0.0, 0.0], radius = -1e-3 } }]\n", "geometry.add[0].radius"),
        ("[geometry]\nadd = [{ polygon = { points = [[0.0, 0.0], [1e-2, 0.0]] } }]\n", "three or more points"),
    ] {
        let text = with_geometry(geom);
        let e = load(&text).expect_err(geom).to_string();
        assert!(e.contains(needle) && e.starts_with("case.toml:"), "{geom}: {e}");
    }
}

/// A boundary that both holds and moves its nodes along one axis is refused with its key and
/// line: the two rules would fight over those nodes (and the energy ledger's boundary work).
#[test]
fn an_axis_prescribed_twice_is_refused() {
    let text = r#"
[lattice]
kind = "hex"
spacing = 1e-3
thickness = 1e-3

[material]
youngs = 70e9
poisson = 0.2
density = 2440

[geometry]
box = { min = [0.0, 0.0], max = [10e-3, 8e-3] }

[[boundary]]
region = { face = "y-" }
fixed = ["y"]
velocity = [{ axis = "y", value = -1.0 }]

[solver]
end_time = 1e-6
"#;
    let e = hooke_case::load_str(std::path::Path::new("twice.toml"), text, 1.0).unwrap_err();
    assert_eq!(e.key, "boundary[0]", "{e}");
    assert_eq!(e.line, 16, "{e}"); // the boundary's region
    assert!(e.message.contains("axis y is prescribed twice"), "{e}");
}
