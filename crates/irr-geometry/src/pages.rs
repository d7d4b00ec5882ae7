//! Where a wide BVH keeps its nodes, triangle packets and the packets' triangle ids: on Linux,
//! a large array goes into an anonymous mapping advised for transparent huge pages
//! (`MADV_HUGEPAGE`, through memmap2's safe API, and read back through bytemuck); otherwise,
//! and for small arrays, into a `Vec`.
//!
//! Why: a large scene's rays reach nodes and packets all over a tree of tens of megabytes, and
//! with 4-KiB pages nearly every one of those visits is also a TLB miss. The price on a small
//! scene, whose arrays stay on the heap, is the storage check, once per array per ray (and for
//! the ids once per closest hit). See docs/performance.md, huge pages.
//!
//! Huge pages are advice: where the kernel has none to give, or the mapping fails, the arrays
//! stay where they would have been. The nodes are moved onto huge pages once built, before
//! the packets are allocated, so that their heap copy is freed by then and the build's peak
//! memory does not grow.

use std::ops::Deref;

use bytemuck::AnyBitPattern;

/// Arrays of at least this many bytes go on huge pages (one huge page on x86-64: a smaller
/// array could not use one).
const HUGE_PAGE: usize = 2 << 20;

/// A type that can be written into a mapping as bytes, and read back from it as itself.
pub(crate) trait Plain: AnyBitPattern {
    /// Writes the value's bytes into `out` (`size_of::<Self>()` bytes; padding may be left as
    /// it is).
    fn write_to(&self, out: &mut [u8]);
}

/// A packet's four triangle ids (`wide.rs`).
impl Plain for [u32; 4] {
    fn write_to(&self, out: &mut [u8]) {
        out.copy_from_slice(bytemuck::bytes_of(self));
    }
}

/// A fixed-length array (see the module docs).
pub(crate) struct Pages<T> {
    storage: Storage<T>,
}

enum Storage<T> {
    Heap(Vec<T>),
    #[cfg(target_os = "linux")]
    Mapped {
        map: memmap2::MmapMut,
        len: usize,
    },
}

impl<T: Plain> Pages<T> {
    /// The elements of `v`, on the heap.
    pub(crate) fn from_vec(v: Vec<T>) -> Pages<T> {
        Pages {
            storage: Storage::Heap(v),
        }
    }

    /// The elements `f(0), f(1), …, f(len − 1)`, on huge pages if the array is large.
    pub(crate) fn from_fn(len: usize, mut f: impl FnMut(usize) -> T) -> Pages<T> {
        Pages::mapped(len, &mut f).unwrap_or_else(|| Pages::from_vec((0..len).map(f).collect()))
    }

    /// The same elements, moved onto huge pages if the array is large (the heap array is freed
    /// once they are copied); otherwise `self`, uncopied.
    pub(crate) fn onto_huge_pages(self) -> Pages<T> {
        match self.storage {
            Storage::Heap(v) => Pages::mapped(v.len(), |i| v[i]).unwrap_or(Pages::from_vec(v)),
            #[cfg(target_os = "linux")]
            mapped @ Storage::Mapped { .. } => Pages { storage: mapped },
        }
    }

    /// The elements `f(0), …, f(len − 1)` in a mapping advised for huge pages, or `None` (the
    /// array is too small, the system is not Linux, or the mapping or the advice failed).
    #[cfg_attr(not(target_os = "linux"), allow(unused_variables, unused_mut))]
    fn mapped(len: usize, mut f: impl FnMut(usize) -> T) -> Option<Pages<T>> {
        #[cfg(target_os = "linux")]
        {
            let mut map = huge_mapping(len * size_of::<T>())?;
            for (i, out) in map.chunks_exact_mut(size_of::<T>()).take(len).enumerate() {
                f(i).write_to(out);
            }
            Some(Pages {
                storage: Storage::Mapped { map, len },
            })
        }
        #[cfg(not(target_os = "linux"))]
        None
    }

    /// Whether the elements are in a mapping advised for huge pages.
    pub(crate) fn huge_pages(&self) -> bool {
        !matches!(self.storage, Storage::Heap(_))
    }
}

/// An anonymous mapping of `bytes` (at least [`HUGE_PAGE`]) advised for huge pages; `None`
/// for a smaller size, or where the mapping or the advice fails.
#[cfg(target_os = "linux")]
fn huge_mapping(bytes: usize) -> Option<memmap2::MmapMut> {
    if bytes < HUGE_PAGE {
        return None;
    }
    let map = memmap2::MmapMut::map_anon(bytes).ok()?;
    map.advise(memmap2::Advice::HugePage).ok()?;
    Some(map)
}

impl<T: Plain> Deref for Pages<T> {
    type Target = [T];

    #[inline(always)]
    fn deref(&self) -> &[T] {
        match &self.storage {
            Storage::Heap(v) => v,
            #[cfg(target_os = "linux")]
            Storage::Mapped { map, len } => bytemuck::cast_slice(&map[..len * size_of::<T>()]),
        }
    }
}

/// An empty array (on the heap), for a place to be filled later.
impl<T: Plain> Default for Pages<T> {
    fn default() -> Pages<T> {
        Pages::from_vec(Vec::new())
    }
}

impl<T: Plain> Clone for Pages<T> {
    fn clone(&self) -> Pages<T> {
        Pages::from_fn(self.len(), |i| self[i])
    }
}

impl<T: Plain> std::fmt::Debug for Pages<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pages")
            .field("len", &self.len())
            .field("huge_pages", &self.huge_pages())
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::intersect::{Tri4, TriSoa};

    /// Arrays big enough for huge pages hold exactly what they were given, and so do their
    /// clones, whichever storage they got (a kernel without transparent huge pages refuses the
    /// advice, and the array then lives in a `Vec`).
    #[test]
    fn a_huge_page_array_holds_its_elements_bit_for_bit() {
        let len = HUGE_PAGE / size_of::<Tri4>() + 3;
        let packet = |i: usize| {
            let x = i as f32;
            let tri = TriSoa::new([Vec3::new(x, 0.0, 1.0), Vec3::new(x, 1.0, 2.0), Vec3::X]);
            Tri4::new(&[tri, TriSoa::new([Vec3::ZERO, Vec3::Y, Vec3::Z * x])])
        };
        let packets = Pages::from_fn(len, packet);
        println!("huge pages: {}", packets.huge_pages());
        assert_eq!(packets.len(), len);
        let copy = packets.clone();
        let moved = Pages::from_vec((0..len).map(packet).collect()).onto_huge_pages();
        assert_eq!(moved.huge_pages(), packets.huge_pages());
        for (i, ((p, c), m)) in packets
            .iter()
            .zip(copy.iter())
            .zip(moved.iter())
            .enumerate()
        {
            let want = packet(i);
            for (got, what) in [(p, "array"), (c, "clone"), (m, "moved array")] {
                assert_eq!(
                    bytemuck::bytes_of(got),
                    bytemuck::bytes_of(&want),
                    "{what} {i}"
                );
            }
        }
        // A small array stays on the heap.
        assert!(!Pages::from_fn(3, packet).huge_pages());
    }

    /// The same for packets' triangle ids (`[u32; 4]`, written through their own `Plain`).
    #[test]
    fn a_huge_page_array_of_ids_holds_them() {
        let len = HUGE_PAGE / size_of::<[u32; 4]>() + 3;
        let ids = |i: usize| {
            let i = i as u32;
            [4 * i, 4 * i + 1, u32::MAX - i, i.reverse_bits()]
        };
        let on_pages = Pages::from_fn(len, ids);
        println!("huge pages: {}", on_pages.huge_pages());
        assert_eq!(on_pages.len(), len);
        for (i, got) in on_pages.iter().enumerate() {
            assert_eq!(*got, ids(i), "ids {i}");
        }
    }
}
