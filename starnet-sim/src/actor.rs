//! [`Actor`]: a labelled object of a scene, its parts in its own frame and its straight-line
//! motion.

use super::street::Ground;
use super::{AnnotationMargin, Part, tight_box};
use starnet_data::Box3d;
use starnet_data::kitti::ObjectClass;

/// A labelled object: its parts in its own frame and its straight-line motion.
#[derive(Debug, Clone)]
pub struct Actor {
    /// Object class.
    pub class: ObjectClass,
    /// Track id, stable across the frames of a sequence.
    pub track_id: u32,
    /// Parts in the object's own frame (origin on the ground, x along the heading).
    pub parts: Vec<Part>,
    /// The labelled box in the object's own frame: centre and `[dx, dy, dz]` (the tight box of
    /// the parts grown by the annotator's margin, [`AnnotationMargin`]).
    pub local_box: ([f32; 3], [f32; 3]),
    /// World position at t = 0.
    pub start: [f32; 2],
    /// Heading (constant: actors move straight).
    pub heading: f32,
    /// Speed along the heading, m/s.
    pub speed: f32,
    /// Footprint at t = 0 with a safety margin, for placing other objects.
    pub footprint: Box3d,
}

impl Actor {
    /// An actor from its parts, the margin its label leaves around them, and its motion.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        class: ObjectClass,
        track_id: u32,
        parts: Vec<Part>,
        margin: AnnotationMargin,
        start: [f32; 2],
        heading: f32,
        speed: f32,
        footprint: Box3d,
    ) -> Self {
        let local_box = margin.label_box(tight_box(&parts));
        Self {
            class,
            track_id,
            parts,
            local_box,
            start,
            heading,
            speed,
            footprint,
        }
    }

    /// World pose of the actor's frame at `t`: `[x, y, z, heading]`, z on the ground.
    pub fn pose(&self, t: f32, ground: &Ground) -> [f32; 4] {
        let (s, c) = self.heading.sin_cos();
        let (x, y) = (self.start[0] + c * self.speed * t, self.start[1] + s * self.speed * t);
        let lateral = ground.street.lateral(y).abs();
        let kerb = if lateral > ground.street.half_width() && !ground.street.in_crossing(x) {
            ground.street.kerb
        } else {
            0.0
        };
        [x, y, ground.height(x, y) + kerb, self.heading]
    }
}
