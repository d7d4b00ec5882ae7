//! irr-cache in your own tracer: a value type of your own, records computed lazily where a
//! query misses (Ward's loop), then interpolation checked against the exact answer.
//!
//! The toy scene is analytic, so no rays are traced: a floor (z = 0, normal +z) lit by two
//! spherical lights. A sphere of radius r and radiance L at c, wholly above the floor's horizon,
//! gives p the irradiance E = π·L·r²·(n·d)/|d|³ with d = c − p. Each light is a channel of the
//! value type, so one record holds both.
//!
//! Run with `cargo run -p irr-cache --example own_tracer`.

use glam::Vec3;
use irr_cache::{
    CacheValue, IrradianceCache, RadiusInputs, RadiusLimits, Record, TabellionLamorlette,
};
use std::f32::consts::PI;

/// Your own value: the irradiance from each of the two lights, as two `f32` channels.
#[derive(Clone, Copy, Debug, PartialEq)]
struct TwoLights([f32; 2]);

impl CacheValue for TwoLights {
    const CHANNELS: usize = 2;
    // Cache files name the value type by this tag and CHANNELS: pick one irr-cache does not use
    // (1 to 3 are its own types'), so a file of another type is refused.
    const TAG: u32 = 0x7700;
    // Irradiance is never negative: the cache refuses negative records and clamps a steep
    // gradient's extrapolation at zero.
    const NON_NEGATIVE: bool = true;
    type Wide = [f64; 2];
    fn channels(&self) -> &[f32] {
        &self.0
    }
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
        Self(std::array::from_fn(f))
    }
    fn wide_zero() -> [f64; 2] {
        [0.0; 2]
    }
}

/// The lights: centre, radius, radiance.
const LIGHTS: [(Vec3, f32, f32); 2] = [
    (Vec3::new(-1.0, 0.0, 1.5), 0.3, 10.0),
    (Vec3::new(1.5, 0.5, 1.0), 0.2, 20.0),
];

/// E at a floor point and its translation gradient ∂E/∂p per world axis, exactly: with
/// k = π·L·r² and D = |d|, E = k·d_z/D³ and ∇E = k·(3·d_z·d/D⁵ − ẑ/D³).
fn irradiance(p: Vec3) -> (TwoLights, [TwoLights; 3]) {
    let per_light = LIGHTS.map(|(c, r, l)| {
        let (k, d) = (PI * l * r * r, c - p);
        let dist = d.length();
        let grad = k * (3.0 * d.z * d / dist.powi(5) - Vec3::Z / dist.powi(3));
        (k * d.z / dist.powi(3), grad)
    });
    let grad = [0, 1, 2].map(|axis| TwoLights(per_light.map(|(_, g)| g[axis])));
    (TwoLights(per_light.map(|(e, _)| e)), grad)
}

/// Point (i, j) of an n×n grid over the floor's square [−2, 2]², shifted by `offset` cells.
fn grid(i: u32, j: u32, n: u32, offset: f32) -> Vec3 {
    let at = |k: u32| -2.0 + 4.0 * (k as f32 + offset) / n as f32;
    Vec3::new(at(i), at(j), 0.0)
}

/// Fills a cache the way a renderer's first pass would: query each point of a grid, and on a
/// miss compute a record there.
fn build(gradients: bool) -> Result<IrradianceCache<TwoLights>, Box<dyn std::error::Error>> {
    // κ = 1: a record of radius R is used within R/2 of its position.
    let mut cache = IrradianceCache::new(TabellionLamorlette::new(1.0)?);
    for p in (0..64).flat_map(|j| (0..64).map(move |i| grid(i, j, 64, 0.5))) {
        if cache.covers(p, Vec3::Z) {
            continue;
        }
        let (e, grad) = irradiance(p);
        // The floor has no rotation gradient here: every query's normal is +z.
        let zero = [TwoLights([0.0; 2]); 3];
        let record = Record::new(p, Vec3::Z, 1.0, e)
            .with_gradients(if gradients { grad } else { zero }, zero);
        // The radius pipeline, fed by the distance statistic a gather would give: its rays miss
        // (the sky) or hit a light, so the nearest hit is the nearest light's surface. The
        // pipeline cuts it to the gradient limit E/‖∇E‖ where there are gradients, and clamps
        // it to the limits.
        let distance = LIGHTS
            .iter()
            .map(|&(c, r, _)| c.distance(p) - r)
            .fold(f32::INFINITY, f32::min);
        let limits = RadiusLimits {
            min: 0.02,
            max: 1.0,
        };
        let inputs = RadiusInputs {
            distance,
            limits,
            neighbour_clamping: true,
        };
        cache.insert_with_radius(record, &inputs)?;
    }
    Ok(cache)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    for gradients in [false, true] {
        let cache = build(gradients)?;
        // Read on a finer grid than the one the records came from, and compare each channel
        // with the exact irradiance.
        let (mut worst, mut sum, mut count, mut misses) = (0.0f32, 0.0f64, 0, 0);
        for p in (0..200).flat_map(|j| (0..200).map(move |i| grid(i, j, 200, 0.3))) {
            let Some(read) = cache.interpolate(p, Vec3::Z) else {
                misses += 1; // A renderer would compute a record here too.
                continue;
            };
            let (exact, _) = irradiance(p);
            for c in 0..2 {
                let error = (read.value.0[c] - exact.0[c]).abs() / exact.0[c];
                (worst, sum, count) = (worst.max(error), sum + f64::from(error), count + 1);
            }
        }
        println!(
            "{:<18} {:3} records, relative error mean {:.2} %, worst {:.1} % ({misses} misses)",
            if gradients {
                "with gradients:"
            } else {
                "without gradients:"
            },
            cache.len(),
            100.0 * sum / f64::from(count),
            100.0 * worst,
        );
    }
    // Without gradients a record is flat, and nothing shrinks it where the light falls off
    // fast (the floor's far corners, E ∝ 1/ρ³): the gradient limit needs a gradient.
    Ok(())
}
