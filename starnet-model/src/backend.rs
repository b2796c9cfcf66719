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
