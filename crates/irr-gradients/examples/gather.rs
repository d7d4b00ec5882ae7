//! irr-gradients alone: trace a stratified hemisphere gather in a scene of your own, hand the
//! rays' radiance and hit distances to irr-gradients, and get the irradiance E, its gradients
//! and a record radius, checked against the scene's exact answers.
//!
//! The scene is analytic: a floor point p (normal +z) under a sky of radiance L_sky with a
//! spherical light (centre c, radius r, radiance L) in it. The sphere replaces the sky over its
//! solid angle, so E = π·L_sky + (L − L_sky)·π·r²·d_z/D³ with d = c − p and D = |d|, and
//! ∇E = (L − L_sky)·π·r²·(3·d_z·d/D⁵ − ẑ/D³).
//! (irr-gather-record's example goes on to make cache records of such gathers.)
//!
//! Run with `cargo run -p irr-gradients --example gather`.

use glam::{Vec2, Vec3};
use irr_gradients::{GatherSamples, TranslationGradient};
use irr_sampling::{Frame, HemisphereStrata};
use std::f32::consts::PI;

const SKY: f32 = 0.5;
const LIGHT: (Vec3, f32, f32) = (Vec3::new(0.4, -0.2, 1.2), 0.5, 8.0);

/// Your tracer: the radiance along the ray (p, w) and the distance to what it hits (+∞ for the
/// sky).
fn trace(p: Vec3, w: Vec3) -> (f32, f32) {
    let (c, r, l) = LIGHT;
    // The nearer root of |p + t·w − c|² = r² (w is unit).
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

/// The exact E at a floor point and its gradient.
fn exact(p: Vec3) -> (f32, Vec3) {
    let (c, r, l) = LIGHT;
    let (d, k) = (c - p, (l - SKY) * PI * r * r);
    let dist = d.length();
    let e = PI * SKY + k * d.z / dist.powi(3);
    (
        e,
        k * (3.0 * d.z * d / dist.powi(5) - Vec3::Z / dist.powi(3)),
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let p = Vec3::new(0.0, 0.0, 0.0);
    let frame = Frame::from_normal(Vec3::Z);
    // M×N cells in (θ, φ), cosine-weighted: each cell's ray carries the same weight π/(MN).
    let strata = HemisphereStrata::new(32, 128)?;
    // One ray per cell, through the cell's middle (a renderer jitters it). The directions are
    // in the gather's local frame (normal +z); the frame turns them to world space.
    let gather = GatherSamples::from_fn(strata, |cell| {
        let local = strata.sample(cell, Vec2::splat(0.5));
        trace(p, frame.to_world(local))
    })?;

    let (e, grad) = exact(p);
    println!("exact:            E = {e:.4}, ∇E = {grad:.4}");
    println!("gather:           E = {:.4}", gather.irradiance());
    for variant in [
        TranslationGradient::WardHeckbert,
        TranslationGradient::KrivanekGautron,
        TranslationGradient::OcclusionFan,
    ] {
        // Gradients come in the gather's local frame; `in_world` turns them with the same
        // frame that turned the ray directions.
        let world = gather.gradients(variant).in_world(&frame);
        let t = Vec3::from_array(world.translation);
        // A cache moves along the surface only: compare the gradient in the tangent plane.
        let miss = (t - grad).truncate().length() / grad.truncate().length();
        println!(
            "{:<17} ∇E = {t:.4} (tangent part off by {:.1} %)",
            format!("{variant:?}:"),
            100.0 * miss
        );
    }
    // What sizes a record: the gather's distance statistics, and the gradient's limit
    // R ≤ E/‖∇E‖ (in the tangent plane).
    let world = gather
        .gradients(TranslationGradient::WardHeckbert)
        .in_world(&frame);
    println!(
        "record radius inputs: nearest hit {:.3}, harmonic mean distance {:.3}, gradient limit {:.3}",
        gather.min_distance(),
        gather.harmonic_mean_distance(),
        world.radius_limit(Vec3::Z)
    );
    println!(
        "the gather's own relative error estimate: {:.4}",
        gather.relative_error()
    );
    Ok(())
}
