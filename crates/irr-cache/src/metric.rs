//! Error metrics: where a record may be reused, and with which weight.
//!
//! A metric answers three questions about a record of radius Rᵢ at (pᵢ, nᵢ) seen from a query
//! point (p, n):
//! - [`ErrorMetric::influence_radius`]: the distance from pᵢ beyond which the weight is zero. The
//!   octree files each record by this radius, so the metric alone decides which records a query
//!   can see.
//! - [`ErrorMetric::weight`]: the weight, positive where the record may be used, zero elsewhere;
//!   never NaN or infinite.
//! - [`ErrorMetric::radius_limits`]: the range a new record's radius should be clamped to, given
//!   the world-space size of a pixel at its position (Tabellion & Lamorlette 2004;
//!   pbrt-v2's `minpixelspacing`/`maxpixelspacing`). The limits bound the record's radius, not
//!   its influence: the metric's parameter (κ, a) still scales the influence where they bind,
//!   so it keeps controlling record density in open areas (see [`PixelRange`]). The clamping
//!   itself is the caller's (or the cache's radius pipeline, `RadiusInputs`).
//!
//! Three metrics are provided, [`Ward`], [`TabellionLamorlette`] and [`Hessian`] (elliptical
//! records); all apply the same [`Cuts`] (the "in front" test and the normal-divergence cut)
//! before their formula.
//!
//! # Normal term
//! Both formulas use √(1 − n·nᵢ). For unit vectors ‖n − nᵢ‖² = 2 − 2 n·nᵢ, so
//! √(1 − n·nᵢ) = ‖n − nᵢ‖/√2 exactly; the chord form has no cancellation at small angles (1 − n·nᵢ
//! loses every significant digit below about 0.03°, the chord keeps them), and the angle cut
//! θ < θmax is the chord cut ‖n − nᵢ‖ < 2 sin(θmax/2), with θmax given as an [`Angle`] so no unit
//! can be mistaken (pbrt-v2 passes a limit in degrees through `Degrees()` instead of `Radians()`,
//! which turns 10° into cos⁻¹(cos 572.96) ≈ 68°).

use glam::{DVec3, Vec3};
use thiserror::Error;

/// An angle. Built from degrees or radians explicitly, so a limit cannot be read in the wrong unit.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
pub struct Angle {
    radians: f64,
}

impl Angle {
    /// The angle of `degrees` degrees.
    #[inline]
    pub fn from_degrees(degrees: f32) -> Self {
        Self {
            radians: f64::from(degrees).to_radians(),
        }
    }
    /// The angle of `radians` radians.
    #[inline]
    pub fn from_radians(radians: f32) -> Self {
        Self {
            radians: f64::from(radians),
        }
    }
    /// The angle in radians.
    #[inline]
    pub fn radians(self) -> f64 {
        self.radians
    }
    /// The angle in degrees.
    #[inline]
    pub fn degrees(self) -> f64 {
        self.radians.to_degrees()
    }
    /// The distance between two unit vectors that make this angle: 2 sin(θ/2).
    #[inline]
    pub fn chord(self) -> f64 {
        2.0 * (0.5 * self.radians).sin()
    }
}

/// A metric's parameters that cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Error)]
pub enum MetricError {
    /// Ward's accuracy a must be positive and finite.
    #[error("the accuracy a must be positive and finite, got {0}")]
    Accuracy(f32),
    /// The Hessian metric's accuracy must be positive and finite.
    #[error("the Hessian accuracy must be positive and finite, got {0}")]
    HessianAccuracy(f32),
    /// Tabellion & Lamorlette's κ must be positive and finite.
    #[error("the quality factor kappa must be positive and finite, got {0}")]
    Kappa(f32),
    /// The normal-divergence limit must lie in (0°, 180°].
    #[error("the maximum normal angle must lie in (0°, 180°], got {0}°")]
    NormalAngle(f64),
    /// The in-front tolerance (a fraction of the record's radius) must be finite and ≥ 0.
    #[error("the in-front tolerance must be finite and non-negative, got {0}")]
    InFrontTolerance(f32),
    /// The influence limits in pixels must satisfy 0 < min ≤ max < ∞.
    #[error("the influence limits in pixels must satisfy 0 < min <= max < inf, got [{0}, {1}]")]
    PixelRange(f32, f32),
    /// The second-order limit must lie in [0, 1].
    #[error("the second-order limit must lie in [0, 1], got {0}")]
    SecondOrder(f32),
}

/// Where a candidate record lies relative to a query point: the numbers every metric needs,
/// computed once by the cache in `f64` from the stored `f32` values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// p − pᵢ (exact: the difference of two `f32` values is exact in `f64` unless their exponents
    /// differ by more than 29).
    pub offset: DVec3,
    /// ‖p − pᵢ‖.
    pub distance: f64,
    /// The query normal n (unit).
    pub query_normal: DVec3,
    /// The record's normal nᵢ (unit).
    pub record_normal: DVec3,
    /// The record's radius Rᵢ (> 0): the major radius of an anisotropic record.
    pub record_radius: f64,
    /// The record's minor radius as a fraction of Rᵢ, in (0, 1] (1: isotropic).
    pub record_aspect: f64,
    /// The record's minor axis (unit, ⟂ nᵢ; zero for an isotropic record).
    pub record_tangent: DVec3,
}

impl Candidate {
    /// The candidate for a query at (`p`, `n`) and a record at (`position`, `normal`) of `radius`.
    #[inline]
    pub fn new(p: DVec3, n: DVec3, position: Vec3, normal: Vec3, radius: f32) -> Self {
        let offset = p - position.as_dvec3();
        Self {
            offset,
            distance: offset.length(),
            query_normal: n,
            record_normal: normal.as_dvec3(),
            record_radius: f64::from(radius),
            record_aspect: 1.0,
            record_tangent: DVec3::ZERO,
        }
    }

    /// The same candidate for an anisotropic record (see [`crate::Record`]).
    #[inline]
    pub fn with_ellipse(self, aspect: f32, tangent: Vec3) -> Self {
        Self {
            record_aspect: f64::from(aspect),
            record_tangent: tangent.as_dvec3(),
            ..self
        }
    }

    /// ‖n − nᵢ‖ = √(2(1 − n·nᵢ)) = 2 sin(θ/2), θ the angle between the normals.
    #[inline]
    pub fn normal_chord(&self) -> f64 {
        (self.query_normal - self.record_normal).length()
    }
}

/// The two tests applied before any weight formula.
///
/// - **In front** (Ward & Heckbert 1992, the dᵢ test): with
///   dᵢ = (p − pᵢ)·(n + nᵢ)/2, a record with dᵢ < −τ·Rᵢ lies in front of the query point's
///   tangent plane (it sits on a bump or a fold that may shadow p) and is skipped. On a smooth
///   sphere dᵢ = 0 exactly (the averaged normal cancels the curvature), so τ only has to absorb
///   tessellation and rounding. τ is a **fraction of the record's radius**, not a length in world
///   units (Mitsuba 0.6 compares with −0.05 world units; Radiance adds .001): a fixed length
///   accepts everything in a scene scaled down and rejects too much in one scaled up.
/// - **Normal divergence**: a record whose normal makes an angle ≥ θmax with n is skipped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cuts {
    max_normal_angle: Angle,
    max_chord: f64,
    in_front_tolerance: f32,
}

impl Cuts {
    /// Normals must differ by less than `max_normal_angle` (in (0°, 180°]); records more than
    /// `in_front_tolerance`·Rᵢ in front of the tangent plane are skipped.
    pub fn new(max_normal_angle: Angle, in_front_tolerance: f32) -> Result<Self, MetricError> {
        let radians = max_normal_angle.radians();
        if !(radians > 0.0 && radians <= std::f64::consts::PI) {
            return Err(MetricError::NormalAngle(max_normal_angle.degrees()));
        }
        if !(in_front_tolerance.is_finite() && in_front_tolerance >= 0.0) {
            return Err(MetricError::InFrontTolerance(in_front_tolerance));
        }
        Ok(Self {
            max_normal_angle,
            max_chord: max_normal_angle.chord(),
            in_front_tolerance,
        })
    }

    /// The normal-divergence limit θmax.
    #[inline]
    pub fn max_normal_angle(&self) -> Angle {
        self.max_normal_angle
    }

    /// τ, the in-front tolerance as a fraction of the record's radius.
    #[inline]
    pub fn in_front_tolerance(&self) -> f32 {
        self.in_front_tolerance
    }

    /// Whether the normals differ by less than θmax (chord form, see the module docs).
    #[inline]
    pub fn normals_agree(&self, c: &Candidate) -> bool {
        c.normal_chord() < self.max_chord
    }

    /// Whether the record lies in front of the query point's tangent plane: dᵢ < −τ·Rᵢ.
    #[inline]
    pub fn is_in_front(&self, c: &Candidate) -> bool {
        let d = 0.5 * c.offset.dot(c.query_normal + c.record_normal);
        d < -f64::from(self.in_front_tolerance) * c.record_radius
    }

    /// Whether the record passes both tests.
    #[inline]
    pub fn accept(&self, c: &Candidate) -> bool {
        self.normals_agree(c) && !self.is_in_front(c)
    }
}

impl Default for Cuts {
    /// θmax = 90° (only records on surfaces at a right angle or facing away, which the weights
    /// alone can accept for a loose accuracy, are cut: a tighter cut inside a weight's smooth
    /// support would make seams), τ = 0.05.
    fn default() -> Self {
        Self {
            max_normal_angle: Angle::from_degrees(90.0),
            max_chord: Angle::from_degrees(90.0).chord(),
            in_front_tolerance: 0.05,
        }
    }
}

/// The range a record's radius is clamped to (by the caller, before insertion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiusLimits {
    /// Smallest radius.
    pub min: f32,
    /// Largest radius.
    pub max: f32,
}

impl RadiusLimits {
    /// No clamping: [0, ∞].
    pub const UNBOUNDED: Self = Self {
        min: 0.0,
        max: f32::INFINITY,
    };

    /// `r` clamped to [min, max] (a NaN `r` gives `min`).
    #[inline]
    pub fn clamp(&self, r: f32) -> f32 {
        r.max(self.min).min(self.max)
    }
}

/// Radius limits in pixels (Tabellion & Lamorlette 2004: R⁻ = 1.5 and R⁺ = 10 pixels).
///
/// They bound each metric's **distance scale**, the length over which its position error grows
/// by 1 at parameter 1: R/2 for [`TabellionLamorlette`] (whose error is κ·‖p − pᵢ‖/(R/2)), R for
/// [`Ward`] (a·… with ‖p − pᵢ‖/R). So Tabellion & Lamorlette's radius is clamped to
/// [2R⁻, 2R⁺] pixels, which is their rule max(min(Rᵢ/2, R⁺), R⁻) on the weight's denominator,
/// and the influence R/(2κ) then spans [R⁻/κ, R⁺/κ] pixels (Mitsuba 0.6 the same): a smaller κ
/// allows larger records, a larger κ makes them denser, also where a limit binds. Ward's radius
/// is clamped to [R⁻, R⁺] pixels (pbrt-v2 clamps its record distance the same way) and its
/// influence a·R spans [a·R⁻, a·R⁺] pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelRange {
    min: f32,
    max: f32,
}

impl PixelRange {
    /// The range [`min`, `max`] in pixels, 0 < min ≤ max < ∞.
    pub fn new(min: f32, max: f32) -> Result<Self, MetricError> {
        if min > 0.0 && min <= max && max.is_finite() {
            Ok(Self { min, max })
        } else {
            Err(MetricError::PixelRange(min, max))
        }
    }
    /// Smallest influence, in pixels.
    pub fn min(&self) -> f32 {
        self.min
    }
    /// Largest influence, in pixels.
    pub fn max(&self) -> f32 {
        self.max
    }
    /// The radius limits for a metric whose distance scale is R/`per_radius` (see the type's
    /// docs), at a pixel of world-space size `pixel_spacing`; unbounded when the spacing is
    /// unknown (zero, negative or not finite, e.g. a ray without a footprint).
    fn radius_limits(&self, pixel_spacing: f32, per_radius: f64) -> RadiusLimits {
        if !(pixel_spacing.is_finite() && pixel_spacing > 0.0) {
            return RadiusLimits::UNBOUNDED;
        }
        let s = f64::from(pixel_spacing) * per_radius;
        RadiusLimits {
            min: (f64::from(self.min) * s) as f32,
            max: (f64::from(self.max) * s) as f32,
        }
    }
}

impl Default for PixelRange {
    /// [1.5, 10] pixels (Tabellion & Lamorlette 2004).
    fn default() -> Self {
        Self {
            min: 1.5,
            max: 10.0,
        }
    }
}

/// A weighting of cache records. Implementations must be cheap to clone and thread-safe.
///
/// The cache calls [`ErrorMetric::weight`] only for records with ‖p − pᵢ‖ <
/// [`ErrorMetric::influence_radius`]`(Rᵢ)` and uses a record only when the weight is positive and
/// finite; so a metric's weight must be zero wherever ‖p − pᵢ‖ ≥ its influence radius.
pub trait ErrorMetric: Clone + std::fmt::Debug + Send + Sync + 'static {
    /// The distance from a record of radius `record_radius` beyond which its weight is zero
    /// (≥ 0; the cache refuses a record for which it is not finite).
    fn influence_radius(&self, record_radius: f32) -> f32;
    /// The weight of a record for a query, ≥ 0 and finite; zero where the record must not be used.
    fn weight(&self, candidate: &Candidate) -> f64;
    /// The radius range for a new record at a point where a pixel spans `pixel_spacing` in world
    /// units (unbounded when the spacing is not positive and finite).
    fn radius_limits(&self, pixel_spacing: f32) -> RadiusLimits;
    /// How far a record's second-order term ([`crate::Record::curvature`]) may move its value
    /// at a lookup, as a fraction of the value, in [0, 1]; 0 (the default): the curvature is
    /// ignored and records extrapolate to first order.
    #[inline]
    fn second_order_limit(&self) -> f64 {
        0.0
    }
}

/// `x` (computed in `f64`) as the smallest `f32` ≥ x: an influence radius rounded up, so that
/// every point the formula weighs positively lies inside the radius the octree files.
#[inline]
fn f32_up(x: f64) -> f32 {
    let r = x as f32;
    if f64::from(r) < x { r.next_up() } else { r }
}

/// Ward, Rubinstein & Clear 1988, "A Ray Tracing Solution for Diffuse Interreflection":
///
/// wᵢ = 1 / ε, ε = ‖p − pᵢ‖/Rᵢ + √(1 − n·nᵢ), and a record is used where wᵢ > 1/a, i.e. ε < a,
/// with a the user's accuracy. The weight is then Ward's wᵢ itself (not shifted by 1/a), as in the
/// original paper.
///
/// Ward's weight is infinite when p = pᵢ and n = nᵢ. The cache needs finite weights, so ε is
/// floored at 2⁻²³ (`f32::EPSILON`): positions and normals are stored as `f32`, whose relative
/// precision is 2⁻²⁴, so ε below 2⁻²³ is below what the inputs can resolve; a coincident record
/// weighs 2²³, which still dominates any record that the inputs can tell apart from it.
///
/// Influence radius: ε < a needs ‖p − pᵢ‖ < a·Rᵢ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ward {
    accuracy: f32,
    cuts: Cuts,
    pixels: PixelRange,
}

impl Ward {
    /// ε floor, see the type's docs.
    pub const MIN_ERROR: f64 = f32::EPSILON as f64;

    /// Ward's metric with accuracy `a` (Radiance's `-aa`, typically 0.1–0.3), default [`Cuts`] and
    /// [`PixelRange`].
    pub fn new(accuracy: f32) -> Result<Self, MetricError> {
        if !(accuracy.is_finite() && accuracy > 0.0) {
            return Err(MetricError::Accuracy(accuracy));
        }
        Ok(Self {
            accuracy,
            cuts: Cuts::default(),
            pixels: PixelRange::default(),
        })
    }
    /// The same metric with other cuts.
    pub fn with_cuts(self, cuts: Cuts) -> Self {
        Self { cuts, ..self }
    }
    /// The same metric with other influence limits in pixels.
    pub fn with_pixel_range(self, pixels: PixelRange) -> Self {
        Self { pixels, ..self }
    }
    /// The accuracy a.
    pub fn accuracy(&self) -> f32 {
        self.accuracy
    }
    /// The cuts applied before the formula.
    pub fn cuts(&self) -> &Cuts {
        &self.cuts
    }
    /// Ward's ε for a candidate (no cuts, no floor).
    #[inline]
    pub fn error(c: &Candidate) -> f64 {
        c.distance / c.record_radius + c.normal_chord() * std::f64::consts::FRAC_1_SQRT_2
    }
}

impl ErrorMetric for Ward {
    #[inline]
    fn influence_radius(&self, record_radius: f32) -> f32 {
        f32_up(f64::from(self.accuracy) * f64::from(record_radius))
    }

    #[inline]
    fn weight(&self, c: &Candidate) -> f64 {
        if !self.cuts.accept(c) {
            return 0.0;
        }
        let e = Self::error(c);
        if e < f64::from(self.accuracy) {
            1.0 / e.max(Self::MIN_ERROR)
        } else {
            0.0
        }
    }

    fn radius_limits(&self, pixel_spacing: f32) -> RadiusLimits {
        // Distance scale R: R ∈ [R⁻, R⁺] pixels, whatever a.
        self.pixels.radius_limits(pixel_spacing, 1.0)
    }
}

/// Tabellion & Lamorlette 2004 ("An Approximate Global Illumination System for Computer
/// Generated Films"), in the form of Křivánek & Gautron 2009 ("Practical Global Illumination with
/// Irradiance Caching", ch. 2, the "Tabellion and Lamorlette" weight), which this type follows
/// (Mitsuba 0.6's `Record::getWeight` and YafaRay's `irradianceCache_t::weight` compute the same
/// form, the latter with the clamping inside as Tabellion & Lamorlette write it):
///
/// εᵢ = κ · max( ‖p − pᵢ‖ / (Rᵢ/2),  √(1 − n·nᵢ) / √(1 − cos 10°) ),  wᵢ = 1 − εᵢ, used where
/// wᵢ > 0.
///
/// A **maximum** of the two terms, not Ward's sum. The 10° is a normalisation: at κ = 1 the
/// normal term alone reaches 1 at 10°. Tabellion & Lamorlette write the position term's
/// denominator as max(min(Rᵢ/2, R⁺), R⁻), clamping inside the weight; Křivánek & Gautron clamp
/// Rᵢ when the record is made, which is the same for limits [2R⁻, 2R⁺] on Rᵢ, and that is what
/// [`ErrorMetric::radius_limits`] returns here, for every κ (see [`PixelRange`]). With the chord identity (module docs) the normal
/// term is ‖n − nᵢ‖ / (2 sin 5°).
///
/// Influence radius: κ·‖p − pᵢ‖/(Rᵢ/2) < 1 needs ‖p − pᵢ‖ < Rᵢ/(2κ).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TabellionLamorlette {
    kappa: f32,
    /// 1 / (2 sin 5°), the normal term's normalisation, computed once.
    inv_chord_10: f64,
    cuts: Cuts,
    pixels: PixelRange,
}

impl TabellionLamorlette {
    /// The metric with quality factor κ (larger is stricter; Mitsuba's default is 1), default
    /// [`Cuts`] and [`PixelRange`].
    pub fn new(kappa: f32) -> Result<Self, MetricError> {
        if !(kappa.is_finite() && kappa > 0.0) {
            return Err(MetricError::Kappa(kappa));
        }
        Ok(Self {
            kappa,
            inv_chord_10: 1.0 / Angle::from_degrees(10.0).chord(),
            cuts: Cuts::default(),
            pixels: PixelRange::default(),
        })
    }
    /// The same metric with other cuts.
    pub fn with_cuts(self, cuts: Cuts) -> Self {
        Self { cuts, ..self }
    }
    /// The same metric with other influence limits in pixels.
    pub fn with_pixel_range(self, pixels: PixelRange) -> Self {
        Self { pixels, ..self }
    }
    /// κ.
    pub fn kappa(&self) -> f32 {
        self.kappa
    }
    /// The cuts applied before the formula.
    pub fn cuts(&self) -> &Cuts {
        &self.cuts
    }
    /// εᵢ for a candidate (no cuts).
    #[inline]
    pub fn error(&self, c: &Candidate) -> f64 {
        let position = c.distance / (0.5 * c.record_radius);
        let normal = c.normal_chord() * self.inv_chord_10;
        f64::from(self.kappa) * position.max(normal)
    }
}

impl Default for TabellionLamorlette {
    /// κ = 1, default [`Cuts`] and [`PixelRange`].
    fn default() -> Self {
        Self {
            kappa: 1.0,
            inv_chord_10: 1.0 / Angle::from_degrees(10.0).chord(),
            cuts: Cuts::default(),
            pixels: PixelRange::default(),
        }
    }
}

impl ErrorMetric for TabellionLamorlette {
    #[inline]
    fn influence_radius(&self, record_radius: f32) -> f32 {
        f32_up(f64::from(record_radius) / (2.0 * f64::from(self.kappa)))
    }

    #[inline]
    fn weight(&self, c: &Candidate) -> f64 {
        if !self.cuts.accept(c) {
            return 0.0;
        }
        let w = 1.0 - self.error(c);
        if w > 0.0 { w } else { 0.0 }
    }

    fn radius_limits(&self, pixel_spacing: f32) -> RadiusLimits {
        // Distance scale R/2: R ∈ [2R⁻, 2R⁺] pixels, whatever κ (influence R/(2κ)).
        self.pixels.radius_limits(pixel_spacing, 2.0)
    }
}

/// The Hessian metric (Schwarzhaupt, Jensen & Jarosz 2012, in the form Radiance ≥ 4.2 looks
/// records up with, `sumambient`): records are ellipses (see [`crate::Record`]) whose radii the
/// caller set from the irradiance Hessian, and a record is used inside its ellipse scaled by the
/// accuracy a.
///
/// With Δ = p − pᵢ in the record's frame (u the minor axis, v = nᵢ × u), r₁ = Rᵢ and
/// r₀ = aspect·Rᵢ:
///
/// δₜ = √((Δ·nᵢ)² / r₀² + (Δ·u)² / r₀² + (Δ·v)² / r₁²)  (the ellipsoid with axes r₀, r₁, r₀;
/// ‖Δ‖/Rᵢ for a record without a minor axis),
/// wᵢ = (1 − δₜ/a)·(1 − ‖n − nᵢ‖/(2 sin 5°)),  used where both factors are positive.
///
/// The normal factor reaches 0 at 10°, as Tabellion & Lamorlette's normal term reaches 1 there
/// (Radiance's limit is 10° + a radians). An isotropic record (aspect 1) has
/// δₜ = ‖Δ‖/Rᵢ: Ward's distance term in Radiance's linear weight.
///
/// Influence radius: δₜ < a needs ‖Δ‖ < a·r₁ = a·Rᵢ (r₀ ≤ r₁), so the octree's sphere contains
/// the ellipse. The radius limits are Ward's ([R⁻, R⁺] pixels on Rᵢ): the distance scale is R.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hessian {
    accuracy: f32,
    inv_chord_10: f64,
    cuts: Cuts,
    pixels: PixelRange,
    second_order: f32,
}

impl Hessian {
    /// The metric with accuracy `a` (> 0; smaller is stricter), default [`Cuts`] and
    /// [`PixelRange`].
    pub fn new(accuracy: f32) -> Result<Self, MetricError> {
        if !(accuracy.is_finite() && accuracy > 0.0) {
            return Err(MetricError::HessianAccuracy(accuracy));
        }
        Ok(Self {
            accuracy,
            inv_chord_10: 1.0 / Angle::from_degrees(10.0).chord(),
            cuts: Cuts::default(),
            pixels: PixelRange::default(),
            second_order: 0.0,
        })
    }
    /// The same metric with other cuts.
    pub fn with_cuts(self, cuts: Cuts) -> Self {
        Self { cuts, ..self }
    }
    /// The same metric with other influence limits in pixels.
    pub fn with_pixel_range(self, pixels: PixelRange) -> Self {
        Self { pixels, ..self }
    }
    /// The same metric extrapolating records to second order by their curvature (Jarosz et al.
    /// 2012), the correction ½ Δᵀ(H/E)Δ (relative to the record's value) clamped into
    /// [−`limit`, `limit`]; 0 turns it off. Errors unless `limit` lies in [0, 1].
    pub fn with_second_order(self, limit: f32) -> Result<Self, MetricError> {
        if !(0.0..=1.0).contains(&limit) {
            return Err(MetricError::SecondOrder(limit));
        }
        Ok(Self {
            second_order: limit,
            ..self
        })
    }
    /// The accuracy a.
    pub fn accuracy(&self) -> f32 {
        self.accuracy
    }
    /// δₜ, the candidate's distance in units of the record's ellipse (no cuts).
    #[inline]
    pub fn elliptical_distance(c: &Candidate) -> f64 {
        let r1 = c.record_radius;
        if c.record_tangent == DVec3::ZERO {
            return c.distance / r1;
        }
        let r0 = c.record_aspect * r1;
        let u = c.record_tangent;
        let v = c.record_normal.cross(u);
        let (dn, du, dv) = (
            c.offset.dot(c.record_normal),
            c.offset.dot(u),
            c.offset.dot(v),
        );
        ((dn * dn + du * du) / (r0 * r0) + dv * dv / (r1 * r1)).sqrt()
    }
}

impl ErrorMetric for Hessian {
    #[inline]
    fn influence_radius(&self, record_radius: f32) -> f32 {
        f32_up(f64::from(self.accuracy) * f64::from(record_radius))
    }

    #[inline]
    fn weight(&self, c: &Candidate) -> f64 {
        if !self.cuts.accept(c) {
            return 0.0;
        }
        let position = 1.0 - Self::elliptical_distance(c) / f64::from(self.accuracy);
        let normal = 1.0 - c.normal_chord() * self.inv_chord_10;
        if position > 0.0 && normal > 0.0 {
            position * normal
        } else {
            0.0
        }
    }

    fn radius_limits(&self, pixel_spacing: f32) -> RadiusLimits {
        // Distance scale R: R ∈ [R⁻, R⁺] pixels, as Ward's.
        self.pixels.radius_limits(pixel_spacing, 1.0)
    }

    #[inline]
    fn second_order_limit(&self) -> f64 {
        f64::from(self.second_order)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn at(q: DVec3, n: DVec3, radius: f32) -> Candidate {
        Candidate::new(q, n, Vec3::ZERO, Vec3::Z, radius)
    }

    #[test]
    fn tabellion_lamorlette_known_values() {
        let t = TabellionLamorlette::default();
        // κ·‖p − pᵢ‖/(R/2) = 0.5/1 exactly: w = 0.5 exactly.
        assert_eq!(t.weight(&at(DVec3::new(0.5, 0.0, 0.0), DVec3::Z, 2.0)), 0.5);
        // At 5°, the normal term is sin 2.5° / sin 5° (chord identity).
        let n5 = DVec3::new(5f64.to_radians().sin(), 0.0, 5f64.to_radians().cos());
        let expected = 1.0 - (2.5f64.to_radians().sin() / 5f64.to_radians().sin());
        // The chord is computed from the difference of two unit vectors (a few ulps of 1) and
        // divided by a constant: the weight is exact to a few 2⁻⁵³; 1e-12 is generous.
        assert!((t.weight(&at(DVec3::ZERO, n5, 2.0)) - expected).abs() < 1e-12);
        // κ = 2 halves the influence: R/(2κ) = R/4.
        let strict = TabellionLamorlette::new(2.0).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(strict.influence_radius(4.0), 1.0);
        assert_eq!(
            strict.weight(&at(DVec3::new(1.0, 0.0, 0.0), DVec3::Z, 4.0)),
            0.0
        );
        assert_eq!(
            strict.weight(&at(DVec3::new(0.5, 0.0, 0.0), DVec3::Z, 4.0)),
            0.5
        );
    }

    #[test]
    fn ward_known_values() {
        let w = Ward::new(0.5).unwrap_or_else(|e| panic!("{e}"));
        // ε = 0.5/2 = 0.25 exactly: w = 4.
        assert_eq!(w.weight(&at(DVec3::new(0.5, 0.0, 0.0), DVec3::Z, 2.0)), 4.0);
        // Coincident: ε floored at 2⁻²³.
        assert_eq!(w.weight(&at(DVec3::ZERO, DVec3::Z, 2.0)), 8_388_608.0);
        // ε = a is outside (w must exceed 1/a strictly).
        assert_eq!(w.weight(&at(DVec3::new(1.0, 0.0, 0.0), DVec3::Z, 2.0)), 0.0);
        assert_eq!(w.influence_radius(2.0), 1.0);
        // The normal term: √(1 − cos 60°) = √0.5.
        let n60 = DVec3::new(60f64.to_radians().sin(), 0.0, 60f64.to_radians().cos());
        let loose = Ward::new(1.0).unwrap_or_else(|e| panic!("{e}")).with_cuts(
            Cuts::new(Angle::from_degrees(90.0), 0.05).unwrap_or_else(|e| panic!("{e}")),
        );
        let e = Ward::error(&at(DVec3::ZERO, n60, 1.0));
        assert!((e - 0.5f64.sqrt()).abs() < 1e-12);
        assert!((loose.weight(&at(DVec3::ZERO, n60, 1.0)) - 1.0 / 0.5f64.sqrt()).abs() < 1e-9);
    }

    #[test]
    fn influence_radii_are_rounded_up() {
        let w = Ward::new(0.3).unwrap_or_else(|e| panic!("{e}"));
        let t = TabellionLamorlette::new(3.0).unwrap_or_else(|e| panic!("{e}"));
        for r in [1e-30f32, 0.1, 1.0, 7.3, 1e20] {
            let exact = f64::from(0.3f32) * f64::from(r);
            let got = w.influence_radius(r);
            assert!(
                f64::from(got) >= exact && f64::from(got.next_down()) < exact,
                "{r}"
            );
            let exact = f64::from(r) / 6.0;
            let got = t.influence_radius(r);
            assert!(
                f64::from(got) >= exact && f64::from(got.next_down()) < exact,
                "{r}"
            );
        }
    }

    #[test]
    fn radius_limits_follow_the_pixel_spacing() {
        let t = TabellionLamorlette::default();
        // R/2 in [1.5, 10] pixels of 0.01: R in [0.03, 0.2]. Two f32 roundings (of the
        // spacing 0.01 and of each limit) make a relative error ≤ 2·2⁻²⁴ ≈ 1.2e-7: the absolute
        // bounds below are 0.03·1.2e-7 = 3.6e-9 < 1e-8 and so on.
        let l = t.radius_limits(0.01);
        assert!(
            (l.min - 0.03).abs() < 1e-8 && (l.max - 0.2).abs() < 1e-7,
            "{l:?}"
        );
        // Ward: R itself in [1.5, 10] pixels: [0.015, 0.1], for every a.
        for a in [0.1, 0.3] {
            let l = Ward::new(a)
                .unwrap_or_else(|e| panic!("{e}"))
                .radius_limits(0.01);
            assert!(
                (l.min - 0.015).abs() < 1e-8 && (l.max - 0.1).abs() < 1e-7,
                "{l:?}"
            );
        }
        for unknown in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert_eq!(t.radius_limits(unknown), RadiusLimits::UNBOUNDED);
        }
        let l = RadiusLimits { min: 1.0, max: 2.0 };
        assert_eq!(
            [l.clamp(0.5), l.clamp(1.5), l.clamp(3.0), l.clamp(f32::NAN)],
            [1.0, 1.5, 2.0, 1.0]
        );
    }

    /// The pixel limits bound R the same for every κ, so the influence limits
    /// in pixels are R⁻/κ and R⁺/κ (Tabellion & Lamorlette; Mitsuba 0.6): a smaller κ allows
    /// larger records, and κ keeps controlling density where the maximum binds. Before the fix
    /// the limits were [2κR⁻, 2κR⁺], so the influence in pixels was the same for every κ.
    #[test]
    fn pixel_limits_leave_kappa_in_control() {
        let spacing = 0.01f32;
        for kappa in [0.5f32, 1.0, 2.0] {
            let t = TabellionLamorlette::new(kappa).unwrap_or_else(|e| panic!("{e}"));
            let l = t.radius_limits(spacing);
            // The same R limits for every κ (two f32 roundings: 1.2e-7 relative).
            assert!((l.min - 0.03).abs() < 1e-8, "κ = {kappa}: {l:?}");
            assert!((l.max - 0.2).abs() < 1e-7, "κ = {kappa}: {l:?}");
            // Influence in pixels: R/(2κ)/spacing = R⁻/κ … R⁺/κ; influence_radius rounds up
            // (one more rounding): 4 ulps relative in all.
            let lo = f64::from(t.influence_radius(l.min)) / f64::from(spacing);
            let hi = f64::from(t.influence_radius(l.max)) / f64::from(spacing);
            let tol = 4.0 * f64::from(f32::EPSILON);
            assert!(
                (lo / (1.5 / f64::from(kappa)) - 1.0).abs() < tol,
                "κ = {kappa}: {lo}"
            );
            assert!(
                (hi / (10.0 / f64::from(kappa)) - 1.0).abs() < tol,
                "κ = {kappa}: {hi}"
            );
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        for a in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(matches!(Ward::new(a), Err(MetricError::Accuracy(_))));
            assert!(matches!(
                TabellionLamorlette::new(a),
                Err(MetricError::Kappa(_))
            ));
        }
        for deg in [0.0, -5.0, 180.5, f32::NAN] {
            assert!(matches!(
                Cuts::new(Angle::from_degrees(deg), 0.05),
                Err(MetricError::NormalAngle(_))
            ));
        }
        assert!(Cuts::new(Angle::from_degrees(180.0), 0.0).is_ok());
        for tol in [-0.1, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                Cuts::new(Angle::from_degrees(10.0), tol),
                Err(MetricError::InFrontTolerance(_))
            ));
        }
        for (a, b) in [
            (0.0, 1.0),
            (2.0, 1.0),
            (1.0, f32::INFINITY),
            (f32::NAN, 1.0),
        ] {
            assert!(matches!(
                PixelRange::new(a, b),
                Err(MetricError::PixelRange(..))
            ));
        }
    }

    #[test]
    fn angles_convert_both_ways() {
        assert_eq!(Angle::from_degrees(180.0).radians(), std::f64::consts::PI);
        assert!((Angle::from_radians(1.0).degrees() - 57.295_779_513).abs() < 1e-6);
        assert!((Angle::from_degrees(60.0).chord() - 1.0).abs() < 1e-15);
        assert_eq!(Angle::from_degrees(180.0).chord(), 2.0);
    }

    proptest! {
        /// The chord identity ‖a − b‖²/2 = 1 − a·b holds for unit vectors; for vectors of squared
        /// length 1 + δ it is off by (δa + δb)/2, and each side carries a few f64 roundings of
        /// quantities ≤ 4 (≤ 8·2⁻⁵³ in all).
        #[test]
        fn chord_identity(a in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0), b in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)) {
            let (a, b) = (Vec3::new(a.0, a.1, a.2), Vec3::new(b.0, b.1, b.2));
            prop_assume!(a.length() > 1e-3 && b.length() > 1e-3);
            let (a, b) = (a.normalize().as_dvec3(), b.normalize().as_dvec3());
            let chord = (a - b).length();
            let slack = ((a.length_squared() - 1.0).abs() + (b.length_squared() - 1.0).abs()) / 2.0
                + 8.0 * f64::EPSILON / 2.0;
            prop_assert!((chord * chord / 2.0 - (1.0 - a.dot(b))).abs() <= slack);
        }
    }
}
