//! `material.criterion`: the stretch criterion by default, the spring-energy criterion
//! calibrated to the same G_c on demand, and clear errors where it cannot be had.

use std::path::PathBuf;

fn case(name: &str, kind: &str, material_extra: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hooke-criterion-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join("plate.toml");
    std::fs::write(
        &p,
        format!(
            r#"[lattice]
kind = "{kind}"
spacing = 1.0e-3
thickness = 1.0e-3

[material]
youngs = 72e9
poisson = 0.22
density = 2440
{material_extra}

[geometry]
box = {{ min = [0.0, 0.0], max = [20e-3, 10e-3] }}

[solver]
end_time = 1e-6
"#
        ),
    )
    .unwrap();
    p
}

#[test]
fn energy_criterion_is_built_from_g_c_on_regular_lattices() {
    let p = case(
        "hex",
        "hex",
        "fracture_energy = 3.8\ncriterion = \"energy\"",
    );
    let sim = hooke_case::load(&p, 1.0).unwrap();
    let fr = sim.fracture.expect("fracture is on");
    assert_eq!(fr.criterion().name(), "spring-energy");
    let p = case("stretch", "hex", "fracture_energy = 3.8");
    let sim = hooke_case::load(&p, 1.0).unwrap();
    assert_eq!(sim.fracture.unwrap().criterion().name(), "critical-stretch");
    let p = case(
        "direct",
        "hex",
        "critical_stretch = 1e-3\ncriterion = \"energy\"",
    );
    let sim = hooke_case::load(&p, 1.0).unwrap();
    assert_eq!(sim.fracture.unwrap().criterion().name(), "spring-energy");
}

#[test]
fn energy_criterion_errors_name_the_key_and_the_fix() {
    for (name, kind, extra, want) in [
        (
            "random",
            "random2d",
            "fracture_energy = 3.8\ncriterion = \"energy\"",
            "use \"stretch\" here",
        ),
        (
            "unknown",
            "hex",
            "fracture_energy = 3.8\ncriterion = \"strain\"",
            "unknown criterion \"strain\"",
        ),
        (
            "alone",
            "hex",
            "criterion = \"energy\"",
            "needs fracture_energy or critical_stretch",
        ),
    ] {
        let p = case(name, kind, extra);
        let e = hooke_case::load(&p, 1.0).unwrap_err().to_string();
        assert!(
            e.contains("material.criterion") && e.contains(want) && e.contains("plate.toml:"),
            "{name}: {e}"
        );
    }
}
