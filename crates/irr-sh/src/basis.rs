//! The two bases: real spherical harmonics over the sphere and hemispherical harmonics over the
//! upper hemisphere, evaluated for a direction.
//!
//! **Spherical harmonics** (no Condon–Shortley phase, as Ivanic & Ruedenberg 1996 use, so band
//! 1 is (y, z, x) times √(3/(4π)) and its rotation matrix is the 3×3 rotation itself, permuted):
//!
//! - Y_l^0 = K_l^0 P_l^0(cos θ),
//! - Y_l^m = √2 K_l^m P_l^m(cos θ) cos mφ for m > 0,
//! - Y_l^m = √2 K_l^|m| P_l^|m|(cos θ) sin |m|φ for m < 0,
//!
//! with K_l^m = √((2l+1)/(4π) · (l−m)!/(l+m)!). They are orthonormal over the sphere.
//!
//! **Hemispherical harmonics** (Gautron, Křivánek, Pattanaik & Bouatouch 2004, "A Novel
//! Hemispherical Basis for Accurate and Efficient Rendering", EGSR): the same with the
//! shifted functions P̃_l^m(cos θ) = P_l^m(2 cos θ − 1) and K̃_l^m = √2 K_l^m =
//! √((2l+1)/(2π) · (l−|m|)!/(l+|m|)!). The substitution t = 2 cos θ − 1 maps the hemisphere's
//! cos θ ∈ [0, 1] onto [−1, 1], so they are orthonormal over the upper hemisphere (z ≥ 0).
//! Every H_l^m with m ≠ 0 vanishes on the horizon.
//!
//! Coefficient (l, m) sits at index l² + l + m ([`index`]); order n holds bands 0..n, n²
//! coefficients.
//!
//! Evaluation: with a unit direction (x, y, z), sin^m θ cos mφ and sin^m θ sin mφ are the real
//! and imaginary parts of (x + iy)^m (Sloan 2013, "Efficient Spherical Harmonic Evaluation",
//! JCGT 2(2)), and the rest, Q̄_l^m = K_l^m P_l^m / sin^m θ, is a polynomial in cos θ computed
//! in f64 by the normalised three-term recurrences (no factorials, stable to order 32 and well
//! beyond): Q̄_0^0 = 1/√(4π), Q̄_m^m = √((2m+1)/(2m)) Q̄_{m−1}^{m−1}, Q̄_{m+1}^m = √(2m+3) t
//! Q̄_m^m, and Q̄_l^m = a (t Q̄_{l−1}^m − b Q̄_{l−2}^m) with a = √((4l²−1)/(l²−m²)) and
//! b = √(((l−1)²−m²)/(4(l−1)²−1)) (Press et al., Numerical Recipes 3rd ed., §6.7).
//!
//! For HSH, (1 − t²)^{m/2} = (2√(z(1−z)))^m replaces sin^m θ: it is the m-th power of q sin θ
//! with q = 2√(z/(1+z)), so (q(x + iy))^m gives it without dividing by sin θ.

use crate::error::{ShError, check_len, check_order};
use crate::legendre::for_each_normalised;
use crate::value::Coefficient;
use glam::DVec3;
use std::f64::consts::SQRT_2;

/// Where a basis is defined and orthonormal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Domain {
    /// Real spherical harmonics, orthonormal over the whole sphere.
    Sphere,
    /// Hemispherical harmonics, orthonormal over the upper hemisphere z ≥ 0.
    Hemisphere,
}

/// A basis of order n: bands l = 0..n of real spherical harmonics ([`Basis::sh`]) or of
/// hemispherical harmonics ([`Basis::hsh`]), n² functions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Basis {
    domain: Domain,
    order: usize,
}

/// The index of coefficient (l, m), l² + l + m. Requires |m| ≤ l.
#[inline]
pub const fn index(l: usize, m: isize) -> usize {
    debug_assert!(m.unsigned_abs() <= l);
    (l * l + l).wrapping_add_signed(m)
}

impl Basis {
    /// Real spherical harmonics of order n (bands 0..n). Errors if n = 0 or n >
    /// [`crate::MAX_ORDER`].
    pub fn sh(order: usize) -> Result<Self, ShError> {
        Self::new(Domain::Sphere, order)
    }

    /// Hemispherical harmonics of order n (bands 0..n). Errors if n = 0 or n >
    /// [`crate::MAX_ORDER`].
    pub fn hsh(order: usize) -> Result<Self, ShError> {
        Self::new(Domain::Hemisphere, order)
    }

    /// The basis of order n over `domain`.
    pub fn new(domain: Domain, order: usize) -> Result<Self, ShError> {
        Ok(Self {
            domain,
            order: check_order(order)?,
        })
    }

    /// Where the basis is orthonormal.
    #[inline]
    pub fn domain(&self) -> Domain {
        self.domain
    }

    /// The order n: the number of bands.
    #[inline]
    pub fn order(&self) -> usize {
        self.order
    }

    /// The number of functions, n².
    #[inline]
    pub fn coefficient_count(&self) -> usize {
        self.order * self.order
    }

    /// Every basis function at `direction` into `out` (n² values, in [`index`] order), computed in
    /// f64 and rounded once. The direction need not be unit: it is normalised in f64. An HSH
    /// basis evaluates a direction below the horizon (z < 0) as if z were 0.
    pub fn eval(&self, direction: impl Into<DVec3>, out: &mut [f32]) -> Result<(), ShError> {
        check_len(self.coefficient_count(), out.len())?;
        self.visit(direction.into(), |i, y| out[i] = y as f32)
    }

    /// [`Basis::eval`] in f64.
    pub fn eval_f64(&self, direction: impl Into<DVec3>, out: &mut [f64]) -> Result<(), ShError> {
        check_len(self.coefficient_count(), out.len())?;
        self.visit(direction.into(), |i, y| out[i] = y)
    }

    /// [`Basis::eval`] into a new vector.
    pub fn eval_vec(&self, direction: impl Into<DVec3>) -> Result<Vec<f32>, ShError> {
        let mut out = vec![0.0; self.coefficient_count()];
        self.eval(direction, &mut out)?;
        Ok(out)
    }

    /// The reconstruction Σᵢ cᵢ Bᵢ(direction) of the function whose coefficients are
    /// `coefficients` (n² of them), without storing the basis values.
    pub fn reconstruct<V: Coefficient>(
        &self,
        coefficients: &[V],
        direction: impl Into<DVec3>,
    ) -> Result<V, ShError> {
        check_len(self.coefficient_count(), coefficients.len())?;
        let mut sum = V::ZERO;
        self.visit(direction.into(), |i, y| {
            sum = sum.add_scaled(coefficients[i], y);
        })?;
        Ok(sum)
    }

    /// Calls `f(index, value)` once for each basis function at `direction`.
    pub(crate) fn visit(
        &self,
        direction: DVec3,
        mut f: impl FnMut(usize, f64),
    ) -> Result<(), ShError> {
        let d = unit(direction)?;
        // t: the Legendre functions' argument; scale: HSH's extra √2 (K̃ = √2 K); q: the factor
        // that turns sin θ into √(1 − t²).
        let (t, scale, q) = match self.domain {
            Domain::Sphere => (d.z, 1.0, 1.0),
            Domain::Hemisphere => {
                let z = d.z.clamp(0.0, 1.0);
                (2.0 * z - 1.0, SQRT_2, 2.0 * (z / (1.0 + z)).sqrt())
            }
        };
        let (px, py) = (q * d.x, q * d.y);
        // (c, s) = (q(x + iy))^m, advanced each time m grows (m is the outer loop).
        let (mut c, mut s, mut power) = (1.0, 0.0, 0);
        for_each_normalised(self.order, t, |l, m, p| {
            if m != power {
                (c, s) = (c * px - s * py, c * py + s * px);
                power = m;
            }
            let centre = l * l + l;
            if m == 0 {
                f(centre, scale * p);
            } else {
                let k = SQRT_2 * scale * p;
                f(centre + m, k * c);
                f(centre - m, k * s);
            }
        });
        Ok(())
    }
}

/// `direction` scaled to unit length in f64 (first by its largest component, so no finite
/// input overflows), or an error if it is zero or not finite.
pub(crate) fn unit(direction: DVec3) -> Result<DVec3, ShError> {
    let largest = direction.abs().max_element();
    if !direction.is_finite() || largest == 0.0 {
        return Err(ShError::InvalidDirection);
    }
    let d = direction / largest;
    Ok(d / d.length())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MAX_ORDER;
    use crate::testutil::{
        any_direction, gram_tolerance, hemisphere_rule, sphere_rule, value_error,
    };
    use glam::Vec3;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    /// max |Gᵢⱼ − δᵢⱼ| of the Gram matrix of `basis` under `rule`.
    fn gram_error(basis: Basis, rule: &[(DVec3, f64)]) -> f64 {
        let count = basis.coefficient_count();
        let mut gram = vec![0.0; count * count];
        let mut y = vec![0.0; count];
        for &(d, w) in rule {
            basis.eval_f64(d, &mut y).unwrap_or_else(|e| panic!("{e}"));
            for i in 0..count {
                for j in 0..=i {
                    gram[i * count + j] += w * y[i] * y[j];
                }
            }
        }
        let mut worst = 0.0f64;
        for i in 0..count {
            for j in 0..=i {
                let want = if i == j { 1.0 } else { 0.0 };
                worst = worst.max((gram[i * count + j] - want).abs());
            }
        }
        worst
    }

    #[test]
    fn sh_are_orthonormal_over_the_sphere() {
        // Yᵢ Yⱼ is a polynomial of degree l + l' ≤ 2n − 2 in cos θ (the sin^{m+m'} θ factors
        // pair up: same m, or the φ integral vanishes) times cos/sin of (m ± m')φ, |m ± m'| ≤
        // 2n − 2. n Gauss–Legendre nodes (exact to degree 2n − 1) and 2n − 1 angles (exact
        // below trigonometric degree 2n − 1) integrate it exactly.
        for n in [1, 2, 3, 5, 10, 16] {
            let rule = sphere_rule(n, 2 * n - 1);
            let error = gram_error(Basis::sh(n).unwrap_or_else(|e| panic!("{e}")), &rule);
            assert!(
                error <= gram_tolerance(rule.len(), n),
                "n={n}: Gram error {error:e}"
            );
        }
        // The rule is just enough: one node fewer misses the top band's square.
        let n = 5;
        assert!(
            gram_error(
                Basis::sh(n).unwrap_or_else(|e| panic!("{e}")),
                &sphere_rule(n - 1, 2 * n - 1)
            ) > 1e-3
        );
    }

    #[test]
    fn hsh_are_orthonormal_over_the_hemisphere() {
        // On cos θ = x ∈ [0, 1], H_l^m H_l'^m = P_l^m(t) P_l'^m(t) (t = 2x − 1) times constants:
        // (1 − t²)^m times a polynomial of degree l + l' − 2m in t, so a polynomial of degree
        // l + l' ≤ 2n − 2 in x. The same n nodes (mapped to [0, 1]) and 2n − 1 angles are exact.
        for n in [1, 2, 3, 5, 10, 16] {
            let rule = hemisphere_rule(n, 2 * n - 1);
            let error = gram_error(Basis::hsh(n).unwrap_or_else(|e| panic!("{e}")), &rule);
            assert!(
                error <= gram_tolerance(rule.len(), n),
                "n={n}: Gram error {error:e}"
            );
        }
        let n = 5;
        assert!(
            gram_error(
                Basis::hsh(n).unwrap_or_else(|e| panic!("{e}")),
                &hemisphere_rule(n - 1, 2 * n - 1)
            ) > 1e-3
        );
    }

    /// The closed forms of SH bands 0–2 (no Condon–Shortley phase), e.g. Sloan 2008, "Stupid
    /// Spherical Harmonics (SH) Tricks", GDC, with the signs of odd m flipped (no Condon–Shortley
    /// phase).
    fn sh_closed_form(d: DVec3) -> [f64; 9] {
        let (x, y, z) = (d.x, d.y, d.z);
        let c1 = (3.0 / (4.0 * PI)).sqrt();
        let c2 = 0.5 * (15.0 / PI).sqrt();
        [
            0.5 / PI.sqrt(),
            c1 * y,
            c1 * z,
            c1 * x,
            c2 * x * y,
            c2 * y * z,
            0.25 * (5.0 / PI).sqrt() * (3.0 * z * z - 1.0),
            c2 * x * z,
            0.25 * (15.0 / PI).sqrt() * (x * x - y * y),
        ]
    }

    #[test]
    fn sh_match_closed_forms_at_known_directions() {
        let basis = Basis::sh(3).unwrap_or_else(|e| panic!("{e}"));
        let mut y = [0.0; 9];
        for d in [
            DVec3::Z,
            -DVec3::Z,
            DVec3::X,
            DVec3::Y,
            DVec3::new(1.0, 2.0, 3.0).normalize(),
            DVec3::new(-0.3, 0.1, -0.9).normalize(),
        ] {
            basis.eval_f64(d, &mut y).unwrap_or_else(|e| panic!("{e}"));
            let want = sh_closed_form(d);
            for i in 0..9 {
                // Values below 1.1 from a handful of roundings: 16 ε absolute.
                assert!((y[i] - want[i]).abs() <= 16.0 * f64::EPSILON, "{d} {i}");
            }
        }
        // And at one direction by hand: (0, 0.6, 0.8) gives Y_1^{−1} = 0.6 √(3/(4π)).
        basis
            .eval_f64(DVec3::new(0.0, 0.6, 0.8), &mut y)
            .unwrap_or_else(|e| panic!("{e}"));
        assert!((y[1] - 0.6 * 0.488_602_511_902_919_9).abs() < 1e-15);
    }

    proptest! {
        #[test]
        fn sh_match_closed_forms_anywhere(d in any_direction()) {
            let mut y = [0.0; 9];
            let basis = Basis::sh(3).unwrap_or_else(|e| panic!("{e}"));
            basis.eval_f64(d, &mut y).unwrap_or_else(|e| panic!("{e}"));
            let want = sh_closed_form(d);
            for i in 0..9 {
                // As above; the direction's normalisation adds a few ε.
                prop_assert!((y[i] - want[i]).abs() <= 32.0 * f64::EPSILON);
            }
        }

        /// Unsöld's theorem (the addition theorem at equal arguments): Σ_m Y_l^m(ω)² =
        /// (2l+1)/(4π) in every band, at every direction. Cheap enough to check every order up
        /// to the cap, where the recurrences would first show instability.
        #[test]
        fn every_band_has_the_addition_theorem_norm(d in any_direction()) {
            let basis = Basis::sh(MAX_ORDER).unwrap_or_else(|e| panic!("{e}"));
            let mut y = vec![0.0; basis.coefficient_count()];
            basis.eval_f64(d, &mut y).unwrap_or_else(|e| panic!("{e}"));
            for l in 0..MAX_ORDER {
                let sum: f64 = y[l * l..(l + 1) * (l + 1)].iter().map(|v| v * v).sum();
                let want = (2 * l + 1) as f64 / (4.0 * PI);
                // Each value's error is ≤ value_error(l) ε √want, so the squares' sum moves by
                // ≤ 2 max|δ| Σ|y_m| ≤ 2 value_error(l) ε √want · √(2l+1) √want (Cauchy–Schwarz),
                // and its own rounding adds ≤ (2l+1) ε want.
                let width = (2 * l + 1) as f64;
                let tolerance = (2.0 * value_error(l) * width.sqrt() + width) * f64::EPSILON * want;
                prop_assert!(
                    (sum - want).abs() <= tolerance.max(f64::EPSILON),
                    "l={} {:e}", l, sum - want
                );
            }
        }

        /// The f32 output is the f64 one rounded once.
        #[test]
        fn f32_is_f64_rounded(d in any_direction()) {
            let basis = Basis::hsh(6).unwrap_or_else(|e| panic!("{e}"));
            let mut y64 = vec![0.0; 36];
            basis.eval_f64(d, &mut y64).unwrap_or_else(|e| panic!("{e}"));
            let y32 = basis.eval_vec(d).unwrap_or_else(|e| panic!("{e}"));
            for (a, b) in y32.iter().zip(&y64) {
                prop_assert_eq!(*a, *b as f32);
            }
        }

        /// Length does not matter; direction does.
        #[test]
        fn directions_are_normalised(d in any_direction(), scale in 1e-30f64..1e30) {
            let basis = Basis::sh(5).unwrap_or_else(|e| panic!("{e}"));
            let mut a = vec![0.0; 25];
            let mut b = vec![0.0; 25];
            basis.eval_f64(d, &mut a).unwrap_or_else(|e| panic!("{e}"));
            basis.eval_f64(d * scale, &mut b).unwrap_or_else(|e| panic!("{e}"));
            for (x, y) in a.iter().zip(&b) {
                // Normalising d·scale differs from d by a few ε; values stay below 1.4.
                prop_assert!((x - y).abs() <= 32.0 * f64::EPSILON);
            }
        }

        /// Any direction with a non-finite component is refused, and nothing panics.
        #[test]
        fn non_finite_directions_are_refused(
            v in proptest::array::uniform3(prop_oneof![
                Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY), -1.0f32..1.0
            ])
        ) {
            let v = Vec3::from_array(v);
            let basis = Basis::hsh(4).unwrap_or_else(|e| panic!("{e}"));
            let result = basis.eval_vec(v);
            if v.is_finite() && v != Vec3::ZERO {
                prop_assert!(result.is_ok());
            } else {
                prop_assert_eq!(result, Err(ShError::InvalidDirection));
            }
        }
    }

    #[test]
    fn hsh_match_closed_forms() {
        let basis = Basis::hsh(3).unwrap_or_else(|e| panic!("{e}"));
        let mut h = [0.0; 9];
        for (theta, phi) in [
            (0.0, 0.0),
            (0.3, 1.0),
            (1.2, -2.5),
            (PI / 2.0, 0.7),
            (0.9, 3.0),
        ] {
            let d = DVec3::new(
                theta.sin() * f64::cos(phi),
                theta.sin() * f64::sin(phi),
                theta.cos(),
            );
            basis.eval_f64(d, &mut h).unwrap_or_else(|e| panic!("{e}"));
            let z = theta.cos();
            let t = 2.0 * z - 1.0;
            let root = (z * (1.0 - z)).sqrt();
            // Gautron et al. 2004's definition (module docs), with P_1^1(t) = √(1−t²) = 2√(z(1−z)),
            // P_2^1(t) = 3t√(1−t²), P_2^2(t) = 3(1 − t²), and K̃_l^m as in the module docs.
            let k11 = (3.0 / (4.0 * PI)).sqrt();
            let k21 = (5.0 / (12.0 * PI)).sqrt();
            let k22 = (5.0 / (48.0 * PI)).sqrt();
            let s2 = SQRT_2;
            let want = [
                1.0 / (2.0 * PI).sqrt(),
                s2 * k11 * 2.0 * root * phi.sin(),
                (3.0 / (2.0 * PI)).sqrt() * t,
                s2 * k11 * 2.0 * root * phi.cos(),
                s2 * k22 * 3.0 * (1.0 - t * t) * (2.0 * phi).sin(),
                s2 * k21 * 3.0 * t * 2.0 * root * phi.sin(),
                (5.0 / (2.0 * PI)).sqrt() * 0.5 * (3.0 * t * t - 1.0),
                s2 * k21 * 3.0 * t * 2.0 * root * phi.cos(),
                s2 * k22 * 3.0 * (1.0 - t * t) * (2.0 * phi).cos(),
            ];
            for i in 0..9 {
                // Values below 1.6; the direction built from (θ, φ) and the closed forms each
                // round a few times: 32 ε.
                assert!(
                    (h[i] - want[i]).abs() <= 32.0 * f64::EPSILON,
                    "θ={theta} φ={phi} i={i}: {} vs {}",
                    h[i],
                    want[i]
                );
            }
        }
    }

    #[test]
    fn hsh_treat_directions_below_the_horizon_as_on_it() {
        let basis = Basis::hsh(4).unwrap_or_else(|e| panic!("{e}"));
        let below = basis
            .eval_vec(DVec3::new(0.6, 0.0, -0.8))
            .unwrap_or_else(|e| panic!("{e}"));
        let horizon = basis
            .eval_vec(DVec3::new(1.0, 0.0, 0.0))
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(below, horizon);
        // On the horizon every H_l^m with m ≠ 0 vanishes.
        for l in 0..4usize {
            for m in -(l as isize)..=l as isize {
                if m != 0 {
                    assert_eq!(horizon[index(l, m)], 0.0);
                }
            }
        }
    }

    #[test]
    fn clamped_cosine_has_ramamoorthi_hanrahans_coefficients() {
        // max(cos θ, 0) vanishes below the horizon, so integrate over z ≥ 0 only. There
        // z · Y_l^0 is a polynomial of degree l + 1 ≤ n in z: n nodes are exact. The m ≠ 0
        // coefficients vanish by the φ integral, exact with 2n − 1 angles.
        let n = 12;
        let basis = Basis::sh(n).unwrap_or_else(|e| panic!("{e}"));
        let samples = hemisphere_rule(n, 2 * n - 1);
        let c = crate::project(basis, samples.iter().map(|&(d, w)| (d, w, d.z)))
            .unwrap_or_else(|e| panic!("{e}"));
        // Ramamoorthi & Hanrahan 2001, "An Efficient Representation for Irradiance Environment
        // Maps", SIGGRAPH: Â_l = 2π ∫₀¹ z P_l(z) dz is π, 2π/3, then 0 for odd l > 1
        // and 2π (−1)^{l/2−1} / ((l+2)(l−1)) · l! / (2^l (l/2)!²) for even l; c_l0 =
        // Â_l √((2l+1)/(4π)).
        let factorial = |k: usize| (1..=k).map(|i| i as f64).product::<f64>();
        for l in 0..n {
            let a = match l {
                0 => PI,
                1 => 2.0 * PI / 3.0,
                l if l % 2 == 1 => 0.0,
                l => {
                    let sign = if (l / 2 - 1) % 2 == 0 { 1.0 } else { -1.0 };
                    2.0 * PI * sign / ((l + 2) as f64 * (l - 1) as f64) * factorial(l)
                        / (2f64.powi(l as i32) * factorial(l / 2).powi(2))
                }
            };
            let want = a * ((2 * l + 1) as f64 / (4.0 * PI)).sqrt();
            // As a Gram entry (gram_tolerance) with max(z, 0) in place of one basis function,
            // whose Σ w z² is 2π/3 instead of 1: Cauchy–Schwarz gives √(2π/3) < 2 times the
            // bound (z itself is exact to rounding).
            let tolerance = 2.0 * gram_tolerance(samples.len(), n);
            assert!(
                (c[index(l, 0)] - want).abs() <= tolerance,
                "l={l}: {} vs {want}",
                c[index(l, 0)]
            );
            for m in 1..=l as isize {
                assert!(c[index(l, m)].abs() <= tolerance);
                assert!(c[index(l, -m)].abs() <= tolerance);
            }
        }
        // The three values the literature quotes.
        assert!((c[0] - PI.sqrt() / 2.0).abs() < 1e-14);
        assert!((c[2] - (PI / 3.0).sqrt()).abs() < 1e-14);
        assert!((c[6] - (5.0 * PI).sqrt() / 8.0).abs() < 1e-14);
    }

    #[test]
    fn reconstruct_is_the_sum_of_coefficients_times_values() {
        let basis = Basis::sh(6).unwrap_or_else(|e| panic!("{e}"));
        let coefficients: Vec<f64> = (0..36).map(|i| (i as f64 * 0.37).sin()).collect();
        let d = DVec3::new(0.2, -0.5, 0.7);
        let y = {
            let mut y = vec![0.0; 36];
            basis.eval_f64(d, &mut y).unwrap_or_else(|e| panic!("{e}"));
            y
        };
        let direct: f64 = coefficients.iter().zip(&y).map(|(c, y)| c * y).sum();
        let magnitude: f64 = coefficients
            .iter()
            .zip(&y)
            .map(|(c, y)| (c * y).abs())
            .sum();
        let reconstructed = basis
            .reconstruct(&coefficients, d)
            .unwrap_or_else(|e| panic!("{e}"));
        // The same 36 products summed in two orders (reconstruct visits m outermost): each
        // sum is within 36 ε Σ|cᵢ yᵢ| of the exact one (Higham 2002, "Accuracy and Stability
        // of Numerical Algorithms", ch. 4), so they differ by at most twice that.
        assert!((reconstructed - direct).abs() <= 72.0 * f64::EPSILON * magnitude);
        assert_ne!(reconstructed, 0.0);
        // RGB: each channel is its own sum.
        let rgb: Vec<Vec3> = coefficients
            .iter()
            .map(|&c| Vec3::new(c as f32, 2.0 * c as f32, -c as f32))
            .collect();
        let r = basis.reconstruct(&rgb, d).unwrap_or_else(|e| panic!("{e}"));
        let r0 = basis
            .reconstruct(&rgb.iter().map(|v| v.x).collect::<Vec<_>>(), d)
            .unwrap_or_else(|e| panic!("{e}"));
        let r1 = basis
            .reconstruct(&rgb.iter().map(|v| v.y).collect::<Vec<_>>(), d)
            .unwrap_or_else(|e| panic!("{e}"));
        // The same f32 operations in the same order, channel by channel: identical.
        assert_eq!((r.x, r.y), (r0, r1));
    }

    #[test]
    fn bad_orders_and_lengths_are_errors() {
        assert_eq!(Basis::sh(0), Err(ShError::ZeroOrder));
        assert_eq!(Basis::hsh(0), Err(ShError::ZeroOrder));
        assert_eq!(
            Basis::sh(MAX_ORDER + 1),
            Err(ShError::OrderTooLarge {
                order: MAX_ORDER + 1
            })
        );
        assert_eq!(
            Basis::hsh(usize::MAX),
            Err(ShError::OrderTooLarge { order: usize::MAX })
        );
        assert!(Basis::sh(MAX_ORDER).is_ok());
        let basis = Basis::sh(3).unwrap_or_else(|e| panic!("{e}"));
        let mut short = [0.0f32; 8];
        assert_eq!(
            basis.eval(Vec3::Z, &mut short),
            Err(ShError::LengthMismatch {
                expected: 9,
                actual: 8
            })
        );
        assert_eq!(
            basis.reconstruct(&[0.0f32; 10], Vec3::Z),
            Err(ShError::LengthMismatch {
                expected: 9,
                actual: 10
            })
        );
        assert_eq!(basis.eval_vec(Vec3::ZERO), Err(ShError::InvalidDirection));
        assert_eq!(
            basis
                .eval_vec(DVec3::new(f64::MAX, f64::MAX, 0.0))
                .map(|v| v.len()),
            Ok(9)
        );
        // Every error has a message.
        assert!(
            ShError::OrderTooLarge { order: 40 }
                .to_string()
                .contains("32")
        );
    }

    #[test]
    fn index_is_l_squared_plus_l_plus_m() {
        assert_eq!(index(0, 0), 0);
        assert_eq!(index(1, -1), 1);
        assert_eq!(index(1, 1), 3);
        assert_eq!(index(2, -2), 4);
        assert_eq!(index(31, 31), 1023);
    }
}
