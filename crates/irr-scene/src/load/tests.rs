//! The loader's unit tests.

use super::*;
use crate::testutil::{Gltf, assets, write};

fn dir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"))
}

fn load(path: &Path) -> SceneData {
    load_gltf(path).unwrap_or_else(|e| panic!("{e}"))
}

fn load_err(path: &Path) -> String {
    match load_gltf(path) {
        Ok(_) => panic!("{} loaded but should not", path.display()),
        Err(e) => e.to_string(),
    }
}

const TRIANGLE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// One emissive material, one node with `node_extra`, one mesh whose primitive is
/// `primitive`.
fn one_mesh(g: &Gltf, node_extra: &str, primitive: &str) -> String {
    g.json(&format!(
        r#""scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0{node_extra}}}],
        "meshes":[{{"primitives":[{primitive}]}}],
        "materials":[{{"emissiveFactor":[1,1,1]}}]"#
    ))
}

fn world_triangles(s: &SceneData) -> Vec<[Vec3; 3]> {
    let triangles = |m: &TriangleMesh| -> Vec<[Vec3; 3]> {
        m.indices
            .iter()
            .map(|t| t.map(|i| m.positions[i as usize]))
            .collect()
    };
    let placed = s.instances.iter().flat_map(|i| {
        triangles(&s.prototypes[i.prototype as usize])
            .into_iter()
            .map(|t| t.map(|p| i.to_world.transform_point3(p.as_dvec3()).as_vec3()))
    });
    s.meshes.iter().flat_map(triangles).chain(placed).collect()
}

#[test]
fn cornell_box_loads_with_its_measured_data() {
    let s = load(&assets().join("cornell-box.gltf"));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // 8 surfaces: floor, ceiling, back, two walls, light (1 quad each), blocks (5 quads).
    let triangles: usize = s.meshes.iter().map(|m| m.indices.len()).sum();
    assert_eq!(triangles, 2 * (6 + 5 + 5));
    assert_eq!(s.emissive_triangles, 2);
    let light = s
        .materials
        .iter()
        .find(|m| m.emission.max_element() > 0.0)
        .unwrap_or_else(|| panic!("no light"));
    // emissiveFactor (1, 12/17, 4/17) × strength 17 = (17, 12, 4), to f32 rounding of one
    // division and one product: 2 ulp of 17 ≈ 4e-6.
    assert!(
        (light.emission - Vec3::new(17.0, 12.0, 4.0))
            .abs()
            .max_element()
            < 4e-6
    );
    assert!(!light.two_sided);
    let cam = s.camera.unwrap_or_else(|| panic!("no camera"));
    assert!((cam.position - Vec3::new(0.278, 0.273, -0.8)).length() < 1e-6);
    assert!((cam.forward - Vec3::Z).length() < 1e-6);
    assert!((cam.yfov - 2.0 * (12.5f32 / 35.0).atan()).abs() < 1e-6);
    let (lo, hi) = s.bounds.unwrap_or_else(|| panic!("no bounds"));
    assert!((hi - Vec3::new(0.556, 0.5488, 0.5592)).abs().max_element() < 1e-6);
    assert_eq!(lo, Vec3::ZERO);
}

#[test]
fn glb_and_data_uri_assets_load() {
    let furnace = load(&assets().join("furnace.glb"));
    assert_eq!(furnace.meshes[0].indices.len(), 320);
    assert!(furnace.materials[0].two_sided);
    let disk = load(&assets().join("disk-light.gltf"));
    assert_eq!(disk.emissive_triangles, 256);
    let ao = load(&assets().join("ao-plane.gltf"));
    assert_eq!(ao.emissive_triangles, 0);
    assert_eq!(
        ao.warnings
            .iter()
            .map(|w| w.feature.as_str())
            .collect::<Vec<_>>(),
        ["no-emitter"]
    );
    assert!(ao.warnings[0].to_string().contains("ao-plane.gltf: "));
    assert!(ao.warnings[0].message.contains("the image will be black"));
}

#[test]
fn index_types_and_non_indexed_give_the_same_triangles() {
    let d = dir();
    let quad = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let order = [0u32, 1, 2, 0, 2, 3];
    let mut reference = None;
    for ct in [5121, 5123, 5125] {
        let mut g = Gltf::default();
        let p = g.vec3(&quad);
        let i = g.indices(&order, ct);
        let json = one_mesh(
            &g,
            "",
            &format!(r#"{{"attributes":{{"POSITION":{p}}},"indices":{i}}}"#),
        );
        let s = load(&write(d.path(), &format!("q{ct}.gltf"), json));
        let tris = world_triangles(&s);
        assert_eq!(tris.len(), 2);
        match &reference {
            None => reference = Some(tris),
            Some(r) => assert_eq!(&tris, r),
        }
    }
    let mut g = Gltf::default();
    let flat: Vec<[f32; 3]> = order.iter().map(|&i| quad[i as usize]).collect();
    let p = g.vec3(&flat);
    let json = one_mesh(&g, "", &format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#));
    let s = load(&write(d.path(), "flat.gltf", json));
    assert_eq!(Some(world_triangles(&s)), reference);
}

#[test]
fn strips_and_fans_keep_the_winding() {
    let d = dir();
    // Four vertices of a quad in the z = 0 plane, counter-clockwise seen from +z.
    let strip = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    for (mode, verts) in [
        (5, strip),
        (
            6,
            [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
        ),
    ] {
        let mut g = Gltf::default();
        let p = g.vec3(&verts);
        let json = one_mesh(
            &g,
            "",
            &format!(r#"{{"attributes":{{"POSITION":{p}}},"mode":{mode}}}"#),
        );
        let s = load(&write(d.path(), &format!("m{mode}.gltf"), json));
        let tris = world_triangles(&s);
        assert_eq!(tris.len(), 2, "mode {mode}");
        for t in tris {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            assert!(n.z > 0.0, "mode {mode}: triangle {t:?} faces away");
        }
    }
}

#[test]
fn node_hierarchy_transforms_compose() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    // Parent: translate by (10, 0, 0); child: scale 2, then a quarter turn about Z given as
    // a column-major matrix; the mesh hangs on the child.
    let json = g.json(&format!(
        r#""scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"translation":[10,0,0],"children":[1]}},
                 {{"mesh":0,"matrix":[0,2,0,0, -2,0,0,0, 0,0,2,0, 0,0,0,1]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}],
        "materials":[]"#
    ));
    let s = load(&write(d.path(), "h.gltf", json));
    let t = world_triangles(&s)[0];
    // (1,0,0) → scaled and turned to (0,2,0) → translated to (10,2,0); (0,1,0) → (8,0,0).
    assert_eq!(
        t,
        [
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 2.0, 0.0),
            Vec3::new(8.0, 0.0, 0.0)
        ]
    );
}

#[test]
fn mirroring_keeps_the_front_face_and_normals_use_the_inverse_transpose() {
    let d = dir();
    let mut g = Gltf::default();
    // A triangle in the plane x + y = 1, front face (counter-clockwise) toward +x+y, with
    // its shading normals given.
    let verts = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let p = g.vec3(&verts);
    let n = g.vec3(&[[0.57735, 0.57735, 0.57735]; 3]);
    let prim = format!(r#"{{"attributes":{{"POSITION":{p},"NORMAL":{n}}}}}"#);
    for (name, scale) in [("plain", [1.0, 1.0, 1.0]), ("mirror", [-1.0, 3.0, 1.0])] {
        let json = one_mesh(
            &g,
            &format!(r#","scale":[{},{},{}]"#, scale[0], scale[1], scale[2]),
            &prim,
        );
        let s = load(&write(d.path(), &format!("{name}.gltf"), json));
        let m = &s.meshes[0];
        let t = m.indices[0].map(|i| m.positions[i as usize]);
        let front = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
        let normal = m.normals.as_ref().unwrap_or_else(|| panic!("no normals"))[0];
        // The shading normal (transformed by the inverse transpose) stays perpendicular to
        // the transformed surface and on its front side. Tolerance: f32 rounding of a few
        // products of O(1) values, 1e-6.
        assert!((t[1] - t[0]).dot(normal).abs() < 1e-6, "{name}");
        assert!((t[2] - t[0]).dot(normal).abs() < 1e-6, "{name}");
        assert!(
            front.dot(normal) > 0.999,
            "{name}: front {front} normal {normal}"
        );
    }
}

#[test]
fn ignored_features_are_counted_in_warnings() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let json = g.json(&format!(
        r#""extensionsUsed":["EXT_lights_image_based","KHR_materials_clearcoat"],
        "extensions":{{"EXT_lights_image_based":{{"lights":[]}}}},
        "scene":0,"scenes":[{{"nodes":[0,1,2]}},{{"nodes":[]}}],
        "nodes":[{{"mesh":0}},{{"extensions":{{"EXT_lights_image_based":{{"light":0}}}}}},{{"mesh":1}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":0}},
                                 {{"attributes":{{"POSITION":{p}}},"material":1}},
                                 {{"attributes":{{"POSITION":{p}}},"mode":0}}]}},
                  {{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}],
        "images":[{{"uri":"a.png"}}],"textures":[{{"source":0}},{{"source":0}}],
        "materials":[{{"occlusionTexture":{{"index":1}},
                       "pbrMetallicRoughness":{{"roughnessFactor":1.5}}}},
                     {{"pbrMetallicRoughness":{{"metallicFactor":0}},"alphaMode":"BLEND",
                       "extensions":{{"KHR_materials_clearcoat":{{"clearcoatFactor":1}},
                                      "KHR_materials_specular":{{"specularFactor":0.5,
                                                                 "specularColorFactor":[1,0.5,1]}}}}}}]"#
    ));
    let s = load(&write(d.path(), "w.gltf", json));
    let got: Vec<(&str, usize)> = s
        .warnings
        .iter()
        .map(|w| (w.feature.as_str(), w.count))
        .collect();
    for expected in [
        ("extension:EXT_lights_image_based", 2),
        ("extension:KHR_materials_clearcoat", 1),
        ("textures", 2),
        ("images", 1),
        ("occlusion-maps", 1),
        ("specular-colour", 1),
        ("factor-clamped", 1),
        ("scenes", 1),
        ("non-triangle", 1),
        ("default-material", 1),
    ] {
        assert!(got.contains(&expected), "missing {expected:?} in {got:?}");
    }
    let text: Vec<String> = s.warnings.iter().map(ToString::to_string).collect();
    assert!(
        text.iter()
            .all(|t| t.starts_with(&format!("{}: ", d.path().join("w.gltf").display())))
    );
    assert!(
        text.iter().any(|t| t
            .ends_with("2 textures ignored (irr reads baseColorTexture, emissiveTexture, metallicRoughnessTexture and normalTexture only)")),
        "{text:?}"
    );
    // The factors: material 0 keeps glTF's defaults (metallic 1, specular 1) with its roughness
    // clamped to 1; material 1 reads KHR_materials_specular's factor; the default material is
    // the specification's white rough metal, appended after the file's two.
    assert_eq!(s.materials.len(), 3);
    let factors: Vec<(f32, f32, f32)> = s
        .materials
        .iter()
        .map(|m| (m.metallic, m.roughness, m.specular))
        .collect();
    assert_eq!(
        factors,
        [(1.0, 1.0, 1.0), (0.0, 1.0, 0.5), (1.0, 1.0, 1.0)],
        "{:?}",
        s.materials
    );
    assert_eq!(s.materials[2].albedo, Vec3::ONE);
    // The three triangle primitives read one POSITION accessor: one prototype, placed three
    // times, the last with the default material.
    assert_eq!(s.prototypes.len(), 1);
    assert_eq!(s.instances.last().and_then(|i| i.material_id), Some(2));
}

#[test]
fn sparse_accessors_substitute_values() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&[[0.0; 3]; 3]);
    // Replace vertices 1 and 2 by (1,0,0) and (0,1,0).
    let idx = g.indices(&[1, 2], 5123);
    let vals = g.vec3(&[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let idx_view = g.accessors[idx]
        .split(',')
        .next()
        .map(|s| s.replace(r#"{"bufferView":"#, ""))
        .unwrap_or_default();
    let val_view = g.accessors[vals]
        .split(',')
        .next()
        .map(|s| s.replace(r#"{"bufferView":"#, ""))
        .unwrap_or_default();
    g.accessors[p] = format!(
        r#"{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
           "sparse":{{"count":2,"indices":{{"bufferView":{idx_view},"componentType":5123}},
                      "values":{{"bufferView":{val_view}}}}}}}"#
    );
    let json = one_mesh(&g, "", &format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#));
    let s = load(&write(d.path(), "sparse.gltf", json));
    assert_eq!(world_triangles(&s)[0], TRIANGLE.map(Vec3::from_array));
}

#[test]
fn bad_content_is_refused_with_the_reason() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let i = g.indices(&[0, 1, 7], 5123);
    let prim = format!(r#"{{"attributes":{{"POSITION":{p}}},"indices":{i}}}"#);
    let e = load_err(&write(d.path(), "idx.gltf", one_mesh(&g, "", &prim)));
    // The entry is named, not its value (bytes of a file are never echoed).
    assert!(
        e.contains("idx.gltf") && e.contains("index entry 2") && e.contains("3 vertices"),
        "{e}"
    );
    assert!(!e.contains("index 7"), "{e}");

    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    g.accessors[p] = g.accessors[p].replace(r#""count":3"#, r#""count":4"#);
    let prim = format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#);
    let e = load_err(&write(d.path(), "range.gltf", one_mesh(&g, "", &prim)));
    assert!(
        e.contains("range.gltf") && e.contains("out of range"),
        "{e}"
    );

    for (name, bad) in [("nan", f32::NAN), ("inf", f32::INFINITY), ("huge", 1e30)] {
        let mut g = Gltf::default();
        let p = g.vec3(&[[0.0, 0.0, 0.0], [bad, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let prim = format!(r#"{{"attributes":{{"POSITION":{p}}}}}"#);
        let e = load_err(&write(
            d.path(),
            &format!("{name}.gltf"),
            one_mesh(&g, "", &prim),
        ));
        assert!(
            e.contains(&format!("{name}.gltf")) && e.contains("vertex 1"),
            "{e}"
        );
    }

    // A node that is its own child.
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let json = g.json(&format!(
        r#""scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"children":[0]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}]"#
    ));
    let e = load_err(&write(d.path(), "cycle.gltf", json));
    assert!(
        e.contains("cycle.gltf") && e.contains("reached twice"),
        "{e}"
    );

    // A required extension irr cannot honour.
    let g = Gltf::default();
    let json = g.json(r#""extensionsRequired":["KHR_draco_mesh_compression"],"extensionsUsed":["KHR_draco_mesh_compression"]"#);
    let e = load_err(&write(d.path(), "draco.gltf", json));
    assert!(
        e.contains("draco.gltf") && e.contains("requires extension KHR_draco_mesh_compression"),
        "{e}"
    );
}

/// Animations: a channel that moves a node above a camera (rotation, CUBICSPLINE, with zero
/// tangents) gives that camera a path whose chain is the moving parent then the fixed camera
/// node; a channel that moves a mesh, and one that drives the same parent's rotation again,
/// are counted in warnings; a camera no channel reaches has no path. At a key the spline is
/// the key's value (h00(0) = 1): at 1 s the parent's quarter turn about y turns the camera's
/// view from −z to −x and carries its rest translation (0, 0, 1) to (1, 0, 0).
#[test]
fn animations_move_cameras_and_warn_about_the_rest() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let times: Vec<u8> = [0.0f32, 1.0].iter().flat_map(|t| t.to_le_bytes()).collect();
    let input = g.accessor(
        &times,
        r#""componentType":5126,"count":2,"type":"SCALAR","min":[0],"max":[1]"#,
    );
    let quarter = glam::Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    let zero = [0.0f32; 4];
    let keys = [
        zero,
        [0.0, 0.0, 0.0, 1.0],
        zero,
        zero,
        quarter.to_array(),
        zero,
    ];
    let rotations: Vec<u8> = keys
        .iter()
        .flat_map(|q| q.iter().flat_map(|c| c.to_le_bytes()))
        .collect();
    let output = g.accessor(
        &rotations,
        r#""componentType":5126,"count":6,"type":"VEC4""#,
    );
    let shift = g.vec3(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]);
    let json = g.json(&format!(
        r#""scene":0,"scenes":[{{"nodes":[0,1,3]}}],
        "nodes":[{{"mesh":0}},{{"children":[2]}},{{"camera":0,"translation":[0,0,1]}},{{"camera":0}}],
        "cameras":[{{"type":"perspective","perspective":{{"yfov":0.5,"znear":0.01}}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}],
        "materials":[],
        "animations":[{{"channels":[
            {{"sampler":0,"target":{{"node":1,"path":"rotation"}}}},
            {{"sampler":1,"target":{{"node":0,"path":"translation"}}}},
            {{"sampler":0,"target":{{"node":1,"path":"rotation"}}}}],
          "samplers":[{{"input":{input},"output":{output},"interpolation":"CUBICSPLINE"}},
                      {{"input":{input},"output":{shift},"interpolation":"LINEAR"}}]}}]"#
    ));
    let s = load(&write(d.path(), "a.gltf", json));
    let got: Vec<(&str, usize)> = s
        .warnings
        .iter()
        .map(|w| (w.feature.as_str(), w.count))
        .collect();
    assert!(got.contains(&("animations", 1)), "{got:?}");
    assert!(got.contains(&("animation-duplicates", 1)), "{got:?}");
    // The mesh's channel makes the scene non-static; the camera's parent carries no mesh.
    assert_eq!(s.animated_content, 1);
    assert!(
        !got.iter().any(|(f, _)| *f == "animation-content"),
        "{got:?}"
    );
    assert_eq!(s.cameras.len(), 2);
    assert!(s.cameras[1].path.is_none());
    let path = s.cameras[0]
        .path
        .as_ref()
        .unwrap_or_else(|| panic!("no path"));
    assert_eq!(path.chain.len(), 2);
    assert!(matches!(path.chain[0], crate::animation::Link::Moving(_)));
    assert!(matches!(path.chain[1], crate::animation::Link::Fixed(_)));
    assert_eq!(path.span(), (0.0, 1.0));
    let start = path.camera_at(0.0).unwrap_or_else(|| panic!("no camera"));
    assert_eq!(start.position, Vec3::new(0.0, 0.0, 1.0));
    let end = path.camera_at(1.0).unwrap_or_else(|| panic!("no camera"));
    // A quarter turn in f32 (sin and cos of π/4 rounded): within a few ulps of the exact point.
    assert!(
        (end.position - Vec3::X).abs().max_element() < 1e-6,
        "{}",
        end.position
    );
    assert!(
        (end.forward - -Vec3::X).abs().max_element() < 1e-6,
        "{}",
        end.forward
    );
}

/// A file may require an extension irr reads (`extensionsRequired`): irr honours it. The gltf
/// crate's schema check calls `KHR_materials_specular` unsupported (its list lacks it); that
/// verdict is the loader's to give, by its own list, so a file requiring it loads and its
/// factor is read.
#[test]
fn a_required_extension_that_irr_reads_loads() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let json = g.json(&format!(
        r#""extensionsUsed":["KHR_materials_specular"],"extensionsRequired":["KHR_materials_specular"],
        "scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":0}}]}}],
        "materials":[{{"pbrMetallicRoughness":{{"metallicFactor":0}},
                       "extensions":{{"KHR_materials_specular":{{"specularFactor":0.25}}}}}}]"#
    ));
    let s = load(&write(d.path(), "required.gltf", json));
    assert_eq!(s.materials[0].specular, 0.25);
}

/// `KHR_materials_ior`, required: each material's ior is read (1.5 without the extension, 0
/// kept as the extension's infinite ior), and an ior the extension does not allow (in (0, 1))
/// reads as 1 with the clamping warning; no warning names the extension.
#[test]
fn khr_materials_ior_is_read() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let ior = |v: &str| format!(r#"{{"extensions":{{"KHR_materials_ior":{{"ior":{v}}}}}}}"#);
    let json = g.json(&format!(
        r#""extensionsUsed":["KHR_materials_ior"],"extensionsRequired":["KHR_materials_ior"],
        "scene":0,"scenes":[{{"nodes":[0,1,2,3]}}],
        "nodes":[{{"mesh":0}},{{"mesh":1}},{{"mesh":2}},{{"mesh":3}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":0}}]}},
                  {{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":1}}]}},
                  {{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":2}}]}},
                  {{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":3}}]}}],
        "materials":[{},{},{},{{}}]"#,
        ior("1.33"),
        ior("0"),
        ior("0.5"),
    ));
    let s = load(&write(d.path(), "ior.gltf", json));
    let iors: Vec<f32> = s.materials.iter().map(|m| m.ior).collect();
    assert_eq!(iors, [1.33, 0.0, 1.0, 1.5]);
    let features: Vec<&str> = s.warnings.iter().map(|w| w.feature.as_str()).collect();
    assert!(features.iter().all(|f| !f.contains("ior")), "{features:?}");
    assert!(
        s.warnings
            .iter()
            .any(|w| w.message.contains("ior") && w.count == 1),
        "{:?}",
        s.warnings
    );
}

/// `KHR_materials_transmission`, required: each material's factor is read (clamped into
/// [0, 1]), and what irr's thin straight sheet leaves out is counted per material: the
/// transmission texture, a volume of some thickness, a roughness above the smooth floor (glTF's
/// default roughness 1 included), a coloured base colour, and an emitter's transmission.
#[test]
fn khr_materials_transmission_is_read_with_what_it_leaves_out() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let glass = |extra: &str, pbr: &str| {
        format!(
            r#"{{"pbrMetallicRoughness":{{{pbr}}},"extensions":{{"KHR_materials_transmission":{{"transmissionFactor":1{extra}}}}}}}"#
        )
    };
    let materials = [
        glass("", r#""roughnessFactor":0"#),
        glass(r#","transmissionTexture":{"index":0}"#, r#""roughnessFactor":0"#),
        glass("", r#""roughnessFactor":0.5"#),
        glass("", r#""roughnessFactor":0,"baseColorFactor":[1,0.5,0.5,1]"#),
        r#"{"pbrMetallicRoughness":{"roughnessFactor":0},"emissiveFactor":[1,1,1],"extensions":{"KHR_materials_transmission":{"transmissionFactor":0.5}}}"#.to_string(),
        r#"{"pbrMetallicRoughness":{"roughnessFactor":0},"extensions":{"KHR_materials_transmission":{"transmissionFactor":1.5},"KHR_materials_volume":{"thicknessFactor":0.1}}}"#.to_string(),
        // A rough, tinted volume that absorbs: it refracts and absorbs, roughness and tint
        // modelled.
        r#"{"pbrMetallicRoughness":{"roughnessFactor":0.5,"baseColorFactor":[1,0.5,0.5,1]},"extensions":{"KHR_materials_transmission":{"transmissionFactor":1},"KHR_materials_volume":{"thicknessFactor":0.1,"attenuationDistance":0.2,"attenuationColor":[1,0.5,0.5]}}}"#.to_string(),
    ];
    let n = materials.len();
    let nodes: Vec<String> = (0..n).map(|k| format!(r#"{{"mesh":{k}}}"#)).collect();
    let meshes: Vec<String> = (0..n)
        .map(|k| {
            format!(r#"{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":{k}}}]}}"#)
        })
        .collect();
    let roots: Vec<String> = (0..n).map(|k| k.to_string()).collect();
    let json = g.json(&format!(
        r#""extensionsUsed":["KHR_materials_transmission","KHR_materials_volume"],
        "extensionsRequired":["KHR_materials_transmission"],
        "images":[{{"uri":"a.png"}}],"textures":[{{"source":0}}],
        "scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],"meshes":[{}],"materials":[{}]"#,
        roots.join(","),
        nodes.join(","),
        meshes.join(","),
        materials.join(",")
    ));
    // The transmission texture: a 1×1 grey PNG, read as linear data.
    let png = crate::testutil::png_bytes(
        1,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        None,
        &[128],
    );
    write(d.path(), "a.png", png);
    let s = load(&write(d.path(), "glass.gltf", json));
    assert!(s.materials[1].transmission_texture.is_some());
    assert!(s.materials[0].transmission_texture.is_none());
    let factors: Vec<f32> = s.materials.iter().map(|m| m.transmission).collect();
    assert_eq!(factors, [1.0, 1.0, 1.0, 1.0, 0.5, 1.0, 1.0]);
    let transmits: Vec<bool> = s.materials.iter().map(|m| m.transmits()).collect();
    assert_eq!(transmits, [true, true, true, true, false, true, true]);
    let straight: Vec<bool> = s.materials.iter().map(|m| m.passes_straight()).collect();
    assert_eq!(straight, [true, true, true, true, false, false, false]);
    // σ = −ln(c)/d: 0 where the colour is white or the distance infinite (the defaults), and
    // ln 2/0.2 = 3.4657 for c = 0.5 over 0.2 (f32 rounding of ln and one division: 1e-6).
    assert_eq!(s.materials[5].attenuation, Vec3::ZERO);
    let sigma = s.materials[6].attenuation;
    assert_eq!(sigma.x, 0.0);
    for c in [sigma.y, sigma.z] {
        assert!(
            (c - std::f32::consts::LN_2 / 0.2).abs() < 1e-6 * c,
            "{sigma}"
        );
    }
    let got: Vec<(&str, usize)> = s
        .warnings
        .iter()
        .map(|w| (w.feature.as_str(), w.count))
        .collect();
    for expected in [
        ("transmission-rough", 1),
        ("transmission-tint", 1),
        ("transmission-emissive", 1),
        ("factor-clamped", 1),
    ] {
        assert!(got.contains(&expected), "missing {expected:?} in {got:?}");
    }
    assert!(
        got.iter().all(|(f, _)| !f.starts_with("extension:")),
        "{got:?}"
    );
}

/// A mesh drawn by several nodes is loaded once and placed by each (the world triangles as
/// the nodes' transforms put them); a node that mirrors it is copied instead, its winding
/// swapped so the front face stays where the file meant; a mesh drawn once stays a world mesh.
#[test]
fn meshes_drawn_by_several_nodes_are_placed() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let q = g.vec3(&[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]]);
    let json = g.json(&format!(
        r#""scene":0,"scenes":[{{"nodes":[0,1,2,3]}}],
        "nodes":[{{"mesh":0,"translation":[5,0,0]}},{{"mesh":0,"scale":[2,2,2]}},
                 {{"mesh":0,"scale":[-1,1,1]}},{{"mesh":1}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}},
                  {{"primitives":[{{"attributes":{{"POSITION":{q}}}}}]}}]"#
    ));
    let s = load(&write(d.path(), "nodes.gltf", json));
    // The mirrored draw and mesh 1, in node order; then the placements of mesh 0.
    assert_eq!(
        (s.meshes.len(), s.prototypes.len(), s.instances.len()),
        (2, 1, 2)
    );
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    assert_eq!(
        world_triangles(&s),
        [
            [v(0.0, 0.0, 0.0), v(0.0, 1.0, 0.0), v(-1.0, 0.0, 0.0)],
            [v(0.0, 0.0, 1.0), v(1.0, 0.0, 1.0), v(0.0, 1.0, 1.0)],
            [v(5.0, 0.0, 0.0), v(6.0, 0.0, 0.0), v(5.0, 1.0, 0.0)],
            [v(0.0, 0.0, 0.0), v(2.0, 0.0, 0.0), v(0.0, 2.0, 0.0)],
        ]
    );
}

/// `EXT_mesh_gpu_instancing`: a node's mesh placed once per instance (one prototype), each
/// with the instance's translation and scale (rotation left to its default) and then the
/// node's own transform; an
/// instancing whose attributes disagree on the count is refused, naming the node.
#[test]
fn mesh_gpu_instances_are_placed() {
    let d = dir();
    let file = |scales: &[[f32; 3]]| {
        let mut g = Gltf::default();
        let p = g.vec3(&TRIANGLE);
        let t = g.vec3(&[[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 0.0, -5.0]]);
        let s = g.vec3(scales);
        g.json(&format!(
            r#""extensionsUsed":["EXT_mesh_gpu_instancing"],"extensionsRequired":["EXT_mesh_gpu_instancing"],
            "scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0,"translation":[0,1,0],
                       "extensions":{{"EXT_mesh_gpu_instancing":{{"attributes":{{"TRANSLATION":{t},"SCALE":{s}}}}}}}}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":0}}]}}],
            "materials":[{{"emissiveFactor":[1,1,1]}}]"#
        ))
    };
    let one = [1.0f32; 3];
    let s = load(&write(
        d.path(),
        "instances.gltf",
        file(&[one, [2.0; 3], one]),
    ));
    assert_eq!(
        (s.meshes.len(), s.prototypes.len(), s.instances.len()),
        (0, 1, 3)
    );
    let got = world_triangles(&s);
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let expected = [
        [v(0.0, 1.0, 0.0), v(1.0, 1.0, 0.0), v(0.0, 2.0, 0.0)],
        [v(10.0, 1.0, 0.0), v(12.0, 1.0, 0.0), v(10.0, 3.0, 0.0)],
        [v(0.0, 1.0, -5.0), v(1.0, 1.0, -5.0), v(0.0, 2.0, -5.0)],
    ];
    assert_eq!(got, expected);
    assert!(
        s.warnings.iter().all(|w| !w.feature.contains("instancing")),
        "{:?}",
        s.warnings
    );
    let e = load_err(&write(d.path(), "uneven.gltf", file(&[one, one])));
    assert!(
        e.contains("node 0")
            && e.contains("EXT_mesh_gpu_instancing")
            && e.contains("counts differ"),
        "{e}"
    );
}

/// A volume's attenuation distance must be above 0 (`KHR_materials_volume`): a file with a
/// negative one is refused, naming the material and the value.
#[test]
fn a_volume_with_a_negative_attenuation_distance_is_refused() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let json = g.json(&format!(
        r#""extensionsUsed":["KHR_materials_transmission","KHR_materials_volume"],
        "scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":0}}]}}],
        "materials":[{{"name":"murky","extensions":{{"KHR_materials_transmission":{{"transmissionFactor":1}},
        "KHR_materials_volume":{{"thicknessFactor":1,"attenuationDistance":-2}}}}}}]"#
    ));
    let e = load_err(&write(d.path(), "murky.gltf", json));
    assert!(
        e.contains("murky") && e.contains("attenuationDistance -2"),
        "{e}"
    );
}

/// `KHR_mesh_quantization`, required: positions as normalized SHORTs (dequantized by the
/// node's scale and translation, as gltfpack writes them) and normals as normalized BYTEs load
/// as the floats they stand for; a normal of SHORTs that are not normalized, which the extension does not allow, is refused naming the accessor, and so
/// are the quantized positions of a file that does not use the extension.
#[test]
fn khr_mesh_quantization_is_read() {
    let d = dir();
    let mut g = Gltf::default();
    let shorts = |v: &[[i16; 3]]| -> Vec<u8> {
        v.iter()
            .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()).chain([0, 0]))
            .collect()
    };
    // A VEC3 of SHORTs takes 6 bytes and one of BYTEs 3, padded to 8 and 4 by a byteStride
    // (glTF 2.0 §3.6.2.4 aligns each element to 4 bytes).
    let p = g.accessor(
        &shorts(&[[0, 0, 0], [32767, 0, 0], [0, 0, -32767]]),
        r#""componentType":5122,"normalized":true,"count":3,"type":"VEC3""#,
    );
    let n = g.accessor(
        &[0u8, 127, 0, 0, 0, 127, 0, 0, 0, 127, 0, 0],
        r#""componentType":5120,"normalized":true,"count":3,"type":"VEC3""#,
    );
    let bad = g.accessor(
        &shorts(&[[0, 1, 0], [0, 1, 0], [0, 1, 0]]),
        r#""componentType":5122,"count":3,"type":"VEC3""#,
    );
    // Each accessor has a view of its own, with the view's index.
    for (v, stride) in [(p, 8), (n, 4), (bad, 8)] {
        g.views[v] = g.views[v].replace('}', &format!(r#","byteStride":{stride}}}"#));
    }
    let json = |normal: usize, used: bool| {
        let extension = if used {
            r#""extensionsUsed":["KHR_mesh_quantization"],"extensionsRequired":["KHR_mesh_quantization"],"#
        } else {
            ""
        };
        g.json(&format!(
            r#"{extension}
            "scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0,"scale":[2,2,2],"translation":[1,0,0]}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p},"NORMAL":{normal}}}}}]}}]"#
        ))
    };
    let s = load(&write(d.path(), "quantized.gltf", json(n, true)));
    let mesh = &s.meshes[0];
    assert_eq!(
        mesh.positions,
        [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(3.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, -2.0)
        ]
    );
    assert_eq!(mesh.normals.as_deref(), Some(&[Vec3::Y; 3][..]));
    let e = load_err(&write(d.path(), "bad.gltf", json(bad, true)));
    assert!(e.contains("NORMAL accessor") && e.contains("SHORT"), "{e}");
    // Without the extension, glTF 2.0 allows positions of FLOAT only.
    let e = load_err(&write(d.path(), "unused.gltf", json(n, false)));
    assert!(
        e.contains("POSITION accessor") && e.contains("which the file does not use"),
        "{e}"
    );
}

/// `KHR_materials_unlit`, required or only used: the material is unlit with its base colour,
/// coverage and sides; its other factors and textures (the extension's fallbacks) are a black
/// Lambertian's that emits nothing, and no warning names the extension. A scene lit by nothing
/// but unlit surfaces is not warned of as black.
#[test]
fn unlit_materials_keep_their_colour_and_drop_their_fallbacks() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let json = g.json(&format!(
        r#""extensionsUsed":["KHR_materials_unlit"],"extensionsRequired":["KHR_materials_unlit"],
        "scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}},"material":0}}]}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[1,0.2176376,0,0.5],
                       "metallicFactor":1,"roughnessFactor":0.2}},
                       "emissiveFactor":[1,1,1],"alphaMode":"MASK","doubleSided":false,
                       "extensions":{{"KHR_materials_unlit":{{}}}}}}]"#
    ));
    let s = load(&write(d.path(), "unlit.gltf", json));
    let m = s.materials[0];
    assert!(m.unlit);
    assert_eq!(m.albedo, Vec3::new(1.0, 0.217_637_6, 0.0));
    assert_eq!(
        (m.alpha, m.alpha_mode, m.two_sided),
        (0.5, crate::AlphaMode::Mask(0.5), false)
    );
    assert_eq!((m.metallic, m.roughness, m.specular), (0.0, 1.0, 0.0));
    assert_eq!(m.emission, Vec3::ZERO);
    let warnings: Vec<String> = s.warnings.iter().map(ToString::to_string).collect();
    assert!(
        warnings.iter().all(|w| !w.contains("KHR_materials_unlit ")),
        "{warnings:?}"
    );
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("only its unlit surfaces")),
        "{warnings:?}"
    );
}
