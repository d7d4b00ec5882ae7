//! Animated cameras (glTF 2.0 §3.11 "Animations"): the keyframed translation, rotation and
//! scale of the nodes above a camera, evaluated at a time to place the camera for one frame of
//! a walkthrough.
//!
//! A [`Track`] is one animation channel's sampler: strictly increasing key times (seconds) and
//! the values at them, interpolated as glTF defines:
//! - `STEP`: the value of the last key at or before t;
//! - `LINEAR`: linear between keys, a rotation by spherical linear interpolation along the
//!   shorter arc;
//! - `CUBICSPLINE`: the cubic Hermite spline with each key's in- and out-tangents (stored per key
//!   as in-tangent, value, out-tangent), scaled by the interval's length; a rotation's result is
//!   normalised (Appendix C of the specification).
//!
//! Before the first key a track holds its first value, after the last its last. A
//! [`CameraPath`] is the chain of nodes from the scene's root down to the camera's node, each
//! either fixed or moving, and the camera's projection; [`CameraPath::camera_at`] multiplies the
//! chain's local transforms at time t and places the camera as [`Camera::from_node`] does.

use crate::camera::Camera;
use glam::{Mat4, Quat, Vec3, Vec4};

/// How a track interpolates between keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// The value of the last key at or before t.
    Step,
    /// Linear (spherical linear for rotations).
    Linear,
    /// Cubic Hermite with per-key tangents.
    CubicSpline,
}

/// A value a track can carry: a vector (translation, scale) or a rotation.
pub trait Keyframe: Copy {
    /// Whether every component is finite (and a rotation is not zero).
    fn is_valid(&self) -> bool;
    /// Whether every component is finite (what a tangent must be).
    fn is_finite_tangent(&self) -> bool;
    /// Every component times `d` (a tangent scaled by its interval).
    fn scaled(self, d: f32) -> Self;
    /// The linear interpolation between `a` and `b` at `s` ∈ [0, 1].
    fn interpolate(a: Self, b: Self, s: f32) -> Self;
    /// The cubic Hermite spline from `p0` (out-tangent `m0`) to `p1` (in-tangent `m1`), the
    /// tangents already scaled by the interval's length, at `s` ∈ [0, 1].
    fn hermite(p0: Self, m0: Self, p1: Self, m1: Self, s: f32) -> Self;
}

/// The cubic Hermite basis h00, h10, h01, h11 at `s`.
fn hermite_basis(s: f32) -> [f32; 4] {
    let (s2, s3) = (s * s, s * s * s);
    [
        2.0 * s3 - 3.0 * s2 + 1.0,
        s3 - 2.0 * s2 + s,
        -2.0 * s3 + 3.0 * s2,
        s3 - s2,
    ]
}

impl Keyframe for Vec3 {
    fn is_valid(&self) -> bool {
        self.is_finite()
    }
    fn is_finite_tangent(&self) -> bool {
        self.is_finite()
    }
    fn scaled(self, d: f32) -> Self {
        self * d
    }
    fn interpolate(a: Self, b: Self, s: f32) -> Self {
        a.lerp(b, s)
    }
    fn hermite(p0: Self, m0: Self, p1: Self, m1: Self, s: f32) -> Self {
        let [h00, h10, h01, h11] = hermite_basis(s);
        p0 * h00 + m0 * h10 + p1 * h01 + m1 * h11
    }
}

impl Keyframe for Quat {
    fn is_valid(&self) -> bool {
        self.is_finite() && self.length_squared() > 0.0
    }
    fn is_finite_tangent(&self) -> bool {
        self.is_finite()
    }
    fn scaled(self, d: f32) -> Self {
        Quat::from_vec4(Vec4::from(self) * d)
    }
    fn interpolate(a: Self, b: Self, s: f32) -> Self {
        // The shorter arc: q and −q are the same rotation.
        let b = if a.dot(b) < 0.0 { -b } else { b };
        a.normalize().slerp(b.normalize(), s)
    }
    fn hermite(p0: Self, m0: Self, p1: Self, m1: Self, s: f32) -> Self {
        let [h00, h10, h01, h11] = hermite_basis(s);
        let v = Vec4::from(p0) * h00
            + Vec4::from(m0) * h10
            + Vec4::from(p1) * h01
            + Vec4::from(m1) * h11;
        Quat::from_vec4(v).normalize()
    }
}

/// Why a track could not be made.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TrackError {
    /// No key.
    Empty,
    /// A key time is not finite, or not after the one before it.
    Times(usize),
    /// The number of values does not match the keys (one per key, three with `CUBICSPLINE`).
    Count {
        /// Keys.
        keys: usize,
        /// Values.
        values: usize,
    },
    /// A value is not finite (or a rotation is zero).
    Value(usize),
}

impl std::fmt::Display for TrackError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Empty => write!(f, "the sampler has no keyframe"),
            Self::Times(i) => write!(
                f,
                "keyframe time {i} is not finite or not after the one before it (times must increase strictly)"
            ),
            Self::Count { keys, values } => write!(
                f,
                "{values} output values for {keys} keyframes (one per keyframe, three with CUBICSPLINE)"
            ),
            Self::Value(i) => write!(f, "output value {i} is not finite (or is a zero rotation)"),
        }
    }
}

/// One channel's keyframes (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Track<T> {
    times: Vec<f32>,
    values: Vec<T>,
    interpolation: Interpolation,
}

impl<T: Keyframe> Track<T> {
    /// The track of `times` (seconds, strictly increasing) and `values` (one per key; with
    /// `CUBICSPLINE` three per key: in-tangent, value, out-tangent), checked.
    pub fn new(
        times: Vec<f32>,
        values: Vec<T>,
        interpolation: Interpolation,
    ) -> Result<Self, TrackError> {
        if times.is_empty() {
            return Err(TrackError::Empty);
        }
        if let Some(i) =
            (0..times.len()).find(|&i| !times[i].is_finite() || (i > 0 && times[i] <= times[i - 1]))
        {
            return Err(TrackError::Times(i));
        }
        let per_key = if interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
        if values.len() != per_key * times.len() {
            return Err(TrackError::Count {
                keys: times.len(),
                values: values.len(),
            });
        }
        // With CUBICSPLINE only the middle of each triple is a value; the tangents may be zero.
        let bad = |(i, v): &(usize, &T)| {
            if per_key == 3 && i % 3 != 1 {
                !v.is_finite_tangent()
            } else {
                !v.is_valid()
            }
        };
        if let Some((i, _)) = values.iter().enumerate().find(bad) {
            return Err(TrackError::Value(i));
        }
        Ok(Self {
            times,
            values,
            interpolation,
        })
    }

    /// The first and last key times.
    pub fn span(&self) -> (f32, f32) {
        (self.times[0], self.times[self.times.len() - 1])
    }

    /// The value of key `k` (the middle of its triple with `CUBICSPLINE`).
    fn value(&self, k: usize) -> T {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            _ => self.values[k],
        }
    }

    /// The value at time `t` (seconds; NaN reads as the first key).
    pub fn at(&self, t: f32) -> T {
        let last = self.times.len() - 1;
        if t.is_nan() || t <= self.times[0] {
            return self.value(0);
        }
        if t >= self.times[last] {
            return self.value(last);
        }
        // The last key at or before t: 0 ≤ k < last here.
        let k = self.times.partition_point(|&x| x <= t) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let s = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        match self.interpolation {
            Interpolation::Step => self.value(k),
            Interpolation::Linear => T::interpolate(self.value(k), self.value(k + 1), s),
            Interpolation::CubicSpline => {
                let d = t1 - t0;
                let out_tangent = self.values[3 * k + 2];
                let in_tangent = self.values[3 * (k + 1)];
                T::hermite(
                    self.value(k),
                    out_tangent.scaled(d),
                    self.value(k + 1),
                    in_tangent.scaled(d),
                    s,
                )
            }
        }
    }
}

/// A node's motion: its rest translation, rotation and scale, each replaced by its track where
/// an animation channel drives it.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeMotion {
    /// The rest pose (translation, rotation, scale).
    pub rest: (Vec3, Quat, Vec3),
    /// The translation's track, if animated.
    pub translation: Option<Track<Vec3>>,
    /// The rotation's track, if animated.
    pub rotation: Option<Track<Quat>>,
    /// The scale's track, if animated.
    pub scale: Option<Track<Vec3>>,
}

impl NodeMotion {
    /// The node's local transform at time `t`.
    pub fn local_at(&self, t: f32) -> Mat4 {
        let (t0, r0, s0) = self.rest;
        let translation = self.translation.as_ref().map_or(t0, |k| k.at(t));
        let rotation = self.rotation.as_ref().map_or(r0, |k| k.at(t));
        let scale = self.scale.as_ref().map_or(s0, |k| k.at(t));
        Mat4::from_scale_rotation_translation(scale, rotation.normalize(), translation)
    }

    /// The first and last key times of its tracks (`None` without a track).
    fn span(&self) -> Option<(f32, f32)> {
        [
            self.translation.as_ref().map(Track::span),
            self.rotation.as_ref().map(Track::span),
            self.scale.as_ref().map(Track::span),
        ]
        .into_iter()
        .flatten()
        .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
    }
}

/// A link of the chain from the scene's root to a camera's node.
#[derive(Clone, Debug, PartialEq)]
pub enum Link {
    /// A node no animation moves: its local transform.
    Fixed(Mat4),
    /// A node an animation moves.
    Moving(NodeMotion),
}

/// An animated camera (module docs): the chain of nodes down to it and its projection.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    /// Root first, the camera's own node last.
    pub chain: Vec<Link>,
    /// The camera at rest: its projection (field of view, clipping planes) is every frame's.
    pub rest: Camera,
}

impl CameraPath {
    /// The camera at time `t` (seconds); `None` where the chain's transform collapses the view
    /// direction at that time.
    pub fn camera_at(&self, t: f32) -> Option<Camera> {
        let world = self
            .chain
            .iter()
            .fold(Mat4::IDENTITY, |m, link| match link {
                Link::Fixed(local) => m * *local,
                Link::Moving(motion) => m * motion.local_at(t),
            });
        let mut camera = Camera::from_node(world, self.rest.yfov)?;
        camera.znear = self.rest.znear;
        camera.zfar = self.rest.zfar;
        camera.aspect_ratio_in_file = self.rest.aspect_ratio_in_file;
        Some(camera)
    }

    /// The first and last key times over every moving node.
    pub fn span(&self) -> (f32, f32) {
        self.chain
            .iter()
            .filter_map(|l| match l {
                Link::Moving(m) => m.span(),
                Link::Fixed(_) => None,
            })
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
            .unwrap_or((0.0, 0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(times: &[f32], values: &[Vec3], i: Interpolation) -> Track<Vec3> {
        Track::new(times.to_vec(), values.to_vec(), i).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Keys are hit exactly by every interpolation; before the first and after the last the
    /// track holds; STEP holds the earlier key; LINEAR is the affine mix (exact in f32 for
    /// these dyadic values).
    #[test]
    fn vector_tracks_interpolate_as_gltf_says() {
        let (t, v) = (
            [0.0, 1.0, 3.0],
            [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 4.0, 0.0)],
        );
        let step = track(&t, &v, Interpolation::Step);
        let linear = track(&t, &v, Interpolation::Linear);
        for (k, &tk) in t.iter().enumerate() {
            assert_eq!(step.at(tk), v[k]);
            assert_eq!(linear.at(tk), v[k]);
        }
        assert_eq!(linear.at(-1.0), Vec3::ZERO);
        assert_eq!(linear.at(9.0), v[2]);
        assert_eq!(linear.at(f32::NAN), Vec3::ZERO);
        assert_eq!(step.at(2.5), Vec3::X);
        assert_eq!(linear.at(0.5), Vec3::new(0.5, 0.0, 0.0));
        assert_eq!(linear.at(2.0), Vec3::new(1.0, 2.0, 0.0));
    }

    /// CUBICSPLINE: the Hermite spline through the keys with tangents scaled by the interval.
    /// With values 0 and 1 and both tangents equal to 1/(t₁ − t₀) per second, the spline is
    /// the straight line s: the tangents times the interval are 1, and h10 + h01 + h11 = s.
    /// With zero tangents it is the smoothstep 3s² − 2s³.
    #[test]
    fn cubic_splines_use_scaled_tangents() {
        let d = 2.0;
        let slope = Vec3::splat(1.0 / d);
        let line = track(
            &[0.0, d],
            &[slope, Vec3::ZERO, slope, slope, Vec3::ONE, slope],
            Interpolation::CubicSpline,
        );
        for s in [0.25f32, 0.5, 0.75] {
            let got = line.at(s * d);
            assert!(
                (got - Vec3::splat(s)).abs().max_element() < 1e-6,
                "{s}: {got}"
            );
        }
        let ease = track(
            &[0.0, d],
            &[
                Vec3::ZERO,
                Vec3::ZERO,
                Vec3::ZERO,
                Vec3::ZERO,
                Vec3::ONE,
                Vec3::ZERO,
            ],
            Interpolation::CubicSpline,
        );
        let s = 0.25f32;
        let want = 3.0 * s * s - 2.0 * s * s * s;
        assert!((ease.at(s * d) - Vec3::splat(want)).abs().max_element() < 1e-6);
    }

    /// Rotations: LINEAR takes the shorter arc (a key stored as −q turns the same way), halfway
    /// between identity and a quarter turn is an eighth of a turn.
    #[test]
    fn rotations_slerp_along_the_shorter_arc() {
        let quarter = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        for end in [quarter, -quarter] {
            let r = Track::new(
                vec![0.0, 1.0],
                vec![Quat::IDENTITY, end],
                Interpolation::Linear,
            )
            .unwrap_or_else(|e| panic!("{e}"));
            let half = r.at(0.5);
            let want = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
            assert!(half.dot(want).abs() > 1.0 - 1e-6, "{half} vs {want}");
        }
    }

    /// Bad tracks are errors naming what is wrong.
    #[test]
    fn bad_tracks_are_refused() {
        let v = [Vec3::ZERO, Vec3::ONE];
        assert_eq!(
            Track::<Vec3>::new(vec![], vec![], Interpolation::Linear),
            Err(TrackError::Empty)
        );
        assert_eq!(
            Track::new(vec![0.0, 0.0], v.to_vec(), Interpolation::Linear),
            Err(TrackError::Times(1))
        );
        assert_eq!(
            Track::new(vec![0.0, f32::NAN], v.to_vec(), Interpolation::Linear),
            Err(TrackError::Times(1))
        );
        assert_eq!(
            Track::new(vec![0.0, 1.0], v.to_vec(), Interpolation::CubicSpline),
            Err(TrackError::Count { keys: 2, values: 2 })
        );
        assert_eq!(
            Track::new(
                vec![0.0, 1.0],
                vec![Quat::IDENTITY, Quat::from_xyzw(0.0, 0.0, 0.0, 0.0)],
                Interpolation::Step
            ),
            Err(TrackError::Value(1))
        );
    }

    /// A camera under a moving parent: the parent's translation carries the camera; the path's
    /// span is its track's.
    #[test]
    fn a_camera_follows_its_moving_parent() {
        let rest = Camera::from_node(Mat4::IDENTITY, 0.8).unwrap_or_else(|| panic!("camera"));
        let path = CameraPath {
            chain: vec![
                Link::Moving(NodeMotion {
                    rest: (Vec3::ZERO, Quat::IDENTITY, Vec3::ONE),
                    translation: Some(track(
                        &[0.0, 2.0],
                        &[Vec3::ZERO, Vec3::new(4.0, 0.0, 0.0)],
                        Interpolation::Linear,
                    )),
                    rotation: None,
                    scale: None,
                }),
                Link::Fixed(Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0))),
            ],
            rest,
        };
        let c = path.camera_at(1.0).unwrap_or_else(|| panic!("camera"));
        assert_eq!(c.position, Vec3::new(2.0, 1.0, 0.0));
        assert_eq!(c.forward, -Vec3::Z);
        assert_eq!(path.span(), (0.0, 2.0));
    }
}
