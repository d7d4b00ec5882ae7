//! Bad input, through the library functions that `cargo xtask render` calls: every case gives a
//! one-line error naming the file (or option) and the problem, never a panic, never a partial
//! output, and leaves an earlier output intact.

use crate::support::{asset, read, temp, write};
use glam::Vec3;
use irr_integrator::{PathSettings, PathTracer};
use irr_render::{
    Image, RenderError, RenderSettings, check_output, load_scene, render, write_exr_and_png,
};
use std::path::{Path, PathBuf};

/// Loads `path`, expects an error, and checks that its message is one line that names the
/// file and contains every one of `problem`.
fn expect_load_error(path: &Path, problem: &[&str]) -> String {
    let message = match load_scene(path) {
        Ok(_) => panic!("{} loaded, but it should not", path.display()),
        Err(e) => e.to_string(),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    assert!(!message.contains('\n'), "not one line: {message}");
    assert!(message.contains(&name), "does not name {name}: {message}");
    for p in problem {
        assert!(message.contains(p), "does not say '{p}': {message}");
    }
    message
}

/// A copy of the Cornell box (its .gltf and .bin) in `dir`, the JSON passed through `edit`.
fn cornell_copy(dir: &Path, edit: impl FnOnce(&mut serde_json::Value)) -> PathBuf {
    let mut json: serde_json::Value =
        serde_json::from_slice(&read(&asset("cornell-box.gltf"))).unwrap_or_else(|e| panic!("{e}"));
    edit(&mut json);
    let path = dir.join("cornell-box.gltf");
    write(
        &path,
        serde_json::to_vec(&json).unwrap_or_else(|e| panic!("{e}")),
    );
    write(
        &dir.join("cornell-box.bin"),
        read(&asset("cornell-box.bin")),
    );
    path
}

#[test]
fn missing_file() {
    let dir = temp();
    let e = expect_load_error(&dir.path().join("nowhere.gltf"), &["cannot read"]);
    assert!(e.contains("No such file"), "{e}");
}

#[test]
fn truncated_gltf_and_glb() {
    let dir = temp();
    let gltf = read(&asset("cornell-box.gltf"));
    let path = dir.path().join("half.gltf");
    write(&path, &gltf[..gltf.len() / 2]);
    expect_load_error(&path, &["not a valid glTF 2.0 file", "EOF"]);
    let glb = read(&asset("furnace.glb"));
    for len in [0, 11, 12, 30, glb.len() / 2, glb.len() - 1] {
        let path = dir.path().join(format!("cut{len}.glb"));
        write(&path, &glb[..len]);
        let problem: &[&str] = if len == 0 {
            &["empty"]
        } else {
            &["not a valid glTF 2.0 file"]
        };
        expect_load_error(&path, problem);
    }
}

/// Every single-byte corruption of a .glb at a spread of positions is either refused with a
/// one-line error or loads; it never panics. (Bytes in the binary chunk may just move
/// vertices, which is not an error.)
#[test]
fn corrupt_glb_never_panics() {
    let dir = temp();
    let glb = read(&asset("furnace.glb"));
    let path = dir.path().join("corrupt.glb");
    for (k, pos) in (0..glb.len()).step_by(37).enumerate() {
        let mut bytes = glb.clone();
        bytes[pos] ^= [0xff, 0x01, 0x80, 0x20][k % 4];
        write(&path, &bytes);
        if let Err(e) = load_scene(&path) {
            let m = e.to_string();
            assert!(m.contains("corrupt.glb") && !m.contains('\n'), "{m}");
        }
    }
    // And a text file that is not JSON at all.
    let path = dir.path().join("garbage.gltf");
    write(&path, b"\x00\x01 this is not glTF");
    expect_load_error(&path, &["not a valid glTF 2.0 file", "JSON"]);
}

#[test]
fn buffer_uri_that_points_nowhere() {
    let dir = temp();
    let path = dir.path().join("lonely.gltf");
    write(&path, read(&asset("cornell-box.gltf")));
    expect_load_error(&path, &["buffer 0", "cornell-box.bin", "points nowhere"]);
    let path = cornell_copy(dir.path(), |j| {
        j["buffers"][0]["uri"] = "https://example.com/x.bin".into()
    });
    expect_load_error(&path, &["buffer 0", "scheme 'https:'"]);
    let path = cornell_copy(dir.path(), |j| {
        j["buffers"][0]["uri"] = "data:application/octet-stream;base64,@@@".into()
    });
    expect_load_error(&path, &["buffer 0", "invalid character"]);
}

#[test]
fn accessor_out_of_range() {
    let dir = temp();
    let path = cornell_copy(dir.path(), |j| j["accessors"][0]["count"] = 1000.into());
    expect_load_error(&path, &["accessor 0", "out of range"]);
    let path = cornell_copy(dir.path(), |j| {
        j["bufferViews"][0]["byteOffset"] = 1_000_000.into()
    });
    expect_load_error(&path, &["bufferView 0", "buffer 0 has 960 bytes"]);
    let path = cornell_copy(dir.path(), |j| j["buffers"][0]["byteLength"] = 5000.into());
    // The file is inside the scene's folder, so its size may be named.
    expect_load_error(
        &path,
        &["buffer 0", "which has 960 bytes", "byteLength says 5000"],
    );
    let path = cornell_copy(dir.path(), |j| {
        j["meshes"][0]["primitives"][0]["indices"] = 99.into()
    });
    expect_load_error(&path, &["not a valid glTF 2.0 file", "indices"]);
}

#[test]
fn nan_and_huge_coordinates() {
    let dir = temp();
    for (name, value, problem) in [
        ("nan", f32::NAN, "non-finite"),
        ("inf", f32::NEG_INFINITY, "non-finite"),
        ("huge", 1e30, "beyond"),
    ] {
        let sub = dir.path().join(name);
        std::fs::create_dir(&sub).unwrap_or_else(|e| panic!("{e}"));
        let path = cornell_copy(&sub, |_| {});
        // The floor's first vertex is the first 12 bytes of the buffer: set its x.
        let mut bin = read(&sub.join("cornell-box.bin"));
        bin[..4].copy_from_slice(&value.to_le_bytes());
        write(&sub.join("cornell-box.bin"), bin);
        expect_load_error(&path, &["vertex 0", problem]);
    }
}

#[test]
fn a_scene_without_emitters_warns_that_the_image_will_be_black() {
    let loaded = load_scene(&asset("ao-plane.gltf")).unwrap_or_else(|e| panic!("{e}"));
    let warning = loaded
        .warnings
        .iter()
        .find(|w| w.feature == "no-emitter")
        .unwrap_or_else(|| panic!("no warning in {:?}", loaded.warnings));
    let line = warning.to_string();
    assert!(
        line.contains("ao-plane.gltf") && line.contains("the image will be black"),
        "{line}"
    );
    assert_eq!(loaded.scene.emitter_count(), 0);
    // And it is: the path tracer finds no light anywhere.
    let s = RenderSettings {
        width: 4,
        height: 4,
        spp: 2,
        ..RenderSettings::default()
    };
    let pt = PathTracer::new(PathSettings::default());
    let out = render(&loaded.scene, &loaded.camera_for(4, 4), &pt, &s, false)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(out.image.pixels().iter().all(|p| *p == Vec3::ZERO));
}

#[test]
fn zero_or_negative_size_or_spp() {
    for (w, h, spp, option, value) in [
        (0, 8, 1, "--width", "0"),
        (-8, 8, 1, "--width", "-8"),
        (8, 0, 1, "--height", "0"),
        (8, -1, 1, "--height", "-1"),
        (8, 8, 0, "--spp", "0"),
        (8, 8, -4, "--spp", "-4"),
    ] {
        let e = RenderSettings::from_options(w, h, spp, 0, 0)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_else(|| panic!("{option} {value} accepted"));
        assert_eq!(
            e,
            format!(
                "{option}: must be between 1 and {}, got {value}",
                if option == "--spp" {
                    u32::MAX as i64
                } else {
                    16384
                }
            )
        );
    }
    // Settings built by hand are checked by render() too.
    let loaded = load_scene(&asset("ao-plane.gltf")).unwrap_or_else(|e| panic!("{e}"));
    let pt = PathTracer::new(PathSettings::default());
    for s in [
        RenderSettings {
            width: 0,
            ..RenderSettings::default()
        },
        RenderSettings {
            spp: 0,
            ..RenderSettings::default()
        },
    ] {
        let r = render(&loaded.scene, &loaded.camera_for(1, 1), &pt, &s, false);
        assert!(matches!(r, Err(RenderError::Setting { .. })));
    }
}

fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{e}"))
        .map(|e| {
            e.map(|e| e.file_name().to_string_lossy().into_owned())
                .unwrap_or_default()
        })
        .collect();
    names.sort();
    names
}

#[test]
fn unwritable_output_leaves_no_partial_file_and_keeps_the_earlier_one() {
    let dir = temp();
    let out = dir.path().join("render.exr");
    let mut first = Image::new(2, 2);
    first.set(1, 0, Vec3::new(1.0, 2.0, 3.0));
    write_exr_and_png(&first, &out, 0.0).unwrap_or_else(|e| panic!("{e}"));
    let (exr_before, png_before) = (read(&out), read(&dir.path().join("render.png")));
    let before = listing(dir.path());

    // A path below a regular file, a non-EXR name, an EXR whose PNG place is a folder.
    let blocker = dir.path().join("blocker");
    write(&blocker, b"x");
    std::fs::create_dir(dir.path().join("taken.png")).unwrap_or_else(|e| panic!("{e}"));
    for (bad, problem) in [
        (blocker.join("render.exr"), "cannot create folder"),
        (dir.path().join("render.tiff"), ".exr"),
        (dir.path().join("taken.exr"), "is a folder"),
    ] {
        for result in [
            check_output(&bad).map(drop),
            write_exr_and_png(&first, &bad, 0.0).map(drop),
        ] {
            let e = result
                .err()
                .map(|e| e.to_string())
                .unwrap_or_else(|| panic!("{} accepted", bad.display()));
            let name = bad
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            assert!(
                e.contains(&name) && e.contains(problem) && !e.contains('\n'),
                "{e}"
            );
        }
    }
    // A failed load before rendering: nothing is written either.
    assert!(load_scene(&dir.path().join("missing.gltf")).is_err());

    // The earlier output is intact and nothing else appeared (no temporary files), apart from
    // the two obstacles made above.
    assert_eq!(read(&out), exr_before);
    assert_eq!(read(&dir.path().join("render.png")), png_before);
    let mut expected = before;
    expected.extend(["blocker".to_string(), "taken.png".to_string()]);
    expected.sort();
    assert_eq!(listing(dir.path()), expected);
}
