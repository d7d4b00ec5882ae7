//! Punctual lights and the background through the whole pipeline: a glTF file written the way
//! Blender's exporter writes a point lamp loads and renders the same as an equivalent small
//! emitting sphere; an open plane under a constant background has radiance ρ·L under both
//! integrators; punctual lights reach the irradiance cache's gathers.
//!
//! Tolerances: means of K independent renders (different seeds) with their standard error,
//! compared within 5 standard errors of the difference (as tests/it/ic.rs does), plus the
//! systematic differences the scenes allow, each bounded beside its assertion; zero-variance
//! estimators against f32 rounding bounds.

use crate::support::Indirect;
use glam::{DVec3, Vec3};
use irr_geometry::{Geometry, TriangleMesh};
use irr_integrator::{Integrator, Material, PunctualLight, Scene};
use irr_render::{
    Camera, IcSettings, Image, IrradianceCacheIntegrator, LoadedScene, PathSettings, PathTracer,
    RenderSettings, build_cache, load_scene, render,
};
use serde_json::{Value, json};
use std::f64::consts::PI;
use std::path::Path;

/// A binary glTF: the 12-byte header, the JSON chunk padded with spaces and the BIN chunk
/// padded with zeros, each to 4 bytes (glTF 2.0 §4.4), as Blender writes a `.glb`.
fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut text = json.to_string().into_bytes();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let mut data = bin.to_vec();
    while !data.len().is_multiple_of(4) {
        data.push(0);
    }
    let total = 12 + 8 + text.len() + 8 + data.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((text.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(text);
    out.extend((data.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(data);
    out
}

/// Collects one buffer's views and accessors for meshes of positions, normals and u32 indices.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, data: Vec<u8>) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len()}));
        self.bytes.extend(data);
        self.views.len() - 1
    }

    /// A mesh's primitive JSON (POSITION, NORMAL, indices) with material `material`.
    fn primitive(&mut self, mesh: &TriangleMesh, material: usize) -> Value {
        let floats = |v: &[Vec3]| {
            v.iter()
                .flat_map(|p| p.to_array())
                .flat_map(f32::to_le_bytes)
                .collect()
        };
        let normals: Vec<Vec3> = match &mesh.normals {
            Some(n) => n.clone(),
            None => mesh.positions.iter().map(|p| p.normalize()).collect(),
        };
        let (lo, hi) = mesh.positions.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let p = self.view(floats(&mesh.positions));
        let n = self.view(floats(&normals));
        let i = self.view(
            mesh.indices
                .iter()
                .flatten()
                .flat_map(|i| i.to_le_bytes())
                .collect(),
        );
        let count = mesh.positions.len();
        self.accessors.push(
            json!({"bufferView": p, "componentType": 5126, "count": count,
            "type": "VEC3", "min": lo.to_array(), "max": hi.to_array()}),
        );
        self.accessors
            .push(json!({"bufferView": n, "componentType": 5126, "count": count, "type": "VEC3"}));
        self.accessors
            .push(json!({"bufferView": i, "componentType": 5125,
            "count": mesh.indices.len() * 3, "type": "SCALAR"}));
        let a = self.accessors.len();
        json!({"attributes": {"POSITION": a - 3, "NORMAL": a - 2}, "indices": a - 1, "material": material})
    }
}

/// A quad with corners in counter-clockwise order seen from the side it faces.
fn quad(corners: [Vec3; 4]) -> TriangleMesh {
    let n = (corners[1] - corners[0])
        .cross(corners[2] - corners[0])
        .normalize();
    TriangleMesh {
        positions: corners.to_vec(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: Some(vec![n; 4]),
        material_ids: vec![0; 2],
    }
}

/// A sphere of radius `r` at `c`: the octahedron subdivided `levels` times, vertices pushed to
/// the sphere, winding facing out.
fn sphere(c: Vec3, r: f32, levels: u32) -> TriangleMesh {
    let mut positions = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    for _ in 0..levels {
        let mut midpoints = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push(((positions[a as usize] + positions[b as usize]) * 0.5).normalize());
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let (ab, bc, ca) = (
                mid(a, b, &mut positions),
                mid(b, c, &mut positions),
                mid(c, a, &mut positions),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    let n = faces.len();
    TriangleMesh {
        normals: Some(positions.clone()),
        positions: positions.into_iter().map(|p| c + p * r).collect(),
        indices: faces,
        material_ids: vec![0; n],
    }
}

/// The smallest distance from the centre `c` to the plane of a facet of `mesh`.
fn inscribed_radius(mesh: &TriangleMesh, c: Vec3) -> f64 {
    mesh.indices
        .iter()
        .map(|t| {
            let p = t.map(|i| (mesh.positions[i as usize] - c).as_dvec3());
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            n.dot(p[0]).abs()
        })
        .fold(f64::INFINITY, f64::min)
}

const LAMP: Vec3 = Vec3::new(0.0, 1.0, 0.0);
const LAMP_INTENSITY: f32 = 10.0;
const ALBEDO: f32 = 0.8;

/// The room of the lamp test, as Blender exports it to `.glb`: a floor (4 m × 4 m at y = 0) and a
/// back wall (z = −2), grey (0.8), `doubleSided`, metallicFactor 0 and roughness 0.5 (a rough
/// dielectric, glossy: the lamp and its stand-in meet the same BRDF); a camera on a node; and either Blender's point lamp (`KHR_lights_punctual`
/// used and required, the light on a node with a rotation, as Blender orients its lamps) or, in
/// its place, an emissive sphere.
fn lamp_room(emitter: Option<(&TriangleMesh, f32)>) -> Vec<u8> {
    let mut bin = Bin::default();
    let floor = quad([
        Vec3::new(-2.0, 0.0, 2.0),
        Vec3::new(2.0, 0.0, 2.0),
        Vec3::new(2.0, 0.0, -2.0),
        Vec3::new(-2.0, 0.0, -2.0),
    ]);
    let wall = quad([
        Vec3::new(-2.0, 0.0, -2.0),
        Vec3::new(2.0, 0.0, -2.0),
        Vec3::new(2.0, 3.0, -2.0),
        Vec3::new(-2.0, 3.0, -2.0),
    ]);
    let mut meshes = vec![
        json!({"name": "Floor", "primitives": [bin.primitive(&floor, 0)]}),
        json!({"name": "Wall", "primitives": [bin.primitive(&wall, 0)]}),
    ];
    // The camera at (0, 0.6, 2.5), pitched down by atan(0.4/2.5) to look at (0, 0.2, 0): a
    // rotation about +x by −0.158 rad. Its view (yfov 0.5) reaches 5° above the horizontal at
    // most; the lamp is 9° above it, so neither the lamp nor the sphere is in the image.
    let pitch = -(0.4f32 / 2.5).atan();
    let mut nodes = vec![
        json!({"mesh": 0, "name": "Floor"}),
        json!({"mesh": 1, "name": "Wall"}),
        json!({"camera": 0, "name": "Camera", "translation": [0.0, 0.6, 2.5],
               "rotation": [(pitch / 2.0).sin(), 0.0, 0.0, (pitch / 2.0).cos()]}),
    ];
    let mut materials = vec![json!({"name": "Material", "doubleSided": true,
        "pbrMetallicRoughness": {"baseColorFactor": [ALBEDO, ALBEDO, ALBEDO, 1.0],
                                 "metallicFactor": 0.0, "roughnessFactor": 0.5}})];
    let mut root = json!({
        "asset": {"generator": "Khronos glTF Blender I/O v4.1.63", "version": "2.0"},
        "scene": 0,
        "cameras": [{"name": "Camera", "type": "perspective",
                     "perspective": {"aspectRatio": 1.0, "yfov": 0.5, "zfar": 100.0, "znear": 0.1}}],
    });
    match emitter {
        None => {
            root["extensionsUsed"] = json!(["KHR_lights_punctual"]);
            root["extensionsRequired"] = json!(["KHR_lights_punctual"]);
            root["extensions"] = json!({"KHR_lights_punctual": {"lights": [
                {"color": [1.0, 1.0, 1.0], "intensity": LAMP_INTENSITY, "type": "point", "name": "Point"}
            ]}});
            nodes.push(json!({"name": "Point", "translation": LAMP.to_array(),
                "rotation": [-0.70710677, 0.0, 0.0, 0.70710677],
                "extensions": {"KHR_lights_punctual": {"light": 0}}}));
        }
        Some((mesh, radiance)) => {
            root["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
            materials.push(json!({"name": "Emission",
                "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0},
                "emissiveFactor": [1.0, 1.0, 1.0],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": radiance}}}));
            meshes.push(json!({"name": "Sphere", "primitives": [bin.primitive(mesh, 1)]}));
            nodes.push(json!({"mesh": 2, "name": "Sphere"}));
        }
    }
    root["scenes"] = json!([{"name": "Scene", "nodes": (0..nodes.len()).collect::<Vec<_>>()}]);
    root["nodes"] = json!(nodes);
    root["meshes"] = json!(meshes);
    root["materials"] = json!(materials);
    root["accessors"] = json!(bin.accessors);
    root["bufferViews"] = json!(bin.views);
    root["buffers"] = json!([{"byteLength": bin.bytes.len()}]);
    glb(&root, &bin.bytes)
}

/// The mean over pixels and channels of each image, and the mean and standard error of those
/// K means.
fn mean_and_error(images: &[Image]) -> (f64, f64) {
    let means: Vec<f64> = images
        .iter()
        .map(|im| {
            im.pixels()
                .iter()
                .map(|p| f64::from(p.element_sum()))
                .sum::<f64>()
                / (3 * im.pixels().len()) as f64
        })
        .collect();
    let k = means.len() as f64;
    let mean = means.iter().sum::<f64>() / k;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (k - 1.0);
    (mean, (var / k).sqrt())
}

fn renders(
    loaded: &LoadedScene,
    integrator: &dyn Integrator,
    spp: u32,
    seeds: std::ops::Range<u64>,
) -> Vec<Image> {
    let camera = loaded.camera_for(16, 16);
    seeds
        .map(|seed| {
            let s = RenderSettings {
                width: 16,
                height: 16,
                spp,
                seed,
                threads: 0,
            };
            render(&loaded.scene, &camera, integrator, &s, false)
                .unwrap_or_else(|e| panic!("{e}"))
                .image
        })
        .collect()
}

/// A `.glb` written the way Blender's exporter writes a point lamp (`KHR_lights_punctual` in
/// `extensionsUsed` and `extensionsRequired`, the lamp on a rotated node) loads without a
/// warning, renders a lit image, and renders the same as the same room with the lamp replaced by
/// a small emitting sphere of equal intensity.
///
/// The equivalent sphere: a sphere of radius r and radiance L sends intensity π r² L in every
/// direction, and a surface point that sees all of it above its horizon receives exactly
/// E = π L (r/d)² cos θ, as from a point light of I = π r² L. The rendered sphere is a polyhedron
/// inscribed in the sphere of radius r, containing the sphere of radius h (its nearest facet
/// plane); the cone a convex body subtends grows with the body, so its irradiance lies between
/// those two spheres': E ∈ [h², r²]·π L cos θ / d². With L = I / (π r_m²), r_m² = (r² + h²)/2,
/// the direct light is within ±(r² − h²)/(r² + h²) of the point light's, everywhere.
///
/// The sphere also hides what lies behind it from the surfaces (the lamp hides nothing). At a
/// receiver x, at distance ≥ d₀ from the sphere's centre, it covers a projected solid angle of
/// at most π (r/(d₀ − r))², through which x would otherwise receive reflected radiance at most
/// L_max = B_max/π, B_max ≤ ρ E_max/(1 − ρ) (each bounce at most ρ of the most irradiance
/// E_max = I/d₀² that the lamp gives any point, summed). So the outgoing radiance changes by at
/// most (ρ/π)·π (r/(d₀ − r))²·L_max, at every pixel.
#[test]
fn a_blender_point_lamp_renders_like_a_small_emitting_sphere() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let lamp_path = dir.path().join("lamp.glb");
    std::fs::write(&lamp_path, lamp_room(None)).unwrap_or_else(|e| panic!("{e}"));
    let lamp = load_scene(&lamp_path).unwrap_or_else(|e| panic!("{e}"));
    assert!(lamp.warnings.is_empty(), "{:?}", lamp.warnings);
    assert!(lamp.camera.is_some());
    assert_eq!(lamp.scene.lights().punctual_count(), 1);

    let r = 0.02f32;
    let mesh = sphere(LAMP, r, 4);
    let h = inscribed_radius(&mesh, LAMP);
    let (r2, h2) = (f64::from(r).powi(2), h * h);
    let radiance = f64::from(LAMP_INTENSITY) / (PI * 0.5 * (r2 + h2));
    let sphere_path = dir.path().join("sphere.glb");
    std::fs::write(&sphere_path, lamp_room(Some((&mesh, radiance as f32))))
        .unwrap_or_else(|e| panic!("{e}"));
    let ball = load_scene(&sphere_path).unwrap_or_else(|e| panic!("{e}"));
    assert!(ball.warnings.is_empty(), "{:?}", ball.warnings);

    let pt = PathTracer::new(PathSettings::default());
    let k = 4;
    let (m_lamp, se_lamp) = mean_and_error(&renders(&lamp, &pt, 64, 300..300 + k));
    let (m_ball, se_ball) = mean_and_error(&renders(&ball, &pt, 256, 400..400 + k));
    let tessellation = (r2 - h2) / (r2 + h2) * m_ball;
    let rho = f64::from(ALBEDO);
    let d0 = 1.0; // The floor, 1 m below; the wall is 2 m away.
    let b_max = rho * f64::from(LAMP_INTENSITY) / (d0 * d0) / (1.0 - rho);
    let hidden = rho / PI * PI * (f64::from(r) / (d0 - f64::from(r))).powi(2) * b_max / PI;
    let tol = 5.0 * (se_lamp * se_lamp + se_ball * se_ball).sqrt() + tessellation + hidden;
    println!(
        "lamp {m_lamp:.5} ± {se_lamp:.1e}, sphere {m_ball:.5} ± {se_ball:.1e}: difference {:.1e}, \
         tolerance {tol:.1e} (tessellation {tessellation:.1e}, hidden {hidden:.1e})",
        m_lamp - m_ball
    );
    assert!(m_lamp > 0.05, "the lamp lights nothing: {m_lamp}");
    assert!(
        (m_lamp - m_ball).abs() < tol,
        "lamp {m_lamp} vs sphere {m_ball} (tolerance {tol})"
    );
}

/// An open plane of albedo ρ under a constant background L, through the whole pipeline (cache
/// built by `build_cache`, images by `render`), from a camera that sees only the plane: every
/// pixel is ρL. The path tracer's every sample is ρL to one rounding (its cosine sample always
/// escapes, with weight 1); the irradiance cache's records each hold E = Σ over M·N cells of
/// (π/(M·N))·L, πL to the rounding of that sum (M·N = 192 terms, at most 192·2⁻²⁴ ≈ 1.2e-5
/// relative), their gradients vanish (no hit at any distance; the plane is flat), and the
/// weighted mean of equal values is that value to the f64 rounding of the weights: 1e-4
/// relative leaves a factor 8. A camera that sees only sky gets L exactly, in both.
#[test]
fn an_open_plane_under_a_constant_background_has_radiance_rho_l() {
    let rho = Vec3::new(0.9, 0.7, 0.5);
    let background = Vec3::new(0.4, 0.8, 1.6);
    let plane = quad([
        Vec3::new(-5.0, 0.0, 5.0),
        Vec3::new(5.0, 0.0, 5.0),
        Vec3::new(5.0, 0.0, -5.0),
        Vec3::new(-5.0, 0.0, -5.0),
    ]);
    let geometry = Geometry::build(&[plane]).unwrap_or_else(|e| panic!("{e}"));
    let scene = Scene::new(geometry, vec![Material::diffuse(rho)])
        .and_then(|s| s.with_background(background))
        .unwrap_or_else(|e| panic!("{e}"));
    let down = Camera::look_at(Vec3::new(0.3, 2.0, 0.5), Vec3::ZERO, Vec3::Z, 0.6)
        .unwrap_or_else(|| panic!("camera"));
    let up = Camera::look_at(
        Vec3::new(0.3, 2.0, 0.5),
        Vec3::new(0.0, 4.0, 0.0),
        Vec3::Z,
        0.6,
    )
    .unwrap_or_else(|| panic!("camera"));
    let settings = RenderSettings {
        width: 16,
        height: 16,
        spp: 4,
        seed: 9,
        threads: 0,
    };
    let expected = (rho * background).as_dvec3();
    let check = |image: &Image, want: DVec3, rel: f64, what: &str| {
        for p in image.pixels() {
            let d = (p.as_dvec3() - want).abs();
            assert!(
                d.max_element() <= rel * want.max_element(),
                "{what}: pixel {p} vs {want}"
            );
        }
    };
    let pt = PathTracer::new(PathSettings::default());
    for (camera, want, rel, what) in [
        (&down, expected, 1e-6, "plane"),
        (&up, background.as_dvec3(), 0.0, "sky"),
    ] {
        let image = render(&scene, camera, &pt, &settings, false)
            .unwrap_or_else(|e| panic!("{e}"))
            .image;
        check(&image, want, rel, &format!("path tracer, {what}"));
        let ic_settings = IcSettings {
            strata_m: 8,
            strata_n: 24,
            ..IcSettings::default()
        };
        let mut ic = IrradianceCacheIntegrator::new(ic_settings).unwrap_or_else(|e| panic!("{e}"));
        ic.preprocess(&scene);
        build_cache(&scene, camera, &mut ic, &settings, false, false)
            .unwrap_or_else(|e| panic!("{e}"));
        let image = render(&scene, camera, &ic, &settings, false)
            .unwrap_or_else(|e| panic!("{e}"))
            .image;
        let rel = if rel == 0.0 { 0.0 } else { 1e-4 };
        check(&image, want, rel, &format!("irradiance cache, {what}"));
        if what == "plane" {
            assert!(
                ic.cache(0).is_some_and(|c| !c.is_empty()),
                "no record was built"
            );
        }
    }
}

/// Punctual lights reach the irradiance cache's gathers: inside a closed diffuse sphere lit
/// only by a point light and a spot light, all the indirect light is their light reflected
/// (gathered from the records' rays' hits by NEE, `sample_light`). The cache's indirect image
/// agrees with the path tracer's (K = 4 independent renders each, 5 standard errors of the
/// difference, as tests/it/ic.rs's halo test), and is far from zero: without the lights in the
/// gathers it would be 0. (On a true sphere both would be (ρ/π)·ρ/(1 − ρ)·Φ/(4πR²) everywhere,
/// Φ the lights' flux, wherever the light lands: irr-integrator's `point_light_in_a_closed_sphere`
/// derives it and checks the path tracer against it on a tessellated sphere; the figure is
/// printed for reference.)
#[test]
fn punctual_lights_reach_the_cache_gathers() {
    let rho = 0.5f32;
    let ball = sphere(Vec3::ZERO, 1.0, 4);
    let area: f64 = ball
        .indices
        .iter()
        .map(|t| {
            let p = t.map(|i| ball.positions[i as usize].as_dvec3());
            0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
        })
        .sum();
    let geometry = Geometry::build(&[ball]).unwrap_or_else(|e| panic!("{e}"));
    let point = PunctualLight::point(Vec3::new(0.2, -0.1, 0.15), Vec3::splat(1.0));
    let spot = PunctualLight::spot(
        Vec3::new(-0.3, 0.2, 0.0),
        -Vec3::Y,
        Vec3::splat(2.0),
        0.3,
        0.6,
    );
    let scene = Scene::new(geometry, vec![Material::diffuse(Vec3::splat(rho))])
        .and_then(|s| s.with_lights(vec![point, spot]))
        .unwrap_or_else(|e| panic!("{e}"));
    let flux = point.power(1.0) + spot.power(1.0);
    let rho = f64::from(rho);
    let known = rho / PI * rho / (1.0 - rho) * flux / area;
    let camera = Camera::look_at(
        Vec3::new(0.0, 0.0, 0.6),
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::Y,
        1.2,
    )
    .unwrap_or_else(|| panic!("camera"));
    let pt = PathTracer::new(PathSettings::default());
    let settings = |seed, spp| RenderSettings {
        width: 16,
        height: 16,
        spp,
        seed,
        threads: 0,
    };
    let k = 4;
    let path_images: Vec<Image> = (0..k)
        .map(|i| {
            let view = Indirect {
                path: Some(&pt),
                ic: None,
            };
            render(&scene, &camera, &view, &settings(500 + i, 64), false)
                .unwrap_or_else(|e| panic!("{e}"))
                .image
        })
        .collect();
    let ic_images: Vec<Image> = (0..k)
        .map(|i| {
            let s = settings(600 + i, 4);
            let ic_settings = IcSettings {
                strata_m: 8,
                strata_n: 32,
                ..IcSettings::default()
            };
            let mut ic =
                IrradianceCacheIntegrator::new(ic_settings).unwrap_or_else(|e| panic!("{e}"));
            ic.preprocess(&scene);
            build_cache(&scene, &camera, &mut ic, &s, false, false)
                .unwrap_or_else(|e| panic!("{e}"));
            let view = Indirect {
                path: None,
                ic: Some(&ic),
            };
            render(&scene, &camera, &view, &s, false)
                .unwrap_or_else(|e| panic!("{e}"))
                .image
        })
        .collect();
    let (m_pt, se_pt) = mean_and_error(&path_images);
    let (m_ic, se_ic) = mean_and_error(&ic_images);
    let tol = 5.0 * (se_pt * se_pt + se_ic * se_ic).sqrt();
    println!(
        "indirect: path {m_pt:.5} ± {se_pt:.1e}, cache {m_ic:.5} ± {se_ic:.1e}, sphere's known answer {known:.5}"
    );
    assert!(
        (m_ic - m_pt).abs() < tol,
        "cache {m_ic} vs path {m_pt} (tolerance {tol:.2e})"
    );
    // Lit at all: far from zero beyond the noise (the known answer above is about 0.16).
    assert!(
        m_ic > 10.0 * se_ic,
        "the cache's indirect light is {m_ic} ± {se_ic}"
    );
}

/// The default scene has no punctual light: loading it is unchanged (its triangles are its
/// only emitters).
#[test]
fn the_cornell_box_has_no_punctual_light() {
    let loaded =
        load_scene(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/cornell-box.gltf"))
            .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(loaded.scene.lights().punctual_count(), 0);
    assert_eq!(loaded.scene.background(), Vec3::ZERO);
}

/// A file without a camera is framed by its core bounds (irr-geometry's
/// `Geometry::core_bounds`): the lamp room's floor and wall with a 10 km ground 100 m below
/// them loads with the room's bounds, so the default view frames the room as it frames the
/// room alone (where the whole box would leave it a dot 60 m across in a view 17 km away); a
/// directional light over both keeps the same share of the light samples (tests/it/ic.rs,
/// `a_far_black_ground_plane_changes_no_pixel`).
#[test]
fn a_default_view_frames_the_room_not_its_far_ground() {
    let load = |ground: bool| {
        let mut bin = Bin::default();
        let mut meshes = vec![
            quad([
                Vec3::new(-2.0, 0.0, 2.0),
                Vec3::new(2.0, 0.0, 2.0),
                Vec3::new(2.0, 0.0, -2.0),
                Vec3::new(-2.0, 0.0, -2.0),
            ]),
            quad([
                Vec3::new(-2.0, 0.0, -2.0),
                Vec3::new(2.0, 0.0, -2.0),
                Vec3::new(2.0, 3.0, -2.0),
                Vec3::new(-2.0, 3.0, -2.0),
            ]),
        ];
        if ground {
            meshes.push(quad([
                Vec3::new(-5e3, -100.0, 5e3),
                Vec3::new(5e3, -100.0, 5e3),
                Vec3::new(5e3, -100.0, -5e3),
                Vec3::new(-5e3, -100.0, -5e3),
            ]));
        }
        let meshes: Vec<Value> = meshes
            .iter()
            .map(|m| json!({"primitives": [bin.primitive(m, 0)]}))
            .collect();
        let root = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": (0..meshes.len()).collect::<Vec<_>>()}],
            "nodes": (0..meshes.len()).map(|m| json!({"mesh": m})).collect::<Vec<_>>(),
            "meshes": meshes,
            "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}}],
            "accessors": bin.accessors,
            "bufferViews": bin.views,
            "buffers": [{"byteLength": bin.bytes.len()}],
        });
        let dir = crate::support::temp();
        let path = dir
            .path()
            .join(if ground { "ground.glb" } else { "room.glb" });
        crate::support::write(&path, glb(&root, &bin.bytes));
        load_scene(&path).unwrap_or_else(|e| panic!("{e}"))
    };
    let (room, far) = (load(false), load(true));
    assert_eq!(far.bounds, room.bounds, "the far ground's bounds");
    assert_eq!(
        room.bounds,
        (Vec3::new(-2.0, 0.0, -2.0), Vec3::new(2.0, 3.0, 2.0)),
        "the room's bounds"
    );
    assert_eq!(far.camera_for(64, 48), room.camera_for(64, 48));
}
