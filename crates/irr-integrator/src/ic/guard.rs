//! The leak guard: keeps a record from lighting points it cannot see.
//!
//! [`LeakGuard::Visibility`]: each record keeps the nearest hit distance oᵢ of its whole gather
//! (horizon rays included). A query farther than oᵢ/2 from the record may have an occluder
//! between them, so a shadow ray between the two decides; closer than oᵢ/2 nothing can be
//! (every direction from pᵢ was free for at least oᵢ, up to the angular gap between sampled
//! directions, which for a wall is a factor 1/cos(gap) ≈ 1.02 at 32×128, far inside the factor
//! 2). A record on the lit side of a 1 mm wall therefore never lights the dark side.
//!
//! The shadow ray leaves and reaches the two surfaces by their geometric normals, as
//! `Ray::spawn_to` requires: a shading normal can tilt across the direction between two points
//! of a smooth-shaded mesh, and an offset along it would start the ray behind its own triangle.

use super::levels::{Core, Level};
use super::settings::LeakGuard;
use super::value::IcValue;
use crate::path::ShadingPoint;
use crate::scene::Scene;
use glam::Vec3;
use irr_cache::{Record, RecordId};
use irr_geometry::Ray;

/// What the leak guard keeps of a record besides the record itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuardRecord {
    /// The nearest hit distance of the record's whole gather (at most the scene's diagonal).
    pub nearest_hit: f32,
    /// The geometric normal of the surface at the record (either orientation): its shadow rays
    /// leave from there.
    pub geometric_normal: Vec3,
}

/// A point the cache is asked about: position, shading normal (what the records' weights
/// compare) and geometric normal (where the leak guard's shadow rays reach it).
#[derive(Clone, Copy, Debug)]
pub(super) struct Query {
    pub(super) p: Vec3,
    pub(super) ns: Vec3,
    pub(super) ng: Vec3,
}

impl From<&ShadingPoint> for Query {
    fn from(x: &ShadingPoint) -> Self {
        Self {
            p: x.position,
            ns: x.ns,
            ng: x.ng,
        }
    }
}

/// What the leak guard asks before record may be used at a point.
pub(super) enum GuardTest {
    /// Nothing can stand between them (or the guard is off): the record may be used.
    Pass,
    /// The record has no guard data: it may not be used.
    Fail,
    /// The record may be used if this shadow ray is unoccluded.
    Ray(Ray),
}

impl<V: IcValue> Core<V> {
    /// What the guard asks before record `id` of `level` may be used at `q`.
    pub(super) fn guard_test(
        &self,
        level: &Level<V>,
        id: RecordId,
        record: &Record<V>,
        q: &Query,
    ) -> GuardTest {
        if self.settings.leak_guard == LeakGuard::Off {
            return GuardTest::Pass;
        }
        let Some(guard) = level.guard.get(id as usize) else {
            return GuardTest::Fail;
        };
        let d = (q.p - record.position).length();
        if d <= 0.5 * guard.nearest_hit {
            return GuardTest::Pass;
        }
        GuardTest::Ray(Ray::spawn_to(
            record.position,
            guard.geometric_normal,
            q.p,
            q.ng,
        ))
    }

    /// Whether record `id` of `level` may be used at `q`: the leak guard, its shadow ray (if it
    /// needs one) traced and counted in `rays`.
    pub(super) fn visible(
        &self,
        scene: &Scene,
        level: &Level<V>,
        id: RecordId,
        record: &Record<V>,
        q: &Query,
        rays: &mut u64,
    ) -> bool {
        match self.guard_test(level, id, record, q) {
            GuardTest::Pass => true,
            GuardTest::Fail => false,
            GuardTest::Ray(ray) => {
                *rays += 1;
                !scene.geometry().occluded(&ray)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Material;
    use crate::ic::{IcSettings, IrradianceCacheIntegrator};
    use crate::tests::{icosphere, scene};
    use irr_cache::Rgb;
    use irr_sampling::SampleKey;

    /// Inside a closed convex mesh every surface point sees every other, so the guard must let
    /// every record through. A smooth-shaded icosphere of 80 triangles is the hard case: its
    /// shading normals tilt up to ~20° from the faces', so between points of neighbouring
    /// triangles they often fall on the other side of the direction from the geometric normal,
    /// and a shadow ray offset along the shading normal would start behind its own triangle.
    #[test]
    fn the_guard_sees_across_the_inside_of_a_smooth_convex_mesh() {
        let mut sphere = icosphere(Vec3::ZERO, 1.0, 1, 0);
        sphere.normals = Some(sphere.positions.iter().map(|p| p.normalize()).collect());
        let scene = scene(&[sphere], vec![Material::diffuse(Vec3::splat(0.5))]);
        let mut ic =
            IrradianceCacheIntegrator::new(IcSettings::default()).unwrap_or_else(|e| panic!("{e}"));
        // Points on the inside, seen from the centre in many directions.
        let points: Vec<ShadingPoint> = (0..400u64)
            .filter_map(|i| {
                let u = SampleKey::new(5, i, 0).uniform_2d(0);
                let (z, phi) = (1.0 - 2.0 * u.x, std::f32::consts::TAU * u.y);
                let r = (1.0 - z * z).max(0.0).sqrt();
                let ray = Ray::new(Vec3::ZERO, Vec3::new(r * phi.cos(), r * phi.sin(), z));
                let hit = scene.geometry().intersect(&ray)?;
                let s = scene.geometry().surface(&ray, &hit);
                Some(ShadingPoint::new(&s, -ray.direction))
            })
            .collect();
        assert_eq!(points.len(), 400);
        let tilted = points.iter().filter(|x| x.ns.dot(x.ng) < 0.99).count();
        assert!(
            tilted > 100,
            "only {tilted} points with a tilted shading normal"
        );
        // Each point a record whose guard always traces (nearest hit 0), queried from all.
        let level = &mut ic.core.levels[0];
        for x in &points {
            let id = level
                .cache
                .insert(Record::new(x.position, x.ns, 1.0, Rgb::splat(1.0)))
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(id as usize, level.guard.len());
            level.guard.push(GuardRecord {
                nearest_hit: 0.0,
                geometric_normal: x.ng,
            });
        }
        let level = &ic.core.levels[0];
        let mut rays = 0;
        let mut blocked = 0;
        for (id, record) in level.cache.records().iter().enumerate() {
            for x in &points {
                let q = Query::from(x);
                if (q.p - record.position).length() > 0.0
                    && !ic
                        .core
                        .visible(&scene, level, id as u32, record, &q, &mut rays)
                {
                    blocked += 1;
                }
            }
        }
        assert!(rays > 100_000, "{rays} shadow rays");
        assert_eq!(blocked, 0, "{blocked} of {rays} pairs seen as occluded");
    }
}
