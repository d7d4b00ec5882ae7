//! irr-geometry as an integrator uses it: the BVH against brute force and an independent `f64`
//! reference, watertightness on shared edges, and the robustness of secondary and shadow rays in
//! scenes scaled by 1e-4, 1 and 1e3 and translated by 1e5.

use glam::{DVec3, Quat, Vec3};
use irr_geometry::{BvhLayout, Geometry, Hit, Ray, Triangle, TriangleMesh};
use proptest::prelude::*;

/// SplitMix64: a small deterministic generator so every test is reproducible from its seed.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    fn unit_vector(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f32::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
    /// Uniform barycentrics (b1, b2) on a triangle.
    fn barycentrics(&mut self) -> (f32, f32) {
        let (u, v) = (self.f32(), self.f32());
        if u + v > 1.0 {
            (1.0 - u, 1.0 - v)
        } else {
            (u, v)
        }
    }
    /// A direction in the hemisphere around the unit `n`: a quarter of them grazing, with
    /// cos θ = 10^−k for k uniform in [2, 7); the rest with cos θ uniform in (0, 1].
    fn hemisphere(&mut self, n: Vec3) -> Vec3 {
        let cos = if self.below(4) == 0 {
            10f32.powf(-self.range(2.0, 7.0))
        } else {
            1.0 - self.f32()
        };
        let t = n.any_orthonormal_vector();
        let b = n.cross(t);
        let phi = self.range(0.0, std::f32::consts::TAU);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        n * cos + (t * phi.cos() + b * phi.sin()) * sin
    }
    /// A direction from [`Rng::hemisphere`] around `side` (±`ng`), redrawn until `ng·d` has the
    /// sign of `ng·side` as `Ray::spawn` computes it: below cos θ ≈ 1e-7 the rounding of the
    /// tangent frame can put a drawn direction on the other side of the surface.
    fn leaving(&mut self, ng: Vec3, side: Vec3) -> Vec3 {
        loop {
            let d = self.hemisphere(side);
            if (ng.dot(d) >= 0.0) == (ng.dot(side) >= 0.0) {
                return d;
            }
        }
    }
}

/// A closed box (12 triangles, outward winding) centred at `c` with half extents `h`, rotated
/// by `q`; face `f` carries material id `first_face + f`, so a material id names a planar face.
fn closed_box(c: Vec3, h: Vec3, q: Quat, first_face: u32) -> TriangleMesh {
    let corner = |i: usize| {
        let s = Vec3::new(
            if i & 1 == 0 { -1.0 } else { 1.0 },
            if i & 2 == 0 { -1.0 } else { 1.0 },
            if i & 4 == 0 { -1.0 } else { 1.0 },
        );
        c + q * (s * h)
    };
    // Each face as a quad (a, b, c, d) in counter-clockwise order seen from outside.
    let faces: [[u32; 4]; 6] = [
        [0, 4, 6, 2], // −x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // −y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // −z
        [4, 5, 7, 6], // +z
    ];
    let mut indices = Vec::new();
    let mut material_ids = Vec::new();
    for (f, [a, b, c, d]) in faces.into_iter().enumerate() {
        indices.push([a, b, c]);
        indices.push([a, c, d]);
        material_ids.extend([first_face + f as u32; 2]);
    }
    TriangleMesh {
        positions: (0..8).map(corner).collect(),
        indices,
        normals: None,
        material_ids,
    }
}

/// The test scenes in their unit size: a closed room [−1, 1]³ (faces 0..6) with two closed
/// boxes inside, rotated about tilted axes so that none of their faces is axis-aligned.
fn room_with_boxes() -> Vec<TriangleMesh> {
    vec![
        closed_box(Vec3::ZERO, Vec3::ONE, Quat::IDENTITY, 0),
        closed_box(
            Vec3::new(0.4, -0.55, 0.35),
            Vec3::new(0.3, 0.3, 0.3),
            Quat::from_axis_angle(Vec3::new(0.2, 1.0, 0.1).normalize(), 0.3),
            6,
        ),
        closed_box(
            Vec3::new(-0.4, -0.2, -0.3),
            Vec3::new(0.25, 0.6, 0.25),
            Quat::from_axis_angle(Vec3::new(-0.3, 1.0, 0.2).normalize(), -0.5),
            12,
        ),
    ]
}

/// `p·scale + translation` for every position.
fn transformed(meshes: &[TriangleMesh], scale: f32, translation: Vec3) -> Vec<TriangleMesh> {
    meshes
        .iter()
        .map(|m| TriangleMesh {
            positions: m
                .positions
                .iter()
                .map(|&p| p * scale + translation)
                .collect(),
            ..m.clone()
        })
        .collect()
}

/// The four configurations the issue names: the unit scene scaled by 1e-4, 1 and 1e3, and the
/// unit scene translated by 1e5 along every axis.
const CONFIGS: [(f32, f32); 4] = [(1e-4, 0.0), (1.0, 0.0), (1e3, 0.0), (1.0, 1e5)];

/// Both BVH layouts: every property must hold for each.
const LAYOUTS: [BvhLayout; 3] = [BvhLayout::Bvh2, BvhLayout::Wide4, BvhLayout::Wide8];

/// Every (layout, (scale, translation)) pair.
fn cases() -> impl Iterator<Item = (BvhLayout, (f32, f32))> {
    LAYOUTS
        .into_iter()
        .flat_map(|l| CONFIGS.into_iter().map(move |c| (l, c)))
}

fn build(meshes: &[TriangleMesh], layout: BvhLayout) -> Geometry {
    Geometry::build_with_layout(meshes, layout).unwrap_or_else(|e| panic!("{e}"))
}

/// 10⁵ rays leave random points of random faces, on a random side, in random directions of that
/// side's hemisphere (a quarter of them grazing, down to cos θ = 1e-7). Half start from points
/// sampled on the triangle (as a light sampler would), half from the surface point of a hit of
/// a random ray (as a path tracer would). Every box is closed, so every such ray must hit
/// something — except those leaving the outside of the room — and none may hit the face it
/// leaves (a planar face cannot be hit by a ray leaving its plane).
#[test]
fn no_self_hits_and_no_escapes_at_any_scale() {
    for (layout, (scale, shift)) in cases() {
        let translation = Vec3::splat(shift);
        let g = build(&transformed(&room_with_boxes(), scale, translation), layout);
        let mut rng = Rng(0x5EED_0001 ^ scale.to_bits() as u64 ^ shift.to_bits() as u64);
        let (mut self_hits, mut escapes, mut phantoms) = (0, 0, 0);
        let mut first_failure = None;
        for i in 0..100_000 {
            // A surface point, its triangle and the side the ray leaves from.
            let (p, id, side) = if i % 2 == 0 {
                let id = rng.below(g.triangle_count()) as u32;
                let (b1, b2) = rng.barycentrics();
                let tri = g.triangle(id);
                let n = tri.normal();
                let side = if rng.below(2) == 0 { n } else { -n };
                (tri.point(b1, b2), id, side)
            } else {
                // A random ray from a random point inside the room, away from the boxes' region
                // only by chance: it may start inside a box, which is just as valid.
                let o = Vec3::new(
                    rng.range(-0.9, 0.9),
                    rng.range(-0.9, 0.9),
                    rng.range(-0.9, 0.9),
                ) * scale
                    + translation;
                let ray = Ray::new(o, rng.unit_vector());
                let Some(hit) = g.intersect(&ray) else {
                    escapes += 1;
                    first_failure.get_or_insert(format!("primary ray {ray:?} escaped"));
                    continue;
                };
                let s = g.surface(&ray, &hit);
                // Reflect or transmit at random.
                let toward_ray = if s.geometric_normal.dot(ray.direction) < 0.0 {
                    s.geometric_normal
                } else {
                    -s.geometric_normal
                };
                let side = if rng.below(2) == 0 {
                    toward_ray
                } else {
                    -toward_ray
                };
                (s.position, hit.triangle, side)
            };
            let src = g.triangle(id);
            let direction = rng.leaving(src.normal(), side);
            let ray = Ray::spawn(p, src.normal(), direction);
            // The room's walls are axis-aligned and centred on `translation`: a ray leaves the
            // room when it leaves a wall on the side facing away from the centre.
            let leaves_room = src.material_id < 6 && side.dot(p - translation) > 0.0;
            // A sampled point within half an ulp of an edge rounds onto the adjacent face's
            // plane (at 1e5, where the float spacing is 2⁻⁷, this is 0.4% of the points). A ray
            // leaving such an origin outward through that plane is outside the room from t = 0
            // in exact arithmetic too, so missing everything is then the right answer.
            let on_wall_going_out = (0..3).any(|i| {
                let o = f64::from(ray.origin[i]) - f64::from(translation[i]);
                o.abs() >= f64::from(scale) && o * f64::from(ray.direction[i]) > 0.0
            });
            match g.intersect(&ray) {
                Some(hit) if g.triangle(hit.triangle).material_id == src.material_id => {
                    self_hits += 1;
                    first_failure.get_or_insert(format!(
                        "self-hit: from face {} at {p} along {direction}, t = {}",
                        src.material_id, hit.t
                    ));
                }
                Some(hit) if leaves_room => {
                    phantoms += 1;
                    first_failure.get_or_insert(format!(
                        "ray leaving the room at {p} along {direction} hit triangle {}",
                        hit.triangle
                    ));
                }
                None if !leaves_room && !on_wall_going_out => {
                    escapes += 1;
                    first_failure.get_or_insert(format!(
                        "escape: from face {} at {p} along {direction} (side {side})",
                        src.material_id
                    ));
                }
                _ => {}
            }
        }
        assert!(
            self_hits + escapes + phantoms == 0,
            "{layout:?}, scale {scale}, translation {shift}: {self_hits} self-hits, {escapes} escapes, \
             {phantoms} phantom hits in 1e5 rays; first: {}",
            first_failure.unwrap_or_default()
        );
    }
}

/// A closed slab (a box of 1 × h × 1), rotated so no face is axis-aligned, placed at `centre`.
fn slab(scale: f32, thickness: f32, centre: Vec3) -> (Vec<TriangleMesh>, Quat) {
    let q = Quat::from_axis_angle(Vec3::new(0.3, 0.2, 1.0).normalize(), 0.4);
    let mesh = closed_box(
        centre,
        Vec3::new(0.5 * scale, 0.5 * thickness, 0.5 * scale),
        q,
        0,
    );
    (vec![mesh], q)
}

/// Rays leaving the inner side of one face of a thin closed slab toward the other face: every
/// one hits the slab (no tunnelling, no self-hit), and the opposite face whenever the exact ray
/// (in `f64`) reaches that face's plane well inside the face.
///
/// The slab is 1e-3 thick relative to its 1 × 1 faces at scales 1e-4, 1 and 1e3. At a
/// translation of 1e5 a thickness of 1e-3 is below the float spacing there (2⁻⁷ ≈ 7.8e-3: the two
/// faces would coincide), so that configuration uses a slab of 16 ulps (1/8). An offset origin
/// moves by `Σ|n_i|·2⁻²²·|p_i|` plus one ulp per component, up to ~6 ulps (0.045) for a tilted
/// normal there, and the rotated slab's vertices are rounded to that 2⁻⁷ grid, which changes
/// its local thickness by up to ~1 ulp: 16 ulps leaves a margin of about 2.
#[test]
fn rays_cross_a_thin_slab_without_tunnelling() {
    for (layout, (scale, shift)) in cases() {
        let centre = Vec3::splat(shift);
        let thickness = if shift == 0.0 {
            1e-3 * scale
        } else {
            1.0 / 8.0
        };
        let (meshes, q) = slab(scale, thickness, centre);
        let g = build(&meshes, layout);
        let up = q * Vec3::Y;
        let mut rng = Rng(0x51AB ^ scale.to_bits() as u64);
        let (mut wrong, mut first) = (0, None);
        for i in 0..20_000 {
            // Leave the bottom face (material 2, −y) upward, or the top face (3, +y) downward.
            let (from, to, inward) = if i % 2 == 0 { (2, 3, up) } else { (3, 2, -up) };
            let ids: Vec<u32> = (0..g.triangle_count() as u32)
                .filter(|&t| g.triangle(t).material_id == from)
                .collect();
            let id = ids[rng.below(ids.len())];
            let tri = g.triangle(id);
            let (b1, b2) = rng.barycentrics();
            let p = tri.point(b1, b2);
            let d = rng.leaving(tri.normal(), inward);
            let ray = Ray::spawn(p, tri.normal(), d);
            let hit_face = g
                .intersect(&ray)
                .map(|h| g.triangle(h.triangle).material_id);
            // Where the exact ray from p meets the opposite face's plane, in slab coordinates.
            let local = |v: DVec3| q.as_dquat().inverse() * v;
            let pl = local(p.as_dvec3() - centre.as_dvec3()) / f64::from(scale);
            let dl = local(d.as_dvec3());
            let t = f64::from(thickness) / f64::from(scale) / dl.y.abs();
            let reach = pl + dl * t;
            // Well inside: 1e-4 of the face from its border, far above the ~1e-6 relative
            // error of the f32 vertices and point — plus, at the translation of 1e5, four
            // times the float spacing there (2⁻⁷), to which the vertices and point are
            // rounded. A ray that reaches the opposite plane near the border may hit a side
            // instead. A ray starting that close to a side may start outside it (its point and
            // offset are rounded to that spacing) and then miss the slab: only a self-hit is
            // wrong for those.
            let border = 1e-4
                + if shift == 0.0 {
                    0.0
                } else {
                    4.0 / 128.0 / f64::from(scale)
                };
            let inside = |v: DVec3| v.x.abs() < 0.5 - border && v.z.abs() < 0.5 - border;
            let must_hit_opposite = inside(pl) && inside(reach);
            let ok = match hit_face {
                Some(f) if f == to => true,
                Some(f) if f != from => !must_hit_opposite,
                Some(_) => false,
                None => !inside(pl),
            };
            if !ok {
                wrong += 1;
                first.get_or_insert(format!(
                    "from face {from} at {p} along {d}: hit {hit_face:?}, expected {to}"
                ));
            }
        }
        assert_eq!(
            wrong,
            0,
            "{layout:?}, scale {scale}, translation {shift}, thickness {thickness}: {wrong} of 2e4 rays \
             wrong; first: {}",
            first.unwrap_or_default()
        );
    }
}

/// A uniformly random point of triangle `id`, and its unit normal.
fn sample(g: &Geometry, rng: &mut Rng, id: u32) -> (Vec3, Vec3) {
    let (b1, b2) = rng.barycentrics();
    let tri = g.triangle(id);
    (tri.point(b1, b2), tri.normal())
}

/// Shadow rays between random points of two different walls of an empty closed room: the
/// segment lies inside the convex room, so nothing may occlude it — in particular not either
/// endpoint's own wall, including for nearly grazing segments between points close to the
/// shared edge of two adjacent walls. The same room with an occluding quad across its middle
/// must block every segment that crosses the quad well inside it.
#[test]
fn shadow_rays_see_no_false_occlusion_at_any_scale() {
    for (layout, (scale, shift)) in cases() {
        let translation = Vec3::splat(shift);
        let room = transformed(
            &[closed_box(Vec3::ZERO, Vec3::ONE, Quat::IDENTITY, 0)],
            scale,
            translation,
        );
        let g = build(&room, layout);
        let mut rng = Rng(0x5AD0 ^ scale.to_bits() as u64);

        let mut false_occlusions = Vec::new();
        for i in 0..50_000 {
            let a = rng.below(12) as u32;
            let mut b = rng.below(12) as u32;
            if g.triangle(a).material_id == g.triangle(b).material_id {
                b = (b + 2) % 12;
            }
            let (mut p, n) = sample(&g, &mut rng, a);
            let (q, m) = sample(&g, &mut rng, b);
            if i % 4 == 0 {
                // Pull p toward q's wall along p's wall, down to 1e-6 of the room size, so the
                // segment grazes one or both walls.
                let to_q = (q - p) - n * n.dot(q - p);
                let f = 1.0 - 10f32.powf(-rng.range(0.0, 6.0));
                p += to_q * f * 0.999;
            }
            let ray = Ray::spawn_to(p, n, q, m);
            if g.occluded(&ray) && false_occlusions.len() < 5 {
                false_occlusions.push(format!("{p} -> {q}"));
            }
        }
        assert!(
            false_occlusions.is_empty(),
            "{layout:?}, scale {scale}, translation {shift}: false occlusion, e.g. {false_occlusions:?}"
        );

        // Now with an occluder: the quad y = 0, |x|, |z| < 0.5 across the room's middle.
        let mut with_occluder = room.clone();
        with_occluder.push(TriangleMesh {
            positions: [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
                .map(|(x, z)| Vec3::new(x, 0.0, z) * scale + translation)
                .to_vec(),
            indices: vec![[0, 1, 2], [0, 2, 3]],
            normals: None,
            material_ids: vec![99, 99],
        });
        let g = build(&with_occluder, layout);
        let floor: Vec<u32> = (0..12)
            .filter(|&t| g.triangle(t).material_id == 2)
            .collect();
        let ceiling: Vec<u32> = (0..12)
            .filter(|&t| g.triangle(t).material_id == 3)
            .collect();
        let mut wrong = 0;
        for _ in 0..20_000 {
            let (i, j) = (rng.below(2), rng.below(2));
            let (p, n) = sample(&g, &mut rng, floor[i]);
            let (q, m) = sample(&g, &mut rng, ceiling[j]);
            // The segment crosses y = 0 (in unit coordinates) at its midpoint.
            let mid = ((p + q) * 0.5 - translation) / scale;
            let inside = mid.x.abs() < 0.5 - 1e-4 && mid.z.abs() < 0.5 - 1e-4;
            let outside = mid.x.abs() > 0.5 + 1e-4 || mid.z.abs() > 0.5 + 1e-4;
            let blocked = g.occluded(&Ray::spawn_to(p, n, q, m));
            if (inside && !blocked) || (outside && blocked) {
                wrong += 1;
            }
        }
        assert_eq!(
            wrong, 0,
            "{layout:?}, scale {scale}, translation {shift}: {wrong} wrong visibilities"
        );
    }
}

/// A random triangle soup in [−1, 1]³ plus a random height field (a grid mesh whose triangles
/// share edges and vertices).
fn random_scene(rng: &mut Rng, soup: usize, grid: usize) -> Vec<TriangleMesh> {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for t in 0..soup as u32 {
        let c = Vec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let size = 10f32.powf(rng.range(-2.0, 0.0));
        for _ in 0..3 {
            positions.push(c + rng.unit_vector() * size);
        }
        indices.push([3 * t, 3 * t + 1, 3 * t + 2]);
    }
    let soup_mesh = TriangleMesh {
        material_ids: vec![0; indices.len()],
        positions,
        indices,
        normals: None,
    };
    let mut heights = TriangleMesh::default();
    let n = grid as u32;
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (
                i as f32 / n as f32 * 2.0 - 1.0,
                j as f32 / n as f32 * 2.0 - 1.0,
            );
            heights
                .positions
                .push(Vec3::new(x, -1.5 + 0.3 * rng.f32(), z));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let v = |di: u32, dj: u32| (j + dj) * (n + 1) + i + di;
            heights.indices.push([v(0, 0), v(1, 0), v(1, 1)]);
            heights.indices.push([v(0, 0), v(1, 1), v(0, 1)]);
        }
    }
    heights.material_ids = vec![1; heights.indices.len()];
    vec![soup_mesh, heights]
}

/// Every hit (and near miss, down to −1e-3 in barycentrics) of an independent `f64`
/// Möller–Trumbore test, sorted by distance: (t, triangle, barycentric margin).
fn reference_hits(g: &Geometry, ray: &Ray) -> Vec<(f64, u32, f64)> {
    let o = ray.origin.as_dvec3();
    let d = ray.direction.as_dvec3();
    let mut hits = Vec::new();
    for (id, tri) in g.triangles().enumerate() {
        let [p0, p1, p2] = tri.p.map(Vec3::as_dvec3);
        let (e1, e2) = (p1 - p0, p2 - p0);
        let pv = d.cross(e2);
        let det = e1.dot(pv);
        if det == 0.0 {
            continue;
        }
        let s = o - p0;
        let u = s.dot(pv) / det;
        let qv = s.cross(e1);
        let v = d.dot(qv) / det;
        let t = e2.dot(qv) / det;
        let margin = u.min(v).min(1.0 - u - v);
        if margin > -1e-3 && t > 0.0 {
            hits.push((t, id as u32, margin));
        }
    }
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    hits
}

/// Twice the crate's bound on the error of a hit's t on triangle `id` for a unit-direction ray:
/// δt = (γ₇·Σ|a_i n_i| + γ₆·t·Σ|d_i n_i|)/|d·n| + γ₂·t with a = p0 − o, where
/// Σ|a_i n_i| ≤ |a|, Σ|d_i n_i| ≤ |d| = 1 and γ₇ < 4.2e-7:
/// tol = 1e-6·(|a| + t)/|d·n| + 1e-6·t.
fn tolerance_for(g: &Geometry, ray: &Ray, id: u32, t: f64) -> f64 {
    let tri = g.triangle(id);
    let a = f64::from((tri.p[0] - ray.origin).length());
    let cos = f64::from(ray.direction.dot(tri.normal()).abs());
    1e-6 * (a + t) / cos + 1e-6 * t
}

fn tolerance(g: &Geometry, ray: &Ray, hit: &Hit) -> f64 {
    tolerance_for(g, ray, hit.triangle, f64::from(hit.t))
}

fn random_ray(rng: &mut Rng) -> Ray {
    let o = Vec3::new(
        rng.range(-2.0, 2.0),
        rng.range(-2.0, 2.0),
        rng.range(-2.0, 2.0),
    );
    // Mix in axis-aligned directions: zero components exercise the box test's clamping.
    let d = if rng.below(8) == 0 {
        [Vec3::X, Vec3::NEG_Y, Vec3::Z][rng.below(3)]
    } else {
        rng.unit_vector()
    };
    Ray::new(o, d)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The BVH (both layouts) returns what testing every triangle returns. Both use the same
    /// triangle test, so hit or miss must agree exactly. The triangle may differ only in a tie:
    /// the boxes are culled conservatively (a culled triangle's exact t exceeds the best t
    /// found), so the two answers' t differ by at most the triangles' own error bound δt, which
    /// `tolerance` bounds (see `closest_hit_matches_an_f64_reference`).
    #[test]
    fn bvh_equals_brute_force(
        seed: u64,
        // Small scenes are built with PLOC, those above 1024 triangles top down.
        soup in prop_oneof![1usize..200, 1100usize..1600],
        grid in 1usize..8,
    ) {
        let mut rng = Rng(seed);
        let scene = random_scene(&mut rng, soup, grid);
        for layout in LAYOUTS {
            let g = build(&scene, layout);
            for _ in 0..200 {
                let mut ray = random_ray(&mut rng);
                if rng.below(4) == 0 {
                    ray.t_max = rng.range(0.0, 3.0);
                }
                let bvh = g.intersect(&ray);
                let brute = g.intersect_brute_force(&ray);
                match (bvh, brute) {
                    (None, None) => {}
                    (Some(a), Some(b)) => {
                        let tol = tolerance(&g, &ray, &a).max(tolerance(&g, &ray, &b));
                        prop_assert!(
                            a.triangle == b.triangle && a.t == b.t
                                || f64::from((a.t - b.t).abs()) <= tol,
                            "{layout:?} {ray:?}: bvh {a:?}, brute force {b:?}"
                        );
                    }
                    (a, b) => prop_assert!(false, "{layout:?} {ray:?}: bvh {a:?}, brute {b:?}"),
                }
                prop_assert_eq!(g.occluded(&ray), g.occluded_brute_force(&ray), "{:?}", ray);
                prop_assert_eq!(g.occluded(&ray), bvh.is_some(), "{:?}", ray);
            }
        }
    }

    /// The f32 closest hit agrees with an independent f64 test wherever the f64 answer is not
    /// borderline, with t within `tolerance_for` (twice the crate's bound). The check applies where the hit is ≥ 1e-4 inside its
    /// triangle (in barycentrics, ~100× their error for these well-shaped triangles) and the
    /// next hit is more than 10·tol farther. The barycentric point must then be within
    /// 1e-4 of the exact hit (its error is the barycentrics' error times the triangle size ≤ 2).
    #[test]
    fn closest_hit_matches_an_f64_reference(seed: u64, soup in 1usize..100) {
        let mut rng = Rng(seed);
        let g = build(&random_scene(&mut rng, soup, 3), BvhLayout::default());
        for _ in 0..100 {
            let ray = random_ray(&mut rng);
            let reference = reference_hits(&g, &ray);
            let hit: Option<Hit> = g.intersect(&ray);
            let Some(&(t, id, margin)) = reference.first() else {
                prop_assert!(hit.is_none(), "{ray:?}: hit {hit:?}, reference misses");
                continue;
            };
            let tol = tolerance_for(&g, &ray, id, t);
            let gap = reference.get(1).map_or(f64::INFINITY, |h| h.0 - t);
            if margin > 1e-4 && gap > 10.0 * tol {
                let h = hit.ok_or_else(|| {
                    TestCaseError::fail(format!("{ray:?} missed; reference hits {id} at {t}"))
                })?;
                prop_assert_eq!(h.triangle, id, "{:?}", ray);
                prop_assert!((f64::from(h.t) - t).abs() <= tol, "t {} vs {} (tol {})", h.t, t, tol);
                let tri: Triangle = g.triangle(id);
                let p = tri.point(h.b1, h.b2).as_dvec3();
                let exact = ray.origin.as_dvec3() + ray.direction.as_dvec3() * t;
                prop_assert!((p - exact).length() <= 1e-4, "{p} vs {exact}");
            }
        }
    }

    /// Watertightness on shared edges: a ray aimed from above at any point of a height field's
    /// footprint hits the height field — including rays aimed exactly at its vertices and along
    /// its edges, where a non-watertight test lets rays slip between triangles.
    #[test]
    fn height_field_has_no_cracks(seed: u64, grid in 2usize..12) {
        let mut rng = Rng(seed);
        let n = grid as f32;
        let scene = random_scene(&mut rng, 0, grid);
        for layout in LAYOUTS {
        let g = build(&scene[1..], layout);
        for k in 0..400 {
            // Every other target snapped to a grid line (an edge) or a grid vertex.
            let mut x = rng.range(-1.0, 1.0);
            let mut z = rng.range(-1.0, 1.0);
            if k % 2 == 0 {
                x = ((x + 1.0) * 0.5 * n).round() / n * 2.0 - 1.0;
            }
            if k % 4 == 0 {
                z = ((z + 1.0) * 0.5 * n).round() / n * 2.0 - 1.0;
            }
            // Between y = −1.2 and −1.5 (the height field's band) the ray drifts at most
            // 0.05·0.15 < 0.01 sideways, so it crosses the band inside the footprint.
            let target = Vec3::new(x.clamp(-0.99, 0.99), -1.35, z.clamp(-0.99, 0.99));
            let d = Vec3::new(rng.range(-0.05, 0.05), -1.0, rng.range(-0.05, 0.05));
            let ray = Ray::new(target - d * 2.0, d);
            prop_assert!(g.intersect(&ray).is_some(), "{layout:?}: crack at {target} along {d}");
            prop_assert!(g.occluded(&ray), "crack (occlusion) at {target} along {d}");
        }
        }
    }
}

/// `a` is the scalar oracle's answer `b`: the same hit or miss, and the same triangle with the
/// same distance and barycentrics bit for bit (the packet tests do the scalar test's operations
/// in its order) or, in a tie between triangles, distances within `tolerance` of each other
/// (the boxes are culled conservatively, so a culled triangle's exact distance exceeds the
/// best found; the computed distances then differ by at most the two triangles' bounds δt).
fn matches_oracle(g: &Geometry, ray: &Ray, a: Option<Hit>, b: Option<Hit>) -> Result<(), String> {
    match (a, b) {
        (None, None) => Ok(()),
        (Some(a), Some(b)) if a.triangle == b.triangle => {
            if (a.t, a.b1, a.b2) == (b.t, b.b1, b.b2) {
                Ok(())
            } else {
                Err(format!(
                    "{ray:?}: same triangle, other bits: {a:?} vs {b:?}"
                ))
            }
        }
        (Some(a), Some(b)) => {
            let tol = tolerance(g, ray, &a).max(tolerance(g, ray, &b));
            if f64::from((a.t - b.t).abs()) <= tol {
                Ok(())
            } else {
                Err(format!("{ray:?}: {a:?} vs oracle {b:?} (tol {tol})"))
            }
        }
        (a, b) => Err(format!("{ray:?}: {a:?} vs oracle {b:?}")),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Every SIMD path returns the scalar oracle's hit (`intersect_brute_force`: the scalar
    /// watertight test on every triangle), at every scale and translation of the robustness
    /// tests: the wide layouts' traversals (four-triangle packets, 4-wide box tests, compiled
    /// for the instruction set detected at run time), and `intersect_many`, `intersect_stream`
    /// and `occluded_stream`, which must equal `intersect` and `occluded` exactly (these scenes
    /// are too small to stream; `streams_answer_as_single_rays` in irr-geometry forces it).
    /// Rays come as gathers: from a random point of a random triangle, 64 directions of one
    /// side's hemisphere (a quarter of them grazing) sharing their spawned origin plus one ray
    /// that can hit nothing, four such gathers and 64 random rays from one random point per
    /// scene, all in one call of each batched query.
    #[test]
    fn simd_paths_match_the_scalar_oracle(
        seed: u64,
        // Small scenes are built with PLOC, those above 1024 triangles top down.
        soup in prop_oneof![1usize..120, 1100usize..1400],
        grid in 1usize..6,
    ) {
        let mut rng = Rng(seed);
        let unit = random_scene(&mut rng, soup, grid);
        for (scale, shift) in CONFIGS {
            let translation = Vec3::splat(shift);
            let scene = transformed(&unit, scale, translation);
            for layout in [BvhLayout::Wide4, BvhLayout::Wide8] {
                let g = build(&scene, layout);
                let mut rays = Vec::new();
                for _ in 0..4 {
                    let id = rng.below(g.triangle_count()) as u32;
                    let (p, ng) = sample(&g, &mut rng, id);
                    let side = if rng.below(2) == 0 { ng } else { -ng };
                    let origin = Ray::spawn(p, ng, side).origin;
                    for _ in 0..64 {
                        let d = rng.leaving(ng, side);
                        let ray = Ray::spawn(p, ng, d);
                        prop_assert_eq!(ray.origin, origin);
                        rays.push(ray);
                    }
                    // Rays that hit nothing (zero, NaN direction; a zero t_max), in the
                    // gather's run and its packets' classes: they must not disturb the rest.
                    let k = rng.below(rays.len());
                    let invalid = [Vec3::ZERO, Vec3::NAN, side];
                    let which = rng.below(3);
                    let mut bad = Ray::new(origin, invalid[which]);
                    if which == 2 {
                        bad.t_max = 0.0;
                    }
                    rays.insert(rays.len() - k % 64, bad);
                }
                let o = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0))
                    * scale
                    + translation;
                rays.extend((0..64).map(|_| Ray::new(o, rng.unit_vector())));
                let mut many = vec![None; rays.len()];
                g.intersect_many(&rays, &mut many);
                let mut streamed = vec![None; rays.len()];
                g.intersect_stream(&rays, &mut streamed);
                let mut occluded = vec![false; rays.len()];
                g.occluded_stream(&rays, &mut occluded);
                for (((ray, &m), &s), &o) in rays.iter().zip(&many).zip(&streamed).zip(&occluded) {
                    let oracle = g.intersect_brute_force(ray);
                    let context = format!("{layout:?}, scale {scale}, translation {shift}");
                    let one = g.intersect(ray);
                    matches_oracle(&g, ray, one, oracle)
                        .map_err(|e| TestCaseError::fail(format!("{context}, intersect: {e}")))?;
                    prop_assert_eq!(m, one, "{}, intersect_many: {:?}", context, ray);
                    prop_assert_eq!(s, one, "{}, intersect_stream: {:?}", context, ray);
                    prop_assert_eq!(g.occluded(ray), oracle.is_some(), "{}: {:?}", context, ray);
                    prop_assert_eq!(o, oracle.is_some(), "{}, occluded_stream: {:?}", context, ray);
                }
            }
        }
    }
}
