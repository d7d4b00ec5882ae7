//! Normal textures through the whole pipeline: a quad whose normal texture tilts its shading
//! normal renders like the same quad with that normal as its vertex normals, in the path
//! tracer and in the irradiance cache, whether the file gives `TANGENT` or irr generates
//! MikkTSpace tangents, and under a mirroring node transform.
//!
//! The scene: the quad of the texture tests (facing +z, u growing along +x and v down the
//! image, i.e. along −y) in a box of black walls, one of which (x = +2) emits, so that the
//! light on the quad depends on its shading normal. glTF's normal texels are tangent-space
//! normals with +X along u and +Y up the image (glTF 2.0 §3.9.3): on this quad, world +x and
//! +y.

use crate::support::rel_mse;
use crate::textures::{Builder, QUAD, Quad, camera_node, cube, png};
use glam::Vec3;
use irr_integrator::{PathSettings, PathTracer};
use irr_render::{IcSettings, LoadedScene, RenderSettings, load_scene, render};
use serde_json::json;
use std::path::{Path, PathBuf};

/// The normal texel (8-bit codes, stored linear).
const TEXEL: [u8; 3] = [200, 90, 230];

/// The tangent-space normal TEXEL encodes: normalize(2c/255 − 1), computed in f64.
fn texel_normal() -> Vec3 {
    let c = TEXEL.map(|c| 2.0 * f64::from(c) / 255.0 - 1.0);
    glam::DVec3::from_array(c).normalize().as_vec3()
}

/// The tangent of the quad's vertices as Blender's exporter writes it: along u (+x), with
/// w = +1 since n × t = +y is up the image.
const ALONG_U: [f32; 4] = [1.0, 0.0, 0.0, 1.0];

/// How the quad gets its shading normal.
#[derive(Clone, Copy, Debug)]
enum Shading {
    /// The normal texture, with this TANGENT at every vertex.
    MapWithTangents([f32; 4]),
    /// The normal texture, tangents generated (MikkTSpace).
    MapGenerated,
    /// No normal texture: `normal` as the vertex normal at every corner.
    Tilted(Vec3),
    /// The normal texture with TANGENT along u, on vertex normals −z, against the winding.
    MapAgainstWinding,
}

/// Writes the scene; `mirror` puts every node under a parent that scales x by −1.
fn scene(dir: &Path, name: &str, shading: Shading, mirror: bool) -> PathBuf {
    std::fs::write(dir.join("normal.png"), png(1, 1, &[TEXEL])).unwrap_or_else(|e| panic!("{e}"));
    let mut b = Builder::default();
    let quad: Quad = match shading {
        Shading::Tilted(n) => (QUAD.0, n.to_array(), QUAD.2),
        Shading::MapAgainstWinding => (QUAD.0, [0.0, 0.0, -1.0], QUAD.2),
        _ => QUAD,
    };
    let mut plane = b.quads(&[quad], 0);
    let tangent = match shading {
        Shading::MapWithTangents(t) => Some(t),
        Shading::MapAgainstWinding => Some(ALONG_U),
        _ => None,
    };
    if let Some(tangent) = tangent {
        let t = b.floats(&[tangent; 4], "VEC4", false);
        plane["attributes"]["TANGENT"] = json!(t);
    }
    let faces = cube(2.0);
    // cube() lists the faces at x = −2, x = +2, y = −2, …: the second one glows.
    let glow = b.quads(&faces[1..2], 1);
    let walls: Vec<Quad> = faces
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != 1)
        .map(|(_, f)| *f)
        .collect();
    let walls = b.quads(&walls, 2);
    let (camera, cameras) = camera_node();
    let mut quad_material = json!({
        "name": "Bumped",
        "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0],
                                 "metallicFactor": 0.0, "roughnessFactor": 0.4}
    });
    if !matches!(shading, Shading::Tilted(_)) {
        quad_material["normalTexture"] = json!({"index": 0, "scale": 1.0});
    }
    let children: Vec<usize> = vec![1, 2, 3, 4];
    let root = if mirror {
        json!({"name": "Mirror", "scale": [-1.0, 1.0, 1.0], "children": children})
    } else {
        json!({"name": "Root", "children": children})
    };
    b.finish(
        dir,
        name,
        json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [root, {"mesh": 0}, {"mesh": 1}, {"mesh": 2}, camera],
            "cameras": cameras,
            "materials": [
                quad_material,
                {"name": "Glow", "doubleSided": true, "emissiveFactor": [1.0, 1.0, 1.0],
                 "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]}},
                {"name": "Black", "doubleSided": true,
                 "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]}}
            ],
            "meshes": [{"primitives": [plane]}, {"primitives": [glow]},
                       {"primitives": [walls]}],
            "textures": [{"source": 0}],
            "images": [{"uri": "normal.png"}],
        }),
    )
}

fn load(path: &Path) -> LoadedScene {
    load_scene(path).unwrap_or_else(|e| panic!("{e}"))
}

/// The shading normal where the ray from (x, y, 1) straight down meets the quad.
fn shading_normal(loaded: &LoadedScene, x: f32, y: f32) -> Vec3 {
    let ray = irr_geometry::Ray::new(Vec3::new(x, y, 1.0), -Vec3::Z);
    let scene = &loaded.scene;
    let hit = scene
        .geometry()
        .intersect(&ray)
        .unwrap_or_else(|| panic!("no hit at ({x}, {y})"));
    scene.shading_normal(&scene.geometry().surface(&ray, &hit))
}

/// The texel's normal in world space: (x, y, z) along (+x, +y, +z), with x mirrored by the
/// mirroring node (the mirror image of a bump is the bump of the mirrored texture). On vertex
/// normals that face against the winding (−z), the file's frame (t, w·(n × t), n) = (+x, −y,
/// −z) gives (x, −y, −z), which irr turns to the winding's side whole: (−x, y, z).
#[test]
fn normal_texels_turn_the_normal_by_gltfs_axes() {
    let dir = crate::support::temp();
    let n = texel_normal();
    let against = load(&scene(
        dir.path(),
        "against",
        Shading::MapAgainstWinding,
        false,
    ));
    let got = shading_normal(&against, 0.2, -0.1);
    assert!(
        (got - Vec3::new(-n.x, n.y, n.z)).length() < 2e-6,
        "against the winding: {got}"
    );
    for (mirror, expected) in [(false, n), (true, Vec3::new(-n.x, n.y, n.z))] {
        for shading in [Shading::MapWithTangents(ALONG_U), Shading::MapGenerated] {
            let loaded = load(&scene(dir.path(), "map", shading, mirror));
            for (x, y) in [(0.1, 0.2), (-0.3, 0.4), (0.45, -0.45)] {
                let got = shading_normal(&loaded, x, y);
                // About 30 f32 operations on values of order 1 (the texel's decode, the
                // frame, the normalisations), each within 2⁻²⁴ relative: below 2·10⁻⁶.
                assert!(
                    (got - expected).length() < 2e-6,
                    "{shading:?}, mirror {mirror}, at ({x}, {y}): {got}, expected {expected}"
                );
            }
        }
    }
}

/// A 16×16 render of `spp` samples per pixel, seed 3 (the glass tests' size too).
pub(crate) fn settings(spp: u32) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 16,
        spp,
        seed: 3,
        threads: 0,
    }
}

#[test]
fn a_normal_mapped_quad_renders_like_the_tilted_quad() {
    let dir = crate::support::temp();
    let s = settings(16);
    let images = |shading: Shading| {
        let loaded = load(&scene(dir.path(), "quad", shading, false));
        let camera = loaded.camera_for(s.width, s.height);
        let pt = PathTracer::new(PathSettings::default());
        let path = render(&loaded.scene, &camera, &pt, &s, false)
            .unwrap_or_else(|e| panic!("{e}"))
            .image;
        let (ic, _) = crate::support::ic_image(&loaded.scene, &camera, IcSettings::default(), &s);
        (path, ic)
    };
    let (tilted_path, tilted_ic) = images(Shading::Tilted(texel_normal()));
    // The scene tells normals apart: the untilted quad's image is far from the tilted one's.
    let (flat_path, _) = images(Shading::Tilted(Vec3::Z));
    let apart = rel_mse(&flat_path, &tilted_path);
    assert!(
        apart > 1e-3,
        "the flat and the tilted quad differ by relMSE {apart:e} only"
    );
    for shading in [Shading::MapWithTangents(ALONG_U), Shading::MapGenerated] {
        let (path, ic) = images(shading);
        // The two scenes differ only in how the shading normal is computed: the same random
        // numbers meet normals that agree within 2·10⁻⁶ (the test above). A sample is a
        // smooth function of the normal whose relative sensitivity is at most about 1/α² = 39
        // (GGX's lobe at roughness 0.4, α = 0.16), so each sample, and so each pixel, moves
        // by at most 8·10⁻⁵ relative: relMSE ≤ 6.4·10⁻⁹. (A discrete decision flipped by the
        // rounding, such as a direction at the horizon, has probability of order 10⁻⁶ per
        // sample.)
        for (what, a, b) in [("path", &path, &tilted_path), ("cache", &ic, &tilted_ic)] {
            let e = rel_mse(a, b);
            assert!(e <= 6.4e-9, "{shading:?}, {what}: relMSE {e:e}");
        }
    }
}

/// The scene of `shading` with `edit` applied to its JSON, loaded: the result or the error.
fn edited(
    dir: &Path,
    shading: Shading,
    edit: impl Fn(&mut serde_json::Value),
) -> Result<LoadedScene, String> {
    let path = scene(dir, "edited", shading, false);
    let mut doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap_or_else(|e| panic!("{e}")))
            .unwrap_or_else(|e| panic!("{e}"));
    edit(&mut doc);
    std::fs::write(&path, doc.to_string()).unwrap_or_else(|e| panic!("{e}"));
    load_scene(&path).map_err(|e| e.to_string())
}

#[test]
fn bad_normal_textures_and_tangents_are_refused_or_replaced() {
    let dir = crate::support::temp();
    let d = dir.path();
    // A scale beyond f32 reads as infinite.
    let e = edited(d, Shading::MapGenerated, |doc| {
        doc["materials"][0]["normalTexture"]["scale"] = json!(1e39);
    })
    .err()
    .unwrap_or_else(|| panic!("an infinite scale was accepted"));
    assert!(e.contains("normalTexture: scale inf is not finite"), "{e}");
    // TANGENT of three components, or fewer elements than positions.
    let tangent = |doc: &serde_json::Value| {
        doc["meshes"][0]["primitives"][0]["attributes"]["TANGENT"]
            .as_u64()
            .unwrap_or_else(|| panic!("no TANGENT")) as usize
    };
    let e = edited(d, Shading::MapWithTangents(ALONG_U), |doc| {
        let t = tangent(doc);
        doc["accessors"][t]["type"] = json!("VEC3");
    })
    .err()
    .unwrap_or_else(|| panic!("a VEC3 TANGENT was accepted"));
    assert!(e.contains("VEC3 of FLOAT; irr reads VEC4 of FLOAT"), "{e}");
    let e = edited(d, Shading::MapWithTangents(ALONG_U), |doc| {
        let t = tangent(doc);
        doc["accessors"][t]["count"] = json!(3);
    })
    .err()
    .unwrap_or_else(|| panic!("a short TANGENT was accepted"));
    assert!(
        e.contains("TANGENT has 3 elements but POSITION has 4"),
        "{e}"
    );
    // Zero tangents: MikkTSpace's are used instead, with a warning, giving the texel's normal
    // as in the test above.
    let zero =
        edited(d, Shading::MapWithTangents([0.0; 4]), |_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        zero.warnings.iter().any(|w| w.feature == "bad-tangents"),
        "{:?}",
        zero.warnings
    );
    let got = shading_normal(&zero, 0.2, 0.1);
    assert!((got - texel_normal()).length() < 2e-6, "{got}");
    // A KHR_texture_transform on the normal texture is read.
    let moved = edited(d, Shading::MapGenerated, |doc| {
        doc["materials"][0]["normalTexture"]["extensions"] =
            json!({"KHR_texture_transform": {"offset": [0.5, 0.25], "texCoord": 0}});
        doc["extensionsUsed"] = json!(["KHR_texture_transform"]);
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let m = moved.scene.materials()[0];
    let t = m
        .normal_texture
        .unwrap_or_else(|| panic!("no normal texture"));
    assert_eq!(t.transform.translation, glam::Vec2::new(0.5, 0.25));
}

/// A fan of more triangles around one vertex than MikkTSpace is given (its grouping recurses
/// once per triangle of a fan: a hostile file could overflow the stack) loads with a warning,
/// each triangle taking its own tangent, which on a flat fan is MikkTSpace's: the texel's
/// normal on glTF's axes.
#[test]
fn a_huge_fan_gets_per_triangle_tangents() {
    let dir = crate::support::temp();
    let d = dir.path();
    std::fs::write(d.join("normal.png"), png(1, 1, &[TEXEL])).unwrap_or_else(|e| panic!("{e}"));
    let rim = 5000;
    let mut p = vec![[0.0f32; 3]];
    for k in 0..=rim {
        let a = std::f32::consts::TAU * k as f32 / rim as f32;
        p.push([0.5 * a.cos(), 0.5 * a.sin(), 0.0]);
    }
    // u along +x, v down the image along −y.
    let uv: Vec<[f32; 2]> = p.iter().map(|q| [q[0] + 0.5, 0.5 - q[1]]).collect();
    let idx: Vec<u16> = (0..p.len() as u16).collect();
    let mut b = Builder::default();
    let (pa, na, ta, ia) = (
        b.floats(&p, "VEC3", true),
        b.floats(&vec![[0.0f32, 0.0, 1.0]; p.len()], "VEC3", false),
        b.floats(&uv, "VEC2", false),
        b.indices(&idx),
    );
    let path = b.finish(
        d,
        "fan",
        json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pa, "NORMAL": na,
                                                       "TEXCOORD_0": ta},
                                        "indices": ia, "mode": 6, "material": 0}]}],
            "materials": [{"normalTexture": {"index": 0},
                           "pbrMetallicRoughness": {"metallicFactor": 0.0}}],
            "textures": [{"source": 0}],
            "images": [{"uri": "normal.png"}],
        }),
    );
    let loaded = load(&path);
    assert!(
        loaded.warnings.iter().any(|w| w.feature == "tangent-fan"),
        "{:?}",
        loaded.warnings
    );
    for (x, y) in [(0.1, 0.2), (-0.3, 0.1), (0.05, -0.35)] {
        let got = shading_normal(&loaded, x, y);
        // A triangle's tangent comes from differences of its corners' coordinates (of order
        // ½, rounded to 6·10⁻⁸) over its rim edge of 6·10⁻⁴ (π/5000): each difference is
        // within 10⁻⁴ relative, and the tangent, a ratio of a few of them, within 10⁻³.
        assert!(
            (got - texel_normal()).length() < 1e-3,
            "at ({x}, {y}): {got}"
        );
    }
}
