//! `material.criterion`: the stretch criterion by default, the spring-energy criterion
//! calibrated to the same G_c on demand, and clear errors where it cannot be had.

use std::path::PathBuf;

use hooke_core::LatticeKind;
use hooke_fracture::softening::strength_factor;

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

/// `criterion = "softening"`: from G_f with the tensile strength or the characteristic length,
/// or from the two stretches; linear by default, bilinear on demand.
#[test]
fn softening_springs_are_built_from_g_f_and_the_strength() {
    for (name, extra, shape) in [
        (
            "soft-ft",
            "fracture_energy = 3.8\ncriterion = \"softening\"\ntensile_strength = 4e6",
            "Linear",
        ),
        (
            "soft-lch",
            "fracture_energy = 3.8\ncriterion = \"softening\"\nsoftening = \"bilinear\"\ncharacteristic_length = 17.1e-3",
            "Bilinear",
        ),
        (
            "soft-stretch",
            "criterion = \"softening\"\npeak_stretch = 5e-4\nfinal_stretch = 4e-3",
            "Linear",
        ),
    ] {
        let p = case(name, "random2d", extra);
        let sim = hooke_case::load(&p, 1.0).unwrap();
        let fr = sim.fracture.as_ref().expect("fracture is on");
        assert_eq!(fr.criterion().name(), "softening");
        let text = format!("{:?}", fr.criterion());
        assert!(text.contains(shape), "{name}: {text}");
        // 4 MPa on 72 GPa (the characteristic length gives the same f_t): the springs peak
        // at f_t / (E S), S the strength factor measured at the law's own peak fraction.
        if name != "soft-stretch" {
            let law = fr.criterion().as_softening().unwrap();
            let rho = law.peak / law.equivalent_stretch();
            let nu = hooke_core::material::nu_from_q(LatticeKind::Random2d, sim.q);
            let s = strength_factor(LatticeKind::Random2d, nu, rho, law.shape).unwrap();
            assert!(s > 0.7 && s < 1.5, "{name}: S = {s}");
            let f_t = 72e9 * law.peak * s;
            assert!((f_t / 4e6 - 1.0).abs() < 1e-9, "{name}: {text}, f_t = {f_t}");
        }
    }
}

/// Inconsistent softening parameters are refused with the file, line, key and fix.
#[test]
fn softening_errors_name_the_key_and_the_fix() {
    for (name, extra, key, want) in [
        (
            "snap",
            "criterion = \"softening\"\npeak_stretch = 5e-4\nfinal_stretch = 4e-4",
            "material.final_stretch",
            "cannot snap back",
        ),
        (
            "strong",
            "fracture_energy = 0.01\ncriterion = \"softening\"\ntensile_strength = 2e9",
            "material.tensile_strength",
            "snap back",
        ),
        (
            "nostrength",
            "fracture_energy = 3.8\ncriterion = \"softening\"",
            "material.fracture_energy",
            "add tensile_strength",
        ),
        (
            "both",
            "fracture_energy = 3.8\ncriterion = \"softening\"\ntensile_strength = 4e7\ncharacteristic_length = 1e-3",
            "material.tensile_strength",
            "not both",
        ),
        (
            "shape",
            "fracture_energy = 3.8\ncriterion = \"softening\"\ntensile_strength = 4e7\nsoftening = \"exponential\"",
            "material.softening",
            "use \"linear\" or \"bilinear\"",
        ),
        (
            "stray",
            "fracture_energy = 3.8\ntensile_strength = 4e7",
            "material.tensile_strength",
            "add criterion = \"softening\"",
        ),
        (
            "half",
            "criterion = \"softening\"\npeak_stretch = 5e-4",
            "material.peak_stretch",
            "add final_stretch",
        ),
        (
            "negative",
            "fracture_energy = 3.8\ncriterion = \"softening\"\ntensile_strength = -4e7",
            "material.tensile_strength",
            "not a positive number",
        ),
    ] {
        let p = case(name, "random2d", extra);
        let e = hooke_case::load(&p, 1.0).unwrap_err().to_string();
        assert!(
            e.contains(key) && e.contains(want) && e.contains("plate.toml:"),
            "{name}: {e}"
        );
    }
}
