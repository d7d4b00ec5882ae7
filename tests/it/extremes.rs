//! The numbers at the extremes: the same scene in other units or far from the origin renders the
//! same image, and degenerate geometry makes no NaN.

use crate::support::{ic_image, path_image, rel_mse};
use glam::Vec3;
use irr_geometry::{Geometry, TriangleMesh};
use irr_integrator::Scene;
use irr_render::{Camera, IcSettings, Image, MetricKind, RenderSettings, load_gltf};
use std::path::Path;

/// The Cornell box's meshes, materials and camera, every position mapped by `f` (a uniform scale
/// s and a translation t), and the camera moved with them.
fn cornell_mapped(s: f32, t: Vec3) -> (Scene, Camera) {
    let data = load_gltf(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/cornell-box.gltf"))
        .unwrap_or_else(|e| panic!("{e}"));
    let meshes: Vec<TriangleMesh> = data
        .meshes
        .iter()
        .map(|m| TriangleMesh {
            positions: m.positions.iter().map(|p| *p * s + t).collect(),
            ..m.clone()
        })
        .collect();
    let geometry = Geometry::build(&meshes).unwrap_or_else(|e| panic!("{e}"));
    let scene = Scene::new(geometry, data.materials).unwrap_or_else(|e| panic!("{e}"));
    let c = data
        .camera
        .unwrap_or_else(|| panic!("the Cornell box has a camera"));
    let camera = Camera {
        position: c.position * s + t,
        znear: c.znear * s,
        zfar: c.zfar.map(|z| z * s),
        ..c
    };
    (scene, camera)
}

fn ic_render(scene: &Scene, camera: &Camera, settings: &RenderSettings) -> Image {
    let ic = IcSettings {
        strata_m: 8,
        strata_n: 32,
        ..IcSettings::default()
    };
    ic_image(scene, camera, ic, settings).0
}

/// The cache with the Hessian metric: elliptical records whose radii come from the irradiance
/// Hessian (1/length²) and the scene's diagonal; with `second_order`, each record's curvature
/// (1/length²) times the squared offset from it, a number without unit, extrapolates it.
fn hessian_ic(second_order: f32) -> IcSettings {
    IcSettings {
        strata_m: 8,
        strata_n: 32,
        metric: MetricKind::Hessian,
        error: 0.5,
        second_order,
        ..IcSettings::default()
    }
}

fn hessian_render(scene: &Scene, camera: &Camera, settings: &RenderSettings) -> Image {
    ic_image(scene, camera, hessian_ic(0.0), settings).0
}

fn hessian_second_order_render(scene: &Scene, camera: &Camera, settings: &RenderSettings) -> Image {
    ic_image(scene, camera, hessian_ic(0.25), settings).0
}

/// No record, weight, radius, clamp, octree query or ray offset depends on the unit: the Cornell
/// box in metres, in millimetres (×1000) and at ×1e-4 gives the same image with the same seed,
/// for the irradiance cache (with Tabellion & Lamorlette's metric and with the Hessian's, whose
/// radii (4/|λ|)^¼ scale as √length until the scene's diagonal makes them lengths, with and
/// without its second-order extrapolation) and for the
/// path tracer. "The same" is measured against the natural
/// scale of the images' differences: two renders of the unscaled scene with different seeds.
/// With the same seed the scaled render follows the same random numbers, so its difference from
/// the unscaled one must be far below that noise; we allow a quarter of it (a scale-dependent
/// radius, offset or clamp changes the cache's records everywhere and lands at or above it).
#[test]
fn units_do_not_change_the_image() {
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp: 4,
        seed: 17,
        threads: 0,
    };
    let other_seed = RenderSettings {
        seed: 18,
        ..settings
    };
    let (scene, camera) = cornell_mapped(1.0, Vec3::ZERO);
    for (name, render_with) in [
        (
            "cache",
            ic_render as fn(&Scene, &Camera, &RenderSettings) -> Image,
        ),
        ("hessian cache", hessian_render),
        ("hessian cache, second order", hessian_second_order_render),
        ("path", path_image),
    ] {
        let base = render_with(&scene, &camera, &settings);
        let noise = rel_mse(&render_with(&scene, &camera, &other_seed), &base);
        for s in [1000.0f32, 1e-4] {
            let (scaled_scene, scaled_camera) = cornell_mapped(s, Vec3::ZERO);
            let scaled = render_with(&scaled_scene, &scaled_camera, &settings);
            let d = rel_mse(&scaled, &base);
            println!(
                "{name} ×{s}: relMSE to the unscaled image {d:.2e}, noise between seeds {noise:.2e}"
            );
            assert!(
                d < 0.25 * noise,
                "{name} ×{s}: {d:.2e} against noise {noise:.2e}"
            );
        }
    }
}

/// Far from the origin the float grid is coarse: at 1e5 units an f32 step is 7.8e-3, so the
/// Cornell box (0.55 m) translated by 1e5 has every vertex moved by up to 3.9 mm: a slightly
/// different scene. Rendered in millimetres (×1000) the same translation is 0.1 % of the box's
/// size and the vertices move by at most 3.9e-3 mm: that image must match the untranslated one
/// within the noise between seeds (a quarter of it, as above), for both integrators.
#[test]
fn far_from_the_origin_the_image_holds() {
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp: 16,
        seed: 23,
        threads: 0,
    };
    let (scene, camera) = cornell_mapped(1000.0, Vec3::ZERO);
    let (far_scene, far_camera) = cornell_mapped(1000.0, Vec3::new(1e5, -1e5, 1e5));
    for (name, render_with) in [
        (
            "cache",
            ic_render as fn(&Scene, &Camera, &RenderSettings) -> Image,
        ),
        ("hessian cache", hessian_render),
        ("path", path_image),
    ] {
        let base = render_with(&scene, &camera, &settings);
        let noise = rel_mse(
            &render_with(
                &scene,
                &camera,
                &RenderSettings {
                    seed: 24,
                    ..settings
                },
            ),
            &base,
        );
        let far = render_with(&far_scene, &far_camera, &settings);
        let d = rel_mse(&far, &base);
        println!("{name} at 1e5: relMSE {d:.2e}, noise {noise:.2e}");
        assert!(
            d < 0.25 * noise,
            "{name}: {d:.2e} against noise {noise:.2e}"
        );
    }
}

/// Zero-area, sliver (aspect 1e6) and duplicated coplanar triangles added to the Cornell box: the
/// zero-area ones are dropped and counted, and the cache's image has no NaN or infinite pixel.
#[test]
fn degenerate_triangles_make_no_nan() {
    let data = load_gltf(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/cornell-box.gltf"))
        .unwrap_or_else(|e| panic!("{e}"));
    let mut meshes = data.meshes.clone();
    let p = Vec3::new(0.2, 0.0, 0.2);
    meshes.push(TriangleMesh {
        positions: vec![
            // Zero area: a repeated vertex, and three collinear points.
            p,
            p,
            p + Vec3::X * 0.1,
            p,
            p + Vec3::X * 0.05,
            p + Vec3::X * 0.1,
            // A sliver of aspect 1e6 lying on the floor.
            p + Vec3::Z * 0.1,
            p + Vec3::Z * 0.1 + Vec3::X * 0.2,
            p + Vec3::Z * 0.1 + Vec3::new(0.1, 0.0, 2e-7),
            // The same floor patch twice, coplanar with the floor.
            Vec3::new(0.1, 0.0, 0.1),
            Vec3::new(0.2, 0.0, 0.1),
            Vec3::new(0.2, 0.0, 0.2),
        ],
        indices: vec![[0, 1, 2], [3, 4, 5], [6, 7, 8], [9, 10, 11], [9, 11, 10]],
        normals: None,
        material_ids: vec![0; 5],
    });
    let geometry = Geometry::build(&meshes).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(geometry.report().dropped_degenerate, 2);
    let scene = Scene::new(geometry, data.materials).unwrap_or_else(|e| panic!("{e}"));
    let camera = data.camera.unwrap_or_else(|| panic!("camera"));
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp: 2,
        seed: 1,
        threads: 0,
    };
    let image = ic_render(&scene, &camera, &settings);
    assert!(image.pixels().iter().all(|p| p.is_finite()));
    let _ = image.mean();
}

/// A very bright, very small emitter: a square of side 1 mm (area 1e-6 of the 1 m² floor's
/// scale) and radiance 1e6, 1 m above a diffuse floor (ρ = 0.5), facing down. On the floor right
/// below it the irradiance is L·A·cos θ·cos θ'/d² = 1e6·1e-6·1·1/1 = 1 (to 1e-6: the square
/// subtends 1e-6 sr), so the radiance leaving the floor towards the camera is ρ/π = 0.159. The
/// cache's direct light (NEE) must give that in the pixel looking straight down, finite; the
/// indirect part is 0 (nothing else reflects: the floor sees only the emitter's back, black).
/// Tolerance: NEE picks a point on the square and the pixel's samples land within 1 mm of the
/// point below it: d² and the two cosines vary by at most 1e-6 relative each over those, and the
/// f32 arithmetic (a few dozen roundings of 6e-8) adds below 3e-6: 1e-5 relative in all.
#[test]
fn a_tiny_bright_emitter_gives_the_known_direct_light() {
    let s = 5e-4f32;
    let light = TriangleMesh {
        positions: vec![
            Vec3::new(-s, 1.0, -s),
            Vec3::new(s, 1.0, -s),
            Vec3::new(s, 1.0, s),
            Vec3::new(-s, 1.0, s),
        ],
        // Counter-clockwise seen from below: the winding normal points down.
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: None,
        material_ids: vec![1, 1],
    };
    let floor = TriangleMesh {
        positions: vec![
            Vec3::new(-5.0, 0.0, -5.0),
            Vec3::new(5.0, 0.0, -5.0),
            Vec3::new(5.0, 0.0, 5.0),
            Vec3::new(-5.0, 0.0, 5.0),
        ],
        indices: vec![[0, 2, 1], [0, 3, 2]],
        normals: None,
        material_ids: vec![0, 0],
    };
    let geometry = Geometry::build(&[floor, light]).unwrap_or_else(|e| panic!("{e}"));
    let materials = vec![
        irr_integrator::Material::diffuse(Vec3::splat(0.5)),
        irr_integrator::Material::emitter(Vec3::splat(1e6)),
    ];
    let scene = Scene::new(geometry, materials).unwrap_or_else(|e| panic!("{e}"));
    // Looking straight down from 0.5 m (below the emitter) at the floor, a narrow field of view:
    // the middle pixel sees the floor within 1 mm of the point below the light.
    let camera = Camera::look_at(Vec3::new(0.0, 0.5, 0.0), Vec3::ZERO, Vec3::Z, 0.01)
        .unwrap_or_else(|| panic!("camera"));
    let settings = RenderSettings {
        width: 9,
        height: 9,
        spp: 4,
        seed: 2,
        threads: 0,
    };
    let image = ic_render(&scene, &camera, &settings);
    assert!(image.pixels().iter().all(|p| p.is_finite()));
    let centre = image.get(4, 4);
    let expected = 0.5 / std::f32::consts::PI;
    assert!(
        (centre - Vec3::splat(expected)).abs().max_element() <= 1e-5 * expected,
        "{centre} vs {expected}"
    );
}
