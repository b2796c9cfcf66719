//! A small parallel-for over all cores, for the data-preparation commands.

use crate::Result;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Runs `job(i)` for `i in 0..n` on all cores and returns the first error (remaining work is
/// skipped once one job failed).
pub fn parallel_for(n: usize, job: impl Fn(usize) -> Result<()> + Sync) -> Result<()> {
    let next = AtomicUsize::new(0);
    let error = Mutex::new(None);
    let threads = std::thread::available_parallelism()
        .map_or(1, |t| t.get())
        .min(n.max(1));
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= n || error.lock().expect("no panics while holding it").is_some() {
                        break;
                    }
                    if let Err(e) = job(i) {
                        error.lock().expect("no panics while holding it").get_or_insert(e);
                    }
                }
            });
        }
    });
    error
        .into_inner()
        .expect("no panics while holding it")
        .map_or(Ok(()), Err)
}
