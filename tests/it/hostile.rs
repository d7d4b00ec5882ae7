//! The scene loader as an attack surface. Each test is one of the hostile files or
//! options that once read outside the scene's folder, read without bound, allocated without
//! bound, panicked, or rendered wrong; every file is generated here.

use crate::support::{asset, read, temp, write};
use glam::{Vec2, Vec3};
use irr_integrator::{PathSettings, PathTracer};
use irr_render::{LoadOptions, RenderSettings, load_gltf, load_scene, load_scene_with, render};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::time::Duration;

fn mkdir(path: &Path) {
    std::fs::create_dir_all(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

/// The Cornell box's JSON, edited by `edit`, written as `dir/scene.gltf` (the .bin is not
/// copied: each test puts it where it wants).
fn cornell_json(dir: &Path, edit: impl FnOnce(&mut Value)) -> PathBuf {
    let mut json: Value =
        serde_json::from_slice(&read(&asset("cornell-box.gltf"))).unwrap_or_else(|e| panic!("{e}"));
    edit(&mut json);
    let path = dir.join("scene.gltf");
    write(
        &path,
        serde_json::to_vec(&json).unwrap_or_else(|e| panic!("{e}")),
    );
    path
}

/// Runs `f` on another thread and fails the test if it does not finish within 20 s (a hang is
/// what some of these files used to cause; the test must fail, not hang with it).
fn within_20_s<T: Send + 'static>(what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(20))
        .unwrap_or_else(|_| panic!("{what}: still running after 20 s"))
}

/// The error of loading `path`, as one line, which must name the file and contain every one of
/// `needles`.
fn load_error(path: &Path, options: &LoadOptions, needles: &[&str]) -> String {
    let p = path.to_path_buf();
    let o = options.clone();
    let result = within_20_s(&path.display().to_string(), move || {
        load_scene_with(&p, &o).map(drop).map_err(|e| e.to_string())
    });
    let message = match result {
        Ok(()) => panic!("{} loaded, but it should not", path.display()),
        Err(e) => e,
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    assert!(!message.contains('\n'), "not one line: {message}");
    assert!(message.contains(&name), "does not name {name}: {message}");
    for n in needles {
        assert!(message.contains(n), "does not say '{n}': {message}");
    }
    message
}

/// A buffer URI that is absolute, climbs with `..` (plain or percent-encoded), or is a
/// symbolic link out of the folder is refused before the file is read or even looked at; the
/// message quotes none of the file's bytes and not its size. `--asset-root` widens the folder.
#[test]
fn buffer_uris_cannot_leave_the_scene_folder() {
    let dir = temp();
    let scene_dir = dir.path().join("scene");
    mkdir(&scene_dir);
    // A "secret" beside the scene's folder: a valid copy of the Cornell box's buffer (so that,
    // if it were read, the scene would load) whose size, 960, must not appear in any message.
    let secret = dir.path().join("secret.bin");
    write(&secret, read(&asset("cornell-box.bin")));
    let default = LoadOptions::default();
    for uri in [
        secret.display().to_string(),
        "../secret.bin".to_string(),
        "%2e%2e/secret.bin".to_string(),
        "%2E%2E%2Fsecret.bin".to_string(),
        "sub/../../secret.bin".to_string(),
        "/proc/self/environ".to_string(),
        "../../../../../../../../proc/self/environ".to_string(),
        "/etc/shadow".to_string(),
    ] {
        let path = cornell_json(&scene_dir, |j| j["buffers"][0]["uri"] = uri.clone().into());
        let e = load_error(&path, &default, &["buffer 0", "outside the folder"]);
        assert!(!e.contains("960"), "{uri}: the message names a size: {e}");
    }
    // Percent-encoded and plain `..` that stay inside the folder are fine.
    mkdir(&scene_dir.join("sub"));
    write(&scene_dir.join("box.bin"), read(&asset("cornell-box.bin")));
    let path = cornell_json(&scene_dir, |j| {
        j["buffers"][0]["uri"] = "sub/%2e%2e/box.bin".into()
    });
    load_scene(&path).unwrap_or_else(|e| panic!("{e}"));

    // A symbolic link inside the folder that leads out of it.
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&secret, scene_dir.join("link.bin"))
            .unwrap_or_else(|e| panic!("{e}"));
        let path = cornell_json(&scene_dir, |j| j["buffers"][0]["uri"] = "link.bin".into());
        let e = load_error(&path, &default, &["buffer 0", "symbolic link", "outside"]);
        assert!(!e.contains("960"), "{e}");
    }

    // An index accessor over the secret: refused before a byte is read, so no index value can
    // be printed.
    let path = cornell_json(&scene_dir, |j| {
        j["buffers"][0]["uri"] = "../secret.bin".into();
        j["accessors"][1]["count"] = 100_000.into();
    });
    load_error(&path, &default, &["outside the folder"]);

    // The user widens the folder: now `../secret.bin` is allowed and loads.
    let wide = LoadOptions {
        asset_root: Some(dir.path().to_path_buf()),
        ..LoadOptions::default()
    };
    let path = cornell_json(&scene_dir, |j| {
        j["buffers"][0]["uri"] = "../secret.bin".into()
    });
    load_scene_with(&path, &wide).unwrap_or_else(|e| panic!("{e}"));
    // But not beyond it.
    let path = cornell_json(&scene_dir, |j| {
        j["buffers"][0]["uri"] = "../../secret.bin".into()
    });
    load_error(&path, &wide, &["outside the folder"]);
}

/// Errors inside the allowed folder never quote the file's bytes: an index past the
/// vertex count names the entry, not the index; a bad vertex names the vertex, not its value.
#[test]
fn errors_quote_no_bytes_of_a_file() {
    let dir = temp();
    let path = cornell_json(dir.path(), |j| j["buffers"][0]["uri"] = "data.bin".into());
    // Fill the first index buffer (view 1, 12 bytes at offset 48) with 0x4141 = 16705.
    let mut bin = read(&asset("cornell-box.bin"));
    bin[48..60].fill(0x41);
    write(&dir.path().join("data.bin"), &bin);
    let e = load_error(
        &path,
        &LoadOptions::default(),
        &["index entry 0", "out of range"],
    );
    assert!(!e.contains("16705"), "{e}");
    // A vertex whose x is 1e30 (beyond irr's coordinate limit).
    let mut bin = read(&asset("cornell-box.bin"));
    bin[..4].copy_from_slice(&1.234_567e30f32.to_le_bytes());
    write(&dir.path().join("data.bin"), &bin);
    let e = load_error(&path, &LoadOptions::default(), &["vertex 0", "beyond"]);
    assert!(!e.contains("1.234"), "{e}");
}

/// A FIFO, a device or a folder as the scene or as a buffer is refused at once (never
/// opened for a blocking read), and a buffer file far larger than its `byteLength` is read only
/// as far as `byteLength` says.
#[test]
fn only_regular_files_are_read_and_only_as_far_as_needed() {
    let dir = temp();
    let default = LoadOptions::default();
    #[cfg(unix)]
    {
        let fifo = dir.path().join("pipe.gltf");
        let status = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap_or_else(|e| panic!("mkfifo: {e}"));
        assert!(status.success());
        load_error(&fifo, &default, &["cannot read", "not a regular file"]);
        let fifo_bin = dir.path().join("pipe.bin");
        let status = std::process::Command::new("mkfifo")
            .arg(&fifo_bin)
            .status()
            .unwrap_or_else(|e| panic!("mkfifo: {e}"));
        assert!(status.success());
        let path = cornell_json(dir.path(), |j| j["buffers"][0]["uri"] = "pipe.bin".into());
        load_error(&path, &default, &["buffer 0", "not a regular file"]);
        // /dev/zero and /dev/urandom, as the scene and (with the root widened to /) as buffers.
        for dev in ["/dev/zero", "/dev/urandom"] {
            load_error(Path::new(dev), &default, &["not a regular file"]);
            let path = cornell_json(dir.path(), |j| j["buffers"][0]["uri"] = dev.into());
            load_error(&path, &default, &["outside the folder"]);
            let path = cornell_json(dir.path(), |j| {
                j["buffers"][0]["uri"] = format!("../../../../../../../..{dev}").into()
            });
            let everything = LoadOptions {
                asset_root: Some(PathBuf::from("/")),
                ..LoadOptions::default()
            };
            load_error(&path, &everything, &["buffer 0", "not a regular file"]);
        }
    }
    // A folder.
    mkdir(&dir.path().join("folder.bin"));
    let path = cornell_json(dir.path(), |j| j["buffers"][0]["uri"] = "folder.bin".into());
    load_error(&path, &default, &["buffer 0", "a folder"]);

    // A 64 GiB buffer file (sparse: it takes no disk) whose byteLength says 960: read whole, it
    // would exhaust the machine's memory; read as far as byteLength, the scene loads.
    let big = dir.path().join("big.bin");
    write(&big, read(&asset("cornell-box.bin")));
    std::fs::OpenOptions::new()
        .write(true)
        .open(&big)
        .and_then(|f| f.set_len(64 << 30))
        .unwrap_or_else(|e| panic!("{e}"));
    let path = cornell_json(dir.path(), |j| j["buffers"][0]["uri"] = "big.bin".into());
    let loaded = within_20_s("64 GiB buffer", move || load_scene(&path).map(|l| l.bounds));
    assert!(loaded.is_ok(), "{loaded:?}");
}

/// A one-mesh glTF whose POSITION accessor is `accessor` (JSON), with `buffers`/`bufferViews`.
fn one_accessor_scene(dir: &Path, name: &str, accessor: Value, extra: Value) -> PathBuf {
    let mut json = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [accessor],
        "buffers": [{"byteLength": 16, "uri": "data:application/octet-stream;base64,AQAAAAAAAAAAAAAAAAAAAA=="}],
        "bufferViews": [{"buffer": 0, "byteLength": 4}, {"buffer": 0, "byteOffset": 4, "byteLength": 12}]
    });
    if let (Value::Object(j), Value::Object(e)) = (&mut json, extra) {
        j.extend(e);
    }
    let path = dir.join(name);
    write(
        &path,
        serde_json::to_vec(&json).unwrap_or_else(|e| panic!("{e}")),
    );
    path
}

/// Counts stated freely by a small file (an accessor without a buffer view, with or
/// without a sparse block) cannot make the loader allocate more than its budget: each is refused
/// with a message naming the accessor and the budget, instead of taking gigabytes or aborting.
#[test]
fn allocation_bombs_are_refused() {
    let dir = temp();
    let sparse = json!({"count": 1,
        "indices": {"bufferView": 0, "componentType": 5125},
        "values": {"bufferView": 1}});
    for (name, count) in [
        ("sparse-2-33.gltf", 1u64 << 33),
        ("sparse-2-28.gltf", 1 << 28),
        ("sparse-1e8.gltf", 100_000_000),
    ] {
        let mut accessor = json!({"componentType": 5126, "count": count, "type": "VEC3"});
        accessor["sparse"] = sparse.clone();
        let path = one_accessor_scene(dir.path(), name, accessor, json!({}));
        load_error(
            &path,
            &LoadOptions::default(),
            &["POSITION accessor 0", "MiB of memory"],
        );
    }
    // A count of 10⁸ over a real buffer view is refused by the range check, before anything is
    // allocated.
    let accessor =
        json!({"bufferView": 1, "componentType": 5126, "count": 100_000_000, "type": "VEC3"});
    let path = one_accessor_scene(dir.path(), "view-1e8.gltf", accessor, json!({}));
    load_error(
        &path,
        &LoadOptions::default(),
        &["POSITION accessor 0", "out of range"],
    );
    // The same sparse accessor with an honest count loads: the budget is not in the way.
    let accessor = json!({"componentType": 5126, "count": 3, "type": "VEC3", "sparse": sparse});
    let path = one_accessor_scene(dir.path(), "honest.gltf", accessor, json!({}));
    load_gltf(&path).unwrap_or_else(|e| panic!("{e}"));
}

/// A mesh whose accessors many primitives share (as the Khronos sample
/// MetalRoughSpheresNoTextures shares two accessors among 98 spheres) loads as one prototype
/// placed once per primitive: the 320 draws of a 40×40 grid (10⁶ triangles, 29 MB of arrays as
/// copies) hold one grid's arrays. The memory check counts the grid's BVH and the placements,
/// and a limit just below that figure refuses the file before the BVH is built.
#[test]
fn shared_accessors_load_within_the_memory_limit() {
    let dir = temp();
    let n = 40u32;
    let mut g = irr_scene::testutil::Gltf::default();
    let vertices: Vec<[f32; 3]> = (0..=n)
        .flat_map(|j| (0..=n).map(move |i| [i as f32 / n as f32, 0.0, j as f32 / n as f32]))
        .collect();
    let positions = g.vec3(&vertices);
    let normals = g.vec3(&vec![[0.0, 1.0, 0.0]; vertices.len()]);
    let indices: Vec<u32> = (0..n)
        .flat_map(|j| (0..n).map(move |i| (i, j)))
        .flat_map(|(i, j)| {
            let v = |a: u32, b: u32| b * (n + 1) + a;
            [
                v(i, j),
                v(i, j + 1),
                v(i + 1, j),
                v(i + 1, j),
                v(i, j + 1),
                v(i + 1, j + 1),
            ]
        })
        .collect();
    let indices = g.indices(&indices, 5125);
    let copies = 320;
    let primitive = format!(
        r#"{{"primitives":[{{"attributes":{{"POSITION":{positions},"NORMAL":{normals}}},"indices":{indices}}}]}}"#
    );
    let meshes = vec![primitive; copies].join(",");
    let nodes: Vec<String> = (0..copies)
        .map(|k| format!(r#"{{"mesh":{k},"translation":[{},0,0]}}"#, 1.5 * k as f32))
        .collect();
    let roots: Vec<String> = (0..copies).map(|k| k.to_string()).collect();
    let json = g.json(&format!(
        r#""scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],"meshes":[{meshes}]"#,
        roots.join(","),
        nodes.join(",")
    ));
    let path = dir.path().join("shared.gltf");
    write(&path, &json);
    let data = load_gltf(&path).unwrap_or_else(|e| panic!("{e}"));
    let grid = 2 * (n * n) as usize;
    let triangles = copies * grid;
    assert_eq!((data.meshes.len(), data.prototypes.len()), (0, 1));
    assert_eq!(data.instances.len(), copies);
    assert_eq!(data.prototypes[0].indices.len(), grid);
    // One grid's arrays (positions, normals, indices, material ids: 88 kB), not 320.
    let arrays = data.heap_bytes();
    assert!(arrays < 1 << 20, "{arrays} bytes");
    let need = data.check_memory().unwrap_or_else(|e| panic!("{e}"));
    assert!(need > arrays);
    let tight = LoadOptions {
        max_memory: Some(need - 1),
        ..LoadOptions::default()
    };
    let e = load_error(
        &path,
        &tight,
        &["memory limit", "set by --max-memory", "BVH"],
    );
    assert!(e.contains(&format!("{grid} triangles")), "{e}");
    let enough = LoadOptions {
        max_memory: Some(need),
        ..LoadOptions::default()
    };
    let loaded = load_scene_with(&path, &enough).unwrap_or_else(|e| panic!("{e}"));
    let geometry = loaded.scene.geometry();
    assert_eq!(geometry.triangle_count(), triangles);
    assert_eq!(geometry.unique_triangle_count(), grid);
}

/// A forest: one node draws a grid of 10⁴ vertices 2¹⁶ times (`EXT_mesh_gpu_instancing`,
/// 0.8 MB of translations), 6.4·10⁸ triangles and 7.9 GB of positions as copies. Placed, it
/// loads and builds under a 1 GiB limit (about 37 MB of placements); under 16 MiB its
/// placements are refused before any is made, naming the node and their count; made emissive,
/// its light sampler's bytes refuse it under 1 GiB.
#[test]
fn a_forest_of_instances_loads_and_its_placements_are_bounded() {
    let dir = temp();
    let n = 99u32;
    let mut g = irr_scene::testutil::Gltf::default();
    let vertices: Vec<[f32; 3]> = (0..=n)
        .flat_map(|j| (0..=n).map(move |i| [i as f32, 0.0, j as f32]))
        .collect();
    let positions = g.vec3(&vertices);
    let indices: Vec<u32> = (0..n)
        .flat_map(|j| (0..n).map(move |i| (i, j)))
        .flat_map(|(i, j)| {
            let v = |a: u32, b: u32| b * (n + 1) + a;
            [v(i, j), v(i, j + 1), v(i + 1, j)]
        })
        .collect();
    let indices = g.indices(&indices, 5125);
    let copies = 1usize << 16;
    let translations: Vec<[f32; 3]> = (0..copies).map(|k| [0.0, k as f32, 0.0]).collect();
    let translations = g.vec3(&translations);
    let json = g.json(&format!(
        r#""extensionsUsed":["EXT_mesh_gpu_instancing"],"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"mesh":0,"extensions":{{"EXT_mesh_gpu_instancing":{{"attributes":{{"TRANSLATION":{translations}}}}}}}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{positions}}},"indices":{indices}}}]}}]"#
    ));
    let path = dir.path().join("forest.gltf");
    write(&path, &json);
    let roomy = LoadOptions {
        max_memory: Some(1 << 30),
        ..LoadOptions::default()
    };
    let loaded = load_scene_with(&path, &roomy).unwrap_or_else(|e| panic!("{e}"));
    let geometry = loaded.scene.geometry();
    let grid = 99 * 99; // one triangle per quad
    assert_eq!(geometry.unique_triangle_count(), grid);
    assert_eq!(geometry.triangle_count(), copies * grid);
    // A ray down the column of grids (one every unit of y) meets the top one, at y = 65535.
    let ray = irr_geometry::Ray::new(Vec3::new(0.5, 65545.0, 0.25), -Vec3::Y);
    let hit = geometry
        .intersect(&ray)
        .unwrap_or_else(|| panic!("the forest was missed"));
    assert_eq!(geometry.instance_of(hit.triangle), Some(copies as u32 - 1));
    let tight = LoadOptions {
        max_memory: Some(16 << 20),
        ..LoadOptions::default()
    };
    load_error(
        &path,
        &tight,
        &[
            "node 0",
            "EXT_mesh_gpu_instancing",
            "65536 instances take",
            "memory limit",
        ],
    );
    // The same forest glowing: 6.4·10⁸ emitting triangles, 41 GB of light sampler at
    // `BYTES_PER_EMITTER`, refused before the BVH and the sampler are built.
    let glowing = json.replacen(
        r#""primitives":[{"attributes""#,
        r#""primitives":[{"material":0,"attributes""#,
        1,
    );
    let glowing = glowing.replacen(
        r#""meshes":"#,
        r#""materials":[{"emissiveFactor":[1,1,1]}],"meshes":"#,
        1,
    );
    let path = dir.path().join("glowing-forest.gltf");
    write(&path, &glowing);
    load_error(&path, &roomy, &["memory limit", "loaded"]);
}

/// A long chain of nodes (each the only child of the one before) loads: the walk keeps
/// no recursion and no per-level copy.
#[test]
fn a_long_chain_of_nodes_loads() {
    let dir = temp();
    let n = 100_000;
    let mut nodes: Vec<Value> = (1..n).map(|i| json!({"children": [i]})).collect();
    nodes.push(json!({"mesh": 0}));
    let path = cornell_json(dir.path(), |j| {
        j["buffers"][0]["uri"] = "data.bin".into();
        j["nodes"] = Value::Array(nodes);
        j["scenes"] = json!([{"nodes": [0]}]);
    });
    write(
        &dir.path().join("data.bin"),
        read(&asset("cornell-box.bin")),
    );
    let data = load_gltf(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(data.meshes.len(), 1);
}

/// A camera whose `type` names the other projection's object (which made the gltf crate
/// panic), sparse indices of a float type (an `unreachable!` in the gltf crate), and a POSITION
/// accessor index past the end (indexed unchecked by its schema check) are refused with errors.
#[test]
fn inputs_that_panicked_inside_the_gltf_crate_are_refused() {
    let dir = temp();
    for (name, camera, needle) in [
        (
            "ortho.gltf",
            json!({"type": "orthographic", "perspective": {"yfov": 0.5, "znear": 0.1}}),
            "no \"orthographic\" object",
        ),
        (
            "persp.gltf",
            json!({"type": "perspective", "orthographic": {"xmag": 1, "ymag": 1, "zfar": 10, "znear": 0.1}}),
            "no \"perspective\" object",
        ),
    ] {
        let path = cornell_json(dir.path(), |j| {
            j["cameras"] = json!([camera]);
            j["buffers"][0]["uri"] = "x.bin".into();
        });
        let renamed = dir.path().join(name);
        std::fs::rename(&path, &renamed).unwrap_or_else(|e| panic!("{e}"));
        load_error(&renamed, &LoadOptions::default(), &["camera 0", needle]);
    }
    let sparse = json!({"count": 1,
        "indices": {"bufferView": 0, "componentType": 5126},
        "values": {"bufferView": 1}});
    let accessor = json!({"componentType": 5126, "count": 3, "type": "VEC3", "sparse": sparse});
    let path = one_accessor_scene(dir.path(), "float-sparse.gltf", accessor, json!({}));
    load_error(
        &path,
        &LoadOptions::default(),
        &["sparse.indices.componentType"],
    );
    let accessor = json!({"bufferView": 1, "componentType": 5126, "count": 1, "type": "VEC3"});
    let path = one_accessor_scene(
        dir.path(),
        "position-past-end.gltf",
        accessor,
        json!({"meshes": [{"primitives": [{"attributes": {"POSITION": 7}}]}]}),
    );
    load_error(
        &path,
        &LoadOptions::default(),
        &["accessor 7 does not exist"],
    );
    // An animation channel aimed at a node that does not exist (gltf's `Target::node` unwraps).
    let path = cornell_json(dir.path(), |j| {
        j["animations"] = json!([{"channels": [{"sampler": 0, "target": {"node": 99, "path": "translation"}}],
            "samplers": [{"input": 0, "output": 0}]}]);
    });
    load_error(
        &path,
        &LoadOptions::default(),
        &["animation 0 channel 0", "target node 99 does not exist"],
    );
}

/// A camera under a parent translated by 3·10⁶ m and turned 17° renders the scene
/// where it is: a square straight ahead of the camera lands in the middle of a 64×64 image.
/// The f32 `look_at` it replaced put it 3.3 px off (its direction was rebuilt from two points
/// rounded to f32's 0.25 m spacing at 3·10⁶ m).
///
/// Tolerance: the square, 10⁵ m away, covers pixels 24..40 in both axes (its edges fall on
/// pixel boundaries), so its centroid is (32, 32) up to the f32 rounding of its corners
/// (≤ 0.125 m against a half-width of 6.4 km: 3·10⁻⁴ px) and of the camera rays (a relative
/// 6·10⁻⁸: 10⁻⁶ px); 0.05 px leaves room for both and is 60× below the old error.
#[test]
fn a_far_away_camera_renders_the_scene_where_it_is() {
    let dir = temp();
    let angle = 17f32.to_radians();
    let far = 3.0e6f32;
    // The camera's world transform: translate (far, 0, far), then turn by 17° about Y. It looks
    // down its turned −Z: d = (−sin 17°, 0, −cos 17°). The square sits 10⁵ m along d, facing the
    // camera, spanning ±s with s = 5·tan(yfov/2)/4 so that it covers the middle quarter of each
    // axis: pixels 24 to 40 of 64.
    let yfov = 0.5f32;
    let distance = 1.0e5f32;
    let half = distance * (0.5 * yfov).tan() / 4.0;
    let d = glam::DVec3::new(-f64::from(angle.sin()), 0.0, -f64::from(angle.cos()));
    let right = glam::DVec3::new(f64::from(angle.cos()), 0.0, -f64::from(angle.sin()));
    let centre = glam::DVec3::new(f64::from(far), 0.0, f64::from(far)) + d * f64::from(distance);
    let corner = |sx: f64, sy: f64| {
        (centre + right * sx * f64::from(half) + glam::DVec3::Y * sy * f64::from(half)).as_vec3()
    };
    let quad = [
        corner(-1.0, -1.0),
        corner(1.0, -1.0),
        corner(1.0, 1.0),
        corner(-1.0, 1.0),
    ];
    let positions: Vec<u8> = quad
        .iter()
        .flat_map(|p| p.to_array())
        .flat_map(f32::to_le_bytes)
        .collect();
    let indices: Vec<u8> = [0u16, 1, 2, 0, 2, 3]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    let mut bin = positions;
    bin.extend(indices);
    write(&dir.path().join("far.bin"), &bin);
    let json = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 2]}],
        "nodes": [
            {"translation": [far, 0.0, far], "children": [1]},
            {"rotation": [0.0, (0.5 * angle).sin(), 0.0, (0.5 * angle).cos()], "camera": 0},
            {"mesh": 0}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": yfov, "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [{"emissiveFactor": [1.0, 1.0, 1.0], "doubleSided": true}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "buffers": [{"byteLength": bin.len(), "uri": "far.bin"}],
        "bufferViews": [
            {"buffer": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 12}
        ]
    });
    let path = dir.path().join("far.gltf");
    write(
        &path,
        serde_json::to_vec(&json).unwrap_or_else(|e| panic!("{e}")),
    );
    let loaded = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    let camera = loaded
        .camera
        .unwrap_or_else(|| panic!("the camera was not loaded"));
    let settings = RenderSettings {
        width: 64,
        height: 64,
        spp: 16,
        ..RenderSettings::default()
    };
    let pt = PathTracer::new(PathSettings {
        max_depth: 0,
        ..PathSettings::default()
    });
    let out =
        render(&loaded.scene, &camera, &pt, &settings, false).unwrap_or_else(|e| panic!("{e}"));
    let (mut sum, mut weight) = (Vec2::ZERO, 0.0f32);
    for y in 0..64 {
        for x in 0..64 {
            let v = out.image.get(x, y).x;
            sum += v * Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            weight += v;
        }
    }
    assert!(weight > 0.0, "the square is not in the image");
    let centroid = sum / weight;
    assert!(
        (centroid - Vec2::splat(32.0)).length() < 0.05,
        "the square's centroid is at {centroid}, not (32, 32)"
    );
    // The same camera at 10⁸ m is no longer refused.
    let json8 = serde_json::to_vec(&json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"translation": [1e8, 0.0, 0.0], "children": [1]}, {"camera": 0}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "znear": 0.01}}]
    }))
    .unwrap_or_else(|e| panic!("{e}"));
    let path8 = dir.path().join("far8.gltf");
    write(&path8, json8);
    let data = load_gltf(&path8).unwrap_or_else(|e| panic!("{e}"));
    let c = data.camera.unwrap_or_else(|| panic!("no camera"));
    assert_eq!(c.forward, Vec3::NEG_Z);
}

/// `extras` of any JSON type and attribute names beginning with `_` are valid glTF and
/// load; names from the file reach messages and warnings with control characters escaped.
#[test]
fn extras_and_underscore_attributes_load_and_names_are_escaped() {
    let dir = temp();
    write(
        &dir.path().join("data.bin"),
        read(&asset("cornell-box.bin")),
    );
    let path = cornell_json(dir.path(), |j| {
        j["buffers"][0]["uri"] = "data.bin".into();
        j["extras"] = json!([1]);
        j["nodes"][0]["extras"] = json!("text");
        j["meshes"][0]["primitives"][0]["attributes"]["_TEMPERATURE"] = 0.into();
    });
    load_scene(&path).unwrap_or_else(|e| panic!("{e}"));

    let evil = "\u{1b}]0;owned\u{7}\u{1b}[2J\u{202e}";
    let path = cornell_json(dir.path(), |j| {
        j["buffers"][0]["uri"] = "data.bin".into();
        j["extensionsUsed"] = json!([format!("EXT_{evil}")]);
        j["nodes"][0]["name"] = evil.into();
        j["nodes"][0]["camera"] = 0.into();
        j["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 7.0, "znear": 0.1}}]);
    });
    let e = load_error(
        &path,
        &LoadOptions::default(),
        &["yfov", "\\u{1b}]0;owned\\u{7}"],
    );
    assert!(
        !e.contains('\u{1b}') && !e.contains('\u{7}') && !e.contains('\u{202e}'),
        "{e:?}"
    );
    let path = cornell_json(dir.path(), |j| {
        j["buffers"][0]["uri"] = "data.bin".into();
        j["extensionsUsed"] = json!([format!("EXT_{evil}")]);
    });
    let loaded = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    let text: String = loaded.warnings.iter().map(|w| format!("{w}\n")).collect();
    assert!(text.contains("EXT_\\u{1b}"), "{text}");
    assert!(
        !text.contains('\u{1b}') && !text.contains('\u{202e}'),
        "{text:?}"
    );
}
