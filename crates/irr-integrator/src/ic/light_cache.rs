//! The light cache: a dense, cheap estimate of the irradiance at any surface point, for the
//! gather rays' continuations (V-Ray's light cache, Corona's UHD cache).
//!
//! # What it stores
//! Camera-launched paths ([`trace_light_path`]) deposit, at every vertex v they reach, an
//! estimate of the irradiance E(v) there: the direct part by one light sample and the emission
//! the path's next ray finds, weighted against each other by the power heuristic as the path
//! tracer weighs them (a light sample alone has unbounded weight where an emitter meets a
//! surface: rare, huge deposits that would leave a cell bright for every gather that reads
//! it), plus the indirect part
//! carried back from the rest of the same path
//! (cos θ/(pdf·q)·L_reflected(v₊₁) with q the Russian-roulette probability of continuing and
//! pdf the drawn direction's density: π/q on a Lambertian vertex; B in place of L_reflected when
//! the path left the scene). Each estimate is unbiased for E(v) (with the path tracer's limit
//! on reflections), and a path's vertices share its suffix, so a vertex costs about one
//! closest-hit ray and one shadow ray. Irradiance does not depend on the surface's BSDF, so
//! glossy vertices deposit too; their paths go on by a defensive mixture of cosine and BSDF
//! sampling (weighted by the BSDF, so the light they carry back is what the glossy surface
//! reflects).
//!
//! The deposits are averaged in cells of a world-space grid, keyed by the cell and by the
//! shading normal's dominant axis and sign (six buckets), so that the two sides of a thin wall,
//! or a floor and the wall beside it, never share a cell. With the view the paths come from
//! ([`LightCache::for_view`]), a cell's width at a point is a fixed fraction of the image's
//! height at the point's distance, rounded to a power of two: cells are as fine as the image
//! looks, wherever it looks, and geometry the view does not approach (a far ground plane) gets
//! coarse cells instead of coarsening every cell, as a width taken from the scene's bounds would.
//!
//! # Walls
//! No key of position and orientation tells apart the floors of two rooms split by a wall
//! thinner than a cell: they are coplanar and face the same way. So each cell keeps an anchor,
//! the point of its first deposit (in merge order, so the same in every run), and a later
//! deposit that does not see it (a shadow ray between the two surfaces' fronts, as the records'
//! leak guard traces it) goes to the cell's hidden side, a second cell of the same place; the
//! cell is then split. A read of a split cell takes the side whose anchor the reader sees (one
//! shadow ray), and a filtered read takes a neighbouring cell only where the reader sees that
//! cell's anchor (one or two), so neither reaches through a wall. A cell whose deposits all saw
//! its anchor is read without a ray: a reader behind a wall from all of them stands where no
//! path went. The points hidden from the anchor share the hidden side whatever hides them (two
//! walls within one cell). The cost: a shadow ray per deposit, and the reads' above.
//!
//! # Its memory
//! At most [`MAX_CELLS`] cells, in a table of at most 2²² slots: [`TABLE_BYTES`] (516 MiB)
//! whatever the scene and the number of paths. Once the table holds [`MAX_CELLS`] cells, a
//! deposit in a cell it does not hold is dropped and counted ([`LightCacheCounts::dropped`]);
//! the cells it holds keep every deposit. So no cell's mean changes, and a lookup in a cell that
//! was never made path-traces as in a sparse one: the full table costs rays, never bias. Paths
//! are merged in their index order, so which cells exist is the same in every run.
//!
//! # What a gather ray takes from it
//! A gather ray that hits a Lambertian x₁ brings back (ρ(x₁)/π)·Ē(cell of x₁): no light sample
//! and no continuation at all. On a glossy x₁ it brings back (ρ_d/π)·Ē plus, with the
//! probability `Bsdf::residual_probability` and weighted by its inverse, one path-traced sample
//! of the residual f − ρ_d/π (module `ic`, "Glossy surfaces"). A camera hit's lobe samples,
//! which gather near a few points, read the cells filtered ([`LightCache::irradiance_filtered`]),
//! and their glossy hits' residuals go on through the cache, reading one or two reflections
//! deeper ([`DEEPER_READS`]). A cell with fewer than [`MIN_DEPOSITS`] deposits is not used: the
//! gather ray path-traces its continuation as in `BounceMode::PathTraced`, so no light is lost
//! where the camera's paths never went.
//!
//! # Its error
//! The cell mean is an average of E over the cell's surface (weighted by where paths landed),
//! not E(x₁): one lookup errs by O(h·|∇E|) for cells of width h, and a gather, whose rays land
//! all over its cells, by O(h²·∇²E) where E is smooth and O(h) along a crease or a shadow edge,
//! seen through one more diffuse reflection. It shrinks with the cell. Its noise is frozen:
//! every gather ray that hits a cell reads the same mean, so it is shared by neighbouring
//! records and shows as a smooth tint, not as record-sized splotches. docs/performance.md,
//! "Continuations", has the measured bias against the path tracer.

use crate::bsdf::Bsdf;
use crate::ic::guard::between_fronts;
use crate::integrator::RayCounter;
use crate::path::{ShadingPoint, emission_weight, power_heuristic, sample_light};
use crate::scene::Scene;
use glam::{DVec3, Vec2, Vec3};
use irr_geometry::Ray;
use irr_sampling::rng::Dimensions;
use irr_sampling::{Frame, SampleKey};
use rustc_hash::FxHashMap;
use std::collections::hash_map::Entry;

/// The fewest deposits a cell must hold to be used. Below it the cell's mean rests on a few
/// paths, shared by every gather ray that hits the cell, and a path-traced continuation (one
/// path, but independent per ray) is the better estimate.
pub const MIN_DEPOSITS: u32 = 8;

/// How many standard errors of their difference the means of a split cell's two sides must
/// differ by for [`LightCache::settle`] to keep them apart: 3, so that two sides of the same
/// light stay joined in all but 0.3 % of cells (a normal difference's two-sided tail), and a
/// wall that matters, whose sides differ by many standard errors, keeps them apart.
pub const SIDES_APART: f64 = 3.0;

/// The width, in cells, of the box by which [`LightCache::irradiance_filtered`] filters the
/// cells: on the glossy room with order-10 records and 16 lobe samples (docs/performance.md,
/// "Filtered light-cache reads") one cell lowered the glossy error 15 %, two 30 %, three 34 %,
/// four 32 % and six 22 %, the sharper lobes' error rising from three on (their reflections
/// blur).
pub const FILTER_CELLS: f32 = 2.0;

/// The least probability that a light-cache path goes on past `rr_start` vertices (see
/// [`trace_light_path`]): each step's weight 1/q stays at most 2.
pub const MIN_CONTINUATION: f32 = 0.5;

/// The share of the deposits that cells holding at least [`MIN_DEPOSITS`] must have before the
/// cache counts as converged: below it, too many gather rays would find a sparse cell and
/// path-trace their continuation.
pub const CONVERGED_SHARE: f64 = 0.95;

/// A cell of the grid: its level (the base-2 logarithm of its width, 0 in a uniform grid), its
/// integer coordinates at that width, the shading normal's bucket (0–5: the dominant axis,
/// times 2, plus 1 if it points the negative way), and its side: 0 for the points that see the
/// cell's anchor, 1 for those hidden from it (module docs, "Walls").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CellKey {
    level: i8,
    x: i32,
    y: i32,
    z: i32,
    bucket: u8,
    side: u8,
}

impl CellKey {
    /// The cell of `position` with shading normal `ns`, at `level` in a grid of cells
    /// 1/`inv_cell` wide.
    fn of(position: Vec3, ns: Vec3, (level, inv_cell): (i8, f32)) -> Self {
        // Coordinates beyond i32 saturate (`as` on floats does): a scene so far from the origin
        // (2³¹ cells) shares its outermost cells, caching worse there, never indexing wrong.
        let c = (position * inv_cell).floor();
        let a = ns.abs();
        let axis = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let bucket = 2 * axis + u8::from(ns[axis as usize] < 0.0);
        Self {
            level,
            x: c.x as i32,
            y: c.y as i32,
            z: c.z as i32,
            bucket,
            side: 0,
        }
    }

    /// The cell of the same place for the points hidden from its anchor.
    #[inline]
    fn hidden(self) -> Self {
        Self { side: 1, ..self }
    }
}

/// A surface point and the side of its surface it is seen from (its geometric normal turned
/// to the viewer): a cell's anchor, or a deposit's point.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Seen {
    position: Vec3,
    front: Vec3,
}

impl Seen {
    fn of(x: &ShadingPoint) -> Self {
        Self {
            position: x.position,
            front: x.ng,
        }
    }

    /// The shadow ray that tells whether `other` sees this point: between the two fronts, as
    /// the records' leak guard traces it.
    fn ray_to(&self, other: &Seen) -> Ray {
        between_fronts((self.position, self.front), (other.position, other.front))
    }
}

/// The view the light cache sizes its cells by (its paths' camera): where it is and how tall
/// the image it sees is at a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheView {
    /// The centre of projection (for an orthographic view, any point of its axis).
    pub position: Vec3,
    /// The image's height in world units at unit distance, 2·tan(yfov/2) (0 for an
    /// orthographic view).
    pub height_per_distance: f32,
    /// The image's height in world units at any distance: an orthographic view's (0 for a
    /// perspective one).
    pub height: f32,
}

impl CacheView {
    /// The height of the image, in world units, at `p`'s distance from the view.
    #[inline]
    pub fn height_at(&self, p: Vec3) -> f32 {
        self.height + self.height_per_distance * (p - self.position).length()
    }
}

/// How the light cache's cells are laid out.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Grid {
    /// One cell width everywhere: 1/`inv_cell` world units.
    Uniform { inv_cell: f32 },
    /// Cells `fraction` of the view's image height at their distance (a width in screen
    /// units, as V-Ray's light cache sizes its samples), rounded to a power of two so that the
    /// width at a point is a function of the point alone (NVIDIA's SHaRC levels its hash grid
    /// by the distance to the camera the same way): fine where the view looks closely, coarse
    /// far from it, the same cells at any scale of the scene.
    View { view: CacheView, fraction: f32 },
}

/// The finest cell relative to a point's coordinates, 2⁻²⁰·|p|∞: every coordinate of a cell
/// then fits an i32, and the cell is wider than f32's spacing there (2⁻²³·|p|∞).
const FINEST_RELATIVE_LEVEL: i32 = -20;

/// The levels a cell of a view grid may take: widths 2⁻¹⁰⁰ to 2¹⁰⁰ world units, whose
/// reciprocals are exact f32s.
const LEVELS: std::ops::RangeInclusive<i32> = -100..=100;

/// ⌊log₂ x⌋ for a positive normal f32, from its exponent bits (exact on every machine, unlike a
/// library log2); −127 for 0 or a subnormal, 128 for ∞ or NaN.
#[inline]
fn exponent(x: f32) -> i32 {
    ((x.to_bits() >> 23) & 0xff) as i32 - 127
}

impl Grid {
    /// The level of the cell holding `p` and the reciprocal of its width.
    #[inline]
    fn level(&self, p: Vec3) -> (i8, f32) {
        match *self {
            Self::Uniform { inv_cell } => (0, inv_cell),
            Self::View { view, fraction } => {
                // The power of two nearest the target width in log scale: ⌊log₂(√2·t)⌋, so the
                // width lies in (t/√2, √2·t].
                let target = std::f32::consts::SQRT_2 * fraction * view.height_at(p);
                let finest = exponent(p.abs().max_element()) + FINEST_RELATIVE_LEVEL;
                let level = exponent(target)
                    .max(finest)
                    .clamp(*LEVELS.start(), *LEVELS.end());
                // 2^−level, built from its exponent bits: exact.
                let inv = f32::from_bits(((127 - level) as u32) << 23);
                (level as i8, inv)
            }
        }
    }

    /// The cell of a point with shading normal `ns`.
    #[inline]
    fn key(&self, position: Vec3, ns: Vec3) -> CellKey {
        CellKey::of(position, ns, self.level(position))
    }

    /// The width of the cell holding `p`.
    #[inline]
    fn width(&self, p: Vec3) -> f32 {
        1.0 / self.level(p).1
    }
}

/// The most reflections deeper than a gather ray's hit at which a cell can be read
/// ([`LightCache::irradiance_filtered`]'s `deeper`). A deposit's window holds the light of
/// `max_depth` − 2 reflections after its vertex, as a gather ray's hit may reflect; a point m
/// reflections further from the camera may reflect m fewer, so each deposit also keeps what
/// the last `DEEPER_READS` vertices of its window brought, and a read m deeper leaves out the
/// last m. Deeper than this, the reader path-traces.
pub const DEEPER_READS: usize = 2;

/// One path vertex's estimate of the irradiance at its point, filed under its cell, and the
/// parts of it the last vertices of its window brought (`tails[t]`: the vertex t before the
/// window's last; see [`DEEPER_READS`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightDeposit {
    key: CellKey,
    at: Seen,
    irradiance: Vec3,
    tails: [Vec3; DEEPER_READS],
}

/// The bytes of one cell in the light cache's table: its key and its sums (the table adds a
/// control byte, and keeps at most 7/8 of its slots full).
pub const CELL_BYTES: usize = size_of::<CellKey>() + size_of::<CellSums>();

/// The most cells the light cache holds: 7/8 of 2²² (NVIDIA's SHaRC uses 2²² entries), the
/// most a table of 2²² slots holds before it would double (hashbrown keeps at most 7/8 of its
/// slots full), so the table never grows past 2²² slots. Module docs, "Its memory".
pub const MAX_CELLS: usize = 7 << 19;

/// The most bytes the light cache's table takes: 2²² slots of a cell and a control byte each
/// (hashbrown's layout; its 16 trailing control bytes aside), 516 MiB.
pub const TABLE_BYTES: usize = (1 << 22) * (CELL_BYTES + 1);

/// A cell's running sums (in f64: a cell may take millions of deposits), and the sum of its
/// deposits' squared luminances, for the standard error of its mean.
#[derive(Clone, Copy, Debug, Default)]
struct CellSums {
    sum: DVec3,
    tails: [DVec3; DEEPER_READS],
    squares: f64,
    count: u32,
    /// The point of the cell's first deposit, against which later deposits and reads are
    /// tested (module docs, "Walls").
    anchor: Seen,
    /// Whether a deposit hidden from the anchor went to the cell's other side.
    split: bool,
}

/// Whether `at` sees the anchor of cell `c` (a shadow ray, counted in `rays`).
fn sees(scene: &Scene, at: &Seen, c: &CellSums, rays: &mut RayCounter) -> bool {
    rays.shadow += 1;
    !scene.occluded(&c.anchor.ray_to(at))
}

impl CellSums {
    /// Whether this cell's mean luminance and `other`'s differ by more than [`SIDES_APART`]
    /// standard errors of their difference (each side's from its own deposits).
    fn apart_from(&self, other: &CellSums) -> bool {
        let ((m0, v0), (m1, v1)) = (self.luminance_stats(), other.luminance_stats());
        let (n0, n1) = (f64::from(self.count), f64::from(other.count));
        (m0 - m1).abs() > SIDES_APART * (v0 / n0 + v1 / n1).sqrt()
    }

    /// The mean luminance of the cell's deposits and their sample variance (at least 0).
    fn luminance_stats(&self) -> (f64, f64) {
        let n = f64::from(self.count);
        let mean = luminance(self.sum) / n;
        let var = ((self.squares - n * mean * mean) / (n - 1.0)).max(0.0);
        (mean, var)
    }

    /// The cell's mean without the last `deeper` vertices' parts of its deposits, if it holds
    /// at least [`MIN_DEPOSITS`] and `deeper` ≤ [`DEEPER_READS`].
    fn mean(&self, deeper: usize) -> Option<Vec3> {
        let tails = self.tails.get(..deeper)?;
        let sum = tails.iter().fold(self.sum, |sum, t| sum - *t);
        (self.count >= MIN_DEPOSITS).then(|| (sum / f64::from(self.count)).as_vec3())
    }

    /// The squared relative standard error of the cell's mean luminance (0 for a black cell).
    fn relative_variance(&self) -> f64 {
        let (mean, var) = self.luminance_stats();
        if self.count < 2 || mean <= 0.0 {
            return 0.0;
        }
        var / (f64::from(self.count) * mean * mean)
    }
}

/// Rec. 709 luminance in f64, for the cells' f64 sums ([`irr_bsdf::luminance`] is the f32 one).
fn luminance(v: DVec3) -> f64 {
    v.dot(DVec3::new(0.2126, 0.7152, 0.0722))
}

/// The light cache: cell means of the irradiance deposited by camera-launched paths.
#[derive(Clone, Debug)]
pub struct LightCache {
    grid: Grid,
    /// A fixed hasher (rustc's Fx, not std's per-process random SipHash): the cells' iteration
    /// order, and so the float sums over them (`relative_error`), depend on the deposits alone;
    /// and a gather ray's lookup hashes its key in a few instructions.
    cells: FxHashMap<CellKey, CellSums>,
    /// The most cells it makes ([`MAX_CELLS`] but in tests).
    capacity: usize,
    deposits: u64,
    /// Deposits in cells it did not make, the table being full.
    dropped: u64,
    paths: u64,
}

impl LightCache {
    /// An empty cache of cells `cell` wide (world units, > 0).
    pub fn new(cell: f32) -> Self {
        Self::with_grid(Grid::Uniform {
            inv_cell: 1.0 / cell,
        })
    }

    /// An empty cache whose cells at a point are `fraction` (> 0) of `view`'s image height at
    /// the point's distance, rounded to a power of two (the nearest in log scale).
    pub fn for_view(view: CacheView, fraction: f32) -> Self {
        Self::with_grid(Grid::View { view, fraction })
    }

    fn with_grid(grid: Grid) -> Self {
        Self {
            grid,
            cells: FxHashMap::default(),
            capacity: MAX_CELLS,
            deposits: 0,
            dropped: 0,
            paths: 0,
        }
    }

    /// This cache holding at most `cells` cells (at most [`MAX_CELLS`]), as the full table
    /// behaves: for tests of that behaviour without millions of cells.
    #[cfg(test)]
    fn with_capacity(self, cells: usize) -> Self {
        Self {
            capacity: cells.min(MAX_CELLS),
            ..self
        }
    }

    /// Whether nothing was deposited yet.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The cell of `x`, as deposits and lookups file it.
    fn key(&self, x: &ShadingPoint) -> CellKey {
        self.grid.key(x.position, x.ns)
    }

    /// A tracer of this cache's paths: all it needs of the cache is the grid, so a renderer
    /// can trace the next paths while it adds the last ones.
    pub fn tracer(&self, (max_depth, rr_start): (u32, u32)) -> LightPathTracer {
        LightPathTracer {
            grid: self.grid,
            max_depth,
            rr_start,
        }
    }

    /// Adds paths' deposits, in the order given. The sums depend on that order, so the
    /// renderer adds paths in their index order whatever thread traced them. A deposit in a
    /// cell not held yet makes it, its point the cell's anchor; a later deposit there that does
    /// not see the anchor goes to the cell's hidden side (module docs, "Walls").
    /// `occluded(rays)` tells which of a batch of shadow rays are occluded (the renderer traces
    /// them in parallel); the return value is how many it was given.
    pub fn add_paths(
        &mut self,
        paths: &[Vec<LightDeposit>],
        occluded: &dyn Fn(&[Ray]) -> Vec<bool>,
    ) -> u64 {
        let deposits: Vec<&LightDeposit> = paths.iter().flatten().collect();
        self.paths += paths.len() as u64;
        self.deposits += deposits.len() as u64;
        // The anchors first, in order, and the test each other deposit takes.
        let mut tests = Vec::new();
        let test: Vec<Option<usize>> = deposits
            .iter()
            .map(|d| match self.cells.get(&d.key) {
                Some(c) => {
                    tests.push(c.anchor.ray_to(&d.at));
                    Some(tests.len() - 1)
                }
                None => {
                    if self.cells.len() < self.capacity {
                        let anchored = CellSums {
                            anchor: d.at,
                            ..CellSums::default()
                        };
                        self.cells.insert(d.key, anchored);
                    }
                    None
                }
            })
            .collect();
        let hidden = occluded(&tests);
        for (d, t) in deposits.into_iter().zip(test) {
            let key = if t.and_then(|i| hidden.get(i).copied()) == Some(true) {
                if let Some(c) = self.cells.get_mut(&d.key) {
                    c.split = true;
                }
                d.key.hidden()
            } else {
                d.key
            };
            let full = self.cells.len() >= self.capacity;
            let c = match self.cells.entry(key) {
                Entry::Occupied(e) => e.into_mut(),
                Entry::Vacant(e) if !full => e.insert(CellSums {
                    anchor: d.at,
                    ..CellSums::default()
                }),
                Entry::Vacant(_) => {
                    self.dropped += 1;
                    continue;
                }
            };
            let e = d.irradiance.as_dvec3();
            c.sum += e;
            for (sum, tail) in c.tails.iter_mut().zip(d.tails) {
                *sum += tail.as_dvec3();
            }
            c.squares += luminance(e).powi(2);
            c.count += 1;
        }
        tests.len() as u64
    }

    /// Joins the two sides of every split cell whose means differ by no more than
    /// [`SIDES_APART`] standard errors of their difference (in luminance), once every path is
    /// added: there the wall (or the column, or the chair leg) that split it changes nothing
    /// the cell's noise shows, and the joined cell is read without a shadow ray. A side too
    /// sparse to be used keeps the cell split (its readers path-trace rather than read the
    /// other side's light).
    pub fn settle(&mut self) {
        let hidden: Vec<(CellKey, CellSums)> = self
            .cells
            .iter()
            .filter(|(k, _)| k.side == 1)
            .map(|(k, c)| (*k, *c))
            .collect();
        for (key, h) in hidden {
            let seen = CellKey { side: 0, ..key };
            let Some(c) = self.cells.get_mut(&seen) else {
                continue;
            };
            if c.count < MIN_DEPOSITS || h.count < MIN_DEPOSITS || c.apart_from(&h) {
                continue;
            }
            c.sum += h.sum;
            for (sum, tail) in c.tails.iter_mut().zip(h.tails) {
                *sum += tail;
            }
            c.squares += h.squares;
            c.count += h.count;
            c.split = false;
            self.cells.remove(&key);
        }
    }

    /// The mean irradiance deposited in `x`'s cell, if it holds at least [`MIN_DEPOSITS`]: on
    /// the side of a split cell that `x` belongs to (one shadow ray, counted in `rays`).
    pub fn irradiance(
        &self,
        scene: &Scene,
        x: &ShadingPoint,
        rays: &mut RayCounter,
    ) -> Option<Vec3> {
        self.side_of(scene, &Seen::of(x), self.key(x), rays)?
            .mean(0)
    }

    /// The side of cell `key` that `at` belongs to: the anchor's, unless the cell is split and
    /// `at` does not see the anchor (one shadow ray, counted in `rays`).
    fn side_of(
        &self,
        scene: &Scene,
        at: &Seen,
        key: CellKey,
        rays: &mut RayCounter,
    ) -> Option<&CellSums> {
        let c = self.cells.get(&key)?;
        if !c.split || sees(scene, at, c, rays) {
            Some(c)
        } else {
            self.cells.get(&key.hidden())
        }
    }

    /// The cell mean read at x moved by (`u` − ½)·[`FILTER_CELLS`] cells along x's tangents,
    /// or x's own cell's where the moved point's cell is too sparse: over uniform `u`, the
    /// cell means filtered by a box [`FILTER_CELLS`] cells wide on x's tangent plane
    /// (stochastic filtering). A lobe's samples near one point then read several cells rather
    /// than one, so a cell's frozen noise, which all of them would share, averages down with
    /// the samples (to 5/12 of its variance per axis for a box two cells wide), and the mean
    /// read is the cell means' smooth interpolation rather than a staircase. The box shrinks
    /// with the cells, so what it blurs vanishes as they do. A neighbouring cell counts only
    /// where `x` sees its anchor (or its hidden side's): the filter does not reach through a
    /// wall (a shadow ray or two, counted in `rays`).
    ///
    /// For a point `deeper` reflections further from the camera than a gather ray's hit, the
    /// means leave out the light of as many reflections at the end of each deposit's window, so
    /// that what the point reflects obeys the depth limit ([`DEEPER_READS`] at most: `None`
    /// beyond).
    pub fn irradiance_filtered(
        &self,
        scene: &Scene,
        x: &ShadingPoint,
        u: Vec2,
        deeper: usize,
        rays: &mut RayCounter,
    ) -> Option<Vec3> {
        let frame = Frame::from_normal(x.ns);
        let d = (u - Vec2::splat(0.5)) * (FILTER_CELLS * self.grid.width(x.position));
        let moved = self
            .grid
            .key(x.position + frame.s * d.x + frame.t * d.y, x.ns);
        let own = self.key(x);
        let at = Seen::of(x);
        if moved != own
            && let Some(c) = self.cells.get(&moved)
        {
            let seen = if sees(scene, &at, c, rays) {
                Some(c)
            } else if c.split {
                self.cells
                    .get(&moved.hidden())
                    .filter(|h| sees(scene, &at, h, rays))
            } else {
                None
            };
            if let Some(mean) = seen.and_then(|c| c.mean(deeper)) {
                return Some(mean);
            }
        }
        self.side_of(scene, &at, own, rays)?.mean(deeper)
    }

    /// The relative standard error of the used cells' means (luminance), their root mean
    /// square weighted by deposits (a cell's deposits stand for how often rays reach it).
    pub fn relative_error(&self) -> f64 {
        let (mut weighted, mut deposits) = (0.0, 0.0);
        for c in self.cells.values().filter(|c| c.count >= MIN_DEPOSITS) {
            weighted += f64::from(c.count) * c.relative_variance();
            deposits += f64::from(c.count);
        }
        if deposits > 0.0 {
            (weighted / deposits).sqrt()
        } else {
            0.0
        }
    }

    /// Whether the cells' [`relative_error`](Self::relative_error) is at most `target` and
    /// the cells in use hold at least [`CONVERGED_SHARE`] of the deposits.
    pub fn converged(&self, target: f64) -> bool {
        let used: u64 = self
            .cells
            .values()
            .filter(|c| c.count >= MIN_DEPOSITS)
            .map(|c| u64::from(c.count))
            .sum();
        self.deposits > 0
            && used as f64 >= CONVERGED_SHARE * self.deposits as f64
            && self.relative_error() <= target
    }

    /// Paths added, deposits, cells, and cells holding at least [`MIN_DEPOSITS`].
    pub fn counts(&self) -> LightCacheCounts {
        LightCacheCounts {
            paths: self.paths,
            deposits: self.deposits,
            dropped: self.dropped,
            cells: self.cells.len() as u64,
            used_cells: self
                .cells
                .values()
                .filter(|c| c.count >= MIN_DEPOSITS)
                .count() as u64,
            split: self.cells.keys().filter(|k| k.side == 1).count() as u64,
        }
    }
}

/// What a light cache holds (see [`LightCache::counts`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LightCacheCounts {
    /// Paths traced.
    pub paths: u64,
    /// Vertices deposited.
    pub deposits: u64,
    /// Of those, the deposits in cells the full table did not make ([`MAX_CELLS`]).
    pub dropped: u64,
    /// Cells with a deposit.
    pub cells: u64,
    /// Cells with enough deposits to be used ([`MIN_DEPOSITS`]).
    pub used_cells: u64,
    /// Of the cells, those that are the hidden side of a split cell (module docs, "Walls").
    pub split: u64,
}

/// The most vertices of one path that deposit (its first ones): a path's deposits, and the work
/// of summing them, stay bounded whatever `max_depth` is. Which vertices deposit is fixed before
/// the path is traced, so the choice biases nothing.
pub const DEPOSITS_PER_PATH: usize = 16;

/// One depositing vertex's estimate while the path goes on.
struct Slot {
    key: CellKey,
    at: Seen,
    /// The parts of `irradiance` from the last vertices of the window ([`LightDeposit`]).
    tails: [Vec3; DEEPER_READS],
    /// What turns radiance arriving at the current vertex along its drawn direction into the
    /// slot's irradiance: cos θ/(pdf·q) of the slot's own draw times f·cos θ/(pdf·q) of each
    /// later vertex's draw up to the current one.
    factor: Vec3,
    irradiance: Vec3,
    /// Black vertices reflect nothing, so no gather reads their cell for them: not deposited
    /// (their walk ends there, so their estimate would lack its indirect part).
    deposit: bool,
}

impl Slot {
    /// Adds light `v` that the vertex `before_last` vertices before the window's last brought.
    fn take(&mut self, before_last: usize, v: Vec3) {
        self.irradiance += v;
        if let Some(tail) = self.tails.get_mut(before_last) {
            *tail += v;
        }
    }
}

/// What tracing a light cache's paths needs ([`LightCache::tracer`]): its cells' size and the
/// path tracer's depth limits. Holds no deposits, so it can be copied to the threads that trace
/// while the cache itself takes earlier paths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPathTracer {
    grid: Grid,
    max_depth: u32,
    rr_start: u32,
}

impl LightPathTracer {
    /// One path from the camera ray `ray` (`trace_light_path`).
    pub fn trace(
        &self,
        scene: &Scene,
        ray: &Ray,
        key: SampleKey,
        rays: &mut RayCounter,
    ) -> Vec<LightDeposit> {
        trace_light_path(
            &self.grid,
            scene,
            ray,
            key,
            (self.max_depth, self.rr_start),
            rays,
        )
    }
}

/// Follows a camera ray through the scene by BSDF-sampled bounces (cosine-weighted on
/// Lambertian surfaces, `Bsdf::sample_defensive` on glossy ones; Russian roulette on the
/// albedo, at least [`MIN_CONTINUATION`], from vertex `rr_start` on) and returns the estimate of
/// the irradiance at each of its first [`DEPOSITS_PER_PATH`] vertices, filed under its cell
/// of `grid`. All randomness comes from `key`, so the deposits do not depend on the thread that
/// traces them.
///
/// The estimate at vertex k unrolls E(v) = d(v) + (cos θ/(pdf·q))(v)·R(v₊₁), d(v) the light
/// arriving at v with no reflection beyond it (its light sample's irradiance and the emission
/// its drawn ray finds, each weighted by the power heuristic, and the background B through the
/// drawn direction's weight when the path left the scene from v), and R(v) the
/// radiance v reflects back along the path, R(v) = f·d-like terms + (f cos θ/(pdf·q))(v)·R(v₊₁):
/// on a Lambertian path the familiar E(v) = d(v) + (ρ(v₊₁)/q(v))·E(v₊₁). A
/// gather ray's hit is the second reflection from the camera at least, so what it reflects may
/// reflect at most `max_depth` − 2 more times: every vertex's estimate takes the d of itself
/// and of the `max_depth` − 2 vertices after it, whatever its own depth on its path, so the
/// cache obeys the path tracer's depth limit. The walk goes no further than the last depositing
/// vertex's window needs.
fn trace_light_path(
    grid: &Grid,
    scene: &Scene,
    ray: &Ray,
    key: SampleKey,
    (max_depth, rr_start): (u32, u32),
    rays: &mut RayCounter,
) -> Vec<LightDeposit> {
    let Some(after) = max_depth.checked_sub(2) else {
        return Vec::new();
    };
    let after = after as usize;
    // Vertex j counts for slot k when k ≤ j ≤ k + after.
    let cap = (DEPOSITS_PER_PATH - 1).saturating_add(after);
    let geometry = scene.geometry();
    let mut dims = Dimensions::new(key);
    let mut slots: Vec<Slot> = Vec::with_capacity(DEPOSITS_PER_PATH);
    // Adds light arriving at vertex j along the direction drawn there, with no further
    // reflection, to every slot whose window holds j (through the slot's factor, which holds
    // that draw's weight).
    let add = |slots: &mut Vec<Slot>, j: usize, light: Vec3| {
        for (k, slot) in slots.iter_mut().enumerate() {
            if j - k <= after {
                let v = slot.factor * light;
                slot.take(after - (j - k), v);
            }
        }
    };
    let mut ray = *ray;
    let mut j = 0usize;
    // The last vertex, whose drawn ray is `ray`, with its draw's density and light samples,
    // for weighting the emission the ray finds.
    let mut last: Option<(ShadingPoint, f32, f32)> = None;
    loop {
        rays.closest += 1;
        let hit = scene.intersect(&ray);
        // Inside an absorbing volume, the segment keeps e^(−σd) of the light it carries back.
        if let Some((x, _, _)) = &last {
            let tr = scene.segment_transmittance(x, ray.direction, hit.map(|h| h.t));
            if tr != Vec3::ONE {
                for slot in &mut slots {
                    slot.factor *= tr;
                }
            }
        }
        let Some(hit) = hit else {
            // The background's light arrives at vertex j − 1 along its drawn direction.
            if j > 0 {
                add(&mut slots, j - 1, scene.background());
            }
            break;
        };
        let surface = geometry.surface(&ray, &hit);
        // Emission the last vertex's draw found: light arriving there, weighted against its
        // light sample by the power heuristic (as the path tracer weighs them).
        if let Some((from, pdf_draw, light_samples)) = &last {
            let (pdf_draw, light_samples) = (*pdf_draw, *light_samples);
            let le = scene.emitted_at(&surface, -ray.direction);
            if le != Vec3::ZERO {
                let ray = (from.position, ray.direction);
                let w = emission_weight(scene, &surface, ray, pdf_draw, light_samples);
                add(&mut slots, j - 1, le * w);
            }
        }
        // Past every window: this ray was traced only to see whether vertex `cap` escaped.
        if j > cap {
            break;
        }
        let x = scene.shading_point(&surface, -ray.direction);
        let bsdf = Bsdf::at(scene, &x);
        // A refracting vertex (a volume's boundary) is crossed by BSDF sampling alone, and
        // deposits nothing: its diffuse part, if any, path-traces where its cell is sparse.
        let refracts = bsdf.refracts();
        if j < DEPOSITS_PER_PATH {
            slots.push(Slot {
                key: grid.key(x.position, x.ns),
                at: Seen::of(&x),
                tails: [Vec3::ZERO; DEEPER_READS],
                factor: Vec3::ZERO,
                irradiance: Vec3::ZERO,
                // Black vertices reflect nothing (their walk ends there, so their estimate
                // would lack its indirect part).
                deposit: !bsdf.is_black() && !refracts,
            });
        }
        // One light sample, weighted against this vertex's draw by the power heuristic (a
        // punctual light, which no draw finds, with weight 1): its irradiance w·Le·cos θ / pdf
        // for this vertex's own slot, and the radiance f·w·Le·cos θ / pdf it reflects back
        // along the path for the earlier slots.
        if let Some(a) = sample_light(scene, &x, &mut dims, rays) {
            let w = if a.delta {
                1.0
            } else if refracts {
                power_heuristic(a.pdf, bsdf.pdf(a.wi))
            } else {
                power_heuristic(a.pdf, bsdf.pdf_defensive(a.wi))
            };
            let irradiance = a.le * (w * a.cos_surface / a.pdf);
            let reflected = bsdf.eval(a.wi) * irradiance;
            for (k, slot) in slots.iter_mut().enumerate() {
                if k == j {
                    slot.take(after, irradiance);
                } else if j - k <= after {
                    let v = slot.factor * reflected;
                    slot.take(after - (j - k), v);
                }
            }
        }
        // Russian roulette. Every vertex deposits its own estimate, in which the rest of the
        // path counts at full weight (the BSDF multiplies it only for the vertices before), so
        // the probability of going on is never below MIN_CONTINUATION: a dark wall (ρ = 10⁻⁶)
        // would otherwise almost never carry the light beyond it to its own deposit, an
        // unbiased but so heavy-tailed estimate that its finite means read low.
        let q = if j as u64 + 1 >= u64::from(rr_start) {
            bsdf.albedo_estimate()
                .max_element()
                .clamp(MIN_CONTINUATION, 1.0)
        } else {
            1.0
        };
        let u_rr = dims.next_1d();
        // Defensive on glossy vertices: half the draws cosine-distributed, so that the
        // irradiance weight cos θ/pdf stays bounded under a narrow lobe; a refracting vertex,
        // which deposits nothing, by its BSDF alone (cosine draws would not cross it).
        let draw = if refracts {
            bsdf.draw(&mut dims)
        } else {
            bsdf.sample_defensive(dims.next_2d())
        };
        // A direction below the geometric surface carries no light (as in the path tracer),
        // unless it refracts through it.
        let Some(d) = draw.filter(|d| {
            !bsdf.is_black() && u_rr < q && d.leaves(x.ng) && d.cos > 0.0 && d.pdf > 0.0
        }) else {
            break;
        };
        // The drawn direction's weights: cos θ / (pdf·q) turns the radiance arriving along it
        // into this vertex's irradiance (π/q on a Lambertian vertex); f·cos θ / (pdf·q) carries
        // it, reflected here, back to the earlier vertices (ρ/q on a Lambertian one).
        for (k, slot) in slots.iter_mut().enumerate() {
            if k == j {
                slot.factor = Vec3::splat(d.cos / (d.pdf * q));
            } else if j - k <= after {
                slot.factor *= d.weight / q;
            }
        }
        last = Some((x, d.pdf, d.light_samples(1.0)));
        ray = Ray::spawn(x.position, x.ng, d.wi);
        j += 1;
    }
    slots
        .into_iter()
        .filter(|s| s.deposit && s.irradiance.is_finite())
        .map(|s| LightDeposit {
            key: s.key,
            at: s.at,
            irradiance: s.irradiance,
            tails: s.tails,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Material;
    use crate::tests::{assert_close, first_surface, furnace, scene};
    use irr_sampling::sample_uniform_sphere;
    use std::f32::consts::PI;

    /// A deposit of irradiance `e` (grey) in cell `key`, from the point `p` of a floor seen
    /// from above.
    fn on_floor(key: CellKey, p: Vec3, e: f32) -> LightDeposit {
        LightDeposit {
            key,
            at: Seen {
                position: p,
                front: Vec3::Y,
            },
            irradiance: Vec3::splat(e),
            tails: [Vec3::ZERO; DEEPER_READS],
        }
    }

    /// Adds one path's deposits, every one of them seeing its cell's anchor.
    fn add(cache: &mut LightCache, deposits: &[LightDeposit]) {
        let none = |rays: &[Ray]| vec![false; rays.len()];
        cache.add_paths(&[deposits.to_vec()], &none);
    }

    /// A scene with nothing within 100 of the origin: every point there sees every other.
    fn open() -> Scene {
        let far = crate::tests::polygon(Vec3::new(0.0, -100.0, 0.0), 0.1, 3, 1.0, 0);
        scene(&[far], vec![Material::diffuse(Vec3::splat(0.5))])
    }

    /// A point of a floor (normal +Y) seen from above.
    fn floor_point(position: Vec3) -> ShadingPoint {
        ShadingPoint {
            position,
            ng: Vec3::Y,
            ns: Vec3::Y,
            triangle: 0,
            b1: 0.0,
            b2: 0.0,
            wo: Vec3::Y,
        }
    }

    /// A deposit read m reflections deeper (its window's last m vertices' parts left out) is
    /// the deposit a depth limit m lower gives, from the same random numbers: the walk's prefix
    /// is the same, only the windows shrink. Tolerance: f32 rounding of sums of at most 64
    /// terms of one sign, 64·2⁻²⁴ relative, doubled.
    #[test]
    fn a_deeper_read_is_a_lower_depth_limit() {
        let scene = furnace(Vec3::ZERO, 0.7, 1.0);
        let inv_cell = 4.0;
        for i in 0..200u64 {
            let key = SampleKey::new(8, i, 0);
            let d = sample_uniform_sphere(SampleKey::new(9, i, 0).uniform_2d(0));
            let trace = |max_depth| {
                let ray = Ray::new(Vec3::ZERO, d);
                let mut rays = RayCounter::default();
                trace_light_path(
                    &Grid::Uniform { inv_cell },
                    &scene,
                    &ray,
                    key,
                    (max_depth, 3),
                    &mut rays,
                )
            };
            let full = trace(8);
            for m in 1..=DEEPER_READS {
                let shorter = trace(8 - m as u32);
                assert_eq!(full.len(), shorter.len(), "path {i}, {m} deeper");
                for (a, b) in full.iter().zip(&shorter) {
                    let left = a.irradiance - a.tails[..m].iter().sum::<Vec3>();
                    let bound = 2.0 * 64.0 * f32::EPSILON / 2.0 * a.irradiance.max_element();
                    assert!(
                        (left - b.irradiance).abs().max_element() <= bound,
                        "path {i}, {m} deeper: {left} vs {}",
                        b.irradiance
                    );
                }
            }
        }
    }

    /// The filtered read of a point at a cell's centre on a floor, over a fine grid of `u`,
    /// weighs the cells of its tangent plane (the floor's tangents are the grid's x and z
    /// axes) by a box two cells wide: ¼, ½, ¼ along each axis, and never a cell above or
    /// below. Cell (a, b) holds 1 + a + 3b + 9ab + 5a², whose mean under those weights is
    /// 1 + 5·½ = 3.5 (a box offset from the point moves the odd terms, one of another width the
    /// a² term's ½); the layers above and below hold 1000.
    /// Tolerance: the midpoint grid of 64² points puts exactly 16, 32, 16 of 64 in each
    /// column's thirds (the offsets −1…1 cells cross cell borders at ±½), so only f32 sums'
    /// rounding remains.
    #[test]
    fn a_filtered_read_weighs_the_neighbouring_cells_by_a_box() {
        let inv = 4.0;
        let mut cache = LightCache::new(1.0 / inv);
        let centre = Vec3::new(0.125, 0.01, 0.125);
        let value = |a: i32, b: i32| (1 + a + 3 * b + 9 * a * b + 5 * a * a) as f32;
        for a in -2..=2 {
            for b in -2..=2 {
                for (y, v) in [(0.01, value(a, b)), (0.26, 1000.0), (-0.24, 1000.0)] {
                    let p = Vec3::new(centre.x + a as f32 / inv, y, centre.z + b as f32 / inv);
                    let key = CellKey::of(p, Vec3::Y, (0, inv));
                    for _ in 0..MIN_DEPOSITS {
                        add(&mut cache, &[on_floor(key, p, v)]);
                    }
                }
            }
        }
        let x = floor_point(centre);
        let open = open();
        let n = 64;
        let mut sum = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                let e = cache
                    .irradiance_filtered(&open, &x, u, 0, &mut RayCounter::default())
                    .unwrap_or_else(|| panic!("cells around the point"));
                assert!(e.x < 500.0, "u {u}: a cell of another layer");
                sum += f64::from(e.x);
            }
        }
        let mean = sum / f64::from(n * n);
        assert!((mean - 3.5).abs() < 1e-6, "mean read {mean}");
        // An empty neighbourhood falls back to the point's own cell.
        let lone = floor_point(Vec3::new(10.1, 0.01, 10.1));
        let key = cache.key(&lone);
        for _ in 0..MIN_DEPOSITS {
            add(&mut cache, &[on_floor(key, lone.position, 7.0)]);
        }
        assert_eq!(
            cache.irradiance_filtered(
                &open,
                &lone,
                Vec2::new(0.01, 0.99),
                0,
                &mut RayCounter::default()
            ),
            Some(Vec3::splat(7.0))
        );
        assert_eq!(
            cache.irradiance_filtered(
                &open,
                &lone,
                Vec2::ZERO,
                DEEPER_READS + 1,
                &mut RayCounter::default()
            ),
            None
        );
    }

    /// Every deposit is an unbiased estimate of the irradiance at its vertex, with the depth
    /// limit: in a white furnace (a closed sphere that emits Le from both faces and reflects ρ)
    /// the radiance arriving after at most L further reflections is Le·Σᵢ₌₀ᴸ ρⁱ from every
    /// direction, so E = π·Le·Σᵢ₌₀ᴸ ρⁱ at every point, with L = `max_depth` − 2. The k-th
    /// deposits of independent paths are independent (given that the path reached vertex k, its
    /// future does not depend on its past), so their mean is tested against E within 6
    /// standard errors (the crate's known-answer tolerance, `crate::tests`), for every vertex
    /// that deposits (those that 1000 paths or more reached), with Russian roulette from the
    /// second vertex (q = ρ) and from the fifth (the default; a depth limit of 3 gives each
    /// vertex a window of one further reflection, and the walk goes on past the last window).
    #[test]
    fn a_deposit_is_the_irradiance_in_a_furnace() {
        let (rho, le) = (0.6f32, 1.0f32);
        let scene = furnace(Vec3::ZERO, rho, le);
        let cache = LightCache::new(0.25);
        for (max_depth, rr_start) in [(3u32, 5u32), (4, 64), (64, 2)] {
            let limit = max_depth as i32 - 2;
            let expected =
                f64::from(PI * le) * (0..=limit).map(|i| f64::from(rho).powi(i)).sum::<f64>();
            let n = 20_000u64;
            let paths: Vec<Vec<LightDeposit>> = (0..n)
                .map(|i| {
                    let key = SampleKey::new(3, i, 0);
                    let d = sample_uniform_sphere(SampleKey::new(4, i, 0).uniform_2d(0));
                    let mut rays = RayCounter::default();
                    trace_light_path(
                        &cache.grid,
                        &scene,
                        &Ray::new(Vec3::ZERO, d),
                        key,
                        (max_depth, rr_start),
                        &mut rays,
                    )
                })
                .collect();
            for k in 0..DEPOSITS_PER_PATH {
                let values: Vec<f64> = paths
                    .iter()
                    .filter_map(|p| p.get(k).map(|d| f64::from(d.irradiance.x)))
                    .collect();
                let m = values.len() as f64;
                if k < 3 {
                    assert!(m > 1000.0, "depth {max_depth}, vertex {k}: {m} deposits");
                } else if m < 1000.0 {
                    // Too few paths lived this long for the normal approximation.
                    continue;
                }
                let mean = values.iter().sum::<f64>() / m;
                let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (m - 1.0);
                assert_close(
                    &format!("depth {max_depth}, vertex {k}"),
                    (mean, (var / m).sqrt()),
                    expected,
                );
            }
        }
    }

    /// A path whose limit allows no light after a gather's hit (`max_depth` < 2: the cache has
    /// no gathers then) deposits nothing. Without Russian roulette in the furnace (no escape,
    /// no black surface) a path of `max_depth` 3 deposits its first DEPOSITS_PER_PATH vertices
    /// and walks one vertex past the last one's window (one further reflection), then traces one
    /// more ray to see whether that vertex escaped: 16 + 1 vertices with a light sample each,
    /// 16 + 2 closest-hit rays.
    #[test]
    fn a_path_walks_as_far_as_its_last_window() {
        let scene = furnace(Vec3::ZERO, 0.5, 1.0);
        let cache = LightCache::new(0.25);
        let ray = Ray::new(Vec3::ZERO, Vec3::Y);
        let key = SampleKey::new(1, 2, 3);
        let mut rays = RayCounter::default();
        assert!(trace_light_path(&cache.grid, &scene, &ray, key, (1, 64), &mut rays).is_empty());
        assert_eq!(rays, RayCounter::default());
        let deposits = trace_light_path(&cache.grid, &scene, &ray, key, (3, 64), &mut rays);
        assert_eq!(deposits.len(), DEPOSITS_PER_PATH);
        assert_eq!(rays.shadow, DEPOSITS_PER_PATH as u64 + 1);
        assert_eq!(rays.closest, DEPOSITS_PER_PATH as u64 + 2);
    }

    /// A deposit is what a gather ray's path-traced continuation estimates, divided by ρ/π, in
    /// an open scene where paths escape to a background B (the π·B/q term) after bouncing
    /// between a floor and a reflective canopy lit by a disk: at a fixed floor point, the mean
    /// of (ρ/π)·E over first deposits against the mean of `PathTracer::reflected` with the
    /// gather's depth limit (`max_depth` − 1), for depths 2, 3 and 64. The two means are
    /// independent estimates of one value: 6 standard errors of their difference (the crate's
    /// tolerance).
    #[test]
    fn a_deposit_is_what_a_continuation_estimates() {
        let scene = floor_under_canopy(None);
        let ray = Ray::new(
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.3, -1.0, 0.2).normalize(),
        );
        deposits_match_continuations(&scene, &ray, &[2, 3, 64]);
    }

    /// The same where the disk's light reaches the floor point only through a sphere of glass
    /// whose volume absorbs (σ = 2 per unit length, e^(−1.8) across its diameter): paths that
    /// cross it keep e^(−σd) over each segment inside, in the light cache as in the path tracer.
    #[test]
    fn a_deposit_through_absorbing_glass_is_what_a_continuation_estimates() {
        let glass = Material {
            transmission: 1.0,
            thin_walled: false,
            attenuation: Vec3::splat(2.0),
            ..Material::metallic_roughness(Vec3::ONE, 0.0, 0.0)
        };
        let scene = floor_under_canopy(Some(glass));
        let ray = Ray::new(
            Vec3::new(0.0, 0.4, 0.0),
            Vec3::new(0.1, -1.0, 0.1).normalize(),
        );
        deposits_match_continuations(&scene, &ray, &[4, 64]);
    }

    /// A floor (ρ 0.5) under a canopy (ρ 0.8, 2 up) and a disk emitter (Le 5) below it, in a
    /// background of 0.4; with `glass`, a sphere of it (radius 0.45, centred 0.9 up under the
    /// disk) hides the disk from the floor below.
    fn floor_under_canopy(glass: Option<Material>) -> Scene {
        use crate::tests::{icosphere, polygon};
        let mut meshes = vec![
            polygon(Vec3::ZERO, 2.0, 24, 1.0, 0),
            polygon(Vec3::new(0.0, 2.0, 0.0), 1.2, 24, -1.0, 1),
        ];
        let mut materials = vec![
            Material::diffuse(Vec3::splat(0.5)),
            Material::diffuse(Vec3::splat(0.8)),
            Material::emitter(Vec3::splat(5.0)),
        ];
        match glass {
            None => meshes.push(polygon(Vec3::new(0.4, 1.5, 0.0), 0.3, 16, -1.0, 2)),
            Some(glass) => {
                meshes.push(polygon(Vec3::new(0.0, 1.5, 0.0), 0.3, 16, -1.0, 2));
                meshes.push(icosphere(Vec3::new(0.0, 0.9, 0.0), 0.45, 2, 3));
                materials.push(glass);
            }
        }
        scene(&meshes, materials)
            .with_background(Vec3::splat(0.4))
            .unwrap_or_else(|e| panic!("{e}"))
    }

    /// At the floor point `ray` hits: the mean of (ρ/π)·E over 40000 first deposits against the
    /// mean of `PathTracer::reflected` with the gather's depth limit (`max_depth` − 1), for
    /// each of `depths`, within 6 standard errors of their difference.
    fn deposits_match_continuations(scene: &Scene, ray: &Ray, depths: &[u32]) {
        use crate::{PathSettings, PathTracer};
        let cache = LightCache::new(0.25);
        let hit = first_surface(scene, ray);
        let n = 40_000u32;
        for &max_depth in depths {
            let cached = crate::tests::estimate(n, |i| {
                let key = SampleKey::new(7, u64::from(i), 0);
                let d = trace_light_path(
                    &cache.grid,
                    scene,
                    ray,
                    key,
                    (max_depth, 5),
                    &mut RayCounter::default(),
                );
                d.first().map_or(Vec3::ZERO, |d| 0.5 / PI * d.irradiance)
            });
            let tracer = PathTracer::new(PathSettings {
                max_depth: max_depth - 1,
                ..PathSettings::default()
            });
            let traced = crate::tests::estimate(n, |i| {
                let mut dims = Dimensions::new(SampleKey::new(8, u64::from(i), 0));
                let r = tracer.reflected(
                    scene,
                    &hit,
                    -ray.direction,
                    &mut dims,
                    &mut RayCounter::default(),
                );
                r.direct + r.indirect
            });
            let band = 6.0 * (cached.1.powi(2) + traced.1.powi(2)).sqrt();
            assert!(
                (cached.0 - traced.0).abs() < band,
                "depth {max_depth}: light cache {:.5} ± {:.1e}, path tracer {:.5} ± {:.1e}",
                cached.0,
                cached.1,
                traced.0,
                traced.1
            );
        }
    }

    /// The light arriving at a vertex with no further reflection is bounded where an emitter
    /// meets the surface: a floor (ρ 0.5) and an emitting wall (Le 1, one-sided, facing +x)
    /// standing on it, seen at points 10⁻⁴ to 10⁻² from the wall's foot, where one light sample
    /// alone has unbounded weight (Le·cos θ·cos θ_l/(p_A·r²), r → 0). With a depth limit of 2
    /// (no reflection after a gather's hit) a deposit is that light alone: the light sample
    /// weighted by the power heuristic, Le·cos θ·p_l/(p_l² + p_b²) ≤ Le·cos θ/(2·p_b) = π·Le/2
    /// (p_b = cos θ/π), plus the emission its own draw finds, (π/q)·Le·w ≤ π·Le (no Russian
    /// roulette here, q = 1): every deposit at most 3π/2·Le, up to f32 rounding (1e-5).
    #[test]
    fn light_next_to_an_emitter_is_bounded() {
        use crate::tests::polygon;
        use irr_geometry::TriangleMesh;
        let wall = TriangleMesh {
            positions: vec![
                Vec3::new(0.0, 0.0, -0.5),
                Vec3::new(0.0, 1.0, -0.5),
                Vec3::new(0.0, 1.0, 0.5),
                Vec3::new(0.0, 0.0, 0.5),
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            normals: None,
            material_ids: vec![1, 1],
        };
        let scene = scene(
            &[polygon(Vec3::ZERO, 2.0, 24, 1.0, 0), wall],
            vec![
                Material::diffuse(Vec3::splat(0.5)),
                Material::emitter(Vec3::ONE),
            ],
        );
        let cache = LightCache::new(0.25);
        let bound = 1.5 * PI * (1.0 + 1e-5);
        let mut deposits = 0;
        for i in 0..4000u64 {
            let u = SampleKey::new(11, i, 0).uniform_2d(0);
            let x = 10f32.powf(-4.0 + 2.0 * u.x);
            let ray = Ray::new(Vec3::new(x, 0.5, u.y - 0.5), Vec3::NEG_Y);
            let key = SampleKey::new(12, i, 0);
            for d in trace_light_path(
                &cache.grid,
                &scene,
                &ray,
                key,
                (2, 64),
                &mut RayCounter::default(),
            ) {
                deposits += 1;
                assert!(
                    d.irradiance.max_element() <= bound,
                    "{} at {x:e} from the wall",
                    d.irradiance
                );
            }
        }
        // Every path deposits at least its first vertex (most then leave the open scene).
        assert!(deposits >= 4000, "{deposits} deposits");
    }

    /// Cells: the same cell for points within a cell that face the same way, different cells
    /// for the two faces of a wall and for a floor and the wall beside it; the mean of a cell is
    /// used from MIN_DEPOSITS deposits on, and is the mean of its deposits.
    #[test]
    fn cells_keep_faces_apart_and_average_their_deposits() {
        let inv = 4.0;
        let a = CellKey::of(Vec3::new(0.1, 0.0, 0.1), Vec3::Y, (0, inv));
        assert_eq!(a, CellKey::of(Vec3::new(0.2, 0.01, 0.2), Vec3::Y, (0, inv)));
        assert_ne!(a, CellKey::of(Vec3::new(0.1, 0.0, 0.1), -Vec3::Y, (0, inv)));
        assert_ne!(a, CellKey::of(Vec3::new(0.1, 0.0, 0.1), Vec3::X, (0, inv)));
        assert_ne!(a, CellKey::of(Vec3::new(0.3, 0.0, 0.1), Vec3::Y, (0, inv)));
        let mut cache = LightCache::new(0.25);
        let x = floor_point(Vec3::new(0.1, 0.0, 0.1));
        for i in 0..MIN_DEPOSITS {
            assert_eq!(
                cache.irradiance(&open(), &x, &mut RayCounter::default()),
                None,
                "{i} deposits"
            );
            let key = cache.key(&x);
            add(&mut cache, &[on_floor(key, x.position, i as f32)]);
        }
        let mean = (MIN_DEPOSITS - 1) as f32 / 2.0;
        assert_eq!(
            cache.irradiance(&open(), &x, &mut RayCounter::default()),
            Some(Vec3::splat(mean))
        );
        let counts = cache.counts();
        assert_eq!(
            counts,
            LightCacheCounts {
                paths: u64::from(MIN_DEPOSITS),
                deposits: u64::from(MIN_DEPOSITS),
                dropped: 0,
                cells: 1,
                used_cells: 1,
                split: 0,
            }
        );
    }

    /// A view grid's cells: at distance d from the view (image height d at unit distance
    /// here), the width is the power of two nearest in log scale to `fraction`·d, i.e.
    /// 2^⌊log₂(√2·d/64)⌋ for 1/64: √2·0.7/64 = 0.0155 gives 2⁻⁷, √2/64 = 0.0221 gives 2⁻⁶,
    /// √2·1.5/64 = 0.0331 and √2·2/64 = 0.0442 give 2⁻⁵. Exact: the width comes from exponent
    /// bits, with no rounding to tolerate.
    #[test]
    fn view_cells_are_a_fraction_of_the_image_at_their_distance() {
        let view = CacheView {
            position: Vec3::new(0.25, -3.0, 7.5),
            height_per_distance: 1.0,
            height: 0.0,
        };
        let grid = Grid::View {
            view,
            fraction: 1.0 / 64.0,
        };
        for (d, width) in [
            (0.7, 1.0 / 128.0),
            (1.0, 1.0 / 64.0),
            (1.5, 1.0 / 32.0),
            (2.0, 1.0 / 32.0),
        ] {
            let p = view.position + Vec3::new(0.0, 0.0, d);
            assert_eq!(grid.width(p), width, "at {d}");
        }
        // Nearer than any width the point's coordinates can tell apart: the finest level,
        // 2⁻²⁰ of the largest coordinate (7.5 here: 2² · 2⁻²⁰).
        assert_eq!(grid.width(view.position), 4.0 / 1_048_576.0);
        // As far as a scene may reach (irr-scene's MAX_COORDINATE, 10¹⁸), cells stay within an
        // i32's coordinates.
        let far = Vec3::splat(1e18);
        let key = grid.key(far, Vec3::Y);
        assert!(key.x.abs() < 1 << 21 && key.x != 0, "{key:?}");
    }

    proptest::proptest! {
        /// A scene and its view scaled by 2^k have the same cells, k levels up: the same
        /// coordinates and buckets (every step is exact under a power-of-two scale: products,
        /// the distance's square root, the exponent bits, the floor), so a cache is the same
        /// at any scale.
        #[test]
        fn view_cells_scale_with_the_scene(
            (x, y, z) in (-50.0f32..50.0, -50.0f32..50.0, -50.0f32..50.0),
            k in -20i32..20,
        ) {
            let view = CacheView {
                position: Vec3::new(0.5, 1.25, -2.0),
                height_per_distance: 0.75,
                height: 0.0,
            };
            let scale = 2f32.powi(k);
            let scaled = CacheView {
                position: view.position * scale,
                ..view
            };
            let a = Grid::View { view, fraction: 1.0 / 48.0 };
            let b = Grid::View { view: scaled, fraction: 1.0 / 48.0 };
            let p = Vec3::new(x, y, z);
            let (ka, kb) = (a.key(p, Vec3::X), b.key(p * scale, Vec3::X));
            proptest::prop_assert_eq!((ka.x, ka.y, ka.z, ka.bucket), (kb.x, kb.y, kb.z, kb.bucket));
            proptest::prop_assert_eq!(i32::from(ka.level) + k, i32::from(kb.level));
        }
    }

    /// The bytes a cell takes, as the module's memory bound states them: a key of 16 bytes
    /// (level, three i32 coordinates, bucket and side, padded to 4) and sums of 112 (three
    /// DVec3s of 24, the sum and its two tails, an f64, a u32, the anchor's two Vec3s of 12 and
    /// the split flag, padded to 8); the table's bound, 2²² slots of 129 bytes, is 516 MiB; and
    /// `MAX_CELLS` is what hashbrown holds in 2²² slots (7/8 of them) before it doubles: a table
    /// of `MAX_CELLS` cells has 2²² slots.
    #[test]
    fn a_cell_takes_128_bytes_and_the_table_516_mib() {
        assert_eq!(size_of::<CellKey>(), 16);
        assert_eq!(CELL_BYTES, 128);
        assert_eq!(TABLE_BYTES, 516 << 20);
        let mut table: FxHashMap<u32, ()> = FxHashMap::default();
        table.extend((0..MAX_CELLS as u32).map(|k| (k, ())));
        assert!(table.capacity() >= MAX_CELLS && table.capacity() < 1 << 22);
        table.insert(u32::MAX, ());
        assert!(
            table.capacity() >= 1 << 22,
            "one more cell doubles the table"
        );
    }

    /// A full table makes no cell: deposits in new cells are dropped and counted, the cells it
    /// holds keep taking every deposit (so their means are those of all their deposits), and a
    /// read of a cell never made finds nothing (the reader path-traces).
    #[test]
    fn a_full_table_drops_deposits_in_new_cells_only() {
        let mut cache = LightCache::new(1.0).with_capacity(2);
        let point = |x: f32| floor_point(Vec3::new(x, 0.01, 0.5));
        let deposit = |cache: &mut LightCache, x: f32, e: f32| {
            let key = cache.key(&point(x));
            add(cache, &[on_floor(key, point(x).position, e)]);
        };
        for k in 0..MIN_DEPOSITS {
            deposit(&mut cache, 0.5, 1.0);
            deposit(&mut cache, 1.5, 2.0);
            // Cells 2 and 3 arrive once the table is full.
            deposit(&mut cache, 2.5, 3.0);
            deposit(&mut cache, 3.5 + k as f32, 4.0);
        }
        // The kept cells took their later deposits too.
        deposit(&mut cache, 0.5, 1.0 + MIN_DEPOSITS as f32 + 1.0);
        let counts = cache.counts();
        assert_eq!(
            (counts.cells, counts.dropped),
            (2, 2 * u64::from(MIN_DEPOSITS))
        );
        assert_eq!(counts.deposits, 4 * u64::from(MIN_DEPOSITS) + 1);
        assert_eq!(
            cache.irradiance(&open(), &point(0.5), &mut RayCounter::default()),
            Some(Vec3::splat(2.0))
        );
        assert_eq!(
            cache.irradiance(&open(), &point(1.5), &mut RayCounter::default()),
            Some(Vec3::splat(2.0))
        );
        assert_eq!(
            cache.irradiance(&open(), &point(2.5), &mut RayCounter::default()),
            None
        );
    }

    /// The light cache is consistent: at every cell width its cell means are the average of
    /// the irradiance over their cells, so its blur shrinks with the cell, and nothing else
    /// biases them. A floor (albedo 0.5, y = 0.05, mid-cell at every width below) lit by an
    /// octagon of radiance 4 and radius 0.5 facing down from 1 above its centre, nothing else:
    /// a deposit on the floor is an unbiased estimate of the irradiance E at its point (light
    /// sample and emission hit weighted by MIS; no indirect light reaches a lone floor), and
    /// vertical camera rays at uniform points of the region x ∈ [0.4, 2.0], z ∈ [−0.8, 0.8]
    /// (where E falls from 81 % to 4 % of its peak) spread the deposits uniformly, so a cell's
    /// expected mean is E's average over the cell, computed exactly here (Lambert's polygon
    /// formula, a 16² midpoint rule inside the cell, its error bounded by halving the grid).
    ///
    /// For cells 0.4, 0.2 and 0.1 wide, the mean over the region's cells of (mean − average) /
    /// average lies within 5 standard errors (the cells are independent; measured SE 0.09 to
    /// 0.11 %, means −0.10 % to −0.03 %) plus the quadrature's error; a cache that scaled its
    /// means by 1.01 is 9 SE away. And the blur itself, the RMS of (average − E at the cell's
    /// centre) / E, which a read at the centre returns, falls with the cell: second order in the
    /// width at a cell's centre, 16× from the 0.4 to the 0.1 cell (measured 1.35 %, 0.34 %,
    /// 0.086 %); asserted 8×.
    #[test]
    fn cell_means_are_the_irradiance_averaged_over_their_cells() {
        use crate::tests::{polygon, polygon_irradiance};
        let (l, radius, floor_y) = (4.0f32, 0.5f32, 0.05f32);
        let light_at = Vec3::new(0.0, floor_y + 1.0, 0.0);
        let scene = scene(
            &[
                polygon(Vec3::new(1.2, floor_y, 0.0), 6.0, 4, 1.0, 0),
                polygon(light_at, radius, 8, -1.0, 1),
            ],
            vec![
                Material::diffuse(Vec3::splat(0.5)),
                Material::emitter(Vec3::splat(l)),
            ],
        );
        let ring: Vec<Vec3> = (0..8)
            .map(|i| {
                let a = std::f32::consts::TAU * i as f32 / 8.0;
                light_at + Vec3::new(radius * a.cos(), 0.0, radius * a.sin())
            })
            .collect();
        let exact = |x: f32, z: f32| {
            let p = Vec3::new(x, floor_y, z);
            let v: Vec<Vec3> = ring.iter().map(|q| *q - p).collect();
            polygon_irradiance(&v, f64::from(l))
        };
        let average = |x0: f32, z0: f32, h: f32, n: usize| {
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n {
                    let (u, v) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                    sum += exact(x0 + u * h, z0 + v * h);
                }
            }
            sum / (n * n) as f64
        };
        let (x_lo, z_lo, side) = (0.4f32, -0.8f32, 1.6f32);
        let mut blur = Vec::new();
        for cells in [4u32, 8, 16] {
            let h = side / cells as f32;
            let mut cache = LightCache::new(h);
            let tracer = cache.tracer((2, 3));
            for i in 0..200_000u64 {
                let u = SampleKey::new(21, u64::from(cells), i).uniform_2d(0);
                let at = Vec3::new(x_lo + side * u.x, floor_y + 0.5, z_lo + side * u.y);
                let mut rays = RayCounter::default();
                let deposits = tracer.trace(
                    &scene,
                    &Ray::new(at, -Vec3::Y),
                    SampleKey::new(22, u64::from(cells), i),
                    &mut rays,
                );
                add(&mut cache, &deposits);
            }
            let (mut diffs, mut quadrature, mut blurs) = (Vec::new(), 0.0f64, Vec::new());
            for a in 0..cells {
                for b in 0..cells {
                    let (x0, z0) = (x_lo + a as f32 * h, z_lo + b as f32 * h);
                    let centre = Vec3::new(x0 + 0.5 * h, floor_y, z0 + 0.5 * h);
                    let (fine, coarse) = (average(x0, z0, h, 16), average(x0, z0, h, 8));
                    quadrature = quadrature.max((fine - coarse).abs() / fine);
                    let read = cache
                        .irradiance(&scene, &floor_point(centre), &mut RayCounter::default())
                        .unwrap_or_else(|| panic!("cell ({a}, {b}) of {cells}² has no mean"));
                    diffs.push((f64::from(read.x) - fine) / fine);
                    let at_centre = exact(centre.x, centre.z);
                    blurs.push(((fine - at_centre) / at_centre).powi(2));
                }
            }
            let n = diffs.len() as f64;
            let mean = diffs.iter().sum::<f64>() / n;
            let se = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
            let tol = 5.0 * se + quadrature;
            assert!(
                mean.abs() <= tol,
                "cells {h}: mean relative difference {mean:+.4} beyond {tol:.4} (SE {se:.4})"
            );
            blur.push((blurs.iter().sum::<f64>() / n).sqrt());
        }
        assert!(blur[2] * 8.0 < blur[0], "the blur did not shrink: {blur:?}");
    }
}
