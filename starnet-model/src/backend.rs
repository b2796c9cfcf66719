//! Which Burn backend a build uses. Exactly one CPU backend is compiled in by default
//! (`flex`); `ndarray` is kept selectable for comparison. The `BURN_DEVICE` environment
//! variable is not consulted: the device is the one this build was compiled for.

use burn::prelude::Device;
use serde_with::{DeserializeFromStr, SerializeDisplay};

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

/// Where a model computes: the CPU (`flex`, the default) or a GPU through wgpu — `vulkan` (pinned
/// to Vulkan) or `wgpu` (whichever graphics API wgpu settles on), each optionally `:N`, the N-th
/// discrete GPU (without it: wgpu's choice, the high-power adapter, or the one
/// `CUBECL_WGPU_DEFAULT_DEVICE` names). The GPU choices need a build with the cargo feature of
/// the same name; the fused StarNet kernels are flex's, so a GPU runs the composed operations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, SerializeDisplay, DeserializeFromStr)]
pub enum DeviceChoice {
    /// The flex CPU backend.
    #[default]
    Flex,
    /// A Vulkan device: wgpu's choice, or the given discrete GPU.
    Vulkan(Option<usize>),
    /// A wgpu device on any graphics API: wgpu's choice, or the given discrete GPU.
    Wgpu(Option<usize>),
}

/// A device name that is not `flex`, `vulkan[:N]` or `wgpu[:N]`, or one this build lacks.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DeviceError {
    /// Not a device name.
    #[error("unknown device {0:?}: expected flex, vulkan, vulkan:N, wgpu or wgpu:N")]
    Unknown(String),
    /// A device whose cargo feature this build was compiled without.
    #[error("device {0}: this build lacks the `{1}` cargo feature (cargo build --release --features {1})")]
    NotBuilt(DeviceChoice, &'static str),
    /// A GPU that could not be opened (no GPU, no Vulkan loader or driver): wgpu's message.
    #[error("device {0}: no GPU could be opened (it needs libvulkan.so.1 and the GPU's Vulkan driver): {1}")]
    Unavailable(DeviceChoice, String),
}

impl std::str::FromStr for DeviceChoice {
    type Err = DeviceError;

    fn from_str(s: &str) -> Result<Self, DeviceError> {
        let unknown = || DeviceError::Unknown(s.to_string());
        let (name, index) = match s.split_once(':') {
            Some((name, n)) => (name, Some(n.parse::<usize>().map_err(|_| unknown())?)),
            None => (s, None),
        };
        match (name, index) {
            ("flex", None) => Ok(Self::Flex),
            ("vulkan", n) => Ok(Self::Vulkan(n)),
            ("wgpu", n) => Ok(Self::Wgpu(n)),
            _ => Err(unknown()),
        }
    }
}

impl std::fmt::Display for DeviceChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (name, index) = match self {
            Self::Flex => return f.write_str("flex"),
            Self::Vulkan(n) => ("vulkan", n),
            Self::Wgpu(n) => ("wgpu", n),
        };
        match index {
            Some(n) => write!(f, "{name}:{n}"),
            None => f.write_str(name),
        }
    }
}

/// The wgpu adapter a GPU choice names.
#[cfg(any(feature = "vulkan", feature = "wgpu"))]
fn device_kind(index: Option<usize>) -> burn::tensor::DeviceKind {
    index.map_or(
        burn::tensor::DeviceKind::DefaultDevice,
        burn::tensor::DeviceKind::DiscreteGpu,
    )
}

/// `device` once its adapter has answered. wgpu looks for the adapter at the first operation and,
/// finding none, panics on its own thread and then on the caller's: the probe runs that first
/// operation here, keeps the first panic's message (the hook is this process's for the moment)
/// and returns it as an error, so that a machine without the GPU gets a message, not a panic.
#[cfg(any(feature = "vulkan", feature = "wgpu"))]
fn probed(choice: DeviceChoice, device: Device) -> Result<Device, DeviceError> {
    use std::sync::{Arc, Mutex};
    let first = Arc::new(Mutex::new(None::<String>));
    let seen = Arc::clone(&first);
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let mut first = seen.lock().unwrap_or_else(|e| e.into_inner());
        first.get_or_insert_with(|| info.payload_as_str().unwrap_or("a panic").to_string());
    }));
    let probe = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        burn::tensor::Tensor::<1>::zeros([1], &device).into_data()
    }));
    std::panic::set_hook(previous);
    match probe {
        Ok(_) => Ok(device),
        Err(_) => {
            let message = first.lock().unwrap_or_else(|e| e.into_inner()).take();
            Err(DeviceError::Unavailable(choice, message.unwrap_or_default()))
        }
    }
}

impl DeviceChoice {
    /// The (non-autodiff) device; an error when this build lacks its backend, or when the GPU
    /// cannot be opened.
    pub fn device(self) -> Result<Device, DeviceError> {
        match self {
            Self::Flex => Ok(default_device()),
            #[cfg(feature = "vulkan")]
            Self::Vulkan(n) => probed(self, Device::vulkan(device_kind(n))),
            #[cfg(not(feature = "vulkan"))]
            Self::Vulkan(_) => Err(DeviceError::NotBuilt(self, "vulkan")),
            #[cfg(feature = "wgpu")]
            Self::Wgpu(n) => probed(self, Device::wgpu(device_kind(n))),
            #[cfg(not(feature = "wgpu"))]
            Self::Wgpu(_) => Err(DeviceError::NotBuilt(self, "wgpu")),
        }
    }
}

/// Makes the calling thread one of the compute pool's threads (rayon's global pool, of
/// `RAYON_NUM_THREADS` or one thread per core in all, this one included). Call it first, from
/// the thread that will run the model: the parallel parts of every operation it starts (the
/// products, the fused blocks' row passes) then run on it and the pool's other threads, instead
/// of being handed to the pool while it sleeps until they are done, a hand-over and a wake-up
/// per operation that cost a fifth of a small model's training step (docs/benchmarks-history.md, issue
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
    fn device_names_round_trip_and_bad_ones_are_named() {
        for (text, choice) in [
            ("flex", DeviceChoice::Flex),
            ("vulkan", DeviceChoice::Vulkan(None)),
            ("vulkan:1", DeviceChoice::Vulkan(Some(1))),
            ("wgpu:0", DeviceChoice::Wgpu(Some(0))),
        ] {
            assert_eq!(text.parse::<DeviceChoice>().unwrap(), choice);
            assert_eq!(choice.to_string(), text);
        }
        for bad in ["cuda", "vulkan:x", "flex:0", ""] {
            let err = bad.parse::<DeviceChoice>().unwrap_err().to_string();
            assert!(err.contains(&format!("{bad:?}")), "{err}");
        }
        assert!(DeviceChoice::Flex.device().is_ok());
    }

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
