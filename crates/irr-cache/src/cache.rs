//! The cache: records, their octree, the metric, and gradient-corrected interpolation.

use crate::metric::{Candidate, ErrorMetric, RadiusLimits, TabellionLamorlette};
use crate::octree::{Entry, Octree, contains, contains_offset};
use crate::record::{InsertError, Record, unit_query_normal};
use crate::value::CacheValue;
use glam::{DVec3, Vec3};

/// An irradiance cache: records of `V`, weighted by the metric `M`.
///
/// Insertion takes `&mut self`; every query takes `&self`, and the cache is `Sync` (when `V` and
/// `M` are), so a renderer can query from many threads between insertion phases (or put the cache
/// behind an `RwLock`).
#[derive(Clone, Debug)]
pub struct IrradianceCache<V: CacheValue, M: ErrorMetric = TabellionLamorlette> {
    metric: M,
    records: Vec<Record<V>>,
    octree: Octree,
}

/// The result of [`IrradianceCache::interpolate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interpolation<V> {
    /// E(p, n), the weighted mean of the records' gradient-corrected values.
    pub value: V,
    /// Σ wᵢ over the records used (> 0).
    pub total_weight: f64,
    /// How many records were used (≥ 1).
    pub count: u32,
}

/// A record of a batch was refused ([`IrradianceCache::extend`]); nothing was added.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("record {index} of the batch was refused: {source}")]
pub struct BatchError {
    /// The record's position in the batch.
    pub index: usize,
    /// Why it was refused.
    #[source]
    pub source: InsertError,
}

/// The index of a record in its cache ([`IrradianceCache::records`]), in insertion order.
pub type RecordId = u32;

impl<V: CacheValue, M: ErrorMetric> IrradianceCache<V, M> {
    /// An empty cache weighted by `metric`.
    pub fn new(metric: M) -> Self {
        Self {
            metric,
            records: Vec::new(),
            octree: Octree::default(),
        }
    }

    /// The metric.
    #[inline]
    pub fn metric(&self) -> &M {
        &self.metric
    }

    /// The records, in insertion order (as stored: normals unit).
    #[inline]
    pub fn records(&self) -> &[Record<V>] {
        &self.records
    }

    /// Number of records.
    #[inline]
    pub fn len(&self) -> usize {
        self.records.len()
    }

    /// Whether the cache holds no record.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Checks a record (see [`Record::validated`]) and the influence radius the metric gives it.
    fn prepare(&self, record: Record<V>) -> Result<(Record<V>, f32), InsertError> {
        let record = record.validated()?;
        let influence = self.metric.influence_radius(record.radius);
        if !(influence.is_finite() && influence >= 0.0) {
            return Err(InsertError::Influence(influence));
        }
        Ok((record, influence))
    }

    /// Adds a record and returns its id; the record is refused, and the cache unchanged, when it
    /// is not valid (a zero radius, a NaN, …).
    pub fn insert(&mut self, record: Record<V>) -> Result<RecordId, InsertError> {
        let (record, influence) = self.prepare(record)?;
        if self.records.len() >= u32::MAX as usize {
            return Err(InsertError::Full);
        }
        Ok(self.push(record, influence))
    }

    fn push(&mut self, record: Record<V>, influence: f32) -> RecordId {
        let index = self.records.len() as u32;
        self.octree.insert(
            Entry {
                center: record.position,
                radius: influence,
                index,
            },
            record.unclamped_radius,
        );
        self.records.push(record);
        index
    }

    /// Adds a batch of records, all or none: if one is refused, the error names its position in
    /// the batch and nothing is added. Returns the ids given to the batch.
    pub fn extend<I: IntoIterator<Item = Record<V>>>(
        &mut self,
        records: I,
    ) -> Result<std::ops::Range<RecordId>, BatchError> {
        let batch = records
            .into_iter()
            .enumerate()
            .map(|(index, r)| {
                self.prepare(r)
                    .map_err(|source| BatchError { index, source })
            })
            .collect::<Result<Vec<_>, _>>()?;
        if self.records.len() + batch.len() > u32::MAX as usize {
            let first_over = (u32::MAX as usize).saturating_sub(self.records.len());
            return Err(BatchError {
                index: first_over,
                source: InsertError::Full,
            });
        }
        let start = self.records.len() as u32;
        self.records.reserve(batch.len());
        for (record, influence) in batch {
            self.push(record, influence);
        }
        Ok(start..self.records.len() as u32)
    }

    /// Calls `f` with every record whose sphere of influence contains `p` (‖p − pᵢ‖ <
    /// `metric.influence_radius(Rᵢ)`, as [`crate::within_influence`] decides), whatever the
    /// normals; each record once. The order is the octree's, not insertion order.
    pub fn for_each_in_range(&self, p: Vec3, mut f: impl FnMut(RecordId, &Record<V>)) {
        if !p.is_finite() {
            return;
        }
        let pd = p.as_dvec3();
        self.octree.for_each_on_path(pd, |e| {
            if contains(e.center, e.radius, pd) {
                f(e.index, &self.records[e.index as usize]);
            }
        });
    }

    /// Calls `f` with every record that has a positive weight at (`p`, `n`), and that weight. `n`
    /// need not be unit (it is normalised); nothing is visited when `p` or `n` is not finite or
    /// `n` is zero.
    pub fn for_each_weighted(
        &self,
        p: Vec3,
        n: Vec3,
        mut f: impl FnMut(RecordId, &Record<V>, f64),
    ) {
        if let Some((pd, nd)) = query(p, n) {
            self.weighted(pd, nd, |index, record, _, w| f(index, record, w));
        }
    }

    /// `record`'s candidate for a query whose offset from it is `offset` (squared length `d2`)
    /// and whose unit normal is `n`, with its weight, if that is positive and finite.
    #[inline]
    fn weigh(
        &self,
        record: &Record<V>,
        offset: DVec3,
        d2: f64,
        n: DVec3,
    ) -> Option<(Candidate, f64)> {
        let candidate = Candidate {
            offset,
            distance: d2.sqrt(),
            query_normal: n,
            record_normal: record.normal.as_dvec3(),
            record_radius: f64::from(record.radius),
            record_aspect: f64::from(record.aspect),
            record_tangent: record.tangent.as_dvec3(),
        };
        let w = self.metric.weight(&candidate);
        (w > 0.0 && w.is_finite()).then_some((candidate, w))
    }

    /// Calls `f` for every record of positive weight at (p, n).
    ///
    /// In two passes: the records in range are collected (a batch at a time) before any is read,
    /// so that their cache misses overlap instead of each waiting for the previous weight.
    #[inline]
    fn weighted(
        &self,
        p: DVec3,
        n: DVec3,
        mut f: impl FnMut(RecordId, &Record<V>, &Candidate, f64),
    ) {
        const BATCH: usize = 32;
        let mut batch = [(0u32, DVec3::ZERO, 0.0f64); BATCH];
        let mut len = 0;
        let mut flush = |batch: &[(u32, DVec3, f64)]| {
            for &(index, offset, d2) in batch {
                let record = &self.records[index as usize];
                if let Some((candidate, w)) = self.weigh(record, offset, d2, n) {
                    f(index, record, &candidate, w);
                }
            }
        };
        self.octree.for_each_on_path(p, |e| {
            if let Some((offset, d2)) = contains_offset(e.center, e.radius, p) {
                batch[len] = (e.index, offset, d2);
                len += 1;
                if len == BATCH {
                    flush(&batch);
                    len = 0;
                }
            }
        });
        flush(&batch[..len]);
    }

    /// E(p, n) = Σ wᵢ·Ẽᵢ / Σ wᵢ over the records with wᵢ > 0, where each record's value is
    /// corrected to first order by its gradients (Ward & Heckbert 1992, "Irradiance Gradients";
    /// the form of Křivánek & Gautron 2009, ch. 2, and Mitsuba 0.6's interpolation):
    ///
    /// Ẽᵢ = Eᵢ + (nᵢ × n)·∇ᵣEᵢ + (p − pᵢ)·∇ₜEᵢ,
    ///
    /// clamped at zero per channel for a [`CacheValue::NON_NEGATIVE`] type. `None` when no record
    /// has a positive weight (the caller then computes a new record), or when `p` or `n` is not
    /// finite or `n` is zero.
    ///
    /// Accuracy: Ẽᵢ, the products and both sums are computed in `f64` from the stored `f32`s, and
    /// the mean is rounded to `f32` once. So with k records each channel is the exact weighted mean
    /// of the Ẽᵢ up to a relative (k + 2)·2⁻⁵³ (of Σ wᵢ|Ẽᵢ| / Σ wᵢ), then one `f32` rounding
    /// (2⁻²⁴ relative).
    pub fn interpolate(&self, p: Vec3, n: Vec3) -> Option<Interpolation<V>> {
        self.interpolate_filtered(p, n, |_, _| true)
    }

    /// [`IrradianceCache::interpolate`] over the records `accept` lets through: it is asked about
    /// each record of positive weight, once, in the octree's order (which depends only on the set
    /// of records). A renderer uses it to skip records it finds invalid for reasons the cache
    /// cannot see, e.g. a record on the other side of a wall (a visibility test between the query
    /// point and the record, as a leak guard).
    pub fn interpolate_filtered(
        &self,
        p: Vec3,
        n: Vec3,
        mut accept: impl FnMut(RecordId, &Record<V>) -> bool,
    ) -> Option<Interpolation<V>> {
        let nd = unit_query_normal(n)?;
        if !p.is_finite() {
            return None;
        }
        let mut mean = WeightedMean::<V>::new(self.metric.second_order_limit());
        self.weighted(p.as_dvec3(), nd, |index, record, candidate, w| {
            if accept(index, record) {
                mean.add(record, candidate, w);
            }
        });
        mean.finish()
    }

    /// The records whose sphere of influence may meet the box [`lo`, `hi`] (a superset of those
    /// that contain some point of it), in index order, into `out` (cleared first). For a caller
    /// that queries many points of a small region, as a renderer does a pixel's samples: one walk
    /// of the octree for the region, then [`IrradianceCache::interpolate_among`] for each point.
    pub fn records_meeting_box(&self, lo: Vec3, hi: Vec3, out: &mut Vec<NearbyRecord>) {
        out.clear();
        if !(lo.is_finite() && hi.is_finite()) {
            return;
        }
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        self.octree.for_each_in_box(lo, hi, &mut |e: &Entry| {
            // The sphere meets the box if its centre is within its radius of the box's nearest
            // point; the pad of 2⁻⁴⁰ keeps every point `contains` accepts (see the octree).
            let c = e.center.as_dvec3();
            let r = f64::from(e.radius) * (1.0 + 2f64.powi(-40));
            if (c.clamp(lo, hi) - c).length_squared() <= r * r {
                out.push(NearbyRecord {
                    id: e.index,
                    center: e.center,
                    influence: e.radius,
                });
            }
        });
        out.sort_unstable_by_key(|r| r.id);
        out.dedup_by_key(|r| r.id);
    }

    /// [`IrradianceCache::interpolate_filtered`] over `nearby`, the records
    /// [`IrradianceCache::records_meeting_box`] found for a box that holds `p`: the same records
    /// weigh in as there (the same containment test, to the last bit) and the same value per
    /// record, summed in index order. `accept` is asked about each record of positive weight,
    /// once, in index order.
    pub fn interpolate_among(
        &self,
        nearby: &[NearbyRecord],
        p: Vec3,
        n: Vec3,
        mut accept: impl FnMut(RecordId, &Record<V>) -> bool,
    ) -> Option<Interpolation<V>> {
        let (pd, nd) = query(p, n)?;
        let mut mean = WeightedMean::<V>::new(self.metric.second_order_limit());
        self.weighted_among(nearby, pd, nd, |id, record, candidate, w| {
            if accept(id, record) {
                mean.add(record, candidate, w);
            }
        });
        mean.finish()
    }

    /// [`IrradianceCache::interpolate_filtered`] for a point that may lie up to `reach` beyond
    /// the records' spheres of influence: each record weighs in as if `p` were `reach` nearer
    /// to it (the offset its weight sees shortened by `reach`, the normals' term unchanged),
    /// while its value is still extrapolated to `p` itself by its gradients. With `reach` 0 it
    /// weighs `interpolate_filtered`'s records with its weights, summed in index order rather
    /// than the octree's. For a renderer's final pass: a point in a gap between spheres
    /// narrower than the probes that built the cache reads its neighbours instead of gathering.
    /// `None` as `interpolate_filtered`, or when `reach` is negative or not finite.
    pub fn interpolate_within(
        &self,
        p: Vec3,
        n: Vec3,
        reach: f32,
        mut accept: impl FnMut(RecordId, &Record<V>) -> bool,
    ) -> Option<Interpolation<V>> {
        let (pd, nd) = query(p, n)?;
        if !(reach >= 0.0 && reach.is_finite()) {
            return None;
        }
        let mut nearby = Vec::new();
        self.records_meeting_box(p - Vec3::splat(reach), p + Vec3::splat(reach), &mut nearby);
        let r = f64::from(reach);
        let mut mean = WeightedMean::<V>::new(self.metric.second_order_limit());
        for near in &nearby {
            let Some(record) = self.records.get(near.id as usize) else {
                continue;
            };
            let offset = pd - record.position.as_dvec3();
            let d = offset.length();
            let seen = if d > r {
                offset * ((d - r) / d)
            } else {
                DVec3::ZERO
            };
            let Some((candidate, w)) = self.weigh(record, seen, seen.length_squared(), nd) else {
                continue;
            };
            if accept(near.id, record) {
                let at_p = Candidate {
                    offset,
                    distance: d,
                    ..candidate
                };
                mean.add(record, &at_p, w);
            }
        }
        mean.finish()
    }

    /// Calls `f` for every record of `nearby` whose sphere contains `p` and whose weight at
    /// (`p`, unit `n`) is positive, in `nearby`'s order.
    fn weighted_among(
        &self,
        nearby: &[NearbyRecord],
        p: DVec3,
        n: DVec3,
        mut f: impl FnMut(RecordId, &Record<V>, &Candidate, f64),
    ) {
        for near in nearby {
            let Some((offset, d2)) = contains_offset(near.center, near.influence, p) else {
                continue;
            };
            let Some(record) = self.records.get(near.id as usize) else {
                continue;
            };
            if let Some((candidate, w)) = self.weigh(record, offset, d2, n) {
                f(near.id, record, &candidate, w);
            }
        }
    }

    /// Calls `f` with every record of `nearby` (as [`IrradianceCache::records_meeting_box`]
    /// found them for a box that holds `p`) that has a positive weight at (`p`, `n`), and that
    /// weight, in index order: the records and weights of [`IrradianceCache::interpolate_among`].
    /// For a caller that combines values the cache cannot, e.g. coefficients in each record's
    /// own frame that must be rotated into the query's before they are averaged.
    pub fn for_each_weighted_among(
        &self,
        nearby: &[NearbyRecord],
        p: Vec3,
        n: Vec3,
        mut f: impl FnMut(RecordId, &Record<V>, f64),
    ) {
        if let Some((pd, nd)) = query(p, n) {
            self.weighted_among(nearby, pd, nd, |id, record, _, w| f(id, record, w));
        }
    }

    /// Whether any record has a positive weight at (`p`, `n`): the test [`IrradianceCache::interpolate`]
    /// makes before it sums, without the sums, and stopping at the first record found. `false`
    /// when `p` or `n` is not finite or `n` is zero. A renderer that computes candidate records in
    /// parallel uses it to drop a candidate that an earlier candidate of the same pass covers.
    pub fn covers(&self, p: Vec3, n: Vec3) -> bool {
        self.covers_filtered(p, n, |_, _| true)
    }

    /// [`IrradianceCache::covers`] counting only the records `accept` lets through (see
    /// [`IrradianceCache::interpolate_filtered`]): `covers_filtered` is true exactly when
    /// `interpolate_filtered` with the same filter finds a record.
    pub fn covers_filtered(
        &self,
        p: Vec3,
        n: Vec3,
        mut accept: impl FnMut(RecordId, &Record<V>) -> bool,
    ) -> bool {
        let Some(nd) = unit_query_normal(n) else {
            return false;
        };
        if !p.is_finite() {
            return false;
        }
        let pd = p.as_dvec3();
        let mut found = false;
        self.octree.for_each_on_path(pd, |e| {
            if found {
                return;
            }
            if let Some((offset, d2)) = contains_offset(e.center, e.radius, pd) {
                let record = &self.records[e.index as usize];
                found = self.weigh(record, offset, d2, nd).is_some() && accept(e.index, record);
            }
        });
        found
    }

    /// Neighbour clamping, first half (Křivánek et al. 2006, "Making Radiance and Irradiance
    /// Caching Practical: Adaptive Caching and Neighbor Clamping"): the unclamped radius
    /// `radius` of a new record at `p`, lowered to min over existing records j of
    /// (gⱼ + ‖p − pⱼ‖), gⱼ their unclamped radii ([`Record::unclamped_radius`]), so radii vary no
    /// faster than distance (the triangle inequality). Only records with ‖p − pⱼ‖ < `radius` can
    /// lower it, and only those are visited. The second half, lowering the neighbours' radii in
    /// turn, is [`IrradianceCache::clamp_neighbours`].
    pub fn neighbour_clamped_radius(&self, p: Vec3, radius: f32) -> f32 {
        if !(p.is_finite() && radius.is_finite() && radius >= f32::MIN_POSITIVE) {
            return radius;
        }
        let pd = p.as_dvec3();
        let mut r = f64::from(radius);
        self.records_near(pd, radius, |_, record| {
            let d = (pd - record.position.as_dvec3()).length();
            r = r.min(f64::from(record.unclamped_radius) + d);
        });
        r as f32
    }

    /// Neighbour clamping, second half (Křivánek et al. 2006): every record j with
    /// gⱼ > `radius` + dⱼ (gⱼ its unclamped radius, dⱼ = ‖p − pⱼ‖) gets gⱼ ← `radius` + dⱼ, and its
    /// radius Rⱼ ← min(Rⱼ, max(gⱼ, its minimum radius)): a record is never pushed below its own
    /// minimum (Mitsuba 0.6 re-clamps the same way). A record whose Rⱼ changes is refiled in the
    /// octree. Call it with the new record's unclamped radius, before or after inserting it.
    /// Returns how many records changed (g or R).
    ///
    /// The records to lower can lie far from `p`: a large record whose sphere reaches past the new
    /// one has dⱼ up to gⱼ − `radius`. The octree's search covers, on each level, the largest
    /// unclamped radius filed there (`Octree::for_each_within_reach`), so none is missed.
    ///
    /// Nothing changes when `p` is not finite or `radius` is not a valid record radius (see
    /// [`Record::validated`]), so every stored radius stays valid.
    pub fn clamp_neighbours(&mut self, p: Vec3, radius: f32) -> usize {
        if !(p.is_finite() && radius.is_finite() && radius >= f32::MIN_POSITIVE) {
            return 0;
        }
        let pd = p.as_dvec3();
        let r = f64::from(radius);
        let mut due: Vec<RecordId> = Vec::new();
        let records = &self.records;
        self.octree.for_each_within_reach(pd, r, &mut |e: &Entry| {
            let record = &records[e.index as usize];
            let d = (pd - record.position.as_dvec3()).length();
            if f64::from(record.unclamped_radius) > r + d {
                due.push(e.index);
            }
        });
        due.sort_unstable();
        due.dedup();
        let mut changed = 0;
        for &index in &due {
            let record = self.records[index as usize];
            let d = (pd - record.position.as_dvec3()).length();
            let g = (r + d) as f32;
            if g >= record.unclamped_radius {
                // Rounding r + d to f32 reached gⱼ again: nothing to lower.
                continue;
            }
            let new_radius = record
                .radius
                .min(g.max(record.min_radius).max(f32::MIN_POSITIVE));
            self.records[index as usize].unclamped_radius = g;
            changed += 1;
            if new_radius < record.radius {
                let old = self.metric.influence_radius(record.radius);
                let new = self.metric.influence_radius(new_radius);
                self.octree.remove(record.position, old, index);
                self.records[index as usize].radius = new_radius;
                self.octree.insert(
                    Entry {
                        center: record.position,
                        radius: new,
                        index,
                    },
                    g,
                );
            }
        }
        changed
    }

    /// The radius pipeline for a new record, without inserting it: what
    /// [`IrradianceCache::insert_with_radius`] would store. Read-only, so a renderer can plan
    /// candidates from many threads; see [`RadiusInputs`] for the steps.
    pub fn plan_radius(
        &self,
        record: &Record<V>,
        inputs: &RadiusInputs,
    ) -> Result<Placement, InsertError> {
        let limits = inputs.limits;
        if !(limits.min.is_finite()
            && limits.min >= 0.0
            && limits.max.is_finite()
            && limits.max >= limits.min)
        {
            return Err(InsertError::Limits(limits.min, limits.max));
        }
        if inputs.distance.is_nan() {
            return Err(InsertError::Distance(inputs.distance));
        }
        let normal = crate::record::unit_normal(record.normal).ok_or(InsertError::Normal)?;
        // 1. The gather's distance; nothing hit (+∞) means the maximum, the scene's own bound on
        //    how far a record may reach. A hit at zero distance is the smallest radius there is.
        let mut g = if inputs.distance == f32::INFINITY {
            limits.max
        } else {
            inputs.distance.max(f32::MIN_POSITIVE)
        };
        // 2. The gradient limit R ≤ E/‖∇ₜE‖ (Křivánek et al. 2006), per channel, the gradient
        //    taken in the tangent plane (cached neighbours lie on the surface).
        let channel_limits = gradient_limits(record, normal);
        let gradient_limit = channel_limits.iter().copied().fold(f32::INFINITY, f32::min);
        g = g.min(gradient_limit).max(f32::MIN_POSITIVE);
        // 3. Neighbour clamping's first half: g ≤ gⱼ + dⱼ for every record j.
        if inputs.neighbour_clamping {
            g = self
                .neighbour_clamped_radius(record.position, g)
                .max(f32::MIN_POSITIVE);
        }
        // 4. The pixel and world-space limits.
        let radius = limits.clamp(g).max(f32::MIN_POSITIVE);
        // 5. The gradient cap: where the minimum raised R above what the gradient allows, scale
        //    the gradient down so that ‖∇ₜE‖·R ≤ E (Radiance's `doambient`; Mitsuba 0.6 scales
        //    by R_limit/R too), per channel: extrapolated over R, no channel moves by more than
        //    its own value.
        let scales = channel_limits.map(|l| if l < radius { l / radius } else { 1.0 });
        Ok(Placement {
            radius,
            unclamped_radius: g,
            min_radius: limits.min,
            gradient_limit,
            gradient_scale: scales,
        })
    }

    /// Inserts a record whose radius comes from the radius pipeline (see [`RadiusInputs`]): the
    /// record's own `radius`, `unclamped_radius` and `min_radius` are replaced by the pipeline's,
    /// its translation gradient is scaled by the gradient cap, and with neighbour clamping on, the
    /// neighbours are lowered in turn ([`IrradianceCache::clamp_neighbours`]). Returns the new
    /// record's id and the placement used. A refused record changes nothing.
    pub fn insert_with_radius(
        &mut self,
        record: Record<V>,
        inputs: &RadiusInputs,
    ) -> Result<(RecordId, Placement), InsertError> {
        let placement = self.plan_radius(&record, inputs)?;
        let record = placement.apply(record);
        let (record, influence) = self.prepare(record)?;
        if self.records.len() >= u32::MAX as usize {
            return Err(InsertError::Full);
        }
        if inputs.neighbour_clamping {
            self.clamp_neighbours(record.position, record.unclamped_radius);
        }
        Ok((self.push(record, influence), placement))
    }

    /// Calls `f` with records whose position lies within `radius` of `p` (possibly more than
    /// once; a superset filtered by distance).
    fn records_near(&self, p: DVec3, radius: f32, mut f: impl FnMut(RecordId, &Record<V>)) {
        // A record's entry lies in cells overlapping its sphere, which contains its position; so
        // the cells overlapping the ball of `radius` around p hold every record whose position is
        // in that ball.
        let r = f64::from(radius);
        let (lo, hi) = (p - DVec3::splat(r), p + DVec3::splat(r));
        self.octree.for_each_in_box(lo, hi, &mut |e: &Entry| {
            let record = &self.records[e.index as usize];
            if (p - record.position.as_dvec3()).length() < r {
                f(e.index, record);
            }
        });
    }

    /// Bytes held by the cache (records, octree cells and entries), capacity included.
    pub fn memory_bytes(&self) -> usize {
        size_of::<Self>()
            + self.records.capacity() * size_of::<Record<V>>()
            + self.octree.memory_bytes()
    }

    /// The number of non-empty octree cells and of entries (a record is filed in 1 to 8 cells).
    pub fn octree_counts(&self) -> (usize, usize) {
        self.octree.counts()
    }
}

/// A record near a region ([`IrradianceCache::records_meeting_box`]): its id and its sphere of
/// influence as the octree files it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearbyRecord {
    /// The record's id.
    pub id: RecordId,
    center: Vec3,
    influence: f32,
}

/// The gradient-corrected weighted mean of records, summed in f64 (see
/// [`IrradianceCache::interpolate`]).
struct WeightedMean<V: CacheValue> {
    sum: V::Wide,
    total_weight: f64,
    count: u32,
    /// The metric's [`ErrorMetric::second_order_limit`].
    second_order: f64,
}

/// 1 + ½ Δᵀ(H/E)Δ, the second-order term in `record`'s tangent frame (its curvature along the
/// minor axis u and along nᵢ × u) for the offset of `candidate`, the term clamped into
/// ±`limit`: the factor on the record's value (the Hessian is relative to it).
#[inline(never)]
fn second_order_scale<V: CacheValue>(record: &Record<V>, candidate: &Candidate, limit: f64) -> f64 {
    if record.curvature == [0.0; 2] {
        return 1.0;
    }
    let u = candidate.record_tangent;
    let v = candidate.record_normal.cross(u);
    let (du, dv) = (candidate.offset.dot(u), candidate.offset.dot(v));
    let [cu, cv] = record.curvature.map(f64::from);
    1.0 + (0.5 * (cu * du * du + cv * dv * dv)).clamp(-limit, limit)
}

impl<V: CacheValue> WeightedMean<V> {
    fn new(second_order: f64) -> Self {
        Self {
            sum: V::wide_zero(),
            total_weight: 0.0,
            count: 0,
            second_order,
        }
    }

    /// Adds `record`'s value, corrected to the query of `candidate`, with weight `w`; with a
    /// positive second-order limit, also by its curvature.
    #[inline]
    fn add(&mut self, record: &Record<V>, candidate: &Candidate, w: f64) {
        // The rotation: the first-order change of E when the normal turns from nᵢ to n.
        let turn = candidate.record_normal.cross(candidate.query_normal);
        // The translation: from pᵢ to p.
        let step = candidate.offset;
        let scale = if self.second_order > 0.0 {
            second_order_scale(record, candidate, self.second_order)
        } else {
            1.0
        };
        let (e, tg, rg) = (
            record.value.channels(),
            &record.translation_gradient,
            &record.rotation_gradient,
        );
        for (c, acc) in self.sum.as_mut().iter_mut().enumerate() {
            let mut v = f64::from(e[c]);
            if scale != 1.0 {
                v *= scale;
            }
            for axis in 0..3 {
                v += turn[axis] * f64::from(rg[axis].channels()[c])
                    + step[axis] * f64::from(tg[axis].channels()[c]);
            }
            if V::NON_NEGATIVE {
                v = v.max(0.0);
            }
            *acc += w * v;
        }
        self.total_weight += w;
        self.count += 1;
    }

    fn finish(self) -> Option<Interpolation<V>> {
        if self.count == 0 {
            return None;
        }
        let sum = self.sum.as_ref();
        // Clamped to the finite f32 range: a mean of finite values, extrapolated by gradients,
        // can exceed f32::MAX only when the values are near it; the result stays finite.
        let max = f64::from(f32::MAX);
        let total = self.total_weight;
        let value = V::from_fn(|c| (sum[c] / total).clamp(-max, max) as f32);
        Some(Interpolation {
            value,
            total_weight: total,
            count: self.count,
        })
    }
}

/// What the radius pipeline needs besides the record ([`IrradianceCache::plan_radius`],
/// [`IrradianceCache::insert_with_radius`]).
///
/// The pipeline sets a new record's radius in the order the sources use (Ward et al. 1988; Ward
/// & Heckbert 1992; Tabellion & Lamorlette 2004; Křivánek et al. 2006; Radiance's `ambient.c`,
/// Mitsuba 0.6's `irrcache.cpp`):
/// 1. the gather's distance statistic `distance` (the harmonic mean, or the minimum, of the hit
///    distances above ~10° of the horizon, computed by the caller, e.g. irr-gradients'
///    `GatherSamples::harmonic_mean_distance_above`); +∞ (nothing hit: open sky) becomes
///    `limits.max`, so every record's radius is finite;
/// 2. the gradient limit g ≤ E/‖∇ₜE‖ per channel (Křivánek et al. 2006), ∇ₜE in the tangent
///    plane; skipped for value types that may be negative;
/// 3. neighbour clamping's first half, g ≤ gⱼ + dⱼ (if `neighbour_clamping`): the result is the
///    record's **unclamped radius**;
/// 4. the pixel and world-space limits: R = clamp(g, `limits.min`, `limits.max`);
/// 5. the gradient cap: where R exceeds a channel's gradient limit (step 4 raised it to the
///    minimum), that channel's translation gradient is scaled by limit/R, so ‖∇ₜE‖·R ≤ E.
///
/// Inserting then applies neighbour clamping's second half to the existing records.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiusInputs {
    /// The gather's distance statistic (world units, > 0; +∞ when every ray missed).
    pub distance: f32,
    /// The limits: R ∈ [min, max], max finite (the caller combines the pixel limits of
    /// [`ErrorMetric::radius_limits`] with its world-space ones).
    pub limits: RadiusLimits,
    /// Whether to apply neighbour clamping (both halves).
    pub neighbour_clamping: bool,
}

/// What the radius pipeline decided for one record ([`IrradianceCache::plan_radius`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// R, the radius the record is used with.
    pub radius: f32,
    /// g, the unclamped radius (after steps 1–3).
    pub unclamped_radius: f32,
    /// The minimum radius the record keeps for later neighbour clamping.
    pub min_radius: f32,
    /// The gradient limit min over channels of E/‖∇ₜE‖ (+∞ for no gradient).
    pub gradient_limit: f32,
    /// The factor each channel's translation gradient is scaled by (1 where the cap does not
    /// bind). Channels past [`CacheValue::CHANNELS`] are 1 and unused.
    pub gradient_scale: [f32; MAX_SCALED_CHANNELS],
}

/// How many channels [`Placement::gradient_scale`] holds: the gradient cap applies to value types
/// of at most this many channels (irradiance, occlusion); wider ones (coefficient vectors, which
/// may be negative) are not capped.
pub const MAX_SCALED_CHANNELS: usize = 4;

impl Placement {
    /// `record` with this placement's radii and its translation gradient scaled by the cap.
    pub fn apply<V: CacheValue>(&self, record: Record<V>) -> Record<V> {
        let scale = |g: V| {
            let c = g.channels();
            V::from_fn(|i| c[i] * self.gradient_scale.get(i).copied().unwrap_or(1.0))
        };
        Record {
            radius: self.radius,
            unclamped_radius: self.unclamped_radius,
            min_radius: self.min_radius,
            translation_gradient: record.translation_gradient.map(scale),
            ..record
        }
    }
}

/// Per channel, E/‖∇ₜE‖ with ∇ₜE projected on the tangent plane of `normal` (+∞ for a zero
/// tangent gradient, and for value types that may be negative or have more channels than
/// [`MAX_SCALED_CHANNELS`]). Computed in f64, rounded down to f32 so the cap it implies holds.
fn gradient_limits<V: CacheValue>(record: &Record<V>, normal: Vec3) -> [f32; MAX_SCALED_CHANNELS] {
    let mut out = [f32::INFINITY; MAX_SCALED_CHANNELS];
    if !V::NON_NEGATIVE || V::CHANNELS > MAX_SCALED_CHANNELS {
        return out;
    }
    let n = normal.as_dvec3();
    let e = record.value.channels();
    let t = &record.translation_gradient;
    for (c, limit) in out.iter_mut().enumerate().take(V::CHANNELS) {
        let g = DVec3::new(
            f64::from(t[0].channels()[c]),
            f64::from(t[1].channels()[c]),
            f64::from(t[2].channels()[c]),
        );
        let len = (g - n * g.dot(n)).length();
        if len > 0.0 {
            let l = f64::from(e[c]).max(0.0) / len;
            let r = l as f32;
            *limit = if f64::from(r) > l { r.next_down() } else { r };
        }
    }
    out
}

/// Whether `p` lies strictly inside a sphere of influence: the exact test the octree applies, to
/// be used by anyone who scans records by hand and wants the same answer to the last bit.
#[inline]
pub fn within_influence(center: Vec3, influence_radius: f32, p: Vec3) -> bool {
    p.is_finite() && contains(center, influence_radius, p.as_dvec3())
}

/// A query's point and unit normal in f64, or `None` when `p` is not finite or `n` is not a
/// usable normal (`unit_query_normal`).
fn query(p: Vec3, n: Vec3) -> Option<(DVec3, DVec3)> {
    let nd = unit_query_normal(n)?;
    p.is_finite().then(|| (p.as_dvec3(), nd))
}
