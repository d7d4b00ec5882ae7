//! The final pass a pixel at a time ([`crate::Batching::ByPixel`]): a pixel's samples share one
//! walk of the octree, the leak guard's answers, and the gathers of the points no record
//! covers.
//!
//! - **One walk**: the records whose spheres meet the box of the pixel's shading points are
//!   found once (`IrradianceCache::records_meeting_box`); each sample then weighs only those
//!   (`interpolate_among`: the same records and weights as its own octree query, summed in
//!   index order). A pixel whose points spread far (a silhouette between near and far
//!   surfaces) meets many records; past [`MAX_NEARBY`] its samples query the octree each.
//! - **The guard's answers**: a record's shadow ray is traced once per pixel and surface (the
//!   triangle the sample hit), for the first sample that needs it; the pixel's later samples on
//!   that triangle reuse the answer. Within a pixel the points of one surface lie a pixel's
//!   footprint apart, far closer than the record they look at.
//! - **Shared gathers**: a sample that no record covers gets a gather of its own, as a record
//!   of the pixel alone (never stored in the cache, which the final pass only reads), whose
//!   influence reaches every point of the pixel on the same triangle; the pixel's later samples
//!   that this record covers interpolate it instead of gathering again.
//!
//! Everything a sample gets depends on its pixel's samples in the call and on the cache: the
//! image is the same whatever the thread count, and `--debug-pixel` replays a pixel exactly.

use super::guard::{GuardRecord, GuardTest, Query};
use super::levels::Level;
use super::{FALLBACK_STREAM, IrradianceCacheIntegrator, direct_light};
use crate::bsdf::Bsdf;
use crate::integrator::{FirstHit, RayCounter};
use crate::path::{Radiance, ShadingPoint, first_surface};
use crate::scene::Scene;
use glam::Vec3;
use irr_cache::{ErrorMetric, IrradianceCache, NearbyRecord, Record, RecordId, Rgb};
use irr_geometry::Ray;
use irr_sampling::SampleKey;
use irr_sampling::rng::Dimensions;
use std::f32::consts::FRAC_1_PI;
use std::sync::atomic::Ordering;

/// The most records a pixel's samples weigh from one walk of the octree; past it, each sample
/// queries the octree itself (the same records, in the octree's order).
pub const MAX_NEARBY: usize = 256;

/// A sample waiting for its indirect light: its index in the batch, its shading point and
/// albedo, and what it has so far.
struct Pending {
    index: usize,
    x: ShadingPoint,
    albedo: Vec3,
    /// With radiance caching, the BSDF whose lobe the records reflect (module `radiance`).
    lobe: Option<Bsdf>,
    partial: Radiance,
}

/// Which records a pixel's lookup weighs.
#[derive(Clone, Copy)]
enum Among<'a> {
    /// Those the pixel's walk of the octree listed (`IrradianceCache::interpolate_among`).
    Nearby(&'a [NearbyRecord]),
    /// The octree's own query, for a pixel whose list grew past [`MAX_NEARBY`].
    Octree,
    /// Those whose spheres lie within this distance of the point
    /// (`IrradianceCache::interpolate_within`).
    Reach(f32),
}

/// Scratch for the radiance records' sums (`lobe_in_pixel`), reused across a pixel's samples.
#[derive(Default)]
struct LobeScratch {
    sum: Vec<Vec3>,
    moved: Vec<Vec3>,
    turned: Vec<Vec3>,
}

/// The leak guard's answers within one pixel: (record, triangle the sample hit, visible).
#[derive(Default)]
struct GuardMemo(Vec<(RecordId, u32, bool)>);

impl GuardMemo {
    /// The memoised answer for `id` seen from `triangle`, or `answer()` (then memoised).
    fn get(&mut self, id: RecordId, triangle: u32, answer: impl FnOnce() -> bool) -> bool {
        if let Some(&(_, _, v)) = self.0.iter().find(|e| e.0 == id && e.1 == triangle) {
            return v;
        }
        let v = answer();
        self.0.push((id, triangle, v));
        v
    }
}

impl IrradianceCacheIntegrator {
    /// [`IrradianceCacheIntegrator::li_split`] for the samples of one pixel (see the module
    /// docs): `out[i]` for `camera_rays[i]`, with `dims[i]`.
    /// With `first`, also what each camera ray met first (`None` for a miss), found on the way.
    pub(super) fn li_split_pixel(
        &self,
        scene: &Scene,
        camera_rays: &[Ray],
        dims: &mut [Dimensions],
        out: &mut [Radiance],
        mut first: Option<&mut [Option<FirstHit>]>,
        rays: &mut RayCounter,
    ) {
        assert!(
            camera_rays.len() == dims.len()
                && dims.len() == out.len()
                && first.as_ref().is_none_or(|f| f.len() == out.len()),
            "one dimension stream and one answer per ray"
        );
        // Emission and direct light, sample by sample; the samples that need the cache wait.
        let mut pending = Vec::with_capacity(camera_rays.len());
        for (index, ((ray, d), o)) in camera_rays
            .iter()
            .zip(dims.iter_mut())
            .zip(out.iter_mut())
            .enumerate()
        {
            let (surface, wo, emitted, t) = match first_surface(scene, ray, rays) {
                Ok(first) => first,
                Err(background) => {
                    *o = background;
                    continue;
                }
            };
            if let Some(f) = first.as_deref_mut() {
                f[index] = Some(FirstHit::at(scene, &surface, wo, t));
            }
            // The depth counts reflections as the path tracer's does: none at depth 0, the
            // direct light's one at depth 1, and the cache's indirect light (two or more) from
            // depth 2 on, where the integrator has at least one cache level.
            // An unlit surface is all the camera sees of it (`first_surface`).
            if self.core.settings.path.max_depth == 0 || scene.is_unlit(surface.triangle) {
                *o = Radiance {
                    emitted,
                    ..Radiance::default()
                };
                continue;
            }
            let x = scene.shading_point(&surface, wo);
            let bsdf = Bsdf::at(scene, &x);
            let light_samples = self.core.settings.direct_samples;
            // Direct light: NEE at x₀; on a glossy x₀ weighted against the BSDF sample that
            // also brings the light the cache leaves out (`glossy_sample`), unless the
            // radiance records reflect that lobe (module `radiance`): then NEE alone.
            let share = bsdf.residual_probability();
            let lobe = self
                .core
                .radiance
                .as_ref()
                .is_some_and(|r| r.covers(&bsdf, share))
                .then_some(bsdf);
            let glossy = !bsdf.is_lambertian() && lobe.is_none();
            // Without a cache level (at most one reflection) no record brings the background
            // that x₀ reflects once (paths `L D B`, `indirect` in the path tracer too): the same
            // BSDF samples do, through the whole BSDF.
            let whole = self.core.levels.is_empty() && scene.background() != Vec3::ZERO;
            // How many BSDF samples the lobe takes, once for the MIS weights and the samples.
            let count = if glossy || whole {
                self.lobe_samples_for(share)
            } else {
                0
            };
            let mis = if glossy { count } else { 0 };
            let mut direct = direct_light(scene, &x, &bsdf, light_samples, mis, d, rays);
            let (mut indirect, mut glossy_part) = (Vec3::ZERO, Vec3::ZERO);
            if glossy || whole {
                let samples = (light_samples, count, glossy);
                let (more, rest, part) =
                    self.glossy_lobe(scene, &x, (&bsdf, whole), samples, d, rays);
                direct += more;
                indirect = rest;
                glossy_part = part;
            }
            *o = Radiance {
                emitted,
                direct,
                indirect,
                glossy: glossy_part,
            };
            // The cache holds irradiance, so the (textured) diffuse reflectance of x₀ itself
            // multiplies it, never a record's.
            let albedo = bsdf.diffuse_reflectance();
            if (albedo != Vec3::ZERO || lobe.is_some()) && !self.core.levels.is_empty() {
                pending.push(Pending {
                    index,
                    x,
                    albedo,
                    lobe,
                    partial: *o,
                });
            }
        }
        let Some(level) = self.core.levels.first() else {
            return;
        };
        if pending.is_empty() {
            return;
        }
        // One walk of the octree for the pixel.
        let (lo, hi) = pending.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(p.x.position), hi.max(p.x.position)),
        );
        let mut nearby = Vec::new();
        level.cache.records_meeting_box(lo, hi, &mut nearby);
        let walked = nearby.len() <= MAX_NEARBY;
        let mut memo = GuardMemo::default();
        let mut local: Option<Level<Rgb>> = None;
        let mut guard_rays = 0;
        let mut lobe_scratch = LobeScratch::default();
        for p in &pending {
            let q = Query::from(&p.x);
            let mut indirect = p.partial.indirect;
            let mut glossy = p.partial.glossy;
            if let Some(bsdf) = &p.lobe {
                let reflected = self.lobe_in_pixel(
                    scene,
                    level,
                    (walked.then_some(nearby.as_slice()), &q, p.x.triangle),
                    bsdf,
                    (&mut memo, &mut guard_rays),
                    &mut lobe_scratch,
                );
                let lobe = match reflected {
                    Some(v) => v,
                    // No record with coefficients covers x₀: its lobe is path-traced, and the
                    // BSDF sample's emitter hits count for nothing (its direct light was NEE
                    // alone).
                    None => {
                        let light_samples = self.core.settings.direct_samples;
                        let d = &mut dims[p.index];
                        self.glossy_lobe(
                            scene,
                            &p.x,
                            (bsdf, false),
                            (light_samples, self.lobe_samples(bsdf), false),
                            d,
                            rays,
                        )
                        .1
                    }
                };
                indirect += lobe;
                glossy += lobe;
            }
            if p.albedo == Vec3::ZERO {
                out[p.index] = Radiance {
                    indirect,
                    glossy,
                    ..p.partial
                };
                continue;
            }
            let among = if walked {
                Among::Nearby(&nearby)
            } else {
                Among::Octree
            };
            let shared = self.lookup_in_pixel(
                scene,
                level,
                among,
                &q,
                p.x.triangle,
                &mut memo,
                &mut guard_rays,
            );
            let e = match shared {
                Some(e) => e,
                None => {
                    self.core.misses.fetch_add(1, Ordering::Relaxed);
                    // How far the pixel's points on this triangle lie from this one.
                    let reach = pending
                        .iter()
                        .filter(|o| o.x.triangle == p.x.triangle)
                        .map(|o| (o.x.position - p.x.position).length())
                        .fold(0.0f32, f32::max);
                    // A point in a gap between the records' spheres narrower than the repair
                    // passes' probes lies within the pixel's extent on its surface of a sphere
                    // that covered a probe: it reads the records within that reach (a bias no
                    // larger than the pixel limits', docs/bias.md) before it gathers.
                    let within = self.lookup_in_pixel(
                        scene,
                        level,
                        Among::Reach(reach),
                        &q,
                        p.x.triangle,
                        &mut memo,
                        &mut guard_rays,
                    );
                    match within {
                        Some(e) => {
                            self.core.fallbacks_within.fetch_add(1, Ordering::Relaxed);
                            e
                        }
                        None => self.local_irradiance(
                            scene,
                            &mut local,
                            &p.x,
                            reach,
                            &mut dims[p.index],
                            rays,
                        ),
                    }
                }
            };
            out[p.index] = Radiance {
                indirect: indirect + p.albedo * FRAC_1_PI * e,
                glossy,
                ..p.partial
            };
        }
        rays.shadow += guard_rays;
    }

    /// The first level's interpolated irradiance at `q`, from the records `among` names, with
    /// the leak guard's answers shared through `memo`.
    #[expect(
        clippy::too_many_arguments,
        reason = "the pixel's shared state (records, memo, counter) beside the query"
    )]
    fn lookup_in_pixel(
        &self,
        scene: &Scene,
        level: &Level<Rgb>,
        among: Among,
        q: &Query,
        triangle: u32,
        memo: &mut GuardMemo,
        guard_rays: &mut u64,
    ) -> Option<Vec3> {
        let mut accept = |id: RecordId, r: &Record<Rgb>| match self.core.guard_test(level, id, r, q)
        {
            GuardTest::Pass => true,
            GuardTest::Fail => false,
            GuardTest::Ray(ray) => memo.get(id, triangle, || {
                *guard_rays += 1;
                !scene.occluded(&ray)
            }),
        };
        let found = match among {
            Among::Nearby(nearby) => level
                .cache
                .interpolate_among(nearby, q.p, q.ns, &mut accept),
            Among::Octree => level.cache.interpolate_filtered(q.p, q.ns, &mut accept),
            Among::Reach(reach) => level
                .cache
                .interpolate_within(q.p, q.ns, reach, &mut accept),
        };
        found.map(|i| Vec3::from_array(i.value.0))
    }

    /// The light `bsdf`'s lobe reflects from the first level's radiance records at `q`
    /// (module `radiance`): the records `nearby` (or the octree's own query) weigh in as for
    /// the irradiance, through the same leak guard; `None` when none of them has coefficients.
    fn lobe_in_pixel(
        &self,
        scene: &Scene,
        level: &Level<Rgb>,
        (nearby, q, triangle): (Option<&[NearbyRecord]>, &Query, u32),
        bsdf: &Bsdf,
        (memo, guard_rays): (&mut GuardMemo, &mut u64),
        scratch: &mut LobeScratch,
    ) -> Option<Vec3> {
        let (radiance, Bsdf::Glossy { frame, .. }) = (self.core.radiance.as_ref()?, bsdf) else {
            return None;
        };
        let count = radiance.count();
        scratch.sum.clear();
        scratch.sum.resize(count, Vec3::ZERO);
        scratch.turned.resize(count, Vec3::ZERO);
        scratch.moved.resize(count, Vec3::ZERO);
        let mut total = 0.0f64;
        let mut visit = |id: RecordId, r: &Record<Rgb>, w: f64| {
            let Some(stored) = self.core.coefficients(level, id) else {
                return;
            };
            let visible = match self.core.guard_test(level, id, r, q) {
                GuardTest::Pass => true,
                GuardTest::Fail => false,
                GuardTest::Ray(ray) => memo.get(id, triangle, || {
                    *guard_rays += 1;
                    !scene.occluded(&ray)
                }),
            };
            if visible {
                total += w;
                radiance.accumulate(
                    (stored, r.normal, q.p - r.position),
                    frame,
                    w as f32,
                    &mut scratch.sum,
                    (&mut scratch.moved, &mut scratch.turned),
                );
            }
        };
        match nearby {
            Some(nearby) => level
                .cache
                .for_each_weighted_among(nearby, q.p, q.ns, &mut visit),
            None => level.cache.for_each_weighted(q.p, q.ns, &mut visit),
        }
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let inverse = (1.0 / total) as f32;
        for c in &mut scratch.sum {
            *c *= inverse;
        }
        Some(radiance.reflect(bsdf, &mut scratch.sum, &mut scratch.turned))
    }

    /// The irradiance at `x`, which no record of the cache covers: from the pixel's own records
    /// (`local`) if one covers it, else from a gather of its own, which becomes one of them with
    /// an influence of at least `reach` (the pixel's points on the same triangle).
    fn local_irradiance(
        &self,
        scene: &Scene,
        local: &mut Option<Level<Rgb>>,
        x: &ShadingPoint,
        reach: f32,
        dims: &mut Dimensions,
        rays: &mut RayCounter,
    ) -> Vec3 {
        let q = Query::from(x);
        if let Some(l) = local.as_ref() {
            let mut guard = 0;
            let e = l
                .cache
                .interpolate_filtered(q.p, q.ns, |id, r| {
                    self.core.visible(scene, l, id, r, &q, &mut guard)
                })
                .map(|i| Vec3::from_array(i.value.0));
            rays.shadow += guard;
            if let Some(e) = e {
                return e;
            }
        }
        // The fallback gather's own key: a hash of this sample's key and the cursor's position,
        // so it depends only on the sample (the pixel, the index, the seed).
        let key = SampleKey::new(dims.key().bits(dims.position()), FALLBACK_STREAM, 0);
        self.core.fallbacks.fetch_add(1, Ordering::Relaxed);
        let Some((samples, _, frame)) = self.core.gather(
            scene,
            (self.core.fallback_strata, None),
            x,
            key,
            rays,
            None,
            |traced, r| self.gather_radiances(scene, 0, traced, r),
        ) else {
            return Vec3::ZERO;
        };
        // The pixel's record: sized by its gather and the world limits, and at least as large as
        // the pixel's points on its triangle ask (it serves this pixel's samples only, as a
        // record of the pixel's footprint would: no sample of the pixel's surface gathers twice).
        let (record, mut inputs, nearest_hit) =
            self.core
                .record_from(0, x, (&samples, None), &frame, (0.0, 1.0));
        let e = Vec3::from_array(record.value.0);
        if let Some(first) = self.core.levels.first() {
            let needed = reach / first.cache.metric().influence_radius(1.0);
            if needed.is_finite() && needed > inputs.limits.min {
                inputs.limits.min = needed.min(inputs.limits.max);
            }
            let l = local.get_or_insert_with(|| Level {
                cache: IrradianceCache::new(*first.cache.metric()),
                guard: Vec::new(),
                noise: Vec::new(),
                radiance: Vec::new(),
                radiance_slot: Vec::new(),
                strata: self.core.fallback_strata,
            });
            if l.cache.insert_with_radius(record, &inputs).is_ok() {
                l.guard.push(GuardRecord {
                    nearest_hit,
                    geometric_normal: x.ng,
                });
                l.noise.push(samples.relative_error());
            }
        }
        e
    }
}
