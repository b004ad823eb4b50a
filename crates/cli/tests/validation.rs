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

/// Reference positions (x, y) and damage of every node of one frame.
fn damage(path: &Path) -> Vec<(f64, f64, f64)> {
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
        .map(|i| (pts[3 * i] - u[3 * i], pts[3 * i + 1] - u[3 * i + 1], d[i]))
        .collect()
}

/// The glass-plate benchmark at full resolution and nu = 0.22: one crack runs from the notch
/// and branches before the far edge (two damaged bands, above and below the notch line), and
/// its tip stays slower than the Rayleigh wave (about 3.1 km/s for this glass). With the
/// measured lattice toughness (G_c matched in steady growth) the crack runs straight for only
/// about 4 mm before it roughens and branches, near 62 mm: the straight stretch checked is
/// 1 to 4 mm past the notch.
#[test]
#[ignore = "full resolution: about a minute"]
fn glass_plate_branches_below_the_rayleigh_speed() {
    let case = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../cases/glass_branching.toml");
    let out = std::env::temp_dir().join(format!("hooke-glass-{}", std::process::id()));
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
    let fs = frames(&out, "glass_branching");
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
        .windows(2)
        .map(|w| (w[1].1 - w[0].1) / (w[1].0 - w[0].0))
        .fold(0.0, f64::max);
    let c_r = 3100.0;
    // Branching: far from the notch, damage on both sides of the notch line, well apart.
    let far: Vec<&(f64, f64, f64)> = last
        .iter()
        .filter(|n| n.2 >= 0.2 && n.0 > notch_end + 25e-3)
        .collect();
    let above = far.iter().filter(|n| n.1 > y_c + 2e-3).count();
    let below = far.iter().filter(|n| n.1 < y_c - 2e-3).count();
    // Before branching: a single crack on the notch line.
    let near: Vec<&(f64, f64, f64)> = last
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
