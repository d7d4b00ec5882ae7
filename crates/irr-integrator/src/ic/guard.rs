//! The leak guard: keeps a record from lighting points it cannot see.
//!
//! [`LeakGuard::Visibility`]: each record keeps the nearest hit distance oᵢ of its whole gather
//! (horizon rays included). A query farther than oᵢ/2 from the record may have an occluder
//! between them, so a shadow ray between the two decides; closer than oᵢ/2 nothing can be
//! (every direction from pᵢ was free for at least oᵢ, up to the angular gap between sampled
//! directions, which for a wall is a factor 1/cos(gap) ≈ 1.02 at 32×128, far inside the factor
//! 2). A record on the lit side of a 1 mm wall therefore never lights the dark side.

use super::levels::{Core, Level};
use super::settings::LeakGuard;
use super::value::IcValue;
use crate::scene::Scene;
use glam::Vec3;
use irr_cache::{Record, RecordId};
use irr_geometry::Ray;

impl<V: IcValue> Core<V> {
    /// Whether record `id` of `level` may be used at (p, n): the leak guard.
    pub(super) fn visible(
        &self,
        scene: &Scene,
        level: &Level<V>,
        id: RecordId,
        record: &Record<V>,
        (p, n): (Vec3, Vec3),
        rays: &mut u64,
    ) -> bool {
        if self.settings.leak_guard == LeakGuard::Off {
            return true;
        }
        let o = level.occluder.get(id as usize).copied().unwrap_or(0.0);
        let d = (p - record.position).length();
        if d <= 0.5 * o {
            return true;
        }
        *rays += 1;
        let ray = Ray::spawn_to(record.position, record.normal, p, n);
        !scene.geometry().occluded(&ray)
    }
}
