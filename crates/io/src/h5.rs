//! HDF5 + XDMF output for large runs (cargo feature `hdf5`; needs the system HDF5 library,
//! `tools/install-hdf5.sh`).
//!
//! One `.h5` file per run holds the reference mesh (`/mesh/points`, `/mesh/vertices`) and one
//! group per frame (`/frames/STEP/displacement`, `velocity`, `damage`, `pool_ratio`,
//! `strain_energy_density`, `stress`), chunked and deflate-compressed. An `.xdmf` file describes
//! the time series in the layout meshio's `TimeSeriesReader` and ParaView's XDMF3 reader read: a
//! uniform grid with the mesh, and a temporal collection whose grids include it and carry the
//! frame's point data; warp by `displacement` to see the deformed body.
//!
//! The `.h5` file is flushed after every frame and the `.xdmf` is rewritten atomically, listing
//! only complete frames. HDF5 itself is not crash-safe: a run killed in the middle of writing a
//! frame can damage the `.h5`, so the VTK series remains the crash-safe output.

use std::path::{Path, PathBuf};

use hooke_core::{Body, Real, State};

use crate::error::{io, IoError};
use crate::fields::derived;
use crate::vtk::{write_atomic, FrameExtras};

/// An HDF5 time series with its XDMF description.
pub struct H5Series {
    file: hdf5_metno::File,
    h5_name: String,
    h5_path: PathBuf,
    xdmf_path: PathBuf,
    n: usize,
    frames: Vec<(Real, String)>,
    has_damage: bool,
}

fn h5err(path: &Path) -> impl FnOnce(hdf5_metno::Error) -> IoError + '_ {
    move |e| IoError::Vtk {
        path: path.to_path_buf(),
        msg: format!("HDF5: {e}"),
    }
}

impl H5Series {
    /// A new series `dir/stem.h5` + `dir/stem.xdmf` for `body`.
    pub fn create(dir: &Path, stem: &str, body: &Body) -> Result<Self, IoError> {
        std::fs::create_dir_all(dir).map_err(|e| IoError::NotWritable {
            path: dir.to_path_buf(),
            why: e.to_string(),
        })?;
        let h5_name = format!("{stem}.h5");
        let h5_path = dir.join(&h5_name);
        let file = hdf5_metno::File::create(&h5_path).map_err(h5err(&h5_path))?;
        let n = body.nodes();
        let pos = &body.lattice.pos;
        let points: Vec<Real> = (0..n)
            .flat_map(|i| [pos.x[i], pos.y[i], pos.z[i]])
            .collect();
        let mesh = file.create_group("mesh").map_err(h5err(&h5_path))?;
        write(&mesh, "points", &points, 3, &h5_path)?;
        let vertices: Vec<i64> = (0..n as i64).collect();
        let ds = mesh
            .new_dataset::<i64>()
            .shape((n, 1))
            .create("vertices")
            .map_err(h5err(&h5_path))?;
        ds.write_raw(&vertices[..]).map_err(h5err(&h5_path))?;
        file.create_group("frames").map_err(h5err(&h5_path))?;
        Ok(H5Series {
            file,
            h5_name,
            h5_path,
            xdmf_path: dir.join(format!("{stem}.xdmf")),
            n,
            frames: Vec::new(),
            has_damage: false,
        })
    }

    /// Continue the series of a previous run in `dir`, keeping the frames its `.xdmf` lists up
    /// to time `until` (a resumed run rewrites what came after its checkpoint).
    pub fn reopen(dir: &Path, stem: &str, body: &Body, until: Real) -> Result<Self, IoError> {
        let h5_name = format!("{stem}.h5");
        let h5_path = dir.join(&h5_name);
        let xdmf_path = dir.join(format!("{stem}.xdmf"));
        let Ok(text) = std::fs::read_to_string(&xdmf_path) else {
            return Self::create(dir, stem, body);
        };
        let file = hdf5_metno::File::append(&h5_path).map_err(h5err(&h5_path))?;
        let mut frames = Vec::new();
        let mut time = None;
        for line in text.lines() {
            if let Some(v) = line
                .split("<Time Value=\"")
                .nth(1)
                .and_then(|r| r.split('"').next())
            {
                time = v.parse::<Real>().ok();
            }
            if let (Some(t), Some(name)) = (
                time,
                line.split("/frames/")
                    .nth(1)
                    .and_then(|r| r.split('/').next()),
            ) {
                if t <= until && !frames.iter().any(|(_, f): &(Real, String)| f == name) {
                    frames.push((t, name.to_string()));
                }
            }
        }
        let has_damage = text.contains("Name=\"damage\"");
        Ok(H5Series {
            file,
            h5_name,
            h5_path,
            xdmf_path,
            n: body.nodes(),
            frames,
            has_damage,
        })
    }

    /// Path of the `.xdmf` description.
    pub fn xdmf_path(&self) -> &Path {
        &self.xdmf_path
    }

    /// Write one frame and update the description.
    pub fn write(
        &mut self,
        body: &Body,
        state: &State,
        extras: FrameExtras,
    ) -> Result<(), IoError> {
        let p = &self.h5_path;
        let name = format!("{:06}", state.step);
        let frames = self.file.group("frames").map_err(h5err(p))?;
        if frames.link_exists(&name) {
            frames.unlink(&name).map_err(h5err(p))?;
        }
        let g = frames.create_group(&name).map_err(h5err(p))?;
        let n = self.n;
        let vec3 = |c: &hooke_core::Coords| -> Vec<Real> {
            (0..n).flat_map(|i| [c.x[i], c.y[i], c.z[i]]).collect()
        };
        write(&g, "displacement", &vec3(&state.u), 3, p)?;
        write(
            &g,
            "velocity",
            &vec3(extras.velocity.unwrap_or(&state.v)),
            3,
            p,
        )?;
        if let Some(d) = extras.damage {
            write(&g, "damage", d, 1, p)?;
            self.has_damage = true;
        }
        let d = derived(body, state);
        write(&g, "pool_ratio", &d.pool, 1, p)?;
        write(&g, "strain_energy_density", &d.energy_density, 1, p)?;
        let stress: Vec<Real> = d.stress.iter().flatten().copied().collect();
        write(&g, "stress", &stress, 9, p)?;
        self.file.flush().map_err(h5err(p))?;
        self.frames.retain(|(_, f)| f != &name);
        self.frames.push((state.time, name));
        self.write_xdmf()
    }

    fn write_xdmf(&self) -> Result<(), IoError> {
        let (h5, n) = (&self.h5_name, self.n);
        let item = |path: &str, dims: &str, ty: &str| {
            format!("<DataItem DataType=\"{ty}\" Dimensions=\"{dims}\" Format=\"HDF\" Precision=\"8\">{h5}:{path}</DataItem>")
        };
        let mut x = String::from("<?xml version=\"1.0\"?>\n<Xdmf xmlns:xi=\"http://www.w3.org/2001/XInclude\" Version=\"3.0\">\n  <Domain>\n");
        x.push_str("    <Grid Name=\"mesh\" GridType=\"Uniform\">\n");
        x.push_str(&format!(
            "      <Geometry GeometryType=\"XYZ\">{}</Geometry>\n",
            item("/mesh/points", &format!("{n} 3"), "Float")
        ));
        x.push_str(&format!("      <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\" NodesPerElement=\"1\">{}</Topology>\n", item("/mesh/vertices", &format!("{n} 1"), "Int")));
        x.push_str("    </Grid>\n    <Grid Name=\"TimeSeries\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
        for (t, f) in &self.frames {
            x.push_str("      <Grid Name=\"mesh\" GridType=\"Uniform\">\n");
            x.push_str("        <xi:include xpointer=\"xpointer(//Grid[@Name=&quot;mesh&quot;]/*[self::Topology or self::Geometry])\"/>\n");
            x.push_str(&format!("        <Time Value=\"{t:.17e}\"/>\n"));
            let mut fields = vec![("displacement", "Vector", 3), ("velocity", "Vector", 3)];
            if self.has_damage {
                fields.push(("damage", "Scalar", 1));
            }
            fields.extend([
                ("pool_ratio", "Scalar", 1),
                ("strain_energy_density", "Scalar", 1),
                ("stress", "Tensor", 9),
            ]);
            for (name, kind, c) in fields {
                let dims = if c == 1 {
                    format!("{n}")
                } else {
                    format!("{n} {c}")
                };
                x.push_str(&format!("        <Attribute Name=\"{name}\" AttributeType=\"{kind}\" Center=\"Node\">{}</Attribute>\n", item(&format!("/frames/{f}/{name}"), &dims, "Float")));
            }
            x.push_str("      </Grid>\n");
        }
        x.push_str("    </Grid>\n  </Domain>\n</Xdmf>\n");
        let path = &self.xdmf_path;
        write_atomic(path, |w| w.write_all(x.as_bytes()).map_err(io(path)))
    }
}

/// A chunked, deflate-compressed `rows x cols` dataset of `data` (row-major).
fn write(
    g: &hdf5_metno::Group,
    name: &str,
    data: &[Real],
    cols: usize,
    path: &Path,
) -> Result<(), IoError> {
    let rows = data.len() / cols;
    let chunk_rows = rows.clamp(1, 1 << 16);
    let ds = if cols == 1 {
        g.new_dataset::<Real>()
            .shape(rows)
            .chunk(chunk_rows)
            .deflate(4)
            .create(name)
    } else {
        g.new_dataset::<Real>()
            .shape((rows, cols))
            .chunk((chunk_rows, cols))
            .deflate(4)
            .create(name)
    }
    .map_err(h5err(path))?;
    ds.write_raw(data).map_err(h5err(path))
}
