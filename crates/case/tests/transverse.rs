//! Transversely isotropic materials from case files (`[material] kind = "transverse"`): the
//! shipped fibre block bulges by nu_p across the load in the plane of isotropy and by
//! nu_pt = nu_tp E_p / E_t along the fibre, and mistakes name the file, line, key and fix.

use std::path::Path;

const BASE: &str = r#"
[lattice]
kind = "cubic"
spacing = 1.0e-3

[material]
kind = "transverse"
youngs_plane = 10e9
youngs_fibre = 25e9
poisson_plane = 0.35
poisson_fibre = 0.28
shear_fibre = 4e9
fibre = [0, 0, 1]
density = 1500

[geometry]
box = { min = [0.0, 0.0, 0.0], max = [6e-3, 4e-3, 4e-3] }

[solver]
end_time = 1e-6
"#;

fn load(text: &str) -> Result<hooke_case::Simulation, hooke_case::CaseError> {
    hooke_case::load_str(Path::new("case.toml"), text, 1.0)
}

#[test]
fn a_transverse_body_is_built_from_its_keys() {
    let sim = load(BASE).unwrap();
    let Some(hooke_core::Anisotropic::Transverse(t)) = sim.anisotropic else {
        panic!("a transverse material");
    };
    assert_eq!(t.fibre, [0.0, 0.0, 1.0]);
    // Its springs carry levers, so it runs on the general kernel.
    assert!(sim.body.lever.is_some());
    assert!(sim.q > 0.0 && sim.q < 0.1, "q {}", sim.q);
}

/// Each broken file: (what is replaced, by what, the key and text the message must hold, the
/// line).
#[test]
fn transverse_mistakes_name_line_key_and_fix() {
    let cases: &[(&str, &str, &str, &str, usize)] = &[
        ("fibre = [0, 0, 1]\n", "", "material.fibre", "missing", 7),
        (
            "fibre = [0, 0, 1]",
            "fibre = [0, 1]",
            "material.fibre",
            "three numbers",
            13,
        ),
        (
            "fibre = [0, 0, 1]",
            "fibre = [1, 1, 0]",
            "material.fibre",
            "lattice axis",
            13,
        ),
        (
            "shear_fibre = 4e9",
            "shear_fibre = 9e9",
            "material.shear_fibre",
            "2 G_p",
            12,
        ),
        (
            "poisson_fibre = 0.28",
            "poisson_fibre = 1.2",
            "material.poisson_fibre",
            "positive definite",
            11,
        ),
        (
            "density = 1500",
            "density = 1500\nyoungs = 70e9",
            "material.youngs",
            "remove it",
            15,
        ),
        (
            "shear_fibre = 4e9\n",
            "",
            "material.shear_fibre",
            "missing",
            7,
        ),
        (
            "kind = \"transverse\"",
            "kind = \"anisotropic\"",
            "material.kind",
            "orthotropic\"",
            7,
        ),
        (
            "density = 1500",
            "density = 1500\nfracture_energy = 100",
            "material.fracture_energy",
            "critical_stretch",
            15,
        ),
    ];
    for &(from, to, key, text, line) in cases {
        assert!(BASE.contains(from), "{from}");
        let broken = BASE.replacen(from, to, 1);
        let e = load(&broken)
            .err()
            .unwrap_or_else(|| panic!("{to}: accepted"));
        let shown = e.to_string();
        assert_eq!(e.key, key, "{to}: {shown}");
        assert!(shown.contains(text), "{to}: {shown}");
        assert_eq!(e.line, line, "{to}: {shown}");
    }
    // A lattice laid along a fibre: only the cubic one, along a direction.
    for (from, to, text) in [
        (
            "spacing = 1.0e-3",
            "spacing = 1.0e-3\nrotate_to = [1, 1]",
            "three numbers",
        ),
        (
            "spacing = 1.0e-3",
            "spacing = 1.0e-3\nrotate_to = [0, 0, 0]",
            "non-zero",
        ),
    ] {
        let e = load(&BASE.replacen(from, to, 1)).err().unwrap();
        assert_eq!((e.key.as_str(), e.line), ("lattice.rotate_to", 5), "{e}");
        assert!(e.to_string().contains(text), "{e}");
    }
    let turned = BASE
        .replacen(
            "spacing = 1.0e-3",
            "spacing = 1.0e-3\nrotate_to = [1, 1, 0]",
            1,
        )
        .replacen("fibre = [0, 0, 1]", "fibre = [1, 1, 0]", 1);
    let sim = load(&turned).unwrap();
    assert!(sim.body.lattice.grid.is_none() && sim.body.nodes() > 20);
    // ... but no traction on its stepped faces.
    let pulled = format!(
        "{turned}\n[[boundary]]\nregion = {{ face = \"x+\" }}\ntraction = [{{ value = [1e6, 0, 0], normal = \"x\" }}]\n"
    );
    let e = load(&pulled).err().unwrap();
    assert!(e.key.starts_with("boundary[0].traction"), "{e}");
    assert!(e.to_string().contains("stepped faces"), "{e}");
    // The fibre's own critical stretch: with critical_stretch, on a transverse material, not
    // with softening springs.
    for (extra, text) in [
        ("critical_stretch_fibre = 5e-3", "give critical_stretch"),
        (
            "critical_stretch = 1e-3\ncritical_stretch_fibre = 5e-3\ncriterion = \"energy\"",
            "stretch criterion",
        ),
        (
            "criterion = \"softening\"\npeak_stretch = 1e-3\nfinal_stretch = 5e-3\ncritical_stretch_fibre = 5e-3",
            "softening",
        ),
    ] {
        let e = load(&BASE.replacen("density = 1500", &format!("density = 1500\n{extra}"), 1))
            .err()
            .unwrap_or_else(|| panic!("{extra}: accepted"));
        assert_eq!(e.key, "material.critical_stretch_fibre", "{e}");
        assert!(e.to_string().contains(text), "{extra}: {e}");
    }
    let random = BASE.replacen(
        "kind = \"cubic\"",
        "kind = \"random3d\"\nrotate_to = [1, 0, 0]",
        1,
    );
    let e = load(&random).err().unwrap();
    assert_eq!(e.key, "lattice.rotate_to", "{e}");
    assert!(e.to_string().contains("only the cubic lattice"), "{e}");
    // Transverse keys on an isotropic material are named too.
    let iso = "[lattice]\nkind = \"cubic\"\nspacing = 1e-3\n[material]\nyoungs = 1e9\npoisson = 0.3\ndensity = 1000\nshear_fibre = 1e9\n[geometry]\nbox = { min = [0, 0, 0], max = [3e-3, 3e-3, 3e-3] }\n[solver]\nend_time = 1e-6\n";
    let e = load(iso).err().unwrap();
    assert_eq!((e.key.as_str(), e.line), ("material.shear_fibre", 8), "{e}");
    assert!(e.to_string().contains("kind = \"transverse\""), "{e}");
    let e = load(&iso.replace(
        "shear_fibre = 1e9",
        "critical_stretch = 1e-3\ncritical_stretch_fibre = 5e-3",
    ))
    .err()
    .unwrap();
    assert_eq!(e.key, "material.critical_stretch_fibre", "{e}");
    assert!(e.to_string().contains("needs a fibre"), "{e}");
}

/// The shipped fibre block, compressed along x (across the fibre, which runs along z): at the
/// middle section the lateral strain along y over the axial one is nu_p = 0.35, along z it is
/// nu_pt = 0.112, each within the free faces' bias of the uniform-spring block (+0.009 at this
/// width, `hooke moduli --transverse ... --fibre z`: 0.359 and 0.115).
#[test]
fn the_fibre_block_bulges_by_nu_p_across_and_nu_pt_along_the_fibre() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../cases/fibre_block.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let (sim, mut opts) = hooke_case::prepare(&path, &text, 1.0, &[]).unwrap();
    let out = std::env::temp_dir().join(format!("hooke_fibre_block_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    opts.out = out.clone();
    let (_, sim) = hooke_sim::run_keeping(sim, opts, &mut hooke_sim::Silent).unwrap();
    let _ = std::fs::remove_dir_all(&out);
    let (pos, u) = (&sim.body.lattice.pos, &sim.state.u);
    let mean = |pick: &dyn Fn(usize) -> bool, c: usize| {
        let v: Vec<f64> = (0..pos.len())
            .filter(|&i| pick(i))
            .map(|i| u.comp(c)[i])
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let near = |x: f64, at: f64| (x - at).abs() < 0.1e-3;
    let ex =
        (mean(&|i| near(pos.x()[i], 45e-3), 0) - mean(&|i| near(pos.x()[i], 25e-3), 0)) / 20e-3;
    let mid = |i: usize| (pos.x()[i] - 35e-3).abs() < 0.6e-3;
    let ey = (mean(&|i| mid(i) && near(pos.y()[i], 15e-3), 1)
        - mean(&|i| mid(i) && near(pos.y()[i], 0.0), 1))
        / 15e-3;
    let ez = (mean(&|i| mid(i) && near(pos.z()[i], 15e-3), 2)
        - mean(&|i| mid(i) && near(pos.z()[i], 0.0), 2))
        / 15e-3;
    let (nu_y, nu_z) = (-ey / ex, -ez / ex);
    eprintln!("axial strain {ex:e}: nu_y {nu_y:.4} (0.35), nu_z {nu_z:.4} (0.112)");
    assert!(ex < -4e-4, "axial strain {ex}");
    assert!((nu_y - 0.35).abs() < 0.015, "nu_y {nu_y}");
    assert!((nu_z - 0.112).abs() < 0.008, "nu_z {nu_z}");
}

const ORTHO: &str = r#"
[lattice]
kind = "cubic"
spacing = 1.0e-3

[material]
kind = "orthotropic"
youngs_x = 60e9
youngs_y = 50e9
youngs_z = 10e9
poisson_xy = 0.05
poisson_xz = 0.3
poisson_yz = 0.32
shear_yz = 4e9
shear_xz = 4.5e9
shear_xy = 5e9
density = 1600

[geometry]
box = { min = [0.0, 0.0, 0.0], max = [6e-3, 4e-3, 4e-3] }

[solver]
end_time = 1e-6
"#;

#[test]
fn orthotropic_bodies_are_built_and_their_mistakes_named() {
    let sim = load(ORTHO).unwrap();
    assert!(matches!(
        sim.anisotropic,
        Some(hooke_core::Anisotropic::Orthotropic(_))
    ));
    assert!(sim.body.lever.is_some());
    for (from, to, key, text, line) in [
        ("shear_xy = 5e9\n", "", "material.shear_xy", "missing", 7),
        (
            "density = 1600",
            "density = 1600\nfibre = [0, 0, 1]",
            "material.fibre",
            "kind = \"transverse\"",
            18,
        ),
        (
            "density = 1600",
            "density = 1600\nshear_fibre = 1e9",
            "material.shear_fibre",
            "kind = \"transverse\"",
            18,
        ),
        (
            "density = 1600",
            "density = 1600\npoisson = 0.3",
            "material.poisson",
            "remove it",
            18,
        ),
        (
            "shear_yz = 4e9",
            "shear_yz = 30e9",
            "material.kind",
            "negative stiffness",
            7,
        ),
    ] {
        let broken = ORTHO.replacen(from, to, 1);
        let e = load(&broken)
            .err()
            .unwrap_or_else(|| panic!("{to}: accepted"));
        let shown = e.to_string();
        assert_eq!(e.key, key, "{to}: {shown}");
        assert!(shown.contains(text), "{to}: {shown}");
        assert_eq!(e.line, line, "{to}: {shown}");
    }
}

/// The springs the run broke (not the pre-crack's), as their midpoints in the reference
/// configuration (m), and the nodes that lost at least a fifth of their springs (the damage
/// the crack maps draw).
fn broken_midpoints(case: &str, set: &[&str]) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../cases")
        .join(case);
    let text = std::fs::read_to_string(&path).unwrap();
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    let overrides = hooke_case::parse_overrides(&set).unwrap();
    let (sim, mut opts) = hooke_case::prepare(&path, &text, 1.0, &overrides).unwrap();
    let before = sim.state.alive().to_vec();
    let out =
        std::env::temp_dir().join(format!("hooke_{case}_{}_{}", std::process::id(), set.len()));
    let _ = std::fs::remove_dir_all(&out);
    opts.out = out.clone();
    let (_, sim) = hooke_sim::run_keeping(sim, opts, &mut hooke_sim::Silent).unwrap();
    let _ = std::fs::remove_dir_all(&out);
    let (lat, alive) = (&sim.body.lattice, sim.state.alive());
    let broken = (0..sim.body.springs())
        .filter(|&b| before[b] && !alive[b])
        .map(|b| {
            let [i, j] = lat.bonds.ends[b].map(|v| v as usize);
            let (p, q) = (lat.pos.get(i), lat.pos.get(j));
            [0.5 * (p.x + q.x), 0.5 * (p.y + q.y), 0.5 * (p.z + q.z)]
        })
        .collect();
    let damaged = (0..lat.len())
        .filter(|&n| {
            let row = lat.bonds.row(n);
            let total = row.len();
            let gone = row.filter(|&e| !alive[lat.bonds.bond[e] as usize]).count();
            5 * gone >= total
        })
        .map(|n| {
            let p = lat.pos.get(n);
            [p.x, p.y, p.z]
        })
        .collect();
    (broken, damaged)
}

/// The shipped notched fibre plate: with strong fibres across the notch (the case as shipped)
/// the crack turns at the notch tip and splits along the fibres, up and down (nine in ten new
/// breaks within 1.5 mm of the tip's x = 20 mm and none ahead of x = 24.5 mm, over y from
/// below 10 mm to above 50 mm); with the fibres
/// along the notch (`material.fibre = [1, 0, 0]`) it runs on along them as a damage band
/// (breaks past x = 50 mm, nine in ten damaged nodes ahead of the tip within 8 mm of the notch's
/// plane, no break on the other case's splitting line).
#[test]
#[ignore = "slow (90 s here): two fibre plates run to splitting; run with --ignored before changing fracture or anisotropy"]
fn a_notched_fibre_plate_splits_along_strong_fibres() {
    let (across, _) = broken_midpoints("fibre_notch.toml", &[]);
    assert!(across.len() > 200, "{} breaks", across.len());
    // The split: nine in ten breaks within 1.5 mm of x = 20 mm (the faces' springs split a
    // little wider), none ahead of the tip beyond x = 24.5 mm (the crack never cuts on across
    // the fibres).
    let off = across
        .iter()
        .filter(|m| (m[0] - 20e-3).abs() > 1.5e-3)
        .count();
    let far = across.iter().filter(|m| m[0] > 24.5e-3).count();
    let (lo, hi) = across
        .iter()
        .fold((1.0f64, 0.0f64), |(lo, hi), m| (lo.min(m[1]), hi.max(m[1])));
    eprintln!(
        "fibres across the notch: {} breaks, {off} more than 1.5 mm off the splitting line, {far} ahead of x = 24.5 mm, y from {:.1} to {:.1} mm",
        across.len(),
        lo * 1e3,
        hi * 1e3
    );
    assert!(
        (off as f64) < 0.1 * across.len() as f64 && far == 0,
        "breaks off the splitting line x = 20 mm: {off}, {far}"
    );
    assert!(lo < 10e-3 && hi > 50e-3, "split from y = {lo} to {hi}");

    let (along, damaged) = broken_midpoints("fibre_notch.toml", &["material.fibre=[1, 0, 0]"]);
    let far = along.iter().map(|m| m[0]).fold(0.0f64, f64::max);
    // Ahead of the tip, away from the far edge (whose free-face springs also break late in
    // the run): the damaged nodes (a fifth of their springs broken, what the crack map draws;
    // single springs across the weak matrix also break here and there) form a band along the
    // notch's plane.
    let ahead: Vec<&[f64; 3]> = damaged
        .iter()
        .filter(|m| m[0] > 25e-3 && m[0] < 55e-3)
        .collect();
    // The band's half-width: nine in ten of those breaks lie within it.
    let mut dy: Vec<f64> = ahead.iter().map(|m| (m[1] - 30.5e-3).abs()).collect();
    dy.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let band = dy[(0.9 * dy.len() as f64) as usize];
    let split = along
        .iter()
        .filter(|m| (m[0] - 20e-3).abs() < 1.5e-3 && (m[1] - 30.5e-3).abs() > 8e-3)
        .count();
    eprintln!(
        "fibres along the notch: {} breaks, reaching x = {:.1} mm; between x = 25 and 55 mm nine in ten of {} damaged nodes lie within {:.1} mm of the notch's plane; {split} on the other case's splitting line",
        along.len(),
        far * 1e3,
        ahead.len(),
        band * 1e3
    );
    assert!(far > 50e-3, "the crack stopped at x = {far}");
    assert!(band < 8e-3, "a band {band} m wide about the notch's plane");
    assert!(split < 20, "{split} breaks split along y at the tip");
}

/// The oblique plates' split: the breaks between y = 33 and 44 mm (above the tip, below the
/// grip's own damage), the angle to the notch of their least-squares line x = x0 + y cot(theta)
/// in degrees, and the breaks on the notch's plane ahead of the tip beyond x = 30 mm.
fn split_line(broken: &[[f64; 3]]) -> (usize, f64, usize) {
    let band: Vec<&[f64; 3]> = broken
        .iter()
        .filter(|m| m[1] > 33e-3 && m[1] < 44e-3)
        .collect();
    let n = band.len() as f64;
    let (my, mx) = (
        band.iter().map(|m| m[1]).sum::<f64>() / n,
        band.iter().map(|m| m[0]).sum::<f64>() / n,
    );
    let sxy: f64 = band.iter().map(|m| (m[1] - my) * (m[0] - mx)).sum();
    let syy: f64 = band.iter().map(|m| (m[1] - my) * (m[1] - my)).sum();
    let ahead = broken
        .iter()
        .filter(|m| m[0] > 30e-3 && (m[1] - 30.5e-3).abs() < 3e-3)
        .count();
    (band.len(), (syy / sxy).atan().to_degrees(), ahead)
}

/// Fibres at 60 degrees to the notch, on a lattice laid along them (`lattice.rotate_to`): the
/// crack leaves the notch's plane at the tip and runs along the fibres. The breaks between
/// y = 33 and 44 mm (above the tip, below the grip's own damage) lie on a line at 60 +- 6 degrees to the
/// notch (least squares), and fewer than 10 lie on the notch's plane ahead of the tip beyond
/// x = 30 mm.
#[test]
fn an_oblique_fibre_plate_splits_at_the_fibre_angle() {
    let (broken, _) = broken_midpoints("fibre_notch_oblique.toml", &[]);
    let (band, angle, ahead) = split_line(&broken);
    assert!(band > 100, "{band} breaks above the tip");
    eprintln!(
        "fibres at 60 degrees: {} breaks, {} between y = 33 and 44 mm on a line at {angle:.1} degrees; {ahead} on the notch's plane ahead of the tip",
        broken.len(),
        band
    );
    assert!(
        (angle - 60.0).abs() < 6.0,
        "the split runs at {angle} degrees"
    );
    // A crack running on along the notch would break hundreds there.
    assert!(ahead < 10, "{ahead} breaks ahead on the notch's plane");
}

/// The same plate on a random3d lattice (`cases/fibre_notch_random.toml`): no turned lattice,
/// the springs' stiffness and weights follow their directions; the crack still splits along
/// the fibres. Measured: 5869 breaks, 1161 between y = 33 and 44 mm on a line at 60.2
/// degrees; 73 (1.2 %) in a band 6 mm wide on the notch's plane ahead of the tip, scattered
/// damage of the random network rather than a crack (a crack running on along the notch would
/// break thousands there).
#[test]
#[ignore = "slow: half a minute of calibration and a 14 000-node run"]
fn a_random_lattice_fibre_plate_splits_at_the_fibre_angle() {
    let (broken, _) = broken_midpoints("fibre_notch_random.toml", &[]);
    let (band, angle, ahead) = split_line(&broken);
    assert!(band > 50, "{band} breaks above the tip");
    eprintln!(
        "random lattice, fibres at 60 degrees: {} breaks, {} between y = 33 and 44 mm on a line at {angle:.1} degrees; {ahead} on the notch's plane ahead of the tip",
        broken.len(),
        band
    );
    assert!(
        (angle - 60.0).abs() < 8.0,
        "the split runs at {angle} degrees"
    );
    assert!(
        ahead * 20 < broken.len(),
        "{ahead} of {} breaks ahead on the notch's plane",
        broken.len()
    );
}

/// `material.axes` turns an orthotropic material against the body and lays the lattice along
/// its axes: every spring then runs along a material axis or a face diagonal of two (none
/// along the body's own x at 30 degrees off); the mistakes name their key and line.
#[test]
fn turned_orthotropic_bodies_lay_the_lattice_along_their_axes() {
    let turned = ORTHO.replacen(
        "density = 1600",
        "density = 1600\naxes = [[0.8660254037844387, 0.5, 0], [-0.5, 0.8660254037844387, 0]]",
        1,
    );
    let sim = load(&turned).unwrap();
    let Some(hooke_core::Anisotropic::Orthotropic(o)) = sim.anisotropic else {
        panic!("an orthotropic material");
    };
    assert!((o.axes[0][1] - 0.5).abs() < 1e-15 && o.axes[2] == [0.0, 0.0, 1.0]);
    let lat = &sim.body.lattice;
    let a = lat.spacing;
    let mut along_x = 0;
    for b in 0..lat.bonds.len() {
        let [i, j] = lat.bonds.ends[b].map(|v| v as usize);
        let d = lat.reference_vector(i, j);
        let local = o
            .axes
            .map(|e| (e[0] * d[0] + e[1] * d[1] + e[2] * d[2]) / a);
        // Components in the material frame are 0 or +-1.
        for c in local {
            assert!(c.abs() < 1e-9 || (c.abs() - 1.0).abs() < 1e-9, "{local:?}");
        }
        along_x += (local[0].abs() > 0.5 && local[1].abs() < 0.5 && local[2].abs() < 0.5) as usize;
    }
    assert!(along_x > 10);
    // Stepped faces: no node of the turned lattice lies outside the box.
    assert!((0..lat.len()).all(|i| {
        let p = lat.pos.get(i);
        p.x >= -1e-12 && p.x <= 6e-3 + 1e-12 && p.y >= -1e-12 && p.y <= 4e-3 + 1e-12
    }));
    for (text, key, shown, line) in [
        (
            turned.replacen("kind = \"orthotropic\"", "kind = \"orthotropic\"\n", 1).replacen(
                "axes = [[0.8660254037844387, 0.5, 0], [-0.5, 0.8660254037844387, 0]]",
                "axes = [[1, 0, 0], [0.1, 1, 0]]",
                1,
            ),
            "material.axes",
            "not perpendicular",
            19,
        ),
        (
            turned.replacen(
                "axes = [[0.8660254037844387, 0.5, 0], [-0.5, 0.8660254037844387, 0]]",
                "axes = [[1, 0, 0]]",
                1,
            ),
            "material.axes",
            "two directions",
            18,
        ),
        (
            turned.replacen("spacing = 1.0e-3", "spacing = 1.0e-3\nrotate_to = [1, 0, 0]", 1),
            "lattice.rotate_to",
            "remove lattice.rotate_to",
            5,
        ),
        (
            BASE.replacen("density = 1500", "density = 1500\naxes = [[1, 0, 0], [0, 1, 0]]", 1),
            "material.axes",
            "kind = \"orthotropic\"",
            15,
        ),
        (
            format!(
                "{turned}\n[[boundary]]\nregion = {{ box = {{ min = [-1, -1, -1], max = [1, 1e-3, 1] }} }}\ntraction = [{{ value = [0, -1e6, 0], normal = \"y\" }}]\n"
            ),
            "boundary[0].traction[0]",
            "stepped faces",
            0,
        ),
    ] {
        let e = load(&text).err().unwrap_or_else(|| panic!("{key}: accepted"));
        let msg = e.to_string();
        assert_eq!(e.key, key, "{msg}");
        assert!(msg.contains(shown), "{msg}");
        if line > 0 {
            assert_eq!(e.line, line, "{msg}");
        }
    }
}

/// The notched plate as a random2d plate (`cases/fibre_notch_plate.toml`, plane stress): with
/// the fibres at 60 degrees in the plane the crack leaves the notch's plane at the tip and runs
/// up towards the fibres, then flattens (measured: the breaks between y = 33 and 44 mm on a line
/// at 24.4 degrees, held to 15-65; the 3D slab's, `fibre_notch_random.toml`, at 60; near the
/// tip the plate's runs at 50 degrees, `docs/anisotropy.md`, "Plates"); with the fibres along the notch
/// (`material.fibre = [1, 0, 0]`) it runs on along the notch's plane to the far edge (measured:
/// nine in ten breaks between x = 22 and 55 mm within 3.5 mm of the plane, held to 5; short
/// branches hang below it).
#[test]
#[ignore = "slow (80 s here): a calibrated random plate run to splitting; run with --ignored before changing fracture or anisotropy"]
fn a_random_plate_with_oblique_fibres_deflects_its_crack() {
    let (oblique, _) = broken_midpoints("fibre_notch_plate.toml", &[]);
    let (band, angle, ahead) = split_line(&oblique);
    eprintln!(
        "plate, fibres at 60 degrees: {} breaks, {band} between y = 33 and 44 mm on a line at {angle:.1} degrees; {ahead} on the notch's plane ahead of the tip",
        oblique.len()
    );
    assert!(band > 50, "{band} breaks above the tip");
    assert!(
        angle > 15.0 && angle < 65.0,
        "the crack runs at {angle} degrees"
    );
    assert!(
        ahead * 20 < oblique.len(),
        "{ahead} of {} breaks ahead on the notch's plane",
        oblique.len()
    );
    let (along, _) = broken_midpoints("fibre_notch_plate.toml", &["material.fibre=[1, 0, 0]"]);
    // The least-squares line of the breaks past the tip, y = y0 + x tan(theta), short of the
    // far edge (which splits along itself once the crack arrives).
    let past: Vec<&[f64; 3]> = along
        .iter()
        .filter(|m| m[0] > 22e-3 && m[0] < 55e-3)
        .collect();
    let n = past.len() as f64;
    let (mx, my) = (
        past.iter().map(|m| m[0]).sum::<f64>() / n,
        past.iter().map(|m| m[1]).sum::<f64>() / n,
    );
    let sxy: f64 = past.iter().map(|m| (m[0] - mx) * (m[1] - my)).sum();
    let sxx: f64 = past.iter().map(|m| (m[0] - mx) * (m[0] - mx)).sum();
    let flat = (sxy / sxx).atan().to_degrees();
    let reach = along.iter().map(|m| m[0]).fold(0.0f64, f64::max);
    // The band's half-width: nine in ten breaks past the tip lie within it.
    let mut dy: Vec<f64> = past.iter().map(|m| (m[1] - 30.25e-3).abs()).collect();
    dy.sort_by(|a, b| a.total_cmp(b));
    let width = dy[(0.9 * n) as usize];
    eprintln!(
        "plate, fibres along the notch: {} breaks, {} between x = 22 and 55 mm on a line at {flat:.1} degrees through y = {:.1} mm, nine in ten within {:.1} mm of the notch's plane, reaching x = {:.1} mm",
        along.len(),
        past.len(),
        my * 1e3,
        width * 1e3,
        reach * 1e3
    );
    assert!(
        past.len() > 50 && reach > 50e-3,
        "the crack stopped at x = {reach}"
    );
    assert!(
        width < 5e-3,
        "nine in ten breaks within {width} m of the notch's plane"
    );
}

/// A random2d plate takes any fibre and orthotropic axes turned about z only; other axes name
/// the key and the fix. A valid plate is built with the
/// plate's design (its springs' stiffness follows the in-plane direction).
#[test]
fn plate_materials_need_z_as_a_material_axis() {
    let plate = BASE
        .replacen(
            "kind = \"cubic\"",
            "kind = \"random2d\"\nthickness = 2e-3",
            1,
        )
        .replace("max = [6e-3, 4e-3, 4e-3]", "max = [6e-3, 4e-3, 0.0]");
    // A fibre out of the plane: the plate is orthotropic in the fibre's projection (x here)
    // and y, stiffer along x than y (E_x = E(45 degrees) = 10.9 GPa against E_y = E_p = 10 GPa).
    let sim = load(&plate.replace("fibre = [0, 0, 1]", "fibre = [1, 0, 1]")).unwrap();
    let d = &sim
        .random_design
        .as_ref()
        .expect("a calibrated design")
        .design;
    assert!(d.kappa_at([1.0, 0.0, 0.0]) > d.kappa_at([0.0, 1.0, 0.0]));
    let ortho = plate.replace(
        "kind = \"transverse\"\nyoungs_plane = 10e9\nyoungs_fibre = 25e9\npoisson_plane = 0.35\npoisson_fibre = 0.28\nshear_fibre = 4e9\nfibre = [0, 0, 1]",
        "kind = \"orthotropic\"\nyoungs_x = 20e9\nyoungs_y = 15e9\nyoungs_z = 10e9\npoisson_xy = 0.2\npoisson_xz = 0.25\npoisson_yz = 0.3\nshear_yz = 4e9\nshear_xz = 5e9\nshear_xy = 6e9\naxes = [[1, 1, 0], [-1, 1, 1]]",
    );
    assert!(ortho.contains("orthotropic"));
    let Err(e) = load(&ortho) else {
        panic!("axes with none along z were accepted");
    };
    assert_eq!(e.key, "material.axes", "{e}");
    assert!(e.to_string().contains("turn them about z only"), "{e}");
    // Turned about z: built, and the springs follow their direction (stiffest along the
    // material x at 45 degrees).
    let sim = load(&ortho.replace("[-1, 1, 1]", "[-1, 1, 0]")).unwrap();
    let design = sim.random_design.as_ref().expect("a calibrated design");
    assert_eq!(design.design.dim, 2);
    let d = &design.design;
    let s = 0.5f64.sqrt();
    assert!(d.kappa_at([s, s, 0.0]) > d.kappa_at([-s, s, 0.0]));
}
