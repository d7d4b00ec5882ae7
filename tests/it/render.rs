//! The whole pipeline on the scenes in assets/: load the glTF, render a small image, check a
//! known answer. Tolerances come from the estimator's variance, measured from the image itself,
//! plus f32 rounding; each derivation is written beside its assertion. A failing image check
//! writes `-actual`, `-reference` and `-error` EXRs under target/ and names them.

use crate::support::asset;
use glam::Vec3;
use irr_geometry::{Geometry, TriangleMesh};
use irr_integrator::{
    AmbientOcclusion, AoSettings, Integrator, Material, PathSettings, PathTracer, Scene,
};
use irr_render::{
    Camera, Image, LoadedScene, RenderSettings, load_gltf, load_scene, mean_of_samples,
    pixel_samples, render, write_exr_and_png,
};
use std::path::Path;

fn load(name: &str) -> LoadedScene {
    load_scene(&asset(name)).unwrap_or_else(|e| panic!("{e}"))
}

fn settings(width: u32, height: u32, spp: u32) -> RenderSettings {
    RenderSettings {
        width,
        height,
        spp,
        seed: 7,
        threads: 0,
    }
}

fn render_image(
    scene: &Scene,
    camera: &Camera,
    integrator: &dyn Integrator,
    s: &RenderSettings,
) -> Image {
    render(scene, camera, integrator, s, false)
        .unwrap_or_else(|e| panic!("{e}"))
        .image
}

fn path_tracer(max_depth: u32) -> PathTracer {
    PathTracer::new(PathSettings {
        max_depth,
        ..PathSettings::default()
    })
}

/// Writes `<name>-actual.exr`, `<name>-reference.exr` and `<name>-error.exr` (|actual −
/// reference|) under target/, and returns a sentence naming them.
fn write_failure_images(name: &str, actual: &Image, reference: &Image) -> String {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("image-tests");
    let error: Vec<Vec3> = actual
        .pixels()
        .iter()
        .zip(reference.pixels())
        .map(|(a, r)| (*a - *r).abs())
        .collect();
    let error = Image::from_pixels(actual.width(), actual.height(), error)
        .unwrap_or_else(|| panic!("size mismatch"));
    let mut written = Vec::new();
    for (suffix, image) in [
        ("actual", actual),
        ("reference", reference),
        ("error", &error),
    ] {
        let path = dir.join(format!("{name}-{suffix}.exr"));
        match write_exr_and_png(image, &path, 0.0) {
            Ok((exr, _)) => written.push(exr.display().to_string()),
            Err(e) => written.push(format!("(not written: {e})")),
        }
    }
    format!("images: {}", written.join(", "))
}

/// The per-channel mean of the pixels and its standard error s/√N, where s² is the sample
/// variance of the N pixel values. Pixels use disjoint sample keys, so they are independent
/// estimates of the same quantity when the answer is constant over the image.
pub(crate) fn mean_and_standard_error(image: &Image) -> ([f64; 3], [f64; 3]) {
    let n = image.pixels().len() as f64;
    let mut mean = [0.0; 3];
    for p in image.pixels() {
        for c in 0..3 {
            mean[c] += f64::from(p[c]) / n;
        }
    }
    let mut var = [0.0; 3];
    for p in image.pixels() {
        for c in 0..3 {
            let d = f64::from(p[c]) - mean[c];
            var[c] += d * d / (n - 1.0);
        }
    }
    (mean, var.map(|v| (v / n).sqrt()))
}

/// Checks that the image's mean is `expected` within `z` standard errors plus `bias` (a bound
/// on any known systematic difference) plus `rounding` (f32 arithmetic), per channel; on
/// failure, writes the images.
pub(crate) fn assert_mean(
    name: &str,
    image: &Image,
    expected: Vec3,
    z: f64,
    bias: f64,
    rounding: f64,
) {
    let (mean, se) = mean_and_standard_error(image);
    for c in 0..3 {
        let tolerance = z * se[c] + bias + rounding;
        let diff = (mean[c] - f64::from(expected[c])).abs();
        if diff > tolerance {
            let reference = Image::from_pixels(
                image.width(),
                image.height(),
                vec![expected; image.pixels().len()],
            )
            .unwrap_or_else(|| panic!("size"));
            panic!(
                "{name}: channel {c}: mean {} differs from {} by {diff:e} > {tolerance:e} \
                 ({z}·SE {:e} + bias {bias:e} + rounding {rounding:e}); {}",
                mean[c],
                expected[c],
                se[c],
                write_failure_images(name, image, &reference)
            );
        }
    }
}

/// White furnace (assets/furnace.glb): a closed sphere of albedo ρ = 0.8 emitting Le = 1 from
/// both faces. Radiance everywhere is Le·Σₖ ρᵏ over the bounces counted; with at most d
/// bounces, Le·(1 − ρ^(d+1))/(1 − ρ) (pbrt-v4's integrators_test.cpp has the same scene).
#[test]
fn white_furnace() {
    let loaded = load("furnace.glb");
    let (rho, le) = (0.8f64, 1.0f64);
    let m = loaded.scene.materials()[0];
    assert_eq!((m.albedo, m.emission), (Vec3::splat(0.8), Vec3::ONE));
    let s = settings(32, 32, 64);
    let camera = loaded.camera_for(s.width, s.height);
    for depth in [1u32, 64] {
        let image = render_image(&loaded.scene, &camera, &path_tracer(depth), &s);
        let expected = le * (1.0 - rho.powi(depth as i32 + 1)) / (1.0 - rho);
        // z = 5: a correct estimator fails with probability 6·10⁻⁷ per channel (normal tail;
        // 1024 pixel means of 64 samples each are close to normal, and the seed is fixed, so
        // the outcome is deterministic). Rounding: each bounce multiplies the throughput by a
        // few f32 factors (≤ 4 roundings of 2⁻²⁴ each), over up to `depth` bounces, relative
        // to the answer: 4·depth·2⁻²⁴·expected.
        let rounding = 4.0 * f64::from(depth) * 2f64.powi(-24) * expected;
        assert_mean(
            &format!("furnace-depth{depth}"),
            &image,
            Vec3::splat(expected as f32),
            5.0,
            0.0,
            rounding,
        );
    }
}

/// Irradiance from a uniform disk of radiance L and radius r, on a parallel plane at distance
/// h, at lateral distance d from the axis (the disk-to-point configuration factor; Howell's
/// catalogue of configuration factors, B-13): E = (πL/2)·(1 − (h² + d² − r²)/√((h² + d² +
/// r²)² − 4r²d²)). On the axis it is πL·r²/(r² + h²).
fn disk_irradiance(l: f64, r: f64, h: f64, d: f64) -> f64 {
    let (h2, d2, r2) = (h * h, d * d, r * r);
    std::f64::consts::PI * l / 2.0
        * (1.0 - (h2 + d2 - r2) / ((h2 + d2 + r2).powi(2) - 4.0 * r2 * d2).sqrt())
}

/// assets/disk-light.gltf: a disk light (r = 0.5, h = 1, L = 4, single-sided facing down,
/// black) over a plane of albedo 0.5, seen from the axis through a 2° field of view. The plane
/// reflects L_o = (ρ/π)·E, with E = πL·r²/(r² + h²) on the axis.
#[test]
fn disk_light_over_a_plane() {
    let loaded = load("disk-light.gltf");
    let (l, r, h, rho) = (4.0f64, 0.5f64, 1.0f64, 0.5f64);
    let s = settings(32, 32, 16);
    let camera = loaded.camera_for(s.width, s.height);
    let image = render_image(&loaded.scene, &camera, &path_tracer(64), &s);
    let on_axis = disk_irradiance(l, r, h, 0.0);
    assert!((on_axis - std::f64::consts::PI * l * r * r / (r * r + h * h)).abs() < 1e-12);
    let expected = rho / std::f64::consts::PI * on_axis;
    // Known biases, both bounded because E decreases as d grows and as r shrinks:
    // 1. The pixels see the plane up to the image corner, at d = c·tan(yfov/2)·√2 from the
    //    axis (camera height c = 0.5): E there is at most E(0) − E(d).
    let corner = 0.5 * (camera.yfov as f64 / 2.0).tan() * 2f64.sqrt();
    let footprint = rho / std::f64::consts::PI * (on_axis - disk_irradiance(l, r, h, corner));
    // 2. The disk is a 256-gon inscribed in the circle, so it lies between the circles of
    //    radius r·cos(π/256) and r.
    let inner = r * (std::f64::consts::PI / 256.0).cos();
    let polygon = rho / std::f64::consts::PI * (on_axis - disk_irradiance(l, inner, h, 0.0));
    // z = 5 as for the furnace; rounding: a few f32 operations per sample on O(1) values,
    // 16·2⁻²⁴·expected.
    assert_mean(
        "disk-light",
        &image,
        Vec3::splat(expected as f32),
        5.0,
        footprint + polygon,
        16.0 * 2f64.powi(-24) * expected,
    );
    // A single-sided light emits from its front face only: from below it shows L exactly (every
    // sample sees the emission and nothing else: the light is black), from above nothing.
    let below = Camera::look_at(
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::Z,
        0.1,
    )
    .unwrap_or_else(|| panic!("camera"));
    let above = Camera::look_at(
        Vec3::new(0.0, 1.5, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::Z,
        0.1,
    )
    .unwrap_or_else(|| panic!("camera"));
    let s = settings(4, 4, 4);
    let pt = path_tracer(64);
    let front = render_image(&loaded.scene, &below, &pt, &s);
    assert!(
        front.pixels().iter().all(|p| *p == Vec3::splat(4.0)),
        "{front:?}"
    );
    let back = render_image(&loaded.scene, &above, &pt, &s);
    assert!(back.pixels().iter().all(|p| *p == Vec3::ZERO), "{back:?}");
    // The same file with the light double-sided: it now shows L from above too.
    let mut data = load_gltf(&asset("disk-light.gltf")).unwrap_or_else(|e| panic!("{e}"));
    for m in &mut data.materials {
        m.two_sided = true;
    }
    let geometry = Geometry::build(&data.meshes).unwrap_or_else(|e| panic!("{e}"));
    let scene = Scene::new(geometry, data.materials).unwrap_or_else(|e| panic!("{e}"));
    let back = render_image(&scene, &above, &pt, &s);
    assert!(
        back.pixels().iter().all(|p| *p == Vec3::splat(4.0)),
        "{back:?}"
    );
}

/// assets/ao-plane.gltf: a plane under nothing. Every ambient-occlusion ray escapes, so every
/// sample is exactly 1 and so is every pixel (the f64 sum of n ones is n; n/n = 1).
#[test]
fn ambient_occlusion_of_an_open_plane_is_one() {
    let loaded = load("ao-plane.gltf");
    let s = settings(16, 16, 8);
    let camera = loaded.camera_for(s.width, s.height);
    let image = render_image(
        &loaded.scene,
        &camera,
        &AmbientOcclusion::new(AoSettings::default()),
        &s,
    );
    let reference =
        Image::from_pixels(16, 16, vec![Vec3::ONE; 256]).unwrap_or_else(|| panic!("size"));
    if image != reference {
        panic!(
            "AO of an open plane is not 1 everywhere; {}",
            write_failure_images("ao-plane", &image, &reference)
        );
    }
}

/// Same seed, same image, bit for bit, for 1, 2 and 8 threads; another seed, another image.
/// The image is 3 × 2 tiles (`TILE_SIZE` 16, the last row and column partial), so that the
/// threads share the work.
#[test]
fn same_seed_same_image_for_any_thread_count() {
    let loaded = load("cornell-box.gltf");
    let pt = path_tracer(64);
    let (w, h) = (40, 24);
    assert!(w > 2 * irr_render::TILE_SIZE && h > irr_render::TILE_SIZE);
    let camera = loaded.camera_for(w, h);
    let bits = |threads: usize, seed: u64| -> Vec<u32> {
        let s = RenderSettings {
            width: w,
            height: h,
            spp: 2,
            seed,
            threads,
        };
        let out = render(&loaded.scene, &camera, &pt, &s, false).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(out.stats.threads, threads);
        assert!(
            out.stats.rays.total() >= u64::from(w * h * 2),
            "every sample traces a camera ray"
        );
        out.image
            .pixels()
            .iter()
            .flat_map(|p| p.to_array().map(f32::to_bits))
            .collect()
    };
    let one = bits(1, 3);
    assert_eq!(one, bits(2, 3));
    assert_eq!(one, bits(8, 3));
    assert_ne!(one, bits(2, 4));
}

/// `--debug-pixel` replays a pixel: the mean of its samples is the rendered value, bit for bit.
#[test]
fn a_pixel_replays_exactly() {
    let loaded = load("cornell-box.gltf");
    let pt = path_tracer(64);
    let s = settings(8, 8, 4);
    let camera = loaded.camera_for(s.width, s.height);
    let image = render_image(&loaded.scene, &camera, &pt, &s);
    for (x, y) in [(0, 0), (3, 5), (7, 7)] {
        let samples =
            pixel_samples(&loaded.scene, &camera, &pt, &s, x, y).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(samples.len(), 4);
        assert_eq!(
            mean_of_samples(&samples).to_array().map(f32::to_bits),
            image.get(x, y).to_array().map(f32::to_bits)
        );
    }
    assert!(pixel_samples(&loaded.scene, &camera, &pt, &s, 8, 0).is_err());
}

/// On a scene large enough to stream (`Geometry::streams`: the path tracer then traces a tile's
/// paths a bounce at a time, `li_many`), the image is still each sample's `li`, bit for bit:
/// every pixel replayed one sample at a time matches, and 1 and 2 threads give the same image.
/// A closed room whose floor is a 150 × 150-quad heightfield (45 000 triangles), lit by an
/// emitting patch under the ceiling with a shade below it. (The test fails when the batched
/// paths ignore an occluded shadow ray on every other path: checked, then restored.)
#[test]
fn a_streaming_scene_renders_each_samples_li() {
    let (n, mut floor) = (150u32, TriangleMesh::default());
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (
                2.0 * i as f32 / n as f32 - 1.0,
                2.0 * j as f32 / n as f32 - 1.0,
            );
            let y = 0.05 * (7.0 * x).sin() * (5.0 * z).cos();
            floor.positions.push(Vec3::new(x, y, z));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            floor.indices.extend([[a, c, b], [b, c, d]]);
        }
    }
    floor.material_ids = vec![0; floor.indices.len()];
    // The walls and ceiling (material 0), the light (1, facing down: emission is one-sided) and
    // a shade under it, so that shadow rays are blocked too: corners (x, y, z) and material.
    #[rustfmt::skip]
    let faces: [([[f32; 3]; 4], u32); 7] = [
        ([[-1., -0.1, -1.], [1., -0.1, -1.], [1., 2., -1.], [-1., 2., -1.]], 0),
        ([[-1., -0.1, 1.], [-1., 2., 1.], [1., 2., 1.], [1., -0.1, 1.]], 0),
        ([[-1., -0.1, -1.], [-1., 2., -1.], [-1., 2., 1.], [-1., -0.1, 1.]], 0),
        ([[1., -0.1, -1.], [1., -0.1, 1.], [1., 2., 1.], [1., 2., -1.]], 0),
        ([[-1., 2., -1.], [1., 2., -1.], [1., 2., 1.], [-1., 2., 1.]], 0),
        ([[-0.3, 1.9, -0.3], [0.3, 1.9, -0.3], [0.3, 1.9, 0.3], [-0.3, 1.9, 0.3]], 1),
        ([[-0.4, 1.2, -0.6], [0.2, 1.2, -0.6], [0.2, 1.2, 0.0], [-0.4, 1.2, 0.0]], 0),
    ];
    let mut meshes = vec![floor];
    meshes.extend(faces.map(|(corners, material)| TriangleMesh {
        positions: corners.map(Vec3::from).to_vec(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: None,
        material_ids: vec![material; 2],
    }));
    let geometry = Geometry::build_owned(meshes).unwrap_or_else(|e| panic!("{e}"));
    assert!(geometry.streams(), "the scene is too small to stream");
    let scene = Scene::new(
        geometry,
        vec![
            Material::diffuse(Vec3::splat(0.7)),
            Material::emitter(Vec3::splat(5.0)),
        ],
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let (eye, target) = (Vec3::new(0.0, 1.5, 0.9), Vec3::new(0.0, 0.0, -0.3));
    let camera =
        Camera::look_at(eye, target, Vec3::Y, 1.0).unwrap_or_else(|| panic!("a valid camera"));
    let pt = path_tracer(64);
    // 3 × 2 tiles, so that two threads share the work.
    let s = |threads: usize| RenderSettings {
        threads,
        ..settings(40, 24, 2)
    };
    let image = render_image(&scene, &camera, &pt, &s(1));
    assert_eq!(image, render_image(&scene, &camera, &pt, &s(2)));
    for (x, y) in (0..24).flat_map(|y| (0..40).map(move |x| (x, y))) {
        let samples =
            pixel_samples(&scene, &camera, &pt, &s(1), x, y).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            mean_of_samples(&samples).to_array().map(f32::to_bits),
            image.get(x, y).to_array().map(f32::to_bits),
            "pixel ({x}, {y})"
        );
    }
}

/// The Cornell box's orientation and radiometry through the whole pipeline, EXR included:
/// row 0 of the file is the top of the image, the red wall is on the left, and pixel values
/// are radiance in the file's units.
#[test]
fn cornell_box_orientation_and_units() {
    let loaded = load("cornell-box.gltf");
    let s = settings(32, 32, 4);
    let camera = loaded.camera_for(s.width, s.height);
    let light = loaded
        .scene
        .materials()
        .iter()
        .find(|m| m.emission.max_element() > 0.0)
        .copied()
        .unwrap_or_else(|| panic!("no light"));
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let path = dir.path().join("cornell.exr");

    // Emission only (max depth 0). The light, 130 × 105 mm at y = 548.7 mm, projects (camera
    // at (278, 273, −800) mm, yfov = 2·atan(12.5/35)) onto ndc x ∈ [−0.168, 0.168] and
    // ndc y ∈ [0.682, 0.752]: in a 32×32 image, columns 13.3 to 18.7 and rows 3.97 to 5.09,
    // so pixels (14..=17, 4) lie wholly on it. Every sample there returns the light's emission
    // exactly, and the mean of n equal f32 values summed in f64 is that value exactly.
    let image = render_image(&loaded.scene, &camera, &path_tracer(0), &s);
    write_exr_and_png(&image, &path, 0.0).unwrap_or_else(|e| panic!("{e}"));
    let read = Image::read_exr(&path).unwrap_or_else(|e| panic!("{e}"));
    for x in 14..=17 {
        assert_eq!(read.get(x, 4), light.emission, "pixel ({x}, 4)");
        // The mirrored row near the bottom sees the floor, which does not emit.
        assert_eq!(read.get(x, 31 - 4), Vec3::ZERO, "pixel ({x}, 27)");
    }

    // Direct light only (max depth 1). Pixel (1, 16) sees the left wall near the front and
    // pixel (30, 16) the right wall. Every non-zero sample there is (albedo · Le · a scalar
    // factor), so the red/green ratio of the pixel is exactly ρ_r·Le_r/(ρ_g·Le_g), up to f32
    // rounding: at most 32 roundings of 2⁻²⁴ per channel per sample (albedo/π, Le, cosines,
    // geometry term, MIS weight, pdf, accumulation), in both channels: 2·32·2⁻²⁴ ≈ 3.8e-6.
    let image = render_image(&loaded.scene, &camera, &path_tracer(1), &s);
    for (x, albedo) in [
        (1, Vec3::new(0.63, 0.065, 0.05)),
        (30, Vec3::new(0.14, 0.45, 0.091)),
    ] {
        let p = image.get(x, 16);
        let expected = (albedo.x * light.emission.x) / (albedo.y * light.emission.y);
        let ratio = p.x / p.y;
        assert!(p.y > 0.0, "pixel ({x}, 16) is black");
        assert!(
            (ratio / expected - 1.0).abs() < 3.8e-6,
            "pixel ({x}, 16): red/green {ratio}, expected {expected}"
        );
    }
}
