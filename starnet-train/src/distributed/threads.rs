//! [`ThreadGroup`]: replicas that are threads of one process.

use starnet_model::replicas::Replicas;
use std::sync::{Arc, Barrier, Mutex};

#[derive(Debug)]
struct Shared {
    barrier: Barrier,
    /// Each member's values of the sum in progress, by rank.
    slots: Mutex<Vec<Vec<f64>>>,
}

/// One member of a group of threads that train one model together; [`ThreadGroup::new`] makes
/// the members, one per thread. Sums add the members' values in rank order, so they do not depend
/// on which thread arrives first.
#[derive(Debug, Clone)]
pub struct ThreadGroup {
    rank: usize,
    size: usize,
    shared: Arc<Shared>,
}

impl ThreadGroup {
    /// The `size` members of a new group (give each to its own thread).
    pub fn new(size: usize) -> Vec<Self> {
        let shared = Arc::new(Shared {
            barrier: Barrier::new(size),
            slots: Mutex::new(vec![Vec::new(); size]),
        });
        (0..size)
            .map(|rank| Self {
                rank,
                size,
                shared: Arc::clone(&shared),
            })
            .collect()
    }

    fn slots(&self) -> std::sync::MutexGuard<'_, Vec<Vec<f64>>> {
        // A member that panicked mid-sum leaves the others waiting at the barrier anyway.
        self.shared.slots.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Replicas for ThreadGroup {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn sum_f64(&self, values: &mut [f64]) {
        self.slots()[self.rank] = values.to_vec();
        self.shared.barrier.wait();
        {
            let slots = self.slots();
            values.fill(0.0);
            for member in slots.iter() {
                values.iter_mut().zip(member).for_each(|(v, m)| *v += m);
            }
        }
        // Nobody writes the next sum's values before everyone has read this one's.
        self.shared.barrier.wait();
    }

    fn sum_f32(&self, values: &mut [f32]) {
        let mut wide: Vec<f64> = values.iter().map(|&v| f64::from(v)).collect();
        self.sum_f64(&mut wide);
        values.iter_mut().zip(wide).for_each(|(v, w)| *v = w as f32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn members_get_the_sum_in_rank_order() {
        let handles: Vec<_> = ThreadGroup::new(3)
            .into_iter()
            .map(|g| {
                std::thread::spawn(move || {
                    let mut v = [g.rank() as f64, 1.0];
                    g.sum_f64(&mut v);
                    let mut w = [0.5f32 * g.rank() as f32];
                    g.sum_f32(&mut w);
                    (v, w)
                })
            })
            .collect();
        for h in handles {
            let (v, w) = h.join().unwrap();
            assert_eq!(v, [3.0, 3.0]);
            assert_eq!(w, [1.5]);
        }
    }
}
