//! Lists of lists in two flat arrays (compressed sparse rows), built by a counting sort.

/// A compressed list of lists (CSR): `items[start[i]..start[i + 1]]` for list `i`.
#[derive(Clone, Debug, Default)]
pub struct Lists<T> {
    pub start: Vec<u32>,
    pub items: Vec<T>,
}

impl<T: Copy + Default> Lists<T> {
    /// The lists of `n` keys from (key, item) pairs, each list in the order given.
    pub fn from_pairs(n: usize, pairs: impl Iterator<Item = (u32, T)> + Clone) -> Self {
        let mut start = vec![0u32; n + 1];
        for (k, _) in pairs.clone() {
            start[k as usize + 1] += 1;
        }
        for i in 0..n {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut items = vec![T::default(); start[n] as usize];
        for (k, v) in pairs {
            items[fill[k as usize] as usize] = v;
            fill[k as usize] += 1;
        }
        Lists { start, items }
    }

    /// List `i`.
    pub fn of(&self, i: u32) -> &[T] {
        &self.items[self.start[i as usize] as usize..self.start[i as usize + 1] as usize]
    }
}
