//! Which Burn backend a build uses. Exactly one CPU backend is compiled in by default
//! (`flex`); `ndarray` is kept selectable for comparison. The `BURN_DEVICE` environment
//! variable is not consulted: the device is the one this build was compiled for.

use burn::prelude::Device;

#[cfg(not(any(feature = "flex", feature = "ndarray")))]
compile_error!("starnet-model needs a backend feature: `flex` (default), `x86-v4` or `ndarray`");

/// The name of the compiled-in backend, for logs and benchmark reports.
pub fn backend_name() -> &'static str {
    if cfg!(feature = "x86-v4") {
        "flex+x86-v4"
    } else if cfg!(feature = "flex") {
        "flex"
    } else {
        "ndarray"
    }
}

/// The CPU device of the compiled-in backend (flex wins when several are enabled).
pub fn default_device() -> Device {
    #[cfg(feature = "flex")]
    {
        Device::flex()
    }
    #[cfg(all(feature = "ndarray", not(feature = "flex")))]
    #[allow(deprecated)] // ndarray is deprecated upstream; kept only as a comparison backend
    {
        Device::ndarray()
    }
}

/// Makes the calling thread one of the compute pool's threads (rayon's global pool, of
/// `RAYON_NUM_THREADS` or one thread per core in all, this one included). Call it first, from
/// the thread that will run the model: the parallel parts of every operation it starts (the
/// products, the fused blocks' row passes) then run on it and the pool's other threads, instead
/// of being handed to the pool while it sleeps until they are done, a hand-over and a wake-up
/// per operation that cost a fifth of a small model's training step (BENCHMARKS.md, issue
/// #16). Results do not change: reductions do not depend on the threads.
///
/// Returns false, changing nothing, when the global pool already exists (everything works
/// then, only with the hand-overs).
pub fn compute_on_this_thread() -> bool {
    rayon::ThreadPoolBuilder::new()
        .use_current_thread()
        .build_global()
        .is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::prelude::Tensor;

    #[test]
    fn device_computes_a_matmul() {
        let dev = default_device();
        let a = Tensor::<2>::from_floats([[1.0, 2.0], [3.0, 4.0]], &dev);
        let b = Tensor::<2>::from_floats([[5.0], [6.0]], &dev);
        let c: Vec<f32> = a.matmul(b).into_data().iter::<f32>().collect();
        assert_eq!(c, vec![17.0, 39.0]);
        assert!(!backend_name().is_empty());
    }
}
