//! The cache: records, their octree, the metric, and gradient-corrected interpolation.

use crate::metric::{Candidate, ErrorMetric, TabellionLamorlette};
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
        self.octree.insert(Entry {
            center: record.position,
            radius: influence,
            index,
        });
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
        let Some(nd) = unit_query_normal(n) else {
            return;
        };
        if !p.is_finite() {
            return;
        }
        let pd = p.as_dvec3();
        self.weighted(pd, nd, |index, record, candidate, w| {
            let _ = candidate;
            f(index, record, w);
        });
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
                let candidate = Candidate {
                    offset,
                    distance: d2.sqrt(),
                    query_normal: n,
                    record_normal: record.normal.as_dvec3(),
                    record_radius: f64::from(record.radius),
                };
                let w = self.metric.weight(&candidate);
                if w > 0.0 && w.is_finite() {
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
        let nd = unit_query_normal(n)?;
        if !p.is_finite() {
            return None;
        }
        let pd = p.as_dvec3();
        let mut sum = V::wide_zero();
        let mut total_weight = 0.0;
        let mut count = 0u32;
        self.weighted(pd, nd, |_, record, candidate, w| {
            // The rotation: the first-order change of E when the normal turns from nᵢ to n.
            let turn = candidate.record_normal.cross(nd);
            // The translation: from pᵢ to p.
            let step = candidate.offset;
            let (e, tg, rg) = (
                record.value.channels(),
                &record.translation_gradient,
                &record.rotation_gradient,
            );
            for (c, acc) in sum.as_mut().iter_mut().enumerate() {
                let mut v = f64::from(e[c]);
                for axis in 0..3 {
                    v += turn[axis] * f64::from(rg[axis].channels()[c])
                        + step[axis] * f64::from(tg[axis].channels()[c]);
                }
                if V::NON_NEGATIVE {
                    v = v.max(0.0);
                }
                *acc += w * v;
            }
            total_weight += w;
            count += 1;
        });
        if count == 0 {
            return None;
        }
        let sum = sum.as_ref();
        // Clamped to the finite f32 range: a mean of finite values, extrapolated by gradients,
        // can exceed f32::MAX only when the values are near it; the result stays finite.
        let max = f64::from(f32::MAX);
        let value = V::from_fn(|c| (sum[c] / total_weight).clamp(-max, max) as f32);
        Some(Interpolation {
            value,
            total_weight,
            count,
        })
    }

    /// Neighbour clamping, first half (Křivánek et al. 2006, "Making Radiance and Irradiance
    /// Caching Practical: Adaptive Caching and Neighbor Clamping"): the radius `radius` of a
    /// new record at `p`, lowered to min over existing records j of (Rⱼ + ‖p − pⱼ‖), so radii
    /// vary no faster than distance (the triangle inequality). Only records with ‖p − pⱼ‖ <
    /// `radius` can lower it. The second half, lowering the neighbours' radii in turn, is
    /// [`IrradianceCache::clamp_neighbours`].
    pub fn neighbour_clamped_radius(&self, p: Vec3, radius: f32) -> f32 {
        if !(p.is_finite() && radius.is_finite() && radius >= f32::MIN_POSITIVE) {
            return radius;
        }
        let pd = p.as_dvec3();
        let mut r = f64::from(radius);
        self.records_near(pd, radius, |_, record| {
            let d = (pd - record.position.as_dvec3()).length();
            r = r.min(f64::from(record.radius) + d);
        });
        r as f32
    }

    /// Neighbour clamping, second half (Křivánek et al. 2006): every record j within
    /// `radius` of `p` gets Rⱼ ← min(Rⱼ, `radius` + ‖p − pⱼ‖), and is refiled in the octree when
    /// its radius changes. Call it with the new record's (already clamped) radius, before or
    /// after inserting it. Returns how many records changed. Nothing changes when `p` is not
    /// finite or `radius` is not a valid record radius (see [`Record::validated`]), so every
    /// stored radius stays valid (and the cache can still be written and read back).
    pub fn clamp_neighbours(&mut self, p: Vec3, radius: f32) -> usize {
        if !(p.is_finite() && radius.is_finite() && radius >= f32::MIN_POSITIVE) {
            return 0;
        }
        let pd = p.as_dvec3();
        let mut lowered: Vec<(RecordId, f32)> = Vec::new();
        self.records_near(pd, radius, |index, record| {
            let d = (pd - record.position.as_dvec3()).length();
            let limit = (f64::from(radius) + d) as f32;
            if limit < record.radius && !lowered.iter().any(|&(i, _)| i == index) {
                lowered.push((index, limit));
            }
        });
        for &(index, limit) in &lowered {
            let record = self.records[index as usize];
            let old = self.metric.influence_radius(record.radius);
            let new = self.metric.influence_radius(limit);
            self.octree.remove(record.position, old, index);
            self.records[index as usize].radius = limit;
            self.octree.insert(Entry {
                center: record.position,
                radius: new,
                index,
            });
        }
        lowered.len()
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

/// Whether `p` lies strictly inside a sphere of influence: the exact test the octree applies, to
/// be used by anyone who scans records by hand and wants the same answer to the last bit.
#[inline]
pub fn within_influence(center: Vec3, influence_radius: f32, p: Vec3) -> bool {
    p.is_finite() && contains(center, influence_radius, p.as_dvec3())
}
