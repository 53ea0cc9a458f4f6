//! A small open-addressing hash map from `u64` keys (slot keys) to `u32` values, for sets that grow
//! (the closure's faces, [`crate::irregular`]); fixed sorted key sets use [`crate::rankmap`].
//!
//! Only ever used for look-ups: nothing iterates over it, so no hash order can leak into the
//! output.

/// Maps distinct `u64` keys (never `u64::MAX`) to `u32` values.
#[derive(Clone, Debug, Default)]
pub(crate) struct KeyMap {
    shift: u32,
    len: usize,
    keys: Vec<u64>,
    values: Vec<u32>,
}

const EMPTY: u64 = u64::MAX;

#[inline]
fn hash(key: u64, shift: u32) -> usize {
    (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> shift) as usize
}

impl KeyMap {
    /// An empty map sized for `n` keys (load factor at most 1/2).
    pub(crate) fn with_capacity(n: usize) -> Self {
        let bits = (2 * n.max(1)).next_power_of_two().trailing_zeros().max(4);
        let cap = 1usize << bits;
        Self { shift: 64 - bits, len: 0, keys: vec![EMPTY; cap], values: vec![0; cap] }
    }

    fn grow(&mut self) {
        let old_keys = std::mem::take(&mut self.keys);
        let old_values = std::mem::take(&mut self.values);
        let mut next = Self::with_capacity(old_keys.len());
        next.len = 0;
        for (k, v) in old_keys.into_iter().zip(old_values) {
            if k != EMPTY {
                next.insert(k, v);
            }
        }
        *self = next;
    }

    /// Inserts or overwrites `key -> value`; returns whether the key was new.
    pub(crate) fn insert(&mut self, key: u64, value: u32) -> bool {
        debug_assert_ne!(key, EMPTY);
        let mask = self.keys.len() - 1;
        let mut i = hash(key, self.shift);
        loop {
            let k = self.keys[i];
            if k == key {
                self.values[i] = value;
                return false;
            }
            if k == EMPTY {
                self.keys[i] = key;
                self.values[i] = value;
                break;
            }
            i = (i + 1) & mask;
        }
        self.len += 1;
        if 2 * self.len > self.keys.len() {
            self.grow();
        }
        true
    }

    /// The value stored for `key`.
    #[inline]
    pub(crate) fn get(&self, key: u64) -> Option<u32> {
        let mask = self.keys.len() - 1;
        let mut i = hash(key, self.shift);
        loop {
            let k = self.keys[i];
            if k == key {
                return Some(self.values[i]);
            }
            if k == EMPTY {
                return None;
            }
            i = (i + 1) & mask;
        }
    }

    /// Whether `key` is present.
    #[inline]
    pub(crate) fn contains(&self, key: u64) -> bool {
        self.get(key).is_some()
    }
}
