//! Reading a level of the cache: interpolation and coverage, with the leak guard.

use super::levels::Core;
use super::value::IcValue;
use crate::integrator::RayCounter;
use crate::scene::Scene;
use glam::Vec3;

impl<V: IcValue> Core<V> {
    /// The interpolated value of `level` at (p, n), leak guard applied.
    pub(super) fn lookup(
        &self,
        scene: &Scene,
        level: usize,
        p: Vec3,
        n: Vec3,
        rays: &mut RayCounter,
    ) -> Option<V> {
        let l = &self.levels[level];
        let mut guard = 0;
        let v = l
            .cache
            .interpolate_filtered(p, n, |id, r| {
                self.visible(scene, l, id, r, (p, n), &mut guard)
            })
            .map(|i| i.value);
        rays.shadow += guard;
        v
    }

    /// Whether `level` covers (p, n), leak guard applied.
    pub(super) fn covers(
        &self,
        scene: &Scene,
        level: usize,
        p: Vec3,
        n: Vec3,
        rays: &mut u64,
    ) -> bool {
        let l = &self.levels[level];
        l.cache
            .covers_filtered(p, n, |id, r| self.visible(scene, l, id, r, (p, n), rays))
    }
}
