//! Known-answer tests of punctual lights and of the background, on scenes built in code.
//!
//! Tolerances follow tests.rs: Monte Carlo means within 6 standard errors (estimated from the
//! same samples), plus, where the scene is a tessellation of a curved one, a bound on what the
//! tessellation changes, derived beside the assertion. Estimators with zero variance (a single
//! punctual light seen by NEE, an open plane under a uniform background) are checked sample by
//! sample against f32 rounding bounds.

use crate::path::{ShadingPoint, sample_light};
use crate::tests::{assert_close, estimate, icosphere, polygon, polygon_irradiance, scene};
use crate::{
    IcSettings, Integrator, IrradianceCacheIntegrator, LightSample, LightSampler, Material,
    PathSettings, PathTracer, PunctualLight, Radiance, RayCounter, Scene,
};
use glam::{DVec3, Vec3};
use irr_geometry::{Geometry, Ray, SurfacePoint, TriangleMesh};
use irr_sampling::SampleKey;
use irr_sampling::rng::Dimensions;
use std::f64::consts::PI;

/// A square of half-size `s` in the plane through `c` with unit normal `n` (counter-clockwise
/// seen from `n`).
fn square(c: Vec3, n: Vec3, s: f32, material: u32) -> TriangleMesh {
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    TriangleMesh {
        positions: vec![
            c + (-u - v) * s,
            c + (u - v) * s,
            c + (u + v) * s,
            c + (-u + v) * s,
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: None,
        material_ids: vec![material; 2],
    }
}

/// A camera ray from `from` through `target`.
fn ray_to(from: Vec3, target: Vec3) -> Ray {
    Ray::new(from, (target - from).normalize())
}

/// The radiance of `integrator` along `ray` for sample `i` (dimension 0 is the pixel's).
fn li(integrator: &dyn Integrator, s: &Scene, ray: &Ray, seed: u64, i: u32) -> Vec3 {
    let key = SampleKey::new(seed, u64::from(i), 0);
    let mut rays = RayCounter::default();
    integrator.li(s, ray, &mut Dimensions::starting_at(key, 1), &mut rays)
}

/// Asserts |got − expected| ≤ tolerance per channel.
fn assert_within(what: &str, got: Vec3, expected: DVec3, tolerance: DVec3) {
    let d = (got.as_dvec3() - expected).abs();
    assert!(
        d.x <= tolerance.x && d.y <= tolerance.y && d.z <= tolerance.z,
        "{what}: got {got}, expected {expected} (tolerance {tolerance})"
    );
}

/// An integrator whose cache is empty: every shading point gathers for itself (the final pass's
/// fallback), an unbiased estimate of the indirect part (ic.rs).
fn empty_cache(s: &Scene) -> IrradianceCacheIntegrator {
    let mut ic = IrradianceCacheIntegrator::new(IcSettings {
        strata_m: 8,
        strata_n: 32,
        ..IcSettings::default()
    })
    .unwrap_or_else(|e| panic!("{e}"));
    ic.preprocess(s);
    ic
}

/// A point light of intensity I at height h over a diffuse plane of albedo ρ: the radiance of a
/// plane point at distance r, at angle θ from the normal, is (ρ/π)·I·cos θ / r², all of it
/// direct. NEE picks the only light with probability 1 and the plane sees nothing else (the
/// blocker is black: albedo 0, no emission), so every sample is that exact value, or exactly 0
/// where the blocker is between the point and the light; the indirect part is exactly 0. Both
/// integrators, sample by sample.
#[test]
fn point_light_over_a_plane() {
    let rho = Vec3::new(0.6, 0.5, 0.4);
    let intensity = Vec3::new(5.0, 3.0, 2.0);
    let light_at = Vec3::new(0.3, 1.2, -0.2);
    // A black square at half height, centred under the light, 0.2 m across: its shadow on the
    // floor is the 0.4 m square centred at the light's foot.
    let blocker = square(Vec3::new(0.3, 0.6, -0.2), Vec3::Y, 0.1, 1);
    let floor = square(Vec3::ZERO, Vec3::Y, 10.0, 0);
    let s = scene(
        &[floor, blocker],
        vec![Material::diffuse(rho), Material::diffuse(Vec3::ZERO)],
    )
    .with_lights(vec![PunctualLight::point(light_at, intensity)])
    .unwrap_or_else(|e| panic!("{e}"));
    let pt = PathTracer::default();
    let ic = empty_cache(&s);
    for (x, z) in [
        (0.3, -0.2),
        (0.45, -0.1),
        (0.7, -0.2),
        (-1.0, 0.5),
        (2.0, 3.0),
        (-6.0, -4.0),
    ] {
        let target = Vec3::new(x, 0.0, z);
        let in_shadow = (x - 0.3f32).abs() < 0.2 && (z + 0.2f32).abs() < 0.2;
        let expected = if in_shadow {
            DVec3::ZERO
        } else {
            let d = light_at.as_dvec3() - target.as_dvec3();
            let r2 = d.length_squared();
            let cos = d.y / r2.sqrt();
            rho.as_dvec3() / PI * intensity.as_dvec3() * cos / r2
        };
        // f32 rounding: the hit point (from the ray's barycentrics, accurate to a few ulps of
        // its coordinates), the direction to the light, its length and cosine, the division
        // by r² and the products with ρ/π and I: about 20 roundings of 2⁻²⁴ each, below 2e-6
        // relative; 1e-5 leaves a factor 5.
        let tolerance = expected * 1e-5;
        let ray = ray_to(Vec3::new(x - 0.7, 1.5, z + 0.9), target);
        for i in 0..16 {
            let mut rays = RayCounter::default();
            let key = SampleKey::new(21, u64::from(i), 0);
            let split = pt.li_split(&s, &ray, &mut Dimensions::starting_at(key, 1), &mut rays);
            assert_eq!(split.indirect, Vec3::ZERO);
            assert_eq!(split.emitted, Vec3::ZERO);
            assert_within(
                &format!("path tracer at ({x}, {z})"),
                split.direct,
                expected,
                tolerance,
            );
            assert_within(
                &format!("irradiance cache at ({x}, {z})"),
                li(&ic, &s, &ray, 22, i),
                expected,
                tolerance,
            );
        }
    }
}

/// A spot light at height h = 1 pointing straight down at a plane: a plane point at angle α from
/// the axis is at distance r = h / cos α and sees the light at cos θ = cos α, so its radiance is
/// (ρ/π)·I·f(α)·cos³α / h², f the falloff of the KHR_lights_punctual specification, written
/// here again from its reference code: t = clamp((cos α − cos θ_o) / (cos θ_i − cos θ_o), 0, 1),
/// f = t². Inside the inner cone f = 1, outside the outer cone the radiance is exactly 0.
#[test]
fn spot_light_cone_edge() {
    let (inner, outer) = (0.3f64, 0.5f64);
    let (ci, co) = (inner.cos(), outer.cos());
    let rho = 0.7f32;
    let intensity = 2.0f32;
    let s = scene(
        &[square(Vec3::ZERO, Vec3::Y, 10.0, 0)],
        vec![Material::diffuse(Vec3::splat(rho))],
    )
    .with_lights(vec![PunctualLight::spot(
        Vec3::Y,
        -Vec3::Y,
        Vec3::splat(intensity),
        inner as f32,
        outer as f32,
    )])
    .unwrap_or_else(|e| panic!("{e}"));
    let pt = PathTracer::default();
    for alpha in [
        0.0f64, 0.1, 0.25, 0.31, 0.35, 0.4, 0.45, 0.48, 0.52, 0.7, 1.2,
    ] {
        let target = Vec3::new(alpha.tan() as f32, 0.0, 0.0);
        // cos α of the f32 target itself (h = 1).
        let c = 1.0 / (1.0 + f64::from(target.x).powi(2)).sqrt();
        let t = ((c - co) / (ci - co)).clamp(0.0, 1.0);
        let f = t * t;
        let unfalloff = f64::from(rho) / PI * f64::from(intensity) * c * c * c;
        let expected = unfalloff * f;
        // Rounding: as for the point light (1e-5 relative), plus the falloff's sensitivity to
        // cos α: the f32 cosine differs from the exact one by the rounding of the hit point and
        // the direction, δc ≤ 1e-6 (a few ulps of O(1) values, generously), and
        // df/dc = 2t/(cos θ_i − cos θ_o), so f moves by at most 2t·δc/(cos θ_i − cos θ_o).
        let tolerance = expected * 1e-5 + unfalloff * 2.0 * t * 1e-6 / (ci - co);
        let ray = ray_to(Vec3::new(0.2, 0.5, 0.8), target);
        for i in 0..8 {
            let got = li(&pt, &s, &ray, 23, i);
            if alpha > outer {
                assert_eq!(got, Vec3::ZERO, "α = {alpha}: outside the outer cone");
            } else {
                assert_within(
                    &format!("α = {alpha}, falloff {f}"),
                    got,
                    DVec3::splat(expected),
                    DVec3::splat(tolerance),
                );
            }
        }
    }
}

/// A directional light of irradiance E⊥ (on a surface facing it) on planes tilted by β from
/// facing it: each receives E = E⊥·cos β and shows (ρ/π)·E⊥·cos β, exactly (one light, chosen
/// with probability 1, no other surface). A plane seen from its unlit side shows 0, and so
/// does the part of a plane under a blocker (a shadow ray to infinity).
#[test]
fn directional_light_on_tilted_planes() {
    let rho = Vec3::new(0.5, 0.6, 0.7);
    let e_perp = Vec3::new(3.0, 2.0, 1.0);
    let towards = Vec3::new(0.2, -1.0, 0.3).normalize();
    let pt = PathTracer::default();
    for beta_deg in [0.0f32, 30.0, 60.0, 85.0] {
        let beta = beta_deg.to_radians();
        // The plane's normal: the direction to the light, turned by β about an axis
        // perpendicular to it.
        let axis = towards.any_orthonormal_vector();
        let n = glam::Quat::from_axis_angle(axis, beta) * -towards;
        let plane = square(Vec3::ZERO, n, 2.0, 0);
        // A black blocker 5 m up-light from the point q = 1 m along the plane.
        let q = n.any_orthonormal_vector();
        let blocker = square(q - towards * 5.0, towards, 0.2, 1);
        let s = scene(
            &[plane, blocker],
            vec![Material::diffuse(rho), Material::diffuse(Vec3::ZERO)],
        )
        .with_lights(vec![PunctualLight::directional(towards, e_perp)])
        .unwrap_or_else(|e| panic!("{e}"));
        let cos = f64::from(n.dot(-towards));
        // The cosine of the constructed normal against the exact cos β: rounding of the
        // rotation (a few ulps), far inside the 1e-5 relative band of the point-light test.
        assert!((cos - f64::from(beta).cos()).abs() < 1e-6, "{cos}");
        let expected = rho.as_dvec3() / PI * e_perp.as_dvec3() * cos;
        let lit = ray_to(
            n * 1.5 + q * -0.7 + n.any_orthonormal_vector() * 0.1,
            -q * 0.5,
        );
        let unlit = ray_to(-n * 1.5 + q * 0.3, -q * 0.5);
        let shadowed = ray_to(q * 0.5 + n * 1.5, q);
        for i in 0..8 {
            assert_within(
                &format!("β = {beta_deg}°"),
                li(&pt, &s, &lit, 24, i),
                expected,
                expected * 1e-5,
            );
            assert_eq!(li(&pt, &s, &unlit, 24, i), Vec3::ZERO, "β = {beta_deg}°");
            assert_eq!(li(&pt, &s, &shadowed, 24, i), Vec3::ZERO, "β = {beta_deg}°");
        }
    }
}

/// K(x, y) = cos θx · cos θy / d², the kernel of the irradiance at x due to radiance leaving y
/// (E(x) = ∫ L(y) K(x, y) dA_y), with `nx`, `ny` the normals facing into the sphere.
fn kernel(x: DVec3, nx: DVec3, y: DVec3, ny: DVec3) -> f64 {
    let d = y - x;
    let d2 = d.length_squared();
    if d2 == 0.0 {
        return 0.0;
    }
    let cx = nx.dot(d).max(0.0);
    let cy = (-ny).dot(d).max(0.0);
    cx * cy / (d2 * d2)
}

/// A point light inside a closed diffuse sphere: the furnace with a punctual light.
///
/// # The known answer on a sphere
/// Let the sphere have radius R and albedo ρ, and the light intensity I, so flux Φ = 4πI, all of
/// which lands on the wall. Write B(y) for the radiosity (flux per area leaving y; radiance
/// B/π) and K(x, y) = cos θx cos θy / d² the exchange kernel (E(x) = ∫ L(y) K(x, y) dA_y). On a
/// sphere cos θx = cos θy = d/(2R), so K = 1/(4R²) for every pair: the irradiance at x due to
/// the light reflected by the wall is E_ind(x) = ∫ (B(y)/π) K dA_y = Φ_r/(4πR²), the same
/// everywhere, Φ_r = ∫B dA the total reflected flux. Energy balance on a closed shape:
/// everything reflected lands on the wall again, so Φ_r = ρ(Φ + Φ_r), Φ_r = ρΦ/(1 − ρ), and
///   E_ind = ρ/(1 − ρ) · Φ/(4πR²) = ρ/(1 − ρ) · I/R²,
///   L(x) = (ρ/π)·(I cos θ/r² + ρ/(1 − ρ) · I/R²),
/// the first term direct (r, θ: distance and angle to the light), the second indirect.
///
/// # On the icosphere the test renders
/// Its facets are flat, so K is not constant (its L1 deviation from the mean is a few per cent)
/// and the area A is below 4πR². What still holds exactly, for any closed convex shape:
/// Φ_r = ρΦ/(1 − ρ) (energy balance), and ∫K(x, y) dA_y = π (the form factors from x to the
/// whole wall sum to 1). Write K̄ = π/A, Ē = Φ_r/A and B = ρ(E_dir + Ē + δ), δ(y) = E_ind(y) − Ē.
/// Then (1/π)∫B·K̄ dA = Ē and (1/π)∫Ē(K − K̄) dA = 0, so
///   E_ind(x) = Ē + c₁(x) + r(x),  c₁(x) = (ρ/π)∫E_dir(y)(K(x, y) − K̄) dA_y,
///   |r(x)| = |(ρ/π)∫δ(y)(K(x, y) − K̄) dA_y| ≤ (ρ/π)·δ_max·D(x),  D(x) = ∫|K(x, y) − K̄| dA_y.
/// E_dir is known in closed form, so c₁ (first order in the facets' size) is computed; δ is
/// bounded crudely but rigorously: 0 ≤ E_ind ≤ B_max (the form factors from y sum to 1), and
/// B_max ≤ ρ(E_dir,max + B_max), so B_max ≤ ρE_dir,max/(1 − ρ) and |δ| ≤ max(B_max − Ē, Ē),
/// with E_dir,max ≤ I/d_min², d_min ≥ h_min − |c| (c the light, h_min the nearest facet
/// plane's distance from the centre). c₁, D and the check ∫K dA = π are integrated by the
/// midpoint rule on each facet cut into 64 pieces; its error is estimated by the change from 16
/// pieces to 64 and added to the band.
#[test]
fn point_light_in_a_closed_sphere() {
    let (radius, rho, intensity) = (1.0f64, 0.5f64, 1.0f64);
    let light_at = Vec3::new(0.2, -0.1, 0.15);
    let c = light_at.as_dvec3();
    let sphere = icosphere(Vec3::ZERO, radius as f32, 4, 0);
    let s = scene(
        std::slice::from_ref(&sphere),
        vec![Material::diffuse(Vec3::splat(rho as f32))],
    )
    .with_lights(vec![PunctualLight::point(
        light_at,
        Vec3::splat(intensity as f32),
    )])
    .unwrap_or_else(|e| panic!("{e}"));
    // The facets in f64, with inward unit normals (the winding faces out).
    let facets: Vec<([DVec3; 3], DVec3)> = sphere
        .indices
        .iter()
        .map(|t| {
            let p = t.map(|i| sphere.positions[i as usize].as_dvec3());
            (p, -(p[1] - p[0]).cross(p[2] - p[0]).normalize())
        })
        .collect();
    let area: f64 = facets
        .iter()
        .map(|(p, _)| 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length())
        .sum();
    let h_min = facets
        .iter()
        .map(|(p, n)| (-*n).dot(p[0]))
        .fold(f64::INFINITY, f64::min);
    let d_min = h_min - c.length();
    let b_max = rho * intensity / (d_min * d_min) / (1.0 - rho);
    let phi_r = rho * 4.0 * PI * intensity / (1.0 - rho);
    let e_bar = phi_r / area;
    let delta_max = (b_max - e_bar).max(e_bar);
    let k_bar = PI / area;
    let e_dir = |y: DVec3, n: DVec3| {
        let to_light = c - y;
        intensity * n.dot(to_light).max(0.0) / to_light.length().powi(3)
    };
    // The midpoint rule on each facet cut 4^levels ways: (∫K, c₁, D) at x.
    let integrals = |x: DVec3, nx: DVec3, levels: u32| -> (f64, f64, f64) {
        let mut sums = (0.0, 0.0, 0.0);
        for (p, ny) in &facets {
            let mut tris = vec![*p];
            for _ in 0..levels {
                tris = tris
                    .iter()
                    .flat_map(|[a, b, c]| {
                        let (ab, bc, ca) = ((*a + *b) * 0.5, (*b + *c) * 0.5, (*c + *a) * 0.5);
                        [[*a, ab, ca], [ab, *b, bc], [ca, bc, *c], [ab, bc, ca]]
                    })
                    .collect();
            }
            for [a, b, c] in tris {
                let y = (a + b + c) / 3.0;
                let da = 0.5 * (b - a).cross(c - a).length();
                let k = kernel(x, nx, y, *ny);
                sums.0 += k * da;
                sums.1 += e_dir(y, *ny) * (k - k_bar) * da;
                sums.2 += (k - k_bar).abs() * da;
            }
        }
        (sums.0, rho / PI * sums.1, sums.2)
    };
    let origin = Vec3::new(-0.1, 0.2, 0.0);
    let pt = PathTracer::new(PathSettings::default());
    for (which, facet) in [0usize, 900, 2611, 4400].into_iter().enumerate() {
        let (p, n_in) = facets[facet];
        let x = (p[0] + p[1] + p[2]) / 3.0;
        let d = (x - c).length();
        let direct = rho / PI * intensity * n_in.dot(c - x) / d.powi(3);
        let (k_total, c1, deviation) = integrals(x, n_in, 3);
        let (k_coarse, c1_coarse, _) = integrals(x, n_in, 2);
        // The quadrature is sound: ∫K dA = π to within what the finer rule changes (and 1e-3).
        assert!(
            (k_total - PI).abs() < 1e-3 + 2.0 * (k_total - k_coarse).abs(),
            "∫K = {k_total} (16 pieces: {k_coarse})"
        );
        let expected = direct + rho / PI * (e_bar + c1);
        let remainder = rho / PI * (rho / PI * delta_max * deviation);
        let quadrature = rho / PI * (c1 - c1_coarse).abs();
        let ray = ray_to(origin, x.as_vec3());
        let mut direct_seen = Vec3::ZERO;
        let est = estimate(50_000, |i| {
            let key = SampleKey::new(25, u64::from(i), which as u64);
            let mut rays = RayCounter::default();
            let split = pt.li_split(&s, &ray, &mut Dimensions::starting_at(key, 1), &mut rays);
            direct_seen = split.direct;
            split.total()
        });
        // The direct part has zero variance (one light, always chosen, always visible inside
        // the convex shape): exact to the rounding bound of the point-light test.
        assert!(
            (f64::from(direct_seen.x) - direct).abs() <= direct * 1e-5,
            "facet {facet}: direct {direct_seen} vs {direct}"
        );
        println!(
            "facet {facet}: mean {:.5} ± {:.1e}, expected {expected:.5} (direct {direct:.5}, \
             indirect on a true sphere {:.5}, on the icosphere {:.5}), remainder bound \
             {remainder:.1e}, quadrature {quadrature:.1e}",
            est.0,
            est.1,
            rho / PI * rho / (1.0 - rho) * intensity / (radius * radius),
            rho / PI * (e_bar + c1),
        );
        // Within 6 standard errors (tests.rs) plus the remainder and quadrature bounds above.
        let band = 6.0 * est.1 + remainder + quadrature;
        assert!(
            (est.0 - expected).abs() < band,
            "facet {facet}: mean {} vs expected {expected} (band ±{band})",
            est.0
        );
    }
}

/// An area light (a 64-gon) and a point light over a plane together: the plane's radiance is the
/// sum of what each gives alone, (ρ/π)·(E_polygon + I cos θ/r²). The light sampler now splits
/// its samples between them by power, and the area light's MIS weights use the shared
/// distribution: a wrong choice probability on either side would bias the sum.
#[test]
fn area_and_point_lights_add_up() {
    let (l, r, h, rho) = (5.0f32, 0.5f32, 1.0f32, 0.6f32);
    let light = polygon(Vec3::new(0.0, h, 0.0), r, 64, -1.0, 1);
    let vertices: Vec<Vec3> = light.positions[1..].to_vec();
    let floor = square(Vec3::ZERO, Vec3::Y, 10.0, 0);
    let point_at = Vec3::new(1.0, 0.8, 0.5);
    let intensity = 1.5f32;
    let s = scene(
        &[floor, light],
        vec![
            Material::diffuse(Vec3::splat(rho)),
            Material::emitter(Vec3::splat(l)),
        ],
    )
    .with_lights(vec![PunctualLight::point(point_at, Vec3::splat(intensity))])
    .unwrap_or_else(|e| panic!("{e}"));
    let d = point_at.as_dvec3();
    let e_point = f64::from(intensity) * d.y / d.length().powi(3);
    let expected = f64::from(rho) / PI * (polygon_irradiance(&vertices, f64::from(l)) + e_point);
    let origin = Vec3::new(3.0 * r, 0.5 * h, 0.0);
    let ray = ray_to(origin, Vec3::ZERO);
    let pt = PathTracer::default();
    let est = estimate(20_000, |i| li(&pt, &s, &ray, 26, i));
    assert_close("disk and point light", est, expected);
}

/// Placed emitters light as their closed form: one emitting square, stored once as a
/// prototype, placed twice (turned to face the floor, one placement with a brighter material
/// of its own) over a floor point. The floor's radiance is (ρ/π)·(E₁ + E₂), each E the
/// square's polygon irradiance at its placed vertices. The light sampler must find the placed
/// triangles (their world areas and normals), choose them by power, and give their density to
/// MIS when a BSDF sample hits one; a placed copy missed, or an area taken in object space
/// (the placements scale by 0.5), biases the sum. The same in a scene of world-space copies.
#[test]
fn placed_emitters_light_as_their_closed_form() {
    use glam::{DAffine3, DQuat, DVec3};
    use irr_geometry::Instance;
    let (l1, l2, rho) = (4.0f32, 7.0f32, 0.6f32);
    // A unit square facing +z in object space, placed facing -y at height 1.
    let prototype = square(Vec3::ZERO, Vec3::Z, 0.5, 1);
    let place = |x: f64, material_id| Instance {
        prototype: 0,
        to_world: DAffine3::from_scale_rotation_translation(
            DVec3::splat(0.5),
            DQuat::from_rotation_x(std::f64::consts::FRAC_PI_2),
            DVec3::new(x, 1.0, 0.2),
        ),
        material_id,
    };
    let instances = [place(-0.6, None), place(0.7, Some(2))];
    let floor = square(Vec3::ZERO, Vec3::Y, 10.0, 0);
    let materials = || {
        vec![
            Material::diffuse(Vec3::splat(rho)),
            Material::emitter(Vec3::splat(l1)),
            Material::emitter(Vec3::splat(l2)),
        ]
    };
    let placed = Geometry::build_instanced(vec![floor.clone()], vec![prototype], &instances)
        .unwrap_or_else(|e| panic!("{e}"));
    // The placed triangles as world-space copies (the same ids).
    let mut copies = vec![floor];
    for id in 2..placed.triangle_count() as u32 {
        let t = placed.triangle(id);
        copies.push(TriangleMesh {
            positions: t.p.to_vec(),
            indices: vec![[0, 1, 2]],
            normals: None,
            material_ids: vec![t.material_id],
        });
    }
    let mut expected = 0.0;
    for (k, le) in [(2u32, l1), (4, l2)] {
        // Both triangles of a placement: their four distinct vertices, in order.
        let [a, b, c] = placed.triangle(k).p;
        let d = placed.triangle(k + 1).p[2];
        assert!(placed.geometric_normal(k).y < -0.99, "faces the floor");
        expected += polygon_irradiance(&[a, b, c, d], f64::from(le));
    }
    let expected = f64::from(rho) / PI * expected;
    let ray = ray_to(Vec3::new(0.0, 0.5, 3.0), Vec3::ZERO);
    let pt = PathTracer::default();
    for (what, geometry) in [
        ("placed", placed),
        (
            "copied",
            Geometry::build(&copies).unwrap_or_else(|e| panic!("{e}")),
        ),
    ] {
        let s = Scene::new(geometry, materials()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.emitter_count(), 4, "{what}");
        let est = estimate(20_000, |i| li(&pt, &s, &ray, 31, i));
        assert_close(what, est, expected);
    }
}

/// The light sampler holds at most `irr_scene::BYTES_PER_EMITTER` an emitting triangle (the
/// figure the loader's memory check charges): 3000 placed emitters of a 2-triangle square,
/// whose ids no dense table covers.
#[test]
fn the_light_samplers_bytes_per_emitter_stay_under_their_bound() {
    use glam::{DAffine3, DVec3};
    use irr_geometry::Instance;
    let instances: Vec<Instance> = (0..3000)
        .map(|k| Instance {
            prototype: 0,
            to_world: DAffine3::from_translation(DVec3::new(f64::from(k), 2.0, 0.0)),
            material_id: None,
        })
        .collect();
    let geometry = Geometry::build_instanced(
        vec![square(Vec3::ZERO, Vec3::Y, 1.0, 0)],
        vec![square(Vec3::ZERO, -Vec3::Y, 0.4, 1)],
        &instances,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let materials = [
        Material::diffuse(Vec3::splat(0.5)),
        Material::emitter(Vec3::ONE),
    ];
    let sampler = LightSampler::new(&geometry, &materials);
    assert_eq!(sampler.len(), 6000);
    let per = sampler.heap_bytes() as f64 / 6000.0;
    assert!(
        per <= irr_scene::BYTES_PER_EMITTER as f64,
        "{per} bytes an emitter"
    );
}

/// The light sampler chooses every light with probability proportional to its power: a
/// triangle's π·A·s·Le and the punctual lights' (point 4πI, spot 2πI((1 − cos θ_i) +
/// (cos θ_i − cos θ_o)/3), directional πr²E with r the scene's bounding radius); the
/// probabilities sum to 1 and a light of zero power is left out.
#[test]
fn light_sampler_chooses_by_power() {
    let floor = square(Vec3::ZERO, Vec3::Y, 2.0, 0);
    let emitter = square(Vec3::new(0.0, 1.0, 0.0), -Vec3::Y, 0.5, 1);
    let materials = vec![
        Material::diffuse(Vec3::splat(0.5)),
        Material::emitter(Vec3::splat(2.0)),
    ];
    let geometry = Geometry::build(&[floor, emitter]).unwrap_or_else(|e| panic!("{e}"));
    let (lo, hi) = geometry.bounds();
    let scene_radius = 0.5 * f64::from((hi - lo).length());
    let lights = [
        PunctualLight::point(Vec3::Y, Vec3::new(1.0, 2.0, 3.0)),
        PunctualLight::point(Vec3::Y, Vec3::ZERO),
        PunctualLight::spot(Vec3::Y, -Vec3::Y, Vec3::splat(4.0), 0.2, 0.6),
        PunctualLight::directional(-Vec3::Y, Vec3::splat(0.5)),
    ];
    let sampler = LightSampler::with_punctual(&geometry, &materials, &lights);
    assert_eq!(
        sampler.len(),
        2 + 3,
        "two triangles and three lights of non-zero power"
    );
    assert_eq!(sampler.punctual_count(), 3);
    // The emitter: area 1 (a 1 m square), one side, Le = 2: Φ = 2π.
    let powers = [
        2.0 * PI,
        4.0 * PI * 2.0,
        2.0 * PI * 4.0 * ((1.0 - 0.2f64.cos()) + (0.2f64.cos() - 0.6f64.cos()) / 3.0),
        PI * scene_radius * scene_radius * 0.5,
    ];
    let total: f64 = powers.iter().sum();
    let mut sum = 0.0f64;
    for id in 0..geometry.triangle_count() as u32 {
        sum += f64::from(sampler.pdf_area(id) * geometry.triangle(id).area());
    }
    // f32 probabilities and areas: a few roundings of 2⁻²⁴ each, 1e-6 relative.
    assert!((sum - powers[0] / total).abs() < 1e-6, "{sum}");
    for (i, p) in powers[1..].iter().enumerate() {
        let got = f64::from(sampler.punctual_probability(i));
        assert!(
            (got - p / total).abs() < 1e-6,
            "light {i}: {got} vs {}",
            p / total
        );
        sum += got;
    }
    assert!((sum - 1.0).abs() < 1e-6, "{sum}");
    assert_eq!(sampler.punctual_probability(3), 0.0);
    // Sampling follows the same distribution: the choice of u ∈ [0, 1) on a fine grid lands on
    // each entry a fraction of the time equal to its probability, to the grid's resolution.
    let n = 100_000;
    let mut counts = [0usize; 4];
    for k in 0..n {
        let u = (k as f32 + 0.5) / n as f32;
        match sampler.sample(&geometry, u, glam::Vec2::splat(0.5)) {
            Some(LightSample::Area { .. }) => counts[0] += 1,
            Some(LightSample::Punctual { light, .. }) => {
                let i = lights[..]
                    .iter()
                    .filter(|l| l.power(1.0) > 0.0)
                    .position(|l| *l == light)
                    .unwrap_or_else(|| panic!("unknown light"));
                counts[1 + i] += 1;
            }
            None => panic!("no light"),
        }
    }
    for (i, c) in counts.iter().enumerate() {
        // A grid of n points: each interval's count is its length · n ± 1, and the cdf's f32
        // rounding moves a boundary by 1e-7 (≪ 1/n).
        let expected = powers[i] / total * n as f64;
        assert!(
            (*c as f64 - expected).abs() <= 2.0,
            "entry {i}: {c} vs {expected}"
        );
    }
}

/// Determinism: next-event estimation draws the same dimensions of the sample's key (a 1-D draw
/// for the choice, a 2-D draw for the point: two positions of the cursor) whatever light it
/// picks, so the dimensions after it (the BSDF sample, roulette) never shift with the light
/// chosen.
#[test]
fn nee_draws_the_same_dimensions_for_every_light() {
    let floor = square(Vec3::ZERO, Vec3::Y, 2.0, 0);
    let emitter = square(Vec3::new(0.0, 1.0, 0.0), -Vec3::Y, 0.5, 1);
    let s = scene(
        &[floor, emitter],
        vec![
            Material::diffuse(Vec3::splat(0.5)),
            Material::emitter(Vec3::splat(2.0)),
        ],
    )
    .with_lights(vec![
        PunctualLight::point(Vec3::new(0.5, 0.5, 0.5), Vec3::splat(3.0)),
        PunctualLight::spot(Vec3::Y, -Vec3::Y, Vec3::splat(4.0), 0.2, 0.6),
        PunctualLight::directional(-Vec3::Y, Vec3::splat(0.5)),
    ])
    .unwrap_or_else(|e| panic!("{e}"));
    // From under the emitter (at y = 1), to the floor.
    let ray = ray_to(Vec3::new(1.5, 0.5, 0.3), Vec3::new(0.1, 0.0, -0.2));
    let hit = s
        .geometry()
        .intersect(&ray)
        .unwrap_or_else(|| panic!("no hit"));
    let surface = s.geometry().surface(&ray, &hit);
    assert_eq!(surface.position.y, 0.0, "the ray must hit the floor");
    let x = ShadingPoint::new(&surface, -ray.direction);
    let mut kinds = [0usize; 2];
    for i in 0..2_000u32 {
        let mut dims = Dimensions::starting_at(SampleKey::new(27, u64::from(i), 0), 1);
        let before = dims.position();
        let mut rays = RayCounter::default();
        let arrival = sample_light(&s, &x, &mut dims, &mut rays);
        assert_eq!(dims.position(), before + 2, "sample {i}");
        if let Some(a) = arrival {
            kinds[usize::from(a.delta)] += 1;
        }
    }
    assert!(kinds[0] > 0 && kinds[1] > 0, "{kinds:?}");
}

/// An open plane under a constant background L: every direction above it sees L, so its
/// irradiance is πL and its radiance (ρ/π)·πL = ρL, from either side (reflection is two-sided).
/// The path tracer's cosine sample always escapes and brings back ρ·L with weight 1: every
/// sample is ρL to one rounding, carried by `indirect` (the background's light, module docs of
/// path.rs). The irradiance cache's gather sums M·N cells of π/(M·N)·L: ρL to the rounding of
/// that sum (N·M = 256 terms of 2⁻²⁴ relative each at most: 2e-5; it is summed in f64, far
/// less). A camera ray that misses sees L itself, in `emitted`.
#[test]
fn open_plane_under_a_constant_background() {
    let rho = Vec3::new(0.8, 0.6, 0.4);
    let background = Vec3::new(0.2, 0.5, 1.0);
    let s = scene(
        &[square(Vec3::ZERO, Vec3::Y, 1.0, 0)],
        vec![Material::diffuse(rho)],
    )
    .with_background(background)
    .unwrap_or_else(|e| panic!("{e}"));
    let expected = (rho * background).as_dvec3();
    let pt = PathTracer::default();
    let ic = empty_cache(&s);
    for (from, to) in [
        (Vec3::new(0.5, 1.0, 0.3), Vec3::new(0.1, 0.0, -0.2)),
        (Vec3::new(-2.0, 0.2, 0.0), Vec3::new(0.3, 0.0, 0.4)),
        (Vec3::new(0.3, -1.0, 0.2), Vec3::new(-0.5, 0.0, 0.5)),
    ] {
        let ray = ray_to(from, to);
        for i in 0..16u32 {
            let key = SampleKey::new(28, u64::from(i), 0);
            let mut rays = RayCounter::default();
            let split = pt.li_split(&s, &ray, &mut Dimensions::starting_at(key, 1), &mut rays);
            assert_eq!(split.emitted, Vec3::ZERO);
            assert_eq!(split.direct, Vec3::ZERO);
            assert_within("path tracer", split.indirect, expected, expected * 1e-6);
            let split = ic.li_split(&s, &ray, &mut Dimensions::starting_at(key, 1), &mut rays);
            assert_eq!(split.direct, Vec3::ZERO);
            assert_within(
                "irradiance cache",
                split.indirect,
                expected,
                expected * 2e-5,
            );
        }
    }
    let miss = Ray::new(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.3, 1.0, 0.0));
    for integrator in [&pt as &dyn Integrator, &ic] {
        assert_eq!(li(integrator, &s, &miss, 29, 0), background);
    }
}

/// A scene refuses lights and backgrounds it cannot render, naming the light.
#[test]
fn scene_refuses_bad_lights_and_backgrounds() {
    let make = || {
        scene(
            &[square(Vec3::ZERO, Vec3::Y, 1.0, 0)],
            vec![Material::diffuse(Vec3::ONE)],
        )
    };
    let e = make()
        .with_lights(vec![
            PunctualLight::point(Vec3::Y, Vec3::ONE),
            PunctualLight::point(Vec3::Y, Vec3::new(1.0, -1.0, 0.0)),
        ])
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(e.starts_with("punctual light 1: its strength"), "{e}");
    for bad in [
        Vec3::new(0.0, -1.0, 0.0),
        Vec3::splat(f32::NAN),
        Vec3::splat(f32::INFINITY),
    ] {
        let e = make().with_background(bad).err();
        assert!(
            matches!(e, Some(crate::SceneError::InvalidBackground { .. })),
            "{bad}: {e:?}"
        );
    }
    assert_eq!(make().background(), Vec3::ZERO);
}

/// The bits of a radiance split, for exact comparisons.
fn bits(r: &Radiance) -> [[u32; 3]; 3] {
    [r.emitted, r.direct, r.indirect].map(|v| v.to_array().map(f32::to_bits))
}

/// Checks that `li_many` answers `rays` as `li` does alone (the same bits, each ray's
/// dimensions left where `li` leaves them, the same rays counted), and that `reflected_many`
/// answers the camera rays' first surfaces as `reflected` does: the batched paths themselves,
/// which `li_many` takes only where the geometry streams. `fresh(i)` makes ray `i`'s dimensions.
fn check_batched_paths(
    pt: &PathTracer,
    s: &Scene,
    rays: &[Ray],
    fresh: impl Fn(usize) -> Dimensions,
) -> Result<(), String> {
    let mut dims: Vec<Dimensions> = (0..rays.len()).map(&fresh).collect();
    let mut out = vec![Vec3::NAN; rays.len()];
    let mut counted = RayCounter::default();
    pt.li_many(s, rays, &mut dims, &mut out, &mut counted);
    let mut alone = RayCounter::default();
    for (i, ray) in rays.iter().enumerate() {
        let mut d = fresh(i);
        let want = pt.li(s, ray, &mut d, &mut alone);
        let same =
            |a: Vec3, b: Vec3| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits);
        if !same(out[i], want) || dims[i].next_1d().to_bits() != d.next_1d().to_bits() {
            return Err(format!("li_many, ray {i}: {} against {want}", out[i]));
        }
    }
    if counted != alone {
        return Err(format!("li_many counted {counted:?}, li {alone:?}"));
    }
    let starts: Vec<(SurfacePoint, Vec3)> = rays
        .iter()
        .filter_map(|r| {
            let hit = s.geometry().intersect(r)?;
            Some((s.geometry().surface(r, &hit), -r.direction.normalize()))
        })
        .collect();
    let mut dims: Vec<Dimensions> = (0..starts.len()).map(&fresh).collect();
    let mut out = vec![Radiance::default(); starts.len()];
    let mut counted = RayCounter::default();
    pt.reflected_many(s, &starts, &mut dims, &mut out, &mut counted);
    let mut alone = RayCounter::default();
    for (i, (surface, wo)) in starts.iter().enumerate() {
        let mut d = fresh(i);
        let want = pt.reflected(s, surface, *wo, &mut d, &mut alone);
        if bits(&out[i]) != bits(&want) || dims[i].next_1d().to_bits() != d.next_1d().to_bits() {
            return Err(format!(
                "reflected_many, start {i}: {:?} against {want:?}",
                out[i]
            ));
        }
    }
    if counted != alone {
        return Err(format!(
            "reflected_many counted {counted:?}, reflected {alone:?}"
        ));
    }
    Ok(())
}

/// `li_many` where the geometry streams (a scene larger than the caches: inside an icosphere of
/// 20 480 triangles, lit by a point light), for 200 camera rays: exactly `li`'s answers.
#[test]
fn li_many_on_a_large_scene_answers_as_li() {
    let shell = icosphere(Vec3::ZERO, 2.0, 5, 0);
    let ball = icosphere(Vec3::new(0.3, -0.5, 0.2), 0.5, 2, 1);
    let s = scene(
        &[shell, ball],
        vec![
            Material::diffuse(Vec3::new(0.7, 0.6, 0.5)),
            Material::diffuse(Vec3::splat(0.3)),
        ],
    )
    .with_lights(vec![PunctualLight::point(
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::splat(2.0),
    )])
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(s.geometry().streams(), "the scene is too small to stream");
    let pt = PathTracer::default();
    let rays: Vec<Ray> = (0..200)
        .map(|i| {
            let u = SampleKey::new(31, i, 0).uniform_2d(0);
            let d = Vec3::new(2.0 * u.x - 1.0, -1.0, 2.0 * u.y - 1.0);
            Ray::new(Vec3::new(0.0, 0.5, 0.0), d.normalize())
        })
        .collect();
    let fresh = |i: usize| Dimensions::starting_at(SampleKey::new(32, i as u64, 0), 1);
    check_batched_paths(&pt, &s, &rays, fresh).unwrap_or_else(|e| panic!("{e}"));
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]

    /// The path tracer's batched paths (`reflected_many`: traced together, a bounce at a time)
    /// and `li_many` answer every ray exactly as `reflected` and `li` do alone: the same bits,
    /// each ray's dimensions left where those leave them (the next draw is the same), and the
    /// same rays counted (`check_batched_paths`). In a half-open box
    /// with an area light, a point light, a black block and a background, so that paths end in
    /// every way (escaping, at the depth limit, on a black surface, by roulette), for camera
    /// rays that hit and miss, at two depth limits, for batches of any length.
    #[test]
    fn li_many_answers_as_li(seed in 0u64..1 << 20, len in 0usize..48, shallow: bool) {
        let floor = square(Vec3::ZERO, Vec3::Y, 1.0, 0);
        let back = square(Vec3::new(0.0, 1.0, -1.0), Vec3::Z, 1.0, 0);
        let side = square(Vec3::new(-1.0, 1.0, 0.0), Vec3::X, 1.0, 0);
        let light = polygon(Vec3::new(0.0, 1.9, 0.0), 0.3, 8, -1.0, 1);
        let ball = icosphere(Vec3::new(0.3, 0.3, 0.2), 0.3, 1, 0);
        let block = square(Vec3::new(-0.4, 0.2, 0.3), Vec3::new(0.3, 1.0, 0.2).normalize(), 0.2, 2);
        let s = scene(
            &[floor, back, side, light, ball, block],
            vec![
                Material::diffuse(Vec3::new(0.8, 0.6, 0.4)),
                Material::emitter(Vec3::splat(4.0)),
                Material::diffuse(Vec3::ZERO),
            ],
        )
        .with_lights(vec![PunctualLight::point(Vec3::new(0.5, 1.2, 0.5), Vec3::splat(0.8))])
        .and_then(|s| s.with_background(Vec3::new(0.1, 0.2, 0.3)))
        .unwrap_or_else(|e| panic!("{e}"));
        let pt = PathTracer::new(PathSettings {
            max_depth: if shallow { 2 } else { 64 },
            ..PathSettings::default()
        });
        let k = SampleKey::new(seed, 0, 0);
        let rays: Vec<Ray> = (0..len as u32)
            .map(|i| {
                let u = k.uniform_2d(i);
                let target = Vec3::new(2.0 * u.x - 1.0, 0.0, 2.0 * u.y - 1.0);
                // Every fifth ray looks up and away, into the background.
                let from = if i % 5 == 4 {
                    Vec3::new(0.0, 0.5, 0.5)
                } else {
                    Vec3::new(0.2, 1.5, 2.0)
                };
                let to = if i % 5 == 4 { Vec3::new(0.0, 3.0, 3.0) } else { target };
                ray_to(from, to)
            })
            .collect();
        let fresh = |i: usize| Dimensions::starting_at(SampleKey::new(seed, 1 + i as u64, 7), 1);
        check_batched_paths(&pt, &s, &rays, fresh)
            .map_err(proptest::test_runner::TestCaseError::fail)?;
    }
}
