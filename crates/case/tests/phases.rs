//! Cases of several materials: `[materials.NAME]` and `[[phases]]` build a body whose nodes in
//! each shape are of the phase's material; a run breaks springs and balances its energy; and
//! mistakes name the file, line, key and fix.

use std::path::Path;

use hooke_core::Real;

/// A random plate pulled along x with a stiff, dense disk in its middle and a soft auxetic
/// band on its left, breaking by a critical stretch.
fn plate(phases: &str, criterion: &str) -> String {
    format!(
        r#"
[lattice]
kind = "random2d"
spacing = 1.0e-3
thickness = 1.0e-3

[material]
youngs = 10e9
poisson = 0.25
density = 2000
{criterion}

[materials.grain]
youngs = 60e9
poisson = 0.3
density = 2700

[materials.soft]
youngs = 4e9
poisson = -0.3
density = 1200

{phases}

[geometry]
box = {{ min = [0.0, 0.0], max = [30e-3, 20e-3] }}

[[precrack]]
segment = [[0.0, 10e-3], [6e-3, 10e-3]]

[[boundary]]
region = {{ face = "y-" }}
velocity = [{{ axis = "y", value = -1.0, ramp = 2e-6 }}]

[[boundary]]
region = {{ face = "y+" }}
velocity = [{{ axis = "y", value = 1.0, ramp = 2e-6 }}]

[solver]
end_time = 8e-6

[output]
every = 4e-6
"#
    )
}

const PHASES: &str = r#"
[[phases]]
material = "grain"
shape.circle = { center = [18e-3, 10e-3], radius = 4e-3 }

[[phases]]
material = "soft"
shape.box = { min = [0.0, 0.0], max = [4e-3, 20e-3] }
"#;

fn load(text: &str) -> Result<hooke_case::Simulation, hooke_case::CaseError> {
    hooke_case::load_str(Path::new("plate.toml"), text, 1.0)
}

/// The body takes each node's material: its mass and its dispersion ratio (q of nu = 0.3,
/// 0.25 and -0.3 on random2d, in the disk, the matrix and the band), and a spring between
/// two materials the two in series.
#[test]
fn phases_give_each_node_its_material() {
    let sim = load(&plate(PHASES, "critical_stretch = 2e-3")).unwrap();
    let body = &sim.body;
    let q = body.q_node.as_ref().expect("a body of several materials");
    let pos = &body.lattice.pos;
    let (mut grain, mut soft, mut matrix) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..body.nodes() {
        let (x, y) = (pos.x()[i], pos.y()[i]);
        if (x - 18e-3).hypot(y - 10e-3) <= 4e-3 - 1e-6 {
            grain.push(i);
        } else if x <= 4e-3 - 1e-6 {
            soft.push(i);
        } else if (x - 18e-3).hypot(y - 10e-3) > 4e-3 + 1e-6 && x > 4e-3 + 1e-6 {
            matrix.push(i);
        }
    }
    assert!(grain.len() > 20 && soft.len() > 20 && matrix.len() > 100);
    let distinct = |set: &[usize]| {
        let mut v: Vec<u64> = set.iter().map(|&i| q[i].to_bits()).collect();
        v.sort_unstable();
        v.dedup();
        v.into_iter().map(Real::from_bits).collect::<Vec<_>>()
    };
    let (qg, qs, qm) = (distinct(&grain), distinct(&soft), distinct(&matrix));
    assert!(
        qg.len() == 1 && qs.len() == 1 && qm.len() == 1,
        "{qg:?} {qs:?} {qm:?}"
    );
    assert!(
        qs[0] < 0.0 && qg[0] > qm[0],
        "q: soft {qs:?}, grain {qg:?}, matrix {qm:?}"
    );
    // Masses follow the densities over the same cells: the disk's nodes are 2700/2000 heavier
    // per volume than the matrix's.
    let per_volume = |i: usize| body.mass[i] / body.lattice.node_volume(i);
    assert!((per_volume(grain[0]) / per_volume(matrix[0]) - 2700.0 / 2000.0).abs() < 1e-9);
    assert!((per_volume(soft[0]) / per_volume(matrix[0]) - 1200.0 / 2000.0).abs() < 1e-9);
}

/// A run of the plate breaks springs from the pre-crack and keeps its energy ledger balanced,
/// as a plate of one material does.
#[test]
fn a_plate_of_several_materials_runs_and_balances_its_energy() {
    let text = plate(PHASES, "critical_stretch = 1.5e-3");
    let (sim, mut opts) = hooke_case::prepare(Path::new("plate.toml"), &text, 1.0, &[]).unwrap();
    let out = std::env::temp_dir().join(format!("hooke-phases-run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    opts.out = out.clone();
    opts.name = "plate".into();
    let summary = hooke_sim::run(sim, opts, &mut hooke_sim::Silent).unwrap();
    let _ = std::fs::remove_dir_all(&out);
    assert!(summary.steps > 50, "{}", summary.steps);
    assert!(summary.broken_springs > 0, "no spring broke");
    assert!(
        summary.balance.abs() < 1e-3,
        "energy balance {:.3e}",
        summary.balance
    );
}

/// Mistakes: an unknown material (the known ones listed), a phase whose shape holds no node,
/// a material no phase assigns, and a criterion calibrated for one material.
#[test]
fn phase_mistakes_name_the_key_and_the_fix() {
    let unknown = PHASES.replace("material = \"grain\"", "material = \"granite\"");
    let e = load(&plate(&unknown, "critical_stretch = 2e-3")).unwrap_err();
    assert_eq!(e.key, "phases[0].material", "{e}");
    assert!(e.line > 0, "{e}");
    assert!(
        e.message.contains("granite") && e.message.contains("grain, soft"),
        "{e}"
    );
    let outside = PHASES.replace("center = [18e-3, 10e-3]", "center = [80e-3, 10e-3]");
    let e = load(&plate(&outside, "critical_stretch = 2e-3")).unwrap_err();
    assert_eq!(e.key, "phases[0]", "{e}");
    assert!(e.message.contains("holds no node"), "{e}");
    assert!(e.line > 0, "{e}");
    let e = load(&plate("", "critical_stretch = 2e-3")).unwrap_err();
    assert!(e.key.starts_with("materials."), "{e}");
    assert!(e.message.contains("no [[phases]]"), "{e}");
    let softening = "fracture_energy = 10.0\ncriterion = \"softening\"\ntensile_strength = 3e6";
    let e = load(&plate(PHASES, softening)).unwrap_err();
    assert_eq!(e.key, "material.criterion", "{e}");
    assert!(
        e.message.contains("critical_stretch or fracture_energy"),
        "{e}"
    );
}

/// The matrix named, scattering (Weibull m = 8), the disk with a critical stretch of its own,
/// and a weak, compliant interface between them.
const STRENGTHS: &str = r#"
[[interfaces]]
between = ["grain", "matrix"]
critical_stretch = 0.6e-3
stiffness_factor = 0.5
"#;
const MATRIX: &str =
    "critical_stretch = 1.5e-3\nname = \"matrix\"\nweibull = { modulus = 8, seed = 11 }";

fn with_strengths(text: &str) -> String {
    text.replace(
        "density = 2700\n",
        "density = 2700\ncritical_stretch = 3e-3\n",
    )
}

/// Each spring's critical stretch is its material's, its interface's, or the weaker
/// material's where no interface is given; the matrix's scatter as Weibull says (mean
/// `s_0 Gamma(1 + 1/8)` within 4 standard errors); an interface's springs are its factor
/// times as stiff as the two materials in series; and the draws follow the seed alone.
#[test]
fn materials_and_interfaces_take_their_own_strength_and_stiffness() {
    let text = with_strengths(&plate(&format!("{PHASES}{STRENGTHS}"), MATRIX));
    let sim = load(&text).unwrap();
    let plain = load(&plate(PHASES, "critical_stretch = 1.5e-3")).unwrap();
    let body = &sim.body;
    let phase = body.phase.as_ref().expect("phases");
    let f = sim.fracture.as_ref().unwrap();
    let s_base = f.criterion().screen().unwrap();
    assert_eq!(s_base, 1.5e-3);
    let factor = f.strength().expect("strength factors");
    let names: Vec<&str> = sim.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["matrix", "grain", "soft"]);
    let mut matrix = Vec::new();
    let (mut interface, mut grain, mut soft) = (0, 0, 0);
    for (b, e) in body.lattice.bonds.ends.iter().enumerate() {
        let [p, q] = e.map(|v| phase[v as usize]);
        let s_c = s_base * factor[b];
        let k_ratio = body.k[b] / plain.body.k[b];
        match (p.min(q), p.max(q)) {
            (0, 0) => matrix.push(factor[b]),
            (0, 1) => {
                interface += 1;
                assert!((s_c - 0.6e-3).abs() < 1e-15, "interface spring {b}: {s_c}");
                assert!(
                    (k_ratio - 0.5).abs() < 1e-12,
                    "interface spring {b}: k x {k_ratio}"
                );
            }
            (1, 1) => {
                grain += 1;
                assert!((s_c - 3e-3).abs() < 1e-15, "disk spring {b}: {s_c}");
            }
            (2, 2) | (0, 2) => {
                soft += 1;
                // The band's springs and its springs to the matrix: the body's own stretch.
                assert_eq!(factor[b], 1.0, "spring {b} of phases {p}, {q}");
            }
            other => panic!("spring {b} joins phases {other:?}"),
        }
        if p.min(q) != 0 || p.max(q) != 1 {
            assert_eq!(k_ratio, 1.0, "spring {b} of phases {p}, {q}");
        }
    }
    assert!(interface > 20 && grain > 50 && soft > 50 && matrix.len() > 500);
    let n = matrix.len() as Real;
    let mean = matrix.iter().sum::<Real>() / n;
    let sd = (matrix.iter().map(|x| (x - mean).powi(2)).sum::<Real>() / n).sqrt();
    let want = hooke_fracture::Weibull::new(8.0, 11).unwrap().mean();
    assert!(
        (mean - want).abs() < 4.0 * sd / n.sqrt(),
        "mean factor {mean}, Gamma(1 + 1/8) = {want}"
    );
    // The same seed gives the same draws, another seed others.
    let again = load(&text).unwrap();
    assert_eq!(again.fracture.as_ref().unwrap().strength(), Some(factor));
    let other = load(&text.replace("seed = 11", "seed = 12")).unwrap();
    assert_ne!(other.fracture.as_ref().unwrap().strength(), Some(factor));
}

/// The run's frames carry each node's phase as the `material` point field, and run.json the
/// materials' names and constants in that order.
#[test]
fn frames_carry_the_material_and_run_json_names_it() {
    let text = with_strengths(&plate(&format!("{PHASES}{STRENGTHS}"), MATRIX));
    let (sim, mut opts) = hooke_case::prepare(Path::new("plate.toml"), &text, 1.0, &[]).unwrap();
    let phases = sim.body.phase.clone().unwrap();
    let out = std::env::temp_dir().join(format!("hooke-phases-frames-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    opts.out = out.clone();
    opts.name = "plate".into();
    let summary = hooke_sim::run(sim, opts, &mut hooke_sim::Silent).unwrap();
    assert!(summary.broken_springs > 0);
    // The materials' strain energies add up to the body's.
    let by: Vec<&str> = summary
        .strain_by_material
        .iter()
        .map(|(n, _)| n.as_str())
        .collect();
    assert_eq!(by, ["matrix", "grain", "soft"]);
    let total: Real = summary.strain_by_material.iter().map(|(_, e)| e).sum();
    let strain = summary.energy.strain_direct + summary.energy.strain_dispersive;
    assert!(
        (total - strain).abs() < 1e-9 * strain.abs(),
        "by material {total:e}, body {strain:e}"
    );
    assert!(summary.strain_by_material.iter().all(|(_, e)| *e > 0.0));
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    let materials = run["constants"]["materials"].as_array().unwrap();
    let names: Vec<&str> = materials
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["matrix", "grain", "soft"]);
    assert_eq!(materials[1]["youngs"], 60e9);
    assert_eq!(materials[2]["index"], 2);
    let frame = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "vtu"))
        .expect("a frame");
    let vtk = vtkio::Vtk::import(&frame).unwrap();
    let vtkio::model::DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
        panic!("not an unstructured grid")
    };
    let vtkio::model::Piece::Inline(p) = &pieces[0] else {
        panic!("not inline")
    };
    let material = p
        .data
        .point
        .iter()
        .find_map(|a| match a {
            vtkio::model::Attribute::DataArray(d) if d.name == "material" => Some(d),
            _ => None,
        })
        .expect("a material field");
    let got: Vec<u32> = material.data.clone().into_vec().unwrap();
    let want: Vec<u32> = phases.iter().map(|&p| p as u32).collect();
    assert_eq!(got, want);
    let _ = std::fs::remove_dir_all(&out);
}

/// Mistakes in interfaces and scatter: an unknown material (the known ones listed), two
/// materials that never touch, an interface in a body of one material, one material twice, a
/// factor that is not positive, a Weibull modulus out of range.
#[test]
fn interface_and_weibull_mistakes_name_the_key_and_the_fix() {
    let case = |interfaces: &str, matrix: &str| {
        load(&with_strengths(&plate(
            &format!("{PHASES}{interfaces}"),
            matrix,
        )))
        .unwrap_err()
    };
    let e = case(
        &STRENGTHS.replace("\"grain\", \"matrix\"", "\"grain\", \"mortar\""),
        MATRIX,
    );
    assert_eq!(e.key, "interfaces[0].between", "{e}");
    assert!(e.line > 0, "{e}");
    assert!(
        e.message.contains("mortar") && e.message.contains("grain, matrix, soft"),
        "{e}"
    );
    let e = case(
        &STRENGTHS.replace("\"grain\", \"matrix\"", "\"grain\", \"soft\""),
        MATRIX,
    );
    assert_eq!(e.key, "interfaces[0].between", "{e}");
    assert!(e.message.contains("never touch"), "{e}");
    let e = case(
        &STRENGTHS.replace("\"grain\", \"matrix\"", "\"grain\", \"grain\""),
        MATRIX,
    );
    assert!(e.message.contains("two different materials"), "{e}");
    let e = case(&STRENGTHS.replace("0.5", "-1.0"), MATRIX);
    assert_eq!(e.key, "interfaces[0].stiffness_factor", "{e}");
    let e = case(
        &STRENGTHS.replace("between = [\"grain\", \"matrix\"]", "between = [\"grain\"]"),
        MATRIX,
    );
    assert!(e.message.contains("give two materials"), "{e}");
    let e = case(STRENGTHS, &MATRIX.replace("modulus = 8", "modulus = 0.5"));
    assert_eq!(e.key, "material.weibull.modulus", "{e}");
    assert!(e.message.contains("from 1 to 100"), "{e}");
    let e = case(STRENGTHS, &MATRIX.replace("seed = 11", "seed = -1"));
    assert_eq!(e.key, "material.weibull.seed", "{e}");
    let one = plate(STRENGTHS, MATRIX).replace("[materials.grain]", "[unused_grain]");
    let e = load(&one).unwrap_err();
    assert!(!e.message.is_empty(), "{e}");
    let e = load(&with_strengths(&plate(PHASES, MATRIX)).replace(
        "critical_stretch = 3e-3",
        "critical_stretch = 3e-3\nfracture_energy = 5.0",
    ))
    .unwrap_err();
    assert_eq!(e.key, "materials.grain.fracture_energy", "{e}");
}

/// A body of one material with scattered strength: the criterion's stretch scales each
/// spring's draw, and a run from a fracture energy breaks springs.
#[test]
fn one_material_scatters_by_weibull() {
    let text = plate(
        "",
        "fracture_energy = 5.0\nweibull = { modulus = 5, seed = 1 }",
    )
    .replace(
        "[materials.grain]\nyoungs = 60e9\npoisson = 0.3\ndensity = 2700\n",
        "",
    )
    .replace(
        "[materials.soft]\nyoungs = 4e9\npoisson = -0.3\ndensity = 1200\n",
        "",
    );
    let sim = load(&text).unwrap();
    let factor = sim.fracture.as_ref().unwrap().strength().unwrap();
    let n = factor.len() as Real;
    let mean = factor.iter().sum::<Real>() / n;
    let want = hooke_fracture::weibull::gamma(1.2);
    assert!((mean / want - 1.0).abs() < 0.05, "mean {mean}, want {want}");
    assert!(sim.body.phase.is_none() && sim.materials.is_empty());
}

/// Random inclusions: a grading at 40 % of a plate's area becomes one phase holding about that
/// share of the nodes, the same on a second load; a fraction beyond reach is refused with the
/// fraction reached, inclusions larger than the body and a bad grading with the key.
#[test]
fn inclusions_become_a_phase_and_what_cannot_be_placed_is_refused() {
    let inclusions = |fraction: &str, d_max: &str, grading: &str| {
        format!(
            r#"
[[inclusions]]
material = "grain"
grading = "{grading}"
d_min = 2e-3
d_max = {d_max}
fraction = {fraction}
gap = 0.5e-3
seed = 3
"#
        )
    };
    let text = plate(
        &inclusions("0.40", "6e-3", "fuller"),
        "critical_stretch = 2e-3",
    )
    .replace(
        "[materials.soft]\nyoungs = 4e9\npoisson = -0.3\ndensity = 1200\n",
        "",
    );
    let sim = load(&text).unwrap();
    let phase = sim.body.phase.as_ref().unwrap();
    let share = phase.iter().filter(|&&p| p == 1).count() as Real / phase.len() as Real;
    assert!(
        (share - 0.40).abs() < 0.05,
        "share of nodes in the inclusions {share}"
    );
    assert_eq!(load(&text).unwrap().body.phase.as_ref(), Some(phase));
    let names: Vec<&str> = sim.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["material", "grain"]);

    let e = load(&text.replace("fraction = 0.40", "fraction = 0.75")).unwrap_err();
    assert_eq!(e.key, "inclusions[0].fraction", "{e}");
    assert!(e.line > 0, "{e}");
    assert!(
        e.message.contains("cannot be reached") && e.message.contains("volume fraction of 0."),
        "{e}"
    );
    let e = load(&text.replace("d_max = 6e-3", "d_max = 50e-3")).unwrap_err();
    assert_eq!(e.key, "inclusions[0].d_max", "{e}");
    assert!(e.message.contains("do not fit"), "{e}");
    let e = load(&text.replace("\"fuller\"", "\"gaussian\"")).unwrap_err();
    assert_eq!(e.key, "inclusions[0].grading", "{e}");
    let e = load(&text.replace("material = \"grain\"", "material = \"gravel\"")).unwrap_err();
    assert_eq!(e.key, "inclusions[0].material", "{e}");
    assert!(
        e.message.contains("gravel") && e.message.contains("grain"),
        "{e}"
    );
}

/// A stiffness field: each spring is the plain body's times the field's factors at its two
/// nodes in series; the factors have the mean asked for within 10 % and the spread within
/// 35 % (the plate holds only about 30 correlation areas; `hooke_sim::field`'s tests check the
/// field's statistics over many); masses unchanged; mistakes named.
#[test]
fn a_stiffness_field_scales_each_spring_by_its_halves() {
    let field = "stiffness_field = { cov = 0.25, correlation_length = 2e-3, seed = 8 }";
    let one = |extra: &str| {
        plate("", &format!("critical_stretch = 2e-3\n{extra}"))
            .replace(
                "[materials.grain]\nyoungs = 60e9\npoisson = 0.3\ndensity = 2700\n",
                "",
            )
            .replace(
                "[materials.soft]\nyoungs = 4e9\npoisson = -0.3\ndensity = 1200\n",
                "",
            )
    };
    let sim = load(&one(field)).unwrap();
    let plain = load(&one("")).unwrap();
    let modes = hooke_sim::field::StiffnessField {
        cov: 0.25,
        correlation_length: 2e-3,
        seed: 8,
    }
    .modes(2);
    let pos = &sim.body.lattice.pos;
    let f: Vec<Real> = (0..sim.body.nodes())
        .map(|i| modes.factor(pos.get(i)))
        .collect();
    for (b, &[i, j]) in sim.body.lattice.bonds.ends.iter().enumerate() {
        let want = plain.body.k[b] * hooke_core::phases::series(f[i as usize], f[j as usize]);
        assert_eq!(sim.body.k[b].to_bits(), want.to_bits(), "spring {b}");
    }
    let mean = f.iter().sum::<Real>() / f.len() as Real;
    let cov = (f.iter().map(|x| (x - mean).powi(2)).sum::<Real>() / f.len() as Real).sqrt() / mean;
    assert!(
        (mean - 1.0).abs() < 0.1 && (cov / 0.25 - 1.0).abs() < 0.35,
        "mean {mean}, cov {cov}"
    );
    assert_eq!(sim.body.mass, plain.body.mass);
    let e = load(&one(&field.replace("cov = 0.25", "cov = -1.0"))).unwrap_err();
    assert_eq!(e.key, "material.stiffness_field.cov", "{e}");
    assert!(e.line > 0, "{e}");
    let e = load(&plate(PHASES, &format!("critical_stretch = 2e-3\n{field}"))).unwrap_err();
    assert_eq!(e.key, "material.stiffness_field", "{e}");
}

/// `--set interfaces[0].critical_stretch=...`: a key of an entry of an array of tables is
/// changed as a table's is; an entry or key that is not there is refused with the reason.
#[test]
fn set_reaches_the_keys_of_an_interface() {
    let text = with_strengths(&plate(&format!("{PHASES}{STRENGTHS}"), MATRIX));
    let set = |arg: &str| {
        let o = hooke_case::parse_overrides(&[arg.to_string()]).unwrap();
        hooke_case::load_str_with(Path::new("plate.toml"), &text, 1.0, &o)
    };
    let sim = set("interfaces[0].critical_stretch=0.3e-3").unwrap();
    let f = sim.fracture.as_ref().unwrap();
    let (s_base, factor) = (f.criterion().screen().unwrap(), f.strength().unwrap());
    let phase = sim.body.phase.as_ref().unwrap();
    let ends = &sim.body.lattice.bonds.ends;
    let b = (0..ends.len())
        .find(|&b| {
            let [i, j] = ends[b].map(|v| phase[v as usize]);
            i.min(j) == 0 && i.max(j) == 1
        })
        .unwrap();
    assert!((s_base * factor[b] - 0.3e-3).abs() < 1e-15);
    let e = set("interfaces[3].critical_stretch=0.3e-3").unwrap_err();
    assert!(e.message.contains("[[interfaces]]"), "{e}");
    let e = set("interfaces[0].fracture_energy=2.0").unwrap_err();
    assert!(e.message.contains("not in that [[...]] entry"), "{e}");
}
