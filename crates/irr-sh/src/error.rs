//! The crate's one error type.

use std::fmt;

/// Input that the bases, projections and rotations refuse. Every fallible function returns it
/// instead of panicking.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShError {
    /// An order n = 0: a basis needs at least band 0.
    ZeroOrder,
    /// An order above [`crate::MAX_ORDER`].
    OrderTooLarge {
        /// The order asked for.
        order: usize,
    },
    /// A direction that is zero or has a non-finite component.
    InvalidDirection,
    /// A slice whose length is not the n² coefficients the operation needs.
    LengthMismatch {
        /// The length the operation needs.
        expected: usize,
        /// The length it was given.
        actual: usize,
    },
    /// A matrix that is not a rotation: a non-finite entry, columns not orthonormal within
    /// [`crate::ROTATION_TOLERANCE`], or a reflection (determinant −1).
    NotARotation,
}

impl fmt::Display for ShError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ShError::ZeroOrder => write!(f, "a harmonic basis needs an order n ≥ 1"),
            ShError::OrderTooLarge { order } => write!(
                f,
                "order {order} is above the largest supported order {}",
                crate::MAX_ORDER
            ),
            ShError::InvalidDirection => {
                write!(f, "a direction must be finite and non-zero")
            }
            ShError::LengthMismatch { expected, actual } => {
                write!(f, "expected {expected} coefficients, got {actual}")
            }
            ShError::NotARotation => write!(
                f,
                "the matrix is not a rotation (orthonormal columns, determinant +1)"
            ),
        }
    }
}

impl std::error::Error for ShError {}

/// `n` if it is a supported order, else the error saying why not.
pub(crate) fn check_order(n: usize) -> Result<usize, ShError> {
    match n {
        0 => Err(ShError::ZeroOrder),
        n if n > crate::MAX_ORDER => Err(ShError::OrderTooLarge { order: n }),
        n => Ok(n),
    }
}

/// `Ok` if `actual` is `expected`.
pub(crate) fn check_len(expected: usize, actual: usize) -> Result<(), ShError> {
    if expected == actual {
        Ok(())
    } else {
        Err(ShError::LengthMismatch { expected, actual })
    }
}
