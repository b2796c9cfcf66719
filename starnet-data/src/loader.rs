//! A data loader that prepares items in worker threads while the consumer works.
//!
//! Item `i` is computed with its own RNG, seeded from `(seed, i)`, and items are handed out in
//! index order whatever thread finished first, so the stream is the same for any number of
//! workers. At most `prefetch` items are in flight, which bounds memory.

use crate::Result;
use crate::seed::sub_seed;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// Ordered, prefetching iterator over `job(0) .. job(len − 1)`.
pub struct Loader<T> {
    results: Receiver<(usize, Result<T>)>,
    tickets: Option<Sender<usize>>,
    pending: BTreeMap<usize, Result<T>>,
    next: usize,
    issued: usize,
    len: usize,
    workers: Vec<JoinHandle<()>>,
}

impl<T: Send + 'static> Loader<T> {
    /// Starts `workers` threads computing `job(i, rng_i)` for `i in 0..len`.
    pub fn new<F>(len: usize, workers: usize, prefetch: usize, seed: u64, job: F) -> Self
    where
        F: Fn(usize, &mut ChaCha8Rng) -> Result<T> + Send + Sync + 'static,
    {
        let (ticket_tx, ticket_rx) = channel::<usize>();
        let (result_tx, results) = channel();
        let ticket_rx = Arc::new(Mutex::new(ticket_rx));
        let job = Arc::new(job);
        let workers = (0..workers.max(1))
            .map(|_| {
                let (rx, tx, job) = (Arc::clone(&ticket_rx), result_tx.clone(), Arc::clone(&job));
                std::thread::spawn(move || {
                    loop {
                        let ticket = rx.lock().expect("no panics while holding it").recv();
                        let Ok(i) = ticket else { return };
                        let mut rng = ChaCha8Rng::seed_from_u64(sub_seed(seed, 11, i as u64));
                        // A panicking job (a bug) becomes an error item, so the consumer stops
                        // with a message instead of crashing on a dead channel.
                        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(i, &mut rng)))
                            .unwrap_or_else(|p| {
                                let message = p
                                    .downcast_ref::<&str>()
                                    .map(|s| s.to_string())
                                    .or_else(|| p.downcast_ref::<String>().cloned())
                                    .unwrap_or_else(|| "panic".into());
                                Err(crate::DataError::WorkerPanic { index: i, message })
                            });
                        if tx.send((i, result)).is_err() {
                            return;
                        }
                    }
                })
            })
            .collect();
        let issued = prefetch.max(1).min(len);
        for i in 0..issued {
            ticket_tx.send(i).expect("workers are alive");
        }
        Self {
            results,
            tickets: Some(ticket_tx),
            pending: BTreeMap::new(),
            next: 0,
            issued,
            len,
            workers,
        }
    }
}

impl<T> Iterator for Loader<T> {
    type Item = Result<T>;

    fn next(&mut self) -> Option<Result<T>> {
        if self.next == self.len {
            return None;
        }
        while !self.pending.contains_key(&self.next) {
            match self.results.recv() {
                Ok((i, item)) => {
                    self.pending.insert(i, item);
                }
                // Every worker is gone (they only stop when the loader is dropped).
                Err(_) => return None,
            }
        }
        let item = self.pending.remove(&self.next).expect("just checked");
        self.next += 1;
        if self.issued < self.len
            && let Some(t) = &self.tickets
            && t.send(self.issued).is_ok()
        {
            self.issued += 1;
        }
        Some(item)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.len - self.next;
        (left, Some(left))
    }
}

impl<T> Drop for Loader<T> {
    fn drop(&mut self) {
        // Closing the ticket channel stops the workers after their current item.
        self.tickets = None;
        while self.results.try_recv().is_ok() {}
        for w in self.workers.drain(..) {
            let _ = w.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    fn stream(workers: usize) -> Vec<(usize, u64)> {
        Loader::new(40, workers, 4, 9, |i, rng| {
            // Uneven work, so threads finish out of order.
            std::thread::sleep(std::time::Duration::from_micros(((i * 7919) % 13) as u64 * 100));
            Ok((i, rng.random::<u64>()))
        })
        .map(|r| r.unwrap())
        .collect()
    }

    #[test]
    fn same_stream_for_any_worker_count() {
        let one = stream(1);
        assert_eq!(one.iter().map(|x| x.0).collect::<Vec<_>>(), (0..40).collect::<Vec<_>>());
        assert_eq!(stream(2), one);
        assert_eq!(stream(3), one);
    }

    #[test]
    fn a_panicking_job_becomes_an_error_item() {
        let items: Vec<_> = Loader::new(
            4,
            2,
            2,
            1,
            |i, _| if i == 2 { panic!("bug in item {i}") } else { Ok(i) },
        )
        .collect();
        assert_eq!(items.len(), 4);
        let err = items[2].as_ref().unwrap_err().to_string();
        assert!(err.contains("item 2") && err.contains("bug in item 2"), "{err}");
        assert!(items[3].is_ok());
    }

    #[test]
    fn errors_arrive_in_place_and_early_drop_is_clean() {
        let mut l = Loader::new(10, 2, 3, 1, |i, _| {
            if i == 4 {
                Err(crate::DataError::parse("x", 1, "f", "bad"))
            } else {
                Ok(i)
            }
        });
        let got: Vec<bool> = (&mut l).take(6).map(|r| r.is_ok()).collect();
        assert_eq!(got, [true, true, true, true, false, true]);
        drop(l);
    }
}
