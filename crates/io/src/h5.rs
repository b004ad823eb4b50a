//! HDF5 + XDMF output for large runs (cargo feature `hdf5`; needs the system HDF5 library,
//! `tools/install-hdf5.sh`).
//!
//! When a run completes, one `.h5` file holds the reference mesh (`/mesh/points`,
//! `/mesh/vertices`) and one group per frame (`/frames/STEP/points` (current positions),
//! `displacement`, `velocity`, `damage`, `pool_ratio`, `strain_energy_density`, `stress`,
//! `node_volume`, `node_id`, `region`, `material`), chunked and deflate-compressed. An `.xdmf` file describes
//! the time series in the layout meshio's `TimeSeriesReader` and ParaView's XDMF3 reader read: a
//! uniform grid with the mesh, and a temporal collection whose grids include it and carry the
//! frame's point data. Each frame's geometry is its current positions, as in the VTK frames
//! (the same convention in both formats).
//!
//! HDF5 files are not crash-safe when appended in place, so during a run each frame goes to its
//! own small file (`STEM.frames/STEP.h5`, written under a temporary name and renamed), and the
//! `.xdmf`, rewritten atomically, lists only completed frames: a run killed at any moment leaves
//! every listed frame readable, and `hooke run --resume` continues the series. When the run
//! completes, [`H5Series::finish`] merges everything into `STEM.h5` (again through a temporary
//! name) and points the `.xdmf` at it.

use std::path::{Path, PathBuf};

use hooke_core::{Body, Real, State};

use crate::error::{io, IoError};
use crate::fields::FieldSet;
use crate::vtk::{write_atomic, FrameExtras};

/// An HDF5 time series with its XDMF description.
pub struct H5Series {
    dir: PathBuf,
    stem: String,
    xdmf_path: PathBuf,
    n: usize,
    /// (time, frame name, file that holds the frame, the point fields it holds).
    frames: Vec<(Real, String, String, FieldSet)>,
    /// The point fields later frames carry (see [`H5Series::set_fields`]).
    fields: FieldSet,
}

fn h5err(path: &Path) -> impl FnOnce(hdf5_metno::Error) -> IoError + '_ {
    move |e| IoError::Vtk {
        path: path.to_path_buf(),
        msg: format!("HDF5: {e}"),
    }
}

/// The fields of a frame, in the order they are written.
const FIELDS: [(&str, &str, usize); 7] = [
    ("displacement", "Vector", 3),
    ("velocity", "Vector", 3),
    ("damage", "Scalar", 1),
    ("pool_ratio", "Scalar", 1),
    ("strain_energy_density", "Scalar", 1),
    ("stress", "Tensor", 9),
    ("node_volume", "Scalar", 1),
];

/// Integer fields of a frame (written as 64-bit integers).
const INT_FIELDS: [&str; 3] = ["node_id", "region", "material"];

/// Create an HDF5 file through a temporary name, fill it, and rename it into place.
fn atomic_h5(
    path: &Path,
    fill: impl FnOnce(&hdf5_metno::File) -> Result<(), IoError>,
) -> Result<(), IoError> {
    let tmp = path.with_extension("h5.partial");
    {
        let f = hdf5_metno::File::create(&tmp).map_err(h5err(&tmp))?;
        fill(&f)?;
        f.flush().map_err(h5err(&tmp))?;
    }
    std::fs::rename(&tmp, path).map_err(io(path))
}

impl H5Series {
    /// A new series for `body` in `dir`: `stem.xdmf`, the mesh in `stem.mesh.h5`, frames in
    /// `stem.frames/`; [`H5Series::finish`] merges them into `stem.h5`.
    pub fn create(dir: &Path, stem: &str, body: &Body) -> Result<Self, IoError> {
        let frames_dir = dir.join(format!("{stem}.frames"));
        std::fs::create_dir_all(&frames_dir).map_err(|e| IoError::NotWritable {
            path: dir.to_path_buf(),
            why: e.to_string(),
        })?;
        let s = H5Series {
            dir: dir.to_path_buf(),
            stem: stem.to_string(),
            xdmf_path: dir.join(format!("{stem}.xdmf")),
            n: body.nodes(),
            frames: Vec::new(),
            fields: FieldSet::ALL,
        };
        let mesh = s.dir.join(s.mesh_file());
        atomic_h5(&mesh, |f| write_mesh(f, body, &mesh))?;
        Ok(s)
    }

    fn mesh_file(&self) -> String {
        format!("{}.mesh.h5", self.stem)
    }

    /// Continue the series of a previous run in `dir`, keeping the frames its `.xdmf` lists up
    /// to time `until` (a resumed run rewrites what came after its checkpoint).
    pub fn reopen(dir: &Path, stem: &str, body: &Body, until: Real) -> Result<Self, IoError> {
        let xdmf_path = dir.join(format!("{stem}.xdmf"));
        let Ok(text) = std::fs::read_to_string(&xdmf_path) else {
            return Self::create(dir, stem, body);
        };
        let mut s = Self::create(dir, stem, body)?;
        let mut time = None;
        for line in text.lines() {
            if let Some(v) = line
                .split("<Time Value=\"")
                .nth(1)
                .and_then(|r| r.split('"').next())
            {
                time = v.parse::<Real>().ok();
            }
            // A frame's data items read `FILE:/frames/NAME/field`.
            if let (Some(t), Some(item)) = (
                time,
                line.split("Precision=\"8\">")
                    .nth(1)
                    .and_then(|r| r.split('<').next()),
            ) {
                if let Some((file, path)) = item.split_once(":/frames/") {
                    let (name, field) = path.split_once('/').unwrap_or((path, ""));
                    if t > until {
                        continue;
                    }
                    if !s.frames.iter().any(|(_, f, _, _)| f == name) {
                        s.frames
                            .push((t, name.to_string(), file.to_string(), FieldSet::NONE));
                    }
                    if let (Some(frame), Ok(one)) = (
                        s.frames.iter_mut().find(|(_, f, _, _)| f == name),
                        FieldSet::from_names(&[field]),
                    ) {
                        frame.3 = frame.3.or(one);
                    }
                }
            }
        }
        Ok(s)
    }

    /// Write only these point fields in every later frame (`node_id` always; by default all).
    pub fn set_fields(&mut self, fields: FieldSet) {
        self.fields = fields;
    }

    /// Path of the `.xdmf` description.
    pub fn xdmf_path(&self) -> &Path {
        &self.xdmf_path
    }

    /// Write one frame (to its own file, atomically) and update the description.
    pub fn write(
        &mut self,
        body: &Body,
        state: &State,
        extras: FrameExtras,
    ) -> Result<(), IoError> {
        let name = format!("{:06}", state.step);
        let file = format!("{}.frames/{name}.h5", self.stem);
        let path = self.dir.join(&file);
        let n = self.n;
        let vec3 = |c: &hooke_core::Coords| -> Vec<Real> {
            (0..n)
                .flat_map(|i| [c.x()[i], c.y()[i], c.z()[i]])
                .collect()
        };
        // The fields this frame holds: those asked for that it has.
        let mut fields = extras.fields.and(self.fields);
        if extras.damage.is_none() {
            fields = fields.without("damage");
        }
        if extras.region.is_none() {
            fields = fields.without("region");
        }
        if body.phase.is_none() {
            fields = fields.without("material");
        }
        let d = fields
            .derived()
            .then(|| extras.derived_or_compute(body, state));
        atomic_h5(&path, |f| {
            let g = f
                .create_group("frames")
                .and_then(|g| g.create_group(&name))
                .map_err(h5err(&path))?;
            if fields.has("displacement") {
                write(&g, "displacement", &vec3(&state.u), 3, &path)?;
            }
            if fields.has("velocity") {
                write(
                    &g,
                    "velocity",
                    &vec3(extras.velocity.unwrap_or(&state.v)),
                    3,
                    &path,
                )?;
            }
            if let Some(dmg) = extras.damage.filter(|_| fields.has("damage")) {
                write(&g, "damage", dmg, 1, &path)?;
            }
            if let Some(d) = &d {
                if fields.has("pool_ratio") {
                    write(&g, "pool_ratio", &d.pool, 1, &path)?;
                }
                if fields.has("strain_energy_density") {
                    write(&g, "strain_energy_density", &d.energy_density, 1, &path)?;
                }
                if fields.has("stress") {
                    let stress: Vec<Real> = d.stress.iter().flatten().copied().collect();
                    write(&g, "stress", &stress, 9, &path)?;
                }
            }
            // Current positions, the frame's geometry (as the VTK frames' points).
            write(&g, "points", &vec3(&state.positions(body)), 3, &path)?;
            if fields.has("node_volume") {
                let volume: Vec<Real> = (0..n).map(|i| body.lattice.node_volume(i)).collect();
                write(&g, "node_volume", &volume, 1, &path)?;
            }
            write_ints(&g, "node_id", &(0..n as i64).collect::<Vec<_>>(), &path)?;
            if let Some(r) = extras.region.filter(|_| fields.has("region")) {
                let r: Vec<i64> = r.iter().map(|&v| v as i64).collect();
                write_ints(&g, "region", &r, &path)?;
            }
            if let Some(m) = body.phase.as_ref().filter(|_| fields.has("material")) {
                let m: Vec<i64> = m.iter().map(|&v| v as i64).collect();
                write_ints(&g, "material", &m, &path)?;
            }
            Ok(())
        })?;
        self.frames.retain(|(_, f, _, _)| f != &name);
        self.frames.push((state.time, name, file, fields));
        self.write_xdmf()
    }

    /// Merge the mesh and every frame into the single file `stem.h5` (through a temporary name),
    /// point the description at it and remove the per-frame files. Call when the run completes.
    pub fn finish(&mut self) -> Result<PathBuf, IoError> {
        let target = self.dir.join(format!("{}.h5", self.stem));
        let merged_name = format!("{}.h5", self.stem);
        let sources: Vec<(String, String)> = self
            .frames
            .iter()
            .map(|(_, name, file, _)| (name.clone(), file.clone()))
            .collect();
        let mesh_path = self.dir.join(self.mesh_file());
        let dir = self.dir.clone();
        atomic_h5(&target, |out| {
            let mesh = hdf5_metno::File::open(&mesh_path).map_err(h5err(&mesh_path))?;
            let g = out.create_group("mesh").map_err(h5err(&target))?;
            let pts: Vec<Real> = mesh
                .dataset("mesh/points")
                .and_then(|d| d.read_raw())
                .map_err(h5err(&mesh_path))?;
            write(&g, "points", &pts, 3, &target)?;
            let v: Vec<i64> = mesh
                .dataset("mesh/vertices")
                .and_then(|d| d.read_raw())
                .map_err(h5err(&mesh_path))?;
            let ds = g
                .new_dataset::<i64>()
                .shape((v.len(), 1))
                .create("vertices")
                .map_err(h5err(&target))?;
            ds.write_raw(&v[..]).map_err(h5err(&target))?;
            let frames = out.create_group("frames").map_err(h5err(&target))?;
            for (name, file) in &sources {
                let src_path = dir.join(file);
                let src = hdf5_metno::File::open(&src_path).map_err(h5err(&src_path))?;
                let fg = frames.create_group(name).map_err(h5err(&target))?;
                for (field, _, cols) in FIELDS.into_iter().chain([("points", "", 3)]) {
                    if let Ok(ds) = src.dataset(&format!("frames/{name}/{field}")) {
                        let data: Vec<Real> = ds.read_raw().map_err(h5err(&src_path))?;
                        write(&fg, field, &data, cols, &target)?;
                    }
                }
                for field in INT_FIELDS {
                    if let Ok(ds) = src.dataset(&format!("frames/{name}/{field}")) {
                        let data: Vec<i64> = ds.read_raw().map_err(h5err(&src_path))?;
                        write_ints(&fg, field, &data, &target)?;
                    }
                }
            }
            Ok(())
        })?;
        for f in self.frames.iter_mut() {
            f.2 = merged_name.clone();
        }
        self.write_xdmf_with_mesh(&merged_name)?;
        let _ = std::fs::remove_dir_all(self.dir.join(format!("{}.frames", self.stem)));
        let _ = std::fs::remove_file(self.dir.join(self.mesh_file()));
        Ok(target)
    }

    fn write_xdmf(&self) -> Result<(), IoError> {
        self.write_xdmf_with_mesh(&self.mesh_file())
    }

    fn write_xdmf_with_mesh(&self, mesh_file: &str) -> Result<(), IoError> {
        let n = self.n;
        let item = |file: &str, path: &str, dims: &str, ty: &str| {
            format!("<DataItem DataType=\"{ty}\" Dimensions=\"{dims}\" Format=\"HDF\" Precision=\"8\">{file}:{path}</DataItem>")
        };
        let mut x = String::from("<?xml version=\"1.0\"?>\n<Xdmf xmlns:xi=\"http://www.w3.org/2001/XInclude\" Version=\"3.0\">\n  <Domain>\n");
        x.push_str("    <Grid Name=\"mesh\" GridType=\"Uniform\">\n");
        x.push_str(&format!(
            "      <Geometry GeometryType=\"XYZ\">{}</Geometry>\n",
            item(mesh_file, "/mesh/points", &format!("{n} 3"), "Float")
        ));
        x.push_str(&format!(
            "      <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{n}\" NodesPerElement=\"1\">{}</Topology>\n",
            item(mesh_file, "/mesh/vertices", &format!("{n} 1"), "Int")
        ));
        x.push_str("    </Grid>\n    <Grid Name=\"TimeSeries\" GridType=\"Collection\" CollectionType=\"Temporal\">\n");
        for (t, name, file, fields) in &self.frames {
            // Named apart from the mesh grid: the include below selects `Grid[@Name="mesh"]`.
            x.push_str(&format!(
                "      <Grid Name=\"step_{name}\" GridType=\"Uniform\">\n"
            ));
            // The mesh's topology, the frame's own geometry (current positions, as in the VTK
            // frames; meshio's TimeSeriesReader reads the mesh grid's reference positions).
            x.push_str("        <xi:include xpointer=\"xpointer(//Grid[@Name=&quot;mesh&quot;]/*[self::Topology])\"/>\n");
            x.push_str(&format!(
                "        <Geometry GeometryType=\"XYZ\">{}</Geometry>\n",
                item(
                    file,
                    &format!("/frames/{name}/points"),
                    &format!("{n} 3"),
                    "Float"
                )
            ));
            x.push_str(&format!("        <Time Value=\"{t:.17e}\"/>\n"));
            for (field, kind, c) in FIELDS {
                if !fields.has(field) {
                    continue;
                }
                let dims = if c == 1 {
                    format!("{n}")
                } else {
                    format!("{n} {c}")
                };
                x.push_str(&format!(
                    "        <Attribute Name=\"{field}\" AttributeType=\"{kind}\" Center=\"Node\">{}</Attribute>\n",
                    item(file, &format!("/frames/{name}/{field}"), &dims, "Float")
                ));
            }
            for field in INT_FIELDS {
                if !fields.has(field) {
                    continue;
                }
                x.push_str(&format!(
                    "        <Attribute Name=\"{field}\" AttributeType=\"Scalar\" Center=\"Node\">{}</Attribute>\n",
                    item(file, &format!("/frames/{name}/{field}"), &format!("{n}"), "Int")
                ));
            }
            x.push_str("      </Grid>\n");
        }
        x.push_str("    </Grid>\n  </Domain>\n</Xdmf>\n");
        let path = &self.xdmf_path;
        write_atomic(path, |w| w.write_all(x.as_bytes()).map_err(io(path)))
    }
}

fn write_mesh(f: &hdf5_metno::File, body: &Body, path: &Path) -> Result<(), IoError> {
    let n = body.nodes();
    let pos = &body.lattice.pos;
    let points: Vec<Real> = (0..n)
        .flat_map(|i| [pos.x()[i], pos.y()[i], pos.z()[i]])
        .collect();
    let mesh = f.create_group("mesh").map_err(h5err(path))?;
    write(&mesh, "points", &points, 3, path)?;
    let vertices: Vec<i64> = (0..n as i64).collect();
    let ds = mesh
        .new_dataset::<i64>()
        .shape((n, 1))
        .create("vertices")
        .map_err(h5err(path))?;
    ds.write_raw(&vertices[..]).map_err(h5err(path))
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

/// A chunked, deflate-compressed column of 64-bit integers.
fn write_ints(g: &hdf5_metno::Group, name: &str, data: &[i64], path: &Path) -> Result<(), IoError> {
    let ds = g
        .new_dataset::<i64>()
        .shape(data.len())
        .chunk(data.len().clamp(1, 1 << 16))
        .deflate(4)
        .create(name)
        .map_err(h5err(path))?;
    ds.write_raw(data).map_err(h5err(path))
}
