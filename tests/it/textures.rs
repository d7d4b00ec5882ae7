//! Base-colour and emissive textures through the whole pipeline: glTF files written here (a
//! `.gltf`, its `.bin` and its PNGs side by side, as Blender's "glTF Separate" export lays them
//! out), loaded, rendered, and checked against known answers.
//!
//! The known-answer scene: a quad inside a closed box whose black walls all emit Le from both
//! faces. Every direction above the quad meets a wall, so the irradiance on it is E = π·Le, and
//! nothing else reflects (the walls are black, the quad cannot see itself): the quad's radiance
//! is exactly ρ(x)/π·E = ρ(x)·Le, with ρ(x) the albedo factor × the texture at x. The camera
//! looks straight down at the quad and frames exactly it, so pixel footprints are squares of the
//! quad whose texture coordinates are known in closed form.
//!
//! Tolerances: a pixel's mean is checked against its known value within 5 standard errors of
//! its own samples (a correct estimator fails with probability 6·10⁻⁷ per channel: the normal
//! tail, and 64 or more samples per mean make the mean close to normal; the seed is fixed, so
//! the outcome is deterministic), plus f32 rounding.

use crate::support::write;
use glam::{Vec2, Vec3};
use irr_geometry::Ray;
use irr_integrator::ic::direct_nee;
use irr_integrator::path::ShadingPoint;
use irr_integrator::{Integrator, PathSettings, PathTracer, Radiance, RayCounter, Scene};
use irr_render::{
    IcSettings, IrradianceCacheIntegrator, LoadedScene, RenderSettings, build_cache, load_scene,
    pixel_samples,
};
use irr_sampling::SampleKey;
use irr_sampling::rng::Dimensions;
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// The sRGB EOTF (IEC 61966-2-1), written out again here as the reference.
fn lin(code: u8) -> f32 {
    let c = f64::from(code) / 255.0;
    (if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }) as f32
}

fn lin3(c: [u8; 3]) -> Vec3 {
    Vec3::new(lin(c[0]), lin(c[1]), lin(c[2]))
}

/// An 8-bit RGB PNG of `texels` (rows from the top).
pub(crate) fn png(width: u32, height: u32, texels: &[[u8; 3]]) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut e = png::Encoder::new(&mut out, width, height);
        e.set_color(png::ColorType::Rgb);
        e.set_depth(png::BitDepth::Eight);
        let mut w = e.write_header().unwrap_or_else(|e| panic!("{e}"));
        w.write_image_data(texels.as_flattened())
            .unwrap_or_else(|e| panic!("{e}"));
    }
    out
}

/// A quad: its four corners (counter-clockwise seen from the front), its normal, and the
/// texture coordinates of its corners.
pub(crate) type Quad = ([[f32; 3]; 4], [f32; 3], [[f32; 2]; 4]);

/// A hostile case: its name, the image file, an edit of the JSON, and what the error must say.
type Case = (
    &'static str,
    Vec<u8>,
    Box<dyn Fn(&mut Value)>,
    &'static [&'static str],
);

/// Builds a glTF's binary buffer, views and accessors the way Blender's exporter does (one
/// view per accessor, `target` set, `min`/`max` on positions).
#[derive(Default)]
pub(crate) struct Builder {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    fn add(&mut self, bytes: &[u8], target: u32, accessor: Value) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(),
                               "byteLength": bytes.len(), "target": target}));
        self.bin.extend_from_slice(bytes);
        let mut a = accessor;
        a["bufferView"] = json!(self.views.len() - 1);
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    pub(crate) fn floats<const N: usize>(
        &mut self,
        v: &[[f32; N]],
        kind: &str,
        bounds: bool,
    ) -> usize {
        let bytes: Vec<u8> = v
            .as_flattened()
            .iter()
            .flat_map(|f| f.to_le_bytes())
            .collect();
        let mut a = json!({"componentType": 5126, "count": v.len(), "type": kind});
        if bounds {
            let lo: Vec<f32> = (0..N)
                .map(|k| v.iter().map(|p| p[k]).fold(f32::INFINITY, f32::min))
                .collect();
            let hi: Vec<f32> = (0..N)
                .map(|k| v.iter().map(|p| p[k]).fold(f32::NEG_INFINITY, f32::max))
                .collect();
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.add(&bytes, 34962, a)
    }

    pub(crate) fn indices(&mut self, v: &[u16]) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|i| i.to_le_bytes()).collect();
        self.add(
            &bytes,
            34963,
            json!({"componentType": 5123, "count": v.len(), "type": "SCALAR"}),
        )
    }

    /// A mesh primitive from quads, each given by its four corners (counter-clockwise seen from
    /// the front), a normal and the texture coordinates of its corners.
    pub(crate) fn quads(&mut self, quads: &[Quad], material: usize) -> Value {
        let (mut p, mut n, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (corners, normal, coords) in quads {
            let base = p.len() as u16;
            p.extend_from_slice(corners);
            n.extend_from_slice(&[*normal; 4]);
            uv.extend_from_slice(coords);
            idx.extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
        }
        let (p, n, uv, idx) = (
            self.floats(&p, "VEC3", true),
            self.floats(&n, "VEC3", false),
            self.floats(&uv, "VEC2", false),
            self.indices(&idx),
        );
        json!({"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": uv},
               "indices": idx, "material": material})
    }

    /// Writes `dir/name.gltf` and `dir/name.bin`, completing `doc` with the buffer.
    pub(crate) fn finish(self, dir: &Path, name: &str, mut doc: Value) -> PathBuf {
        write(&dir.join(format!("{name}.bin")), &self.bin);
        doc["buffers"] = json!([{"byteLength": self.bin.len(), "uri": format!("{name}.bin")}]);
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
        let path = dir.join(format!("{name}.gltf"));
        write(
            &path,
            serde_json::to_vec_pretty(&doc).unwrap_or_else(|e| panic!("{e}")),
        );
        path
    }
}

/// The six inward faces of the cube [−s, s]³ (the walls are double-sided, so the winding only
/// matters for the normals Blender would write).
pub(crate) fn cube(s: f32) -> Vec<Quad> {
    let mut faces = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: f32, b: f32| {
                let mut c = [0.0; 3];
                c[axis] = sign * s;
                c[u] = a * s;
                c[v] = b * s;
                c
            };
            let mut normal = [0.0; 3];
            normal[axis] = -sign;
            faces.push((
                [
                    corner(-1.0, -1.0),
                    corner(1.0, -1.0),
                    corner(1.0, 1.0),
                    corner(-1.0, 1.0),
                ],
                normal,
                [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            ));
        }
    }
    faces
}

/// The quad [−½, ½]² at z = 0 facing +z, with texture coordinates u = 3(x + ½) − 1 and
/// v = 3(½ − y) − 1: three periods of the texture, from −1 to 2, v growing downwards as image
/// rows do.
pub(crate) const QUAD: Quad = (
    [
        [-0.5, -0.5, 0.0],
        [0.5, -0.5, 0.0],
        [0.5, 0.5, 0.0],
        [-0.5, 0.5, 0.0],
    ],
    [0.0, 0.0, 1.0],
    [[-1.0, 2.0], [2.0, 2.0], [2.0, -1.0], [-1.0, -1.0]],
);

/// The camera 1 m above the quad's centre, looking down −z (glTF's camera axis), with
/// yfov = 2·atan(½): it frames exactly the quad.
pub(crate) fn camera_node() -> (Value, Value) {
    (
        json!({"name": "Camera", "camera": 0, "translation": [0.0, 0.0, 1.0]}),
        json!([{"name": "Camera", "type": "perspective",
                "perspective": {"aspectRatio": 1.0, "yfov": 2.0 * 0.5f64.atan(),
                                "znear": 0.01, "zfar": 100.0}}]),
    )
}

/// The known-answer scene as Blender's exporter writes it: the textured quad (`quad_material`
/// is its material JSON; texture 0 is `texture.png` with `sampler`) in a box of black walls
/// emitting 1 from both faces (as Blender writes an emission shader: emissiveFactor with
/// KHR_materials_emissive_strength).
pub(crate) fn furnace_scene(
    dir: &Path,
    name: &str,
    texture: &[u8],
    sampler: Value,
    quad_material: Value,
) -> PathBuf {
    write(&dir.join("texture.png"), texture);
    let mut b = Builder::default();
    let plane = b.quads(&[QUAD], 0);
    let walls = b.quads(&cube(2.0), 1);
    let (camera, cameras) = camera_node();
    b.finish(
        dir,
        name,
        json!({
            "asset": {"generator": "Khronos glTF Blender I/O v4.2.69", "version": "2.0"},
            "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_specular"],
            "scene": 0,
            "scenes": [{"name": "Scene", "nodes": [0, 1, 2]}],
            "nodes": [{"mesh": 0, "name": "Plane"}, {"mesh": 1, "name": "Walls"}, camera],
            "cameras": cameras,
            "materials": [
                quad_material,
                {"name": "Glow", "doubleSided": true, "emissiveFactor": [1.0, 1.0, 1.0],
                 "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 1.0},
                                "KHR_materials_specular": {"specularFactor": 0.0}},
                 "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0],
                                          "metallicFactor": 0.0, "roughnessFactor": 0.5}}
            ],
            "meshes": [{"name": "Plane", "primitives": [plane]},
                       {"name": "Walls", "primitives": [walls]}],
            "textures": [{"sampler": 0, "source": 0}],
            "images": [{"mimeType": "image/png", "name": "texture", "uri": "texture.png"}],
            "samplers": [sampler],
        }),
    )
}

pub(crate) fn load(path: &Path) -> LoadedScene {
    load_scene(path).unwrap_or_else(|e| panic!("{e}"))
}

pub(crate) const SIZE: u32 = 24;

pub(crate) fn settings(spp: u32) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp,
        seed: 5,
        threads: 0,
    }
}

/// Checks that pixel (x, y)'s samples have mean `expected` within 5 of their standard errors
/// plus f32 rounding (16 roundings of 2⁻²⁴ relative: the estimate multiplies a handful of f32
/// factors of order 1).
fn assert_pixel(
    what: &str,
    loaded: &LoadedScene,
    s: &RenderSettings,
    x: u32,
    y: u32,
    expected: Vec3,
) {
    let camera = loaded.camera_for(s.width, s.height);
    let pt = PathTracer::new(PathSettings::default());
    let samples =
        pixel_samples(&loaded.scene, &camera, &pt, s, x, y).unwrap_or_else(|e| panic!("{e}"));
    let n = samples.len() as f64;
    for c in 0..3 {
        let mean = samples.iter().map(|l| f64::from(l[c])).sum::<f64>() / n;
        let var = samples
            .iter()
            .map(|l| (f64::from(l[c]) - mean).powi(2))
            .sum::<f64>()
            / (n - 1.0);
        let e = f64::from(expected[c]);
        let tolerance = 5.0 * (var / n).sqrt() + 16.0 * 2f64.powi(-24) * e;
        assert!(
            (mean - e).abs() <= tolerance,
            "{what}: pixel ({x}, {y}) channel {c}: mean {mean} differs from {e} by more than {tolerance:e}"
        );
    }
}

/// The texture of the known-answer tests: 2×2 texels of distinct colours, one of them mid-grey
/// (code 128, linear 0.2158…) so the sRGB conversion is exercised.
const TEXELS: [[u8; 3]; 4] = [[255, 0, 0], [0, 255, 0], [0, 0, 255], [128, 128, 128]];

/// The albedo factor of the known-answer quad: it multiplies the texture per channel.
const FACTOR: [f32; 3] = [1.0, 0.5, 1.0];

fn wrap_index(mode: u32, i: i64, n: i64) -> i64 {
    match mode {
        33071 => i.clamp(0, n - 1),
        33648 => {
            let m = i.rem_euclid(2 * n);
            if m < n { m } else { 2 * n - 1 - m }
        }
        _ => i.rem_euclid(n),
    }
}

/// The reference texture lookup (OpenGL 4.6 §8.14.2), independent of irr's.
fn reference(mode: u32, linear: bool, uv: Vec2) -> Vec3 {
    let texel = |i: i64, j: i64| {
        lin3(TEXELS[(wrap_index(mode, j, 2) * 2 + wrap_index(mode, i, 2)) as usize])
    };
    if !linear {
        return texel((uv.x * 2.0).floor() as i64, (uv.y * 2.0).floor() as i64);
    }
    let (x, y) = (uv.x * 2.0 - 0.5, uv.y * 2.0 - 0.5);
    let (i, j) = (x.floor() as i64, y.floor() as i64);
    let (fx, fy) = (x - x.floor(), y - y.floor());
    let row = |j: i64| texel(i, j) * (1.0 - fx) + texel(i + 1, j) * fx;
    row(j) * (1.0 - fy) + row(j + 1) * fy
}

/// The texture coordinate at the centre of pixel (x, y) (see `QUAD` and `camera_node`).
fn pixel_uv(x: u32, y: u32) -> Vec2 {
    Vec2::new(
        3.0 * (x as f32 + 0.5) / SIZE as f32 - 1.0,
        3.0 * (y as f32 + 0.5) / SIZE as f32 - 1.0,
    )
}

/// A checkerboard-like texture on the quad, every wrap mode with nearest and linear
/// filtering, at pixels over the whole of u, v ∈ [−1, 2]: each pixel's value is
/// ρ(x)·Le = factor × texel (× Le = 1).
///
/// A texel spans 1/6 of the quad, 4 pixels: with nearest filtering, the pixels not next to a
/// texel edge (x mod 4 ∈ {1, 2}) see one texel only. With linear filtering, the texture is
/// bilinear between texel centres (edges at x ≡ 2 mod 4), so over a pixel that does not straddle
/// one (x mod 4 ∈ {3, 0}) its mean is its value at the pixel's centre: a bilinear function
/// a + bu + cv + d·uv averages to its centre value over a rectangle.
#[test]
fn checkerboard_pixels_follow_filter_and_wrap_modes() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let texture = png(2, 2, &TEXELS);
    let s = settings(256);
    for (mode, mode_name) in [(10497, "repeat"), (33071, "clamp"), (33648, "mirrored")] {
        for (filter, linear) in [(9728, false), (9729, true)] {
            let name = format!("{mode_name}-{}", if linear { "linear" } else { "nearest" });
            let path = furnace_scene(
                dir.path(),
                &name,
                &texture,
                json!({"magFilter": filter, "wrapS": mode, "wrapT": mode}),
                json!({"name": "Checker", "doubleSided": true,
                       "pbrMetallicRoughness": {"baseColorFactor": [FACTOR[0], FACTOR[1], FACTOR[2], 1.0],
                                                "baseColorTexture": {"index": 0, "texCoord": 0},
                                                "metallicFactor": 0.0},
                       "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}),
            );
            let loaded = load(&path);
            let inside: &[u32] = if linear { &[0, 3] } else { &[1, 2] };
            // One pixel per texel (or bilinear cell) of the 6×6 the quad shows.
            for block_y in 0..6 {
                for block_x in 0..6 {
                    let (x, y) = (
                        4 * block_x + inside[block_x as usize % 2],
                        4 * block_y + inside[block_y as usize % 2],
                    );
                    let expected =
                        Vec3::from_array(FACTOR) * reference(mode, linear, pixel_uv(x, y));
                    assert_pixel(&name, &loaded, &s, x, y, expected);
                }
            }
        }
    }
}

/// A file laid out as Blender's glTF exporter writes a textured material (images with `uri`
/// and `mimeType`, a sampler with LINEAR / LINEAR_MIPMAP_LINEAR, `baseColorTexture` with
/// `index` and `texCoord`, a `.bin` beside it) loads with no texture ignored, and renders in
/// the texture's colour.
#[test]
fn a_blender_style_textured_file_renders_in_the_texture_colour() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let colour = [200u8, 100, 50];
    let path = furnace_scene(
        dir.path(),
        "blender",
        &png(4, 4, &[colour; 16]),
        json!({"magFilter": 9729, "minFilter": 9987}),
        json!({"name": "Wood", "doubleSided": true,
               "pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 0},
                                        "metallicFactor": 0.0, "roughnessFactor": 0.5},
               "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}),
    );
    let loaded = load(&path);
    let features: Vec<&str> = loaded.warnings.iter().map(|w| w.feature.as_str()).collect();
    assert_eq!(features, ["min-filter"], "{:?}", loaded.warnings);
    let s = settings(64);
    for (x, y) in [(0, 0), (5, 17), (12, 12), (23, 23)] {
        assert_pixel("blender", &loaded, &s, x, y, lin3(colour));
    }
}

/// The hostile inputs of a textured file: each refused with one line naming the scene file and
/// the image or texture, never a panic.
#[test]
fn hostile_textures_are_refused_with_clear_errors() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let scene_dir = dir.path().join("scene");
    std::fs::create_dir(&scene_dir).unwrap_or_else(|e| panic!("{e}"));
    let good = png(2, 2, &TEXELS);
    write(&dir.path().join("outside.png"), &good);
    // A PNG whose header claims 100000×100000 texels (only IHDR's width and height changed:
    // irr reads them before the CRC matters).
    let mut huge = good.clone();
    huge[16..20].copy_from_slice(&100_000u32.to_be_bytes());
    huge[20..24].copy_from_slice(&100_000u32.to_be_bytes());
    let truncated = good[..good.len() - 20].to_vec();
    let material = json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}});
    let cases: [Case; 5] = [
        (
            "huge",
            huge,
            Box::new(|_| {}),
            &[
                "image 0 \"texture\"",
                "texture.png",
                "100000×100000",
                "16384",
            ],
        ),
        (
            "truncated",
            truncated,
            Box::new(|_| {}),
            &["image 0 \"texture\"", "PNG"],
        ),
        (
            "outside",
            good.clone(),
            Box::new(|j| j["images"][0]["uri"] = json!("../outside.png")),
            &["image 0", "outside the folder irr reads images from"],
        ),
        (
            "escaped",
            good.clone(),
            Box::new(|j| j["images"][0]["uri"] = json!("%2e%2e/outside.png")),
            &["image 0", "outside the folder"],
        ),
        (
            "index",
            good.clone(),
            Box::new(|j| {
                j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = json!(3)
            }),
            &["baseColorTexture.index", "Index out of bounds"],
        ),
    ];
    for (name, image, edit, needles) in cases {
        let path = furnace_scene(&scene_dir, name, &image, json!({}), material.clone());
        let mut doc: Value =
            serde_json::from_slice(&std::fs::read(&path).unwrap_or_else(|e| panic!("{e}")))
                .unwrap_or_else(|e| panic!("{e}"));
        edit(&mut doc);
        write(
            &path,
            serde_json::to_vec(&doc).unwrap_or_else(|e| panic!("{e}")),
        );
        let e = match std::panic::catch_unwind(|| load_scene(&path)) {
            Err(_) => panic!("{name}: the loader panicked"),
            Ok(Ok(_)) => panic!("{name}: loaded"),
            Ok(Err(e)) => e.to_string(),
        };
        assert!(!e.contains('\n'), "{name}: {e}");
        assert!(e.contains(&format!("{name}.gltf")), "{name}: {e}");
        for n in needles {
            assert!(e.contains(n), "{name}: no '{n}' in: {e}");
        }
    }
}

/// Irradiance at the origin of a plane from a uniform polygon of radiance `l` with vertices `v`
/// (relative to the point, the plane's normal +z): Lambert's formula E = (L/2)·Σᵢ θᵢ·(Γᵢ·n),
/// θᵢ the angle edge i subtends and Γᵢ the unit normal of the plane through the point and edge i.
fn polygon_irradiance(v: &[glam::DVec3], l: f64) -> f64 {
    let mut sum = 0.0;
    for i in 0..v.len() {
        let a = v[i].normalize();
        let b = v[(i + 1) % v.len()].normalize();
        sum += a.dot(b).clamp(-1.0, 1.0).acos() * a.cross(b).normalize().z;
    }
    0.5 * l * sum.abs()
}

/// An emitter textured half white, half black lights a plane as its white half alone would:
/// at points under its middle, as a uniform emitter of half the radiance would.
///
/// Scene: a receiver quad (albedo ρ = 0.5) at z = 0, and 1 m above it an emitter [−½, ½]²
/// (black, double-sided) with emissiveFactor 2 × a 2×1 nearest-filtered texture, white on the
/// left (x < 0), black on the right. Nothing else reflects (the emitter is black, the receiver
/// is flat), so the receiver's radiance is (ρ/π)·E with E the irradiance from the white
/// rectangle [−½, 0] × [−½, ½] of radiance 2 (Lambert's polygon formula), which at x = 0 equals
/// that of the whole square of radiance 1. The light sampler chooses the emitter by its mean
/// (half the factor) and reads the texture at the sampled point; the BSDF-sampled rays read it
/// where they hit. Both the path tracer (NEE and BSDF sampling, MIS) and NEE alone (the
/// irradiance cache's direct light) must be unbiased.
#[test]
fn a_half_black_emissive_texture_emits_half() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let rho = 0.5f64;
    let make = |name: &str, textured: bool| {
        write(
            &dir.path().join("half.png"),
            png(2, 1, &[[255, 255, 255], [0, 0, 0]]),
        );
        let mut b = Builder::default();
        let receiver = b.quads(
            &[(
                [
                    [-5.0, -5.0, 0.0],
                    [5.0, -5.0, 0.0],
                    [5.0, 5.0, 0.0],
                    [-5.0, 5.0, 0.0],
                ],
                [0.0, 0.0, 1.0],
                [[0.0; 2]; 4],
            )],
            0,
        );
        let emitter = b.quads(
            &[(
                [
                    [-0.5, -0.5, 1.0],
                    [0.5, -0.5, 1.0],
                    [0.5, 0.5, 1.0],
                    [-0.5, 0.5, 1.0],
                ],
                [0.0, 0.0, -1.0],
                [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]],
            )],
            1,
        );
        let light = if textured {
            json!({"doubleSided": true, "emissiveFactor": [1.0, 1.0, 1.0],
                   "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2.0},
                                  "KHR_materials_specular": {"specularFactor": 0.0}},
                   "emissiveTexture": {"index": 0},
                   "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0}})
        } else {
            json!({"doubleSided": true, "emissiveFactor": [1.0, 1.0, 1.0],
                   "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}},
                   "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0}})
        };
        let path = b.finish(
            dir.path(),
            name,
            json!({
                "asset": {"version": "2.0"},
                "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_specular"],
                "scene": 0, "scenes": [{"nodes": [0, 1]}],
                "nodes": [{"mesh": 0}, {"mesh": 1}],
                "materials": [
                    {"pbrMetallicRoughness": {"baseColorFactor": [rho, rho, rho, 1.0], "metallicFactor": 0.0},
                     "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}},
                    light
                ],
                "meshes": [{"primitives": [receiver]}, {"primitives": [emitter]}],
                "textures": [{"sampler": 0, "source": 0}],
                "images": [{"uri": "half.png"}],
                "samplers": [{"magFilter": 9728, "wrapS": 33071, "wrapT": 33071}],
            }),
        );
        load(&path)
    };
    let textured = make("textured", true);
    let uniform = make("uniform", false);
    let white_half = |x: f64, y: f64| {
        let v: Vec<glam::DVec3> = [[-0.5, -0.5], [0.0, -0.5], [0.0, 0.5], [-0.5, 0.5]]
            .iter()
            .map(|c| glam::DVec3::new(c[0] - x, c[1] - y, 1.0))
            .collect();
        polygon_irradiance(&v, 2.0)
    };
    let whole = |x: f64, y: f64| {
        let v: Vec<glam::DVec3> = [[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]
            .iter()
            .map(|c| glam::DVec3::new(c[0] - x, c[1] - y, 1.0))
            .collect();
        polygon_irradiance(&v, 1.0)
    };
    // At x = 0 the white half alone and the uniform half-radiance square agree exactly.
    assert!((white_half(0.0, 0.2) - whole(0.0, 0.2)).abs() < 1e-12);
    let pt = PathTracer::new(PathSettings::default());
    let n = 20_000u32;
    for (x, y) in [(0.0f32, 0.0f32), (0.0, 0.3), (-0.4, 0.1), (0.6, -0.2)] {
        for (scene_name, scene, expected_e) in [
            (
                "textured",
                &textured.scene,
                white_half(f64::from(x), f64::from(y)),
            ),
            ("uniform", &uniform.scene, whole(f64::from(x), f64::from(y))),
        ] {
            if scene_name == "uniform" && x != 0.0 {
                continue;
            }
            let expected = rho / std::f64::consts::PI * expected_e;
            let ray = Ray::new(Vec3::new(x, y, 0.5), Vec3::NEG_Z);
            let estimate = |f: &dyn Fn(&Scene, &mut Dimensions, &mut RayCounter) -> f32| {
                let mut rays = RayCounter::default();
                let values: Vec<f64> = (0..n)
                    .map(|i| {
                        let key = SampleKey::new(9, u64::from(i), 0);
                        f64::from(f(scene, &mut Dimensions::starting_at(key, 1), &mut rays))
                    })
                    .collect();
                let mean = values.iter().sum::<f64>() / f64::from(n);
                let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / f64::from(n - 1);
                (mean, (var / f64::from(n)).sqrt())
            };
            let path = estimate(&|s, d, r| pt.li(s, &ray, d, r).x);
            let nee = estimate(&|s, d, r| {
                let hit = s
                    .geometry()
                    .intersect(&ray)
                    .unwrap_or_else(|| panic!("no hit"));
                let x = ShadingPoint::new(&s.geometry().surface(&ray, &hit), Vec3::Z);
                direct_nee(s, &x, 1, d, r).x
            });
            for (estimator, (mean, se)) in [("path tracer", path), ("NEE", nee)] {
                // 5 standard errors (as above) plus f32 rounding of a few factors of order 1.
                let tolerance = 5.0 * se + 16.0 * 2f64.powi(-24) * expected;
                assert!(
                    (mean - expected).abs() <= tolerance,
                    "{scene_name}, {estimator} at ({x}, {y}): {mean} differs from {expected} by more than {tolerance:e}"
                );
            }
        }
    }
}

/// The irradiance cache stores irradiance: the albedo that multiplies it is the texture's at the
/// shading point, never that of the point where a record was computed. On a black-and-white
/// checkerboard inside a box of grey emitting walls (so indirect light is not zero), a point on
/// a black texel reflects nothing, direct or indirect, while its white neighbours, which share
/// records with it, reflect both.
#[test]
fn irradiance_cache_multiplies_by_the_albedo_at_the_shading_point() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let path = furnace_scene(
        dir.path(),
        "ic",
        &png(2, 2, &[[255; 3], [0; 3], [0; 3], [255; 3]]),
        json!({"magFilter": 9728}),
        json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0},
               "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}),
    );
    let mut doc: Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap_or_else(|e| panic!("{e}")))
            .unwrap_or_else(|e| panic!("{e}"));
    // Grey walls: they reflect, so the quad receives indirect light.
    doc["materials"][1]["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.5, 0.5, 0.5, 1.0]);
    write(
        &path,
        serde_json::to_vec(&doc).unwrap_or_else(|e| panic!("{e}")),
    );
    let loaded = load(&path);
    let s = RenderSettings {
        width: 16,
        height: 16,
        spp: 1,
        seed: 3,
        threads: 0,
    };
    let camera = loaded.camera_for(s.width, s.height);
    let ic = IcSettings {
        strata_m: 6,
        strata_n: 18,
        ..IcSettings::default()
    };
    let mut integrator = IrradianceCacheIntegrator::new(ic).unwrap_or_else(|e| panic!("{e}"));
    integrator.preprocess(&loaded.scene);
    build_cache(
        &loaded.scene,
        &camera,
        &mut integrator,
        &s,
        ic.fill_samples,
        false,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(integrator.cache(0).is_some_and(|c| !c.is_empty()));
    // Texel centres of the 6×6 the quad shows: (u, v) = ((i + ½)/2 − 1, (j + ½)/2 − 1), i.e.
    // x = (i + ½)/6 − ½, y = ½ − (j + ½)/6; texel (i mod 2, j mod 2) is black when i + j is odd.
    let mut rays = RayCounter::default();
    for j in 0..6 {
        for i in 0..6 {
            let (x, y) = ((i as f32 + 0.5) / 6.0 - 0.5, 0.5 - (j as f32 + 0.5) / 6.0);
            let ray = Ray::new(Vec3::new(x, y, 0.5), Vec3::NEG_Z);
            // Eight samples: one NEE sample may pick a wall point behind the quad's plane.
            let r = (0..8u64)
                .map(|k| {
                    let key = SampleKey::new(1, (j * 6 + i) as u64, k);
                    integrator.li_split(
                        &loaded.scene,
                        &ray,
                        &mut Dimensions::starting_at(key, 1),
                        &mut rays,
                    )
                })
                .fold(Radiance::default(), |a, b| a + b);
            if (i + j) % 2 == 1 {
                assert_eq!(
                    (r.direct, r.indirect),
                    (Vec3::ZERO, Vec3::ZERO),
                    "black texel ({i}, {j})"
                );
            } else {
                assert!(
                    r.direct.min_element() > 0.0 && r.indirect.min_element() > 0.0,
                    "white texel ({i}, {j}): {r:?}"
                );
            }
        }
    }
}
