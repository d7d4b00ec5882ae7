//! Cut-outs and stochastic transparency (glTF `alphaMode` `MASK` and `BLEND`) through the whole
//! pipeline, on the known-answer scene of the texture tests: a Lambertian quad of albedo ρ
//! inside a box of black walls that emit Le = 1 from both faces. Where the quad is there, a
//! pixel's radiance is ρ·Le (its irradiance is π·Le from every direction); where it is cut
//! out, the camera sees the wall behind it: Le. A blend of coverage α shows α·ρ + (1 − α).
//!
//! Tolerances: each pixel's mean within 5 standard errors of its own samples (a correct
//! estimator fails with probability 6·10⁻⁷ per channel; the seed is fixed), plus f32
//! rounding.

use crate::textures::{SIZE, furnace_scene, load, settings};
use glam::Vec3;
use irr_integrator::{Integrator, PathSettings, PathTracer};
use irr_render::{IcSettings, LoadedScene, RenderSettings, pixel_samples};
use serde_json::{Value, json};

/// An 8-bit RGBA PNG of one texel.
fn rgba(texel: [u8; 4]) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut e = png::Encoder::new(&mut out, 1, 1);
        e.set_color(png::ColorType::Rgba);
        e.set_depth(png::BitDepth::Eight);
        let mut w = e.write_header().unwrap_or_else(|e| panic!("{e}"));
        w.write_image_data(&texel).unwrap_or_else(|e| panic!("{e}"));
    }
    out
}

/// The quad's albedo: white texels × this factor, so that ρ·Le and Le differ.
const RHO: f32 = 0.25;

/// The furnace scene whose quad has `alpha` (its alphaMode, cutoff and factor alpha as JSON
/// members) over a white texture of alpha code `texel_alpha`.
fn scene(dir: &std::path::Path, name: &str, texel_alpha: u8, alpha: Value) -> LoadedScene {
    let mut material = json!({
        "pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                 "baseColorFactor": [RHO, RHO, RHO, 1.0],
                                 "metallicFactor": 0.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}
    });
    if let (Some(m), Some(a)) = (material.as_object_mut(), alpha.as_object()) {
        for (k, v) in a {
            if k == "alpha" {
                m["pbrMetallicRoughness"]["baseColorFactor"][3] = v.clone();
            } else {
                m.insert(k.clone(), v.clone());
            }
        }
    }
    load(&furnace_scene(
        dir,
        name,
        &rgba([255, 255, 255, texel_alpha]),
        json!({}),
        material,
    ))
}

/// Checks pixel (x, y) of `integrator`'s render: mean `expected` within 5 standard errors
/// plus 16 f32 roundings.
fn assert_pixel(
    what: &str,
    loaded: &LoadedScene,
    integrator: &dyn Integrator,
    s: &RenderSettings,
    (x, y): (u32, u32),
    expected: f32,
) {
    let camera = loaded.camera_for(s.width, s.height);
    let samples = pixel_samples(&loaded.scene, &camera, integrator, s, x, y)
        .unwrap_or_else(|e| panic!("{e}"));
    let n = samples.len() as f64;
    let mean = samples.iter().map(|l| f64::from(l.x)).sum::<f64>() / n;
    let var = samples
        .iter()
        .map(|l| (f64::from(l.x) - mean).powi(2))
        .sum::<f64>()
        / (n - 1.0);
    let e = f64::from(expected);
    let tolerance = 5.0 * (var / n).sqrt() + 16.0 * 2f64.powi(-24) * e;
    assert!(
        (mean - e).abs() <= tolerance,
        "{what}: pixel ({x}, {y}): mean {mean} differs from {e} by more than {tolerance:e}"
    );
}

#[test]
fn cut_outs_and_blends_show_what_is_behind_them() {
    let dir = crate::support::temp();
    let d = dir.path();
    let s = settings(64);
    let path = PathTracer::new(PathSettings::default());
    let cases: [(&str, u8, Value, f32); 6] = [
        // MASK: the texel's alpha (200/255 or 100/255) against the default cutoff ½.
        ("mask, covered", 200, json!({"alphaMode": "MASK"}), RHO),
        ("mask, cut out", 100, json!({"alphaMode": "MASK"}), 1.0),
        // The cutoff and the factor's alpha count too: 0.8 × 200/255 < 0.7.
        (
            "mask, factor",
            200,
            json!({"alphaMode": "MASK", "alphaCutoff": 0.7, "alpha": 0.8}),
            1.0,
        ),
        // BLEND: α = 0.5 × 255/255 of the quad, the rest the wall behind.
        (
            "blend",
            255,
            json!({"alphaMode": "BLEND", "alpha": 0.5}),
            0.5 * RHO + 0.5,
        ),
        // OPAQUE ignores alpha.
        ("opaque", 0, json!({"alphaMode": "OPAQUE"}), RHO),
        // BLEND with α = 1 everywhere is opaque.
        ("blend, α 1", 255, json!({"alphaMode": "BLEND"}), RHO),
    ];
    for (what, texel_alpha, alpha, expected) in cases {
        let loaded = scene(d, "cut", texel_alpha, alpha);
        assert!(loaded.warnings.is_empty(), "{what}: {:?}", loaded.warnings);
        let camera = loaded.camera_for(s.width, s.height);
        let ic = crate::support::built(&loaded.scene, &camera, IcSettings::default(), &s);
        for pixel in [(0, 0), (7, 16), (SIZE / 2, SIZE / 2), (SIZE - 1, SIZE - 1)] {
            assert_pixel(what, &loaded, &path, &s, pixel, expected);
            assert_pixel(what, &loaded, &ic, &s, pixel, expected);
        }
    }
}

/// Shadow and gather rays pass through a cut-out as camera rays do: a ray from above the quad
/// to a point below it is occluded exactly where the quad is covered.
#[test]
fn shadow_rays_pass_through_cut_outs() {
    let dir = crate::support::temp();
    for (texel_alpha, covered) in [(200u8, true), (100, false)] {
        let loaded = scene(
            dir.path(),
            "shadow",
            texel_alpha,
            json!({"alphaMode": "MASK"}),
        );
        let scene = &loaded.scene;
        let from = Vec3::new(0.1, 0.2, 0.5);
        let ray = irr_geometry::Ray::spawn_to(from, Vec3::Z, Vec3::new(0.1, 0.2, -0.5), Vec3::Z);
        assert_eq!(scene.occluded(&ray), covered, "texel alpha {texel_alpha}");
        assert_eq!(scene.intersect(&ray).is_some(), covered);
        // The geometry alone knows no alpha.
        assert!(scene.geometry().occluded(&ray));
    }
}

/// Next-event estimation sees an emitter through its coverage: with the walls a blend of
/// α = ½, a ray from the quad meets a wall with probability ½ and otherwise leaves the box
/// into the black background, so the quad's irradiance is π·Le/2 and its pixels show ρ·Le/2,
/// in the path tracer (light samples weighted against BSDF samples that pass through the
/// walls or stop there) and in the cache (whose gathers and light samples do the same).
/// Without the coverage, light samples would count the walls whole: ρ·Le·(½ + ½·MIS share).
#[test]
fn light_samples_take_an_emitters_coverage() {
    let dir = crate::support::temp();
    let path = furnace_scene(
        dir.path(),
        "blend-walls",
        &rgba([255, 255, 255, 255]),
        json!({}),
        json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0},
                                        "baseColorFactor": [RHO, RHO, RHO, 1.0],
                                        "metallicFactor": 0.0},
               "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}}),
    );
    let mut doc: Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap_or_else(|e| panic!("{e}")))
            .unwrap_or_else(|e| panic!("{e}"));
    doc["materials"][1]["alphaMode"] = json!("BLEND");
    doc["materials"][1]["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.0, 0.0, 0.0, 0.5]);
    std::fs::write(&path, doc.to_string()).unwrap_or_else(|e| panic!("{e}"));
    let loaded = load(&path);
    let s = settings(16);
    let camera = loaded.camera_for(s.width, s.height);
    let pt = PathTracer::new(PathSettings::default());
    let ic = crate::support::built(&loaded.scene, &camera, IcSettings::default(), &s);
    // Every pixel has the same expectation: their samples pooled (24²·16 = 9216) make the
    // test sharp (a wall counted whole by the light samples raises the mean by 20–80 %).
    for (what, integrator) in [("path", &pt as &dyn Integrator), ("cache", &ic)] {
        let mut samples = Vec::new();
        for y in 0..SIZE {
            for x in 0..SIZE {
                samples.extend(
                    pixel_samples(&loaded.scene, &camera, integrator, &s, x, y)
                        .unwrap_or_else(|e| panic!("{e}"))
                        .iter()
                        .map(|l| f64::from(l.x)),
                );
            }
        }
        let n = samples.len() as f64;
        let mean = samples.iter().sum::<f64>() / n;
        let var = samples.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let e = f64::from(0.5 * RHO);
        // 5 standard errors; the cache's records add their gathers' frozen noise, each record
        // an estimate of E from 1024 rays that meet a wall with probability ½ (3 % relative),
        // averaged over the image's tens of records: about 1 % of e, within the 5 standard
        // errors (4 % of e here).
        let tolerance = 5.0 * (var / n).sqrt();
        assert!(
            (mean - e).abs() <= tolerance,
            "{what}: image mean {mean} differs from {e} by more than {tolerance:e}"
        );
    }
}
