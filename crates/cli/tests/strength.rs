//! A softening random3d body has the tensile strength it was given: a bar pulled in uniaxial
//! tension peaks at f_t (the springs peak below f_t / E by the measured strength factor S of
//! `hooke_fracture::softening::strength_factor`), on node sets the table was not measured with.

use std::path::Path;
use std::process::Command;

/// Peak tensile stress (Pa) of a concrete bar 50 x 200 x 50 mm (2D: 50 x 200) at a 5 mm spacing, pulled along
/// y at a strain rate of 0.1/s, for the given softening curve and fracture energy.
fn bar_strength(tag: &str, kind: &str, shape: &str, g_f: f64, seed: u64) -> f64 {
    let dir = std::env::temp_dir().join(format!("hooke-strength-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    // 2D: a plate 1 m thick in plane stress, so the force is per metre and the area 50 mm.
    let (lattice, box_, free, held, area) = match kind {
        "random2d" => (
            "thickness = 1.0\nplane = \"stress\"",
            "{ min = [0.0, 0.0], max = [50e-3, 200e-3] }",
            r#"["x"]"#,
            r#"["x", "y"]"#,
            50e-3,
        ),
        _ => (
            "",
            "{ min = [0.0, 0.0, 0.0], max = [50e-3, 200e-3, 50e-3] }",
            r#"["x", "z"]"#,
            r#"["x", "y", "z"]"#,
            50e-3 * 50e-3,
        ),
    };
    let case = format!(
        r#"[lattice]
kind = "{kind}"
spacing = 5e-3
seed = {seed}
{lattice}

[material]
youngs = 25.85e9
poisson = 0.18
density = 2400
criterion = "softening"
softening = "{shape}"
fracture_energy = {g_f}
tensile_strength = 2.7e6

[geometry]
box = {box_}

[[boundary]]
region = {{ face = "y-" }}
fixed = {held}
no_fail = true

[[boundary]]
region = {{ face = "y+" }}
fixed = {free}
velocity = [{{ axis = "y", value = 0.02, ramp = 0.2e-3, smooth = true }}]
no_fail = true

[solver]
end_time = 5e-3
damping = 2000

[output]
every = 5e-3
reactions_every = 10e-6
"#
    );
    let path = dir.join("bar.toml");
    std::fs::write(&path, case).unwrap();
    let out = dir.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_hooke"))
        .args([
            "run",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let peak = peak_force(&out.join("bar_reactions.csv"));
    let _ = std::fs::remove_dir_all(&dir);
    peak / area
}

/// The largest force the pulled grip (region 1) exerts along y, with the grip still moving
/// afterwards (a peak at the last record would be a run too short to reach it).
fn peak_force(csv: &Path) -> f64 {
    let text = std::fs::read_to_string(csv).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (region, fy) = (col("region"), col("force_y"));
    let forces: Vec<f64> = lines
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|f| f[region] == "1")
        .map(|f| f[fy].parse().unwrap())
        .collect();
    let (at, peak) =
        forces
            .iter()
            .enumerate()
            .fold((0, f64::MIN), |m, (i, &f)| if f > m.1 { (i, f) } else { m });
    assert!(
        at + 10 < forces.len(),
        "the bar had not peaked by the end of the run"
    );
    peak
}

/// Bars of both curves at peak fractions about 0.24 and 0.55 (G_f 65 and 15 J/m^2 at 5 mm)
/// peak within 6 % of f_t.
fn bars_peak_at_f_t(kind: &str) {
    for (shape, g_f) in [("linear", 65.0), ("bilinear", 65.0), ("linear", 15.0)] {
        let f = bar_strength(&format!("{kind}-{shape}-{g_f}"), kind, shape, g_f, 7);
        let ratio = f / 2.7e6;
        eprintln!("{kind} {shape}, G_f = {g_f}: peak stress / f_t = {ratio:.3}");
        assert!(
            (ratio - 1.0).abs() < 0.06,
            "{kind} {shape}, G_f = {g_f}: {ratio:.3}"
        );
    }
}

#[test]
#[ignore = "slow (75 s here): a random3d bar loaded past its peak; run with --ignored before changing softening"]
fn a_softening_random3d_bar_peaks_at_its_tensile_strength() {
    bars_peak_at_f_t("random3d");
}

#[test]
fn a_softening_random2d_bar_peaks_at_its_tensile_strength() {
    bars_peak_at_f_t("random2d");
}
