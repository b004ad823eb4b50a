//! Rigid bodies and contact in case files: a valid case builds its bodies with the right mass,
//! and every mistake names its line, key and fix.

use std::path::Path;

const BASE: &str = r#"
[lattice]
kind = "hex"
spacing = 1.0e-3
thickness = 2.0e-3

[material]
youngs = 72e9
poisson = 0.22
density = 2440

[geometry]
box = { min = [0.0, 0.0], max = [20e-3, 10e-3] }

[[rigid]]
name = "ball"
shape = { circle = { radius = 2e-3 } }
position = [10e-3, 13e-3]
velocity = [0.0, -10.0]
density = 7800

[[rigid]]
name = "floor"
shape = { halfspace = { normal = [0.0, 1.0] } }
position = [0.0, -0.6e-3]
motion = "kinematic"
friction = 0.3

[contact]
stiffness_factor = 0.2

[solver]
end_time = 1e-6
"#;

fn load(text: &str) -> Result<hooke_case::Simulation, hooke_case::CaseError> {
    hooke_case::load_str(Path::new("case.toml"), text, 1.0)
}

#[test]
fn bodies_are_built_with_their_mass_and_settings() {
    let sim = load(BASE).unwrap();
    let c = sim.contact.as_ref().unwrap();
    assert_eq!(c.bodies.len(), 2);
    assert_eq!(c.opts.stiffness_factor, 0.2);
    match c.bodies[0].motion {
        hooke_contact::Motion::Dynamic { mass } => {
            // A disk of radius 2 mm, 2 mm thick (the plate's thickness), steel.
            let expect = 7800.0 * std::f64::consts::PI * 4e-6 * 2e-3;
            assert!((mass / expect - 1.0).abs() < 1e-9, "{mass} vs {expect}");
        }
        _ => panic!("the ball is dynamic"),
    }
    assert!(matches!(
        c.bodies[1].motion,
        hooke_contact::Motion::Kinematic(_)
    ));
    assert_eq!(c.bodies[1].friction, 0.3);
    // A dynamic disk turns (its inertia: m r^2 / 2 about z); the floor does not.
    let inertia = c.bodies[0].inertia.expect("a dynamic disk turns");
    let m = match c.bodies[0].motion {
        hooke_contact::Motion::Dynamic { mass } => mass,
        _ => unreachable!(),
    };
    assert!((inertia.tensor[2][2] / (0.5 * m * 4e-6) - 1.0).abs() < 1e-9);
    assert!(c.bodies[1].inertia.is_none() && c.bodies[0].spin == [0.0; 3]);
    // Spin keys: a kinematic body's constant spin, a dynamic body's initial one (L = I w),
    // and rotation switched off.
    let spun = BASE
        .replacen(
            "density = 7800",
            "density = 7800\nangular_velocity = [50.0]",
            1,
        )
        .replacen(
            "friction = 0.3",
            "friction = 0.3\nangular_velocity = [-2.0]",
            1,
        );
    let sim = load(&spun).unwrap();
    let b = &sim.contact.as_ref().unwrap().bodies;
    assert_eq!(b[0].spin, [0.0, 0.0, 50.0]);
    assert!((b[0].angular_momentum[2] / (50.0 * inertia.tensor[2][2]) - 1.0).abs() < 1e-12);
    assert_eq!(b[1].spin, [0.0, 0.0, -2.0]);
    let fixed = BASE.replacen("density = 7800", "density = 7800\nrotates = false", 1);
    assert!(load(&fixed).unwrap().contact.unwrap().bodies[0]
        .inertia
        .is_none());
    // No contact section and no body: no contact at all (and no cost).
    let plain = BASE.split("[[rigid]]").next().unwrap().to_string() + "[solver]\nend_time = 1e-6\n";
    assert!(load(&plain).unwrap().contact.is_none());
}

#[test]
fn contact_mistakes_name_line_key_and_fix() {
    let cases: &[(&str, &str, &str, &str)] = &[
        ("position = [10e-3, 13e-3]", "position = [10e-3, 11.5e-3]", "rigid[0].position", "inside the contact range"),
        ("density = 7800", "density = 7800\nmass = 1.0", "rigid[0].mass", "not both"),
        ("density = 7800", "", "rigid[0].mass", "mass (kg) or density"),
        ("motion = \"kinematic\"\n", "", "rigid[1].motion", "kinematic"),
        ("motion = \"kinematic\"", "motion = \"flying\"", "rigid[1].motion", "unknown motion"),
        ("shape = { circle = { radius = 2e-3 } }", "shape = { polygon = { points = [[0.0, 0.0], [2e-3, 0.0], [1e-3, 0.5e-3], [1e-3, 2e-3]] } }", "rigid[0].shape.polygon.points", "not convex"),
        ("shape = { circle = { radius = 2e-3 } }", "shape = { cylinder = { radius = 1e-3, length = 2e-3, axis = \"z\" } }", "rigid[0].shape", "3D"),
        ("shape = { circle = { radius = 2e-3 } }", "shape = { circle = { radius = 2e-3 }, box = { size = [1e-3, 1e-3] } }", "rigid[0].shape", "exactly one"),
        ("stiffness_factor = 0.2", "stiffness_factor = 3.0", "contact.stiffness_factor", "0 < c <= 1"),
        ("stiffness_factor = 0.2", "fragment_distance = 2e-3", "contact.fragment_distance", "shortest spring"),
        ("friction = 0.3", "friction = -0.3", "rigid[1].friction", ">= 0"),
        ("normal = [0.0, 1.0]", "normal = [0.0, 0.0]", "rigid[1].shape.halfspace.normal", "non-zero"),
        ("density = 7800", "density = 7800\nangular_velocity = [1.0, 2.0, 3.0]", "rigid[0].angular_velocity", "[wz]"),
        ("density = 7800", "density = 7800\nangular_velocity = [\"fast\"]", "angular_velocity", "expected f64"),
        ("friction = 0.3", "friction = 0.3\nrotates = true", "rigid[1].rotates", "kinematic"),
        ("density = 7800", "density = 7800\nrotates = false\nangular_velocity = [5.0]", "rigid[0].angular_velocity", "rotates = false"),
    ];
    for (from, to, key, msg) in cases {
        assert!(BASE.contains(from), "{from}");
        let text = BASE.replacen(from, to, 1);
        let e = load(&text).map(|_| ()).unwrap_err();
        let s = e.to_string();
        assert!(s.contains(key) && s.contains(msg), "{to}: {s}");
        assert!(e.line > 0, "{to}: no line in {s}");
    }
}
