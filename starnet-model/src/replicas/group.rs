//! The calling thread's replica group: installing one, and summing over it.

use std::cell::RefCell;
use std::fmt::Debug;
use std::sync::Arc;

/// A group of replicas that can sum values element-wise across its members (MPI's
/// `MPI_Allreduce` with `MPI_SUM`, or threads of one process). Every member calls each sum with
/// the same length, in the same order; the call returns once every member has made it.
pub trait Replicas: Send + Sync + Debug {
    /// This member's index, `0..size()`.
    fn rank(&self) -> usize;
    /// The number of members.
    fn size(&self) -> usize;
    /// Replaces `values` by their element-wise sum over the members (the same on every member).
    fn sum_f64(&self, values: &mut [f64]);
    /// As [`Replicas::sum_f64`], for the gradients' f32 buffer.
    fn sum_f32(&self, values: &mut [f32]);
}

thread_local! {
    static CURRENT: RefCell<Option<Arc<dyn Replicas>>> = const { RefCell::new(None) };
}

/// Puts the previous group back when the scope ends, a panic included.
struct Restore(Option<Arc<dyn Replicas>>);

impl Drop for Restore {
    fn drop(&mut self) {
        let previous = self.0.take();
        CURRENT.with(|c| *c.borrow_mut() = previous);
    }
}

/// Runs `f` with `group` as the calling thread's replica group.
pub fn scope<R>(group: Arc<dyn Replicas>, f: impl FnOnce() -> R) -> R {
    let previous = CURRENT.with(|c| c.borrow_mut().replace(group));
    let _restore = Restore(previous);
    f()
}

/// The calling thread's group, when it has one of more than one member.
pub fn current() -> Option<Arc<dyn Replicas>> {
    CURRENT.with(|c| c.borrow().clone()).filter(|g| g.size() > 1)
}

/// Sums `values` over the calling thread's group (accumulating in f64); leaves them alone
/// without one.
pub fn sum(values: &mut [f32]) {
    if let Some(group) = current() {
        let mut wide: Vec<f64> = values.iter().map(|&v| f64::from(v)).collect();
        group.sum_f64(&mut wide);
        values.iter_mut().zip(wide).for_each(|(v, w)| *v = w as f32);
    }
}

/// The sum of `value` over the calling thread's group (`value` itself without one).
pub fn sum_scalar(value: f32) -> f32 {
    let mut v = [value];
    sum(&mut v);
    v[0]
}
