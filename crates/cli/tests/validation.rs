//! Full-resolution validation runs (slow: `cargo test --release -p hooke-cli --test validation
//! -- --ignored --nocapture`).

use std::path::{Path, PathBuf};
use std::process::Command;

use vtkio::model::{Attribute, DataSet, IOBuffer, Vtk};

fn frames(dir: &Path, stem: &str) -> Vec<(f64, PathBuf)> {
    let pvd = std::fs::read_to_string(dir.join(format!("{stem}.pvd"))).unwrap();
    pvd.lines()
        .filter_map(|l| {
            let t = l
                .split("timestep=\"")
                .nth(1)?
                .split('"')
                .next()?
                .parse()
                .ok()?;
            let f = l.split("file=\"").nth(1)?.split('"').next()?;
            Some((t, dir.join(f)))
        })
        .collect()
}

/// Run `cases/STEM.toml` at full resolution into a fresh temporary directory: that directory
/// and the frames.
fn run_case(stem: &str) -> (PathBuf, Vec<(f64, PathBuf)>) {
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../cases/{stem}.toml"));
    let out = std::env::temp_dir().join(format!("hooke-{stem}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = Command::new(env!("CARGO_BIN_EXE_hooke"))
        .args([
            "run",
            case.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let fs = frames(&out, stem);
    (out, fs)
}

/// Reference positions (x, y), damage and vertical displacement of every node of one frame.
fn damage(path: &Path) -> Vec<(f64, f64, f64, f64)> {
    let vtk = Vtk::import(path).unwrap();
    let DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
        panic!("not an unstructured grid")
    };
    let piece = pieces[0].load_piece_data(None).unwrap();
    let IOBuffer::F64(pts) = &piece.points else {
        panic!("points not f64")
    };
    let get = |name: &str| -> Vec<f64> {
        match piece.data.point.iter().find(|a| a.name() == name).unwrap() {
            Attribute::DataArray(d) => match &d.data {
                IOBuffer::F64(v) => v.clone(),
                _ => panic!(),
            },
            _ => panic!(),
        }
    };
    let (u, d) = (get("displacement"), get("damage"));
    (0..d.len())
        .map(|i| {
            (
                pts[3 * i] - u[3 * i],
                pts[3 * i + 1] - u[3 * i + 1],
                d[i],
                u[3 * i + 1],
            )
        })
        .collect()
}

/// The glass-plate benchmark at full resolution and nu = 0.22: one crack runs from the notch
/// and branches before the far edge (two damaged bands, above and below the notch line), and
/// its tip stays slower than the Rayleigh wave (about 3.1 km/s for this glass). With the
/// measured lattice toughness (G_c matched in steady growth) the crack runs straight for only
/// about 4 mm before it roughens and branches, near 62 mm: the straight stretch checked is
/// 1 to 4 mm past the notch. The tip speed is taken over two frame intervals (4 us, about
/// 10 mm of growth): over one, the farthest damaged node jumps when damage nucleates ahead of
/// the tip as the crack branches, and that jump is chaotic. Measured with `tools/crack_tip.py
/// OUT --rayleigh 3100 --window K` on runs at `solver.safety` 0.76, 0.78 and 0.80, with and
/// without cell weights: over one interval 0.71 to 1.33 c_R, over two 0.68 to 0.86 c_R.
#[test]
#[ignore = "full resolution: about a minute"]
fn glass_plate_branches_below_the_rayleigh_speed() {
    let (out, fs) = run_case("glass_branching");
    let (y_c, notch_end) = (20.05e-3, 50e-3);
    // Tip: the farthest newly damaged node beyond the notch, frame by frame.
    let first: Vec<bool> = damage(&fs[0].1).iter().map(|n| n.2 >= 0.2).collect();
    let mut tips = Vec::new();
    let mut last = Vec::new();
    for (t, f) in &fs {
        last = damage(f);
        let tip = last
            .iter()
            .zip(&first)
            .filter(|(n, &was)| n.2 >= 0.2 && !was)
            .map(|(n, _)| n.0)
            .fold(notch_end, f64::max);
        tips.push((*t, tip));
    }
    let speed = tips
        .windows(3)
        .map(|w| (w[2].1 - w[0].1) / (w[2].0 - w[0].0))
        .fold(0.0, f64::max);
    let c_r = 3100.0;
    // Branching: far from the notch, damage on both sides of the notch line, well apart.
    let far: Vec<&(f64, f64, f64, f64)> = last
        .iter()
        .filter(|n| n.2 >= 0.2 && n.0 > notch_end + 25e-3)
        .collect();
    let above = far.iter().filter(|n| n.1 > y_c + 2e-3).count();
    let below = far.iter().filter(|n| n.1 < y_c - 2e-3).count();
    // Before branching: a single crack on the notch line.
    let near: Vec<&(f64, f64, f64, f64)> = last
        .iter()
        .filter(|n| n.2 >= 0.2 && n.0 > notch_end + 1e-3 && n.0 < notch_end + 4e-3)
        .collect();
    let straight = near.iter().all(|n| (n.1 - y_c).abs() < 1e-3);
    eprintln!("crack tip reached x = {:.1} mm, largest speed {:.0} m/s = {:.2} c_R; far damage {above} above and {below} below the notch line; straight before branching: {straight}", tips.last().unwrap().1 * 1e3, speed, speed / c_r);
    assert!(
        tips.last().unwrap().1 > notch_end + 25e-3,
        "the crack did not run"
    );
    assert!(
        straight && !near.is_empty(),
        "the crack does not start straight"
    );
    assert!(
        above > 5 && below > 5,
        "no branching: {above} damaged nodes above, {below} below"
    );
    assert!(
        speed < c_r,
        "tip speed {speed} m/s not below the Rayleigh speed"
    );
    std::fs::remove_dir_all(&out).ok();
}

/// The mode-I plate at full resolution (`cases/mode1_plate.toml`: glass, random lattice, edges
/// pulled apart): one crack leaves the notch tip and runs straight across the plate, its tip
/// slower than the Rayleigh wave (about 3.1 km/s for this glass). Straight: until it reaches
/// the far edge, every newly damaged node lies within 5 mm (10 spacings) of the notch line, in a
/// 30 mm high plate, and the mean line of the damage drifts by less than 1.5 mm. One crack:
/// at the end, from x = 20 to 50 mm, the mean vertical displacement 5-7 mm above the notch line
/// minus that 5-7 mm below is more than 0.8 of the loaded edges' opening, which a
/// traction-free cut gives (an uncut, uniformly strained plate gives 12/30 = 0.4). Measured:
/// the crack crosses 45 mm in about 16 us (2.4 km/s on average, up to 3.0 km/s over three
/// frames, 0.97 of the 3.1 km/s used here, 0.95 of the exact plane-stress c_R of 3.17 km/s),
/// band 3.3 mm, drift 0.01 mm, opening 0.92. Other node sets (seed = 2, 3): band 4.2 and 2.3
/// mm, tip speed up to 3.0 and 2.8 km/s.
#[test]
#[ignore = "full resolution: about 10 s"]
fn mode_one_plate_grows_one_straight_crack_below_the_rayleigh_speed() {
    let (out, fs) = run_case("mode1_plate");
    let (y_c, notch_end, far_edge) = (15.05e-3, 15e-3, 60e-3);
    let first: Vec<bool> = damage(&fs[0].1).iter().map(|n| n.2 >= 0.2).collect();
    let mut tips = Vec::new();
    let mut band: f64 = 0.0;
    let mut path = Vec::new();
    for (t, f) in &fs {
        let nodes = damage(f);
        let fresh: Vec<&(f64, f64, f64, f64)> = nodes
            .iter()
            .zip(&first)
            .filter(|(n, &was)| n.2 >= 0.2 && !was)
            .map(|(n, _)| n)
            .collect();
        let tip = fresh.iter().map(|n| n.0).fold(notch_end, f64::max);
        tips.push((*t, tip));
        if tip >= far_edge - 2e-3 {
            // Through: what the edges do after the plate has split is not the crack's path.
            break;
        }
        band = fresh.iter().map(|n| (n.1 - y_c).abs()).fold(band, f64::max);
        path = fresh.iter().map(|n| (n.0, n.1)).collect();
    }
    // Speed inside the plate, over three frames (about 7 mm, 14 spacings: the farthest damaged
    // node jitters by a spacing on the random lattice). The last 5 mm before the free edge are
    // left out, where the ligament fails as a whole and the tip jumps.
    let speed = tips
        .windows(4)
        .filter(|w| w[3].1 < far_edge - 5e-3)
        .map(|w| (w[3].1 - w[0].1) / (w[3].0 - w[0].0))
        .fold(0.0, f64::max);
    let c_r = 3100.0;
    let reached = tips.last().unwrap().1;
    // Mean line of the damage over the first and the last third of the path.
    let third = |lo: f64, hi: f64| {
        let v: Vec<f64> = path
            .iter()
            .filter(|p| p.0 >= lo && p.0 < hi)
            .map(|p| p.1)
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let span = path.iter().map(|p| p.0).fold(notch_end, f64::max) - notch_end;
    let drift = (third(notch_end + 2.0 * span / 3.0, f64::INFINITY)
        - third(notch_end, notch_end + span / 3.0))
    .abs();
    eprintln!(
        "mode-I plate: tip reached x = {:.1} mm, band {:.2} mm, drift {:.2} mm, largest speed {:.0} m/s = {:.2} c_R",
        reached * 1e3,
        band * 1e3,
        drift * 1e3,
        speed,
        speed / c_r
    );
    // One cut: in the last frame, across the damage band, the halves have moved apart by the
    // loaded edges' whole opening (the cut halves carry no load, so their strain is gone).
    let last = damage(&fs.last().unwrap().1);
    let mean_uy = |x0: f64, x1: f64, y0: f64, y1: f64| {
        let v: Vec<f64> = last
            .iter()
            .filter(|n| n.0 >= x0 && n.0 < x1 && n.1 >= y0 && n.1 < y1)
            .map(|n| n.3)
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let edges = mean_uy(0.0, 1.0, 29e-3, 1.0) - mean_uy(0.0, 1.0, -1.0, 1e-3);
    let opening = (0..6)
        .map(|k| {
            let x0 = 20e-3 + 5e-3 * k as f64;
            (mean_uy(x0, x0 + 5e-3, y_c + 5e-3, y_c + 7e-3)
                - mean_uy(x0, x0 + 5e-3, y_c - 7e-3, y_c - 5e-3))
                / edges
        })
        .fold(f64::INFINITY, f64::min);
    eprintln!("mode-I plate: opening across the band over the edges' opening: {opening:.3}");
    assert!(
        reached >= far_edge - 2e-3,
        "the crack did not cross the plate"
    );
    assert!(opening > 0.8, "the plate is not cut: opening {opening}");
    assert!(band < 5e-3, "damage {band} m off the notch line");
    assert!(drift < 1.5e-3, "the crack drifts by {drift} m");
    assert!(speed > 0.0 && speed < c_r, "tip speed {speed} m/s");
    std::fs::remove_dir_all(&out).ok();
}

/// The Kalthoff-Winkler test at full resolution (`cases/kalthoff_winkler.toml`: random lattice
/// at 0.25 mm, plane stress, 1.5 mm wide notches, a rigid projectile at 32 m/s): a crack leaves
/// each notch end steeply towards the back of the plate, away from the impact zone, not along
/// the notch line (the shear-band mode). The angle is measured by `tools/crack_angle.py` at
/// 30 us, before the cracks branch, from the notch end's outer corner: wanted between 55 and 85
/// degrees above the upper notch and below the lower one (Kalthoff and Winkler: about 70).
/// Measured +64 / -66 degrees (seed 1; seed 2: +67 / -70). Needs python3 with numpy and meshio
/// (`tools/requirements.txt`).
#[test]
#[ignore = "full resolution: about 4 minutes"]
fn kalthoff_winkler_cracks_leave_the_notches_steeply() {
    let (out, _) = run_case("kalthoff_winkler");
    let angles = kalthoff_winkler_angles(&out, 1);
    eprintln!("Kalthoff-Winkler crack angles at 30 us: {angles:?} degrees");
    assert_eq!(angles.len(), 2, "{angles:?}");
    assert!(
        (55.0..=85.0).contains(&angles[0]) && (-85.0..=-55.0).contains(&angles[1]),
        "crack angles {angles:?}"
    );
    std::fs::remove_dir_all(&out).ok();
}

/// The crack angles `tools/crack_angle.py` measures at 30 us from the two notch ends' outer
/// corners (upper, then lower; with `slabs` > 1, each followed by its slabs of the thickness).
fn kalthoff_winkler_angles(out: &Path, slabs: usize) -> Vec<f64> {
    let tool = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/crack_angle.py");
    let o = Command::new("python3")
        .arg(&tool)
        .arg(out)
        .args([
            "--tip",
            "50e-3,125.75e-3,1",
            "--tip",
            "50e-3,74.25e-3,-1",
            "--ahead",
            "--time",
            "30e-6",
            "--radius",
            "30e-3",
            "--slabs",
            &slabs.to_string(),
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    text.lines()
        .filter_map(|l| l.split(": ").nth(2)?.split(" degrees").next()?.parse().ok())
        .collect()
}

/// The Kalthoff-Winkler plate in 3D (`cases/kalthoff_winkler_3d.toml`: random3d lattice at
/// 0.5 mm, 18 spacings through the 9 mm thickness, the projectile a rigid box): the cracks leave
/// the notch ends at 55 to 85 degrees through the whole thickness, measured in three slabs of
/// it as in 2D. Measured +68.9 / -71.5 degrees over the thickness, slabs +67.6, +68.5, +70.5 and
/// -72.3, -70.7, -71.7 with the release-rate random3d toughness (with the earlier,
/// dissipation-based one +69.6 / -72.6; the 2D case: +64 / -66; Kalthoff and Winkler: about 70).
#[test]
#[ignore = "full resolution: about 10 minutes on 2 cores, 1.3 M nodes"]
fn kalthoff_winkler_3d_cracks_leave_the_notches_steeply_through_the_thickness() {
    let (out, _) = run_case("kalthoff_winkler_3d");
    let angles = kalthoff_winkler_angles(&out, 3);
    eprintln!("Kalthoff-Winkler 3D crack angles at 30 us (whole, then 3 slabs, per notch): {angles:?} degrees");
    assert_eq!(angles.len(), 8, "{angles:?}");
    let (upper, lower) = angles.split_at(4);
    assert!(
        upper.iter().all(|a| (55.0..=85.0).contains(a))
            && lower.iter().all(|a| (-85.0..=-55.0).contains(a)),
        "crack angles {angles:?}"
    );
    std::fs::remove_dir_all(&out).ok();
}

/// Winkler's L-panel (`cases/l_panel.toml`: concrete with bilinear softening springs, f_t 2.7
/// MPa, G_f 65 J/m^2, random3d at 7 mm, the platen at 25 mm/s): the platen force peaks within
/// 15 % of the experiment's 7 kN and then softens (below half the peak by 0.5 mm), and the crack
/// from the re-entrant corner (250, 250) mm curves upwards to the left edge, which it reaches
/// between y = 270 and 340 mm (the experiment: near 300 mm). Measured: 7.42 kN at 0.236 mm
/// (7.56 kN with an earlier version); the crack at the left edge at y = 313 mm.
#[test]
#[ignore = "full resolution: about 5 minutes on 2 cores"]
fn l_panel_peaks_near_7_kn_and_its_crack_curves_up() {
    let (out, fs) = run_case("l_panel");
    // The platen's load (the lattice's reaction on it, opposing its upward motion) against its
    // travel.
    let text = std::fs::read_to_string(out.join("l_panel_contact.csv")).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
    let (ry, y) = (col("reaction_y"), col("y"));
    let rows: Vec<(f64, f64)> = lines
        .map(|l| l.split(',').collect::<Vec<_>>())
        .map(|f| (f[y].parse().unwrap(), -f[ry].parse::<f64>().unwrap()))
        .collect();
    let y0 = rows[0].0;
    let (at, peak) =
        rows.iter().enumerate().fold(
            (0, f64::MIN),
            |m, (i, r)| if r.1 > m.1 { (i, r.1) } else { m },
        );
    let travel_at_peak = rows[at].0 - y0;
    let after: Vec<f64> = rows
        .iter()
        .filter(|r| r.0 - y0 > 0.5e-3)
        .map(|r| r.1)
        .collect();
    eprintln!(
        "L-panel: peak {peak:.0} N at {:.3} mm; load past 0.5 mm: {:.0} N at most",
        travel_at_peak * 1e3,
        after.iter().cloned().fold(f64::MIN, f64::max)
    );
    assert!((peak / 7e3 - 1.0).abs() < 0.15, "peak {peak} N");
    assert!(
        !after.is_empty() && after.iter().all(|&f| f < 0.5 * peak),
        "no softening branch"
    );
    // The crack: damaged nodes (damage >= 0.1) of the last frame in the leg (x < 250 mm),
    // their median height by 25 mm wide columns.
    let nodes = damage(&fs.last().unwrap().1);
    let median_y = |x0: f64| -> Option<f64> {
        let mut ys: Vec<f64> = nodes
            .iter()
            .filter(|n| n.2 >= 0.1 && n.0 >= x0 && n.0 < x0 + 25e-3 && n.1 > 0.1)
            .map(|n| n.1)
            .collect();
        ys.sort_by(f64::total_cmp);
        (ys.len() >= 5).then(|| ys[ys.len() / 2])
    };
    let path: Vec<Option<f64>> = (0..10).map(|k| median_y(k as f64 * 25e-3)).collect();
    eprintln!("L-panel crack, median y per 25 mm column from x = 0: {path:.3?}");
    let edge = path[0].expect("the crack reaches the left edge");
    assert!(
        (0.27..=0.34).contains(&edge),
        "the crack meets the left edge at y = {edge}"
    );
    let corner = path[9].expect("the crack starts at the corner");
    assert!(
        edge > corner + 0.02,
        "the crack does not curve upwards: {path:?}"
    );
    std::fs::remove_dir_all(&out).ok();
}
