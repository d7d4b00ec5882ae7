//! The leak guard: keeps a record from lighting points it cannot see.
//!
//! [`LeakGuard::Visibility`]: each record keeps the nearest hit distance oᵢ of its whole gather
//! (horizon rays included). A query farther than oᵢ/2 from the record may have an occluder
//! between them, so a shadow ray between the two decides; closer than oᵢ/2 nothing can be
//! (every direction from pᵢ was free for at least oᵢ, up to the angular gap between sampled
//! directions, which for a wall is a factor 1/cos(gap) ≈ 1.02 at 32×128, far inside the factor
//! 2). A record on the lit side of a 1 mm wall therefore never lights the dark side.
//!
//! The shadow ray leaves the record's surface and reaches the query's on their front sides (the
//! sides the record's gather and the query's viewer saw), offset along the geometric normals: a
//! shading normal can tilt across the direction between two points of a smooth-shaded mesh, and
//! an offset along it would start the ray behind its own triangle. An offset toward the other
//! end instead would let a record under a surface (in the gap below a 1 cm step's top, at the
//! foot of its face) reach the surface's top from below without crossing it.

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
        // Between the side of the record's surface its gather saw and the side of the query's
        // surface the camera (or a gather) sees: a record under a surface, however near, does not
        // light that surface's top. A ray sees a surface it crosses as it leaves, not one it
        // would cross at its very end: it starts at the query when the record lies behind the
        // query's surface.
        let front = |ng: Vec3, ns: Vec3| if ng.dot(ns) >= 0.0 { ng } else { -ng };
        let (rf, qf) = (
            front(guard.geometric_normal, record.normal),
            front(q.ng, q.ns),
        );
        GuardTest::Ray(between_fronts((record.position, rf), (q.p, qf)))
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
                !scene.occluded(&ray)
            }
        }
    }
}

/// The shadow ray that tells whether the surface point `q`, seen from the side `qf` of its
/// surface, sees the point `p` seen from the side `pf`: between the two fronts
/// (`Ray::spawn_between_fronts`), so that a point under a surface, however near, is hidden from
/// the surface's top. A ray sees a surface it crosses as it leaves, not one it would cross at
/// its very end: it starts at `q` when `p` lies behind `q`'s surface.
pub(super) fn between_fronts((p, pf): (Vec3, Vec3), (q, qf): (Vec3, Vec3)) -> Ray {
    if qf.dot(p - q) < 0.0 {
        Ray::spawn_between_fronts(q, qf, p, pf)
    } else {
        Ray::spawn_between_fronts(p, pf, q, qf)
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
                let hit = scene.intersect(&ray)?;
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

    /// A 1 cm step: a platform (top at y = 0.01 over x < 0, its face at x = 0) on a floor that
    /// runs on under it. A record in the gap under the top, at the face's foot (where a camera
    /// ray grazing the face's lower edge can put one), must not light the top above it: the
    /// shadow ray has to cross the top, which an offset toward the other end (below the top, at
    /// the query) let it avoid, so that such records darkened the top along the edge by a quarter
    /// (Cornell box with the step, records 10-40 pixels). Records that do see the query still pass.
    #[test]
    fn a_record_under_a_step_does_not_light_its_top() {
        let quad = |p: [Vec3; 4]| irr_geometry::TriangleMesh {
            positions: p.to_vec(),
            indices: vec![[0, 1, 2], [0, 2, 3]],
            normals: None,
            material_ids: vec![0, 0],
        };
        let y = |x: f32, h: f32, z: f32| Vec3::new(x, h, z);
        let meshes = [
            // Floor (+y), the platform's top (+y) and its face (+x).
            quad([
                y(-1.0, 0.0, -1.0),
                y(-1.0, 0.0, 1.0),
                y(1.0, 0.0, 1.0),
                y(1.0, 0.0, -1.0),
            ]),
            quad([
                y(-1.0, 0.01, -1.0),
                y(-1.0, 0.01, 1.0),
                y(0.0, 0.01, 1.0),
                y(0.0, 0.01, -1.0),
            ]),
            quad([
                y(0.0, 0.0, -1.0),
                y(0.0, 0.01, -1.0),
                y(0.0, 0.01, 1.0),
                y(0.0, 0.0, 1.0),
            ]),
        ];
        let scene = scene(&meshes, vec![Material::diffuse(Vec3::splat(0.5))]);
        let mut ic =
            IrradianceCacheIntegrator::new(IcSettings::default()).unwrap_or_else(|e| panic!("{e}"));
        let records = [
            y(-0.0005, 0.0, 0.0), // in the gap under the top
            y(0.005, 0.0, 0.0),   // on the floor in front of the face
            y(-0.03, 0.01, 0.01), // on the top
            y(0.03, 0.0, 0.0),    // on the floor farther out
        ];
        let level = &mut ic.core.levels[0];
        for p in records {
            level
                .cache
                .insert(Record::new(p, Vec3::Y, 1.0, Rgb::splat(1.0)))
                .unwrap_or_else(|e| panic!("{e}"));
            // Nearest hit 0: every query needs a shadow ray.
            level.guard.push(GuardRecord {
                nearest_hit: 0.0,
                geometric_normal: Vec3::Y,
            });
        }
        let level = &ic.core.levels[0];
        let on_top = Query {
            p: y(-0.002, 0.01, 0.0),
            ns: Vec3::Y,
            ng: Vec3::Y,
        };
        let on_floor = Query {
            p: y(0.002, 0.0, 0.01),
            ns: Vec3::Y,
            ng: Vec3::Y,
        };
        let mut rays = 0;
        let mut sees = |id: u32, q: &Query| {
            let r = &level.cache.records()[id as usize];
            ic.core.visible(&scene, level, id, r, q, &mut rays)
        };
        assert!(!sees(0, &on_top), "the record under the top lights it");
        assert!(
            !sees(1, &on_top),
            "the floor record sees the top through the face"
        );
        assert!(sees(2, &on_top), "a record on the top does not see the top");
        assert!(
            !sees(0, &on_floor),
            "the record under the top sees the floor through the face"
        );
        assert!(
            sees(3, &on_floor),
            "a record on the floor does not see the floor"
        );
    }
}
