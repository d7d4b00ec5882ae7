//! Reading glTF accessors (glTF 2.0 §3.6 "Binary Data Storage") with every offset, stride and
//! count checked against the bytes that are really there. A file that lies about its sizes gives
//! an error naming the accessor, never a panic or an out-of-bounds read.
//!
//! Supported: `FLOAT` vectors (positions, normals), `FLOAT` or normalized `UNSIGNED_BYTE` /
//! `UNSIGNED_SHORT` `VEC2`s (texture coordinates), `UNSIGNED_BYTE`/`SHORT`/`INT` scalars
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

/// Reads a `VEC3` of `FLOAT` accessor (positions, normals).
pub(crate) fn read_vec3(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    buffers: &Buffers,
    budget: &mut Budget,
) -> Result<Vec<[f32; 3]>, String> {
    read_floats(what, accessor, Dimensions::Vec3, buffers, budget)
}

/// Reads a `VEC4` accessor of `FLOAT` (`TANGENT`).
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

/// Reads a `VEC2` texture coordinate accessor (`TEXCOORD_n`): `FLOAT`, or normalized
/// `UNSIGNED_BYTE` / `UNSIGNED_SHORT` mapped to [0, 1] by c / 255 and c / 65535 (glTF 2.0
/// §3.7.2.1 "Meshes", §3.11 "Animations"' normalization rule).
pub(crate) fn read_tex_coords(
    what: &str,
    accessor: &gltf::Accessor<'_>,
    buffers: &Buffers,
    budget: &mut Budget,
) -> Result<Vec<[f32; 2]>, String> {
    let (t, d) = (accessor.data_type(), accessor.dimensions());
    if d != Dimensions::Vec2 || !float_or_normalized(accessor) {
        return Err(unreadable(
            what,
            accessor,
            "VEC2 of FLOAT, or of normalized UNSIGNED_BYTE or UNSIGNED_SHORT \
             (KHR_mesh_quantization is not supported)",
        ));
    }
    let size = component_size(t);
    read_elements(what, accessor, 2 * size, buffers, budget, [0.0; 2], |b| {
        [0, 1].map(|k| float_component(t, b, k))
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
    match t {
        DataType::U8 => f32::from(b[k]) / 255.0,
        DataType::U16 => f32::from(u16::from_le_bytes([b[2 * k], b[2 * k + 1]])) / 65535.0,
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
