//! Derived fields against the quantities they stand for.

use hooke_core::material::{Elastic, PlaneModel};
use hooke_core::random::RandomSpec;
use hooke_core::{law, Body, Lattice, State};
use hooke_io::fields::derived;

/// A random body under a non-uniform deformation, with some springs broken.
fn deformed(dim: usize) -> (Body, State) {
    let hi = if dim == 3 {
        [6e-3, 4e-3, 3e-3]
    } else {
        [8e-3, 5e-3, 0.0]
    };
    let lattice = Lattice::random(
        dim,
        [0.0; 3],
        hi,
        1e-3,
        if dim == 2 { 2e-3 } else { 1.0 },
        RandomSpec::default(),
        &|_| true,
    )
    .unwrap();
    let m = Elastic {
        youngs: 70e9,
        poisson: 0.3,
        density: 2500.0,
    };
    let body = Body::new(lattice, &m, PlaneModel::Stress).unwrap();
    let mut state = State::new(&body);
    let pos = &body.lattice.pos;
    for i in 0..body.nodes() {
        let (x, y, z) = (pos.x()[i], pos.y()[i], pos.z()[i]);
        state.u.x_mut()[i] = 1e-6 * (x * 1e3).sin() + 2e-7 * y * 1e3;
        state.u.y_mut()[i] = 3e-7 * (x * y * 1e6).cos();
        if dim == 3 {
            state.u.z_mut()[i] = 1e-7 * z * 1e3;
        }
    }
    for b in (0..body.springs()).step_by(7) {
        state.kill_bond(&body, b);
    }
    (body, state)
}

/// On random lattices each node stands for its own volume: the strain energy density times the
/// node's volume, summed, is the strain energy (1e-9 relative). With the mean cell volume it was
/// off by the scatter of the node volumes.
#[test]
fn strain_energy_density_integrates_to_the_strain_energy_on_random_lattices() {
    for dim in [2, 3] {
        let (body, state) = deformed(dim);
        assert!(body.lattice.cells.is_some());
        let d = derived(&body, &state);
        let sum: f64 = (0..body.nodes())
            .map(|i| d.energy_density[i] * body.lattice.node_volume(i))
            .sum();
        let u = law::energy(&body, &state.u, state.springs(&body), state.norm()).total();
        let rel = ((sum - u) / u).abs();
        eprintln!("random{dim}d: sum(w V_n) = {sum:.12e} J, U = {u:.12e} J, relative {rel:.1e}");
        assert!(rel < 1e-9, "dim {dim}: {sum} vs {u} ({rel:.1e})");
        // The volumes really differ, so the mean volume would not do.
        let v: Vec<f64> = (0..body.nodes())
            .map(|i| body.lattice.node_volume(i))
            .collect();
        let (lo, hi) = v
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(hi > 1.5 * lo, "node volumes {lo:e}..{hi:e}");
    }
}

/// The frame carries each node's volume and id.
#[test]
fn frames_carry_node_volume_and_id() {
    let (body, state) = deformed(2);
    let vtk = hooke_io::vtk::frame_vtk(&body, &state, Default::default(), false);
    let vtkio::model::DataSet::UnstructuredGrid { pieces, .. } = &vtk.data else {
        panic!("not an unstructured grid");
    };
    let vtkio::model::Piece::Inline(piece) = &pieces[0] else {
        panic!("not inline");
    };
    let get = |name: &str| {
        piece
            .data
            .point
            .iter()
            .find_map(|a| match a {
                vtkio::model::Attribute::DataArray(d) if d.name == name => Some(d.data.clone()),
                _ => None,
            })
            .unwrap_or_else(|| panic!("no {name}"))
    };
    let vol: Vec<f64> = get("node_volume").cast_into().unwrap();
    let ids: Vec<u64> = get("node_id").cast_into().unwrap();
    for i in 0..body.nodes() {
        assert_eq!(vol[i], body.lattice.node_volume(i));
        assert_eq!(ids[i], i as u64);
    }
}

/// The one-evaluation frame fields are the separate passes' values, bit for bit: pools and forces
/// as `update_forces`, the strain energy as `energy`, and the virial stress as `node_virial`
/// (to round-off: its length is nalgebra's norm), on random lattices with broken springs.
#[test]
fn frame_fields_are_the_separate_passes() {
    for dim in [2, 3] {
        let (body, mut state) = deformed(dim);
        let f = law::frame_fields(&body, &state.u, state.springs(&body), state.norm());
        law::update_forces(&body, &mut state);
        let bits = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(bits(&f.pool, &state.pool), "dim {dim}: pools differ");
        for c in 0..3 {
            assert!(
                bits(f.force.comp(c), state.f.comp(c)),
                "dim {dim}: forces differ"
            );
        }
        let u = law::energy(&body, &state.u, state.springs(&body), state.norm());
        assert_eq!(f.strain, u);
        let t = law::spring_tensions(&body, &state.u, state.springs(&body), &state.pool);
        let smax = f
            .stress
            .iter()
            .flatten()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(smax > 0.0);
        for i in 0..body.nodes() {
            let s = law::node_virial(&body, &state.u, &t, i);
            for r in 0..3 {
                for c in 0..3 {
                    let d = (s[(r, c)] - f.stress[i][3 * r + c]).abs();
                    assert!(d <= 1e-14 * smax, "dim {dim} node {i}: stress off by {d:e}");
                }
            }
        }
    }
}

/// A frame on disk is the file vtkio writes for the frame's model, byte for byte: whole and in
/// pieces, with springs, in 2D and 3D (the series streams it through its own encoder).
#[test]
fn frames_on_disk_are_vtkios_files() {
    let dir = std::env::temp_dir().join(format!("hooke-vtu-bytes-{}", std::process::id()));
    for dim in [2, 3] {
        let (body, state) = deformed(dim);
        let damage: Vec<f64> = (0..body.nodes()).map(|i| (i % 5) as f64 / 4.0).collect();
        let region: Vec<u32> = (0..body.nodes() as u32).map(|i| i % 3).collect();
        let extras = hooke_io::FrameExtras {
            damage: Some(&damage),
            region: Some(&region),
            ..Default::default()
        };
        let n = body.nodes();
        for (springs, pieces) in [(false, None), (true, None), (true, Some(n / 3))] {
            let _ = std::fs::remove_dir_all(&dir);
            let mut series = hooke_io::VtkSeries::create(&dir, "f", springs).unwrap();
            let nodes = match pieces {
                Some(cut) => {
                    series.set_pieces(1, vec![0..cut, cut..n]);
                    cut..n
                }
                None => 0..n,
            };
            let path = series.write(&body, &state, extras).unwrap();
            let ours = std::fs::read(&path).unwrap();
            let model = hooke_io::vtk::frame_vtk_nodes(&body, &state, extras, springs, nodes);
            let mut theirs = Vec::new();
            model.write_xml(&mut theirs).unwrap();
            assert!(
                ours == theirs,
                "dim {dim}, springs {springs}, pieces {pieces:?}: {} bytes against vtkio's {}",
                ours.len(),
                theirs.len()
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
