//! The typed errors of [`Geometry::build`](crate::Geometry::build): every way a user's meshes can
//! be unusable, each naming the mesh (its index in the slice) and, where there is one, the triangle.

/// Why a set of meshes could not be turned into a [`Geometry`](crate::Geometry).
///
/// Bad triangles (zero area, non-finite coordinates) are *not* errors: they are dropped and
/// counted in the [`BuildReport`](crate::BuildReport). These errors are for input that cannot be
/// read at all, and for a scene with nothing left to trace.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GeometryError {
    /// No triangle survived: the meshes were empty, or every triangle was dropped.
    #[error(
        "no triangles left after dropping {dropped_degenerate} degenerate and \
         {dropped_non_finite} non-finite"
    )]
    EmptyScene {
        /// Triangles dropped for zero area.
        dropped_degenerate: usize,
        /// Triangles dropped for a NaN or infinite coordinate.
        dropped_non_finite: usize,
    },
    /// A triangle names a vertex that the mesh does not have.
    #[error(
        "mesh {mesh}, triangle {triangle}: vertex index {index} is out of range \
         (the mesh has {vertex_count} positions)"
    )]
    IndexOutOfRange {
        /// Index of the mesh in the slice given to `build`.
        mesh: usize,
        /// Index of the triangle within that mesh.
        triangle: usize,
        /// The offending vertex index.
        index: u32,
        /// How many positions the mesh has.
        vertex_count: usize,
    },
    /// The mesh has shading normals, but not one per position.
    #[error(
        "mesh {mesh}: {normals} shading normals for {positions} positions (need one per position)"
    )]
    NormalCountMismatch {
        /// Index of the mesh in the slice given to `build`.
        mesh: usize,
        /// Length of `normals`.
        normals: usize,
        /// Length of `positions`.
        positions: usize,
    },
    /// The mesh does not have exactly one material id per triangle.
    #[error(
        "mesh {mesh}: {material_ids} material ids for {triangles} triangles (need one per triangle)"
    )]
    MaterialCountMismatch {
        /// Index of the mesh in the slice given to `build`.
        mesh: usize,
        /// Length of `material_ids`.
        material_ids: usize,
        /// Length of `indices`.
        triangles: usize,
    },
    /// More triangles survived than [`MAX_TRIANGLES`](crate::MAX_TRIANGLES) (2³⁰), the most a
    /// geometry can hold.
    #[error("{count} triangles kept: more than the 1073741824 (2^30) that irr can hold")]
    TooManyTriangles {
        /// How many triangles were kept.
        count: usize,
    },
    /// A prototype mesh of [`Geometry::build_instanced`](crate::Geometry::build_instanced) is
    /// malformed (`source` names it as mesh 0).
    #[error("prototype {prototype}: {source}")]
    Prototype {
        /// Index of the prototype in the slice given to the build.
        prototype: usize,
        /// What is wrong with it.
        source: Box<GeometryError>,
    },
    /// An instance names a prototype that was not given.
    #[error("instance {instance} places prototype {prototype}, but there are {prototypes}")]
    PrototypeOutOfRange {
        /// Index of the instance.
        instance: usize,
        /// The prototype it names.
        prototype: u32,
        /// How many prototypes were given.
        prototypes: usize,
    },
    /// The placed triangles need more ids than a `u32` holds.
    #[error("{count} triangles placed: more than the 4294967295 ids a hit can name")]
    TooManyIds {
        /// How many ids they would need.
        count: u64,
    },
}
