//! The Khronos glTF sample models in assets/khronos/ as a conformance suite (the folder's
//! README.md lists them and what each exercises). The list is the folder's: a model added
//! there is walked too. Every model either loads, with warnings of one line each that name
//! its file, and renders at 24×24 with both integrators to a finite, non-negative image that
//! is not black, or is refused with a one-line error that names the file and an extension the
//! file requires. The default camera (the file has none) frames each one: the bounds' corners
//! project inside the image and some pixel's ray meets the model.
//!
//! The checks are properties any correct render has, not values: no tolerance but the
//! rounding margin of the corners' projection.

use crate::support::{asset, ic_image, path_image};
use glam::{Vec2, Vec3};
use irr_geometry::Ray;
use irr_render::{Camera, IcSettings, Image, LoadedScene, RenderSettings, load_scene};
use std::path::{Path, PathBuf};

const SIZE: u32 = 24;

/// Each model folder's glTF file (`.gltf` or `.glb`), in name order.
fn models() -> Vec<PathBuf> {
    let root = asset("khronos");
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(&root)
        .unwrap_or_else(|e| panic!("{}: {e}", root.display()))
        .map(|e| {
            e.unwrap_or_else(|e| panic!("{}: {e}", root.display()))
                .path()
        })
        .filter(|p| p.is_dir())
        .collect();
    dirs.sort();
    let models: Vec<PathBuf> = dirs
        .iter()
        .map(|dir| {
            let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
                .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
                .map(|e| {
                    e.unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
                        .path()
                })
                .filter(|p| p.extension().is_some_and(|e| e == "gltf" || e == "glb"))
                .collect();
            assert_eq!(
                files.len(),
                1,
                "{}: a model folder holds one .gltf or .glb, found {files:?}",
                dir.display()
            );
            files.remove(0)
        })
        .collect();
    assert!(!models.is_empty(), "{}: no models", root.display());
    models
}

/// The file's `extensionsRequired` (from its JSON, or a `.glb`'s JSON chunk).
fn required_extensions(path: &Path) -> Vec<String> {
    let bytes = crate::support::read(path);
    let json = if bytes.starts_with(b"glTF") {
        // Header (12 bytes), then the JSON chunk: its length, its type, its bytes.
        let length = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
        &bytes[20..20 + length]
    } else {
        &bytes[..]
    };
    let value: serde_json::Value =
        serde_json::from_slice(json).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    value["extensionsRequired"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|v| v.as_str().map(str::to_string))
        .collect()
}

/// Checks a refusal: one line, naming the file and one of the extensions it requires.
fn check_refusal(path: &Path, error: &str) {
    let required = required_extensions(path);
    assert!(
        !required.is_empty(),
        "{} requires no extension, yet was refused: {error}",
        path.display()
    );
    assert!(!error.contains(['\n', '\r']), "not one line: {error:?}");
    assert!(
        error.contains(&path.display().to_string()),
        "does not name {}: {error}",
        path.display()
    );
    assert!(
        required
            .iter()
            .any(|ext| error.contains(&format!("requires extension {ext}"))),
        "{}: the error names none of the required extensions {required:?}: {error}",
        path.display()
    );
}

/// Checks the load's warnings: one line each, each naming the file.
fn check_warnings(path: &Path, loaded: &LoadedScene) {
    for w in &loaded.warnings {
        let line = w.to_string();
        assert_eq!(w.file, path, "{line}");
        assert!(!line.contains(['\n', '\r']), "not one line: {line:?}");
        assert!(
            line.starts_with(&format!("{}: ", path.display())) && !w.message.is_empty(),
            "does not name {}: {line}",
            path.display()
        );
    }
}

/// Checks an image: every value finite and non-negative, and some value above zero.
fn check_image(what: &str, image: &Image) {
    for (i, p) in image.pixels().iter().enumerate() {
        assert!(
            p.is_finite() && p.min_element() >= 0.0,
            "{what}: pixel {i} is {p}"
        );
    }
    assert!(
        image.pixels().iter().any(|p| p.max_element() > 0.0),
        "{what}: the image is black"
    );
}

fn settings() -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp: 2,
        seed: 1,
        threads: 0,
    }
}

#[test]
fn khronos_models_render_or_are_refused() {
    for path in models() {
        let started = std::time::Instant::now();
        let loaded = match load_scene(&path) {
            Ok(loaded) => loaded,
            Err(e) => {
                check_refusal(&path, &e.to_string());
                eprintln!("{}: refused: {e}", path.display());
                continue;
            }
        };
        check_warnings(&path, &loaded);
        for w in &loaded.warnings {
            eprintln!("warning: {w}");
        }
        let s = settings();
        let camera = loaded.camera_for(s.width, s.height);
        // A model without an emitter or a light is seen under a white sky.
        let lit = loaded.scene.emitter_count() > 0;
        let scene = if lit {
            loaded.scene
        } else {
            loaded
                .scene
                .with_background(Vec3::ONE)
                .unwrap_or_else(|e| panic!("{e}"))
        };
        let name = path.display();
        check_image(
            &format!("{name} (path tracer)"),
            &path_image(&scene, &camera, &s),
        );
        let (image, _) = ic_image(&scene, &camera, IcSettings::default(), &s);
        check_image(&format!("{name} (irradiance cache)"), &image);
        eprintln!(
            "{name}: rendered ({}) in {:.2} s",
            if lit { "its own light" } else { "a white sky" },
            started.elapsed().as_secs_f64()
        );
    }
}

/// Where `p` lands in the image of `camera` at `aspect` (NDC, (0, 0) the top-left corner), and
/// its depth along the view.
fn project(camera: &Camera, aspect: f64, p: Vec3) -> (f64, f64, f64) {
    // A 1000-pixel-high image of that aspect ratio (world_to_ndc takes whole pixels).
    let (w, h) = ((1000.0 * aspect).round() as u32, 1000);
    let h4 = camera.world_to_ndc(w, h) * p.as_dvec3().extend(1.0);
    let depth = (p.as_dvec3() - camera.position.as_dvec3()).dot(camera.forward.as_dvec3());
    (h4.x / h4.w, h4.y / h4.w, depth)
}

#[test]
fn khronos_models_are_framed_by_the_default_camera() {
    for path in models() {
        let Ok(loaded) = load_scene(&path) else {
            continue; // refused: the test above checks its error
        };
        let name = path.display();
        let (lo, hi) = loaded.bounds;
        for aspect in [1.0, 2.0, 0.5] {
            let camera = Camera::framing(lo, hi, aspect as f32);
            for i in 0..8 {
                let corner =
                    Vec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo);
                let (x, y, depth) = project(&camera, aspect, corner);
                // Inside, but for the rounding of f32 coordinates (a relative 10⁻⁴ of the
                // image, as the framing's own test allows).
                let inside = |v: f64| (-1e-4..=1.0 + 1e-4).contains(&v);
                assert!(
                    depth > 0.0 && inside(x) && inside(y),
                    "{name}: at aspect {aspect} the bounds' corner {corner} projects to ({x}, {y}) at depth {depth}, outside the image"
                );
            }
        }
        // Some pixel sees the model: the ray through its centre meets a surface.
        let camera = Camera::framing(lo, hi, 1.0);
        let projection = camera.projection(SIZE, SIZE);
        let seen = (0..SIZE * SIZE)
            .filter(|i| {
                let r = projection.ray(Vec2::new((i % SIZE) as f32 + 0.5, (i / SIZE) as f32 + 0.5));
                let ray = Ray {
                    origin: r.origin,
                    direction: r.direction,
                    t_max: r.t_max,
                };
                loaded.scene.intersect_camera(&ray).is_some()
            })
            .count();
        assert!(
            seen > 0,
            "{name}: no pixel of the default camera's {SIZE}×{SIZE} image sees the model (bounds {lo}..{hi}, camera at {} looking along {})",
            camera.position,
            camera.forward
        );
        eprintln!(
            "{name}: the default camera sees the model in {seen} of {} pixels",
            SIZE * SIZE
        );
    }
}
