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
    let e = load(&plate(PHASES, "fracture_energy = 10.0")).unwrap_err();
    assert!(e.message.contains("critical_stretch"), "{e}");
}
