//! Instances: geometry stored once, in its own object space with its own BVH (a *prototype*),
//! and placed any number of times by an affine transform ([`Instance`]), under a top-level
//! BVH over the placements' world boxes: the two-level structure of pbrt-v4, Mitsuba 3 and
//! Cycles. Memory grows with the unique triangles and the placements, not with the placed
//! triangles.
//!
//! # Ids
//! A [`Geometry`] built with [`Geometry::build_instanced`] numbers its triangles in one space:
//! the world meshes' kept triangles first (`0..W`, as [`Geometry::build`] numbers them), then
//! every placement's copy of its prototype's kept triangles, placement after placement. A hit
//! carries such an id; [`Geometry::instance_of`] tells the placement it lies on, and
//! [`Geometry::attribute_id`] the *unique* triangle whose per-vertex data it shares: the world
//! triangles, then each prototype's kept triangles in prototype order (`W..U`). A caller keeps
//! its own per-vertex data (texture coordinates, say) by attribute id, `U` entries however many
//! times the prototypes are placed.
//!
//! # A ray in object space
//! A placement is hit by transforming the ray into its object space (origin and direction in
//! `f64`, rounded once) and tracing the prototype's BVH. An affine map keeps the ray's
//! parameter, so the object-space hit's `t` is the world hit's. The rounded origin may be up
//! to an ulp of each component away from the exact image of the world origin; as in pbrt-v4
//! (`Transform::operator()(Ray)`), the origin is moved forward along the direction by the
//! distance that error can span, `dt = |d|·err / |d|²`, and the ray's end pulled back by the
//! same bound for its end point (origin error plus `t_max` times the direction's): a hit is
//! reported only where the world ray provably reaches it, and a ray spawned off a placed
//! surface (offset by a few ulps in world space, [`Ray::spawn`]) does not hit it again.
//!
//! The surface point of an instanced hit is computed on the prototype's vertices mapped to
//! world space in `f64` and rounded once, so [`Geometry::surface`], [`Geometry::triangle`] and
//! [`Geometry::geometric_normal`] agree with each other exactly, as for world triangles.

use glam::{DAffine3, DVec3, Vec3, Vec3A};
use obvhs::bvh2::node::Bvh2Node;

use crate::build;
use crate::intersect::{PreparedRay, TriSoa, box_entry};
use crate::layout::bvh2_depth;
use crate::query::RayFilter;
use crate::{Geometry, Hit, POSITION_ERROR_FLOOR, Ray, Triangle};

/// One placement of a prototype mesh: an input of [`Geometry::build_instanced`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Instance {
    /// Index of the prototype it places, into the `prototypes` given to the build.
    pub prototype: u32,
    /// Object to world space. In `f64`, so that a chain of node transforms composed by the
    /// caller loses nothing before the one rounding of each mapped vertex. A placement whose
    /// transform is not finite or not invertible is dropped and counted
    /// ([`BuildReport::dropped_instances`](crate::BuildReport::dropped_instances)).
    pub to_world: DAffine3,
    /// The material id of every triangle it places, or `None` for the prototype's own ids
    /// (glTF meshes that share their accessors but not their materials need the former).
    pub material_id: Option<u32>,
}

/// A kept placement as [`Geometry::placements`] describes it: which ids it gives its
/// triangles and where their per-vertex data lies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Placement {
    /// Its index in the build's `instances`.
    pub instance: u32,
    /// The prototype it places.
    pub prototype: u32,
    /// The id of its first triangle; its ids are `first_id..first_id + count`.
    pub first_id: u32,
    /// How many triangles it places (its prototype's kept triangles).
    pub count: u32,
    /// The attribute id of its first triangle ([`Geometry::attribute_id`]); they run on
    /// consecutively.
    pub first_attribute: u32,
    /// [`Instance::material_id`].
    pub material_id: Option<u32>,
}

/// A kept placement, as queries read it.
#[derive(Debug, Clone)]
pub(crate) struct Placed {
    pub(crate) prototype: u32,
    /// [`Instance::material_id`], or [`NO_MATERIAL`] for the prototype's own.
    material: u32,
    to_world: DAffine3,
    /// `to_world`'s inverse; its linear part's transpose maps shading normals.
    to_object: DAffine3,
    /// The instance's index in the build's input, for [`Geometry::instance_of`].
    input: u32,
}

const NO_MATERIAL: u32 = u32::MAX;

/// The placements of a geometry built with [`Geometry::build_instanced`]: the prototypes'
/// geometries, the kept placements, and the top-level BVH over their world boxes.
#[derive(Debug, Clone)]
pub(crate) struct Instances {
    /// Each prototype's geometry in object space, or `None` where none of its triangles was
    /// kept.
    pub(crate) prototypes: Vec<Option<Geometry>>,
    pub(crate) placed: Vec<Placed>,
    /// The top level: obvhs BVH2 nodes over `placed`, whose leaves index `order`.
    nodes: Vec<Bvh2Node>,
    /// `placed` indices in leaf order.
    order: Vec<u32>,
    /// The world box of each entry of `order`: a leaf holds up to four placements, and a
    /// placement's object-space ray and traversal cost far more than this test.
    boxes: Vec<(Vec3A, Vec3A)>,
    /// The most entries a top-level traversal's stack holds.
    stack_len: usize,
    /// The first id of each placement's triangles (increasing; after the world's `W`).
    bases: Vec<u32>,
    /// The attribute id of each prototype's first kept triangle.
    attribute_bases: Vec<u32>,
    /// `W`, the world triangles' count.
    pub(crate) world: u32,
    /// All ids: `W` plus every placement's triangles.
    pub(crate) total: u32,
    /// `U`: the world's and the prototypes' kept triangles.
    pub(crate) unique: u32,
    /// The world box around every placement.
    pub(crate) bounds: (Vec3, Vec3),
}

/// A filter bound to a world ray, asked about a prototype's candidates: it sees them with the
/// world id and the world ray's parameter.
#[derive(Clone, Copy)]
struct Mapped<B> {
    filter: B,
    base: u32,
    dt: f32,
}

impl<B: RayFilter> RayFilter for Mapped<B> {
    const ALL: bool = B::ALL;

    #[inline(always)]
    fn accept(self, hit: &Hit) -> bool {
        self.filter.accept(&Hit {
            t: hit.t + self.dt,
            triangle: self.base + hit.triangle,
            ..*hit
        })
    }
}

/// The bound on an `f64` value's error once rounded to `f32`, with the `f64` arithmetic's own
/// below it: an ulp (twice the half-ulp rounding), floored as [`crate::position_error`] is.
fn rounding_error(v: Vec3) -> Vec3 {
    v.abs() * f32::EPSILON + Vec3::splat(POSITION_ERROR_FLOOR)
}

impl Placed {
    /// `ray` (the world ray, with `t_max` the closest hit so far) in object space, and the
    /// parameter `dt` by which its origin was moved forward (see the module docs); `None` if
    /// nothing is left of it.
    #[inline]
    fn object_ray(&self, ray: &Ray, t_max: f32) -> Option<(Ray, f32)> {
        let o = self
            .to_object
            .transform_point3(ray.origin.as_dvec3())
            .as_vec3();
        let d = self
            .to_object
            .transform_vector3(ray.direction.as_dvec3())
            .as_vec3();
        let len2 = d.length_squared();
        if !(len2 > 0.0 && len2.is_finite() && o.is_finite()) {
            return None;
        }
        let (eo, ed) = (rounding_error(o), rounding_error(d));
        let dt = d.abs().dot(eo) / len2;
        let t_end = if t_max.is_finite() {
            // The end point's error: the origin's and t_max times the direction's.
            t_max - dt - d.abs().dot(eo + ed * t_max) / len2
        } else {
            t_max
        };
        (t_end > 0.0).then(|| {
            (
                Ray {
                    origin: o + d * dt,
                    direction: d,
                    t_max: t_end,
                },
                dt,
            )
        })
    }

    fn map_point(&self, p: Vec3) -> Vec3 {
        self.to_world.transform_point3(p.as_dvec3()).as_vec3()
    }
}

impl Instances {
    /// Places the prototypes: drops (and counts in `dropped`) placements that are not finite
    /// and invertible or whose prototype kept nothing, numbers the ids, and builds the top
    /// level.
    pub(crate) fn new(
        prototypes: Vec<Option<Geometry>>,
        instances: &[Instance],
        world: u32,
        dropped: &mut usize,
    ) -> Result<Instances, crate::GeometryError> {
        let mut attribute_bases = Vec::with_capacity(prototypes.len());
        let mut unique = u64::from(world);
        for p in &prototypes {
            attribute_bases.push(unique as u32);
            unique += p.as_ref().map_or(0, |g| g.world_count() as u64);
        }
        let mut placed = Vec::new();
        let mut bases = Vec::new();
        let mut prims = Vec::new();
        let mut placed_boxes = Vec::new();
        let mut total = u64::from(world);
        let (mut lo_all, mut hi_all) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for (k, inst) in instances.iter().enumerate() {
            let Some(slot) = prototypes.get(inst.prototype as usize) else {
                return Err(crate::GeometryError::PrototypeOutOfRange {
                    instance: k,
                    prototype: inst.prototype,
                    prototypes: prototypes.len(),
                });
            };
            let Some(proto) = slot else {
                *dropped += 1;
                continue;
            };
            let m = inst.to_world;
            let det = m.matrix3.determinant();
            let to_object = m.inverse();
            if !(m.is_finite() && det != 0.0 && to_object.is_finite()) {
                *dropped += 1;
                continue;
            }
            // The world box: the prototype box's corners mapped in f64, rounded outward.
            let (pmin, pmax) = proto.bounds();
            let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            for c in 0..8 {
                let corner = DVec3::new(
                    if c & 1 == 0 { pmin.x } else { pmax.x }.into(),
                    if c & 2 == 0 { pmin.y } else { pmax.y }.into(),
                    if c & 4 == 0 { pmin.z } else { pmax.z }.into(),
                );
                let w = m.transform_point3(corner);
                lo = lo.min(w);
                hi = hi.max(w);
            }
            let (lo, hi) = (round_down(lo), round_up(hi));
            if !(lo.is_finite() && hi.is_finite()) {
                *dropped += 1;
                continue;
            }
            lo_all = lo_all.min(lo);
            hi_all = hi_all.max(hi);
            prims.push(build::Prim::new(lo, hi, placed.len() as u32));
            placed_boxes.push((Vec3A::from(lo), Vec3A::from(hi)));
            bases.push(total as u32);
            total += proto.world_count() as u64;
            if total > u64::from(u32::MAX) {
                return Err(crate::GeometryError::TooManyIds { count: total });
            }
            placed.push(Placed {
                prototype: inst.prototype,
                material: inst.material_id.unwrap_or(NO_MATERIAL),
                to_world: m,
                to_object,
                input: k as u32,
            });
        }
        placed.shrink_to_fit();
        bases.shrink_to_fit();
        let (nodes, order) = if prims.is_empty() {
            (Vec::new(), Vec::new())
        } else {
            let mut bvh = build::build_bvh2(prims).0;
            bvh.nodes.shrink_to_fit();
            bvh.primitive_indices.shrink_to_fit();
            (
                std::mem::take(&mut bvh.nodes),
                std::mem::take(&mut bvh.primitive_indices),
            )
        };
        let boxes = order.iter().map(|&k| placed_boxes[k as usize]).collect();
        Ok(Instances {
            boxes,
            stack_len: if nodes.is_empty() {
                0
            } else {
                bvh2_depth(&nodes)
            },
            prototypes,
            placed,
            nodes,
            order,
            bases,
            attribute_bases,
            world,
            total: total as u32,
            unique: unique as u32,
            bounds: (lo_all, hi_all),
        })
    }

    /// The kept placements, in id order.
    pub(crate) fn placements(&self) -> impl Iterator<Item = Placement> + '_ {
        self.placed
            .iter()
            .zip(&self.bases)
            .map(|(p, &first_id)| Placement {
                instance: p.input,
                prototype: p.prototype,
                first_id,
                count: self.prototypes[p.prototype as usize]
                    .as_ref()
                    .map_or(0, |g| g.world_count() as u32),
                first_attribute: self.attribute_bases[p.prototype as usize],
                material_id: (p.material != NO_MATERIAL).then_some(p.material),
            })
    }

    /// The material id of placed triangle `id`, without mapping its vertices.
    pub(crate) fn material_id(&self, id: u32) -> u32 {
        let (k, local) = self.locate(id);
        self.material_of(k, local)
    }

    /// The material of placement `k`'s copy of its prototype's triangle `local`.
    #[inline]
    fn material_of(&self, k: usize, local: u32) -> u32 {
        match self.placed[k].material {
            NO_MATERIAL => self.prototype(k).material_id(local),
            m => m,
        }
    }

    /// The placement and the prototype's own id of an id at or beyond `world`.
    #[inline]
    pub(crate) fn locate(&self, id: u32) -> (usize, u32) {
        let k = self.bases.partition_point(|&b| b <= id) - 1;
        (k, id - self.bases[k])
    }

    /// The prototype of placement `k`.
    #[inline]
    fn prototype(&self, k: usize) -> &Geometry {
        match &self.prototypes[self.placed[k].prototype as usize] {
            Some(g) => g,
            // Placements of prototypes that kept nothing were dropped at the build.
            None => unreachable!("a kept placement's prototype kept triangles"),
        }
    }

    /// The attribute id of id `id` (at or beyond `world`).
    pub(crate) fn attribute_id(&self, id: u32) -> u32 {
        let (k, local) = self.locate(id);
        self.attribute_bases[self.placed[k].prototype as usize] + local
    }

    /// The input index of the instance id `id` lies on.
    pub(crate) fn instance_of(&self, id: u32) -> u32 {
        self.placed[self.locate(id).0].input
    }

    /// Placed triangle `id` in world space, and its placement.
    pub(crate) fn triangle(&self, id: u32) -> (Triangle, usize, u32) {
        let (k, local) = self.locate(id);
        let p = &self.placed[k];
        let v = self
            .prototype(k)
            .stored(local)
            .vertices()
            .map(|v| p.map_point(v));
        let material_id = self.material_of(k, local);
        (Triangle { p: v, material_id }, k, local)
    }

    /// The world geometric normal of placed triangle `id` (from its mapped vertices, as
    /// [`Geometry::surface`] computes it).
    pub(crate) fn geometric_normal(&self, id: u32) -> Vec3 {
        TriSoa::new(self.triangle(id).0.p).normal()
    }

    /// The prototype's vertex shading normals of placed triangle `(k, local)`, mapped to world
    /// space (unnormalised: the interpolation normalises).
    pub(crate) fn vertex_normals(&self, k: usize, local: u32) -> Option<[Vec3; 3]> {
        let m = self.placed[k].to_object.matrix3.transpose();
        self.prototype(k)
            .vertex_normals(local)
            .map(|n| n.map(|n| (m * n.as_dvec3()).as_vec3()))
    }

    /// A vector of the prototype's object space (a tangent, say) in world space, for
    /// placed triangle `id`.
    pub(crate) fn vector_to_world(&self, id: u32, v: Vec3) -> Vec3 {
        let k = self.locate(id).0;
        self.placed[k]
            .to_world
            .transform_vector3(v.as_dvec3())
            .as_vec3()
    }

    /// The closest hit among the placements of a world ray that is nearer than `best` (the
    /// world tree's answer), with filter `filter` bound to the ray.
    pub(crate) fn closest<B: RayFilter>(
        &self,
        ray: &Ray,
        mut best: Option<Hit>,
        filter: B,
        brute_force: bool,
    ) -> Option<Hit> {
        let mut t_max = best.map_or(ray.t_max, |h| h.t);
        self.walk(ray, &mut t_max, brute_force, |k, t_max| {
            let Some((proto, object, on)) = self.in_object_space(k, ray, *t_max, filter) else {
                return false;
            };
            let (dt, base) = (on.dt, on.base);
            let hit = if brute_force {
                proto.world_closest_brute_force(&object, on)
            } else {
                proto.world_closest(&object, on)
            };
            if let Some(h) = hit {
                let t = h.t + dt;
                if t < *t_max {
                    *t_max = t;
                    best = Some(Hit {
                        t,
                        triangle: base + h.triangle,
                        ..h
                    });
                }
            }
            false
        });
        best
    }

    /// Placement `k`'s prototype, the world ray (up to `t_max`) in its object space, and the
    /// filter as the prototype's traversal asks it; `None` if nothing is left of the ray.
    #[inline(always)]
    fn in_object_space<B: RayFilter>(
        &self,
        k: usize,
        ray: &Ray,
        t_max: f32,
        filter: B,
    ) -> Option<(&Geometry, Ray, Mapped<B>)> {
        let (object, dt) = self.placed[k].object_ray(ray, t_max)?;
        let on = Mapped {
            filter,
            base: self.bases[k],
            dt,
        };
        Some((self.prototype(k), object, on))
    }

    /// Whether a world ray hits any placement (that `filter` accepts).
    pub(crate) fn any<B: RayFilter>(&self, ray: &Ray, filter: B, brute_force: bool) -> bool {
        let mut t_max = ray.t_max;
        let mut found = false;
        self.walk(ray, &mut t_max, brute_force, |k, t_max| {
            let Some((proto, object, on)) = self.in_object_space(k, ray, *t_max, filter) else {
                return false;
            };
            found = if brute_force {
                proto.world_any_brute_force(&object, on)
            } else {
                proto.world_any(&object, on)
            };
            found
        });
        found
    }

    /// Calls `visit(k, t_max)` for each placement `k` whose box the ray enters before `t_max`
    /// (which `visit` may shrink), nearest box first, until `visit` returns true. With
    /// `brute_force`, every placement in order, without the top level.
    fn walk(
        &self,
        ray: &Ray,
        t_max: &mut f32,
        brute_force: bool,
        mut visit: impl FnMut(usize, &mut f32) -> bool,
    ) {
        if self.nodes.is_empty() || !PreparedRay::traceable(ray) {
            return;
        }
        if brute_force {
            for k in 0..self.placed.len() {
                if visit(k, t_max) {
                    return;
                }
            }
            return;
        }
        let r = PreparedRay::prepare(ray, f32::INFINITY);
        let entry = |n: &Bvh2Node, t: f32| box_entry(n.aabb().min, n.aabb().max, &r, t);
        let mut small = [(0u32, 0f32); 64];
        let mut large = Vec::new();
        let stack: &mut [(u32, f32)] = if self.stack_len <= small.len() {
            &mut small
        } else {
            large.resize(self.stack_len, (0, 0.0));
            &mut large
        };
        let mut sp = 0;
        let mut node = 0usize;
        if entry(&self.nodes[0], *t_max) == f32::INFINITY {
            return;
        }
        loop {
            let n = &self.nodes[node];
            let mut next = None;
            if n.is_leaf() {
                let first = n.first_index as usize;
                for i in first..first + n.prim_count as usize {
                    let (lo, hi) = self.boxes[i];
                    if box_entry(lo, hi, &r, *t_max) != f32::INFINITY
                        && visit(self.order[i] as usize, t_max)
                    {
                        return;
                    }
                }
            } else {
                let (a, b) = (n.first_index as usize, n.first_index as usize + 1);
                let (ta, tb) = (entry(&self.nodes[a], *t_max), entry(&self.nodes[b], *t_max));
                let (near, far, tn, tf) = if ta <= tb {
                    (a, b, ta, tb)
                } else {
                    (b, a, tb, ta)
                };
                if tn != f32::INFINITY {
                    next = Some(near);
                    if tf != f32::INFINITY {
                        stack[sp] = (far as u32, tf);
                        sp += 1;
                    }
                }
            }
            node = match next {
                Some(n) => n,
                None => loop {
                    if sp == 0 {
                        return;
                    }
                    sp -= 1;
                    let (n, t) = stack[sp];
                    if t <= *t_max {
                        break n as usize;
                    }
                },
            };
        }
    }

    /// Heap bytes: the prototypes' geometries and the placements.
    pub(crate) fn heap_bytes(&self) -> Vec<(&'static str, usize)> {
        let prototypes: usize = self
            .prototypes
            .iter()
            .flatten()
            .map(|g| g.heap_bytes().iter().map(|(_, b)| b).sum::<usize>())
            .sum();
        vec![
            ("prototypes", prototypes),
            (
                "placements",
                self.placed.capacity() * size_of::<Placed>()
                    + self.bases.capacity() * size_of::<u32>()
                    + self.attribute_bases.capacity() * size_of::<u32>()
                    + self.order.capacity() * size_of::<u32>()
                    + self.boxes.capacity() * size_of::<(Vec3A, Vec3A)>()
                    + self.nodes.capacity() * size_of::<Bvh2Node>(),
            ),
        ]
    }

    /// Nodes of the top level and of every prototype.
    pub(crate) fn node_count(&self) -> usize {
        self.nodes.len()
            + self
                .prototypes
                .iter()
                .flatten()
                .map(Geometry::node_count)
                .sum::<usize>()
    }
}

fn round_down(v: DVec3) -> Vec3 {
    let f = v.as_vec3();
    Vec3::from_array(std::array::from_fn(|i| {
        if f64::from(f[i]) > v[i] {
            f[i].next_down()
        } else {
            f[i]
        }
    }))
}

fn round_up(v: DVec3) -> Vec3 {
    let f = v.as_vec3();
    Vec3::from_array(std::array::from_fn(|i| {
        if f64::from(f[i]) < v[i] {
            f[i].next_up()
        } else {
            f[i]
        }
    }))
}

#[cfg(test)]
mod tests {
    use glam::{DQuat, DVec3};
    use proptest::prelude::*;

    use super::*;
    use crate::test_meshes::{box_mesh, mixed_meshes, stacked_grids, xorshift};
    use crate::{BvhLayout, GeometryError, HitFilter, TriangleMesh};

    /// `n` placements of prototypes `0..prototypes` with random rotations, scales (some
    /// non-uniform, some mirrored) and translations within `spread`.
    fn placements(n: usize, prototypes: u32, spread: f64, seed: u32) -> Vec<Instance> {
        let mut next = xorshift(seed | 1);
        let mut r = move || f64::from(next());
        (0..n)
            .map(|k| {
                let axis = DVec3::new(r(), r(), r() + 1.5).normalize();
                let scale = DVec3::new(1.0 + 0.5 * r(), 1.0 + 0.5 * r(), 1.0 + 0.5 * r())
                    * if k % 5 == 3 { -1.0 } else { 1.0 };
                Instance {
                    prototype: k as u32 % prototypes,
                    to_world: DAffine3::from_scale_rotation_translation(
                        scale,
                        DQuat::from_axis_angle(axis, 3.0 * r()),
                        DVec3::new(r(), r(), r()) * spread,
                    ),
                    material_id: (k % 3 == 1).then_some(100 + k as u32),
                }
            })
            .collect()
    }

    /// World meshes, prototypes (with dropped triangles and shading normals) and placements.
    fn scene(layout: BvhLayout, seed: u32) -> Geometry {
        let world = vec![mixed_meshes(40).remove(2)];
        let mut prototypes = mixed_meshes(60);
        prototypes.push(stacked_grids(2));
        let instances = placements(12, prototypes.len() as u32, 4.0, seed);
        Geometry::build_instanced_with_layout(world, prototypes, &instances, layout)
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// The same triangles as `g`'s, each stored in world space (ids the same).
    fn flattened(g: &Geometry) -> Geometry {
        let mut mesh = TriangleMesh::default();
        for (id, t) in g.triangles().enumerate() {
            mesh.positions.extend(t.p);
            let v = 3 * id as u32;
            mesh.indices.push([v, v + 1, v + 2]);
            mesh.material_ids.push(t.material_id);
        }
        let flat = Geometry::build(&[mesh]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(flat.triangle_count(), g.triangle_count(), "no copy dropped");
        flat
    }

    fn rays(g: &Geometry, n: usize, seed: u32) -> Vec<Ray> {
        let mut next = xorshift(seed);
        let (lo, hi) = g.bounds();
        let (c, h) = ((lo + hi) * 0.5, (hi - lo) * 0.6);
        (0..n)
            .map(|k| {
                let o = c + h * Vec3::new(next(), next(), next());
                let d = Vec3::new(next(), next(), next());
                Ray {
                    origin: o,
                    direction: d,
                    t_max: if k % 3 == 0 { 2.0 } else { f32::INFINITY },
                }
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(12))]

        /// Every query on placed geometry answers exactly as the brute-force reference (every
        /// placement, every prototype triangle, the same object-space rays), in every layout,
        /// one ray or a batch, filtered or not.
        #[test]
        fn placed_queries_match_the_brute_force(seed in 1u32..u32::MAX) {
            for layout in [BvhLayout::Bvh2, BvhLayout::Wide4, BvhLayout::Wide8] {
                let g = scene(layout, seed);
                let rays = rays(&g, 300, seed ^ 0x9e37);
                // A `dyn` filter: a closure type would instantiate every traversal again.
                let odd: &dyn HitFilter = &|_: &Ray, h: &Hit| h.triangle % 2 == 1;
                let mut many = vec![None; rays.len()];
                let mut stream = vec![None; rays.len()];
                let mut blocked = vec![false; rays.len()];
                g.intersect_many(&rays, &mut many);
                g.intersect_stream_filtered(&rays, &mut stream, odd);
                g.occluded_stream(&rays, &mut blocked);
                for (k, ray) in rays.iter().enumerate() {
                    let hit = g.intersect(ray);
                    prop_assert_eq!(hit, g.intersect_brute_force(ray));
                    prop_assert_eq!(many[k], hit);
                    let filtered = g.intersect_brute_force_filtered(ray, odd);
                    prop_assert_eq!(g.intersect_filtered(ray, odd), filtered);
                    prop_assert_eq!(stream[k], filtered);
                    prop_assert_eq!(g.occluded(ray), g.occluded_brute_force(ray));
                    prop_assert_eq!(blocked[k], g.occluded(ray));
                    prop_assert_eq!(
                        g.occluded_filtered(ray, odd),
                        g.occluded_brute_force_filtered(ray, odd)
                    );
                    prop_assert_eq!(g.occluded(ray), hit.is_some());
                }
            }
        }
    }

    /// Placed triangles are hit where their world-space copies are: rays aimed at each copy's
    /// centroid hit the same id as in a geometry of the copies, or (where copies cross) one
    /// at the same distance within the error bound below.
    #[test]
    fn placed_hits_agree_with_world_copies() {
        let g = scene(BvhLayout::Wide8, 7);
        let flat = flattened(&g);
        let (lo, hi) = g.bounds();
        let extent = lo.abs().max(hi.abs()).max_element();
        let mut next = xorshift(11);
        let mut differing = 0;
        for id in (0..g.triangle_count() as u32).step_by(3) {
            let t = g.triangle(id);
            let target = (t.p[0] + t.p[1] + t.p[2]) / 3.0;
            let origin = target + Vec3::new(next(), next(), next()) * 3.0;
            let ray = Ray::new(origin, target - origin);
            let (Some(a), Some(b)) = (g.intersect(&ray), flat.intersect(&ray)) else {
                panic!("ray at triangle {id}'s centroid missed");
            };
            // Where they differ, both are hits of the same ray on the two copies of one
            // surface: the copies' vertices differ by at most the rounding of the mapped
            // vertex (half an ulp of the extent), and the object-space ray's origin by an ulp
            // of its coordinates (mapped back: at most the placement's scale, 1.5, times the
            // extent's ulp), so the hit points differ along the ray by at most about
            // 4·ε·extent / |cos θ| in world units; t is in units of |d|.
            let cos = g
                .geometric_normal(a.triangle)
                .dot(ray.direction.normalize())
                .abs();
            let bound = 4.0 * f32::EPSILON * extent / (cos.max(1e-3) * ray.direction.length());
            assert!(
                (a.t - b.t).abs() <= bound.max(2.0 * f32::EPSILON * a.t),
                "triangle {id}: t {} placed, {} copied (bound {bound})",
                a.t,
                b.t
            );
            differing += usize::from(a.triangle != b.triangle);
        }
        // Centroids are far from every edge: the same triangle is found but where copies
        // cross within the bound, which the random placements make rare.
        assert!(
            differing * 20 < g.triangle_count() / 3,
            "{differing} differing ids"
        );
    }

    /// Ids, attribute ids, instances, materials and the build report of a placed geometry.
    #[test]
    fn ids_name_their_placement_prototype_and_material() {
        let world = vec![mixed_meshes(10).remove(3)]; // a quad: 2 triangles
        let mut proto = mixed_meshes(10).remove(0); // a soup of 10, 2 dropped
        proto.material_ids = vec![5; proto.indices.len()];
        let grid = mixed_meshes(10).remove(2); // 800 triangles
        let place = |prototype, x: f64, material_id| Instance {
            prototype,
            to_world: DAffine3::from_translation(DVec3::new(x, 0.0, 0.0)),
            material_id,
        };
        let mut singular = place(0, 0.0, None);
        singular.to_world.matrix3.x_axis = DVec3::ZERO;
        let instances = [
            place(0, 10.0, None),
            singular,
            place(1, 20.0, Some(3)),
            place(0, f64::NAN, None),
            place(0, 30.0, Some(4)),
        ];
        let g = Geometry::build_instanced(world, vec![proto, grid], &instances)
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(g.report().dropped_instances, 2);
        assert_eq!(g.report().kept, 2 + 8 + 800);
        assert_eq!(g.unique_triangle_count(), 810);
        assert_eq!(g.triangle_count(), 2 + 8 + 800 + 8);
        // The world quad, then placements 0, 2 and 4 of the input.
        assert_eq!(g.instance_of(1), None);
        assert_eq!(g.instance_of(2), Some(0));
        assert_eq!(g.instance_of(10), Some(2));
        assert_eq!(g.instance_of(810), Some(4));
        assert_eq!(g.attribute_id(1), 1);
        assert_eq!(g.attribute_id(2), 2);
        assert_eq!(g.attribute_id(10), 10);
        assert_eq!(g.attribute_id(809), 809);
        assert_eq!(g.attribute_id(810), 2);
        assert_eq!(g.attribute_id(817), 9);
        assert_eq!(g.material_id(2), 5);
        assert_eq!(g.material_id(10), 3);
        assert_eq!(g.material_id(817), 4);
        assert_eq!(g.world_triangle_count(), 2);
        let placements: Vec<_> = g.placements().collect();
        assert_eq!(
            placements[1],
            Placement {
                instance: 2,
                prototype: 1,
                first_id: 10,
                count: 800,
                first_attribute: 10,
                material_id: Some(3)
            }
        );
        assert_eq!(
            placements
                .iter()
                .map(|p| (p.instance, p.first_id, p.first_attribute))
                .collect::<Vec<_>>(),
            [(0, 2, 2), (2, 10, 10), (4, 810, 2)]
        );
        let copy = g.triangle(2).p;
        let twin = g.triangle(810).p;
        // x + 10 and x + 30, each rounded once: 20 apart within an ulp of 32 each.
        for (a, b) in copy.iter().zip(twin) {
            let gap = (*a + Vec3::new(20.0, 0.0, 0.0) - b).abs().max_element();
            assert!(gap <= 2.0 * 32.0 * f32::EPSILON, "{a} vs {b}");
        }
        let bad = [place(2, 0.0, None)];
        assert_eq!(
            Geometry::build_instanced(Vec::new(), vec![mixed_meshes(4).remove(3)], &bad)
                .map(|_| ()),
            Err(GeometryError::PrototypeOutOfRange {
                instance: 0,
                prototype: 2,
                prototypes: 1
            })
        );
    }

    /// A placement costs at most `BUILT_BYTES_PER_INSTANCE` (10⁴ placements of one quad,
    /// whose prototype's bytes are counted apart).
    #[test]
    fn the_bytes_per_placement_stay_under_their_bound() {
        let instances: Vec<Instance> = (0..10_000)
            .map(|k| Instance {
                prototype: 0,
                to_world: DAffine3::from_translation(DVec3::new(f64::from(k), 0.0, 0.0)),
                material_id: None,
            })
            .collect();
        let g = Geometry::build_instanced(Vec::new(), vec![mixed_meshes(4).remove(3)], &instances)
            .unwrap_or_else(|e| panic!("{e}"));
        let placements = g
            .heap_bytes()
            .iter()
            .find(|(name, _)| *name == "placements")
            .map_or(0, |(_, b)| *b);
        let per = placements as f64 / 1e4;
        assert!(
            per <= crate::BUILT_BYTES_PER_INSTANCE as f64,
            "{per} bytes a placement"
        );
    }

    /// A closed unit cube about the origin, each face its own material.
    fn cube() -> TriangleMesh {
        box_mesh(|i| {
            let s = |bit: usize| if i & bit == 0 { -0.5 } else { 0.5 };
            Vec3::new(s(1), s(2), s(4))
        })
    }

    /// Rays spawned off a placed cube's faces (at tiny, unit and huge scales, rotated,
    /// stretched and far translated) never hit the face they leave: outward they escape,
    /// inward they reach another face.
    #[test]
    fn rays_leave_placed_surfaces_at_every_scale() {
        let mut next = xorshift(3);
        let mut corners = 0;
        for (scale, offset) in [(1e-4, 0.0), (1.0, 0.0), (1e3, 0.0), (1.0, 1e5), (3e2, -2e4)] {
            let to_world = DAffine3::from_scale_rotation_translation(
                DVec3::new(1.0, 0.3, 2.0) * scale,
                DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7),
                DVec3::new(offset, 0.5 * offset, 0.25),
            );
            let placed = Instance {
                prototype: 0,
                to_world,
                material_id: None,
            };
            let g = Geometry::build_instanced(Vec::new(), vec![cube()], &[placed])
                .unwrap_or_else(|e| panic!("{e}"));
            let centre = to_world.translation.as_vec3();
            for _ in 0..2000 {
                // From outside: 4·scale is beyond the cube's half diagonal (1.13·scale).
                let d = Vec3::new(next(), next(), next()).normalize();
                let ray = Ray::new(centre - d * (4.0 * scale as f32), d);
                let hit = g.intersect(&ray).unwrap_or_else(|| panic!("cube missed"));
                let s = g.surface(&ray, &hit);
                let w = Vec3::new(next(), next(), next()).normalize();
                let outward = if w.dot(s.geometric_normal) * d.dot(s.geometric_normal) < 0.0 {
                    w
                } else {
                    -w
                };
                let out = Ray::spawn(s.position, s.geometric_normal, outward);
                assert_eq!(g.intersect(&out), None, "scale {scale}, offset {offset}");
                let inside = Ray::spawn(s.position, s.geometric_normal, -outward);
                match g.intersect(&inside) {
                    Some(far) => assert_ne!(g.material_id(far.triangle), s.material_id),
                    None => {
                        // A point within an ulp of an edge may round (or be offset) onto the
                        // far side of the adjacent face's plane, as for world triangles
                        // (tests/it/geometry.rs): then the ray starts outside the cube, and
                        // leaving through that plane it must miss. Anything else escaped.
                        let to_object = to_world.inverse();
                        let o = to_object.transform_point3(inside.origin.as_dvec3());
                        let d = to_object.transform_vector3(inside.direction.as_dvec3());
                        let outside = (0..3).any(|i| o[i].abs() >= 0.5 && o[i] * d[i] > 0.0);
                        assert!(
                            outside,
                            "scale {scale}, offset {offset}: {inside:?} escaped"
                        );
                        corners += 1;
                    }
                }
            }
        }
        // Such points lie within the offset (at most 6 ulps: 0.05 at 1e5, the coarsest
        // configuration) of an edge: on faces of 1 × 0.3, 2 × 0.3 and 1 × 2, at most
        // perimeter·0.05/area ≈ 1/3 of one configuration's 2000 hit points, and only where
        // the ray leaves through the adjacent plane (half of them): below 2000/6 in all.
        assert!(corners < 2000 / 6, "{corners} rays started outside");
    }

    /// Shading normals are mapped by the inverse transpose: the same as a world copy's
    /// normals so mapped, under a stretch that turns them.
    #[test]
    fn placed_shading_normals_follow_the_inverse_transpose() {
        let mut proto = mixed_meshes(4).remove(3); // a quad at z = 4 with tilted normals
        proto.normals = Some(vec![Vec3::new(0.3, 0.2, 1.0); 4]);
        let to_world = DAffine3::from_scale(DVec3::new(4.0, 1.0, 0.5));
        let n = (to_world.matrix3.inverse().transpose() * DVec3::new(0.3, 0.2, 1.0))
            .normalize()
            .as_vec3();
        let g = Geometry::build_instanced(
            Vec::new(),
            vec![proto],
            &[Instance {
                prototype: 0,
                to_world,
                material_id: None,
            }],
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let ray = Ray::new(Vec3::new(1.0, 0.3, 0.0), Vec3::Z);
        let hit = g.intersect(&ray).unwrap_or_else(|| panic!("missed"));
        let s = g.surface(&ray, &hit);
        assert!((s.position.z - 2.0).abs() < 1e-6);
        // Interpolating three equal normals in f32 and normalising: a few ulps.
        assert!(
            (s.shading_normal - n).length() < 1e-6,
            "{} vs {n}",
            s.shading_normal
        );
        assert_eq!(
            g.vector_to_world(hit.triangle, Vec3::X),
            Vec3::new(4.0, 0.0, 0.0)
        );
    }
}
