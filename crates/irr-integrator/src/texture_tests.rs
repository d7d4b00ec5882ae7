//! Tests of textures read through a [`Scene`]: normal textures, coverage, albedo and emission
//! at a point, the light choice's texture means, and the scene's refusal of inconsistent
//! textures.

use crate::{
    Filter, Material, Sampler, Scene, SceneError, TexCoords, Texture, TextureRef, VertexAttribute,
    VertexTangents, Wrap,
};
use glam::{Affine2, Vec2, Vec3};
use irr_scene::testutil::two_by_two;

/// The unit square at z = 0 as two triangles, facing +z.
fn square(material: u32) -> irr_geometry::TriangleMesh {
    irr_geometry::TriangleMesh {
        positions: vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: None,
        material_ids: vec![material; 2],
    }
}

fn scene(
    meshes: &[irr_geometry::TriangleMesh],
    materials: Vec<Material>,
    textures: Vec<Texture>,
    tex_coords: TexCoords,
) -> Result<Scene, SceneError> {
    let geometry = irr_geometry::Geometry::build(meshes).unwrap_or_else(|e| panic!("{e}"));
    Scene::with_textures(geometry, materials, textures, tex_coords)
}

/// A normal texture of one texel `c` (linear, in [0, 1]) turns the shading normal of the
/// unit square (winding normal +z) to normalize((2c − 1)·(s, s, 1)) in the frame of
/// tangent t, bitangent w·(n × t), normal n; scale 0 leaves the vertex normal; a texel
/// that would tilt it below the surface is clamped to `MIN_COS_TO_GEOMETRY` above it; and
/// a triangle without tangents keeps its vertex normal.
#[test]
fn normal_textures_turn_the_shading_normal_in_the_tangent_frame() {
    use crate::scene::MIN_COS_TO_GEOMETRY;
    use glam::Vec4;
    let texel = Vec3::new(0.8, 0.3, 0.9);
    let texture = |texel: Vec3| {
        Texture::new(1, 1, vec![texel], Sampler::default()).unwrap_or_else(|e| panic!("{e}"))
    };
    let mut tex_coords = TexCoords::default();
    for _ in 0..2 {
        tex_coords
            .push(&[[Vec2::ZERO; 3]])
            .unwrap_or_else(|e| panic!("{e}"));
    }
    let material = |scale: f32| Material {
        normal_texture: Some(TextureRef::new(0, 0)),
        normal_scale: scale,
        ..Material::diffuse(Vec3::splat(0.5))
    };
    // Tangent +y with w = −1: bitangent −(z × y) = +x.
    let tangent = Vec4::new(0.0, 2.0, 0.0, -1.0);
    let shading = |texel: Vec3, scale: f32, tangents: [Option<[Vec4; 3]>; 2]| {
        let mut t = VertexTangents::default();
        for c in tangents {
            t.push(c).unwrap_or_else(|e| panic!("{e}"));
        }
        let s = scene(
            &[square(0)],
            vec![material(scale)],
            vec![texture(texel)],
            tex_coords.clone(),
        )
        .and_then(|s| s.with_tangents(t))
        .unwrap_or_else(|e| panic!("{e}"));
        let ray = irr_geometry::Ray::new(Vec3::new(0.7, 0.2, 1.0), -Vec3::Z);
        let hit = s
            .geometry()
            .intersect(&ray)
            .unwrap_or_else(|| panic!("no hit"));
        s.shading_normal(&s.geometry().surface(&ray, &hit))
    };
    let both = [Some([tangent; 3]); 2];
    for scale in [1.0f32, 0.5, -2.0] {
        let c = texel * 2.0 - Vec3::ONE;
        // x along t = +y, y along b = +x.
        let expected = Vec3::new(c.y * scale, c.x * scale, c.z).normalize();
        let n = shading(texel, scale, both);
        // A handful of f32 operations, each within 2⁻²⁴ relative, on unit-sized values.
        assert!(
            (n - expected).length() < 1e-6,
            "scale {scale}: {n} ≠ {expected}"
        );
    }
    assert_eq!(shading(texel, 0.0, both), Vec3::Z);
    // A texel of blue below ½ points below the surface: clamped to the limit.
    let n = shading(Vec3::new(0.8, 0.3, 0.3), 1.0, both);
    assert!((n.z - MIN_COS_TO_GEOMETRY).abs() < 1e-6, "{n}");
    assert!((n.length() - 1.0).abs() < 1e-6);
    // The point is on triangle 0 (x > y); without its tangents it keeps the vertex normal.
    assert_eq!(shading(texel, 1.0, [None, Some([tangent; 3])]), Vec3::Z);
}

/// A placed triangle's per-vertex data is its prototype's, read by attribute id, and its
/// tangent is turned by its placement: a normal-textured square placed (second) turned a
/// quarter about x and moved shades as its world-space copy, whose tangents are turned alike;
/// its albedo texture's coordinates are the prototype's (checked: reading tangents unturned,
/// or texture coordinates by the hit's id, fails it).
#[test]
fn placed_normal_textures_turn_with_their_placement() {
    use glam::{DAffine3, DQuat, DVec3, Vec4};
    use irr_geometry::{Geometry, Instance, Ray};
    let texel = Vec3::new(0.8, 0.3, 0.9);
    let normal =
        Texture::new(1, 1, vec![texel], Sampler::default()).unwrap_or_else(|e| panic!("{e}"));
    let albedo = Texture::new(
        2,
        1,
        vec![Vec3::splat(0.2), Vec3::splat(0.7)],
        Sampler::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let material = Material {
        normal_texture: Some(TextureRef::new(0, 0)),
        albedo_texture: Some(TextureRef::new(1, 0)),
        ..Material::diffuse(Vec3::ONE)
    };
    let place = DAffine3::from_rotation_translation(
        DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2),
        DVec3::new(3.0, 0.0, 0.0),
    );
    let uv = [[
        Vec2::new(0.1, 0.5),
        Vec2::new(0.9, 0.5),
        Vec2::new(0.9, 0.5),
    ]; 2];
    // Not along the axis the placement turns onto the normal: unturned, it would still give
    // a frame, but another one.
    let tangent = Vec4::new(1.0, 1.0, 0.0, -1.0);
    let turned = place
        .transform_vector3(tangent.truncate().as_dvec3())
        .as_vec3()
        .extend(-1.0);
    // Two triangles of per-vertex data: the prototype's, or the copy's.
    let attributes = |t: Vec4| {
        let mut tex_coords = TexCoords::default();
        let mut tangents = VertexTangents::default();
        for k in 0..2 {
            tex_coords
                .push(&uv[k..=k])
                .unwrap_or_else(|e| panic!("{e}"));
            tangents
                .push(Some([t; 3]))
                .unwrap_or_else(|e| panic!("{e}"));
        }
        (tex_coords, tangents)
    };
    let placed = Geometry::build_instanced(
        Vec::new(),
        vec![square(0)],
        &[
            // Another placement first, so that the one the ray meets has ids 2 and 3 and
            // attribute ids 0 and 1.
            Instance {
                prototype: 0,
                to_world: DAffine3::from_translation(DVec3::new(-3.0, 0.0, 0.0)),
                material_id: None,
            },
            Instance {
                prototype: 0,
                to_world: place,
                material_id: None,
            },
        ],
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let mut copy = square(0);
    for p in &mut copy.positions {
        *p = place.transform_point3(p.as_dvec3()).as_vec3();
    }
    let copied = Geometry::build(&[copy]).unwrap_or_else(|e| panic!("{e}"));
    let shade = |geometry: Geometry, t: Vec4| {
        let (tex_coords, tangents) = attributes(t);
        let s = Scene::with_textures(
            geometry,
            vec![material],
            vec![normal.clone(), albedo.clone()],
            tex_coords,
        )
        .and_then(|s| s.with_tangents(tangents))
        .unwrap_or_else(|e| panic!("{e}"));
        // The square, turned to the plane y = 0 facing +y, seen from above.
        let ray = Ray::new(Vec3::new(3.7, 1.0, 0.2), -Vec3::Y);
        let hit = s
            .geometry()
            .intersect(&ray)
            .unwrap_or_else(|| panic!("no hit"));
        let surface = s.geometry().surface(&ray, &hit);
        let n = s.shading_normal(&surface);
        assert!(
            n.dot(surface.geometric_normal) < 0.99,
            "the texel turns it: {n}"
        );
        (n, s.albedo(hit.triangle, hit.b1, hit.b2))
    };
    let (n_placed, a_placed) = shade(placed, tangent);
    let (n_copied, a_copied) = shade(copied, turned);
    // The same f32 operations on the same unit-sized values, but for the mapped vertices and
    // tangent (each within an ulp of the other's): a few ulps.
    assert!(
        (n_placed - n_copied).length() < 1e-6,
        "{n_placed} vs {n_copied}"
    );
    assert_eq!(a_placed, a_copied);
}

/// The coverage α is the factor × the vertex alphas (interpolated); a cut-out blocks a ray
/// where α reaches its cutoff, a blend with probability α; an opaque material always; and
/// vertex alphas make a non-opaque material with factor 1 cut out.
#[test]
fn coverage_is_the_factor_times_vertex_alpha() {
    use crate::AlphaMode;
    let material = |mode| Material {
        alpha_mode: mode,
        alpha: 0.8,
        ..Material::diffuse(Vec3::splat(0.5))
    };
    let build = |mode| {
        let mut alphas = VertexAttribute::<f32>::default();
        for a in [[0.0, 1.0, 1.0], [1.0, 1.0, 1.0]] {
            alphas.push(Some(a)).unwrap_or_else(|e| panic!("{e}"));
        }
        scene(
            &[square(0)],
            vec![material(mode)],
            vec![],
            TexCoords::default(),
        )
        .and_then(|s| s.with_vertex_alphas(alphas))
        .unwrap_or_else(|e| panic!("{e}"))
    };
    let s = build(AlphaMode::Mask(0.5));
    // Triangle 0's vertex 0 has alpha 0: at barycentrics (b1, b2), α = 0.8·(b1 + b2).
    assert!((s.alpha(0, 0.25, 0.25) - 0.4).abs() < 1e-6);
    assert_eq!(s.alpha(1, 0.25, 0.25), 0.8);
    let ray = irr_geometry::Ray::new(Vec3::new(0.5, 0.5, 1.0), -Vec3::Z);
    let hit = |b1: f32, b2: f32| irr_geometry::Hit {
        t: 1.0,
        triangle: 0,
        b1,
        b2,
    };
    assert!(!s.blocks(&ray, &hit(0.25, 0.25)));
    assert!(s.blocks(&ray, &hit(0.5, 0.25)));
    // A blend: of many rays through the point of α = 0.4, about 40 % are blocked (the
    // count of 4096 independent draws is within 5 standard deviations, √(4096·0.24) = 31).
    let s = build(AlphaMode::Blend);
    let blocked = (0..4096)
        .filter(|&i| {
            let r = irr_geometry::Ray::new(Vec3::new(0.5, 0.5, 1.0 + i as f32), -Vec3::Z);
            s.blocks(&r, &hit(0.25, 0.25))
        })
        .count();
    assert!(
        (blocked as f64 - 0.4 * 4096.0).abs() < 5.0 * 31.4,
        "{blocked}"
    );
    assert!(build(AlphaMode::Opaque).blocks(&ray, &hit(0.0, 0.0)));
    // Alphas outside [0, 1] are refused.
    let mut bad = VertexAttribute::<f32>::default();
    for _ in 0..2 {
        bad.push(Some([0.5, 1.5, 1.0]))
            .unwrap_or_else(|e| panic!("{e}"));
    }
    let e = scene(
        &[square(0)],
        vec![material(AlphaMode::Blend)],
        vec![],
        TexCoords::default(),
    )
    .and_then(|s| s.with_vertex_alphas(bad))
    .err()
    .map(|e| e.to_string())
    .unwrap_or_default();
    assert!(e.contains("alphas: 1.5 is not an alpha in [0, 1]"), "{e}");
}

#[test]
fn scene_reads_albedo_and_emission_at_the_point() {
    let nearest = Sampler {
        filter: Filter::Nearest,
        ..Sampler::default()
    };
    let albedo = Texture::new(
        2,
        2,
        vec![Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0), Vec3::Y, Vec3::ONE],
        nearest,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let values = Texture::new(1, 2, vec![Vec3::splat(0.25), Vec3::ONE], nearest)
        .unwrap_or_else(|e| panic!("{e}"));
    let shift = Affine2::from_translation(Vec2::new(0.5, 0.0));
    let material = Material {
        albedo: Vec3::new(0.5, 0.5, 0.05),
        emission: Vec3::splat(2.0),
        two_sided: false,
        albedo_texture: Some(TextureRef::new(1, 3)),
        emission_texture: Some(TextureRef {
            transform: shift,
            ..TextureRef::new(0, 0)
        }),
        ..Material::diffuse(Vec3::ZERO)
    };
    assert_eq!(material.tex_coord_sets().collect::<Vec<_>>(), [3, 0]);
    // A third texture on a set already read adds no set; on a new one, a third, after the
    // others.
    let on = |set| Material {
        metallic_roughness_texture: Some(TextureRef::new(0, set)),
        ..material
    };
    assert_eq!(on(3).tex_coord_sets().collect::<Vec<_>>(), [3, 0]);
    assert_eq!(on(1).tex_coord_sets().collect::<Vec<_>>(), [3, 0, 1]);
    assert_eq!(on(1).slot(&TextureRef::new(0, 1)), 2);
    assert_eq!(on(1).slot(&TextureRef::new(0, 0)), 1);
    // A normal texture on a fourth set makes four.
    let normal = Material {
        normal_texture: Some(TextureRef::new(0, 2)),
        ..on(1)
    };
    assert_eq!(normal.tex_coord_sets().collect::<Vec<_>>(), [3, 0, 1, 2]);
    assert_eq!(normal.slot(&TextureRef::new(0, 2)), 3);
    // Set 3 (albedo) spans the square's corners as uv = (x, y); set 0 (emission) is (y, x).
    let corners = |t: [usize; 3], f: fn(Vec2) -> Vec2| {
        let c = [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y];
        t.map(|i| f(c[i]))
    };
    let mut tex_coords = TexCoords::default();
    for t in [[0, 1, 2], [0, 2, 3]] {
        tex_coords
            .push(&[corners(t, |c| c), corners(t, |c| Vec2::new(c.y, c.x))])
            .unwrap_or_else(|e| panic!("{e}"));
    }
    // Textures in the order the material names them: 0 is `values`, 1 is `albedo`.
    let s = scene(
        &[square(0)],
        vec![material],
        vec![values, albedo],
        tex_coords,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    // Triangle 0 at barycentrics (b1, b2) = (0.5, 0.25): the point (0.75, 0.25), albedo
    // texel (1, 0) of the 2×2 (z = 1) times the factor.
    assert_eq!(s.albedo(0, 0.5, 0.25), Vec3::new(0.5, 0.0, 0.05));
    // Emission at set 0's (0.25, 0.75) shifted by (0.5, 0) to (0.75, 0.75): row 1 of the
    // 1×2 texture (1), times 2; nothing from the back.
    assert_eq!(s.emitted(0, 0.5, 0.25, Vec3::Z, Vec3::Z), Vec3::splat(2.0));
    assert_eq!(s.emitted(0, 0.5, 0.25, Vec3::Z, -Vec3::Z), Vec3::ZERO);
    // At (x, y) = (0.25, 0.25): albedo texel (0, 0) is black; emission row 0 is 0.25.
    assert_eq!(s.albedo(0, 0.0, 0.25), Vec3::ZERO);
    assert_eq!(s.emitted(0, 0.0, 0.25, Vec3::Z, Vec3::Z), Vec3::splat(0.5));
    assert_eq!(
        s.tex_coord(0, &TextureRef::new(1, 3), 0.0, 0.25),
        Vec2::splat(0.25)
    );
    // The light sampler weighs the emitter by its factor × the texture's mean, 2 × 0.625.
    let light = s.lights().pdf_area(0);
    assert!(light > 0.0, "{light}");
}

#[test]
fn light_choice_weighs_a_textured_emitter_by_its_mean() {
    // Two unit squares side by side: one emits 0.25 uniformly, the other 1 × a texture of
    // mean 0.25 (black and white texels 1 : 3). Same power, so each is chosen with
    // probability ½ and every point has density ½ per unit area.
    let texture = Texture::new(
        2,
        2,
        vec![Vec3::ONE, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO],
        Sampler::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let mut right = square(1);
    for p in &mut right.positions {
        p.x += 2.0;
    }
    let uniform = Material {
        emission: Vec3::splat(0.25),
        ..Material::diffuse(Vec3::ZERO)
    };
    let textured = Material {
        emission: Vec3::ONE,
        emission_texture: Some(TextureRef::new(0, 0)),
        ..uniform
    };
    let mut tex_coords = TexCoords::default();
    for sets in [0, 0, 1, 1] {
        tex_coords
            .push(&vec![[Vec2::ZERO; 3]; sets])
            .unwrap_or_else(|e| panic!("{e}"));
    }
    let s = scene(
        &[square(0), right],
        vec![uniform, textured],
        vec![texture],
        tex_coords,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    for t in 0..4 {
        assert_eq!(s.lights().pdf_area(t), 0.5, "triangle {t}");
    }
}

#[test]
fn scene_refuses_inconsistent_textures() {
    let texture = two_by_two(Wrap::Repeat, Filter::Linear);
    let textured = Material {
        albedo_texture: Some(TextureRef::new(0, 0)),
        ..Material::diffuse(Vec3::ONE)
    };
    let two = || {
        let mut c = TexCoords::default();
        for _ in 0..2 {
            c.push(&[[Vec2::ZERO; 3]]).unwrap_or_else(|e| panic!("{e}"));
        }
        c
    };
    // The 2×2 test texture has texels above 1: not an albedo.
    let bright = scene(&[square(0)], vec![textured], vec![texture.clone()], two());
    assert!(
        matches!(
            bright,
            Err(SceneError::InvalidTextureRef {
                what: "albedo texture",
                ..
            })
        ),
        "{bright:?}"
    );
    let unit =
        Texture::new(1, 1, vec![Vec3::ONE], Sampler::default()).unwrap_or_else(|e| panic!("{e}"));
    let missing = scene(&[square(0)], vec![textured], vec![], two());
    assert!(
        matches!(missing, Err(SceneError::InvalidTextureRef { .. })),
        "{missing:?}"
    );
    let infinite = Material {
        albedo_texture: Some(TextureRef {
            transform: Affine2::from_scale(Vec2::splat(f32::INFINITY)),
            ..TextureRef::new(0, 0)
        }),
        ..textured
    };
    assert!(scene(&[square(0)], vec![infinite], vec![unit.clone()], two()).is_err());
    let short = scene(
        &[square(0)],
        vec![textured],
        vec![unit.clone()],
        TexCoords::default(),
    );
    assert!(
        matches!(
            short,
            Err(SceneError::TexCoordCount {
                triangles: 2,
                found: 0
            })
        ),
        "{short:?}"
    );
    let mut wrong = TexCoords::default();
    wrong
        .push(&[[Vec2::ZERO; 3]])
        .unwrap_or_else(|e| panic!("{e}"));
    wrong.push(&[]).unwrap_or_else(|e| panic!("{e}"));
    let wrong = scene(&[square(0)], vec![textured], vec![unit.clone()], wrong);
    assert!(
        matches!(
            wrong,
            Err(SceneError::TexCoords {
                triangle: 1,
                expected: 1,
                found: 0
            })
        ),
        "{wrong:?}"
    );
    assert!(scene(&[square(0)], vec![textured], vec![unit], two()).is_ok());
    // An untextured scene keeps no texture coordinates at all.
    let plain = scene(
        &[square(0)],
        vec![Material::diffuse(Vec3::ONE)],
        vec![],
        TexCoords::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(plain.tex_coords().is_empty());
    assert_eq!(plain.albedo(1, 0.3, 0.3), Vec3::ONE);
}

/// A transmission texture's red channel multiplies the transmission factor: a clear pane of
/// factor 1 under a texel of (0.5, 0, 0) passes rays, and reflects, exactly as the same pane of
/// factor 0.5 untextured (0.5 × 1 is exact), and the texture's other channels are not read.
#[test]
fn a_transmission_texture_scales_the_factor_by_its_red_channel() {
    let texel = Texture::new(1, 1, vec![Vec3::new(0.5, 0.0, 0.0)], Sampler::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let glass = |transmission, transmission_texture| Material {
        transmission,
        transmission_texture,
        ..Material::metallic_roughness(Vec3::ONE, 0.0, 0.0)
    };
    let mut tex_coords = TexCoords::default();
    for _ in 0..2 {
        tex_coords
            .push(&[[Vec2::ZERO; 3]])
            .unwrap_or_else(|e| panic!("{e}"));
    }
    let textured = scene(
        &[square(0)],
        vec![glass(1.0, Some(TextureRef::new(0, 0)))],
        vec![texel],
        tex_coords,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let plain = scene(
        &[square(0)],
        vec![glass(0.5, None)],
        vec![],
        TexCoords::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(textured.transmission(0, 0.3, 0.3), 0.5);
    for direction in [Vec3::Z, Vec3::new(0.6, 0.0, 0.8)] {
        let p = textured.pass_probability(0, 0.3, 0.3, direction);
        assert_eq!(p, plain.pass_probability(0, 0.3, 0.3, direction));
        assert!(p > 0.0 && p < 0.5, "{p}");
    }
    assert_eq!(
        textured.reflection(0, 0.3, 0.3),
        plain.reflection(0, 0.3, 0.3)
    );
}
