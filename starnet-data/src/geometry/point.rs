//! The point type every cloud, sampler and simulator in the workspace passes around.

/// A LiDAR point: `[x, y, z, reflectance]`, LiDAR frame, reflectance in [0, 1].
pub type Point = [f32; 4];
