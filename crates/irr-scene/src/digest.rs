//! FNV-1a, 64 bits (Fowler, Noll & Vo): the hash of cache files' fingerprints and checksums and
//! of the bytes a scene was loaded from. Each byte is XORed into the state, which is then
//! multiplied by an odd constant (a bijection modulo 2⁶⁴), so two inputs of the same length that
//! differ in one byte always hash differently.

/// An FNV-1a state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    /// Hashes `bytes` into the state.
    pub fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// Hashes `bytes` prefixed by their length, so that consecutive parts cannot run into each
    /// other ("ab" + "c" and "a" + "bc" differ).
    pub fn update_part(&mut self, bytes: &[u8]) {
        self.update(&(bytes.len() as u64).to_le_bytes());
        self.update(bytes);
    }

    /// The hash so far.
    pub fn finish(self) -> u64 {
        self.0
    }
}
