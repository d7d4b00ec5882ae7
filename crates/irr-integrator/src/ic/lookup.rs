//! Reading a level of the cache: interpolation and coverage, with the leak guard.

use super::guard::Query;
use super::levels::Core;
use super::value::IcValue;
use crate::integrator::RayCounter;
use crate::scene::Scene;

impl<V: IcValue> Core<V> {
    /// The interpolated value of `level` at `q`, leak guard applied.
    pub(super) fn lookup(
        &self,
        scene: &Scene,
        level: usize,
        q: &Query,
        rays: &mut RayCounter,
    ) -> Option<V> {
        let l = &self.levels[level];
        let mut guard = 0;
        let v = l
            .cache
            .interpolate_filtered(q.p, q.ns, |id, r| {
                self.visible(scene, l, id, r, q, &mut guard)
            })
            .map(|i| i.value);
        rays.shadow += guard;
        v
    }

    /// Whether `level` covers `q`, leak guard applied.
    pub(super) fn covers(&self, scene: &Scene, level: usize, q: &Query, rays: &mut u64) -> bool {
        let l = &self.levels[level];
        l.cache
            .covers_filtered(q.p, q.ns, |id, r| self.visible(scene, l, id, r, q, rays))
    }
}
