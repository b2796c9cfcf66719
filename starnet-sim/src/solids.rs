//! What the scenery is made of: its solids with their surfaces, the footprints labelled
//! objects must keep clear of, and the upright boxes most of it is built from.

use super::{Part, Shape, Surface};
use starnet_data::Box3d;

/// Scenery solids with their surfaces, and the footprints objects must not overlap.
#[derive(Debug, Clone, Default)]
pub struct Scenery {
    /// Solids and surfaces, world frame.
    pub solids: Vec<Part>,
    /// Footprints of buildings, poles and trunks (for placing objects).
    pub obstacles: Vec<Box3d>,
}

impl Scenery {
    pub(super) fn add(&mut self, shape: Shape, surface: Surface) {
        self.solids.push((shape, surface));
    }

    /// Adds solids that together stand on `footprint` (kept clear of labelled objects).
    pub(super) fn add_group(&mut self, parts: Vec<Part>, footprint: Box3d) {
        self.obstacles.push(footprint);
        self.solids.extend(parts);
    }

    pub(super) fn add_obstacle(&mut self, shape: Shape, surface: Surface) {
        let ([x, y], r) = shape.bounding_circle();
        let (z0, z1) = shape.z_range();
        let (dx, dy, heading) = match shape {
            Shape::Cuboid { half, heading, .. } => (2.0 * half[0], 2.0 * half[1], heading),
            _ => (2.0 * r, 2.0 * r, 0.0),
        };
        self.obstacles
            .push(Box3d::new(x, y, 0.5 * (z0 + z1), dx, dy, z1 - z0, heading));
        self.add(shape, surface);
    }
}

/// An upright box standing on `foot` (`[x, y, ground z]`) with extents `[along x, across, up]`.
pub(super) fn cuboid_at(foot: [f32; 3], size: [f32; 3]) -> Shape {
    turned_cuboid_at(foot, size, 0.0)
}

/// The same, turned by `heading`.
pub(super) fn turned_cuboid_at(foot: [f32; 3], size: [f32; 3], heading: f32) -> Shape {
    Shape::Cuboid {
        c: [foot[0], foot[1], foot[2] + 0.5 * size[2]],
        half: [0.5 * size[0], 0.5 * size[1], 0.5 * size[2]],
        heading,
    }
}
