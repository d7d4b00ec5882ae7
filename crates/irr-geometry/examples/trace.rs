//! irr-geometry alone: a BVH over a few triangles, closest-hit queries checked against the
//! heights the scene is built with, and any-hit (shadow) queries.
//!
//! The scene: a 4×4 floor (y = 0, material 0) with a square pyramid on it (base 1×1, apex at
//! height 1, material 1), and one degenerate triangle, which the build drops and reports.
//!
//! Run with `cargo run -p irr-geometry --example trace`.

use glam::Vec3;
use irr_geometry::{Geometry, Ray, TriangleMesh};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let floor = TriangleMesh {
        positions: vec![
            Vec3::new(-2.0, 0.0, -2.0),
            Vec3::new(-2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, 2.0),
            Vec3::new(2.0, 0.0, -2.0),
        ],
        // Counter-clockwise seen from above, so the front face looks up (+y).
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: None,
        material_ids: vec![0; 2],
    };
    let (a, b, c, d) = (
        Vec3::new(-0.5, 0.0, -0.5),
        Vec3::new(-0.5, 0.0, 0.5),
        Vec3::new(0.5, 0.0, 0.5),
        Vec3::new(0.5, 0.0, -0.5),
    );
    let pyramid = TriangleMesh {
        positions: vec![a, b, c, d, Vec3::Y, Vec3::Y],
        // Four sides, then a triangle whose two last corners coincide: zero area, dropped.
        indices: vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [0, 4, 5]],
        normals: None,
        material_ids: vec![1; 5],
    };
    // Validates the meshes (bad indices or lengths are a typed error) and builds the BVH.
    let geometry = Geometry::build(&[floor, pyramid])?;
    let report = geometry.report();
    println!(
        "built: {} triangles kept, {} degenerate dropped",
        report.kept, report.dropped_degenerate
    );

    // Closest hits: rays straight down from y = 3 over a 41×41 grid. The pyramid's surface is
    // at y = 1 − 2·max(|x|, |z|) over its base, the floor at y = 0 elsewhere.
    let (mut worst, mut on_pyramid) = (0.0f32, 0);
    for j in 0..41 {
        for i in 0..41 {
            let (x, z) = (-1.9 + 0.095 * i as f32, -1.9 + 0.095 * j as f32);
            let ray = Ray::new(Vec3::new(x, 3.0, z), Vec3::NEG_Y);
            let hit = geometry
                .intersect(&ray)
                .ok_or("a ray down missed the floor")?;
            let surface = geometry.surface(&ray, &hit);
            let expected = (1.0 - 2.0 * x.abs().max(z.abs())).max(0.0);
            worst = worst.max((surface.position.y - expected).abs());
            on_pyramid += usize::from(surface.material_id == 1);
        }
    }
    println!("closest hit: 1681 rays down, {on_pyramid} on the pyramid, height error ≤ {worst:e}");

    // Any hit: is a light at (1.5, 2, 0) visible from floor points on a line through the
    // pyramid's shadow? `spawn_to` offsets both ends so neither surface shadows itself, and
    // `occluded` stops at the first blocker it meets, not the closest.
    let light = Vec3::new(1.5, 2.0, 0.0);
    let mut line = String::new();
    for i in 0..40 {
        let p = Vec3::new(-2.0 + 0.1 * i as f32 + 0.05, 0.0, 0.0);
        let shadow = Ray::spawn_to(p, Vec3::Y, light, Vec3::NEG_Y);
        let blocked = geometry.occluded(&shadow);
        // The closest-hit query over the same segment agrees (its t_max stops short of the
        // light).
        if blocked != geometry.intersect(&shadow).is_some() {
            return Err("occluded and intersect disagree".into());
        }
        line.push(if blocked { '#' } else { '.' });
    }
    println!("any hit: the floor along x from −2 to 2 (# in shadow): {line}");
    Ok(())
}
