//! The pinhole camera of glTF 2.0 (§3.10 "Cameras", and Appendix "Projection Matrices"): it sits
//! at its node's origin, looks down its local −Z with +Y up, and its vertical field of view is
//! `yfov`. The horizontal extent follows from the **image's** aspect ratio (width / height); the
//! `aspectRatio` stored in the file is kept only to warn when it differs.
//!
//! Raster space: x to the right, y **down**, in pixels; pixel (x, y) covers [x, x+1) × [y, y+1),
//! so row 0 is the top of the image. A raster point maps to normalised device coordinates
//! `ndc = (2x/W − 1, 1 − 2y/H)` and to the camera-space direction
//! `(ndc.x · tan(yfov/2) · W/H, ndc.y · tan(yfov/2), −1)`, exactly the inverse of glTF's
//! perspective projection matrix.
//!
//! Clipping planes: rays start on the near plane (z = −znear in camera space) and end on the far
//! plane when the file gives one, as a rasteriser using the same projection would clip.
//!
//! # Matrices for the OpenEXR header
//! [`Camera::world_to_camera`] and [`Camera::world_to_ndc`] follow OpenEXR's standard attributes
//! `worldToCamera` and `worldToNDC` (RenderMan's spaces): camera space is left-handed with +x to
//! the right of the image, +y up and +z along the view direction; NDC has (0, 0) at the image's
//! top-left corner and (1, 1) at its bottom-right, reached after the homogeneous divide.

use crate::animation::CameraPath;
use glam::{DMat4, DVec4, Mat4, Vec2, Vec3};

/// How thin, as a fraction of its largest extent, a box must be along x or y for
/// [`Camera::framing`] to call it flat and look at it from that side. Seen from +Z, such a box
/// is a band under 1.5 % of the image's height (or width) across: the frame's shorter side
/// spans 2r/cos(h) at the camera's distance d = r/sin(h) (r the bounding sphere's radius, at
/// least half the largest extent; h ≤ 22.5° the narrower half field of view), and at the box's
/// nearest, d − r, it spans 2r(1 − sin h)/cos h ≥ 1.33·r.
const FLAT: f32 = 0.01;

/// A pinhole camera in world space (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Centre of projection.
    pub position: Vec3,
    /// Unit view direction (the camera's local −Z in world space).
    pub forward: Vec3,
    /// Unit up direction (local +Y), orthogonal to `forward`.
    pub up: Vec3,
    /// Unit right direction (local +X), `forward × up`.
    pub right: Vec3,
    /// Vertical field of view in radians, in (0, π).
    pub yfov: f32,
    /// Distance to the near clipping plane along `forward` (≥ 0).
    pub znear: f32,
    /// Distance to the far clipping plane along `forward`, if any.
    pub zfar: Option<f32>,
    /// The `aspectRatio` the file gave, if any (irr uses the image's instead).
    pub aspect_ratio_in_file: Option<f32>,
}

/// A camera ray: origin on the near plane, unit direction, and the distance to the far plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraRay {
    /// Where the ray starts (on the near plane).
    pub origin: Vec3,
    /// Unit direction.
    pub direction: Vec3,
    /// Distance along `direction` to the far plane (infinite without one).
    pub t_max: f32,
    /// Distance from the centre of projection to `origin` (0 without a near plane): a hit at
    /// parameter t along the ray is `origin_distance + t` from the camera.
    pub origin_distance: f32,
}

/// One of a glTF file's perspective cameras, with the node that holds it.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedCamera {
    /// The index of the node in the file's `nodes`.
    pub node: usize,
    /// The node's `name`, if it has one (as the file spells it: escape it before printing).
    pub name: Option<String>,
    /// The camera, placed by the node's world transform (its rest pose).
    pub camera: Camera,
    /// Where an animation moves the camera's node or a node above it: its path over time.
    pub path: Option<CameraPath>,
}

impl NamedCamera {
    /// `2 "Side view"` (index and escaped name), or `2` for a node without a name.
    pub fn describe(&self) -> String {
        match &self.name {
            Some(n) => format!("node {} \"{}\"", self.node, crate::one_line(n)),
            None => format!("node {}", self.node),
        }
    }
}

impl Camera {
    /// A camera at `position` looking at `target`, with `up` as the approximate up direction and
    /// vertical field of view `yfov` (radians). Returns `None` if the directions are degenerate
    /// (target at the position, up parallel to the view) or `yfov` is not in (0, π).
    pub fn look_at(position: Vec3, target: Vec3, up: Vec3, yfov: f32) -> Option<Self> {
        let forward = (target - position).try_normalize()?;
        let right = forward.cross(up).try_normalize()?;
        let up = right.cross(forward);
        (yfov > 0.0 && yfov < std::f32::consts::PI && position.is_finite()).then_some(Self {
            position,
            forward,
            up,
            right,
            yfov,
            znear: 0.0,
            zfar: None,
            aspect_ratio_in_file: None,
        })
    }

    /// The camera of a glTF node with world transform `world`: local −Z is the view direction,
    /// local +Y the up direction. Scale and shear in `world` are removed (the axes are
    /// re-orthonormalised, −Z kept exactly); `None` if the transform collapses the axes.
    ///
    /// The basis comes straight from the transform's columns, in f64: the view direction is
    /// never recovered as a difference of two far-away points (at 3·10⁶ m from the origin, an
    /// f32 `target − position` keeps only a few bits of the direction).
    pub fn from_node(world: Mat4, yfov: f32) -> Option<Self> {
        let m = world.as_dmat4();
        let position = m.w_axis.truncate();
        let forward = (-m.z_axis.truncate()).try_normalize()?;
        let right = forward.cross(m.y_axis.truncate()).try_normalize()?;
        let up = right.cross(forward);
        let position = position.as_vec3();
        (yfov > 0.0 && yfov < std::f32::consts::PI && position.is_finite()).then_some(Self {
            position,
            forward: forward.as_vec3(),
            up: up.as_vec3(),
            right: right.as_vec3(),
            yfov,
            znear: 0.0,
            zfar: None,
            aspect_ratio_in_file: None,
        })
    }

    /// A camera that frames the box `[lo, hi]` for an image of aspect ratio `aspect` (width /
    /// height): from the +Z side of the box's centre, looking down −Z (the orientation of a glTF
    /// camera with an identity transform), vertical field of view 45°, far enough away that the
    /// box's bounding sphere fits in both the vertical and horizontal fields of view.
    ///
    /// A box flat across that view (thinner in x or y than 1 % of its largest extent) would be
    /// seen edge-on, as a line or nothing: flat in y (a floor, a plane in y = 0) it is seen from
    /// above instead, the view tilted 45° down from +Z about the x axis; flat in x (a wall in
    /// the yz-plane), from the +X side, turned 45° about the y axis. The distance is the same
    /// (the bounding sphere fits in every direction), and every other box is framed exactly as
    /// before.
    pub fn framing(lo: Vec3, hi: Vec3, aspect: f32) -> Self {
        let yfov = std::f32::consts::FRAC_PI_4;
        let centre = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(f32::MIN_POSITIVE);
        let half_y = 0.5 * yfov;
        let half_x = (half_y.tan() * aspect.max(f32::MIN_POSITIVE)).atan();
        let distance = radius / half_y.min(half_x).sin();
        let size = hi - lo;
        let flat = |extent: f32| extent < FLAT * size.max_element();
        let s = std::f32::consts::FRAC_1_SQRT_2;
        // (direction from the centre to the camera, up, right), with right = forward × up.
        let (position, forward, up, right) = if flat(size.y) {
            let back = Vec3::new(0.0, s, s);
            (
                centre + back * distance,
                -back,
                Vec3::new(0.0, s, -s),
                Vec3::X,
            )
        } else if flat(size.x) {
            let back = Vec3::new(s, 0.0, s);
            (
                centre + back * distance,
                -back,
                Vec3::Y,
                Vec3::new(s, 0.0, -s),
            )
        } else {
            (
                centre + Vec3::new(0.0, 0.0, distance),
                Vec3::NEG_Z,
                Vec3::Y,
                Vec3::X,
            )
        };
        Self {
            position,
            forward,
            up,
            right,
            yfov,
            znear: 0.0,
            zfar: None,
            aspect_ratio_in_file: None,
        }
    }

    /// The ray through raster point `raster` (pixels, y down, (0, 0) the top-left corner of the
    /// image) of a `width` × `height` image.
    pub fn ray(&self, raster: Vec2, width: u32, height: u32) -> CameraRay {
        self.projection(width, height).ray(raster)
    }

    /// The camera prepared for the rays of a `width` × `height` image (the field of view's
    /// tangent computed once): [`Projection::ray`] is [`Camera::ray`], bit for bit.
    pub fn projection(&self, width: u32, height: u32) -> Projection {
        Projection {
            camera: *self,
            size: Vec2::new(width as f32, height as f32),
            tan_half: (0.5 * self.yfov).tan(),
        }
    }
}

/// A [`Camera`] prepared for the rays of one image size ([`Camera::projection`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    camera: Camera,
    size: Vec2,
    tan_half: f32,
}

impl Projection {
    /// The ray through raster point `raster` ([`Camera::ray`]).
    #[inline]
    pub fn ray(&self, raster: Vec2) -> CameraRay {
        let (c, w, h, tan_half) = (&self.camera, self.size.x, self.size.y, self.tan_half);
        let ndc = Vec2::new(2.0 * raster.x / w - 1.0, 1.0 - 2.0 * raster.y / h);
        // Camera-space direction with z = −1: a point of the plane one unit in front.
        let d = c.right * (ndc.x * tan_half * (w / h)) + c.up * (ndc.y * tan_half) + c.forward;
        let length = d.length();
        // The near plane is `znear` units along `forward`: the point znear·d, at distance
        // znear·|d| along the unit direction; the far plane likewise at zfar·|d|.
        let t_max = match c.zfar {
            Some(zfar) => (zfar - c.znear) * length,
            None => f32::INFINITY,
        };
        CameraRay {
            origin: c.position + d * c.znear,
            direction: d / length,
            t_max,
            origin_distance: c.znear * length,
        }
    }
}

impl Camera {
    /// OpenEXR's `worldToCamera` (see the module docs) as a matrix acting on column vectors:
    /// `p_camera = M · (p, 1)`, with p_camera = ((p − position)·right, (p − position)·up,
    /// (p − position)·forward). Computed in f64. OpenEXR stores the transpose (Imath multiplies
    /// row vectors), which is this matrix's column-major array, `to_cols_array()`.
    pub fn world_to_camera(&self) -> DMat4 {
        let (r, u, f) = (
            self.right.as_dvec3(),
            self.up.as_dvec3(),
            self.forward.as_dvec3(),
        );
        let p = self.position.as_dvec3();
        DMat4::from_cols(
            DVec4::new(r.x, u.x, f.x, 0.0),
            DVec4::new(r.y, u.y, f.y, 0.0),
            DVec4::new(r.z, u.z, f.z, 0.0),
            DVec4::new(-r.dot(p), -u.dot(p), -f.dot(p), 1.0),
        )
    }

    /// OpenEXR's `worldToNDC` for a `width` × `height` image, acting on column vectors: for a
    /// world point p, `(X, Y, Z, W) = M · (p, 1)` and (X/W, Y/W) is its NDC position, `raster /
    /// (width, height)` (the inverse of [`Camera::ray`]). Z/W is 0 on the near plane and 1 on the
    /// far plane (1 − znear/z without one); OpenEXR readers discard it. Computed in f64.
    pub fn world_to_ndc(&self, width: u32, height: u32) -> DMat4 {
        let aspect = f64::from(width) / f64::from(height.max(1));
        let tan_half = (0.5 * f64::from(self.yfov)).tan();
        let (near, far) = (f64::from(self.znear), self.zfar.map(f64::from));
        // Camera space (x, y, z) to homogeneous NDC with W = z: X/W = 0.5 + 0.5·x/(z·tan·aspect)
        // and Y/W = 0.5 − 0.5·y/(z·tan) (y down), the maps of `ray` inverted.
        let (a, b) = match far {
            Some(f) => (f / (f - near), -f * near / (f - near)),
            None => (1.0, -near),
        };
        let projection = DMat4::from_cols(
            DVec4::new(0.5 / (tan_half * aspect), 0.0, 0.0, 0.0),
            DVec4::new(0.0, -0.5 / tan_half, 0.0, 0.0),
            DVec4::new(0.5, 0.5, a, 1.0),
            DVec4::new(0.0, 0.0, b, 0.0),
        );
        projection * self.world_to_camera()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;
    use proptest::prelude::*;

    #[test]
    fn identity_node_looks_down_negative_z() {
        let c = Camera::from_node(Mat4::IDENTITY, 1.0).unwrap_or_else(|| panic!("degenerate"));
        assert_eq!(c.forward, Vec3::NEG_Z);
        assert_eq!(c.up, Vec3::Y);
        assert_eq!(c.right, Vec3::X);
        // The image centre looks straight ahead; the top row looks up, column 0 looks left.
        let centre = c.ray(Vec2::new(8.0, 8.0), 16, 16);
        assert_eq!(centre.direction, Vec3::NEG_Z);
        let top = c.ray(Vec2::new(8.0, 0.0), 16, 16);
        assert!(top.direction.y > 0.0);
        let left = c.ray(Vec2::new(0.0, 8.0), 16, 16);
        assert!(left.direction.x < 0.0);
    }

    /// The top edge of the image is yfov/2 above the axis and, for a W×H image, the right edge
    /// is atan(tan(yfov/2)·W/H) to the right: the image's aspect ratio sets the horizontal field
    /// of view. Tolerance: a few f32 ulps of the angle (acos near these angles is well
    /// conditioned): 1e-6 rad.
    #[test]
    fn field_of_view_follows_yfov_and_image_aspect() {
        let yfov = 0.7f32;
        let c = Camera::from_node(Mat4::IDENTITY, yfov).unwrap_or_else(|| panic!("degenerate"));
        let top = c.ray(Vec2::new(20.0, 0.0), 40, 20).direction;
        assert!((top.dot(Vec3::NEG_Z).acos() - 0.5 * yfov).abs() < 1e-6);
        let right = c.ray(Vec2::new(40.0, 10.0), 40, 20).direction;
        let expected = ((0.5 * yfov).tan() * 2.0).atan();
        assert!((right.dot(Vec3::NEG_Z).acos() - expected).abs() < 1e-6);
    }

    #[test]
    fn cornell_camera_has_red_wall_on_the_left() {
        // A half turn about Y: the Cornell box camera (looking down +Z). Its right is −X, so the
        // left half of the image sees large x, where the Cornell data puts the red wall.
        let world = Mat4::from_rotation_translation(
            Quat::from_xyzw(0.0, 1.0, 0.0, 0.0),
            Vec3::new(0.278, 0.273, -0.8),
        );
        let c = Camera::from_node(world, 0.6).unwrap_or_else(|| panic!("degenerate"));
        assert!((c.forward - Vec3::Z).length() < 1e-6);
        assert!((c.right - Vec3::NEG_X).length() < 1e-6);
        let left = c.ray(Vec2::new(0.0, 0.5), 1, 1);
        assert!(left.direction.x > 0.0);
    }

    /// A camera far from the origin keeps its exact view direction. A parent
    /// translated by 3·10⁶ m (and, second case, 10⁸ m), then a 17° turn about Y: the view
    /// direction is the turned −Z, (−sin 17°, 0, −cos 17°), to f32 rounding of the rotation
    /// matrix's entries (a few ulps of 1: 1e-6), not the 2.8° error of a direction recovered from
    /// `(position + forward) − position` in f32.
    #[test]
    fn far_away_cameras_keep_their_direction() {
        let angle = 17f32.to_radians();
        let expected = Vec3::new(-angle.sin(), 0.0, -angle.cos());
        for distance in [3e6f32, 1e8] {
            let world = Mat4::from_translation(Vec3::new(distance, -distance, distance))
                * Mat4::from_rotation_y(angle);
            let c = Camera::from_node(world, 0.8)
                .unwrap_or_else(|| panic!("a camera at {distance} m is refused"));
            let error = c.forward.angle_between(expected);
            assert!(error < 1e-6, "at {distance} m the view is {error} rad off");
            assert!((c.up - Vec3::Y).length() < 1e-6);
            assert!((c.right - Vec3::new(angle.cos(), 0.0, -angle.sin())).length() < 1e-6);
            assert_eq!(c.position, Vec3::new(distance, -distance, distance));
        }
    }

    #[test]
    fn near_and_far_planes_clip() {
        let mut c = Camera::from_node(Mat4::IDENTITY, 1.0).unwrap_or_else(|| panic!("degenerate"));
        c.znear = 0.5;
        c.zfar = Some(10.0);
        let r = c.ray(Vec2::new(0.0, 0.0), 4, 4);
        // The origin is on the plane z = −0.5 and the end of the ray on z = −10 (to f32 rounding
        // of a few operations on values of order 10: 1e-5).
        assert!((r.origin.z + 0.5).abs() < 1e-6);
        assert!((r.origin + r.direction * r.t_max).z + 10.0 < 1e-5);
    }

    /// The header matrices invert `ray`: a point along the ray through raster point (x, y)
    /// lands at NDC (x/W, y/H), and in camera space at (·, ·, z > 0) on the view axis side.
    /// Tolerance: f32 inputs (rays, a point at distance 3) carried through f64 matrices: a few
    /// f32 ulps of the NDC coordinates, which are of order 1: 1e-5.
    #[test]
    fn header_matrices_invert_the_camera_rays() {
        let world = Mat4::from_rotation_translation(
            Quat::from_rotation_y(0.4) * Quat::from_rotation_x(-0.3),
            Vec3::new(1.0, 2.0, -3.0),
        );
        let mut c = Camera::from_node(world, 0.8).unwrap_or_else(|| panic!("degenerate"));
        c.znear = 0.1;
        c.zfar = Some(50.0);
        let (w, h) = (40, 30);
        let to_ndc = c.world_to_ndc(w, h);
        let to_camera = c.world_to_camera();
        for raster in [
            Vec2::new(0.0, 0.0),
            Vec2::new(13.5, 7.25),
            Vec2::new(40.0, 30.0),
        ] {
            let r = c.ray(raster, w, h);
            let p = (r.origin + r.direction * 3.0).as_dvec3();
            let q = to_ndc * p.extend(1.0);
            let ndc = Vec2::new((q.x / q.w) as f32, (q.y / q.w) as f32);
            let expected = raster / Vec2::new(w as f32, h as f32);
            assert!(
                (ndc - expected).length() < 1e-5,
                "{raster}: {ndc} vs {expected}"
            );
            // In camera space the point is in front (z > 0), right of centre iff x > W/2.
            let pc = to_camera * p.extend(1.0);
            assert!(pc.z > 0.0);
            assert_eq!(pc.x > 1e-9, raster.x > 20.0);
            // z/w: between the near plane (0) and the far plane (1).
            assert!((0.0..1.0).contains(&(q.z / q.w)));
        }
        // The camera's own position is camera space's origin; one step forward is +z.
        let origin = to_camera * c.position.as_dvec3().extend(1.0);
        assert!(origin.truncate().length() < 1e-6);
        let ahead = to_camera * (c.position + c.forward).as_dvec3().extend(1.0);
        assert!((ahead.truncate() - glam::DVec3::Z).length() < 1e-6);
        // The ray's origin on the near plane is origin_distance from the centre of projection.
        let r = c.ray(Vec2::new(3.0, 4.0), w, h);
        assert!(((r.origin - c.position).length() - r.origin_distance).abs() < 1e-6);
    }

    /// Where the ray through the image's centre crosses the plane through `centre` across
    /// axis `axis`, or `None` if it runs parallel to it or away from it.
    fn centre_ray_meets(c: &Camera, centre: Vec3, axis: usize) -> Option<Vec3> {
        let r = c.ray(Vec2::new(12.0, 12.0), 24, 24);
        let t = (centre[axis] - r.origin[axis]) / r.direction[axis];
        (t.is_finite() && t > 0.0).then(|| r.origin + t * r.direction)
    }

    /// A scene that is one quad in y = 0 (as TwoSidedPlane is) and has no camera: the framing
    /// camera looks at it from above, the ray through the image's centre meets the quad's
    /// centre, and the quad's far edge (−z) is at the top of the image. The same for a quad in
    /// x = 0, seen from the +X side, and for quads away from the origin.
    #[test]
    fn a_flat_quad_is_framed_from_its_thin_side() {
        for (lo, hi, axis) in [
            (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0), 1),
            (Vec3::new(3.0, -2.0, 5.0), Vec3::new(7.0, -2.0, 6.0), 1),
            (Vec3::new(0.0, -1.0, -1.0), Vec3::new(0.0, 1.0, 1.0), 0),
            (Vec3::new(-4.0, 2.0, -9.0), Vec3::new(-4.0, 3.0, -1.0), 0),
        ] {
            let c = Camera::framing(lo, hi, 1.0);
            let centre = 0.5 * (lo + hi);
            assert!(c.position[axis] > centre[axis], "{lo} {hi}: {c:?}");
            let hit = centre_ray_meets(&c, centre, axis)
                .unwrap_or_else(|| panic!("{lo} {hi}: the centre ray misses the plane: {c:?}"));
            // It meets the quad at its centre, to the rounding of a few f32 operations on
            // coordinates as large as the camera's position (2⁻²⁴ relative each).
            let slack = 8.0 * f32::EPSILON * c.position.length().max(1.0);
            assert!(
                (hit - centre).length() <= slack,
                "{lo} {hi}: the centre ray meets the plane at {hit}, not at the quad's centre {centre}"
            );
            let inside = (0..3).all(|k| lo[k] - slack <= hit[k] && hit[k] <= hi[k] + slack);
            assert!(inside, "{lo} {hi}: {hit} is outside the quad");
            // The image's up is the scene's: over a floor, the side away from the viewer is at
            // the top of the image; on a wall, the side towards +y.
            let ndc = c.world_to_ndc(24, 24);
            let raster_y = |p: Vec3| {
                let h = ndc * p.as_dvec3().extend(1.0);
                h.y / h.w
            };
            let up = if axis == 1 {
                (centre - c.position).with_y(0.0).normalize()
            } else {
                Vec3::Y
            };
            assert!(raster_y(centre + up) < raster_y(centre), "{lo} {hi}: {c:?}");
        }
    }

    /// The framing before flat boxes were seen from their thin side: from +Z.
    fn framing_from_plus_z(lo: Vec3, hi: Vec3, aspect: f32) -> Camera {
        let yfov = std::f32::consts::FRAC_PI_4;
        let centre = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(f32::MIN_POSITIVE);
        let half_y = 0.5 * yfov;
        let half_x = (half_y.tan() * aspect.max(f32::MIN_POSITIVE)).atan();
        let distance = radius / half_y.min(half_x).sin();
        Camera {
            position: centre + Vec3::new(0.0, 0.0, distance),
            forward: Vec3::NEG_Z,
            up: Vec3::Y,
            right: Vec3::X,
            yfov,
            znear: 0.0,
            zfar: None,
            aspect_ratio_in_file: None,
        }
    }

    proptest! {
        /// Every ray of the image is a unit vector in front of the camera, and rays through the
        /// image centre follow `forward` (to f32 rounding: 1e-6).
        #[test]
        fn rays_are_unit_and_in_front(
            qx in -1.0f32..1.0, qy in -1.0f32..1.0, qz in -1.0f32..1.0, qw in -1.0f32..1.0,
            yfov in 0.01f32..3.1, px in 0.0f32..1.0, py in 0.0f32..1.0,
            w in 1u32..2000, h in 1u32..2000,
        ) {
            let q = Quat::from_xyzw(qx, qy, qz, qw);
            prop_assume!(q.length() > 0.1);
            let world = Mat4::from_quat(q.normalize());
            let c = Camera::from_node(world, yfov).unwrap_or_else(|| panic!("degenerate"));
            let r = c.ray(Vec2::new(px * w as f32, py * h as f32), w, h);
            prop_assert!((r.direction.length() - 1.0).abs() < 1e-5);
            prop_assert!(r.direction.dot(c.forward) > 0.0);
            let centre = c.ray(Vec2::new(0.5 * w as f32, 0.5 * h as f32), w, h);
            prop_assert!((centre.direction - c.forward).length() < 1e-6);
        }

        /// The framing camera sees the whole bounding sphere: every corner of the box projects
        /// inside the image.
        #[test]
        fn framing_sees_the_whole_box(
            lx in -100.0f32..100.0, ly in -100.0f32..100.0, lz in -100.0f32..100.0,
            sx in 0.01f32..50.0, sy in 0.01f32..50.0, sz in 0.01f32..50.0, aspect in 0.2f32..5.0,
        ) {
            let lo = Vec3::new(lx, ly, lz);
            let hi = lo + Vec3::new(sx, sy, sz);
            let c = Camera::framing(lo, hi, aspect);
            let tan_half = (0.5 * c.yfov).tan();
            for i in 0..8 {
                let p = Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                let v = p - c.position;
                let z = v.dot(c.forward);
                prop_assert!(z > 0.0);
                // Inside the frustum, with a relative margin of 1e-4 for rounding.
                prop_assert!(v.dot(c.up).abs() <= z * tan_half * (1.0 + 1e-4));
                prop_assert!(v.dot(c.right).abs() <= z * tan_half * aspect * (1.0 + 1e-4));
            }
        }

        /// A box that is not flat (its x and y extents at least 1 % of its largest) is framed
        /// bit for bit as before: from +Z. Boxes flat only in z are among them.
        #[test]
        fn framing_of_boxes_not_flat_is_unchanged(
            lx in -100.0f32..100.0, ly in -100.0f32..100.0, lz in -100.0f32..100.0,
            sx in 0.0f32..50.0, sy in 0.0f32..50.0, sz in 0.0f32..50.0, aspect in 0.2f32..5.0,
        ) {
            let lo = Vec3::new(lx, ly, lz);
            let hi = lo + Vec3::new(sx, sy, sz);
            let size = hi - lo;
            prop_assume!(size.x.min(size.y) >= 0.01 * size.max_element());
            prop_assert_eq!(Camera::framing(lo, hi, aspect), framing_from_plus_z(lo, hi, aspect));
        }

        /// A box flat in y or x (thinner there than 1 % of its largest extent) is seen from
        /// that side: every corner in the image, and the ray through the image's centre meets
        /// the box's mid-plane across its thin axis inside the box.
        #[test]
        fn flat_boxes_are_seen_from_their_thin_side(
            lx in -100.0f32..100.0, ly in -100.0f32..100.0, lz in -100.0f32..100.0,
            a in 0.01f32..50.0, b in 0.01f32..50.0, thin in 0.0f32..0.009,
            axis in 0usize..2, aspect in 0.2f32..5.0,
        ) {
            // Flat across `axis` only (a box flat in both x and y is seen from above), clear of
            // the threshold by more than the rounding of `hi − lo`.
            prop_assume!(a >= 2.0 * FLAT * b);
            let lo = Vec3::new(lx, ly, lz);
            let mut size = Vec3::new(a, a, b);
            size[axis] = thin * a.max(b);
            let hi = lo + size;
            let c = Camera::framing(lo, hi, aspect);
            let centre = 0.5 * (lo + hi);
            prop_assert!(c.position[axis] > centre[axis]);
            let hit = centre_ray_meets(&c, centre, axis);
            prop_assert!(hit.is_some());
            let hit = hit.unwrap_or(Vec3::NAN);
            // Inside, but for the rounding of a few f32 operations on coordinates as large as
            // the camera's position (2⁻²⁴ relative each).
            let slack = 8.0 * f32::EPSILON * c.position.length().max(1.0);
            for k in 0..3 {
                prop_assert!(
                    lo[k] - slack <= hit[k] && hit[k] <= hi[k] + slack,
                    "{} {}", hit, c.position
                );
            }
        }
    }
}
