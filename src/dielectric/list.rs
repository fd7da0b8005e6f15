//! The per-ray interior list: the solids a ray is inside, each with its rank.
use crate::scene::Solid;

const INLINE: usize = 6;

/// One entry: the rank in the high half, the solid index in the low half, so
/// the entry with the highest rank is the largest key.
#[inline]
fn key(solid: u32, rank: u32) -> u64 {
    ((rank as u64) << 32) | solid as u64
}

/// The solids a ray is inside (solid indices), unordered, without a fixed cap:
/// six entries inline, more spill to the heap (counted by the caller). Each
/// entry carries its solid's rank (`Solid::rank`: priority, ties broken by
/// declaration order), so the list answers "which solid is on top" itself.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct InteriorList {
    len: u32,
    inline: [u64; INLINE],
    spill: Vec<u64>,
}

impl InteriorList {
    /// The empty list (a ray outside every solid).
    pub fn new() -> Self {
        Self::default()
    }

    /// The list of the solids `inside` (indices into `solids`, e.g. a
    /// scene's `solids` and the camera's interior).
    ///
    /// # Panics
    /// If an index is out of range of `solids`.
    pub fn from_solids(solids: &[Solid], inside: &[u32]) -> Self {
        let mut l = Self::new();
        for &s in inside {
            l.insert(s, solids[s as usize].rank);
        }
        l
    }

    /// Number of solids in the list.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// Is the ray outside every solid?
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Has this list ever needed the heap?
    pub fn spilled(&self) -> bool {
        !self.spill.is_empty()
    }

    #[inline]
    fn get(&self, i: usize) -> u64 {
        if i < INLINE {
            self.inline[i]
        } else {
            self.spill[i - INLINE]
        }
    }

    /// The entries as two slices (inline, then spilled): scanned without a
    /// branch per entry.
    #[inline]
    fn keys(&self) -> (&[u64], &[u64]) {
        (&self.inline[..self.len().min(INLINE)], &self.spill)
    }

    /// The members as a bit set (bit `s` for solid `s`), when every member's
    /// index is below 128.
    #[inline]
    pub fn member_bits(&self) -> Option<u128> {
        self.iter()
            .try_fold(0u128, |bits, s| (s < 128).then(|| bits | 1u128 << s))
    }

    /// The solid indices, in no particular order.
    pub fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        let (a, b) = self.keys();
        a.iter().chain(b).map(|&k| k as u32)
    }

    /// Is the ray inside solid `s`?
    #[inline]
    pub fn contains(&self, s: u32) -> bool {
        let (a, b) = self.keys();
        a.iter().any(|&k| k as u32 == s) || b.iter().any(|&k| k as u32 == s)
    }

    /// Add solid `s` of rank `rank` if absent (idempotent: a duplicate report
    /// of an entry is harmless).
    pub fn insert(&mut self, s: u32, rank: u32) {
        if self.contains(s) {
            return;
        }
        let n = self.len();
        if n < INLINE {
            self.inline[n] = key(s, rank);
        } else {
            self.spill.push(key(s, rank));
        }
        self.len += 1;
    }

    /// Remove `s` if present (idempotent).
    pub fn remove(&mut self, s: u32) {
        let Some(pos) = self.iter().position(|x| x == s) else {
            return;
        };
        let last = self.len() - 1;
        let lv = self.get(last);
        if pos < INLINE {
            self.inline[pos] = lv;
        } else {
            self.spill[pos - INLINE] = lv;
        }
        if last >= INLINE {
            self.spill.pop();
        }
        self.len -= 1;
    }

    /// Flip membership (the paper's toggle).
    pub fn toggle(&mut self, s: u32, rank: u32) {
        if self.contains(s) {
            self.remove(s)
        } else {
            self.insert(s, rank)
        }
    }

    /// The solid with the highest rank (the medium the ray travels in).
    #[inline]
    pub fn top(&self) -> Option<u32> {
        self.top_key().map(|k| k as u32)
    }

    #[inline]
    fn top_key(&self) -> Option<u64> {
        let (a, b) = self.keys();
        a.iter().chain(b).copied().max()
    }

    /// The highest rank in the list (the paper's P0).
    #[inline]
    pub fn top_rank(&self) -> Option<u32> {
        self.top_key().map(|k| (k >> 32) as u32)
    }

    /// Sorted solid indices (for comparisons).
    pub fn sorted(&self) -> Vec<u32> {
        let mut v: Vec<u32> = self.iter().collect();
        v.sort_unstable();
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn list_spills_without_a_cap_and_stays_a_set() {
        let mut l = InteriorList::new();
        for s in 0..50 {
            l.insert(s, 100 - s);
            l.insert(s, 100 - s);
        }
        assert_eq!(l.len(), 50);
        assert!(l.spilled());
        for s in (0..50).step_by(2) {
            l.remove(s);
        }
        assert_eq!(l.sorted(), (1..50).step_by(2).collect::<Vec<_>>());
        assert_eq!(l.top(), Some(1), "the highest rank, not the highest index");
        assert_eq!(l.top_rank(), Some(99));
        l.toggle(49, 51);
        l.toggle(0, 100);
        assert_eq!(l.top(), Some(0));
        assert!(!l.contains(49) && l.contains(0));
        let bits = l.member_bits().unwrap();
        assert!((0..50).all(|s| (bits >> s & 1 != 0) == l.contains(s)));
        l.insert(200, 1);
        assert_eq!(l.member_bits(), None, "an index past the set's width");
    }
}
