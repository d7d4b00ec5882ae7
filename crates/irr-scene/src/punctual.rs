//! Punctual lights: glTF's `KHR_lights_punctual` point, spot and directional lights.
//!
//! # Units
//! glTF gives a point or spot light's `intensity` in candela (lm/sr) and a directional light's
//! in lux (lm/m²), times its linear `color`. irr takes these numbers in the same photometric
//! unit as its emitted radiance (glTF's `emissiveFactor`, read as nits, cd/m²), so that a point
//! light of intensity I lights a surface at distance r, seen at angle θ from its normal, with
//! irradiance E = I·cos θ / r², in the unit in which an emitter of radiance L gives
//! E = ∫ L cos θ dω. There is **no 683 lm/W factor** anywhere: irr never converts between
//! radiometric and photometric units. (Blender's glTF exporter divides its lamps' watts by 4π and
//! multiplies them by 683 lm/W, but writes emissive strengths as they are, so a Blender lamp and
//! a Blender emissive mesh of the same nominal power differ by that factor in irr as in any
//! glTF viewer.)
//!
//! A point light of intensity I is the limit of a small sphere of radius ρ and radiance
//! L = I / (π ρ²): each such sphere sends intensity π ρ² L towards every direction.
//!
//! # Spot falloff
//! Between `innerConeAngle` and `outerConeAngle` the intensity falls off as the glTF
//! specification's reference code has it: t = (cos α − cos θ_outer) / (cos θ_inner − cos θ_outer),
//! clamped to [0, 1], and the factor is t² (α the angle from the spot's axis). Inside the inner
//! cone the factor is 1, outside the outer cone 0. With equal angles (Blender writes these for a
//! spot whose blend is 0) the edge is hard: 1 inside, 0 outside.
//!
//! # Power
//! The light sampler chooses lights by power, alongside the emitting triangles (pbrt-v4's
//! `PowerLightSampler`), each channel's power averaged into one scalar:
//! - point: Φ = 4π·I;
//! - spot: Φ = 2π·I·[(1 − cos θ_inner) + (cos θ_inner − cos θ_outer)/3], the exact integral of
//!   the falloff over the sphere: ∫ t² d(cos α) over the falloff band is (cos θ_inner −
//!   cos θ_outer)/3 (pbrt-v4's `SpotLight::Phi` has /2, the integral of its smoothstep);
//! - directional: Φ = π·r²·E, r the radius of the scene's bounding sphere (pbrt-v4's
//!   `DistantLight::Phi`): the flux through the disk that covers the scene (irr-integrator's
//!   light sampler takes the sphere around the core bounds, without a far ground plane).

use glam::Vec3;
use std::f64::consts::PI;

/// A light at a point or at infinity (glTF `KHR_lights_punctual`), in world space. Its radiance
/// is a delta distribution: only next-event estimation can find it, never a sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PunctualLight {
    /// Light from a point, the same intensity in every direction.
    Point {
        /// Where it is.
        position: Vec3,
        /// Intensity I per channel (glTF `intensity` × `color`, candela read as nits·m²).
        intensity: Vec3,
    },
    /// Light from a point, in a cone around `direction`.
    Spot {
        /// Where it is.
        position: Vec3,
        /// The cone's axis, the direction the light travels (unit; the node's −Z).
        direction: Vec3,
        /// Intensity I per channel on the axis and inside the inner cone.
        intensity: Vec3,
        /// cos θ_inner: full intensity where the cosine of the angle from the axis is at least
        /// this. In [`cos_outer`, 1].
        cos_inner: f32,
        /// cos θ_outer: no light where the cosine is at most this. In [0, 1] (θ_outer ≤ π/2).
        cos_outer: f32,
    },
    /// Parallel light from infinitely far away.
    Directional {
        /// The direction the light travels (unit; the node's −Z).
        direction: Vec3,
        /// Irradiance E per channel on a surface facing the light (glTF `intensity` × `color`,
        /// lux read as the unit of irradiance).
        irradiance: Vec3,
    },
}

/// What a punctual light gives a point: see [`PunctualLight::incidence`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Incidence {
    /// The unit direction from the point towards the light.
    pub wi: Vec3,
    /// The irradiance on a surface at the point facing the light (cos θ = 1): I·falloff / r², or
    /// E for a directional light. A surface at angle θ receives this times cos θ.
    pub irradiance: Vec3,
    /// The light's position, `None` for a directional light (at infinity).
    pub position: Option<Vec3>,
}

impl PunctualLight {
    /// A point light at `position` of intensity `intensity` (per channel).
    pub fn point(position: Vec3, intensity: Vec3) -> Self {
        Self::Point {
            position,
            intensity,
        }
    }

    /// A spot light at `position` shining along `direction` (normalised here), with glTF's cone
    /// angles in radians (0 ≤ `inner` ≤ `outer` ≤ π/2; irr-integrator's `Scene::with_lights` refuses
    /// cosines outside that range).
    pub fn spot(position: Vec3, direction: Vec3, intensity: Vec3, inner: f32, outer: f32) -> Self {
        // The f32 nearest π/2 lies 4.4e-8 above it, so its cosine is −4.4e-8: an angle up to
        // that float means "at most π/2", and its cosine is 0.
        let cos = |a: f32| {
            if a <= std::f32::consts::FRAC_PI_2 {
                a.cos().max(0.0)
            } else {
                a.cos()
            }
        };
        Self::Spot {
            position,
            direction: direction.normalize_or_zero(),
            intensity,
            cos_inner: cos(inner),
            cos_outer: cos(outer),
        }
    }

    /// A directional light shining along `direction` (normalised here) with irradiance
    /// `irradiance` (per channel) on a surface facing it.
    pub fn directional(direction: Vec3, irradiance: Vec3) -> Self {
        Self::Directional {
            direction: direction.normalize_or_zero(),
            irradiance,
        }
    }

    /// The intensity (point, spot) or irradiance (directional) per channel.
    pub fn strength(&self) -> Vec3 {
        match *self {
            Self::Point { intensity, .. } | Self::Spot { intensity, .. } => intensity,
            Self::Directional { irradiance, .. } => irradiance,
        }
    }

    /// Why the light is not one irr can render, if it is not: a non-finite position, a
    /// direction that is not a finite unit vector, a negative or non-finite strength, or spot
    /// cosines out of order or range.
    pub fn problem(&self) -> Option<String> {
        let s = self.strength();
        if !(s.is_finite() && s.min_element() >= 0.0) {
            return Some(format!(
                "its strength {s} must be finite and ≥ 0 in every channel"
            ));
        }
        let unit = |d: Vec3| d.is_finite() && (d.length() - 1.0).abs() < 1e-4;
        match *self {
            Self::Point { position, .. } if !position.is_finite() => {
                Some(format!("its position {position} is not finite"))
            }
            Self::Spot { position, .. } if !position.is_finite() => {
                Some(format!("its position {position} is not finite"))
            }
            Self::Spot { direction, .. } | Self::Directional { direction, .. }
                if !unit(direction) =>
            {
                Some(format!("its direction {direction} is not a unit vector"))
            }
            Self::Spot {
                cos_inner,
                cos_outer,
                ..
            } if !((0.0..=1.0).contains(&cos_outer) && (cos_outer..=1.0).contains(&cos_inner)) => {
                Some(format!(
                    "its cone cosines (inner {cos_inner}, outer {cos_outer}) must satisfy 0 ≤ outer ≤ inner ≤ 1"
                ))
            }
            _ => None,
        }
    }

    /// The spot falloff at cos α (α the angle from the axis): 1 inside the inner cone, 0 outside
    /// the outer cone, and t² between them, t = (cos α − cos θ_outer) / (cos θ_inner −
    /// cos θ_outer) (the glTF specification's reference code). 1 for other lights.
    #[inline]
    pub fn falloff(&self, cos_alpha: f32) -> f32 {
        let Self::Spot {
            cos_inner,
            cos_outer,
            ..
        } = *self
        else {
            return 1.0;
        };
        if cos_alpha >= cos_inner {
            1.0
        } else if cos_alpha <= cos_outer {
            0.0
        } else {
            // Here cos_outer < cos_alpha < cos_inner, so the denominator is positive.
            let t = (cos_alpha - cos_outer) / (cos_inner - cos_outer);
            t * t
        }
    }

    /// The light arriving at `p`: the direction to the light and the irradiance on a surface
    /// facing it, before any occluder. `None` when nothing arrives: `p` at a point light's
    /// position, or outside a spot's outer cone.
    pub fn incidence(&self, p: Vec3) -> Option<Incidence> {
        match *self {
            Self::Directional {
                direction,
                irradiance,
            } => Some(Incidence {
                wi: -direction,
                irradiance,
                position: None,
            }),
            Self::Point {
                position,
                intensity,
            }
            | Self::Spot {
                position,
                intensity,
                ..
            } => {
                let to_light = position - p;
                let dist2 = to_light.length_squared();
                if !(dist2 > 0.0 && dist2.is_finite()) {
                    return None;
                }
                let wi = to_light / dist2.sqrt();
                let axis = match *self {
                    Self::Spot { direction, .. } => direction,
                    _ => -wi,
                };
                // The inverse-square law times the spot's falloff at the angle from its axis.
                let falloff = self.falloff(axis.dot(-wi));
                (falloff > 0.0).then(|| Incidence {
                    wi,
                    irradiance: intensity * (falloff / dist2),
                    position: Some(position),
                })
            }
        }
    }

    /// The emitted power Φ (mean over the channels) that the light sampler chooses by; see the
    /// module docs. `scene_radius` is the radius of the scene's bounding sphere (directional
    /// lights only).
    pub fn power(&self, scene_radius: f64) -> f64 {
        let mean = f64::from(self.strength().element_sum()) / 3.0;
        match *self {
            Self::Point { .. } => 4.0 * PI * mean,
            Self::Spot {
                cos_inner,
                cos_outer,
                ..
            } => {
                let (ci, co) = (f64::from(cos_inner), f64::from(cos_outer));
                2.0 * PI * mean * ((1.0 - ci) + (ci - co) / 3.0)
            }
            Self::Directional { .. } => PI * scene_radius * scene_radius * mean,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::FRAC_PI_2;

    #[test]
    fn point_light_follows_the_inverse_square_law() {
        let light = PunctualLight::point(Vec3::new(1.0, 2.0, 3.0), Vec3::new(4.0, 8.0, 12.0));
        let p = Vec3::new(1.0, 2.0, 1.0);
        let inc = light.incidence(p).unwrap_or_else(|| panic!("no incidence"));
        // r = 2: E = I / 4, exactly (powers of two); wi = +z exactly.
        assert_eq!(inc.wi, Vec3::Z);
        assert_eq!(inc.irradiance, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(inc.position, Some(Vec3::new(1.0, 2.0, 3.0)));
        assert!(light.incidence(Vec3::new(1.0, 2.0, 3.0)).is_none());
    }

    #[test]
    fn spot_falloff_follows_the_specification() {
        let (inner, outer) = (0.3f32, 0.6f32);
        let light = PunctualLight::spot(Vec3::ZERO, -Vec3::Z, Vec3::ONE, inner, outer);
        let (ci, co) = (inner.cos(), outer.cos());
        assert_eq!(light.falloff(1.0), 1.0);
        assert_eq!(light.falloff(ci), 1.0);
        assert_eq!(light.falloff(co), 0.0);
        assert_eq!(light.falloff(0.0), 0.0);
        // Halfway in cosine: t = 1/2, factor 1/4 (f32 rounding of one division and one
        // subtraction of O(1) values: a few ulps, 1e-6).
        let mid = 0.5 * (ci + co);
        assert!((light.falloff(mid) - 0.25).abs() < 1e-6);
        // The falloff only decreases away from the axis.
        let mut last = 1.0;
        for i in 0..=100 {
            let alpha = outer * 1.2 * i as f32 / 100.0;
            let f = light.falloff(alpha.cos());
            assert!(
                f <= last && (0.0..=1.0).contains(&f),
                "α {alpha}: {f} after {last}"
            );
            last = f;
        }
        // Equal angles: a hard edge, never a division by zero.
        let hard = PunctualLight::spot(Vec3::ZERO, -Vec3::Z, Vec3::ONE, 0.5, 0.5);
        assert_eq!(hard.falloff(0.5f32.cos()), 1.0);
        assert_eq!(hard.falloff(0.5f32.cos() - 1e-6), 0.0);
    }

    #[test]
    fn directional_light_is_the_same_everywhere() {
        let light = PunctualLight::directional(Vec3::new(0.0, -2.0, 0.0), Vec3::splat(3.0));
        for p in [Vec3::ZERO, Vec3::new(1e6, -4.0, 2.0)] {
            let inc = light.incidence(p).unwrap_or_else(|| panic!("none"));
            assert_eq!(inc.wi, Vec3::Y);
            assert_eq!(inc.irradiance, Vec3::splat(3.0));
            assert_eq!(inc.position, None);
        }
    }

    /// The spot's power formula against a numerical integral of its falloff over the sphere:
    /// Φ = ∫ I·falloff dω = 2π I ∫₋₁¹ falloff(c) dc, by the midpoint rule on 10⁶ intervals of
    /// width h = 2·10⁻⁶. Where the falloff is smooth the rule's error is O(h²) (its second
    /// derivative is at most 2/(ci − co)² ≈ 70 here: below 10⁻¹⁰ in all); at a kink (the inner
    /// cone's edge) or a step (the hard edge of equal angles, a jump of 1) the one interval that
    /// straddles it is off by at most h·jump = h. So the integral is within h + 10⁻¹⁰ of the
    /// truth, relative h/∫f plus the f32 evaluation of the falloff (1e-6 relative).
    #[test]
    fn spot_power_is_the_integral_of_its_falloff() {
        for (inner, outer) in [(0.0f32, 0.5f32), (0.3, 0.6), (0.2, FRAC_PI_2), (0.4, 0.4)] {
            let light = PunctualLight::spot(Vec3::ZERO, Vec3::Z, Vec3::splat(2.0), inner, outer);
            let n = 1_000_000;
            let h = 2.0 / f64::from(n);
            let integral: f64 = (0..n)
                .map(|i| {
                    let c = -1.0 + (f64::from(i) + 0.5) * h;
                    f64::from(light.falloff(c as f32)) * h
                })
                .sum();
            let expected = 2.0 * PI * 2.0 * integral;
            let power = light.power(1.0);
            let bound = 1e-6 + (h + 1e-10) / integral;
            assert!(
                (power / expected - 1.0).abs() < bound,
                "({inner}, {outer}): {power} vs {expected}"
            );
        }
        let point = PunctualLight::point(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        assert!((point.power(1.0) - 8.0 * PI).abs() < 1e-12);
        let sun = PunctualLight::directional(Vec3::Y, Vec3::splat(2.0));
        assert!((sun.power(3.0) - 18.0 * PI).abs() < 1e-12);
    }

    #[test]
    fn problems_are_named() {
        let bad = [
            PunctualLight::point(Vec3::ZERO, Vec3::new(1.0, -1.0, 1.0)),
            PunctualLight::point(Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 1.0)),
            PunctualLight::point(Vec3::splat(f32::INFINITY), Vec3::ONE),
            PunctualLight::directional(Vec3::ZERO, Vec3::ONE),
            PunctualLight::spot(Vec3::ZERO, Vec3::Z, Vec3::ONE, 0.6, 0.3),
            PunctualLight::spot(Vec3::ZERO, Vec3::Z, Vec3::ONE, 0.3, 2.0),
        ];
        for light in bad {
            assert!(light.problem().is_some(), "{light:?}");
        }
        assert_eq!(
            PunctualLight::spot(Vec3::ZERO, Vec3::Z, Vec3::ONE, 0.0, FRAC_PI_2).problem(),
            None
        );
    }
}
