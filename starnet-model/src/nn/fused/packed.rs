//! The real point rows of a batch laid end to end. The fused featurizer works on these rather
//! than on the padded `[N, P]` slots, so a padded slot costs no product and no pass (about an
//! eighth of the slots of the quickstart's training batches; more at evaluation budgets of many
//! points per center).

use std::ops::Range;

/// Which slots of the padded `[N·P]` layout are real, and where they sit packed: center `n`'s
/// real slots, in slot order, are packed rows `starts[n]..starts[n + 1]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Packed {
    starts: Vec<usize>,
    /// Each packed row's center `[R]`.
    center: Vec<u32>,
    /// Each packed row's index in the padded layout `[R]`.
    slot: Vec<u32>,
}

impl Packed {
    /// The real slots (mask ≠ 0) of `mask` (`[N·P]`, `points` slots per center).
    pub fn from_mask(mask: &[f32], points: usize) -> Self {
        let p = points.max(1);
        let mut starts = Vec::with_capacity(mask.len() / p + 1);
        starts.push(0);
        let real = mask.iter().filter(|m| **m != 0.0).count();
        let (mut center, mut slot) = (Vec::with_capacity(real), Vec::with_capacity(real));
        for (n, m) in mask.chunks(p).enumerate() {
            for (s, _) in m.iter().enumerate().filter(|(_, m)| **m != 0.0) {
                center.push(n as u32);
                slot.push((n * p + s) as u32);
            }
            starts.push(slot.len());
        }
        Self { starts, center, slot }
    }

    /// Packed rows R.
    pub fn rows(&self) -> usize {
        self.slot.len()
    }

    /// Centers N.
    pub fn centers(&self) -> usize {
        self.starts.len() - 1
    }

    /// Center `n`'s packed rows.
    pub fn range(&self, n: usize) -> Range<usize> {
        self.starts[n]..self.starts[n + 1]
    }

    /// The center of packed row `r`.
    pub fn center_of(&self, r: usize) -> usize {
        self.center[r] as usize
    }

    /// Real points per center `[N]`.
    pub fn counts(&self) -> Vec<f32> {
        self.starts.windows(2).map(|w| (w[1] - w[0]) as f32).collect()
    }

    /// The real rows of `x` (`[N·P, cols]`), packed `[R, cols]`.
    pub fn pack(&self, x: &[f32], cols: usize) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.rows() * cols);
        for &s in &self.slot {
            let s = s as usize;
            out.extend_from_slice(&x[s * cols..(s + 1) * cols]);
        }
        out
    }

    /// [`Self::pack`]'s inverse: packed rows `x` (`[R, cols]`) back at their slots of the
    /// padded layout, zeros in the padded ones `[N·P, cols]` (`slots` = N·P).
    pub fn unpack(&self, x: &[f32], cols: usize, slots: usize) -> Vec<f32> {
        let mut out = vec![0.0; slots * cols];
        for (row, &s) in x.chunks_exact(cols.max(1)).zip(&self.slot) {
            let s = s as usize;
            out[s * cols..(s + 1) * cols].copy_from_slice(row);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packs_the_real_slots_in_order_and_unpacks_them_back() {
        // Three centers of three slots: two real, none, one real but not first.
        let mask = [1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let rows = Packed::from_mask(&mask, 3);
        assert_eq!((rows.rows(), rows.centers()), (3, 3));
        assert_eq!([rows.range(0), rows.range(1), rows.range(2)], [0..2, 2..2, 2..3]);
        assert_eq!((0..3).map(|r| rows.center_of(r)).collect::<Vec<_>>(), [0, 0, 2]);
        assert_eq!(rows.counts(), [2.0, 0.0, 1.0]);
        // Two columns per slot: slot s holds (s, 10 s).
        let x: Vec<f32> = (0..9).flat_map(|s| [s as f32, 10.0 * s as f32]).collect();
        let packed = rows.pack(&x, 2);
        assert_eq!(packed, [0.0, 0.0, 1.0, 10.0, 7.0, 70.0]);
        // Round trips: unpack(pack(x)) is x with the padded slots zeroed; pack(unpack(y)) is y.
        let masked: Vec<f32> = x.iter().enumerate().map(|(i, v)| v * mask[i / 2]).collect();
        assert_eq!(rows.unpack(&packed, 2, 9), masked);
        let y = [5.0, 4.0, 3.0, 2.0, 1.0, 0.5];
        assert_eq!(rows.pack(&rows.unpack(&y, 2, 9), 2), y);
    }
}
