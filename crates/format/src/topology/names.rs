//! Names and splits (spec §5.5) of modes 1 and 2: the level's name set, the sorted distinct names
//! its corners predict plus the extra names, found in linear time.

use crate::topology::NONE;

/// The sorted distinct predicted names (into `names`), and per corner the index of its name
/// (into `name_of`; `NONE` for corners without a prediction). `bounds`: the smallest and largest
/// name and the number of predicted corners, when the caller knows them (every corner predicted). Dense names go through a bitmap
/// with ranks (`bits`, `rank`: scratch); others through an LSD radix sort on 11-bit digits,
/// skipping the digits where all names agree, with (name - smallest name, corner) packed in one
/// `u64` when both fit. Linear in the corner count either way.
pub fn sort_names(
    pred: &[u64],
    bounds: Option<(u64, u64, usize)>,
    names: &mut Vec<u64>,
    name_of: &mut Vec<u32>,
    bits: &mut Vec<u64>,
    rank: &mut Vec<u32>,
) {
    let (lo, hi, n) = bounds.unwrap_or_else(|| {
        let (mut lo, mut hi) = (u64::MAX, 0u64);
        let mut n = 0usize;
        for &p in pred {
            if p != u64::MAX {
                lo = lo.min(p);
                hi = hi.max(p);
                n += 1;
            }
        }
        (lo, hi, n)
    });
    names.clear();
    name_of.clear();
    name_of.resize(pred.len(), NONE);
    if n == 0 {
        return;
    }
    if (hi - lo) / 64 < n as u64 {
        // Dense names (every generic level, lattice levels of a surface): a bitmap of the names
        // and a rank per 64-bit word; no more memory than the sort would take.
        let words = ((hi - lo) / 64 + 1) as usize;
        bits.clear();
        bits.resize(words, 0);
        for &p in pred {
            if p != u64::MAX {
                let x = p - lo;
                bits[(x / 64) as usize] |= 1 << (x % 64);
            }
        }
        rank.clear();
        rank.reserve(words);
        let mut acc = 0u32;
        for (w, &b) in bits.iter().enumerate() {
            rank.push(acc);
            acc += b.count_ones();
            let mut b = b;
            while b != 0 {
                names.push(lo + 64 * w as u64 + u64::from(b.trailing_zeros()));
                b &= b - 1;
            }
        }
        for (c, &p) in pred.iter().enumerate() {
            if p != u64::MAX {
                let x = p - lo;
                let w = (x / 64) as usize;
                name_of[c] = rank[w] + (bits[w] & ((1u64 << (x % 64)) - 1)).count_ones();
            }
        }
        return;
    }
    let kbits = 64 - (hi - lo).leading_zeros();
    let cbits = 64 - (pred.len() as u64).leading_zeros();
    if kbits + cbits <= 64 {
        let mut keys: Vec<u64> = Vec::with_capacity(n);
        for (c, &p) in pred.iter().enumerate() {
            if p != u64::MAX {
                keys.push((p - lo) << cbits | c as u64);
            }
        }
        let mut tmp = vec![0u64; n];
        radix_passes(&mut keys, &mut tmp, cbits, cbits + kbits, |x| x);
        let cmask = (1u64 << cbits) - 1;
        for &x in &keys {
            let key = (x >> cbits) + lo;
            if names.last() != Some(&key) {
                names.push(key);
            }
            name_of[(x & cmask) as usize] = names.len() as u32 - 1;
        }
    } else {
        let mut pairs: Vec<(u64, u32)> = Vec::with_capacity(n);
        for (c, &p) in pred.iter().enumerate() {
            if p != u64::MAX {
                pairs.push((p - lo, c as u32));
            }
        }
        let mut tmp = vec![(0u64, 0u32); n];
        radix_passes(&mut pairs, &mut tmp, 0, kbits, |x| x.0);
        for &(key, c) in &pairs {
            let key = key + lo;
            if names.last() != Some(&key) {
                names.push(key);
            }
            name_of[c as usize] = names.len() as u32 - 1;
        }
    }
}

/// Stable LSD radix sort of `items` by bits `from .. to` of `key(item)`, 11 bits per pass; passes
/// whose digit is the same for every item are skipped.
fn radix_passes<T: Copy>(items: &mut Vec<T>, tmp: &mut Vec<T>, from: u32, to: u32, key: impl Fn(T) -> u64) {
    let mut count = [0u32; 2048];
    let mut shift = from;
    while shift < to {
        count.fill(0);
        for &x in items.iter() {
            count[((key(x) >> shift) & 2047) as usize] += 1;
        }
        if count.iter().any(|&c| c as usize == items.len()) {
            shift += 11;
            continue;
        }
        let mut acc = 0u32;
        for c in &mut count {
            let here = *c;
            *c = acc;
            acc += here;
        }
        for &x in items.iter() {
            let d = ((key(x) >> shift) & 2047) as usize;
            tmp[count[d] as usize] = x;
            count[d] += 1;
        }
        std::mem::swap(items, tmp);
        shift += 11;
    }
}

#[cfg(test)]
mod tests {
    use super::sort_names;
    use crate::topology::NONE;

    /// [`sort_names`] on buffers that hold something already.
    fn sorted(pred: &[u64]) -> (Vec<u64>, Vec<u32>) {
        let (mut names, mut name_of) = (vec![7], vec![1, 2]);
        sort_names(pred, None, &mut names, &mut name_of, &mut vec![5; 3], &mut Vec::new());
        if !pred.is_empty() && !pred.contains(&u64::MAX) {
            // With the bounds given, as lattice levels do.
            let bounds = (*pred.iter().min().unwrap(), *pred.iter().max().unwrap(), pred.len());
            let (mut n2, mut of2) = (Vec::new(), Vec::new());
            sort_names(pred, Some(bounds), &mut n2, &mut of2, &mut Vec::new(), &mut Vec::new());
            assert_eq!((&n2, &of2), (&names, &name_of));
        }
        (names, name_of)
    }

    fn naive(pred: &[u64]) -> (Vec<u64>, Vec<u32>) {
        let mut names: Vec<u64> = pred.iter().copied().filter(|&p| p != u64::MAX).collect();
        names.sort_unstable();
        names.dedup();
        let of = pred.iter().map(|p| names.binary_search(p).map_or(NONE, |i| i as u32)).collect();
        (names, of)
    }

    #[test]
    fn names_by_bitmap_and_by_sort_agree_with_a_plain_sort() {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        for (n, spread, base) in
            [(0usize, 1u64, 0u64), (1, 1, 5), (500, 300, 0), (500, 1 << 40, 7), (300, u64::MAX - 9, 0)]
        {
            let pred: Vec<u64> =
                (0..n).map(|_| if next() % 5 == 0 { u64::MAX } else { base + next() % spread.max(1) }).collect();
            assert_eq!(sorted(&pred), naive(&pred), "n {n} spread {spread}");
        }
        assert_eq!(sorted(&[u64::MAX - 1, 0, 3, u64::MAX]), naive(&[u64::MAX - 1, 0, 3, u64::MAX]));
    }
}
