//! A streaming writer for the `.vtu` frames that [`crate::vtk`] builds.
//!
//! vtkio's `Vtk::write_xml` turns every array into a base64 `String`, gathers them into an XML
//! document and serialises it, escaping the strings as it goes: three copies of a frame in fresh
//! memory and a pass of escape checks over it, about 0.3 s for a 38 MB piece of the
//! Kalthoff-Winkler plate, where the steps between two frames take a few seconds. This writer
//! produces the same bytes from the same model (tested against vtkio's output) but encodes each
//! array's base64 in small blocks straight into the output: one pass over the data, no copy of
//! the document. Models outside what the frames use (another data set, cell data, compressed or
//! big-endian output, names that XML would escape) are left to vtkio.

use std::io::{self, Write};

use base64::Engine as _;
use vtkio::model::{
    Attribute, ByteOrder, DataSet, ElementType, IOBuffer, Piece, Version, VertexNumbers, Vtk,
};

/// Input bytes per base64 block: a multiple of 3 (no padding inside the stream) and of 8
/// (whole values), small enough to stay in the L1/L2 caches with its 4/3 as large output.
const BLOCK: usize = 3 * 8 * 1024;

/// Write `vtk` as vtkio's `write_xml` would, byte for byte, when it is an unstructured grid of
/// one inline piece with point data only (what a frame is). Returns `Ok(false)`, having written
/// nothing, for any other model.
pub(crate) fn write_frame(vtk: &Vtk, w: &mut dyn Write) -> io::Result<bool> {
    let Some(piece) = frame_piece(vtk) else {
        return Ok(false);
    };
    let VertexNumbers::XML {
        connectivity,
        offsets,
    } = &piece.cells.cell_verts
    else {
        return Ok(false);
    };
    let arrays: Vec<&vtkio::model::DataArray> = piece
        .data
        .point
        .iter()
        .filter_map(|a| match a {
            Attribute::DataArray(d) => Some(d),
            Attribute::Field { .. } => None,
        })
        .collect();
    // vtkio drops field attributes and writes no `PointData` without arrays; neither happens
    // in a frame, so leave them to it rather than copy its rules for them.
    let plain = |s: &str| !s.contains(['&', '<', '>', '"', '\'']);
    if arrays.is_empty()
        || arrays.len() != piece.data.point.len()
        || !piece.data.cell.is_empty()
        || arrays
            .iter()
            .any(|d| !plain(&d.name) || type_name(&d.data).is_none())
        || type_name(&piece.points).is_none()
    {
        return Ok(false);
    }
    let mut enc = Base64Stream::new();
    write!(
        w,
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\"><UnstructuredGrid><Piece NumberOfPoints=\"{}\" \
         NumberOfCells=\"{}\"><PointData",
        piece.points.len() / 3,
        piece.cells.types.len()
    )?;
    // The active attribute of each kind is the first array of that kind (vtkio's rule), in
    // this attribute order.
    for label in ["Scalars", "Vectors", "Normals", "Tensors", "TCoords"] {
        if let Some(d) = arrays.iter().find(|d| kind(&d.elem) == Some(label)) {
            write!(w, " {label}=\"{}\"", d.name)?;
        }
    }
    w.write_all(b">")?;
    for d in &arrays {
        data_array(w, &mut enc, &d.name, d.num_comp(), &d.data)?;
    }
    w.write_all(b"</PointData><Points>")?;
    data_array(w, &mut enc, "Points", 3, &piece.points)?;
    w.write_all(b"</Points><Cells>")?;
    data_array_of(w, &mut enc, "connectivity", 1, IoSlice::U64(connectivity))?;
    data_array_of(w, &mut enc, "offsets", 1, IoSlice::U64(offsets))?;
    let types: Vec<u8> = piece.cells.types.iter().map(|&t| t as u8).collect();
    data_array_of(w, &mut enc, "types", 1, IoSlice::U8(&types))?;
    w.write_all(b"</Cells></Piece></UnstructuredGrid></VTKFile>")?;
    Ok(true)
}

/// The attribute kind an array's element type makes it active as, if any.
fn kind(e: &ElementType) -> Option<&'static str> {
    Some(match e {
        ElementType::Scalars { .. } => "Scalars",
        ElementType::Vectors => "Vectors",
        ElementType::Normals => "Normals",
        ElementType::Tensors => "Tensors",
        ElementType::TCoords(_) => "TCoords",
        _ => return None,
    })
}

/// The one inline piece of an unstructured grid written as vtkio writes little-endian XML 1.0.
fn frame_piece(vtk: &Vtk) -> Option<&vtkio::model::UnstructuredGridPiece> {
    if vtk.version != (Version::XML { major: 1, minor: 0 })
        || vtk.byte_order != ByteOrder::LittleEndian
    {
        return None;
    }
    let DataSet::UnstructuredGrid { meta: None, pieces } = &vtk.data else {
        return None;
    };
    match pieces.as_slice() {
        [Piece::Inline(p)] => Some(p),
        _ => None,
    }
}

/// The arrays this writer encodes, borrowed.
#[derive(Clone, Copy)]
enum IoSlice<'a> {
    F64(&'a [f64]),
    F32(&'a [f32]),
    U64(&'a [u64]),
    I64(&'a [i64]),
    U32(&'a [u32]),
    I32(&'a [i32]),
    U8(&'a [u8]),
}

impl<'a> IoSlice<'a> {
    fn of(buf: &'a IOBuffer) -> Option<Self> {
        Some(match buf {
            IOBuffer::F64(v) => IoSlice::F64(v),
            IOBuffer::F32(v) => IoSlice::F32(v),
            IOBuffer::U64(v) => IoSlice::U64(v),
            IOBuffer::I64(v) => IoSlice::I64(v),
            IOBuffer::U32(v) => IoSlice::U32(v),
            IOBuffer::I32(v) => IoSlice::I32(v),
            IOBuffer::U8(v) => IoSlice::U8(v),
            _ => return None,
        })
    }

    fn type_name(self) -> &'static str {
        match self {
            IoSlice::F64(_) => "Float64",
            IoSlice::F32(_) => "Float32",
            IoSlice::U64(_) => "UInt64",
            IoSlice::I64(_) => "Int64",
            IoSlice::U32(_) => "UInt32",
            IoSlice::I32(_) => "Int32",
            IoSlice::U8(_) => "UInt8",
        }
    }

    fn bytes(self) -> usize {
        match self {
            IoSlice::F64(v) => 8 * v.len(),
            IoSlice::F32(v) => 4 * v.len(),
            IoSlice::U64(v) => 8 * v.len(),
            IoSlice::I64(v) => 8 * v.len(),
            IoSlice::U32(v) => 4 * v.len(),
            IoSlice::I32(v) => 4 * v.len(),
            IoSlice::U8(v) => v.len(),
        }
    }

    /// The range vtkio writes: the least and greatest value (floats through `min` and `max`,
    /// so NaN only when every value is NaN); none for an empty array.
    fn range(self) -> Option<(f64, f64)> {
        fn ints<T: Copy + Ord + Into<f64>>(v: &[T]) -> Option<(f64, f64)> {
            Some(((*v.iter().min()?).into(), (*v.iter().max()?).into()))
        }
        // 64-bit integers become floats as vtkio's `as f64` makes them.
        fn wide<T: Copy + Ord>(v: &[T], f: fn(T) -> f64) -> Option<(f64, f64)> {
            Some((f(*v.iter().min()?), f(*v.iter().max()?)))
        }
        match self {
            IoSlice::F64(v) => Some((
                v.iter().copied().reduce(f64::min)?,
                v.iter().copied().reduce(f64::max)?,
            )),
            IoSlice::F32(v) => Some((
                v.iter().copied().reduce(f32::min)? as f64,
                v.iter().copied().reduce(f32::max)? as f64,
            )),
            IoSlice::U64(v) => wide(v, |x| x as f64),
            IoSlice::I64(v) => wide(v, |x| x as f64),
            IoSlice::U32(v) => ints(v),
            IoSlice::I32(v) => ints(v),
            IoSlice::U8(v) => ints(v),
        }
    }

    /// Feed the little-endian bytes of the values into `enc`.
    fn encode(self, enc: &mut Base64Stream, w: &mut dyn Write) -> io::Result<()> {
        fn each<T: Copy, const N: usize>(
            v: &[T],
            le: fn(T) -> [u8; N],
            enc: &mut Base64Stream,
            w: &mut dyn Write,
        ) -> io::Result<()> {
            for chunk in v.chunks(BLOCK / N) {
                enc.push_with(w, chunk.len() * N, |out| {
                    for (o, &x) in out.chunks_exact_mut(N).zip(chunk) {
                        o.copy_from_slice(&le(x));
                    }
                })?;
            }
            Ok(())
        }
        match self {
            IoSlice::F64(v) => each(v, f64::to_le_bytes, enc, w),
            IoSlice::F32(v) => each(v, f32::to_le_bytes, enc, w),
            IoSlice::U64(v) => each(v, u64::to_le_bytes, enc, w),
            IoSlice::I64(v) => each(v, i64::to_le_bytes, enc, w),
            IoSlice::U32(v) => each(v, u32::to_le_bytes, enc, w),
            IoSlice::I32(v) => each(v, i32::to_le_bytes, enc, w),
            IoSlice::U8(v) => each(v, |x| [x], enc, w),
        }
    }
}

fn type_name(buf: &IOBuffer) -> Option<&'static str> {
    IoSlice::of(buf).map(IoSlice::type_name)
}

/// One `<DataArray>` of a model buffer (its type checked by [`write_frame`]).
fn data_array(
    w: &mut dyn Write,
    enc: &mut Base64Stream,
    name: &str,
    num_comp: usize,
    buf: &IOBuffer,
) -> io::Result<()> {
    match IoSlice::of(buf) {
        Some(s) => data_array_of(w, enc, name, num_comp, s),
        None => Err(io::Error::other("unsupported array type")),
    }
}

/// One `<DataArray>`: its attributes as vtkio orders and omits them, then the base64 of the
/// 8-byte length header and the values as one stream.
fn data_array_of(
    w: &mut dyn Write,
    enc: &mut Base64Stream,
    name: &str,
    num_comp: usize,
    s: IoSlice,
) -> io::Result<()> {
    write!(w, "<DataArray type=\"{}\"", s.type_name())?;
    if !name.is_empty() {
        write!(w, " Name=\"{name}\"")?;
    }
    if num_comp != 1 {
        write!(w, " NumberOfComponents=\"{num_comp}\"")?;
    }
    w.write_all(b" format=\"binary\"")?;
    if let Some((lo, hi)) = s.range() {
        // Rust's shortest round-trip form without exponent, as vtkio's serialiser writes it.
        write!(w, " RangeMin=\"{lo}\" RangeMax=\"{hi}\"")?;
    }
    w.write_all(b">")?;
    let header = (s.bytes() as u64).to_le_bytes();
    enc.push_with(w, header.len(), |out| out.copy_from_slice(&header))?;
    s.encode(enc, w)?;
    enc.finish(w)?;
    w.write_all(b"</DataArray>")
}

/// Base64 (standard alphabet, padded) of a byte stream fed in pieces, written in blocks.
struct Base64Stream {
    /// Bytes not yet encoded: fewer than [`BLOCK`] between calls.
    input: Vec<u8>,
    output: Vec<u8>,
}

impl Base64Stream {
    fn new() -> Self {
        Base64Stream {
            input: Vec::with_capacity(2 * BLOCK),
            output: vec![0; (2 * BLOCK).div_ceil(3) * 4],
        }
    }

    /// Append `len` bytes that `fill` writes (at most [`BLOCK`]), encoding whole blocks.
    fn push_with(
        &mut self,
        w: &mut dyn Write,
        len: usize,
        fill: impl FnOnce(&mut [u8]),
    ) -> io::Result<()> {
        let start = self.input.len();
        self.input.resize(start + len, 0);
        fill(&mut self.input[start..]);
        if self.input.len() >= BLOCK {
            // Encode a multiple of 3 bytes, so the stream has no padding inside it.
            let whole = self.input.len() / 3 * 3;
            self.encode(w, whole)?;
        }
        Ok(())
    }

    /// Encode and write the first `len` bytes of the input, keeping the rest.
    fn encode(&mut self, w: &mut dyn Write, len: usize) -> io::Result<()> {
        let n = base64::engine::general_purpose::STANDARD
            .encode_slice(&self.input[..len], &mut self.output)
            .map_err(io::Error::other)?;
        w.write_all(&self.output[..n])?;
        self.input.drain(..len);
        Ok(())
    }

    /// Encode what is left, with padding: the end of one array's stream.
    fn finish(&mut self, w: &mut dyn Write) -> io::Result<()> {
        self.encode(w, self.input.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vtkio::model::{CellType, DataArray};

    fn array(name: &str, elem: ElementType, data: IOBuffer) -> Attribute {
        Attribute::DataArray(DataArray {
            name: name.into(),
            elem,
            data,
        })
    }

    fn scalar() -> ElementType {
        ElementType::Scalars {
            num_comp: 1,
            lookup_table: None,
        }
    }

    /// A grid of `n` vertex cells and `lines` line cells with `point` arrays.
    fn grid(n: usize, lines: usize, point: Vec<Attribute>) -> Vtk {
        let mut connectivity: Vec<u64> = (0..n as u64).collect();
        let mut offsets: Vec<u64> = (1..=n as u64).collect();
        let mut types = vec![CellType::Vertex; n];
        for k in 0..lines {
            connectivity.extend([(k % n) as u64, ((k * 7 + 1) % n) as u64]);
            offsets.push(connectivity.len() as u64);
            types.push(CellType::Line);
        }
        let points = (0..3 * n).map(|i| (i as f64 * 0.37).sin() * 1e-3).collect();
        crate::vtk::unstructured("test".into(), points, (connectivity, offsets, types), point)
    }

    fn both(vtk: &Vtk) -> (Option<Vec<u8>>, Vec<u8>) {
        let mut ours = Vec::new();
        let done = write_frame(vtk, &mut ours).unwrap();
        let mut theirs = Vec::new();
        vtk.clone().write_xml(&mut theirs).unwrap();
        (done.then_some(ours), theirs)
    }

    /// Every array type, element kind and awkward value a frame can hold, at lengths on both
    /// sides of a base64 block and of a 3-byte group: vtkio's bytes exactly.
    #[test]
    fn frames_are_vtkios_bytes() {
        for n in [
            1,
            2,
            3,
            5,
            1000,
            BLOCK / 24 - 1,
            BLOCK / 24,
            BLOCK / 8 + 1,
            7001,
        ] {
            let f = |k: usize| -> Vec<f64> {
                (0..k)
                    .map(|i| match i % 11 {
                        0 => -0.0,
                        3 => f64::NAN,
                        5 => 1e-300 * i as f64,
                        7 => -1.5e300,
                        _ => (i as f64).sqrt() - 40.0,
                    })
                    .collect()
            };
            let point = vec![
                array("displacement", ElementType::Vectors, f(3 * n).into()),
                array("damage", scalar(), f(n).into()),
                array("stress", ElementType::Tensors, f(9 * n).into()),
                array(
                    "single",
                    scalar(),
                    f(n).iter().map(|&x| x as f32).collect::<Vec<_>>().into(),
                ),
                array(
                    "node_id",
                    scalar(),
                    (0..n as u64)
                        .map(|i| i * 977 % 1013)
                        .collect::<Vec<_>>()
                        .into(),
                ),
                array(
                    "signed",
                    scalar(),
                    (0..n as i64).map(|i| i - 17).collect::<Vec<_>>().into(),
                ),
                array(
                    "region",
                    scalar(),
                    (0..n as u32).map(|i| i % 3).collect::<Vec<_>>().into(),
                ),
                array(
                    "small",
                    scalar(),
                    (0..n as i32).map(|i| -i).collect::<Vec<_>>().into(),
                ),
                array("normals", ElementType::Normals, vec![0.5f64; 3 * n].into()),
                array("all_nan", scalar(), vec![f64::NAN; n].into()),
            ];
            let (ours, theirs) = both(&grid(n, 2 * n, point));
            let ours = ours.expect("a frame's model");
            assert!(ours == theirs, "n = {n}: the bytes differ from vtkio's");
        }
    }

    /// Models outside a frame's shape are left to vtkio, untouched.
    #[test]
    fn other_models_are_declined() {
        let ok = || array("a", scalar(), vec![1.0f64; 4].into());
        let mut escaped = grid(4, 0, vec![array("a<b", scalar(), vec![1.0f64; 4].into())]);
        assert_eq!(both(&escaped).0, None);
        let mut big = grid(4, 0, vec![ok()]);
        big.byte_order = ByteOrder::BigEndian;
        assert_eq!(both(&big).0, None);
        let mut cell = grid(4, 0, vec![ok()]);
        if let DataSet::UnstructuredGrid { pieces, .. } = &mut cell.data {
            if let Piece::Inline(p) = &mut pieces[0] {
                p.data.cell.push(ok());
            }
        }
        assert_eq!(both(&cell).0, None);
        assert_eq!(both(&grid(4, 0, Vec::new())).0, None);
        escaped.version = Version::new_xml(2, 2);
        assert_eq!(both(&escaped).0, None);
        assert!(both(&grid(4, 1, vec![ok()])).0.is_some());
    }
}
