//! Projection of a set of weighted samples onto a basis: cᵢ = Σₛ wₛ Lₛ Bᵢ(ωₛ).
//!
//! The weight wₛ is the solid angle the sample stands for (1/pdf for one sample drawn with a
//! pdf over solid angle, divided by the number of samples): the sum is then a quadrature, or a
//! Monte Carlo estimate, of cᵢ = ∫ L(ω) Bᵢ(ω) dω.

use crate::basis::Basis;
use crate::error::ShError;
use crate::value::Coefficient;
use glam::DVec3;

/// A projection in progress: add samples one at a time, read the coefficients, [`clear`] and
/// reuse the storage for the next gather (no allocation after [`Projection::new`]).
///
/// [`clear`]: Projection::clear
#[derive(Clone, Debug)]
pub struct Projection<V> {
    basis: Basis,
    coefficients: Vec<V>,
}

impl<V: Coefficient> Projection<V> {
    /// An empty projection onto `basis`: every coefficient zero.
    pub fn new(basis: Basis) -> Self {
        Self {
            basis,
            coefficients: vec![V::ZERO; basis.coefficient_count()],
        }
    }

    /// Adds `weight · value · Bᵢ(direction)` to every coefficient cᵢ. `weight` is the solid
    /// angle the sample represents. The weight and value are used as given: a NaN poisons the
    /// coefficients, as it would any sum. Errors (and adds nothing) if the direction is zero or
    /// not finite.
    pub fn add(
        &mut self,
        direction: impl Into<DVec3>,
        weight: f64,
        value: V,
    ) -> Result<(), ShError> {
        let coefficients = &mut self.coefficients;
        self.basis.visit(direction.into(), |i, y| {
            coefficients[i] = coefficients[i].add_scaled(value, weight * y);
        })
    }

    /// The basis projected onto.
    pub fn basis(&self) -> Basis {
        self.basis
    }

    /// The coefficients so far, in [`crate::index`] order.
    pub fn coefficients(&self) -> &[V] {
        &self.coefficients
    }

    /// The coefficients, consuming the projection.
    pub fn into_coefficients(self) -> Vec<V> {
        self.coefficients
    }

    /// Sets every coefficient back to zero.
    pub fn clear(&mut self) {
        self.coefficients.fill(V::ZERO);
    }
}

/// The coefficients Σₛ wₛ Lₛ Bᵢ(ωₛ) of the samples (direction ωₛ, weight wₛ = solid angle
/// represented, value Lₛ). Errors on the first invalid direction.
pub fn project<V, D>(
    basis: Basis,
    samples: impl IntoIterator<Item = (D, f64, V)>,
) -> Result<Vec<V>, ShError>
where
    V: Coefficient,
    D: Into<DVec3>,
{
    let mut projection = Projection::new(basis);
    for (direction, weight, value) in samples {
        projection.add(direction, weight, value)?;
    }
    Ok(projection.into_coefficients())
}
