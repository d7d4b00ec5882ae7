//! The whole irradiance-cache loop with irr-gradients, irr-gather-record and irr-cache, and
//! your own tracer: query the cache; where it misses, gather, turn the gather into a record
//! and insert it; then compare what the cache reads with the exact irradiance.
//!
//! The scene is analytic: a floor (z = 0, normal +z) under a bluish sky with a warm spherical
//! light in it (centre c, radius r). The sphere replaces the sky over its solid angle, so each
//! channel's E = π·L_sky + (L − L_sky)·π·r²·d_z/|d|³ with d = c − p.
//!
//! Run with `cargo run -p irr-gather-record --example gather_to_cache`.

use glam::{Vec2, Vec3};
use irr_cache::{IrradianceCache, RadiusInputs, RadiusLimits, Rgb, TabellionLamorlette};
use irr_gradients::{GatherSamples, TranslationGradient};
use irr_sampling::{Frame, HemisphereStrata};
use std::f32::consts::PI;

const SKY: Vec3 = Vec3::new(0.3, 0.4, 0.6);
const LIGHT: (Vec3, f32, Vec3) = (Vec3::new(0.3, -0.2, 1.0), 0.3, Vec3::new(12.0, 9.0, 6.0));

/// Your tracer: the radiance along the ray (p, w) and the distance to its hit (+∞: the sky).
fn trace(p: Vec3, w: Vec3) -> (Vec3, f32) {
    let (c, r, l) = LIGHT;
    let o = p - c;
    let (b, q) = (o.dot(w), o.length_squared() - r * r);
    let disc = b * b - q;
    let t = -b - disc.max(0.0).sqrt();
    if disc >= 0.0 && t > 0.0 {
        (l, t)
    } else {
        (SKY, f32::INFINITY)
    }
}

/// The exact irradiance at a floor point.
fn exact(p: Vec3) -> Vec3 {
    let (c, r, l) = LIGHT;
    let d = c - p;
    PI * SKY + (l - SKY) * PI * r * r * d.z / d.length().powi(3)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let strata = HemisphereStrata::new(16, 64)?;
    let frame = Frame::from_normal(Vec3::Z);
    // κ = 1: a record of radius R is used within R/2 of its position.
    let mut cache = IrradianceCache::<Rgb, _>::new(TabellionLamorlette::new(1.0)?);
    let grid = |i: u32, j: u32, n: u32, offset: f32| {
        let at = |k: u32| -2.0 + 4.0 * (k as f32 + offset) / n as f32;
        Vec3::new(at(i), at(j), 0.0)
    };

    // First pass: a renderer's lazy loop over the floor's [−2, 2]².
    let mut gathers = 0;
    for p in (0..64).flat_map(|j| (0..64).map(move |i| grid(i, j, 64, 0.5))) {
        if cache.covers(p, Vec3::Z) {
            continue;
        }
        // One ray per cell, through the cell's middle, as `Vec3` radiance (irr-gradients' type).
        let gather = GatherSamples::from_fn(strata, |cell| {
            trace(p, frame.to_world(strata.sample(cell, Vec2::splat(0.5))))
        })?;
        gathers += 1;
        // E and its gradients, in world space, become a record of `Rgb` (irr-cache's type).
        let world = gather
            .gradients(TranslationGradient::WardHeckbert)
            .in_world(&frame);
        let record = irr_gather_record::record::<Rgb>(p, Vec3::Z, 1.0, &world);
        // irr-cache sizes it: the gather's nearest hit, cut by the gradient limit E/‖∇E‖ and
        // clamped to the limits, then neighbour clamping.
        let inputs = RadiusInputs {
            distance: gather.min_distance(),
            limits: RadiusLimits {
                min: 0.02,
                max: 1.0,
            },
            neighbour_clamping: true,
        };
        cache.insert_with_radius(record, &inputs)?;
    }

    // Second pass: read on a finer grid and compare with the exact irradiance.
    let (mut worst, mut sum, mut count) = (0.0f32, 0.0f64, 0);
    for p in (0..200).flat_map(|j| (0..200).map(move |i| grid(i, j, 200, 0.3))) {
        let Some(read) = cache.interpolate(p, Vec3::Z) else {
            continue; // a renderer would gather here too
        };
        let error = ((Vec3::from(read.value) - exact(p)) / exact(p))
            .abs()
            .max_element();
        (worst, sum, count) = (worst.max(error), sum + f64::from(error), count + 1);
    }
    println!(
        "{gathers} gathers of {} rays made {} records; {count} of 40000 reads covered, \
         relative error mean {:.2} %, worst {:.1} %",
        strata.len(),
        cache.len(),
        100.0 * sum / f64::from(count),
        100.0 * worst
    );
    Ok(())
}
