//! Incoherent-ray throughput of irr-geometry: closest hit and occlusion, single-threaded and
//! on all cores, on (a) a Cornell box (36 triangles) and (b) a generated scene of over 10⁶
//! triangles (a 512 × 512 height field and 420 spheres above it).
//!
//! Each iteration traces the same 2¹⁶ rays; divan's `item/s` column is rays per second (so
//! `Mitem/s` reads as Mrays/s). The rays are those of a path tracer's second bounce, the
//! incoherent kind: primary rays from a pinhole camera through random image points hit the
//! scene, and from each hit point
//! - a closest-hit ray leaves in a cosine-distributed direction around the normal (on the side
//!   the camera ray came from), spawned with `Ray::spawn`;
//! - an occlusion ray goes to a uniformly random point of the scene's area light, built with
//!   `Ray::spawn_to` (a segment, `t_max = 1`).
//!
//! `*_in_render_order` traces the same kinds of rays in the order a renderer makes them: one
//! primary ray per pixel of a 256 × 256 image, pixels row by row within 16 × 16 tiles, tiles
//! row by row (the second bounce of a path tracer's first sample; fewer than 2¹⁶ rays where
//! primary rays miss). Neighbouring rays then start close together and share their part of
//! the tree, which stays in cache: a change that speeds up the incoherent rays above can slow
//! these, and renders with them (docs/performance.md has such changes).
//!
//! `closest_stream` and `occluded_stream` trace the random-order rays in batches of 4096 (a
//! 32 × 128 gather's), one `Geometry::intersect_stream` or `Geometry::occluded_stream` call
//! each: on a tree larger than the caches those keep several rays in flight, so that their
//! waits for memory overlap.
//!
//! The scenes are built once per process, outside the timings.
//!
//! Also: `gather_one_by_one` and `gather_intersect_many`, an irradiance-cache record's
//! gathers in the Cornell box (records at primary hits, 16 × 64 and 32 × 128 stratified
//! cosine-weighted rays each, 2¹⁶ rays in all) traced with `intersect` and with one
//! `intersect_many` call per record; and `build_same_centroid`, the build time of 10⁴ and 10⁵
//! nested triangles sharing one centroid (`IRR_BUILD=<n>` times one build of `n`, e.g. 10⁶;
//! `IRR_BUILD=<n>:ploc` times obvhs's PLOC + reinsertion alone, the build irr used before
//! it handled such clusters).
//!
//! `IRR_BUILD=heightfield:<n>` times `Geometry::build_owned` on the heightfield of
//! `docs/make-huge-scene.py` with about `n` triangles and prints its heap bytes per triangle
//! (`IRR_BUILD_REPEATS=<k>`: best of k). `IRR_SCALE=<k>` shrinks the 10⁶-triangle scene (grid
//! side / k, spheres / k²: 64 386 triangles at 4, 3 266 at 16) for measurements at other sizes.
//!
//! Run with `cargo bench -p irr-geometry`. For a profile, set
//! `IRR_PROFILE=<cornell|million>:<bvh2|wide4|wide8>:<closest|occluded|closest-in-order|occluded-in-order|gather<M>x<N>[many|stream]>`
//! (the first four also with `-stream`: in batches, as `closest_stream`)
//! and run the bench binary under `valgrind --tool=callgrind` (with
//! `--collect-atstart=no --toggle-collect='*trace::trace*'` to count only the tracing): it
//! then traces that case's rays once (or `IRR_PROFILE_REPEATS` times, printing the best rate),
//! outside divan, and exits. `docs/ab-trace.py` runs one such case for several builds in turn
//! on one core (the baseline first) and prints their ratios: how the traversal's changes are
//! measured (docs/performance.md, how the traversal is measured).

use std::sync::LazyLock;
use std::time::Instant;

use divan::{Bencher, counter::ItemsCount};
use glam::Vec3;
use irr_geometry::{BvhLayout, Geometry, Ray, TriangleMesh};

fn main() {
    if let Ok(spec) = std::env::var("IRR_BUILD") {
        return build_time(&spec);
    }
    match std::env::var("IRR_PROFILE") {
        Ok(spec) => profile(&spec),
        Err(_) => divan::main(),
    }
}

/// `n` nested triangles sharing one centroid (and one box centre: the origin), each 1.0001
/// times the size of the previous one (1.00001 beyond 10⁵ triangles, so that the largest stays
/// finite): the input on which PLOC stalls (see irr-geometry's `build.rs`).
fn same_centroid(n: usize) -> Vec<TriangleMesh> {
    let factor: f32 = if n <= 100_000 { 1.0001 } else { 1.00001 };
    let shape = [
        Vec3::new(-1.0, -1.0, -1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let mut mesh = TriangleMesh::default();
    let mut scale = 1.0f32;
    for k in 0..n as u32 {
        mesh.positions.extend(shape.map(|p| p * scale));
        mesh.indices.push([3 * k, 3 * k + 1, 3 * k + 2]);
        scale *= factor;
    }
    mesh.material_ids = vec![0; n];
    vec![mesh]
}

/// `IRR_BUILD=<n>[:ploc]`: the time to build `n` same-centroid triangles, with
/// `Geometry::build` or (`:ploc`) with the obvhs recipe irr-geometry used before it detected
/// such clusters (PLOC with search radius 14, then reinsertion).
fn build_time(spec: &str) {
    if let Some(n) = spec.strip_prefix("heightfield:") {
        return heightfield_build_time(n);
    }
    let (n, ploc) = match spec.split_once(':') {
        Some((n, _)) => (n, true),
        None => (spec, false),
    };
    let n: usize = n
        .parse()
        .unwrap_or_else(|_| panic!("IRR_BUILD={spec}: not a count"));
    let meshes = same_centroid(n);
    let start = Instant::now();
    if ploc {
        use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};
        let aabbs: Vec<obvhs::aabb::Aabb> = meshes[0]
            .indices
            .iter()
            .map(|t| {
                let p = t.map(|i| meshes[0].positions[i as usize]);
                obvhs::aabb::Aabb::new(
                    p[0].min(p[1]).min(p[2]).into(),
                    p[0].max(p[1]).max(p[2]).into(),
                )
            })
            .collect();
        let mut bvh = PlocBuilder::with_capacity(n).build(
            PlocSearchDistance::Medium,
            &aabbs,
            (0..n as u32).collect(),
            SortPrecision::U64,
            3,
        );
        obvhs::bvh2::reinsertion::ReinsertionOptimizer::default().run(&mut bvh, 0.05, None);
        divan::black_box(bvh);
    } else {
        divan::black_box(Geometry::build(&meshes).unwrap_or_else(|e| panic!("{e}")));
    }
    println!(
        "{n} same-centroid triangles ({}): built in {:.3} s",
        if ploc {
            "obvhs PLOC + reinsertion"
        } else {
            "Geometry::build"
        },
        start.elapsed().as_secs_f64()
    );
}

/// The scene of `docs/make-huge-scene.py` with about `n` triangles, as the glTF loader hands it
/// over: a 2 × 2 heightfield of k × k quads (2k² ≥ n triangles, shared vertices, no normals) and
/// a 1 m² emitter above it.
fn heightfield(n: usize) -> Vec<TriangleMesh> {
    let k = ((n as f64 / 2.0).sqrt().ceil() as u32).max(1);
    let mut field = TriangleMesh::default();
    for j in 0..=k {
        let z = -1.0 + 2.0 * f64::from(j) / f64::from(k);
        for i in 0..=k {
            let x = -1.0 + 2.0 * f64::from(i) / f64::from(k);
            let y = 0.05 * (7.0 * x).sin() * (5.0 * z).cos();
            field
                .positions
                .push(Vec3::new(x as f32, y as f32, z as f32));
        }
    }
    for j in 0..k {
        for i in 0..k {
            let a = j * (k + 1) + i;
            let (b, c, d) = (a + 1, a + k + 1, a + k + 2);
            field.indices.extend([[a, c, b], [b, c, d]]);
        }
    }
    field.material_ids = vec![0; field.indices.len()];
    let mut light = TriangleMesh::default();
    let v = Vec3::new;
    quad(
        &mut light,
        [
            v(-0.5, 2.0, -0.5),
            v(0.5, 2.0, -0.5),
            v(0.5, 2.0, 0.5),
            v(-0.5, 2.0, 0.5),
        ],
        1,
    );
    vec![field, light]
}

/// `IRR_BUILD=heightfield:<n>`: the time of `Geometry::build_owned` on [`heightfield`]`(n)`
/// (best of `IRR_BUILD_REPEATS`, default 1) and the heap bytes per triangle of the result.
fn heightfield_build_time(n: &str) {
    let n: usize = n
        .parse()
        .unwrap_or_else(|_| panic!("IRR_BUILD=heightfield:{n}: not a count"));
    let repeats: usize = std::env::var("IRR_BUILD_REPEATS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(1);
    let mut best = f64::INFINITY;
    for _ in 0..repeats {
        let meshes = heightfield(n);
        let start = Instant::now();
        let g = Geometry::build_owned(meshes).unwrap_or_else(|e| panic!("{e}"));
        let first = best.is_infinite();
        best = best.min(start.elapsed().as_secs_f64());
        if first {
            let count = g.triangle_count() as f64;
            let bytes = g.heap_bytes();
            let total: usize = bytes.iter().map(|(_, b)| b).sum();
            let parts: Vec<String> = bytes
                .iter()
                .map(|(name, b)| format!("{name} {:.1}", *b as f64 / count))
                .collect();
            eprintln!(
                "heightfield: {} triangles, {} nodes, {:.1} heap bytes per triangle ({})",
                g.triangle_count(),
                g.node_count(),
                total as f64 / count,
                parts.join(", ")
            );
        }
    }
    println!("heightfield of {n} triangles: built in {best:.3} s (best of {repeats})");
}

/// Build time of `n` nested triangles sharing one centroid (see `same_centroid`); 10⁶ with
/// `IRR_BUILD=1000000` (it takes a few seconds).
#[divan::bench(args = [10_000, 100_000], sample_count = 3)]
fn build_same_centroid(bencher: Bencher, n: usize) {
    let meshes = same_centroid(n);
    bencher.bench(|| Geometry::build(divan::black_box(&meshes)));
}

/// Traces one case's rays once (see the module docs).
fn profile(spec: &str) {
    let parts: Vec<&str> = spec.split(':').collect();
    let [name, layout, query] = parts[..] else {
        panic!("IRR_PROFILE={spec}: expected <scene>:<layout>:<query>");
    };
    let layout = match layout {
        "bvh2" => BvhLayout::Bvh2,
        "wide4" => BvhLayout::Wide4,
        _ => BvhLayout::Wide8,
    };
    let (meshes, camera, light) = setup(name);
    let s = scene(name, &meshes, layout, &camera, light);
    // `<query>-stream`: the rays in batches of `BATCH`, each with one `intersect_stream` (or
    // `occluded_stream`) call.
    let streamed = query.ends_with("-stream");
    let query = query.trim_end_matches("-stream");
    let occlusion = query.starts_with("occluded");
    let in_order = query.ends_with("in-order");
    // `gather<M>x<N>` traces gathers one ray at a time, `gather<M>x<N>many` with
    // `intersect_many`, `gather<M>x<N>stream` with `intersect_stream`.
    let gather = query.strip_prefix("gather").map(|g| {
        let how = match g {
            _ if g.ends_with("many") => Batch::Many,
            _ if g.ends_with("stream") => Batch::Stream,
            _ => Batch::One,
        };
        let (m, n) = g
            .trim_end_matches(char::is_alphabetic)
            .split_once('x')
            .unwrap_or(("16", "64"));
        let (m, n) = (m.parse().unwrap_or(16), n.parse().unwrap_or(64));
        (gather_rays(&s.geometry, &camera, m, n), how, m * n)
    });
    let rays = match &gather {
        Some((g, _, _)) => g,
        None if in_order && occlusion => &s.shadow_in_order,
        None if in_order => &s.closest_in_order,
        None if occlusion => &s.shadow,
        None => &s.closest,
    };
    let repeats: usize = std::env::var("IRR_PROFILE_REPEATS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(1);
    let mut best = f64::INFINITY;
    let mut hits = 0;
    for _ in 0..repeats {
        let start = Instant::now();
        hits = match &gather {
            Some((g, how, per_record)) => trace_batches(&s.geometry, g, false, *per_record, *how),
            None if streamed => trace_batches(&s.geometry, rays, occlusion, BATCH, Batch::Stream),
            None => trace(&s.geometry, rays, occlusion, 1),
        };
        best = best.min(start.elapsed().as_secs_f64());
    }
    println!(
        "{spec}: {hits} of {} rays hit, best of {repeats}: {:.3} Mrays/s",
        rays.len(),
        rays.len() as f64 / best / 1e6
    );
}

/// Rays per iteration.
const RAYS: usize = 1 << 16;

/// SplitMix64, for reproducible scenes and rays.
struct Rng(u64);

impl Rng {
    fn f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
    fn in_box(&mut self, min: Vec3, max: Vec3) -> Vec3 {
        min + (max - min) * Vec3::new(self.f32(), self.f32(), self.f32())
    }
    /// A cosine-distributed direction around the unit `n`.
    fn cosine(&mut self, n: Vec3) -> Vec3 {
        let (u, v) = (self.f32(), self.f32());
        let r = u.sqrt();
        let phi = std::f32::consts::TAU * v;
        let t = n.any_orthonormal_vector();
        let b = n.cross(t);
        (t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u).max(0.0).sqrt()).normalize()
    }
}

/// Appends a quad (two triangles) to `mesh`.
fn quad(mesh: &mut TriangleMesh, corners: [Vec3; 4], material: u32) {
    let base = mesh.positions.len() as u32;
    mesh.positions.extend(corners);
    mesh.indices
        .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    mesh.material_ids.extend([material; 2]);
}

/// Appends a closed box (12 triangles) rotated by `angle` about y.
fn rotated_box(mesh: &mut TriangleMesh, centre: Vec3, half: Vec3, angle: f32, material: u32) {
    let q = glam::Quat::from_rotation_y(angle);
    let c = |x: f32, y: f32, z: f32| centre + q * (Vec3::new(x, y, z) * half);
    let faces = [
        [
            c(-1., -1., -1.),
            c(-1., -1., 1.),
            c(-1., 1., 1.),
            c(-1., 1., -1.),
        ],
        [
            c(1., -1., -1.),
            c(1., 1., -1.),
            c(1., 1., 1.),
            c(1., -1., 1.),
        ],
        [
            c(-1., -1., -1.),
            c(1., -1., -1.),
            c(1., -1., 1.),
            c(-1., -1., 1.),
        ],
        [
            c(-1., 1., -1.),
            c(-1., 1., 1.),
            c(1., 1., 1.),
            c(1., 1., -1.),
        ],
        [
            c(-1., -1., -1.),
            c(-1., 1., -1.),
            c(1., 1., -1.),
            c(1., -1., -1.),
        ],
        [
            c(-1., -1., 1.),
            c(1., -1., 1.),
            c(1., 1., 1.),
            c(-1., 1., 1.),
        ],
    ];
    for f in faces {
        quad(mesh, f, material);
    }
}

/// The Cornell box: five walls, a light quad under the ceiling and two rotated boxes: 36
/// triangles in [0, 1]³, open at the front (z = 1).
fn cornell_box() -> Vec<TriangleMesh> {
    let mut m = TriangleMesh::default();
    let v = Vec3::new;
    quad(
        &mut m,
        [v(0., 0., 0.), v(1., 0., 0.), v(1., 0., 1.), v(0., 0., 1.)],
        0,
    ); // floor
    quad(
        &mut m,
        [v(0., 1., 0.), v(0., 1., 1.), v(1., 1., 1.), v(1., 1., 0.)],
        0,
    ); // ceiling
    quad(
        &mut m,
        [v(0., 0., 0.), v(0., 1., 0.), v(1., 1., 0.), v(1., 0., 0.)],
        0,
    ); // back
    quad(
        &mut m,
        [v(0., 0., 0.), v(0., 0., 1.), v(0., 1., 1.), v(0., 1., 0.)],
        1,
    ); // left
    quad(
        &mut m,
        [v(1., 0., 0.), v(1., 1., 0.), v(1., 1., 1.), v(1., 0., 1.)],
        2,
    ); // right
    quad(
        &mut m,
        [
            v(0.4, 0.999, 0.4),
            v(0.6, 0.999, 0.4),
            v(0.6, 0.999, 0.6),
            v(0.4, 0.999, 0.6),
        ],
        3,
    ); // light
    rotated_box(&mut m, v(0.33, 0.3, 0.35), v(0.15, 0.3, 0.15), 0.3, 0);
    rotated_box(&mut m, v(0.68, 0.15, 0.65), v(0.15, 0.15, 0.15), -0.3, 0);
    vec![m]
}

/// Over 10⁶ triangles: a 512 × 512 height field (524 288 triangles) over [−50, 50]², 420
/// spheres of 1216 triangles (510 720) of random radius scattered above it, and a 40 × 40 area
/// light (2 triangles) high above.
fn million() -> Vec<TriangleMesh> {
    let mut rng = Rng(0x1_000_000);
    // `IRR_SCALE` (see the module docs) shrinks the scene.
    let scale: u32 = std::env::var("IRR_SCALE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1)
        .clamp(1, 512);
    let n = 512u32 / scale;
    let mut terrain = TriangleMesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (
                i as f32 / n as f32 * 100.0 - 50.0,
                j as f32 / n as f32 * 100.0 - 50.0,
            );
            let y = 2.0 * (0.21 * x).sin() * (0.17 * z).cos() + 0.5 * (0.9 * x + 0.4 * z).sin();
            terrain.positions.push(Vec3::new(x, y, z));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let v = |di: u32, dj: u32| (j + dj) * (n + 1) + i + di;
            terrain.indices.push([v(0, 0), v(0, 1), v(1, 1)]);
            terrain.indices.push([v(0, 0), v(1, 1), v(1, 0)]);
        }
    }
    terrain.material_ids = vec![0; terrain.indices.len()];

    let (slices, stacks) = (32u32, 20u32);
    let mut spheres = TriangleMesh::default();
    for _ in 0..420 / (scale * scale) {
        let centre = rng.in_box(Vec3::new(-48.0, 4.0, -48.0), Vec3::new(48.0, 20.0, 48.0));
        let radius = 0.5 + 2.5 * rng.f32();
        let base = spheres.positions.len() as u32;
        for s in 0..=stacks {
            let theta = std::f32::consts::PI * s as f32 / stacks as f32;
            for k in 0..slices {
                let phi = std::f32::consts::TAU * k as f32 / slices as f32;
                let dir = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                spheres.positions.push(centre + radius * dir);
            }
        }
        let v = |s: u32, k: u32| base + s * slices + k % slices;
        for s in 0..stacks {
            for k in 0..slices {
                // One triangle per slice in the rows that touch a pole (the other would be
                // degenerate), two elsewhere: 32·(2·20 − 2) = 1216 per sphere.
                if s != 0 {
                    spheres.indices.push([v(s, k), v(s + 1, k), v(s, k + 1)]);
                }
                if s != stacks - 1 {
                    spheres
                        .indices
                        .push([v(s, k + 1), v(s + 1, k), v(s + 1, k + 1)]);
                }
            }
        }
    }
    spheres.material_ids = vec![1; spheres.indices.len()];
    // A 40 × 40 area light facing down, high above the middle.
    let mut light = TriangleMesh::default();
    let v = Vec3::new;
    quad(
        &mut light,
        [
            v(-20., 40., -20.),
            v(20., 40., -20.),
            v(20., 40., 20.),
            v(-20., 40., 20.),
        ],
        2,
    );
    vec![terrain, spheres, light]
}

struct Scene {
    geometry: Geometry,
    closest: Vec<Ray>,
    shadow: Vec<Ray>,
    /// The same kinds of rays in render order (see the module docs).
    closest_in_order: Vec<Ray>,
    shadow_in_order: Vec<Ray>,
}

/// A pinhole camera at `eye` looking at `target` with a 45° field of view.
struct Camera {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
}

impl Camera {
    fn new(eye: Vec3, target: Vec3) -> Camera {
        let forward = (target - eye).normalize();
        let right = forward.cross(Vec3::Y).normalize();
        let up = right.cross(forward);
        Camera {
            eye,
            forward,
            right,
            up,
        }
    }
    /// The ray through a random image point.
    fn ray(&self, rng: &mut Rng) -> Ray {
        let x = 2.0 * rng.f32() - 1.0;
        let y = 2.0 * rng.f32() - 1.0;
        self.ray_at(x, y)
    }
    /// The ray through image point `(x, y)` (each in `[−1, 1]`).
    fn ray_at(&self, x: f32, y: f32) -> Ray {
        let h = (22.5f32).to_radians().tan();
        let (x, y) = (h * x, h * y);
        Ray::new(
            self.eye,
            (self.forward + x * self.right + y * self.up).normalize(),
        )
    }
}

/// Builds the scene and its second-bounce rays (see the module docs); `light` is the material
/// id of the area light's triangles.
fn scene(
    name: &str,
    meshes: &[TriangleMesh],
    layout: BvhLayout,
    camera: &Camera,
    light: u32,
) -> Scene {
    let start = Instant::now();
    let geometry =
        Geometry::build_with_layout(meshes, layout).unwrap_or_else(|e| panic!("{name}: {e}"));
    let bytes: usize = geometry.heap_bytes().iter().map(|(_, b)| b).sum();
    eprintln!(
        "{name} ({layout:?}): {} triangles, {} nodes, built in {:.2} s, {:.1} heap bytes per triangle",
        geometry.triangle_count(),
        geometry.node_count(),
        start.elapsed().as_secs_f64(),
        bytes as f64 / geometry.triangle_count() as f64
    );
    let lights: Vec<u32> = (0..geometry.triangle_count() as u32)
        .filter(|&t| geometry.triangle(t).material_id == light)
        .collect();
    let mut rng = Rng(0xBEEF);
    let (mut closest, mut shadow) = (Vec::with_capacity(RAYS), Vec::with_capacity(RAYS));
    while closest.len() < RAYS {
        let primary = camera.ray(&mut rng);
        if let Some((c, s)) = bounce(&geometry, &lights, &primary, &mut rng) {
            closest.push(c);
            shadow.push(s);
        }
    }
    // Render order: 16 × 16 tiles of a 256 × 256 image, one jittered sample per pixel.
    let mut rng = Rng(0xF00D);
    let (mut closest_in_order, mut shadow_in_order) = (Vec::new(), Vec::new());
    for tile in 0..256 {
        for pixel in 0..256 {
            let px = 16 * (tile % 16) + pixel % 16;
            let py = 16 * (tile / 16) + pixel / 16;
            let x = (px as f32 + rng.f32()) / 128.0 - 1.0;
            let y = 1.0 - (py as f32 + rng.f32()) / 128.0;
            let primary = camera.ray_at(x, y);
            if let Some((c, s)) = bounce(&geometry, &lights, &primary, &mut rng) {
                closest_in_order.push(c);
                shadow_in_order.push(s);
            }
        }
    }
    Scene {
        geometry,
        closest,
        shadow,
        closest_in_order,
        shadow_in_order,
    }
}

/// Where `primary` hits: a cosine-distributed bounce ray and a shadow ray to a random point of
/// a random light triangle (of `lights`); `None` if it hits nothing.
fn bounce(geometry: &Geometry, lights: &[u32], primary: &Ray, rng: &mut Rng) -> Option<(Ray, Ray)> {
    let hit = geometry.intersect(primary)?;
    let s = geometry.surface(primary, &hit);
    let n = if s.geometric_normal.dot(primary.direction) < 0.0 {
        s.geometric_normal
    } else {
        -s.geometric_normal
    };
    let closest = Ray::spawn(s.position, n, rng.cosine(n));
    let l = geometry.triangle(lights[(rng.f32() * lights.len() as f32) as usize % lights.len()]);
    let (mut b1, mut b2) = (rng.f32(), rng.f32());
    if b1 + b2 > 1.0 {
        (b1, b2) = (1.0 - b1, 1.0 - b2);
    }
    Some((
        closest,
        Ray::spawn_to(s.position, n, l.point(b1, b2), l.normal()),
    ))
}

/// The camera and light of each scene.
fn setup(name: &str) -> (Vec<TriangleMesh>, Camera, u32) {
    if name == "cornell" {
        let camera = Camera::new(Vec3::new(0.5, 0.5, 2.2), Vec3::new(0.5, 0.5, 0.0));
        (cornell_box(), camera, 3)
    } else {
        let camera = Camera::new(Vec3::new(0.0, 30.0, 75.0), Vec3::new(0.0, 0.0, 0.0));
        (million(), camera, 2)
    }
}

fn all_layouts(name: &str) -> [Scene; 3] {
    let (m, camera, light) = setup(name);
    LAYOUTS.map(|layout| scene(name, &m, layout, &camera, light))
}

static CORNELL: LazyLock<[Scene; 3]> = LazyLock::new(|| all_layouts("cornell"));
static MILLION: LazyLock<[Scene; 3]> = LazyLock::new(|| all_layouts("million"));

fn get(name: &str, layout: BvhLayout) -> &'static Scene {
    let scenes = if name == "cornell" {
        &*CORNELL
    } else {
        &*MILLION
    };
    &scenes[LAYOUTS.iter().position(|&l| l == layout).unwrap_or(0)]
}

/// Traces `rays` on `threads` threads (each takes a contiguous share); returns a count of hits
/// so the work cannot be optimised away.
#[inline(never)]
fn trace(g: &Geometry, rays: &[Ray], occlusion: bool, threads: usize) -> usize {
    let work = |chunk: &[Ray]| {
        chunk
            .iter()
            .filter(|r| {
                if occlusion {
                    g.occluded(r)
                } else {
                    g.intersect(r).is_some()
                }
            })
            .count()
    };
    if threads == 1 {
        return work(rays);
    }
    std::thread::scope(|s| {
        let handles: Vec<_> = rays
            .chunks(rays.len().div_ceil(threads))
            .map(|c| s.spawn(move || work(c)))
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| panic!("tracing thread panicked"))
            })
            .sum()
    })
}

/// 2¹⁶ gather rays of an irradiance-cache record's kind, in the Cornell box or another
/// scene: records at the camera's primary hits, each with `m × n` stratified cosine-weighted
/// directions (cell (j, k) of (cos²θ, φ), jittered, in that order) around the normal facing
/// the camera, all leaving from the record's one spawned origin.
fn gather_rays(g: &Geometry, camera: &Camera, m: usize, n: usize) -> Vec<Ray> {
    let mut rng = Rng(0x6A7E);
    let mut rays = Vec::with_capacity(RAYS);
    while rays.len() < RAYS {
        let primary = camera.ray(&mut rng);
        let Some(hit) = g.intersect(&primary) else {
            continue;
        };
        let s = g.surface(&primary, &hit);
        let nrm = if s.geometric_normal.dot(primary.direction) < 0.0 {
            s.geometric_normal
        } else {
            -s.geometric_normal
        };
        let t = nrm.any_orthonormal_vector();
        let b = nrm.cross(t);
        for j in 0..m {
            for k in 0..n {
                let u = (j as f32 + rng.f32()) / m as f32;
                let phi = std::f32::consts::TAU * (k as f32 + rng.f32()) / n as f32;
                let (sin, cos) = (u.sqrt(), (1.0 - u).max(0.0).sqrt());
                let d = (t * (sin * phi.cos()) + b * (sin * phi.sin()) + nrm * cos).normalize();
                rays.push(Ray::spawn(s.position, nrm, d));
            }
        }
    }
    rays.truncate(RAYS);
    rays
}

/// How the batched cases hand their rays to irr-geometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Batch {
    /// `intersect` (or `occluded`), a ray at a time.
    One,
    /// One `intersect_many` call per batch (closest hits; occlusion goes a ray at a time).
    Many,
    /// One `intersect_stream` (or `occluded_stream`) call per batch.
    Stream,
}

/// Traces `rays` in batches of `len` (a gather's rays per record, or [`BATCH`]) as `how`
/// says; returns the number of hits.
#[inline(never)]
fn trace_batches(g: &Geometry, rays: &[Ray], occlusion: bool, len: usize, how: Batch) -> usize {
    let mut hits = vec![None; len];
    let mut occluded = vec![false; len];
    let mut count = 0;
    for chunk in rays.chunks(len) {
        let (hits, occluded) = (&mut hits[..chunk.len()], &mut occluded[..chunk.len()]);
        match (how, occlusion) {
            (Batch::Stream, true) => g.occluded_stream(chunk, occluded),
            (_, true) => {
                for (ray, o) in chunk.iter().zip(occluded.iter_mut()) {
                    *o = g.occluded(ray);
                }
            }
            (Batch::Stream, false) => g.intersect_stream(chunk, hits),
            (Batch::Many, false) => g.intersect_many(chunk, hits),
            (Batch::One, false) => {
                for (ray, h) in chunk.iter().zip(hits.iter_mut()) {
                    *h = g.intersect(ray);
                }
            }
        }
        count += if occlusion {
            occluded.iter().filter(|&&o| o).count()
        } else {
            hits.iter().filter(|h| h.is_some()).count()
        };
    }
    count
}

/// Rays per call in the streamed cases (`closest_stream`, `*-stream`): a 32 × 128 gather's.
const BATCH: usize = 1 << 12;

/// The gather sizes the gather benchmarks trace: M × N rays per record.
const GATHERS: [(usize, usize); 2] = [(16, 64), (32, 128)];

static CORNELL_GATHERS: LazyLock<[Vec<Ray>; 2]> = LazyLock::new(|| {
    let camera = setup("cornell").1;
    let s = get("cornell", BvhLayout::default());
    GATHERS.map(|(m, n)| gather_rays(&s.geometry, &camera, m, n))
});

fn run_gather(bencher: Bencher, size: usize, how: Batch) {
    let s = get("cornell", BvhLayout::default());
    let rays = &CORNELL_GATHERS[size];
    let (m, n) = GATHERS[size];
    bencher
        .counter(ItemsCount::new(rays.len()))
        .bench(|| trace_batches(&s.geometry, divan::black_box(rays), false, m * n, how));
}

/// Cornell-box gathers (16 × 64 and 32 × 128 rays per record) on the default layout, one ray
/// at a time with `intersect`.
#[divan::bench(args = [0, 1], sample_count = 20)]
fn gather_one_by_one(bencher: Bencher, size: usize) {
    run_gather(bencher, size, Batch::One);
}

/// The same gathers with one `intersect_many` call per record.
#[divan::bench(args = [0, 1], sample_count = 20)]
fn gather_intersect_many(bencher: Bencher, size: usize) {
    run_gather(bencher, size, Batch::Many);
}

fn threads_all() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

const SCENES: [&str; 2] = ["cornell", "million"];
/// The layouts, as the benchmarks' const argument numbers them: 0 BVH2 (the scalar oracle),
/// 1 Wide4, 2 Wide8 (the default).
const LAYOUTS: [BvhLayout; 3] = [BvhLayout::Bvh2, BvhLayout::Wide4, BvhLayout::Wide8];

fn run(bencher: Bencher, name: &str, layout: BvhLayout, occlusion: bool, threads: usize) {
    let s = get(name, layout);
    let rays = if occlusion { &s.shadow } else { &s.closest };
    time(bencher, &s.geometry, rays, occlusion, threads);
}

/// Times tracing `rays` on `g` (closest hits, or occlusion) on `threads` threads, counted in
/// rays.
fn time(bencher: Bencher, g: &Geometry, rays: &[Ray], occlusion: bool, threads: usize) {
    bencher
        .counter(ItemsCount::new(rays.len()))
        .bench(|| trace(g, divan::black_box(rays), occlusion, threads));
}

#[divan::bench(args = SCENES, consts = [0, 1, 2], sample_count = 20)]
fn closest_1_thread<const LAYOUT: usize>(bencher: Bencher, name: &str) {
    run(bencher, name, LAYOUTS[LAYOUT], false, 1);
}

#[divan::bench(args = SCENES, consts = [0, 1, 2], sample_count = 20)]
fn closest_all_threads<const LAYOUT: usize>(bencher: Bencher, name: &str) {
    run(bencher, name, LAYOUTS[LAYOUT], false, threads_all());
}

#[divan::bench(args = SCENES, consts = [0, 1, 2], sample_count = 20)]
fn occluded_1_thread<const LAYOUT: usize>(bencher: Bencher, name: &str) {
    run(bencher, name, LAYOUTS[LAYOUT], true, 1);
}

#[divan::bench(args = SCENES, consts = [0, 1, 2], sample_count = 20)]
fn occluded_all_threads<const LAYOUT: usize>(bencher: Bencher, name: &str) {
    run(bencher, name, LAYOUTS[LAYOUT], true, threads_all());
}

/// The second bounce's closest-hit rays in render order (see the module docs), one thread.
#[divan::bench(args = SCENES, consts = [0, 1, 2], sample_count = 20)]
fn closest_in_render_order<const LAYOUT: usize>(bencher: Bencher, name: &str) {
    let s = get(name, LAYOUTS[LAYOUT]);
    time(bencher, &s.geometry, &s.closest_in_order, false, 1);
}

/// The shadow rays in render order, one thread.
#[divan::bench(args = SCENES, consts = [0, 1, 2], sample_count = 20)]
fn occluded_in_render_order<const LAYOUT: usize>(bencher: Bencher, name: &str) {
    let s = get(name, LAYOUTS[LAYOUT]);
    time(bencher, &s.geometry, &s.shadow_in_order, true, 1);
}

/// Times the random-order rays of `name` (shadow rays for `occlusion`) in batches of [`BATCH`],
/// with `intersect_stream` or `occluded_stream`, one thread.
fn stream(bencher: Bencher, name: &str, layout: BvhLayout, occlusion: bool) {
    let s = get(name, layout);
    let rays = if occlusion { &s.shadow } else { &s.closest };
    bencher.counter(ItemsCount::new(rays.len())).bench(|| {
        let rays = divan::black_box(rays);
        trace_batches(&s.geometry, rays, occlusion, BATCH, Batch::Stream)
    });
}

/// The second bounce's closest-hit rays (random order, as `closest_1_thread`) in batches, with
/// `intersect_stream`, one thread.
#[divan::bench(args = SCENES, consts = [0, 1, 2], sample_count = 20)]
fn closest_stream<const LAYOUT: usize>(bencher: Bencher, name: &str) {
    stream(bencher, name, LAYOUTS[LAYOUT], false);
}

/// The shadow rays in batches, with `occluded_stream`, one thread.
#[divan::bench(args = SCENES, consts = [0, 1, 2], sample_count = 20)]
fn occluded_stream<const LAYOUT: usize>(bencher: Bencher, name: &str) {
    stream(bencher, name, LAYOUTS[LAYOUT], true);
}
