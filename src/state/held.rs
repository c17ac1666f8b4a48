//! Arrays indexed by id of which a process may hold only a part: a rank of a decomposed
//! model holds the histories of the work it computes, not the whole model's
//! (docs/cluster.md, "What is not there yet": memory).
//!
//! Guarantees: on one process (or whenever every entry is held) an entry is at its id, as in
//! a `Vec`, and nothing else costs anything; indexing an entry this process does not hold
//! panics with the id rather than reading a stale or default value; a partial array cannot
//! be serialized (a checkpoint is written from the whole state).

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::ops::{Index, IndexMut};
use std::sync::Arc;

/// Slot of an id this process does not hold.
const NOT_HELD: u32 = u32::MAX;

/// Where each id's entry is stored: at its id (every entry held), or, packed in id order,
/// only those of the ids a rank keeps.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Slots(Option<Arc<[u32]>>);

impl Slots {
    /// Every id held, at its own index.
    pub fn all() -> Self {
        Slots(None)
    }

    /// Of ids `0..n`, those `keep` says yes to, packed in id order.
    pub fn keeping(n: usize, mut keep: impl FnMut(usize) -> bool) -> Self {
        let mut next = 0u32;
        let slot: Arc<[u32]> = (0..n)
            .map(|id| {
                if keep(id) {
                    next += 1;
                    next - 1
                } else {
                    NOT_HELD
                }
            })
            .collect();
        Slots(Some(slot))
    }

    pub fn is_all(&self) -> bool {
        self.0.is_none()
    }

    /// Where id `id` is stored, if this process holds it (ids beyond a partial map: no).
    #[inline(always)]
    pub fn get(&self, id: usize) -> Option<usize> {
        match &self.0 {
            None => Some(id),
            Some(s) => s
                .get(id)
                .copied()
                .filter(|&k| k != NOT_HELD)
                .map(|k| k as usize),
        }
    }

    /// Where id `id` is stored; panics, naming it, if this process does not hold it.
    #[inline(always)]
    pub fn at(&self, id: usize) -> usize {
        match &self.0 {
            None => id,
            Some(s) => match s.get(id) {
                Some(&k) if k != NOT_HELD => k as usize,
                _ => not_held(id),
            },
        }
    }
}

#[cold]
#[inline(never)]
fn not_held(id: usize) -> ! {
    panic!(
        "entry {id} is not held by this rank (a rank holds the histories of the work it \
         computes; share them first)"
    )
}

/// An array indexed by id (`a[id]`), holding every entry or only those of its [`Slots`].
#[derive(Clone, Debug, PartialEq)]
pub struct Held<T> {
    data: Vec<T>,
    slots: Slots,
}

impl<T> Default for Held<T> {
    fn default() -> Self {
        Held {
            data: Vec::new(),
            slots: Slots::all(),
        }
    }
}

impl<T> From<Vec<T>> for Held<T> {
    fn from(data: Vec<T>) -> Self {
        Held {
            data,
            slots: Slots::all(),
        }
    }
}

impl<T: Clone> Held<T> {
    /// Every entry held (at its id).
    pub fn is_whole(&self) -> bool {
        self.slots.is_all()
    }

    /// Entries stored here (all of them when whole).
    pub fn held(&self) -> usize {
        self.data.len()
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The entries stored here, in id order.
    pub fn iter(&self) -> std::slice::Iter<'_, T> {
        self.data.iter()
    }

    /// The entries stored here, in id order (the stage kernels' raw access).
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.data
    }

    pub fn slots(&self) -> &Slots {
        &self.slots
    }

    pub fn get(&self, id: usize) -> Option<&T> {
        self.slots.get(id).and_then(|k| self.data.get(k))
    }

    pub fn get_mut(&mut self, id: usize) -> Option<&mut T> {
        self.slots.get(id).and_then(|k| self.data.get_mut(k))
    }

    /// Append the entry of the next id (whole arrays only).
    pub fn push(&mut self, v: T) {
        assert!(self.is_whole(), "an entry pushed on a partial array");
        self.data.push(v);
    }

    /// Grow or cut to `n` entries (whole arrays only).
    pub fn resize(&mut self, n: usize, v: T) {
        assert!(self.is_whole(), "a partial array resized");
        self.data.resize(n, v);
    }

    pub fn shrink_to_fit(&mut self) {
        self.data.shrink_to_fit();
    }

    /// Keep the entries of `slots` only, from an array that holds them (ids `0..n`); the
    /// spare capacity is given back.
    pub fn hold(&mut self, slots: &Slots, n: usize) {
        if *slots == self.slots {
            return;
        }
        let data: Vec<T> = (0..n)
            .filter(|&id| slots.get(id).is_some())
            .map(|id| self[id].clone())
            .collect();
        self.data = data;
        self.slots = slots.clone();
    }

    /// Of ids `0..n`, only `ids` (ascending) held, each `fill`.
    pub fn of_ids(n: usize, ids: &[u32], fill: T) -> Self {
        let mut slot = vec![NOT_HELD; n];
        for (k, &id) in ids.iter().enumerate() {
            slot[id as usize] = k as u32;
        }
        Held {
            data: vec![fill; ids.len()],
            slots: Slots(Some(slot.into())),
        }
    }

    /// Entries the storage has room for.
    pub fn capacity(&self) -> usize {
        self.data.capacity()
    }

    /// Every entry again, ids `0..n`: the held ones kept, the others `fill` (to be filled by
    /// whoever holds them).
    pub fn make_whole(&mut self, n: usize, fill: T) {
        if self.is_whole() {
            return;
        }
        let data: Vec<T> = (0..n)
            .map(|id| self.get(id).cloned().unwrap_or_else(|| fill.clone()))
            .collect();
        self.data = data;
        self.slots = Slots::all();
    }
}

impl<T> Index<usize> for Held<T> {
    type Output = T;
    #[inline(always)]
    fn index(&self, id: usize) -> &T {
        &self.data[self.slots.at(id)]
    }
}

impl<T> IndexMut<usize> for Held<T> {
    #[inline(always)]
    fn index_mut(&mut self, id: usize) -> &mut T {
        let k = self.slots.at(id);
        &mut self.data[k]
    }
}

/// The entries stored here, in id order (every entry when whole).
impl<'a, T> IntoIterator for &'a Held<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;
    fn into_iter(self) -> Self::IntoIter {
        self.data.iter()
    }
}

impl<T: Serialize> Serialize for Held<T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if !self.slots.is_all() {
            return Err(serde::ser::Error::custom(
                "a rank's partial array cannot be serialized: gather the whole state first",
            ));
        }
        self.data.serialize(s)
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Held<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Ok(Held {
            data: Vec::deserialize(d)?,
            slots: Slots::all(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A partial array reads and writes the entries it keeps at their ids, refuses the
    /// others, and made whole again holds the kept entries' values and `fill` elsewhere.
    #[test]
    fn a_partial_array_keeps_its_entries_at_their_ids() {
        let mut a: Held<u64> = (0..10u64).map(|i| i * i).collect::<Vec<_>>().into();
        let slots = Slots::keeping(10, |id| id % 3 == 1);
        a.hold(&slots, 10);
        assert_eq!(a.held(), 3);
        assert_eq!((a[1], a[4], a[7]), (1, 16, 49));
        a[4] = 5;
        assert_eq!(a.get(3), None);
        assert!(std::panic::catch_unwind(|| a[3]).is_err());
        assert!(postcard::to_allocvec(&a).is_err());
        a.make_whole(10, 0);
        assert_eq!(
            a.iter().copied().collect::<Vec<_>>(),
            [0, 1, 0, 0, 5, 0, 0, 49, 0, 0]
        );
        let back: Held<u64> = postcard::from_bytes(&postcard::to_allocvec(&a).unwrap()).unwrap();
        assert_eq!(back, a);
        let b = Held::of_ids(10, &[2, 3, 9], 7u64);
        assert_eq!((b.held(), b[2], b[3], b[9], b.get(4)), (3, 7, 7, 7, None));
    }
}
