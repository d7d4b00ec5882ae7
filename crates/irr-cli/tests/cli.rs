//! The `irr` binary as a user runs it: from a folder other than the scene's, with `--camera`,
//! a size from the camera's aspect ratio, `--aov`, and bad options. Each test runs the built
//! binary (`CARGO_BIN_EXE_irr`) and reads the EXR it wrote with the `exr` crate.

use exr::meta::attribute::{AttributeValue, Text};
use exr::prelude::{ReadChannels, ReadLayers};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The unit roundoff of f32, 2⁻²⁴.
const U: f32 = f32::EPSILON / 2.0;

/// The albedo of the test plane.
const ALBEDO: [f32; 3] = [0.25, 0.5, 0.75];

fn temp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"))
}

fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/cornell-box.gltf")
}

/// A 200 m square in the plane z = 0, facing +z, of albedo [`ALBEDO`], in `dir/plane.gltf`
/// (buffer `plane.bin`), with the perspective cameras `cameras` (JSON objects) on nodes
/// `nodes` (JSON text of the `nodes` array, the mesh on node 0) and scene roots `roots`.
fn write_plane(dir: &Path, name: &str, cameras: &str, nodes: &str, roots: &str) -> PathBuf {
    let h = 100.0f32;
    let positions = [[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]];
    let indices = [0u32, 1, 2, 0, 2, 3];
    let mut bin: Vec<u8> = positions
        .iter()
        .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
        .collect();
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let bin_name = format!("{name}.bin");
    std::fs::write(dir.join(&bin_name), &bin).unwrap_or_else(|e| panic!("{e}"));
    let [r, g, b] = ALBEDO;
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":{roots}}}],
        "nodes":{nodes},"cameras":{cameras},
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[{r},{g},{b},1],"metallicFactor":0}}}}],
        "buffers":[{{"byteLength":{},"uri":"{bin_name}"}}],
        "bufferViews":[{{"buffer":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":24}}],
        "accessors":[
          {{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-{h},-{h},0],"max":[{h},{h},0]}},
          {{"bufferView":1,"componentType":5125,"count":6,"type":"SCALAR"}}]}}"#,
        bin.len()
    );
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, json).unwrap_or_else(|e| panic!("{e}"));
    path
}

/// The plane with two cameras looking down −z at it: node 1 "near" (2 m away, no aspectRatio),
/// a child of node 0, met first in depth-first order; and node 2 "far" (5 m away, aspectRatio
/// 2), a root listed after node 0.
fn two_camera_plane(dir: &Path) -> PathBuf {
    write_plane(
        dir,
        "plane",
        r#"[{"type":"perspective","perspective":{"yfov":0.5,"znear":0.01}},
            {"type":"perspective","perspective":{"yfov":0.5,"znear":0.01,"aspectRatio":2.0}}]"#,
        r#"[{"mesh":0,"children":[1]},
            {"name":"near","camera":0,"translation":[0,0,2]},
            {"name":"far","camera":1,"translation":[0,0,5]}]"#,
        "[0, 2]",
    )
}

/// Runs `irr args…` in `cwd`.
fn irr(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_irr"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap_or_else(|e| panic!("cannot run irr: {e}"))
}

/// Runs `irr`, which must succeed.
fn irr_ok(cwd: &Path, args: &[&str]) {
    let out = irr(cwd, args);
    assert!(
        out.status.success(),
        "irr {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// An EXR as the tests see it: size, every channel by name, the shared chromaticities and the
/// part's attributes.
struct Exr {
    width: usize,
    height: usize,
    channels: BTreeMap<String, Vec<f32>>,
    chromaticities: Option<exr::meta::attribute::Chromaticities>,
    attributes: exr::meta::header::LayerAttributes,
}

impl Exr {
    fn read(path: &Path) -> Self {
        let image = exr::prelude::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_file(path)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!(image.layer_data.len(), 1, "one part");
        let layer = &image.layer_data[0];
        Self {
            width: layer.size.width(),
            height: layer.size.height(),
            channels: layer
                .channel_data
                .list
                .iter()
                .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
                .collect(),
            chromaticities: image.attributes.chromaticities,
            attributes: layer.attributes.clone(),
        }
    }

    fn names(&self) -> Vec<&str> {
        self.channels.keys().map(String::as_str).collect()
    }

    fn channel(&self, name: &str) -> &[f32] {
        self.channels
            .get(name)
            .unwrap_or_else(|| panic!("no channel {name}: {:?}", self.names()))
    }

    /// Channel `name` at pixel (x, y), row 0 at the top.
    fn at(&self, name: &str, x: usize, y: usize) -> f32 {
        self.channel(name)[y * self.width + x]
    }

    fn attribute(&self, name: &str) -> Option<&AttributeValue> {
        self.attributes
            .other
            .get(&Text::from_slice_unchecked(name.as_bytes()))
    }

    fn text(&self, name: &str) -> String {
        match self.attribute(name) {
            Some(AttributeValue::Text(t)) => String::from_utf8_lossy(t.as_slice()).into_owned(),
            other => panic!("{name}: {other:?}"),
        }
    }
}

/// `irr plane.gltf` run from another folder writes `plane.exr` there;
/// with `--aov albedo,normal,depth` it has those layers, named for tev, Nuke and Blender, the
/// chromaticities and pbrt-v4's metadata; the AOVs of a plane are its albedo, its normal and
/// its distance; `--camera 1` renders from the file's second camera; a missing width or height
/// follows the camera's aspect ratio.
#[test]
fn plane_renders_from_another_folder_with_aovs_cameras_and_metadata() {
    let scenes = temp();
    let scene = two_camera_plane(scenes.path());
    let scene_arg = scene.to_string_lossy().into_owned();
    let work = temp();
    let common = [
        "--integrator",
        "ao",
        "--spp",
        "2",
        "--aov",
        "albedo,normal,depth",
    ];

    // The default camera (node "near", 2 m, no aspectRatio) and --height only: square.
    let mut args = vec![scene_arg.as_str(), "--height", "8"];
    args.extend(common);
    irr_ok(work.path(), &args);
    let near = Exr::read(&work.path().join("plane.exr"));
    assert!(work.path().join("plane.png").is_file());
    assert!(!scenes.path().join("plane.exr").exists());
    assert_eq!((near.width, near.height), (8, 8));

    // --camera 1 (node "far", 5 m, aspectRatio 2) and --width only: 32 × 16.
    let out = work.path().join("far.exr");
    let out_arg = out.to_string_lossy().into_owned();
    let mut args = vec![
        scene_arg.as_str(),
        "--camera",
        "1",
        "--width",
        "32",
        "-o",
        &out_arg,
    ];
    args.extend(common);
    irr_ok(work.path(), &args);
    let far = Exr::read(&out);
    assert_eq!((far.width, far.height), (32, 16));

    for (exr, distance) in [(&near, 2.0f32), (&far, 5.0)] {
        assert_eq!(
            exr.names(),
            [
                "B", "G", "R", "albedo.B", "albedo.G", "albedo.R", "depth.Z", "normal.X",
                "normal.Y", "normal.Z"
            ]
        );
        // The plane fills the view: every sample sees albedo ALBEDO, so each pixel's mean (spp
        // equal values summed in f64, divided by spp) is ALBEDO exactly.
        assert!(exr.channel("albedo.R").iter().all(|&v| v == ALBEDO[0]));
        assert!(exr.channel("albedo.G").iter().all(|&v| v == ALBEDO[1]));
        assert!(exr.channel("albedo.B").iter().all(|&v| v == ALBEDO[2]));
        // The normal of the plane is +z, towards the cameras: three roundings in normalising
        // (0, 0, k) keep it within 4.8e-7 of 1, and x, y are exactly 0.
        assert!(
            exr.channel("normal.Z")
                .iter()
                .all(|&v| (v - 1.0).abs() < 4.8e-7)
        );
        assert!(exr.channel("normal.X").iter().all(|&v| v == 0.0));
        // Depth: distance / cos θ along each ray, from the centre of projection. The four
        // pixels around the image's centre reach at most one pixel from the axis in x and y;
        // a pixel spans 2/H in NDC, so for yfov 0.5 and H ≥ 8 rows, tan θ ≤ √2·tan(0.25)·2/8 =
        // 0.0903 and 1/cos θ = √(1 + tan² θ) ≤ 1.0041. Every pixel is at least `distance` (to
        // f32 rounding, 1e-5 relative).
        let (cx, cy) = (exr.width / 2, exr.height / 2);
        for (x, y) in [(cx - 1, cy - 1), (cx, cy - 1), (cx - 1, cy), (cx, cy)] {
            let d = exr.at("depth.Z", x, y);
            assert!(
                d >= distance * (1.0 - 1e-5) && d <= distance * 1.0041,
                "({x}, {y}): {d}"
            );
        }
        assert!(
            exr.channel("depth.Z")
                .iter()
                .all(|&d| d >= distance * (1.0 - 1e-5))
        );
        // The header: linear Rec.709 primaries, D65 white.
        let c = exr
            .chromaticities
            .unwrap_or_else(|| panic!("no chromaticities"));
        assert_eq!(
            (c.red, c.green, c.blue, c.white),
            (
                exr::math::Vec2(0.64, 0.33),
                exr::math::Vec2(0.30, 0.60),
                exr::math::Vec2(0.15, 0.06),
                exr::math::Vec2(0.3127, 0.3290)
            )
        );
        let software = exr.attributes.software_name.as_ref().map(|t| t.to_string());
        assert_eq!(
            software.as_deref(),
            Some(concat!("irr ", env!("CARGO_PKG_VERSION")))
        );
        assert_eq!(
            exr.attribute("samplesPerPixel"),
            Some(&AttributeValue::I32(2))
        );
        assert!(matches!(
            exr.attribute("renderTimeSeconds"),
            Some(AttributeValue::F32(t)) if *t >= 0.0
        ));
        assert_eq!(exr.text("irr.seed"), "0");
        assert_eq!(exr.text("irr.integrator"), "ao");
        assert_eq!(exr.text("irr.scene"), "plane.gltf");
        assert!(exr.text("irr.settings").contains("max_distance"));
        // worldToCamera (Imath's row-vector form) takes the camera's position, (0, 0, d), to
        // the origin and the plane's centre to (0, 0, d) in front of it.
        let m = exr
            .attributes
            .world_to_camera
            .unwrap_or_else(|| panic!("no worldToCamera"));
        let times = |v: [f32; 4]| -> [f32; 4] {
            std::array::from_fn(|c| (0..4).map(|r| v[r] * m[4 * r + c]).sum())
        };
        assert_eq!(times([0.0, 0.0, distance, 1.0]), [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(times([0.0, 0.0, 0.0, 1.0]), [0.0, 0.0, distance, 1.0]);
        assert!(exr.attributes.world_to_normalized_device.is_some());
    }
}

/// The colour's emitted, direct and indirect parts add up to it, for the path tracer and the
/// irradiance cache, on the Cornell box (whose indirect light is far from zero); and asking
/// for them changes no bit of the colour, whatever the thread count.
#[test]
fn split_layers_sum_to_the_colour() {
    let work = temp();
    let scene = cornell().to_string_lossy().into_owned();
    for integrator in ["path", "ic"] {
        // The same small render, to `out`, with `extra` options.
        let render = |out: &str, extra: &[&str]| {
            let mut args = vec![
                scene.as_str(),
                "-o",
                out,
                "--integrator",
                integrator,
                "--width",
                "12",
                "--spp",
                "2",
                "--strata",
                "4x16",
            ];
            args.extend_from_slice(extra);
            irr_ok(work.path(), &args);
        };
        let out = format!("{integrator}.exr");
        render(&out, &["--aov", "emitted,direct,indirect"]);
        let exr = Exr::read(&work.path().join(&out));
        assert_eq!((exr.width, exr.height), (12, 12));
        let mut indirect = 0.0f32;
        for c in ["R", "G", "B"] {
            let colour = exr.channel(c);
            let parts = ["emitted", "direct", "indirect"].map(|p| exr.channel(&format!("{p}.{c}")));
            for (i, &l) in colour.iter().enumerate() {
                let sum = parts[0][i] + parts[1][i] + parts[2][i];
                // All parts ≥ 0. Per sample the colour is fl(fl(e + d) + i), within 2u of the
                // exact sum; the f64 sums add ~spp·2⁻⁵³; the colour and each part's mean round
                // once (u each, relative to at most the total); the sum here rounds twice (2u):
                // under 6u of the total, so 8u bounds it.
                assert!(
                    (sum - l).abs() <= 8.0 * U * l.max(sum),
                    "{integrator} {c}[{i}]: {sum} vs {l}"
                );
                indirect = indirect.max(parts[2][i]);
            }
        }
        assert!(indirect > 0.0, "{integrator}: no indirect light anywhere");
        assert_eq!(exr.text("irr.integrator"), integrator);
        // Without AOVs, and on one thread, the colour is the same to the last bit.
        let plain = format!("{integrator}-plain.exr");
        render(&plain, &["--threads", "1"]);
        let plain = Exr::read(&work.path().join(&plain));
        assert_eq!(plain.names(), ["B", "G", "R"]);
        for c in ["R", "G", "B"] {
            let bits = |e: &Exr| e.channel(c).iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&plain), bits(&exr), "{integrator} {c}");
        }
    }
}

/// Bad options are one-line errors that say what is wrong, never a panic, and write nothing.
#[test]
fn bad_options_are_clear_errors() {
    let scenes = temp();
    let one = write_plane(
        scenes.path(),
        "one",
        r#"[{"type":"perspective","perspective":{"yfov":0.5,"znear":0.01}}]"#,
        r#"[{"mesh":0,"children":[1]},{"name":"cam","camera":0,"translation":[0,0,2]}]"#,
        "[0]",
    );
    let one = one.to_string_lossy().into_owned();
    let work = temp();
    let cases: [(&[&str], &str); 8] = [
        (
            &["--aov", "albedo,foo"],
            "unknown AOV 'foo'; the valid ones are albedo, normal, depth, emitted, direct, indirect",
        ),
        (
            &["--camera", "7"],
            "error: --camera: there is no camera 7: ",
        ),
        (
            &["--width", "0"],
            "error: --width: must be between 1 and 16384, got 0",
        ),
        (&["--camera", "-1"], "invalid value '-1' for '--camera <N>'"),
        (
            &["--debug-pixel", "-1,0"],
            "invalid value '-1,0' for '--debug-pixel <X,Y>': '-1' in '-1,0': pixel coordinates start at 0",
        ),
        (
            &["--debug-pixel", "3,-2", "--width", "8"],
            "'-2' in '3,-2': pixel coordinates start at 0",
        ),
        (
            &["--debug-pixel", "8,0", "--width", "8", "--height", "8"],
            "error: --debug-pixel: pixel (8, 0) is outside the 8×8 image",
        ),
        (
            &["--cache", "c.irrc", "--integrator", "path"],
            "error: --cache: a persistent cache works with --integrator ic only",
        ),
    ];
    for (options, expected) in cases {
        let mut args = vec![one.as_str(), "--spp", "1"];
        args.extend(options);
        let out = irr(work.path(), &args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{options:?} succeeded");
        assert!(stderr.contains(expected), "{options:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{options:?}: {stderr}");
        assert!(
            std::fs::read_dir(work.path()).is_ok_and(|mut d| d.next().is_none()),
            "{options:?} left files behind"
        );
    }
    // The camera error says how many cameras the file has, and names them.
    let out = irr(work.path(), &[&one, "--camera", "7"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("has 1 perspective camera, numbered from 0 (0: node 1 \"cam\")"),
        "{stderr}"
    );
}

/// Runs `irr args…` in `cwd` and returns its output, or panics if it runs for longer than a
/// minute (a hang: the process is killed).
fn irr_within_a_minute(cwd: &Path, args: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_irr"))
        .args(args)
        .current_dir(cwd)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run irr: {e}"));
    let start = std::time::Instant::now();
    while child.try_wait().ok().flatten().is_none() {
        if start.elapsed() > std::time::Duration::from_secs(60) {
            let _ = child.kill();
            panic!("irr {args:?} hung");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child
        .wait_with_output()
        .unwrap_or_else(|e| panic!("cannot read irr's output: {e}"))
}

/// `--cache FILE` keeps the cache for the next render of the same scene, camera, size, settings
/// and seed: read back, the image is the same bit for bit and nothing is rebuilt. Any other
/// scene (another byte in its buffer file), camera, size, setting, background or seed is
/// refused with an error naming the file, before any image is written; so is a corrupt file.
#[test]
fn a_cache_file_serves_only_the_render_it_was_made_for() {
    let scenes = temp();
    let scene = two_camera_plane(scenes.path());
    let scene = scene.to_string_lossy().into_owned();
    let work = temp();
    let base = [
        ("--width", "16"),
        ("--height", "12"),
        ("--spp", "1"),
        ("--strata", "4x8"),
        ("--background", "1,1,1"),
        ("--cache", "plane.irrc"),
    ];
    // The base options, each replaced by the one of the same name in `extra` if there is one.
    let run = |extra: &[&str], out: &str| {
        let mut args = vec![scene.as_str()];
        for (option, value) in base {
            if !extra.contains(&option) {
                args.extend([option, value]);
            }
        }
        args.extend(extra);
        args.extend(["-o", out]);
        irr_within_a_minute(work.path(), &args)
    };
    let first = run(&[], "a.exr");
    let stderr = String::from_utf8_lossy(&first.stderr);
    assert!(first.status.success(), "{stderr}");
    assert!(work.path().join("plane.irrc").is_file());
    let second = run(&[], "b.exr");
    let stderr = String::from_utf8_lossy(&second.stderr);
    assert!(second.status.success(), "{stderr}");
    assert!(stderr.contains("records from plane.irrc"), "{stderr}");
    assert!(
        stderr.contains("no construction pass") && !stderr.contains("cache: "),
        "rebuilt: {stderr}"
    );
    let (a, b) = (
        Exr::read(&work.path().join("a.exr")),
        Exr::read(&work.path().join("b.exr")),
    );
    for c in ["R", "G", "B"] {
        let bits = |e: &Exr| e.channel(c).iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a), bits(&b), "channel {c}");
    }
    let refused = |extra: &[&str], why: &str| {
        let out = run(extra, "refused.exr");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{extra:?} was accepted");
        assert!(
            stderr.contains("plane.irrc") && stderr.contains(why),
            "{extra:?}: {stderr}"
        );
        assert!(
            !work.path().join("refused.exr").exists(),
            "{extra:?} wrote an image"
        );
    };
    let stranger = "another scene, camera, image size, cache setting or seed";
    refused(&["--camera", "1"], stranger);
    refused(&["--width", "20"], stranger);
    refused(&["--error", "2"], stranger);
    refused(&["--strata", "4x12"], stranger);
    refused(&["--background", "1,1,0.5"], stranger);
    refused(&["--seed", "1"], stranger);
    // Another scene: the same .gltf, one byte of its buffer file changed (a vertex moved).
    let bin = scenes.path().join("plane.bin");
    let original = std::fs::read(&bin).unwrap_or_else(|e| panic!("{e}"));
    let mut moved = original.clone();
    moved[0] ^= 1;
    std::fs::write(&bin, &moved).unwrap_or_else(|e| panic!("{e}"));
    refused(&[], stranger);
    std::fs::write(&bin, &original).unwrap_or_else(|e| panic!("{e}"));
    // A corrupt file: one bit of a leak-guard entry (after the 24-byte header and the first
    // level's record count) flipped, which the checksum over the whole file catches.
    let file = work.path().join("plane.irrc");
    let mut bytes = std::fs::read(&file).unwrap_or_else(|e| panic!("{e}"));
    bytes[32 + 3] ^= 0x40;
    std::fs::write(&file, &bytes).unwrap_or_else(|e| panic!("{e}"));
    refused(&[], "checksum mismatch");
}

/// A `--cache` that names a FIFO is refused at once, never waited on; one in a folder that
/// cannot exist (under a regular file) is refused before rendering, naming the option.
#[test]
fn a_cache_path_that_cannot_be_used_is_refused_before_rendering() {
    let work = temp();
    let cornell = cornell();
    let cornell = cornell.to_string_lossy().into_owned();
    let small = [
        cornell.as_str(),
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
    ];
    let made = Command::new("mkfifo")
        .arg(work.path().join("fifo"))
        .status()
        .is_ok_and(|s| s.success());
    if made {
        let mut args = small.to_vec();
        args.extend(["--cache", "fifo", "-o", "a.exr"]);
        let out = irr_within_a_minute(work.path(), &args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{stderr}");
        assert!(
            stderr.contains("fifo") && stderr.contains("FIFO"),
            "{stderr}"
        );
        assert!(!work.path().join("a.exr").exists());
    }
    std::fs::write(work.path().join("file"), b"x").unwrap_or_else(|e| panic!("{e}"));
    let mut args = small.to_vec();
    args.extend(["--cache", "file/cache.irrc", "-o", "b.exr"]);
    let out = irr_within_a_minute(work.path(), &args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("--cache") && stderr.contains("file/cache.irrc"),
        "{stderr}"
    );
    assert!(!stderr.contains("rendered"), "it rendered first: {stderr}");
    assert!(!work.path().join("b.exr").exists());
}

/// relMSE of `x` against `r`: the mean over pixels and channels of (x − r)² / (r² + 0.01).
#[cfg(feature = "denoise")]
fn rel_mse(x: &Exr, r: &Exr) -> f64 {
    let mut sum = 0.0f64;
    for c in ["R", "G", "B"] {
        for (x, r) in x.channel(c).iter().zip(r.channel(c)) {
            let (x, r) = (f64::from(*x), f64::from(*r));
            sum += (x - r) * (x - r) / (r * r + 0.01);
        }
    }
    sum / (3 * x.width * x.height) as f64
}

/// In a build without the denoiser, `--denoise` is refused before anything is loaded, with the
/// way to get one, and nothing is written.
#[cfg(not(feature = "denoise"))]
#[test]
fn denoise_without_the_feature_is_a_clear_error() {
    let work = temp();
    let scene = cornell().to_string_lossy().into_owned();
    let out = irr(work.path(), &[&scene, "--denoise", "--spp", "1"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.starts_with("error: --denoise: this build of irr has no denoiser: install"),
        "{stderr}"
    );
    assert!(stderr.contains("pip install") && stderr.contains("--features denoise"));
    assert!(
        !stderr.contains("loading") && !stderr.contains("rendered"),
        "{stderr}"
    );
    assert!(std::fs::read_dir(work.path()).is_ok_and(|mut d| d.next().is_none()));
}

/// `--denoise` on the Cornell box (64², path tracer, 8 spp): the colour is denoised, the raw
/// colour is kept as `noisy.R/G/B` bit for bit the image the same render writes without
/// `--denoise`, the albedo and normal the denoiser read are written too, and the header says
/// so. Against a 1024-spp reference of another seed, the denoised relMSE is below the raw
/// one's by more than 2×: measured 4.03–7.09× over seeds 1–12 (OIDN 2.5.1, AVX-512 Xeon; raw
/// relMSE 1.9–2.2e-2); the bound is half the least of them. The reference's own relMSE (about
/// 2e-2 × 8/1024 = 1.6e-4) is under 5 % of the denoised error it is compared with.
#[cfg(feature = "denoise")]
#[test]
fn denoise_removes_most_of_the_noise_and_keeps_the_raw_colour() {
    let work = temp();
    let scene = cornell().to_string_lossy().into_owned();
    let common = ["--integrator", "path", "--width", "64"];
    let render = |name: &str, extra: &[&str]| {
        let mut args = vec![scene.as_str()];
        args.extend(common);
        args.extend(extra);
        args.extend(["-o", name]);
        irr_ok(work.path(), &args);
        Exr::read(&work.path().join(name))
    };
    let reference = render("reference.exr", &["--spp", "1024", "--seed", "77"]);
    let raw = render("raw.exr", &["--spp", "8", "--seed", "1"]);
    let denoised = render("denoised.exr", &["--spp", "8", "--seed", "1", "--denoise"]);
    for c in ["R", "G", "B"] {
        assert_eq!(denoised.channel(&format!("noisy.{c}")), raw.channel(c));
    }
    for name in ["albedo.R", "normal.X"] {
        assert!(
            denoised.channels.contains_key(name),
            "{:?}",
            denoised.names()
        );
    }
    assert!(
        denoised
            .text("irr.settings")
            .contains("denoised by Intel Open Image Denoise")
    );
    let (before, after) = (rel_mse(&raw, &reference), rel_mse(&denoised, &reference));
    assert!(
        before > 2.0 * after,
        "raw relMSE {before:.3e}, denoised {after:.3e}"
    );
}

/// The test plane seen from a camera (node 1, looking down −z, yfov 0.5) whose translation an
/// animation moves from z = 2 to z = 5 between 0 and 1 s (LINEAR), in `dir/walk.gltf`; with
/// `times` other than (0, 1) for the bad-input cases.
fn animated_plane(dir: &Path, times: [f32; 2]) -> PathBuf {
    let h = 100.0f32;
    let positions = [[-h, -h, 0.0], [h, -h, 0.0], [h, h, 0.0], [-h, h, 0.0]];
    let indices = [0u32, 1, 2, 0, 2, 3];
    let translations = [[0.0f32, 0.0, 2.0], [0.0, 0.0, 5.0]];
    let mut bin: Vec<u8> = positions
        .iter()
        .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
        .collect();
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    bin.extend(times.iter().flat_map(|t| t.to_le_bytes()));
    bin.extend(
        translations
            .iter()
            .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes())),
    );
    std::fs::write(dir.join("walk.bin"), &bin).unwrap_or_else(|e| panic!("{e}"));
    let [r, g, b] = ALBEDO;
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"mesh":0}},{{"name":"walker","camera":0,"translation":[0,0,2]}}],
        "cameras":[{{"type":"perspective","perspective":{{"yfov":0.5,"znear":0.01}}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[{r},{g},{b},1],"metallicFactor":0}}}}],
        "animations":[{{"channels":[{{"sampler":0,"target":{{"node":1,"path":"translation"}}}}],
          "samplers":[{{"input":2,"output":3,"interpolation":"LINEAR"}}]}}],
        "buffers":[{{"byteLength":{},"uri":"walk.bin"}}],
        "bufferViews":[{{"buffer":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":24}},
          {{"buffer":0,"byteOffset":72,"byteLength":8}},{{"buffer":0,"byteOffset":80,"byteLength":24}}],
        "accessors":[
          {{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-{h},-{h},0],"max":[{h},{h},0]}},
          {{"bufferView":1,"componentType":5125,"count":6,"type":"SCALAR"}},
          {{"bufferView":2,"componentType":5126,"count":2,"type":"SCALAR","min":[{}],"max":[{}]}},
          {{"bufferView":3,"componentType":5126,"count":2,"type":"VEC3"}}]}}"#,
        bin.len(),
        times[0],
        times[1]
    );
    let path = dir.join("walk.gltf");
    std::fs::write(&path, json).unwrap_or_else(|e| panic!("{e}"));
    path
}

/// `--frames 0..3 --fps 2` renders frames 0, 1, 2 at 0, 0.5 and 1 s to `walk.0000.exr` … (the
/// `####` of `-o`): the camera moves from 2 m to 3.5 m and 5 m above the plane, so each pixel's
/// depth (along the same camera-space ray, as the camera only translates) scales by 1.75 and
/// 2.5, up to the f32 rounding of the hit distance (a few ulps: asserted at 8·2⁻²⁴ relative).
/// `--frame 1` alone renders frame 1's image bit for bit; without `####` the frame number goes
/// before the extension. Bad ranges, rates and combinations are refused up front.
#[test]
fn frames_follow_the_camera_animation() {
    let dir = temp();
    let scene = animated_plane(dir.path(), [0.0, 1.0]);
    let scene = scene.to_string_lossy().into_owned();
    let common = [
        "--integrator",
        "path",
        "--spp",
        "1",
        "--width",
        "8",
        "--height",
        "8",
        "--aov",
        "depth",
        "--fps",
        "2",
    ];
    let mut args = vec![scene.as_str(), "--frames", "0..3", "-o", "walk.####.exr"];
    args.extend(common);
    irr_ok(dir.path(), &args);
    let frames: Vec<Exr> = (0..3)
        .map(|f| Exr::read(&dir.path().join(format!("walk.{f:04}.exr"))))
        .collect();
    let depth = |e: &Exr| e.channel("depth.Z").to_vec();
    for (f, ratio) in [(1, 1.75f32), (2, 2.5)] {
        for (a, b) in depth(&frames[0]).iter().zip(depth(&frames[f])) {
            assert!(
                (b / a - ratio).abs() <= 8.0 * U * ratio,
                "frame {f}: {b} / {a}"
            );
        }
    }
    let mut args = vec![scene.as_str(), "--frame", "1", "-o", "one.exr"];
    args.extend(common);
    irr_ok(dir.path(), &args);
    let one = Exr::read(&dir.path().join("one.exr"));
    for name in ["R", "G", "B", "depth.Z"] {
        assert_eq!(one.channel(name), frames[1].channel(name), "{name}");
    }
    let mut args = vec![scene.as_str(), "--frames", "4..=4", "-o", "plain.exr"];
    args.extend(common);
    irr_ok(dir.path(), &args);
    assert!(dir.path().join("plain.0004.exr").exists());
    assert!(dir.path().join("plain.0004.png").exists());
    for (bad, says) in [
        (vec!["--frames", "3..3"], "--frames"),
        (vec!["--shared-cache"], "--shared-cache"),
        (
            vec!["--frames", "0..2", "--shared-cache", "--integrator", "path"],
            "--shared-cache",
        ),
        (
            vec!["--frames", "0..2", "--shared-cache", "--cache-every", "0"],
            "--cache-every",
        ),
        (vec!["--frames", "0..2", "--fps", "0"], "--fps"),
        (vec!["--frames", "0..2", "--cache", "c.bin"], "--cache"),
        (
            vec!["--frames", "0..2", "--debug-pixel", "1,1"],
            "--debug-pixel",
        ),
        (vec!["--frames", "0..2", "--frame", "1"], "--frame"),
    ] {
        let mut args = vec![scene.as_str()];
        args.extend(bad.iter().copied());
        let out = irr(dir.path(), &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(says),
            "{bad:?}: {err}"
        );
    }
    // One cache for the sequence, from frames 0 and 2's views (every 2nd and the last).
    let shared = irr(
        dir.path(),
        &[
            &scene,
            "--frames",
            "0..3",
            "--shared-cache",
            "--cache-every",
            "2",
            "--spp",
            "1",
            "--width",
            "8",
            "--height",
            "8",
            "--background",
            "1,1,1",
            "-o",
            "shared.exr",
        ],
    );
    let err = String::from_utf8_lossy(&shared.stderr);
    assert!(shared.status.success(), "{err}");
    assert!(
        err.contains("shared cache from 2 key frames (0, 2)"),
        "{err}"
    );
    for f in 0..3 {
        assert!(dir.path().join(format!("shared.{f:04}.exr")).exists());
    }
    // The same animation on the plane's node instead: the scene is not static, and a shared
    // cache is refused (the frames alone render, with the plane in its rest pose).
    let moving = temp();
    let file = animated_plane(moving.path(), [0.0, 1.0]);
    let json = std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(
        &file,
        json.replace(r#""target":{"node":1"#, r#""target":{"node":0"#),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let file = file.to_string_lossy().into_owned();
    let out = irr(
        moving.path(),
        &[&file, "--frames", "0..2", "--shared-cache", "--spp", "1"],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("move meshes or lights"),
        "{err}"
    );
    // Key times that do not increase: an error naming the animation's channel.
    let bad = temp();
    let scene = animated_plane(bad.path(), [1.0, 1.0]);
    let out = irr(bad.path(), &[&scene.to_string_lossy(), "--frame", "0"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("walk.gltf") && err.contains("animation 0 channel 0"),
        "{err}"
    );
    assert!(err.contains("increase strictly"), "{err}");
}

/// A farm's route to a walkthrough gives one process's frames bit for bit: the shared cache's
/// shards built by separate processes (`--shard I`, in any order), joined by `irr cache merge`
/// (named in any order), read by a process that renders some of the frames on another thread
/// count. Files of the wrong kind or for other settings are refused with what to do.
#[test]
fn shards_merged_give_the_single_process_frames() {
    let dir = temp();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/cornell-dolly.gltf");
    let scene = scene.to_string_lossy().into_owned();
    let tiny = [
        scene.as_str(),
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "1",
        "--strata",
        "4x16",
        "--light-cache-paths",
        "4096",
    ];
    let mut common = tiny.to_vec();
    common.extend(["--shared-cache", "--cache-every", "1"]);
    let run = |extra: &[&str]| {
        let mut args = common.clone();
        args.extend(extra);
        irr(dir.path(), &args)
    };
    let ok = |extra: &[&str]| {
        let out = run(extra);
        assert!(
            out.status.success(),
            "{extra:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let fails = |extra: &[&str], says: &str| {
        let out = run(extra);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(says),
            "{extra:?}: {err}"
        );
    };
    ok(&[
        "--frames",
        "0..4",
        "--shards",
        "2",
        "-o",
        "one/w.####.exr",
        "--threads",
        "2",
    ]);
    for i in ["1", "0"] {
        let file = format!("s{i}.irrc");
        ok(&[
            "--frames", "0..4", "--shards", "2", "--shard", i, "--cache", &file,
        ]);
    }
    assert!(
        !dir.path().join("w.0000.exr").exists(),
        "--shard rendered a frame"
    );
    let merge = |shards: &[&str]| {
        let mut args = vec!["cache", "merge"];
        args.extend(shards);
        args.extend(["-o", "walk.irrc"]);
        irr(dir.path(), &args)
    };
    let out = merge(&["s1.irrc", "s0.irrc"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    ok(&[
        "--frames",
        "1..3",
        "--cache",
        "walk.irrc",
        "-o",
        "farm/w.####.exr",
        "--threads",
        "1",
    ]);
    for f in [1, 2] {
        let name = format!("w.{f:04}.exr");
        let (a, b) = (
            Exr::read(&dir.path().join("one").join(&name)),
            Exr::read(&dir.path().join("farm").join(&name)),
        );
        for c in ["R", "G", "B"] {
            let bits = |e: &Exr| e.channel(c).iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a), bits(&b), "frame {f}, channel {c}");
        }
    }
    let out = merge(&["s0.irrc"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("shards 1 of 2 are missing"),
        "{err}"
    );
    fails(
        &["--frames", "0..4", "--cache", "s0.irrc"],
        "irr cache merge",
    );
    fails(
        &[
            "--frames", "0..4", "--shards", "2", "--shard", "1", "--cache", "s0.irrc",
        ],
        "a file of its own",
    );
    fails(
        &["--frames", "0..4", "--cache", "walk.irrc", "--seed", "9"],
        "another scene",
    );
    fails(
        &["--frames", "0..4", "--shards", "2", "--shard", "0"],
        "--cache FILE",
    );
    fails(
        &[
            "--frames", "0..4", "--shards", "2", "--shard", "2", "--cache", "x.irrc",
        ],
        "--shard",
    );
    fails(&["--frames", "0..4", "--shards", "5"], "only 4 key frames");
    fails(
        &["--frames", "0..4", "--cache", "walk.irrc", "--camera", "1"],
        "camera 0's path",
    );
    fails(
        &["--frames", "0..4", "--radiance-order", "2"],
        "--radiance-order 0",
    );
    // A view's cache is not a sequence's.
    let mut view = tiny.to_vec();
    view.extend(["--cache", "view.irrc", "-o", "view.exr"]);
    irr_ok(dir.path(), &view);
    fails(
        &["--frames", "0..4", "--cache", "view.irrc"],
        "one view's cache",
    );
}
