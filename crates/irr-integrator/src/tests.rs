//! Known-answer tests of the integrators on scenes built in code.
//!
//! Tolerances: a Monte Carlo mean of n independent samples has standard error σ/√n. We estimate σ
//! from the same samples and require |mean − expected| < 6·σ̂/√n: for a correct estimator the
//! chance of a larger deviation is about 2·10⁻⁹ (normal tail at 6σ; n ≥ 10⁴ makes the CLT and the
//! σ̂ ≈ σ approximation sound). The random numbers are fixed by the seed, so a test never flakes:
//! it fails only when the estimator is biased by more than that. Float rounding (a relative error
//! ~10⁻⁶ per sample) is far below these bands.

use crate::{
    AmbientOcclusion, AoSettings, Integrator, Material, PathSettings, PathTracer, RayCounter, Scene,
};
use glam::Vec3;
use irr_geometry::{Geometry, Ray, TriangleMesh};
use irr_sampling::SampleKey;
use irr_sampling::rng::Dimensions;
use std::f64::consts::PI;

/// Mean and standard error of `n` estimates of the red channel of `f(sample index)`.
pub(crate) fn estimate(n: u32, mut f: impl FnMut(u32) -> Vec3) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for i in 0..n {
        let v = f64::from(f(i).x);
        sum += v;
        sum2 += v * v;
    }
    let mean = sum / f64::from(n);
    let var = (sum2 / f64::from(n) - mean * mean).max(0.0) * f64::from(n) / f64::from(n - 1);
    (mean, (var / f64::from(n)).sqrt())
}

/// Asserts |mean − expected| < 6 standard errors (see the module docs), with a floor of 1e-6
/// relative for estimators whose variance is zero.
pub(crate) fn assert_close(what: &str, (mean, se): (f64, f64), expected: f64) {
    let band = 6.0 * se + 1e-6 * expected.abs();
    assert!(
        (mean - expected).abs() < band,
        "{what}: mean {mean} vs expected {expected} (standard error {se}, band ±{band})"
    );
}

/// An icosphere of `subdivisions` levels, radius `r`, centre `c`, winding facing outward.
pub(crate) fn icosphere(c: Vec3, r: f32, subdivisions: u32, material: u32) -> TriangleMesh {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push(((positions[a as usize] + positions[b as usize]) * 0.5).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let ab = mid(a, b, &mut positions);
            let bc = mid(b, c, &mut positions);
            let ca = mid(c, a, &mut positions);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    let n = faces.len();
    TriangleMesh {
        positions: positions.into_iter().map(|p| c + p * r).collect(),
        indices: faces,
        normals: None,
        material_ids: vec![material; n],
    }
}

/// A regular `sides`-gon of radius `r` centred at `c` in the plane y = c.y, wound so that its
/// normal points along `facing_y` (±1).
pub(crate) fn polygon(c: Vec3, r: f32, sides: u32, facing_y: f32, material: u32) -> TriangleMesh {
    let mut positions = vec![c];
    for i in 0..sides {
        let a = std::f32::consts::TAU * i as f32 / sides as f32;
        positions.push(c + Vec3::new(r * a.cos(), 0.0, r * a.sin()));
    }
    let indices = (0..sides)
        .map(|i| {
            let (a, b) = (1 + i, 1 + (i + 1) % sides);
            // (pa − c)×(pb − c) points along −y for increasing angle; swap for +y.
            if facing_y > 0.0 { [0, b, a] } else { [0, a, b] }
        })
        .collect();
    TriangleMesh {
        positions,
        indices,
        normals: None,
        material_ids: vec![material; sides as usize],
    }
}

/// A grey sphere of radius 2 at the origin (albedo 0.6, outward winding; reflection is
/// two-sided) with a light disk (radiance 5, radius 0.3) at y = 1.5 facing down inside it.
pub(crate) fn sphere_with_light() -> Scene {
    scene(
        &[
            icosphere(Vec3::ZERO, 2.0, 2, 0),
            polygon(Vec3::new(0.0, 1.5, 0.0), 0.3, 16, -1.0, 1),
        ],
        vec![
            Material::diffuse(Vec3::splat(0.6)),
            Material::emitter(Vec3::splat(5.0)),
        ],
    )
}

/// A white furnace: a closed icosphere of radius 2 centred at `c` that reflects `rho` and
/// emits `le` from both faces, so every direction inside sees the same radiance.
pub(crate) fn furnace(c: Vec3, rho: f32, le: f32) -> Scene {
    let material = Material {
        emission: Vec3::splat(le),
        ..Material::diffuse(Vec3::splat(rho))
    };
    scene(&[icosphere(c, 2.0, 2, 0)], vec![material])
}

/// The surface point where `ray` first meets `scene` (the test's geometry must hold one).
pub(crate) fn first_surface(scene: &Scene, ray: &Ray) -> irr_geometry::SurfacePoint {
    scene
        .geometry()
        .intersect(ray)
        .map(|h| scene.geometry().surface(ray, &h))
        .unwrap_or_else(|| panic!("the ray {ray:?} meets nothing"))
}

pub(crate) fn scene(meshes: &[TriangleMesh], materials: Vec<Material>) -> Scene {
    let geometry = Geometry::build(meshes).unwrap_or_else(|e| panic!("{e}"));
    Scene::new(geometry, materials).unwrap_or_else(|e| panic!("{e}"))
}

/// Irradiance at the origin (normal +y) from a polygon of radiance `l` with vertices `v`
/// (relative to the point), by Lambert's formula in Arvo's form: E = (L/2)·|Σᵢ Θᵢ (Γᵢ·n)|, Θᵢ the
/// angle edge i subtends and Γᵢ the unit normal of the plane through the point and edge i.
pub(crate) fn polygon_irradiance(v: &[Vec3], l: f64) -> f64 {
    let n = glam::DVec3::Y;
    let mut sum = 0.0;
    for i in 0..v.len() {
        let a = v[i].as_dvec3().normalize();
        let b = v[(i + 1) % v.len()].as_dvec3().normalize();
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        sum += theta * a.cross(b).normalize().dot(n);
    }
    0.5 * l * sum.abs()
}

#[test]
fn white_furnace_unbounded_depth_with_roulette() {
    // Inside a closed sphere where every point emits Le and reflects ρ, the radiance is
    // Le + ρ·Le + ρ²·Le + … = Le/(1 − ρ) everywhere, for any closed shape.
    for rho in [0.3f32, 0.8] {
        let le = 1.0f32;
        let s = furnace(Vec3::new(0.5, -2.0, 3.0), rho, le);
        let pt = PathTracer::new(PathSettings {
            max_depth: u32::MAX,
            rr_start: 0,
            ..PathSettings::default()
        });
        let mut rays = RayCounter::default();
        let est = estimate(20_000, |i| {
            let key = SampleKey::new(3, u64::from(i), 0);
            let dir = irr_sampling::sample_uniform_sphere(key.uniform_2d(0));
            let ray = Ray::new(Vec3::new(0.7, -1.5, 2.6), dir);
            pt.li(&s, &ray, &mut Dimensions::starting_at(key, 1), &mut rays)
        });
        assert_close(
            &format!("furnace ρ = {rho}"),
            est,
            f64::from(le) / (1.0 - f64::from(rho)),
        );
    }
}

#[test]
fn white_furnace_bounded_depth() {
    // With at most d bounces: Le·(1 + ρ + … + ρᵈ) = Le(1 − ρ^(d+1))/(1 − ρ). Also with roulette
    // (unbiased), and d = 0 (emission only: exact, zero variance).
    let rho = 0.7f64;
    let le = 2.0f64;
    let material = Material {
        emission: Vec3::splat(le as f32),
        ..Material::diffuse(Vec3::splat(rho as f32))
    };
    let s = scene(&[icosphere(Vec3::ZERO, 1.0, 2, 0)], vec![material]);
    for (d, rr_start) in [(0u32, 100u32), (1, 100), (3, 100), (5, 2)] {
        let pt = PathTracer::new(PathSettings {
            max_depth: d,
            rr_start,
            ..PathSettings::default()
        });
        let mut rays = RayCounter::default();
        let est = estimate(20_000, |i| {
            let key = SampleKey::new(4, u64::from(i), u64::from(d));
            let dir = irr_sampling::sample_uniform_sphere(key.uniform_2d(0));
            pt.li(
                &s,
                &Ray::new(Vec3::new(0.1, 0.2, -0.3), dir),
                &mut Dimensions::starting_at(key, 1),
                &mut rays,
            )
        });
        let expected = le * (1.0 - rho.powi(d as i32 + 1)) / (1.0 - rho);
        assert_close(&format!("furnace d = {d}"), est, expected);
    }
}

#[test]
fn disk_light_over_a_plane() {
    // A single-sided disk light of radiance L, radius r, facing down at height h above a diffuse
    // plane of albedo ρ. On the axis the irradiance is E = πL·r²/(r²+h²) for a true disk; the
    // light is a regular 64-gon, whose exact irradiance (Lambert's formula) we compare against,
    // and which is within 0.2% of the disk's (checked below). The plane's radiance is ρ/π·E, all
    // of it direct: the light is black (albedo 0) and the plane cannot see itself, so the
    // indirect part is exactly zero.
    let (l, r, h, rho) = (5.0f32, 0.5f32, 1.0f32, 0.6f32);
    let sides = 64;
    let light = polygon(Vec3::new(0.0, h, 0.0), r, sides, -1.0, 1);
    let floor = TriangleMesh {
        positions: vec![
            Vec3::new(-10.0, 0.0, -10.0),
            Vec3::new(10.0, 0.0, -10.0),
            Vec3::new(10.0, 0.0, 10.0),
            Vec3::new(-10.0, 0.0, 10.0),
        ],
        indices: vec![[0, 2, 1], [0, 3, 2]],
        normals: None,
        material_ids: vec![0, 0],
    };
    let vertices: Vec<Vec3> = light.positions[1..].to_vec();
    let s = scene(
        &[floor, light],
        vec![
            Material::diffuse(Vec3::splat(rho)),
            Material::emitter(Vec3::splat(l)),
        ],
    );
    let e_polygon = polygon_irradiance(&vertices, f64::from(l));
    let e_disk = PI * f64::from(l) * f64::from(r * r) / f64::from(r * r + h * h);
    assert!(
        (e_polygon / e_disk - 1.0).abs() < 2e-3,
        "{e_polygon} vs disk {e_disk}"
    );
    let expected = f64::from(rho) / PI * e_polygon;
    // An oblique camera ray that passes under the light and hits the axis point (the plane is
    // Lambertian, so the viewing direction does not matter).
    let origin = Vec3::new(3.0 * r, 0.5 * h, 0.0);
    let ray = Ray::new(origin, (Vec3::ZERO - origin).normalize());
    let pt = PathTracer::default();
    let mut rays = RayCounter::default();
    let mut indirect = Vec3::ZERO;
    let est = estimate(20_000, |i| {
        let key = SampleKey::new(5, u64::from(i), 0);
        let split = pt.li_split(&s, &ray, &mut Dimensions::starting_at(key, 1), &mut rays);
        indirect += split.indirect;
        split.total()
    });
    assert_close("disk light, plane radiance", est, expected);
    assert_eq!(indirect, Vec3::ZERO);
}

/// An unlit surface (`KHR_materials_unlit`) is its colour to the camera and nothing to any
/// other ray. The disk light over a plane with an unlit disk between them: a camera ray that
/// meets the unlit disk sees exactly its colour, as emission, in both integrators (no light
/// reflected, no path from it); a camera ray to the plane beneath it sees, sample for sample,
/// exactly what it sees without the disk (no shadow, no light, no reflection: every ray but
/// the camera's passes it by, and the same random numbers draw the same paths). Exact.
#[test]
fn an_unlit_surface_is_its_colour_to_the_camera_and_nothing_to_other_rays() {
    let (l, r, h) = (5.0f32, 0.5f32, 1.0f32);
    let floor = polygon(Vec3::ZERO, 10.0, 4, 1.0, 0);
    let light = polygon(Vec3::new(0.0, h, 0.0), r, 16, -1.0, 1);
    let colour = Vec3::new(0.8, 0.3, 0.1);
    let materials = vec![
        Material::diffuse(Vec3::splat(0.6)),
        Material::emitter(Vec3::splat(l)),
        Material::unlit(colour),
    ];
    let without = scene(&[floor.clone(), light.clone()], materials.clone());
    let unlit_disk = polygon(Vec3::new(0.0, 0.5 * h, 0.0), 0.4, 16, 1.0, 2);
    let with = scene(&[floor, light, unlit_disk], materials);
    let pt = PathTracer::default();
    let ic = crate::IrradianceCacheIntegrator::new(crate::IcSettings::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let seen = Ray::new(Vec3::new(0.1, 0.9 * h, 0.05), -Vec3::Y);
    let under = Ray::new(
        Vec3::new(0.6, 0.3 * h, 0.0),
        Vec3::new(-0.6, -0.3, 0.0).normalize(),
    );
    let mut rays = RayCounter::default();
    for i in 0..64u64 {
        let key = SampleKey::new(3, i, 0);
        for integrator in [&pt as &dyn Integrator, &ic] {
            let split = integrator.li_split(
                &with,
                &seen,
                &mut Dimensions::starting_at(key, 1),
                &mut rays,
            );
            assert_eq!(
                split,
                crate::Radiance {
                    emitted: colour,
                    ..crate::Radiance::default()
                },
                "{}",
                integrator.name()
            );
        }
        let a = pt.li_split(
            &with,
            &under,
            &mut Dimensions::starting_at(key, 1),
            &mut rays,
        );
        let b = pt.li_split(
            &without,
            &under,
            &mut Dimensions::starting_at(key, 1),
            &mut rays,
        );
        assert_eq!(a, b, "sample {i} under the unlit disk");
    }
    // The floor beneath is lit (the test would pass on a black scene otherwise).
    let lit = pt.li_split(
        &with,
        &under,
        &mut Dimensions::starting_at(SampleKey::new(3, 0, 0), 1),
        &mut rays,
    );
    assert!(lit.direct.max_element() > 0.0, "{lit:?}");
    assert_eq!(with.emitter_count(), without.emitter_count());
}

#[test]
fn ambient_occlusion_of_an_open_plane_is_one_at_every_scale() {
    // Nothing above the plane: every occlusion ray escapes, so AO is exactly 1, also for grazing
    // views and at any scale or offset (robust ray origins must not re-hit the plane).
    for (scale, offset) in [(1e-4f32, 0.0f32), (1.0, 0.0), (1e3, 0.0), (1.0, 1e5)] {
        let p = |x: f32, z: f32| Vec3::new(x * scale + offset, offset, z * scale + offset);
        let floor = TriangleMesh {
            positions: vec![p(-1.0, -1.0), p(1.0, -1.0), p(1.0, 1.0), p(-1.0, 1.0)],
            indices: vec![[0, 2, 1], [0, 3, 2]],
            normals: None,
            material_ids: vec![0, 0],
        };
        let s = scene(&[floor], vec![Material::diffuse(Vec3::ONE)]);
        let ao = AmbientOcclusion::new(AoSettings {
            max_distance: f32::INFINITY,
            samples: 16,
        });
        let mut rays = RayCounter::default();
        for i in 0..2_000u32 {
            let key = SampleKey::new(6, u64::from(i), 0);
            let u = key.uniform_2d(0) * 1.6 - 0.8;
            let target = p(u.x, u.y);
            // Views from steep to grazing (elevation down to ~0.6°), from both sides of the plane.
            let elevation = 0.01 + 1.5 * key.uniform(1);
            let side = if i % 2 == 0 { 1.0 } else { -1.0 };
            let dir = Vec3::new(elevation.cos(), -side * elevation.sin(), 0.3).normalize();
            let ray = Ray::new(target - dir * scale, dir);
            let v = ao.li(&s, &ray, &mut Dimensions::starting_at(key, 2), &mut rays);
            assert_eq!(v, Vec3::ONE, "scale {scale}, offset {offset}, sample {i}");
        }
    }
}

#[test]
fn light_sampler_is_a_distribution() {
    // Σ over emitters of pdf_area·area = Σ choice probabilities = 1 (f32 rounding of a few
    // additions: 1e-6), and non-emitters have density 0.
    let light = polygon(Vec3::new(0.0, 1.0, 0.0), 0.5, 16, -1.0, 1);
    let other = polygon(Vec3::new(0.0, 3.0, 0.0), 2.0, 8, -1.0, 2);
    let floor = polygon(Vec3::ZERO, 3.0, 8, 1.0, 0);
    let s = scene(
        &[floor, light, other],
        vec![
            Material::diffuse(Vec3::splat(0.5)),
            Material::emitter(Vec3::new(1.0, 2.0, 3.0)),
            Material {
                emission: Vec3::splat(0.1),
                ..Material::diffuse(Vec3::ZERO)
            },
        ],
    );
    assert_eq!(s.emitter_count(), 24);
    let g = s.geometry();
    let mut total = 0.0f64;
    for id in 0..g.triangle_count() as u32 {
        let t = g.triangle(id);
        let area = t.area();
        let pdf = s.lights().pdf_area(id);
        if s.materials()[t.material_id as usize].is_emissive() {
            assert!(pdf > 0.0);
        } else {
            assert_eq!(pdf, 0.0);
        }
        total += f64::from(pdf * area);
    }
    assert!((total - 1.0).abs() < 1e-5, "{total}");
}

#[test]
fn scene_rejects_missing_and_invalid_materials() {
    let floor = polygon(Vec3::ZERO, 1.0, 4, 1.0, 3);
    let g = Geometry::build(&[floor]).unwrap_or_else(|e| panic!("{e}"));
    let err = Scene::new(g, vec![Material::diffuse(Vec3::ONE)]).err();
    assert!(
        matches!(
            err,
            Some(crate::SceneError::MissingMaterial { material: 3, .. })
        ),
        "{err:?}"
    );
    let floor = polygon(Vec3::ZERO, 1.0, 4, 1.0, 0);
    let g = Geometry::build(&[floor]).unwrap_or_else(|e| panic!("{e}"));
    let err = Scene::new(g, vec![Material::diffuse(Vec3::new(0.5, 1.5, 0.5))]).err();
    assert!(
        matches!(
            err,
            Some(crate::SceneError::InvalidMaterial { what: "albedo", .. })
        ),
        "{err:?}"
    );
    for ior in [0.5, f32::NAN, -1.0] {
        let floor = polygon(Vec3::ZERO, 1.0, 4, 1.0, 0);
        let g = Geometry::build(&[floor]).unwrap_or_else(|e| panic!("{e}"));
        let material = Material {
            ior,
            ..Material::metallic_roughness(Vec3::ONE, 0.0, 0.5)
        };
        let err = Scene::new(g, vec![material]).err();
        assert!(
            matches!(
                err,
                Some(crate::SceneError::InvalidMaterial { what: "ior", .. })
            ),
            "{ior}: {err:?}"
        );
    }
}

/// `li_split_many_first_hits` answers as `li_split_many` does, bit for bit, with the first hits
/// `first_hit` finds (the light disk, the sphere, and a miss through a hole); the path tracer and
/// the irradiance cache find them on the way (the same rays as `li_split_many`), the default
/// (ambient occlusion) traces one more closest hit per ray.
#[test]
fn first_hits_come_with_the_answers_at_no_extra_ray_where_the_integrator_finds_them() {
    use crate::{FirstHit, IcSettings, IrradianceCacheIntegrator, Radiance, first_hit};
    // A grey sphere with a light disk inside, and rays from its centre, one of them through a
    // gap: the icosphere is closed, so the miss is a ray from outside pointing away.
    let scene = sphere_with_light();
    let rays: Vec<Ray> = (0..24)
        .map(|i| {
            let a = i as f32 * 0.7;
            Ray::new(
                Vec3::ZERO,
                Vec3::new(a.cos(), (a * 1.3).sin(), a.sin()).normalize(),
            )
        })
        .chain([
            Ray::new(Vec3::ZERO, Vec3::Y),
            Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::Z),
        ])
        .collect();
    let ic =
        IrradianceCacheIntegrator::new(IcSettings::default()).unwrap_or_else(|e| panic!("{e}"));
    let path = PathTracer::new(PathSettings::default());
    let ao = AmbientOcclusion::new(AoSettings::default());
    let integrators: [(&dyn Integrator, u64); 3] = [(&path, 0), (&ic, 0), (&ao, 1)];
    for (integrator, extra_per_ray) in integrators {
        let dims = |k: u64| -> Vec<Dimensions> {
            (0..rays.len() as u64)
                .map(|i| Dimensions::starting_at(SampleKey::new(k, i, 0), 1))
                .collect()
        };
        let (mut plain_dims, mut seen_dims) = (dims(3), dims(3));
        let mut plain = vec![Radiance::default(); rays.len()];
        let mut seen = vec![Radiance::default(); rays.len()];
        let mut first: Vec<Option<FirstHit>> = vec![None; rays.len()];
        let (mut plain_rays, mut seen_rays) = (RayCounter::default(), RayCounter::default());
        integrator.li_split_many(&scene, &rays, &mut plain_dims, &mut plain, &mut plain_rays);
        integrator.li_split_many_first_hits(
            &scene,
            &rays,
            &mut seen_dims,
            &mut seen,
            &mut first,
            &mut seen_rays,
        );
        let name = integrator.name();
        for i in 0..rays.len() {
            let (a, b) = (plain[i], seen[i]);
            assert_eq!(
                [a.emitted, a.direct, a.indirect].map(|v| v.to_array().map(f32::to_bits)),
                [b.emitted, b.direct, b.indirect].map(|v| v.to_array().map(f32::to_bits)),
                "{name}, ray {i}"
            );
            assert_eq!(plain_dims[i].position(), seen_dims[i].position(), "{name}");
            let expected = first_hit(&scene, &rays[i], &mut RayCounter::default());
            assert_eq!(first[i], expected, "{name}, ray {i}");
        }
        assert!(
            first[rays.len() - 1].is_none() && first[0].is_some(),
            "{name}"
        );
        assert!(
            first[rays.len() - 2].is_some_and(|h| h.albedo == Vec3::ZERO),
            "{name}"
        );
        assert_eq!(seen_rays.shadow, plain_rays.shadow, "{name}");
        assert_eq!(
            seen_rays.closest,
            plain_rays.closest + extra_per_ray * rays.len() as u64,
            "{name}"
        );
    }
}

/// The directional albedo ∫ f(wo, wi) cos θi dωi of `m` for `wo` (local frame, normal +z) by
/// midpoint quadrature on n × n cells: the diffuse lobe over wi by the cosine-weighted map
/// (∫ g cos dω = π · mean of g over the unit square mapped by `sample_cosine_hemisphere`), the
/// glossy lobe over the microfacet normal wm with wi = reflect(wo, wm) and dωi = 4 |wo·wm| dωm
/// (Walter et al. 2007, eq. 14) on a grid in θm spaced for the lobe's width α, as irr-bsdf's
/// own tests integrate it.
fn directional_albedo(m: &irr_bsdf::MetallicRoughness, wo: Vec3, n: usize) -> f64 {
    let mut diffuse = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let u = glam::Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let wi = irr_sampling::sample_cosine_hemisphere(u);
            diffuse += f64::from(m.eval_lobes(wo, wi).diffuse.x);
        }
    }
    diffuse *= PI / (n * n) as f64;
    let alpha = f64::from(m.alpha());
    let (dv, dphi) = (1.0 / n as f64, std::f64::consts::TAU / n as f64);
    let mut glossy = 0.0f64;
    for i in 0..n {
        let v = (i as f64 + 0.5) * dv;
        let theta = (alpha * v / (1.0 - v)).atan();
        let jacobian = alpha / ((1.0 - v).powi(2) + (alpha * v).powi(2));
        let (sin_t, cos_t) = theta.sin_cos();
        for j in 0..n {
            let (sin_p, cos_p) = ((j as f64 + 0.5) * dphi).sin_cos();
            let wm = glam::DVec3::new(sin_t * cos_p, sin_t * sin_p, cos_t);
            let d = wo.as_dvec3().dot(wm);
            let wi = 2.0 * d * wm - wo.as_dvec3();
            if d <= 0.0 || wi.z <= 0.0 {
                continue;
            }
            let f = f64::from(m.eval_lobes(wo, wi.as_vec3()).glossy.x);
            glossy += f * wi.z * 4.0 * d * sin_t * jacobian * dv * dphi;
        }
    }
    diffuse + glossy
}

/// A glossy white furnace: a closed sphere that emits Le from both faces and reflects by the
/// glTF metallic-roughness model. With one bounce every point sees Le from every direction, so
/// the radiance towards the camera is Le (1 + A(wo)), A the directional albedo at the hit's wo
/// (by quadrature, `directional_albedo`). This checks the light sampling, the BSDF sampling and
/// their power-heuristic weights for glossy lobes together, in the path tracer and in the
/// cache's direct light (two light samples against one BSDF sample, and against ⌈p²·5⌉ BSDF
/// samples with `glossy_samples` 5: the weights must use the counts). Tolerance: 6 standard
/// errors (module docs) plus the quadrature's error, taken as the whole difference between 256²
/// and 512² cells (second-order midpoint rule: the 512² error is about a third of it).
#[test]
fn glossy_furnace_one_bounce() {
    let le = 1.5f32;
    for (base, metallic, roughness) in [(0.8f32, 1.0f32, 0.3f32), (0.6, 0.0, 0.5), (0.9, 0.5, 0.15)]
    {
        let material = Material {
            emission: Vec3::splat(le),
            two_sided: true,
            ..Material::metallic_roughness(Vec3::splat(base), metallic, roughness)
        };
        let s = scene(&[icosphere(Vec3::ZERO, 2.0, 2, 0)], vec![material]);
        let path = PathSettings {
            max_depth: 1,
            rr_start: 5,
            ..PathSettings::default()
        };
        let pt = PathTracer::new(path);
        // The cache's direct light: its light samples weighted against the BSDF samples it
        // also traces for the glossy lobe (no cache level at one bounce).
        let ic = |glossy_samples| {
            let mut ic = crate::IrradianceCacheIntegrator::new(crate::IcSettings {
                path,
                glossy_samples,
                ..crate::IcSettings::default()
            })
            .unwrap_or_else(|e| panic!("{e}"));
            ic.preprocess(&s);
            ic
        };
        let (one, split) = (ic(1), ic(5));
        // From off-centre, at the wall nearly head-on, obliquely and at a grazing angle.
        let origin = Vec3::new(1.2, 0.0, 0.0);
        for (k, dir) in [
            Vec3::new(1.0, 0.1, 0.05),
            Vec3::new(0.3, 1.0, 0.2),
            Vec3::new(0.95, -0.05, 1.0),
        ]
        .into_iter()
        .enumerate()
        {
            let ray = Ray::new(origin, dir.normalize());
            let surface = first_surface(&s, &ray);
            let x = crate::path::ShadingPoint::new(&surface, -ray.direction);
            let frame = irr_sampling::Frame::from_normal(x.ns);
            let wo = frame.to_local(x.wo.normalize());
            let m = s.reflection(x.triangle, x.b1, x.b2);
            let (fine, coarse) = (
                directional_albedo(&m, wo, 512),
                directional_albedo(&m, wo, 256),
            );
            let mut rays = RayCounter::default();
            let expected = f64::from(le) * (1.0 + fine);
            let quad_err = f64::from(le) * (fine - coarse).abs();
            for integrator in [&pt as &dyn Integrator, &one, &split] {
                let est = estimate(20_000, |i| {
                    let key = SampleKey::new(11, u64::from(i), k as u64);
                    integrator.li(&s, &ray, &mut Dimensions::new(key), &mut rays)
                });
                let band = 6.0 * est.1 + quad_err + 1e-6 * expected;
                assert!(
                    (est.0 - expected).abs() < band,
                    "{}: base {base} metallic {metallic} roughness {roughness} cos θo {}: mean {} \
                     vs {expected} (se {}, quadrature ±{quad_err})",
                    integrator.name(),
                    wo.z,
                    est.0,
                    est.1
                );
            }
        }
    }
}

/// With at most one reflection the background that a surface reflects once (paths `L D B`) is
/// counted by both integrators, the cache having no level to read it from: an open plane under
/// a uniform background B reflects A(wo)·B, A its directional albedo (ρ for a Lambertian plane;
/// by quadrature for a glossy one, `directional_albedo`). Tolerance as in
/// `glossy_furnace_one_bounce`.
#[test]
fn a_background_reflected_once_counts_at_depth_one() {
    let b = 0.8f32;
    for material in [
        Material::diffuse(Vec3::splat(0.6)),
        Material::metallic_roughness(Vec3::splat(0.7), 0.3, 0.4),
    ] {
        let s = scene(&[polygon(Vec3::ZERO, 5.0, 8, 1.0, 0)], vec![material])
            .with_background(Vec3::splat(b))
            .unwrap_or_else(|e| panic!("{e}"));
        let path = PathSettings {
            max_depth: 1,
            rr_start: 5,
            ..PathSettings::default()
        };
        let mut ic = crate::IrradianceCacheIntegrator::new(crate::IcSettings {
            path,
            ..crate::IcSettings::default()
        })
        .unwrap_or_else(|e| panic!("{e}"));
        ic.preprocess(&s);
        let ray = Ray::new(Vec3::new(-0.5, 0.8, 0.0), Vec3::new(0.6, -0.8, 0.0));
        let x = crate::path::ShadingPoint::new(&first_surface(&s, &ray), -ray.direction);
        let wo = irr_sampling::Frame::from_normal(x.ns).to_local(x.wo.normalize());
        let m = s.reflection(x.triangle, x.b1, x.b2);
        let (fine, coarse) = (
            directional_albedo(&m, wo, 512),
            directional_albedo(&m, wo, 256),
        );
        let expected = f64::from(b) * fine;
        let quad_err = f64::from(b) * (fine - coarse).abs();
        for integrator in [&PathTracer::new(path) as &dyn Integrator, &ic] {
            let mut rays = RayCounter::default();
            let est = estimate(20_000, |i| {
                let key = SampleKey::new(12, u64::from(i), 0);
                integrator.li(&s, &ray, &mut Dimensions::new(key), &mut rays)
            });
            let band = 6.0 * est.1 + quad_err + 1e-6 * expected;
            assert!(
                (est.0 - expected).abs() < band,
                "{} on {material:?}: {} vs {expected} (se {})",
                integrator.name(),
                est.0,
                est.1
            );
        }
    }
}
