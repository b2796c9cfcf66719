//! Point clouds from any LiDAR: KITTI velodyne `.bin`, PCD (PCL), PLY and NumPy `.npy`, read
//! into one [`PointCloud`] of `[x, y, z, intensity]` points and written back.
//!
//! * The extension picks the reader ([`CloudKind::from_path`], [`CLOUD_EXTENSIONS`]); the
//!   encoding (ascii or binary) comes from the file's header. A writer is told the format and
//!   encoding ([`CloudFormat`]) and writes atomically.
//! * Fields are found by name, in any order: `x`, `y`, `z` (required) and an optional intensity
//!   ([`INTENSITY_NAMES`]); a file without one reads as [`Intensity::Absent`] with 0.0 as the
//!   4th value. Intensity values are taken as they are: KITTI's reflectance is in [0, 1], and a
//!   sensor that reports 0–255 needs its own scaling before a KITTI-trained model sees it.
//! * A point with a NaN coordinate is "no return" and dropped; any other non-finite value is an
//!   error ([`DataError::NonFinitePoint`](crate::DataError::NonFinitePoint)).
//! * A finite point beyond any sensor's range is dropped and counted, or refused, as the
//!   config's [`WildPoints`] says, by the dataset and `starnet detect`; the readers pass it on.
//! * A header is checked against the file before the format's crate reads it, so a corrupt or
//!   hostile header is an error naming the file, never a panic or a huge allocation.
//!
//! Writers store f32 exactly, so every format round-trips a cloud bit for bit.

mod bin;
mod format;
mod io;
mod npy;
mod pcd;
mod ply;
mod point_cloud;
mod wild;

pub use bin::{decode_points, encode_points, read_points, write_points};
pub use format::{CLOUD_EXTENSIONS, CloudFormat, CloudKind, PcdEncoding, PlyEncoding};
pub use io::{decode_cloud, encode_cloud, read_cloud, write_cloud};
pub use point_cloud::{INTENSITY_NAMES, Intensity, PointCloud};
pub use wild::{Kept, WildAction, WildPoints};

/// Fixtures and an allocation probe for the readers' tests.
#[cfg(test)]
mod test_support {
    use super::{Intensity, PointCloud};
    use crate::Point;
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    /// Values a text encoding could get wrong: signed zero, tiny, subnormal and extreme
    /// magnitudes, and values that need all 9 significant digits (0.1 + 1 ulp).
    pub fn awkward_cloud(intensity: Intensity) -> PointCloud {
        let one_ulp_out = |v: f32| f32::from_bits(v.to_bits() + 1);
        let mut points: Vec<Point> = vec![
            [-0.0, 1e-30, f32::MAX, 0.0],
            [one_ulp_out(0.1), -1e30, 123_456.79, 1.0],
            [f32::MIN_POSITIVE, -f32::MAX, 1e-45, one_ulp_out(0.1)],
            [one_ulp_out(-17.3), 0.3, -0.0, 255.0],
            [1.0e-7, 16_777_216.0, -3.4028e38, -0.0],
        ];
        if intensity == Intensity::Absent {
            points.iter_mut().for_each(|p| p[3] = 0.0);
        }
        PointCloud { points, intensity }
    }

    /// Which error a malformed file must give.
    pub type Expected = fn(&crate::DataError) -> bool;

    /// Bit-for-bit equality (`-0.0 != 0.0`), with the first difference in the message.
    pub fn assert_bits_eq(got: &[Point], want: &[Point]) {
        assert_eq!(got.len(), want.len(), "point counts differ");
        for (i, (g, w)) in got.iter().zip(want).enumerate() {
            assert_eq!(g.map(f32::to_bits), w.map(f32::to_bits), "point {i}: {g:?} != {w:?}");
        }
    }

    thread_local! {
        // Const-initialised and without a destructor, so the allocator may touch it.
        static LARGEST: Cell<usize> = const { Cell::new(0) };
    }

    /// The system allocator, noting the largest request made on each thread.
    struct Probe;

    fn note(size: usize) {
        let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
    }

    // SAFETY: every call is forwarded unchanged to `System`.
    unsafe impl GlobalAlloc for Probe {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            note(layout.size());
            unsafe { System.alloc(layout) }
        }

        unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
            note(layout.size());
            unsafe { System.alloc_zeroed(layout) }
        }

        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            note(new_size);
            unsafe { System.realloc(ptr, layout, new_size) }
        }

        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            unsafe { System.dealloc(ptr, layout) }
        }
    }

    // A zeroed allocation of gigabytes succeeds at once (the pages are mapped lazily), so a test
    // can only see one by asking the allocator.
    #[global_allocator]
    static PROBE: Probe = Probe;

    /// Runs `f` and returns its result with the largest single allocation it asked for on this
    /// thread, in bytes.
    pub fn largest_allocation_during<R>(f: impl FnOnce() -> R) -> (R, usize) {
        LARGEST.with(|l| l.set(0));
        let result = f();
        (result, LARGEST.with(Cell::get))
    }
}
