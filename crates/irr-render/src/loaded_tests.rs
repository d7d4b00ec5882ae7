//! Tests that load a glTF file and read the [`Scene`](crate::Scene) assembled from it: vertex
//! colours and textures as the integrators see them.

use crate::load_scene;
use glam::{Vec2, Vec3};
use irr_scene::testutil::{
    Gltf, base64, lin, png_bytes, texels, texture_transform, textured_quad, write,
};
use irr_scene::{Filter, Sampler, SceneData, TextureRef, Wrap, load_gltf};

/// A right triangle in the z = 0 plane.
const TRIANGLE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

fn dir() -> tempfile::TempDir {
    tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"))
}

/// `COLOR_0` multiplies the base colour (glTF 2.0 §3.7.2.1): normalized unsigned bytes in RGBA
/// (the alpha scaling the coverage) are read per vertex, follow the triangles' vertices (a mirroring transform's
/// swap included), and interpolate barycentrically; float colours outside [0, 1] are clamped
/// with a warning; `COLOR_1` is ignored with a warning.
#[test]
fn vertex_colours_multiply_the_base_colour() {
    let d = dir();
    let mut g = Gltf::default();
    let p = g.vec3(&TRIANGLE);
    let c0 = g.accessor(
        &[255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 128],
        r#""componentType":5121,"normalized":true,"count":3,"type":"VEC4""#,
    );
    let floats: Vec<u8> = [2.0f32, 0.5, 0.5, 0.5, -1.0, 0.5, 0.5, 0.5, 0.5]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let c1 = g.accessor(&floats, r#""componentType":5126,"count":3,"type":"VEC3""#);
    let json = g.json(&format!(
        r#""scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"mesh":0}},{{"mesh":1,"scale":[1,1,-1],"translation":[0,0,1]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p},"COLOR_0":{c0},"COLOR_1":{c1}}},"material":0}}]}},
                  {{"primitives":[{{"attributes":{{"POSITION":{p},"COLOR_0":{c1}}},"material":0}}]}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[0.5,0.5,0.5,1]}},"emissiveFactor":[1,1,1]}}]"#
    ));
    let path = write(d.path(), "c.gltf", json);
    let loaded = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    let features: Vec<(&str, usize)> = loaded
        .warnings
        .iter()
        .map(|w| (w.feature.as_str(), w.count))
        .collect();
    assert_eq!(
        features,
        [("vertex-colours", 1), ("colour-clamped", 2)],
        "{:?}",
        loaded.warnings
    );
    let s = &loaded.scene;
    // Triangle 0: vertex 0 red, vertex 1 green, vertex 2 blue, × 0.5.
    assert_eq!(s.albedo(0, 0.0, 0.0), Vec3::new(0.5, 0.0, 0.0));
    assert_eq!(s.albedo(0, 1.0, 0.0), Vec3::new(0.0, 0.5, 0.0));
    assert_eq!(s.albedo(0, 0.0, 1.0), Vec3::new(0.0, 0.0, 0.5));
    assert_eq!(s.albedo(0, 0.5, 0.5), Vec3::new(0.0, 0.25, 0.25));
    // Triangle 1 is mirrored (scale z −1): its vertices 1 and 2 swap, and their colours with
    // them; the clamped (2, 0.5, 0.5) and (0.5, −1, 0.5) read (1, 0.5, 0.5) and (0.5, 0, 0.5).
    assert_eq!(s.albedo(1, 0.0, 0.0), Vec3::new(0.5, 0.25, 0.25));
    assert_eq!(s.albedo(1, 1.0, 0.0), Vec3::splat(0.25));
    assert_eq!(s.albedo(1, 0.0, 1.0), Vec3::new(0.25, 0.0, 0.25));
    // The alphas: vertex 2's 128/255 on triangle 0; triangle 1's VEC3 colours have alpha 1.
    assert_eq!(s.alpha(0, 0.0, 1.0), 128.0 / 255.0);
    assert_eq!(s.alpha(0, 1.0, 0.0), 1.0);
    assert_eq!(s.alpha(1, 0.3, 0.3), 1.0);
}

/// A metallic-roughness texture is data, not colour: the same image read as a base colour
/// goes through the sRGB EOTF, and as a metallic-roughness texture is scaled to [0, 1]
/// (glTF 2.0 §3.9.2), each decoded once; the roughness is the factor × green, the metallic
/// factor × blue, on the texture's own coordinate set (a third set after the base colour's
/// and the emission's when it differs).
#[test]
fn a_metallic_roughness_texture_is_read_as_linear_data() {
    let d = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let orm = png_bytes(
        1,
        1,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        None,
        &[255, 128, 64],
    );
    let mut g = Gltf::default();
    let view = g.view_of(&orm);
    let rest = format!(
        r#""images":[{{"bufferView":{view},"mimeType":"image/png"}}],
        "textures":[{{"source":0}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}},
            "metallicFactor":0.5,"roughnessFactor":0.8,
            "metallicRoughnessTexture":{{"index":0,"texCoord":1}}}}}}]"#
    );
    let path = textured_quad(d.path(), "mr.gltf", &mut g, &rest);
    let s: SceneData = load_gltf(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.textures.len(), 2);
    let m = s.materials[0];
    assert_eq!(m.albedo_texture, Some(TextureRef::new(0, 0)));
    assert_eq!(m.metallic_roughness_texture, Some(TextureRef::new(1, 1)));
    assert_eq!(
        texels(&s.textures[0]),
        vec![Vec3::new(1.0, lin(128), lin(64))]
    );
    let data = |c: u8| (f64::from(c) / 255.0) as f32;
    assert_eq!(
        texels(&s.textures[1]),
        vec![Vec3::new(1.0, data(128), data(64))]
    );
    // Only the scene's darkness is warned of: no texture or image is left unread.
    let features: Vec<&str> = s.warnings.iter().map(|w| w.feature.as_str()).collect();
    assert_eq!(features, ["no-emitter"], "{:?}", s.warnings);
    let loaded = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    let (metallic, roughness) = loaded.scene.metallic_roughness(0, 0.3, 0.3);
    assert_eq!((metallic, roughness), (0.5 * data(64), 0.8 * data(128)));
}

#[test]
fn a_textured_material_reads_its_images_samplers_and_coordinates() {
    let d = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let red_green = png_bytes(
        2,
        1,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        None,
        &[255, 0, 0, 0, 255, 0],
    );
    let grey = png_bytes(
        1,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        None,
        &[128],
    );
    write(d.path(), "grey file.png", &grey);
    let mut g = Gltf::default();
    let view = g.view_of(&red_green);
    let rest = format!(
        r#""extensionsUsed":["KHR_texture_transform"],
        "images":[{{"bufferView":{view},"mimeType":"image/png"}},
                  {{"uri":"data:image/png;base64,{}"}},
                  {{"uri":"grey%20file.png","name":"grey"}}],
        "samplers":[{{"magFilter":9728,"minFilter":9728,"wrapS":33071,"wrapT":33648}},
                    {{"magFilter":9729,"minFilter":9987}}],
        "textures":[{{"source":0,"sampler":0}},{{"source":1}},{{"source":2,"sampler":1}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[0.5,0.5,0.5,1],
            "baseColorTexture":{{"index":0,"texCoord":1}}}},
            "emissiveFactor":[1,1,1],
            "emissiveTexture":{{"index":2,"extensions":{{"KHR_texture_transform":
                {{"offset":[0.5,0],"scale":[2,2],"texCoord":0}}}}}}}}]"#,
        base64(&grey)
    );
    let path = textured_quad(d.path(), "t.gltf", &mut g, &rest);
    let s: SceneData = load_gltf(&path).unwrap_or_else(|e| panic!("{e}"));
    // Textures 0 and 2 are read; texture 1 (and with it image 1) is not.
    assert_eq!(s.textures.len(), 2);
    let m = s.materials[0];
    assert_eq!(m.albedo_texture, Some(TextureRef::new(0, 1)));
    let e = m
        .emission_texture
        .unwrap_or_else(|| panic!("no emission texture"));
    assert_eq!((e.texture, e.tex_coord), (1, 0));
    assert_eq!(e.transform, texture_transform([0.5, 0.0], 0.0, [2.0, 2.0]));
    assert_eq!(
        s.textures[0].sampler(),
        Sampler {
            wrap_s: Wrap::ClampToEdge,
            wrap_t: Wrap::MirroredRepeat,
            filter: Filter::Nearest
        }
    );
    assert_eq!(s.textures[1].sampler(), Sampler::default());
    assert_eq!(texels(&s.textures[0]), vec![Vec3::X, Vec3::Y]);
    assert_eq!(texels(&s.textures[1]), vec![Vec3::splat(lin(128))]);
    let got: Vec<(&str, usize)> = s
        .warnings
        .iter()
        .map(|w| (w.feature.as_str(), w.count))
        .collect();
    for expected in [("textures", 1), ("images", 1), ("min-filter", 1)] {
        assert!(got.contains(&expected), "missing {expected:?} in {got:?}");
    }
    assert!(
        !got.iter().any(|(f, _)| f.contains("KHR_texture_transform")),
        "{got:?}"
    );
    // The material reads set 1 (albedo), then set 0 (emission): two triples per triangle,
    // u8 coordinates normalized by 255.
    let uv0 = [
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(0.0, 0.2),
    ];
    let uv1 = [
        Vec2::new(0.0, 0.0),
        Vec2::new(2.0, 0.0),
        Vec2::new(2.0, -1.0),
        Vec2::new(0.0, -1.0),
    ];
    let tri = |uv: &[Vec2; 4], t: [usize; 3]| t.map(|i| uv[i]);
    assert_eq!(
        s.tex_coords,
        vec![vec![
            tri(&uv1, [0, 1, 2]),
            tri(&uv0, [0, 1, 2]),
            tri(&uv1, [0, 2, 3]),
            tri(&uv0, [0, 2, 3]),
        ]]
    );
    // The whole scene builds: the texture coordinates follow the triangles' ids.
    let loaded = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    // Vertex 1 of triangle 0 has TEXCOORD_1 (2, 0): clamped in u to the green texel.
    assert_eq!(loaded.scene.albedo(0, 1.0, 0.0), Vec3::new(0.0, 0.5, 0.0));
    // Its centre, TEXCOORD_1 (4/3, −1/3): mirrored in v, still the green column.
    assert_eq!(
        loaded.scene.albedo(0, 1.0 / 3.0, 1.0 / 3.0),
        Vec3::new(0.0, 0.5, 0.0)
    );
    assert_eq!(
        loaded.scene.emitted(0, 0.0, 0.0, Vec3::Z, Vec3::Z),
        Vec3::splat(lin(128))
    );
}
