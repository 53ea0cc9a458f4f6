//! The index of a sorted set of `u64` keys (a level's voxel codes, its face slots): key to rank,
//! answered from occupancy bitmaps of 64 consecutive keys.
//!
//! Every stage asks "is this neighbour occupied, and which voxel is it?" dozens of times per
//! voxel, face or vertex. A hash map entry per key ([`crate::keymap::KeyMap`], 12 bytes a slot
//! at load 1/2 or less: 12 MB for the 369 K voxels of the 4.3 M-point case's level 9) spreads
//! the keys of neighbouring voxels over the whole table, so nearly every look-up is a cache miss.
//! Here the keys are grouped by `key >> 6`: for Morton codes that is a 4x4x4 block of voxels
//! (for slot keys, a 2x2x2 block with its sides), of which a surface crossing the block occupies
//! many. Each occupied block is one hash entry holding its 64-bit occupancy mask and the rank of
//! its first key; a key's rank is that base plus the number of occupied codes below it in the
//! mask. The table is a few bytes per key on surface data (at most 48 bytes per key when no two
//! keys share a block), small enough to stay in cache, and the 26 neighbours of a voxel mostly
//! fall in the blocks already loaded.
//!
//! Only ever used for look-ups of a fixed, sorted key set: nothing iterates over the table, so no
//! hash order can reach the output.

use rayon::prelude::*;

/// One occupied block: 64 consecutive keys.
#[derive(Clone, Copy, Debug)]
struct Block {
    /// `key >> 6` of the block's keys, or [`EMPTY`].
    key: u64,
    /// Bit `k & 63` set for every key `k` of the block.
    mask: u64,
    /// The rank of the block's smallest key.
    base: u32,
}

/// An empty table entry (no block key has its top six bits set).
const EMPTY: u64 = u64::MAX;

const VACANT: Block = Block { key: EMPTY, mask: 0, base: 0 };

#[inline]
fn hash(key: u64, shift: u32) -> usize {
    (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> shift) as usize
}

/// Maps each key of a sorted, distinct key set to its rank (its index in the set).
#[derive(Clone, Debug)]
pub(crate) struct RankMap {
    shift: u32,
    table: Vec<Block>,
}

impl Default for RankMap {
    fn default() -> Self {
        Self::from_sorted(&[])
    }
}

impl RankMap {
    /// The map `keys[i] -> i`. `keys` must be strictly ascending (every caller's keys are: voxels
    /// and slots are kept in Morton order).
    pub(crate) fn from_sorted(keys: &[u64]) -> Self {
        debug_assert!(keys.windows(2).all(|w| w[0] < w[1]), "keys must be strictly ascending");
        // The first key of every block (the keys are sorted, so a block is a run).
        let mut firsts: Vec<u32> = Vec::new();
        if !keys.is_empty() {
            firsts.push(0);
        }
        firsts.par_extend(
            (1..keys.len()).into_par_iter().filter(|&i| keys[i] >> 6 != keys[i - 1] >> 6).map(|i| i as u32),
        );
        let blocks: Vec<Block> = (0..firsts.len())
            .into_par_iter()
            .map(|b| {
                let start = firsts[b] as usize;
                let end = firsts.get(b + 1).map_or(keys.len(), |&e| e as usize);
                let mask = keys[start..end].iter().fold(0u64, |m, &k| m | 1 << (k & 63));
                Block { key: keys[start] >> 6, mask, base: start as u32 }
            })
            .collect();
        drop(firsts);
        // Load factor at most 1/2.
        let bits = (2 * blocks.len().max(1)).next_power_of_two().trailing_zeros().max(4);
        let mut table = vec![VACANT; 1 << bits];
        let (shift, wrap) = (64 - bits, (1usize << bits) - 1);
        for b in blocks {
            let mut i = hash(b.key, shift);
            while table[i].key != EMPTY {
                i = (i + 1) & wrap;
            }
            table[i] = b;
        }
        Self { shift, table }
    }

    /// The rank of `key`, if present.
    #[inline]
    pub(crate) fn get(&self, key: u64) -> Option<u32> {
        let (block, bit) = (key >> 6, key & 63);
        let wrap = self.table.len() - 1;
        let mut i = hash(block, self.shift);
        loop {
            let b = &self.table[i];
            if b.key == block {
                return (b.mask >> bit & 1 != 0).then(|| b.base + (b.mask & ((1u64 << bit) - 1)).count_ones());
            }
            if b.key == EMPTY {
                return None;
            }
            i = (i + 1) & wrap;
        }
    }

    /// Whether `key` is present.
    #[inline]
    pub(crate) fn contains(&self, key: u64) -> bool {
        let (block, bit) = (key >> 6, key & 63);
        let wrap = self.table.len() - 1;
        let mut i = hash(block, self.shift);
        loop {
            let b = &self.table[i];
            if b.key == block {
                return b.mask >> bit & 1 != 0;
            }
            if b.key == EMPTY {
                return false;
            }
            i = (i + 1) & wrap;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every key maps to its rank, and no absent key is found, for dense, sparse and clustered
    /// sets (including block boundaries and the largest keys).
    #[test]
    fn ranks_of_present_keys_and_nothing_else() {
        let mut seed = 3u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            seed >> 11
        };
        let mut sets: Vec<Vec<u64>> = vec![
            vec![],
            vec![0],
            (0..200).collect(),
            (0..300).map(|i| i * 64 + 63).collect(),
            vec![u64::MAX - 1, u64::MAX - 64, 1 << 62],
        ];
        for spread in [70u64, 1 << 20, 1 << 50] {
            let mut v: Vec<u64> = (0..5000).map(|_| rnd() % spread).collect();
            v.sort_unstable();
            v.dedup();
            sets.push(v);
        }
        for keys in &mut sets {
            keys.sort_unstable();
            let map = RankMap::from_sorted(keys);
            for (i, &k) in keys.iter().enumerate() {
                assert_eq!(map.get(k), Some(i as u32));
                assert!(map.contains(k));
            }
            for _ in 0..5000 {
                let probe = match keys.len() {
                    0 => rnd(),
                    n => keys[rnd() as usize % n].wrapping_add(rnd() % 5).wrapping_sub(2),
                };
                let want = keys.binary_search(&probe).ok().map(|i| i as u32);
                assert_eq!(map.get(probe), want, "key {probe}");
                assert_eq!(map.contains(probe), want.is_some());
            }
        }
    }
}
