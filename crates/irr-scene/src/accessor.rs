//! Reading glTF accessors (glTF 2.0 §3.6 "Binary Data Storage") with every offset, stride and
//! count checked against the bytes that are really there. A file that lies about its sizes gives
//! an error naming the accessor, never a panic or an out-of-bounds read.
//!
//! Supported: the mesh attributes' component types of glTF 2.0 and of `KHR_mesh_quantization`
//! (positions, normals, tangents and texture coordinates as `FLOAT`s or as 8- or 16-bit
//! integers, normalized or not where the extension allows: [`Quantized`]), `FLOAT` or
//! normalized `UNSIGNED_BYTE` / `UNSIGNED_SHORT` colours, `UNSIGNED_BYTE`/`SHORT`/`INT` scalars
//! (indices), interleaved views (`byteStride`), accessors without a buffer view (all zeros) and
//! sparse accessors (§3.6.2.3).

use crate::files::Budget;
use gltf::accessor::{DataType, Dimensions};

/// The bytes of each buffer, indexed like `document.buffers()`.
pub(crate) type Buffers = [Vec<u8>];

fn type_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}

fn dims_name(d: Dimensions) -> &'static str {
    match d {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

fn component_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

/// A run of `count` elements of `element_size` bytes, `stride` bytes apart, starting at byte
/// `offset` of a buffer view; checked against the view and the buffer.
struct Strided<'b> {
    bytes: &'b [u8],
    stride: usize,
    element_size: usize,
    count: usize,
}

impl Strided<'_> {
    fn element(&self, i: usize) -> &[u8] {
        // In range by construction (`locate` checked the last element's end).
        let start = i * self.stride;
        &self.bytes[start..start + self.element_size]
    }
}

/// Finds `count` elements in `view` starting at `offset`, or says why they are not all there.
fn locate<'b>(
    what: &str,
    view: gltf::buffer::View<'_>,
    offset: usize,
    count: usize,
    element_size: usize,
    buffers: &'b Buffers,
) -> Result<Strided<'b>, String> {
    let buffer = view.buffer().index();
    let data = buffers
        .get(buffer)
        .ok_or_else(|| format!("{what}: buffer {buffer} does not exist"))?;
    let view_end = view
        .offset()
        .checked_add(view.length())
        .filter(|&end| end <= data.len())
        .ok_or_else(|| {
            format!(
                "{what}: bufferView {} spans bytes {}..{}+{} but buffer {buffer} has {} bytes",
                view.index(),
                view.offset(),
                view.offset(),
                view.length(),
                data.len()
            )
        })?;
    let view_bytes = &data[view.offset()..view_end];
    let stride = view.stride().unwrap_or(element_size);
    if stride < element_size {
        return Err(format!(
            "{what}: bufferView {} has byteStride {stride}, smaller than the {element_size}-byte element",
            view.index()
        ));
    }
    if count == 0 {
        return Ok(Strided {
            bytes: &[],
            stride,
            element_size,
            count,
        });
    }
    // The last element ends at offset + stride·(count − 1) + element_size.
    let end = stride
        .checked_mul(count - 1)
        .and_then(|s| s.checked_add(offset))
        .and_then(|s| s.checked_add(element_size))
        .filter(|&end| end <= view_bytes.len())
        .ok_or_else(|| {
            format!(
                "{what} is out of range: {count} elements of {element_size} bytes (stride {stride}) \
                 from byte {offset} do not fit in bufferView {} of {} bytes",
                view.index(),
                view_bytes.len()
            )
        })?;
    Ok(Strided {
        bytes: &view_bytes[offset..end],
        stride,
        element_size,
        count,
    })
}

fn read_index(t: DataType, b: &[u8]) -> u32 {
    match t {
        DataType::U8 => u32::from(b[0]),
        DataType::U16 => u32::from(u16::from_le_bytes([b[0], b[1]])),
        _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
    }
}

/// Reads the sparse substitutions of `accessor`: (element index, element bytes) pairs.
fn sparse_elements<'b>(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    element_size: usize,
    buffers: &'b Buffers,
    budget: &mut Budget,
) -> Result<Vec<(usize, &'b [u8])>, String> {
    let Some(sparse) = accessor.sparse() else {
        return Ok(Vec::new());
    };
    let n = sparse.count();
    let indices = sparse.indices();
    // `index_type` panics on any other type: `load::prevalidate` refused those already.
    let index_type = match indices.index_type() {
        gltf::accessor::sparse::IndexType::U8 => DataType::U8,
        gltf::accessor::sparse::IndexType::U16 => DataType::U16,
        gltf::accessor::sparse::IndexType::U32 => DataType::U32,
    };
    // Sparse indices and values are tightly packed (the specification forbids byteStride here).
    let index_size = component_size(index_type);
    let idx = locate(
        &format!("{what} (sparse indices)"),
        indices.view(),
        indices.offset(),
        n,
        index_size,
        buffers,
    )?;
    let values = sparse.values();
    let vals = locate(
        &format!("{what} (sparse values)"),
        values.view(),
        values.offset(),
        n,
        element_size,
        buffers,
    )?;
    // `locate` proved that n indices are in the buffers, so n is bounded by the input's size.
    let mut out = budget.vec(&format!("{what} (sparse)"), n)?;
    for k in 0..n {
        let i = read_index(index_type, &idx.bytes[k * index_size..(k + 1) * index_size]) as usize;
        if i >= accessor.count() {
            return Err(format!(
                "{what}: sparse index entry {k} is out of range (the accessor has {} elements)",
                accessor.count()
            ));
        }
        out.push((i, &vals.bytes[k * element_size..(k + 1) * element_size]));
    }
    Ok(out)
}

/// Reads the raw bytes of each element of `accessor` (its dense data with sparse substitutions
/// applied) and hands each to `decode`. The result is charged to `budget` before it is
/// allocated: an accessor without a buffer view states its count freely.
fn read_elements<T>(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    element_size: usize,
    buffers: &Buffers,
    budget: &mut Budget,
    zero: T,
    decode: impl Fn(&[u8]) -> T,
) -> Result<Vec<T>, String>
where
    T: Clone,
{
    let count = accessor.count();
    let mut out = match accessor.view() {
        Some(view) => {
            let run = locate(what, view, accessor.offset(), count, element_size, buffers)?;
            let mut out = budget.vec(what, run.count)?;
            out.extend((0..run.count).map(|i| decode(run.element(i))));
            out
        }
        // No buffer view: every element is zero unless a sparse substitution says otherwise.
        // Nothing in the files holds these elements, so they also count against the unbacked
        // allowance: a few bytes of JSON could otherwise ask for gigabytes.
        None => {
            budget.charge_unbacked::<T>(what, count)?;
            let mut out = budget.vec(what, count)?;
            out.resize(count, zero);
            out
        }
    };
    for (i, bytes) in sparse_elements(what, accessor, element_size, buffers, budget)? {
        out[i] = decode(bytes);
    }
    Ok(out)
}

/// A mesh attribute, and the component types glTF 2.0 allows it, and `KHR_mesh_quantization`
/// where the file uses the extension (its table of attribute types).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Quantized {
    /// `POSITION` (`VEC3`): `FLOAT`; with the extension `BYTE`, `UNSIGNED_BYTE`, `SHORT` or
    /// `UNSIGNED_SHORT`, normalized or not.
    Position,
    /// `NORMAL` (`VEC3`): `FLOAT`; with the extension normalized `BYTE` or `SHORT`.
    Normal,
    /// `TANGENT` (`VEC4`): `FLOAT`; with the extension normalized `BYTE` or `SHORT`.
    Tangent,
    /// `TEXCOORD_n` (`VEC2`): `FLOAT` or normalized `UNSIGNED_BYTE` or `UNSIGNED_SHORT`; with
    /// the extension also normalized `BYTE` or `SHORT`, and the four not normalized.
    TexCoord,
}

impl Quantized {
    fn dimensions(self) -> Dimensions {
        match self {
            Quantized::Position | Quantized::Normal => Dimensions::Vec3,
            Quantized::Tangent => Dimensions::Vec4,
            Quantized::TexCoord => Dimensions::Vec2,
        }
    }

    fn allows(self, t: DataType, normalized: bool, extension: bool) -> bool {
        use DataType::{F32, I8, I16, U8, U16};
        match (self, t) {
            (_, F32) => true,
            (Quantized::TexCoord, U8 | U16) => normalized || extension,
            (Quantized::TexCoord, I8 | I16) => extension,
            (Quantized::Position, I8 | U8 | I16 | U16) => extension,
            (Quantized::Normal | Quantized::Tangent, I8 | I16) => extension && normalized,
            _ => false,
        }
    }

    fn wanted(self, extension: bool) -> String {
        let core = match self {
            Quantized::TexCoord => {
                "VEC2 of FLOAT, or of normalized UNSIGNED_BYTE or UNSIGNED_SHORT"
            }
            Quantized::Position | Quantized::Normal => "VEC3 of FLOAT",
            Quantized::Tangent => "VEC4 of FLOAT",
        };
        let more = match self {
            Quantized::Position => "8- or 16-bit integers, normalized or not",
            Quantized::Normal | Quantized::Tangent => "normalized BYTE or SHORT",
            Quantized::TexCoord => "BYTE or SHORT normalized, or any 8- or 16-bit integer not",
        };
        if extension {
            format!("{core}, or {more} (KHR_mesh_quantization)")
        } else {
            format!("{core} (KHR_mesh_quantization, which the file does not use, allows {more})")
        }
    }
}

/// Reads a mesh attribute `kind` of `N` components (2, 3 or 4 as `kind` has) as floats: a
/// `FLOAT` as it is, an integer component by [`component`]'s rule. `extension`: whether the
/// file uses `KHR_mesh_quantization` (else only glTF 2.0's own types are read).
pub(crate) fn read_attribute<const N: usize>(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    (kind, extension): (Quantized, bool),
    buffers: &Buffers,
    budget: &mut Budget,
) -> Result<Vec<[f32; N]>, String> {
    let (t, d, normalized) = (
        accessor.data_type(),
        accessor.dimensions(),
        accessor.normalized(),
    );
    if d != kind.dimensions() || !kind.allows(t, normalized, extension) {
        return Err(unreadable(what, accessor, &kind.wanted(extension)));
    }
    let size = component_size(t);
    read_elements(what, accessor, N * size, buffers, budget, [0.0; N], |b| {
        std::array::from_fn(|k| component(t, normalized, b, k))
    })
}

/// Reads a `VEC3` of `FLOAT` accessor (an animation's translations and scales).
pub(crate) fn read_vec3(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    buffers: &Buffers,
    budget: &mut Budget,
) -> Result<Vec<[f32; 3]>, String> {
    read_floats(what, accessor, Dimensions::Vec3, buffers, budget)
}

/// Reads a `VEC4` accessor of `FLOAT` (an animation's rotations).
pub(crate) fn read_vec4(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    buffers: &Buffers,
    budget: &mut Budget,
) -> Result<Vec<[f32; 4]>, String> {
    read_floats(what, accessor, Dimensions::Vec4, buffers, budget)
}

/// Reads a `SCALAR` accessor of `FLOAT` (animation key times).
pub(crate) fn read_scalars(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    buffers: &Buffers,
    budget: &mut Budget,
) -> Result<Vec<f32>, String> {
    Ok(
        read_floats::<1>(what, accessor, Dimensions::Scalar, buffers, budget)?
            .into_iter()
            .map(|[x]| x)
            .collect(),
    )
}

/// Reads an accessor of `N` `FLOAT` components, whose dimensions must be `dims`.
fn read_floats<const N: usize>(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    dims: Dimensions,
    buffers: &Buffers,
    budget: &mut Budget,
) -> Result<Vec<[f32; N]>, String> {
    let (t, d) = (accessor.data_type(), accessor.dimensions());
    if d != dims || t != DataType::F32 {
        return Err(format!(
            "{what} is {} of {}; irr reads {} of FLOAT only (quantized attributes, \
             KHR_mesh_quantization, are not supported)",
            dims_name(d),
            type_name(t),
            dims_name(dims)
        ));
    }
    read_elements(what, accessor, 4 * N, buffers, budget, [0.0; N], |b| {
        std::array::from_fn(|k| {
            f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]])
        })
    })
}

/// The message for an accessor (`what`) of a shape or type irr does not read: what it is, and
/// what irr reads (`wanted`).
fn unreadable(what: &str, accessor: &gltf::Accessor<'_>, wanted: &str) -> String {
    format!(
        "{what} is {} of {}{}; irr reads {wanted}",
        dims_name(accessor.dimensions()),
        type_name(accessor.data_type()),
        if accessor.normalized() {
            " (normalized)"
        } else {
            ""
        }
    )
}

/// Whether `accessor` holds `FLOAT`s, or normalized `UNSIGNED_BYTE`s or `UNSIGNED_SHORT`s: the
/// component types glTF allows for texture coordinates and colours.
fn float_or_normalized(accessor: &gltf::Accessor<'_>) -> bool {
    match accessor.data_type() {
        DataType::F32 => true,
        DataType::U8 | DataType::U16 => accessor.normalized(),
        _ => false,
    }
}

/// Component `k` of element `b` of type `t` as a float: a `FLOAT` as it is, a normalized
/// `UNSIGNED_BYTE` or `UNSIGNED_SHORT` as c / 255 or c / 65535 (glTF 2.0 §3.11's rule). The
/// caller has checked that `b` holds the element's components.
fn float_component(t: DataType, b: &[u8], k: usize) -> f32 {
    component(t, true, b, k)
}

/// Component `k` of element `b` of type `t` as a float: a `FLOAT` as it is; an integer c,
/// normalized, by glTF 2.0 §3.11's rule (c / 255, max(c / 127, −1), c / 65535,
/// max(c / 32767, −1)), and as its value otherwise. The caller has checked that `b` holds the
/// element's components (and that `t` is not `UNSIGNED_INT`, which no float attribute uses).
fn component(t: DataType, normalized: bool, b: &[u8], k: usize) -> f32 {
    let scale = |c: f32, max: f32| if normalized { (c / max).max(-1.0) } else { c };
    match t {
        DataType::U8 => scale(f32::from(b[k]), 255.0),
        DataType::I8 => scale(f32::from(b[k].cast_signed()), 127.0),
        DataType::U16 => scale(
            f32::from(u16::from_le_bytes([b[2 * k], b[2 * k + 1]])),
            65535.0,
        ),
        DataType::I16 => scale(
            f32::from(i16::from_le_bytes([b[2 * k], b[2 * k + 1]])),
            32767.0,
        ),
        _ => f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]]),
    }
}

/// Reads a `COLOR_n` accessor: `VEC3` or `VEC4` of `FLOAT`, or of normalized `UNSIGNED_BYTE`
/// or `UNSIGNED_SHORT` (glTF 2.0 §3.7.2.1), as linear RGBA (alpha 1 for `VEC3`).
pub(crate) fn read_colours(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    buffers: &Buffers,
    budget: &mut Budget,
) -> Result<Vec<[f32; 4]>, String> {
    let (t, d) = (accessor.data_type(), accessor.dimensions());
    let components = match d {
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        _ => 0,
    };
    if components == 0 || !float_or_normalized(accessor) {
        return Err(unreadable(
            what,
            accessor,
            "VEC3 or VEC4 of FLOAT, or of normalized UNSIGNED_BYTE or UNSIGNED_SHORT",
        ));
    }
    let size = component_size(t);
    read_elements(
        what,
        accessor,
        components * size,
        buffers,
        budget,
        [0.0, 0.0, 0.0, 1.0],
        |b| {
            [0, 1, 2, 3].map(|k| {
                if k < components {
                    float_component(t, b, k)
                } else {
                    1.0
                }
            })
        },
    )
}

/// Reads a `SCALAR` index accessor of `UNSIGNED_BYTE`, `UNSIGNED_SHORT` or `UNSIGNED_INT`.
pub(crate) fn read_indices(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    buffers: &Buffers,
    budget: &mut Budget,
) -> Result<Vec<u32>, String> {
    let (t, d) = (accessor.data_type(), accessor.dimensions());
    if d != Dimensions::Scalar || !matches!(t, DataType::U8 | DataType::U16 | DataType::U32) {
        return Err(format!(
            "{what} is {} of {}; indices must be SCALAR of UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
            dims_name(d),
            type_name(t)
        ));
    }
    read_elements(what, accessor, component_size(t), buffers, budget, 0, |b| {
        read_index(t, b)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// glTF 2.0 §3.11's normalization, every integer type at its ends and between, and the
    /// values as they are when not normalized; a normalized `FLOAT` or `UNSIGNED_BYTE` reads as
    /// before (`float_component`).
    #[test]
    fn integer_components_follow_the_normalization_rule() {
        let i8s = [127i8, -127, -128, 64].map(i8::cast_unsigned);
        let got = |t, n, b: &[u8], k| component(t, n, b, k);
        assert_eq!(got(DataType::I8, true, &i8s, 0), 1.0);
        assert_eq!(got(DataType::I8, true, &i8s, 1), -1.0);
        assert_eq!(got(DataType::I8, true, &i8s, 2), -1.0, "−128 clamps to −1");
        assert_eq!(got(DataType::I8, true, &i8s, 3), 64.0 / 127.0);
        assert_eq!(got(DataType::I8, false, &i8s, 2), -128.0);
        assert_eq!(got(DataType::U8, true, &[255, 0], 0), 1.0);
        assert_eq!(got(DataType::U8, false, &[255, 0], 0), 255.0);
        let i16s: Vec<u8> = [32767i16, -32768, 100]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(got(DataType::I16, true, &i16s, 0), 1.0);
        assert_eq!(got(DataType::I16, true, &i16s, 1), -1.0);
        assert_eq!(got(DataType::I16, true, &i16s, 2), 100.0 / 32767.0);
        assert_eq!(got(DataType::I16, false, &i16s, 1), -32768.0);
        let u16s = 65535u16.to_le_bytes();
        assert_eq!(got(DataType::U16, true, &u16s, 0), 1.0);
        assert_eq!(got(DataType::U16, false, &u16s, 0), 65535.0);
        for c in 0..=255u8 {
            assert_eq!(
                float_component(DataType::U8, &[c], 0).to_bits(),
                (f32::from(c) / 255.0).to_bits()
            );
        }
        let f = 0.3f32.to_le_bytes();
        assert_eq!(got(DataType::F32, false, &f, 0), 0.3);
    }
}
