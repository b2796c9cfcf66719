//! [`Shard`]: which items of every global batch a replica loads.

use crate::{Result, TrainError};

/// Replica `rank` of `ranks` loads the `rank`-th contiguous part of every global batch: with a
/// global batch of 4 on 2 replicas, items 0 and 1 of each step on replica 0, items 2 and 3 on
/// replica 1. Item `k` of a run is the same frame with the same augmentation whichever replica
/// loads it (its randomness is a function of the seed and `k`), so the shards together are the
/// batch one process would load.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This replica, `0..ranks`.
    pub rank: usize,
    /// The number of replicas.
    pub ranks: usize,
}

impl Shard {
    /// The whole batch (one replica).
    pub fn whole() -> Self {
        Self { rank: 0, ranks: 1 }
    }

    /// The items each replica loads per step of global batch `batch`; an error unless the
    /// replicas divide it.
    pub fn local_batch(&self, batch: usize) -> Result<usize> {
        if batch == 0 || !batch.is_multiple_of(self.ranks) {
            return Err(TrainError::InvalidArgument {
                name: "train.batch_size".into(),
                message: format!(
                    "{batch} is the global batch; it must be a positive multiple of the {} replicas",
                    self.ranks
                ),
            });
        }
        Ok(batch / self.ranks)
    }

    /// The run's item index of this shard's `i`-th item, with global batch `batch` (a multiple
    /// of the replicas: [`Shard::local_batch`]).
    pub fn item(&self, batch: usize, i: usize) -> usize {
        let local = batch / self.ranks;
        (i / local) * batch + self.rank * local + i % local
    }

    /// Whether this replica writes the run's files.
    pub fn writes(&self) -> bool {
        self.rank == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shards_of_a_run_are_its_items_once_each() {
        // Global batch 6 on 3 replicas: steps 0 and 1 cover items 0..12, each replica two
        // contiguous items per step.
        let items = |rank| (0..4).map(move |i| Shard { rank, ranks: 3 }.item(6, i));
        assert_eq!(items(0).collect::<Vec<_>>(), [0, 1, 6, 7]);
        assert_eq!(items(2).collect::<Vec<_>>(), [4, 5, 10, 11]);
        let mut all: Vec<usize> = (0..3).flat_map(items).collect();
        all.sort();
        assert_eq!(all, (0..12).collect::<Vec<_>>());
        assert_eq!(Shard::whole().item(4, 9), 9);
    }

    #[test]
    fn the_global_batch_must_split_evenly() {
        let shard = Shard { rank: 1, ranks: 2 };
        assert_eq!(shard.local_batch(4).unwrap(), 2);
        let err = shard.local_batch(3).unwrap_err().to_string();
        assert!(err.contains("train.batch_size") && err.contains("2 replicas"), "{err}");
    }
}
