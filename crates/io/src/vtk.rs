//! VTK output: one XML unstructured-grid file (`.vtu`) per frame and a `.pvd` collection that
//! ParaView and pyvista open as one time series.
//!
//! Data arrays are written as uncompressed base64 binary (vtkio's XML format without a
//! compressor): ParaView, VTK, pyvista and meshio all read it. (vtkio 0.6.3's compressed output is
//! not readable by ParaView and meshio; we use 0.7 without compression.) A frame's model is
//! streamed to the bytes vtkio would write by this crate's `vtu` module; other models go through vtkio's
//! writer. Every file is written to a temporary name and renamed into place, so a run killed at
//! any moment leaves each listed frame and the collection complete.

use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use hooke_core::{Body, Coords, Real, State};
use vtkio::model::{
    Attribute, Attributes, ByteOrder, CellType, Cells, DataArray, DataSet, ElementType,
    UnstructuredGridPiece, Version, VertexNumbers, Vtk,
};

use crate::error::{io, IoError};

/// Per-frame inputs that are not in the state.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrameExtras<'a> {
    /// Full-step velocity (the state holds half-step velocities during a run).
    pub velocity: Option<&'a Coords>,
    /// Damage per node, 0..1.
    pub damage: Option<&'a [Real]>,
    /// Region id per node.
    pub region: Option<&'a [u32]>,
    /// The derived fields of this state, when the caller computed them already (one
    /// computation per frame for every format); computed here otherwise.
    pub derived: Option<&'a crate::fields::Derived>,
    /// The point fields to write (default: all; `node_id` always).
    pub fields: crate::fields::FieldSet,
}

impl<'a> FrameExtras<'a> {
    /// The derived fields of `state`: the caller's, or computed now.
    pub(crate) fn derived_or_compute(
        &self,
        body: &Body,
        state: &State,
    ) -> std::borrow::Cow<'a, crate::fields::Derived> {
        match self.derived {
            Some(d) => std::borrow::Cow::Borrowed(d),
            None => std::borrow::Cow::Owned(crate::fields::derived(body, state)),
        }
    }
}

/// A time series of `.vtu` frames with its `.pvd` index.
///
/// With [`VtkSeries::set_background`], a frame's arrays are copied on the caller's thread and
/// encoded and written on a thread of their own while the run goes on (encoding a frame as
/// base64 XML costs tens of steps on a plate of 10^5 nodes). At most one frame is in flight:
/// the next write, [`VtkSeries::flush`] and dropping the series wait for it, and report its
/// error. The collection is rewritten after its frame is in place, so a run killed at any
/// moment still lists only complete frames.
#[derive(Debug)]
pub struct VtkSeries {
    dir: PathBuf,
    stem: String,
    springs: bool,
    frames: Vec<(Real, String)>,
    background: bool,
    pending: Option<(PathBuf, std::thread::JoinHandle<Result<(), IoError>>)>,
    /// Written as pieces by several processes (see [`VtkSeries::set_pieces`]).
    pieces: Option<Pieces>,
    /// The point fields its frames carry (see [`VtkSeries::set_fields`]).
    fields: crate::fields::FieldSet,
}

/// This process's part of a series written in pieces.
#[derive(Debug)]
struct Pieces {
    rank: usize,
    /// Every process's nodes.
    nodes: Vec<std::ops::Range<usize>>,
    /// The point arrays of the last piece (name, VTK type, components), for the `.pvtu`.
    arrays: Vec<(String, &'static str, usize)>,
    /// Where this process's nodes are in the states it is given, when it holds a piece of
    /// the body ([`VtkSeries::set_piece_nodes`]); `None`: they are `nodes[rank]`.
    held: Option<std::ops::Range<usize>>,
    /// The last frame's piece files and time, until it is published.
    step: u64,
    time: Real,
}

/// The frames (time, file) a `.pvd` collection lists up to time `until`; none if it is missing.
fn listed_frames(pvd: &Path, until: Real) -> Vec<(Real, String)> {
    let mut frames = Vec::new();
    if let Ok(text) = fs::read_to_string(pvd) {
        for line in text.lines().filter(|l| l.contains("<DataSet")) {
            let attr = |name: &str| {
                line.split(&format!("{name}=\""))
                    .nth(1)
                    .and_then(|r| r.split('"').next())
                    .map(str::to_string)
            };
            if let (Some(t), Some(f)) = (
                attr("timestep").and_then(|t| t.parse::<Real>().ok()),
                attr("file"),
            ) {
                if t <= until {
                    frames.push((t, f));
                }
            }
        }
    }
    frames
}

/// Write `bytes` to `path` through a temporary file in the same directory and a rename.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> Result<(), IoError>,
) -> Result<(), IoError> {
    let tmp = path.with_extension(format!(
        "{}.partial",
        path.extension().and_then(|e| e.to_str()).unwrap_or("tmp")
    ));
    {
        let file = fs::File::create(&tmp).map_err(io(&tmp))?;
        // Large writes: a frame is megabytes, and each 8 KiB write was a system call.
        let mut w = BufWriter::with_capacity(1 << 20, file);
        write(&mut w)?;
        let file = w.into_inner().map_err(|e| IoError::Io {
            path: tmp.clone(),
            source: e.into_error(),
        })?;
        file.sync_all().map_err(io(&tmp))?;
    }
    fs::rename(&tmp, path).map_err(io(path))
}

impl VtkSeries {
    /// A new series in `dir` (created if needed). Fails at once, with the reason, when the
    /// directory cannot be written, so a run never starts only to lose its output.
    pub fn create(dir: &Path, stem: &str, springs: bool) -> Result<Self, IoError> {
        fs::create_dir_all(dir).map_err(|e| IoError::NotWritable {
            path: dir.to_path_buf(),
            why: e.to_string(),
        })?;
        let probe = dir.join(format!(".{stem}.probe"));
        fs::write(&probe, b"hooke").map_err(|e| IoError::NotWritable {
            path: dir.to_path_buf(),
            why: e.to_string(),
        })?;
        let _ = fs::remove_file(&probe);
        Ok(VtkSeries {
            dir: dir.to_path_buf(),
            stem: stem.to_string(),
            springs,
            frames: Vec::new(),
            background: false,
            pending: None,
            pieces: None,
            fields: crate::fields::FieldSet::ALL,
        })
    }

    /// Write frames on a background thread (see the type's docs); off by default, so that a
    /// frame is on disk when [`VtkSeries::write`] returns.
    pub fn set_background(&mut self, on: bool) {
        self.background = on;
    }

    /// Write only these point fields in every later frame (`node_id` always; by default all).
    pub fn set_fields(&mut self, fields: crate::fields::FieldSet) {
        self.fields = fields;
    }

    /// Write each frame as pieces, one per process, as `STEM_STEP_RANK.vtu`: this process
    /// (`rank`) writes the nodes `nodes[rank]` (nodes keep their `node_id`; springs whose ends
    /// lie in two pieces are in neither). Once every process has written its piece, process 0
    /// calls [`VtkSeries::publish`], which writes `STEM_STEP.pvtu` and lists it in the `.pvd`:
    /// ParaView and pyvista read the `.pvtu` as one dataset, other readers its pieces.
    pub fn set_pieces(&mut self, rank: usize, nodes: Vec<std::ops::Range<usize>>) {
        self.pieces = Some(Pieces {
            rank,
            nodes,
            held: None,
            arrays: Vec::new(),
            step: 0,
            time: 0.0,
        });
        self.background = false;
    }

    /// In a series written in pieces (after [`VtkSeries::set_pieces`]), the states this process
    /// is given are its piece of the body ([`hooke_core::team::Piece`]): its own nodes are
    /// `own` there, the body's `nodes[rank]` (their `node_id`). The piece files are the bytes a
    /// process holding the whole state writes.
    pub fn set_piece_nodes(&mut self, own: std::ops::Range<usize>) {
        if let Some(p) = self.pieces.as_mut() {
            p.held = Some(own);
        }
    }

    /// Process 0 of a series in pieces: the last frame's `.pvtu`, then the `.pvd` listing it
    /// (call once every process's piece of it is on disk). Nothing to do otherwise.
    pub fn publish(&mut self) -> Result<(), IoError> {
        let Some(p) = self.pieces.as_ref().filter(|p| p.rank == 0) else {
            return Ok(());
        };
        let name = format!("{}_{:06}.pvtu", self.stem, p.step);
        let path = self.dir.join(&name);
        let mut text = String::from("<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <PUnstructuredGrid GhostLevel=\"0\">\n    <PPointData>\n");
        for (a, ty, nc) in &p.arrays {
            text.push_str(&format!(
                "      <PDataArray type=\"{ty}\" Name=\"{a}\" NumberOfComponents=\"{nc}\"/>\n"
            ));
        }
        text.push_str("    </PPointData>\n    <PPoints>\n      <PDataArray type=\"Float64\" NumberOfComponents=\"3\"/>\n    </PPoints>\n");
        // A process that owns no nodes writes no piece (a VTK piece with no points is not one
        // that every reader accepts: meshio refuses it).
        for r in (0..p.nodes.len()).filter(|&r| !p.nodes[r].is_empty()) {
            text.push_str(&format!(
                "    <Piece Source=\"{}\"/>\n",
                piece_name(&self.stem, p.step, r)
            ));
        }
        text.push_str("  </PUnstructuredGrid>\n</VTKFile>\n");
        write_atomic(&path, |w| w.write_all(text.as_bytes()).map_err(io(&path)))?;
        let time = p.time;
        self.frames.retain(|(_, f)| f != &name);
        self.frames.push((time, name));
        write_pvd(&self.pvd_path(), &self.frames)
    }

    /// Wait for the frame in flight, if any, and return its outcome.
    pub fn flush(&mut self) -> Result<(), IoError> {
        match self.pending.take() {
            None => Ok(()),
            Some((path, h)) => h.join().unwrap_or_else(|_| {
                Err(IoError::Vtk {
                    path,
                    msg: "the writer thread panicked".into(),
                })
            }),
        }
    }

    /// Continue the series of a previous run in `dir`, keeping the frames its `.pvd` lists up
    /// to time `until` (a resumed run rewrites what came after its checkpoint).
    pub fn reopen(dir: &Path, stem: &str, springs: bool, until: Real) -> Result<Self, IoError> {
        let mut s = Self::create(dir, stem, springs)?;
        s.frames = listed_frames(&s.pvd_path(), until);
        Ok(s)
    }

    /// Path of the `.pvd` collection.
    pub fn pvd_path(&self) -> PathBuf {
        self.dir.join(format!("{}.pvd", self.stem))
    }

    /// Frames written so far (time, file name).
    pub fn frames(&self) -> &[(Real, String)] {
        &self.frames
    }

    /// Write one frame of `state` and update the collection. Returns the frame's path (in
    /// pieces: this process's piece, which is not written when it owns no nodes).
    pub fn write(
        &mut self,
        body: &Body,
        state: &State,
        extras: FrameExtras,
    ) -> Result<PathBuf, IoError> {
        let extras = FrameExtras {
            fields: extras.fields.and(self.fields),
            ..extras
        };
        if let Some(p) = self.pieces.as_mut() {
            let path = self.dir.join(piece_name(&self.stem, state.step, p.rank));
            let nodes = p.held.clone().unwrap_or_else(|| p.nodes[p.rank].clone());
            let first_id = p.nodes[p.rank].start;
            let vtk = frame_vtk_piece(body, state, extras, self.springs, nodes, first_id);
            p.arrays = point_arrays(&vtk);
            (p.step, p.time) = (state.step, state.time);
            if !p.nodes[p.rank].is_empty() {
                write_vtu(&path, vtk)?;
            }
            return Ok(path);
        }
        let name = format!("{}_{:06}.vtu", self.stem, state.step);
        let path = self.dir.join(&name);
        let vtk = frame_vtk(body, state, extras, self.springs);
        self.flush()?;
        self.frames.retain(|(_, f)| f != &name);
        self.frames.push((state.time, name));
        let (pvd, frames) = (self.pvd_path(), self.frames.clone());
        let job = {
            let path = path.clone();
            move || {
                write_vtu(&path, vtk)?;
                write_pvd(&pvd, &frames)
            }
        };
        if !self.background {
            job()?;
            return Ok(path);
        }
        let h = std::thread::Builder::new()
            .name("hooke-vtk".into())
            .spawn(job)
            .map_err(io(&path))?;
        self.pending = Some((path.clone(), h));
        Ok(path)
    }
}

impl Drop for VtkSeries {
    /// The frame in flight reaches the disk even when a run ends in an error.
    fn drop(&mut self) {
        let _ = self.flush();
    }
}

/// Write one `.vtu` file atomically: a frame through [`crate::vtu`] (the same bytes as vtkio's,
/// streamed), anything else through vtkio.
fn write_vtu(path: &Path, vtk: Vtk) -> Result<(), IoError> {
    write_atomic(path, |w| {
        if crate::vtu::write_frame(&vtk, w).map_err(io(path))? {
            return Ok(());
        }
        vtk.write_xml(w).map_err(|e| IoError::Vtk {
            path: path.to_path_buf(),
            msg: e.to_string(),
        })
    })
}

/// Write a `.pvd` collection listing `frames` (time, file).
fn write_pvd(path: &Path, frames: &[(Real, String)]) -> Result<(), IoError> {
    let mut text = String::from("<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n");
    for (t, f) in frames {
        // 17 significant digits: the time reads back exactly.
        text.push_str(&format!(
            "    <DataSet timestep=\"{t:.17e}\" group=\"\" part=\"0\" file=\"{f}\"/>\n"
        ));
    }
    text.push_str("  </Collection>\n</VTKFile>\n");
    write_atomic(path, |w| w.write_all(text.as_bytes()).map_err(io(path)))
}

/// The surface of one rigid body at one instant: triangles (3D) or line segments (2D), with its
/// velocity and the force the lattice exerts on it.
#[derive(Clone, Debug, Default)]
pub struct RigidPart {
    pub points: Vec<[Real; 3]>,
    pub triangles: Vec<[u32; 3]>,
    pub lines: Vec<[u32; 2]>,
    pub velocity: [Real; 3],
    pub reaction: [Real; 3],
}

/// The rigid bodies of a run as their own VTK series (`STEM_rigid.pvd`, one `.vtu` per frame),
/// to be shown next to the lattice in ParaView.
pub struct RigidSeries {
    dir: PathBuf,
    stem: String,
    frames: Vec<(Real, String)>,
}

impl RigidSeries {
    /// A new series in `dir` (which the lattice series has created).
    pub fn create(dir: &Path, stem: &str) -> Self {
        RigidSeries {
            dir: dir.to_path_buf(),
            stem: format!("{stem}_rigid"),
            frames: Vec::new(),
        }
    }

    /// Path of the `.pvd` collection.
    pub fn pvd_path(&self) -> PathBuf {
        self.dir.join(format!("{}.pvd", self.stem))
    }

    /// Continue the series of a previous run, keeping the frames up to time `until`.
    pub fn reopen(dir: &Path, stem: &str, until: Real) -> Self {
        let mut s = Self::create(dir, stem);
        s.frames = listed_frames(&s.pvd_path(), until);
        s
    }

    /// Write the bodies at time `t` (frame number `step`) and update the collection. Point
    /// data: `velocity` and `reaction` of each point's body; cell data: `body` (its index).
    pub fn write(&mut self, t: Real, step: u64, parts: &[RigidPart]) -> Result<PathBuf, IoError> {
        let name = format!("{}_{:06}.vtu", self.stem, step);
        let path = self.dir.join(&name);
        let mut points: Vec<Real> = Vec::new();
        let (mut connectivity, mut offsets, mut types) = (Vec::new(), Vec::new(), Vec::new());
        let (mut vel, mut reac, mut body) = (Vec::new(), Vec::new(), Vec::new());
        for (k, p) in parts.iter().enumerate() {
            let base = (points.len() / 3) as u64;
            for q in &p.points {
                points.extend(q);
                vel.extend(p.velocity);
                reac.extend(p.reaction);
            }
            for tri in &p.triangles {
                connectivity.extend(tri.iter().map(|&i| base + i as u64));
                offsets.push(connectivity.len() as u64);
                types.push(CellType::Triangle);
                body.push(k as Real);
            }
            for l in &p.lines {
                connectivity.extend(l.iter().map(|&i| base + i as u64));
                offsets.push(connectivity.len() as u64);
                types.push(CellType::Line);
                body.push(k as Real);
            }
        }
        let vec3 = |name: &str, data: Vec<Real>| {
            Attribute::DataArray(DataArray {
                name: name.into(),
                elem: ElementType::Vectors,
                data: data.into(),
            })
        };
        let vtk = Vtk {
            version: Version::new_xml(1, 0),
            title: format!("hooke rigid bodies, t = {t:e} s"),
            byte_order: ByteOrder::LittleEndian,
            file_path: None,
            data: DataSet::inline(UnstructuredGridPiece {
                points: points.into(),
                cells: Cells {
                    cell_verts: VertexNumbers::XML {
                        connectivity,
                        offsets,
                    },
                    types,
                },
                data: Attributes {
                    point: vec![vec3("velocity", vel), vec3("reaction", reac)],
                    cell: vec![scalars("body", body)],
                },
            }),
        };
        write_vtu(&path, vtk)?;
        self.frames.retain(|(_, f)| f != &name);
        self.frames.push((t, name));
        write_pvd(&self.pvd_path(), &self.frames)?;
        Ok(path)
    }
}

fn vectors(name: &str, c: &Coords, nodes: std::ops::Range<usize>) -> Attribute {
    let mut data = Vec::with_capacity(3 * nodes.len());
    for i in nodes {
        data.extend([c.x()[i], c.y()[i], c.z()[i]]);
    }
    Attribute::DataArray(DataArray {
        name: name.into(),
        elem: ElementType::Vectors,
        data: data.into(),
    })
}

fn scalars(name: &str, data: Vec<Real>) -> Attribute {
    Attribute::DataArray(DataArray {
        name: name.into(),
        elem: ElementType::Scalars {
            num_comp: 1,
            lookup_table: None,
        },
        data: data.into(),
    })
}

/// File name of process `rank`'s piece of the frame at `step`.
fn piece_name(stem: &str, step: u64, rank: usize) -> String {
    format!("{stem}_{step:06}_{rank}.vtu")
}

/// The point arrays of a frame: name, VTK type name, components (what a `.pvtu` declares).
fn point_arrays(vtk: &Vtk) -> Vec<(String, &'static str, usize)> {
    let DataSet::UnstructuredGrid { pieces, .. } = &vtk.data else {
        return Vec::new();
    };
    let Some(vtkio::model::Piece::Inline(p)) = pieces.first() else {
        return Vec::new();
    };
    p.data
        .point
        .iter()
        .filter_map(|a| match a {
            Attribute::DataArray(d) => {
                let ty = match &d.data {
                    vtkio::IOBuffer::F64(_) => "Float64",
                    vtkio::IOBuffer::U64(_) => "UInt64",
                    vtkio::IOBuffer::U32(_) => "UInt32",
                    _ => "Float64",
                };
                let nc = match d.elem {
                    ElementType::Vectors => 3,
                    ElementType::Tensors => 9,
                    ElementType::Scalars { num_comp, .. } => num_comp as usize,
                    _ => 1,
                };
                Some((d.name.clone(), ty, nc))
            }
            _ => None,
        })
        .collect()
}

/// The VTK model of one frame.
pub fn frame_vtk(body: &Body, state: &State, extras: FrameExtras, springs: bool) -> Vtk {
    frame_vtk_nodes(body, state, extras, springs, 0..body.nodes())
}

/// The VTK model of the nodes `nodes` of one frame (a piece; all of them: the frame), with the
/// springs between two of them.
pub fn frame_vtk_nodes(
    body: &Body,
    state: &State,
    extras: FrameExtras,
    springs: bool,
    nodes: std::ops::Range<usize>,
) -> Vtk {
    let first = nodes.start;
    frame_vtk_piece(body, state, extras, springs, nodes, first)
}

/// A frame's point data at `nodes` (the first with id `first_id`): the fields the run asked
/// for, derived ones computed here, and each node's id.
fn point_data(
    body: &Body,
    state: &State,
    extras: FrameExtras,
    nodes: std::ops::Range<usize>,
    first_id: usize,
) -> Vec<Attribute> {
    let n = nodes.len();
    let fields = extras.fields;
    let part = |v: &[Real]| v[nodes.clone()].to_vec();
    let mut point = Vec::new();
    if fields.has("displacement") {
        point.push(vectors("displacement", &state.u, nodes.clone()));
    }
    if fields.has("velocity") {
        point.push(vectors(
            "velocity",
            extras.velocity.unwrap_or(&state.v),
            nodes.clone(),
        ));
    }
    if let Some(dmg) = extras.damage.filter(|_| fields.has("damage")) {
        point.push(scalars("damage", part(dmg)));
    }
    if fields.derived() {
        let d = extras.derived_or_compute(body, state);
        if fields.has("pool_ratio") {
            point.push(scalars("pool_ratio", part(&d.pool)));
        }
        if fields.has("strain_energy_density") {
            point.push(scalars("strain_energy_density", part(&d.energy_density)));
        }
        if fields.has("stress") {
            let stress: Vec<Real> = d.stress[nodes.clone()].iter().flatten().copied().collect();
            point.push(Attribute::DataArray(DataArray {
                name: "stress".into(),
                elem: ElementType::Tensors,
                data: stress.into(),
            }));
        }
    }
    if fields.has("node_volume") {
        point.push(scalars(
            "node_volume",
            nodes.clone().map(|i| body.lattice.node_volume(i)).collect(),
        ));
    }
    point.push(Attribute::DataArray(DataArray {
        name: "node_id".into(),
        elem: ElementType::Scalars {
            num_comp: 1,
            lookup_table: None,
        },
        data: (first_id as u64..(first_id + n) as u64)
            .collect::<Vec<u64>>()
            .into(),
    }));
    if let Some(r) = extras.region.filter(|_| fields.has("region")) {
        point.push(Attribute::DataArray(DataArray {
            name: "region".into(),
            elem: ElementType::Scalars {
                num_comp: 1,
                lookup_table: None,
            },
            data: r[nodes.clone()].to_vec().into(),
        }));
    }
    // A body of several materials: each node's phase (0 the body's material; the names are in
    // the run's run.json).
    if let Some(m) = body.phase.as_ref().filter(|_| fields.has("material")) {
        point.push(Attribute::DataArray(DataArray {
            name: "material".into(),
            elem: ElementType::Scalars {
                num_comp: 1,
                lookup_table: None,
            },
            data: m[nodes.clone()]
                .iter()
                .map(|&p| p as u32)
                .collect::<Vec<u32>>()
                .into(),
        }));
    }
    point
}

/// [`frame_vtk_nodes`] with the nodes' `node_id` counted from `first_id` (a piece of a body
/// renumbered: [`VtkSeries::set_piece_nodes`]).
fn frame_vtk_piece(
    body: &Body,
    state: &State,
    extras: FrameExtras,
    springs: bool,
    nodes: std::ops::Range<usize>,
    first_id: usize,
) -> Vtk {
    let n = nodes.len();
    let first = nodes.start;
    // `X + u`, the bits of `State::positions`, without its whole copy of the positions.
    let (x, u) = (&body.lattice.pos, &state.u);
    let mut points = Vec::with_capacity(3 * n);
    for i in nodes.clone() {
        points.extend([
            x.x()[i] + u.x()[i],
            x.y()[i] + u.y()[i],
            x.z()[i] + u.z()[i],
        ]);
    }
    // One vertex cell per node, so that every reader shows the nodes; intact springs as lines
    // on request (for small models: they double the file size per 9 springs per node).
    let mut connectivity: Vec<u64> = (0..n as u64).collect();
    let mut offsets: Vec<u64> = (1..=n as u64).collect();
    let mut types = vec![CellType::Vertex; n];
    if springs {
        for (b, &[i, j]) in body.lattice.bonds.ends.iter().enumerate() {
            let inside = nodes.contains(&(i as usize)) && nodes.contains(&(j as usize));
            if state.alive()[b] && inside {
                connectivity.extend([(i as usize - first) as u64, (j as usize - first) as u64]);
                offsets.push(connectivity.len() as u64);
                types.push(CellType::Line);
            }
        }
    }
    let point = point_data(body, state, extras, nodes, first_id);
    unstructured(
        format!("hooke frame, step {}, t = {:e} s", state.step, state.time),
        points,
        (connectivity, offsets, types),
        point,
    )
}

/// An XML 1.0 little-endian unstructured grid of one inline piece with point data: what a
/// frame is (and what [`crate::vtu`] streams).
pub(crate) fn unstructured(
    title: String,
    points: Vec<Real>,
    (connectivity, offsets, types): (Vec<u64>, Vec<u64>, Vec<CellType>),
    point: Vec<Attribute>,
) -> Vtk {
    Vtk {
        version: Version::new_xml(1, 0),
        title,
        byte_order: ByteOrder::LittleEndian,
        file_path: None,
        data: DataSet::inline(UnstructuredGridPiece {
            points: points.into(),
            cells: Cells {
                cell_verts: VertexNumbers::XML {
                    connectivity,
                    offsets,
                },
                types,
            },
            data: Attributes {
                point,
                cell: Vec::new(),
            },
        }),
    }
}
