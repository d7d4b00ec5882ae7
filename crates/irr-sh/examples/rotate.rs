//! irr-sh alone: project a function on the sphere onto spherical harmonics, rotate the
//! coefficients, and check them against projecting the rotated function directly.
//!
//! The function is a polynomial of degree 3 in the direction's coordinates, so SH of order 4
//! (bands 0 to 3) hold it exactly: the two routes differ only by the quadrature's error, and the
//! rotated coefficients reconstruct the rotated function.
//!
//! Run with `cargo run -p irr-sh --example rotate`.

use glam::{DMat3, DVec3};
use irr_sh::{Basis, FastRotation, Projection, ShError, ShRotation, Taylor};
use std::f64::consts::{PI, TAU};

/// A smooth, lopsided function of the direction w: degree 3, so exactly in SH of order 4.
fn f(w: DVec3) -> f64 {
    let (a, b) = (DVec3::new(0.3, -0.5, 0.8), DVec3::new(-0.7, 0.1, 0.2));
    1.0 + w.dot(a) + 0.8 * w.dot(b).powi(2) - 0.6 * w.x * w.y * w.z
}

/// Projects `g` onto `basis` with a midpoint rule in (cos θ, φ) over the whole sphere: every
/// sample stands for the same solid angle 4π/(rows·columns).
fn project(basis: Basis, g: impl Fn(DVec3) -> f64) -> Result<Vec<f64>, ShError> {
    let (rows, columns) = (200, 400);
    let mut projection = Projection::<f64>::new(basis);
    for j in 0..rows {
        for k in 0..columns {
            let z = -1.0 + 2.0 * (j as f64 + 0.5) / rows as f64;
            let phi = TAU * (k as f64 + 0.5) / columns as f64;
            let s = (1.0 - z * z).sqrt();
            let w = DVec3::new(s * phi.cos(), s * phi.sin(), z);
            projection.add(w, 4.0 * PI / f64::from(rows * columns), g(w))?;
        }
    }
    Ok(projection.into_coefficients())
}

/// The largest absolute difference between two coefficient vectors.
fn max_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let order = 4;
    let basis = Basis::sh(order)?;
    let original = project(basis, f)?;

    for degrees in [5.0f64, 30.0, 120.0] {
        // A rotation R about an oblique axis. Rotated coefficients describe the function turned
        // by R: g(w) = f(R⁻¹·w), so a feature of f at direction d is at R·d in g.
        let axis = DVec3::new(1.0, 2.0, -0.5).normalize();
        let r = DMat3::from_axis_angle(axis, degrees.to_radians());
        let exact = ShRotation::from_dmat3(order, r)?.rotate(&original)?;
        let fast = FastRotation::from_dmat3(order, r, Taylor::Second)?.rotate(&original)?;

        // The other route: turn the function first, then project it.
        let inverse = r.transpose();
        let direct = project(basis, |w| f(inverse * w))?;

        // And read the rotated coefficients back at a few directions.
        let mut reconstruction: f64 = 0.0;
        for w in [
            DVec3::X,
            DVec3::Y,
            DVec3::Z,
            DVec3::new(-1.0, 1.0, 1.0).normalize(),
        ] {
            let read = basis.reconstruct(&exact, w)?;
            reconstruction = reconstruction.max((read - f(inverse * w)).abs());
        }
        // The midpoint rule's error is O(1/rows²) on this smooth function: ~1e-4 here.
        let difference = max_difference(&exact, &direct);
        if difference > 1e-3 || reconstruction > 1e-3 {
            return Err(format!("the routes disagree at {degrees}°: {difference:e}").into());
        }
        println!(
            "{degrees:5}°: exact rotation vs projecting the rotated function {:.1e}, \
             reconstruction error {reconstruction:.1e}; fast rotation (2nd order) {:.1e}",
            difference,
            max_difference(&fast, &direct),
        );
    }
    println!("(values of f are of order 1; the fast rotation suits small angles only)");
    Ok(())
}
