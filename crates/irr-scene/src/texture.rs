//! Textures: linear RGB images looked up at a texture coordinate, with glTF's sampler rules
//! (which are OpenGL's), and the per-triangle texture coordinates an integrator's scene
//! keeps for the triangles of textured materials.
//!
//! Coordinates follow glTF: (0, 0) is the first texel of the first row of the image (its
//! top-left corner as a file stores it), u grows along a row and v down the rows. Texel (i, j)
//! covers [i/W, (i+1)/W] × [j/H, (j+1)/H] and its centre is at ((i + ½)/W, (j + ½)/H).

use glam::{Affine2, Vec2, Vec3, Vec4};
use std::sync::Arc;
use thiserror::Error;

/// How a coordinate outside [0, 1] maps into the image (glTF's `wrapS` / `wrapT`, with OpenGL's
/// rules: OpenGL 4.6 §8.14.2, table 8.20, applied to texel indices).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles the plane: texel index i mod n. glTF's default.
    #[default]
    Repeat,
    /// Coordinates are clamped to the edge texels: index clamped to [0, n − 1].
    ClampToEdge,
    /// The image tiles the plane, every other copy mirrored: with m = i mod 2n, index m when
    /// m < n, else 2n − 1 − m.
    MirroredRepeat,
}

impl Wrap {
    /// The texel index that index `i` (any integer) wraps to in an image `n` texels wide.
    #[inline]
    fn apply(self, i: i64, n: i64) -> usize {
        let k = match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n { m } else { 2 * n - 1 - m }
            }
        };
        // 0 ≤ k < n ≤ u32::MAX.
        k as usize
    }
}

/// How a lookup between texel centres is filtered (glTF's `magFilter`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    /// The texel whose square holds the coordinate.
    Nearest,
    /// Bilinear interpolation of the four texels whose centres surround the coordinate, each
    /// wrapped on its own (OpenGL's `LINEAR`). glTF's usual default.
    #[default]
    Linear,
}

/// A texture's wrap modes and filter (a glTF sampler).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sampler {
    /// Wrapping of u (glTF `wrapS`).
    pub wrap_s: Wrap,
    /// Wrapping of v (glTF `wrapT`).
    pub wrap_t: Wrap,
    /// The filter of every lookup. irr has no mip maps and no ray footprints: a texture that
    /// covers less than a pixel is averaged by the pixel's own samples (the box filter of the
    /// film), so glTF's `minFilter` has no counterpart here.
    pub filter: Filter,
}

/// A texture that cannot be made.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum TextureError {
    /// The texel count is not width × height, or the image is empty.
    #[error("a {width}×{height} texture needs {width}×{height} texels, not {texels}")]
    Size {
        /// Width in texels.
        width: u32,
        /// Height in texels.
        height: u32,
        /// The texels given.
        texels: usize,
    },
    /// A texel is negative or not finite.
    #[error("texel {index} is {value}: texels must be finite and ≥ 0")]
    InvalidTexel {
        /// Its index, row by row.
        index: usize,
        /// Its value.
        value: Vec3,
    },
}

/// A linear RGB image with its sampler. Cloning shares the texels.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    width: u32,
    height: u32,
    /// Row by row from the top (glTF's v = 0).
    texels: Arc<[Vec3]>,
    sampler: Sampler,
    /// The mean texel, summed in f64.
    mean: Vec3,
    /// The largest texel component.
    max: f32,
}

impl Texture {
    /// A `width` × `height` texture; `texels` holds the rows from the top (v = 0), each from
    /// the left (u = 0), in linear RGB, finite and non-negative.
    ///
    /// # Errors
    /// [`TextureError::Size`] for an empty image or a texel count other than width × height,
    /// [`TextureError::InvalidTexel`] for a negative or non-finite texel.
    pub fn new(
        width: u32,
        height: u32,
        texels: Vec<Vec3>,
        sampler: Sampler,
    ) -> Result<Self, TextureError> {
        let expected = u64::from(width) * u64::from(height);
        if expected == 0 || texels.len() as u64 != expected {
            return Err(TextureError::Size {
                width,
                height,
                texels: texels.len(),
            });
        }
        if let Some((index, &value)) = texels
            .iter()
            .enumerate()
            .find(|(_, t)| !(t.is_finite() && t.min_element() >= 0.0))
        {
            return Err(TextureError::InvalidTexel { index, value });
        }
        let mut sum = glam::DVec3::ZERO;
        let mut max = 0.0f32;
        for t in &texels {
            sum += t.as_dvec3();
            max = max.max(t.max_element());
        }
        Ok(Self {
            width,
            height,
            mean: (sum / texels.len() as f64).as_vec3(),
            max,
            texels: texels.into(),
            sampler,
        })
    }

    /// The same image with another sampler (the texels are shared, not copied).
    #[must_use]
    pub fn with_sampler(&self, sampler: Sampler) -> Self {
        Self {
            sampler,
            ..self.clone()
        }
    }

    /// Width in texels.
    #[inline]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in texels.
    #[inline]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The sampler.
    #[inline]
    pub fn sampler(&self) -> Sampler {
        self.sampler
    }

    /// The mean of the texels: the texture's average over one period of [0, 1]².
    #[inline]
    pub fn mean(&self) -> Vec3 {
        self.mean
    }

    /// The largest texel component (a lookup never exceeds it: both filters take convex
    /// combinations of texels).
    #[inline]
    pub fn max_value(&self) -> f32 {
        self.max
    }

    /// Texel (x, y), row y from the top; wraps like the sampler.
    #[inline]
    pub fn texel(&self, x: i64, y: i64) -> Vec3 {
        let (w, h) = (i64::from(self.width), i64::from(self.height));
        let i = self.sampler.wrap_s.apply(x, w);
        let j = self.sampler.wrap_t.apply(y, h);
        self.texels[j * self.width as usize + i]
    }

    /// The filtered value at texture coordinate `uv`. Never panics: a non-finite coordinate
    /// reads as 0, and coordinates beyond ±2⁴⁰ texels are clamped there (f32 coordinates that
    /// large have no sub-texel precision left).
    #[inline]
    pub fn lookup(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (i64::from(self.width), i64::from(self.height));
        match self.sampler.filter {
            Filter::Nearest => {
                let (i, _) = split(uv.x, w, 0.0);
                let (j, _) = split(uv.y, h, 0.0);
                self.texel(i, j)
            }
            Filter::Linear => {
                // Texel centres sit at half-integers: shift by ½ and blend the four texels
                // around the point by its fractional position (OpenGL's LINEAR).
                let (i, fx) = split(uv.x, w, 0.5);
                let (j, fy) = split(uv.y, h, 0.5);
                let top = self.texel(i, j).lerp(self.texel(i + 1, j), fx);
                let bottom = self.texel(i, j + 1).lerp(self.texel(i + 1, j + 1), fx);
                top.lerp(bottom, fy)
            }
        }
    }
}

/// The integer and fractional parts of c·n − shift, computed in f64 (exact for any f32 c and
/// n ≤ 2³², before the floor); a non-finite c counts as 0 and the result is kept within ±2⁴⁰ so
/// that index arithmetic cannot overflow.
#[inline]
fn split(c: f32, n: i64, shift: f64) -> (i64, f32) {
    const LIMIT: f64 = (1u64 << 40) as f64;
    let c = if c.is_finite() { f64::from(c) } else { 0.0 };
    let x = (c * n as f64 - shift).clamp(-LIMIT, LIMIT);
    let i = x.floor();
    (i as i64, (x - i) as f32)
}

/// A material's use of a texture: which one, with which texture coordinate set, through which
/// transform (glTF's `textureInfo` with `KHR_texture_transform`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    /// The texture's index in the scene's textures.
    pub texture: u32,
    /// The texture coordinate set (glTF `TEXCOORD_n`).
    pub tex_coord: u32,
    /// Applied to the interpolated coordinate before the lookup (identity without
    /// `KHR_texture_transform`).
    pub transform: Affine2,
}

impl TextureRef {
    /// Texture `texture` read with coordinate set `tex_coord`, untransformed.
    pub fn new(texture: u32, tex_coord: u32) -> Self {
        Self {
            texture,
            tex_coord,
            transform: Affine2::IDENTITY,
        }
    }
}

/// The texture coordinates at the three vertices of each triangle of a textured material, by
/// triangle id, one triple per coordinate set the triangle's material reads (see
/// [`Material::tex_coord_sets`](crate::Material::tex_coord_sets)). Empty when no material is
/// textured, so an untextured scene stores nothing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TexCoords {
    /// `offsets[t]..offsets[t + 1]` are triangle t's entries of `uv`; empty, or one longer
    /// than the number of triangles.
    offsets: Vec<u32>,
    uv: Vec<[Vec2; 3]>,
}

/// More texture coordinates than a [`TexCoords`] can index (2³² − 1 triples).
#[derive(Clone, Copy, Debug, Error, PartialEq, Eq)]
#[error("more than {} texture coordinate triples", u32::MAX)]
pub struct TooManyTexCoords;

impl TexCoords {
    /// Adds the next triangle (ids in order from 0): one triple per coordinate set its
    /// material reads, in the order of `Material::tex_coord_sets`; none for an untextured
    /// material.
    ///
    /// # Errors
    /// [`TooManyTexCoords`] past 2³² − 1 triples in all.
    pub fn push(&mut self, sets: &[[Vec2; 3]]) -> Result<(), TooManyTexCoords> {
        if self.offsets.is_empty() {
            self.offsets.push(0);
        }
        let end = u32::try_from(self.uv.len() + sets.len()).map_err(|_| TooManyTexCoords)?;
        self.uv.extend_from_slice(sets);
        self.offsets.push(end);
        Ok(())
    }

    /// The number of triangles added.
    #[inline]
    pub fn triangle_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Whether no triangle has been added.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.triangle_count() == 0
    }

    /// The triples of triangle `triangle` (empty for an id past the end).
    #[inline]
    pub fn of(&self, triangle: u32) -> &[[Vec2; 3]] {
        let t = triangle as usize;
        match (self.offsets.get(t), self.offsets.get(t + 1)) {
            (Some(&a), Some(&b)) => self.uv.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    }

    /// The coordinate of entry `slot` of triangle `triangle` at barycentrics (b1, b2); zero
    /// where there is no such entry.
    #[inline]
    pub fn at(&self, triangle: u32, slot: usize, b1: f32, b2: f32) -> Vec2 {
        match self.of(triangle).get(slot) {
            Some(uv) => (1.0 - b1 - b2) * uv[0] + b1 * uv[1] + b2 * uv[2],
            None => Vec2::ZERO,
        }
    }
}

/// More triangles with values than a [`VertexAttribute`] can index (2³² − 1).
#[derive(Clone, Copy, Debug, Error, PartialEq, Eq)]
#[error("more than {} triangles with per-vertex values", u32::MAX - 1)]
pub struct TooManyAttributeTriangles;

/// Values at the three vertices of the triangles that have them, by triangle id, interpolated
/// barycentrically: [`VertexColours`] (glTF `COLOR_0`) and [`VertexTangents`] (glTF
/// `TANGENT`). Empty when no triangle has any, so a scene without them stores nothing.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexAttribute<T> {
    /// Per triangle, its entry of `values`, or `u32::MAX` for none.
    index: Vec<u32>,
    values: Vec<[T; 3]>,
}

impl<T> Default for VertexAttribute<T> {
    fn default() -> Self {
        Self {
            index: Vec::new(),
            values: Vec::new(),
        }
    }
}

/// The colours at the three vertices of the triangles that have them (glTF `COLOR_0`, linear
/// RGB in [0, 1]), by triangle id: they multiply the base colour.
pub type VertexColours = VertexAttribute<Vec3>;

/// The tangents at the three vertices of the triangles whose material has a normal texture
/// (glTF `TANGENT`, or MikkTSpace's where the file has none), in world space: xyz a unit
/// tangent along which the normal texture's u grows, w = ±1 the handedness, so that the
/// bitangent is w·(n × t).
pub type VertexTangents = VertexAttribute<Vec4>;

impl<T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>> VertexAttribute<T> {
    /// Adds the next triangle (ids in order from 0) with its vertices' values, or none.
    ///
    /// # Errors
    /// [`TooManyAttributeTriangles`] past 2³² − 2 triangles with values.
    pub fn push(&mut self, values: Option<[T; 3]>) -> Result<(), TooManyAttributeTriangles> {
        let entry = match values {
            None => u32::MAX,
            Some(c) => {
                let i = u32::try_from(self.values.len())
                    .ok()
                    .filter(|&i| i < u32::MAX)
                    .ok_or(TooManyAttributeTriangles)?;
                self.values.push(c);
                i
            }
        };
        self.index.push(entry);
        Ok(())
    }

    /// The number of triangles added.
    #[inline]
    pub fn triangle_count(&self) -> usize {
        self.index.len()
    }

    /// Whether no triangle has values.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The values of every triangle that has them.
    #[inline]
    pub fn all(&self) -> &[[T; 3]] {
        &self.values
    }

    /// The values at the vertices of triangle `triangle`, `None` for a triangle without
    /// values (or past the end).
    #[inline]
    pub fn corners(&self, triangle: u32) -> Option<&[T; 3]> {
        self.values
            .get(*self.index.get(triangle as usize)? as usize)
    }

    /// The value of triangle `triangle` at barycentrics (b1, b2), `None` for a triangle
    /// without values (or past the end).
    #[inline]
    pub fn at(&self, triangle: u32, b1: f32, b2: f32) -> Option<T> {
        let c = self.corners(triangle)?;
        Some(c[0] * (1.0 - b1 - b2) + c[1] * b1 + c[2] * b2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testutil::two_by_two;

    /// Vertex colours interpolate barycentrically on the triangles that have them; the others
    /// (and ids past the end) have none.
    #[test]
    fn vertex_colours_interpolate_per_triangle() {
        let mut c = VertexColours::default();
        assert!(c.is_empty());
        let tri = [Vec3::X, Vec3::Y, Vec3::Z];
        for entry in [None, Some(tri), None] {
            c.push(entry).unwrap_or_else(|e| panic!("{e}"));
        }
        assert_eq!(c.triangle_count(), 3);
        assert_eq!(c.at(0, 0.2, 0.3), None);
        assert_eq!(c.at(1, 0.25, 0.5), Some(Vec3::new(0.25, 0.25, 0.5)));
        assert_eq!(c.at(1, 0.0, 0.0), Some(Vec3::X));
        assert_eq!(c.at(2, 0.1, 0.1), None);
        assert_eq!(c.at(7, 0.1, 0.1), None);
    }

    #[test]
    fn nearest_reads_the_texel_whose_square_holds_the_point() {
        let t = two_by_two(Wrap::ClampToEdge, Filter::Nearest);
        assert_eq!(t.lookup(Vec2::new(0.25, 0.25)).z, 0.0);
        assert_eq!(t.lookup(Vec2::new(0.75, 0.25)).z, 1.0);
        assert_eq!(t.lookup(Vec2::new(0.25, 0.75)).z, 10.0);
        assert_eq!(t.lookup(Vec2::new(0.99, 0.99)).z, 11.0);
        // u = 1 lies on the right edge: clamped into the last texel.
        assert_eq!(t.lookup(Vec2::new(1.0, 0.0)).z, 1.0);
    }

    #[test]
    fn wrap_modes_follow_opengl_outside_the_unit_square() {
        // Texel columns for u in [-2, 2) at texel centres, per mode (2 texels wide).
        let us = [-1.75f32, -1.25, -0.75, -0.25, 0.25, 0.75, 1.25, 1.75];
        for (wrap, expected) in [
            (Wrap::Repeat, [0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0]),
            (Wrap::ClampToEdge, [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0]),
            // Mirrored: …, [1 0] mirrored copy of [-1, 0), then [0 1], then [1 0] on [1, 2).
            (
                Wrap::MirroredRepeat,
                [0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0],
            ),
        ] {
            let t = two_by_two(wrap, Filter::Nearest);
            let got: Vec<f32> = us.iter().map(|&u| t.lookup(Vec2::new(u, 0.25)).x).collect();
            assert_eq!(got, expected, "{wrap:?}");
            // v wraps the same way (the y component names the row).
            let got: Vec<f32> = us.iter().map(|&v| t.lookup(Vec2::new(0.25, v)).y).collect();
            assert_eq!(got, expected, "{wrap:?} in v");
        }
    }

    #[test]
    fn linear_interpolates_between_texel_centres() {
        let t = two_by_two(Wrap::ClampToEdge, Filter::Linear);
        // At a texel centre, exactly that texel.
        assert_eq!(t.lookup(Vec2::new(0.25, 0.25)), Vec3::ZERO);
        assert_eq!(t.lookup(Vec2::new(0.75, 0.75)), Vec3::new(1.0, 1.0, 11.0));
        // Halfway between all four centres: their mean (every step is exact in f32).
        assert_eq!(t.lookup(Vec2::splat(0.5)), Vec3::new(0.5, 0.5, 5.5));
        // A quarter of the way from column 0's centre to column 1's.
        assert_eq!(t.lookup(Vec2::new(0.375, 0.25)).x, 0.25);
        // Beyond the last centre, clamping holds the edge texel.
        assert_eq!(t.lookup(Vec2::new(0.9, 0.25)).x, 1.0);
        // With repeat, the left edge blends column 0 with column 1 from the previous copy.
        let r = two_by_two(Wrap::Repeat, Filter::Linear);
        assert_eq!(r.lookup(Vec2::new(0.0, 0.25)).x, 0.5);
        // Mirrored: at u = 0 the neighbour across the edge is column 0 itself.
        let m = two_by_two(Wrap::MirroredRepeat, Filter::Linear);
        assert_eq!(m.lookup(Vec2::new(0.0, 0.25)).x, 0.0);
    }

    #[test]
    fn hostile_coordinates_never_panic_and_stay_in_range() {
        for filter in [Filter::Nearest, Filter::Linear] {
            for wrap in [Wrap::Repeat, Wrap::ClampToEdge, Wrap::MirroredRepeat] {
                let t = two_by_two(wrap, filter);
                for c in [
                    f32::NAN,
                    f32::INFINITY,
                    f32::NEG_INFINITY,
                    f32::MAX,
                    -f32::MAX,
                    1e20,
                    -3.5,
                ] {
                    let v = t.lookup(Vec2::new(c, -c));
                    assert!(
                        v.is_finite() && v.max_element() <= t.max_value(),
                        "{c}: {v}"
                    );
                }
            }
        }
    }

    #[test]
    fn mean_and_validation() {
        let t = two_by_two(Wrap::Repeat, Filter::Linear);
        assert_eq!(t.mean(), Vec3::new(0.5, 0.5, 5.5));
        assert_eq!(t.max_value(), 11.0);
        assert!(matches!(
            Texture::new(2, 2, vec![Vec3::ZERO; 3], Sampler::default()),
            Err(TextureError::Size { texels: 3, .. })
        ));
        assert!(Texture::new(0, 0, vec![], Sampler::default()).is_err());
        assert!(matches!(
            Texture::new(1, 1, vec![Vec3::splat(-1.0)], Sampler::default()),
            Err(TextureError::InvalidTexel { index: 0, .. })
        ));
        let shared = t.with_sampler(Sampler {
            filter: Filter::Nearest,
            ..Sampler::default()
        });
        assert!(Arc::ptr_eq(&shared.texels, &t.texels));
    }

    #[test]
    fn tex_coords_interpolate_per_triangle_and_slot() {
        let mut c = TexCoords::default();
        assert!(c.is_empty());
        let a = [Vec2::ZERO, Vec2::X, Vec2::Y];
        let b = [Vec2::ONE, Vec2::ONE, Vec2::ONE];
        c.push(&[a, b]).unwrap_or_else(|e| panic!("{e}"));
        c.push(&[]).unwrap_or_else(|e| panic!("{e}"));
        c.push(&[b]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(c.triangle_count(), 3);
        assert_eq!(c.at(0, 0, 0.25, 0.5), Vec2::new(0.25, 0.5));
        assert_eq!(c.at(0, 1, 0.25, 0.5), Vec2::ONE);
        assert_eq!(c.at(1, 0, 0.25, 0.5), Vec2::ZERO);
        assert_eq!(c.at(2, 0, 0.0, 0.0), Vec2::ONE);
        assert_eq!(c.at(7, 0, 0.0, 0.0), Vec2::ZERO);
    }
}
