//! Mirrored centers: test-time flip augmentation at no extra compute. Some of a frame's centers
//! see their neighbourhood in the mirror (y → −y), and the boxes they find are mirrored back.
//!
//! At inference StarNet's centers are independent of one another: the featurizer sees only
//! the points' offsets from their own center, and BatchNorm uses its running statistics. A
//! center whose offsets are mirrored is therefore exactly the mirrored center of the mirrored
//! frame, and the boxes its anchors decode to (around the mirrored center), mirrored back, are
//! boxes of the frame as seen. Training flips whole scenes at random (`augment.flip_y`), so the
//! model knows both views; but its errors are not mirror-symmetric, and on a street whose parked
//! cars all stand on one side they do not average out. With every second center mirrored
//! ([`CenterViews::Alternate`]), the centers that see one object split between the two views and
//! box voting averages their errors, for the cost of the same forward pass.

use crate::Box3d;
use serde::{Deserialize, Serialize};

use super::NUM_FEATURES;

/// Which of a frame's centers see their neighbourhood in the mirror.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CenterViews {
    /// Every center as the sensor saw it (the authors').
    #[default]
    AsSeen,
    /// Every second center in sampling order (ranks 1, 3, 5, …) in the mirror.
    Alternate,
    /// Every center in the mirror: the model on the frame's mirror image, which measures how
    /// much a model's figures depend on the side things stand on.
    Mirrored,
}

/// How one center sees its neighbourhood.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// As the sensor saw it.
    AsSeen,
    /// Mirrored left to right, y → −y.
    Mirrored,
}

impl CenterViews {
    /// The view of the center of sampling rank `rank`.
    pub fn of(self, rank: usize) -> View {
        match self {
            Self::AsSeen => View::AsSeen,
            Self::Alternate if rank.is_multiple_of(2) => View::AsSeen,
            Self::Alternate | Self::Mirrored => View::Mirrored,
        }
    }
}

impl View {
    /// A point `[x, y, z]` (or a center) as this view sees it. Its own inverse.
    pub fn point(self, p: [f32; 3]) -> [f32; 3] {
        match self {
            Self::AsSeen => p,
            Self::Mirrored => [p[0], -p[1], p[2]],
        }
    }

    /// A box as this view sees it ([`Box3d::mirrored`] in the mirror). Its own inverse.
    pub fn boxed(self, b: &Box3d) -> Box3d {
        match self {
            Self::AsSeen => *b,
            Self::Mirrored => b.mirrored(),
        }
    }
}

/// Gathered features `[C, P, F]` (offsets from each center first, as [`super::gather`] lays
/// them out) turned, in place, into what each center sees under `views`: the y offset of every
/// point of a mirrored center negated. Its own inverse.
pub fn view_features(features: &mut [f32], num_points: usize, views: CenterViews) {
    if views == CenterViews::AsSeen {
        return;
    }
    for (rank, center) in features.chunks_exact_mut(num_points * NUM_FEATURES).enumerate() {
        if views.of(rank) == View::Mirrored {
            center.chunks_exact_mut(NUM_FEATURES).for_each(|f| f[1] = -f[1]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alternate_mirrors_the_odd_ranks() {
        let views = |v: CenterViews| (0..4).map(|r| v.of(r)).collect::<Vec<_>>();
        let (s, m) = (View::AsSeen, View::Mirrored);
        assert_eq!(views(CenterViews::AsSeen), [s, s, s, s]);
        assert_eq!(views(CenterViews::Alternate), [s, m, s, m]);
        assert_eq!(views(CenterViews::Mirrored), [m, m, m, m]);
    }

    #[test]
    fn features_of_mirrored_centers_have_their_y_negated_and_mirroring_twice_restores_them() {
        // Three centers of two points; feature f of point p of center c is 100c + 10p + f.
        let original: Vec<f32> = (0..3 * 2 * NUM_FEATURES)
            .map(|i| (100 * (i / 8) + 10 * (i / 4 % 2) + i % 4) as f32)
            .collect();
        let mut f = original.clone();
        view_features(&mut f, 2, CenterViews::Alternate);
        assert_eq!(f[..8], original[..8]);
        assert_eq!(f[8..16], [100.0, -101.0, 102.0, 103.0, 110.0, -111.0, 112.0, 113.0]);
        assert_eq!(f[16..], original[16..]);
        view_features(&mut f, 2, CenterViews::Alternate);
        assert_eq!(f, original);
        view_features(&mut f, 2, CenterViews::Mirrored);
        assert!(
            f.chunks(4)
                .zip(original.chunks(4))
                .all(|(a, b)| a[1] == -b[1] && a[0] == b[0])
        );
        let mut same = original.clone();
        view_features(&mut same, 2, CenterViews::AsSeen);
        assert_eq!(same, original);
    }

    #[test]
    fn a_view_undoes_itself_on_points_and_boxes() {
        let b = Box3d::new(8.0, -2.0, -1.0, 4.0, 1.6, 1.5, 2.9);
        for v in [View::AsSeen, View::Mirrored] {
            assert_eq!(v.point(v.point([1.0, 2.0, 3.0])), [1.0, 2.0, 3.0]);
            assert_eq!(v.boxed(&v.boxed(&b)), b);
        }
        assert_eq!(View::Mirrored.point([1.0, 2.0, 3.0]), [1.0, -2.0, 3.0]);
        assert_eq!(
            View::Mirrored.boxed(&b).to_array(),
            [8.0, 2.0, -1.0, 4.0, 1.6, 1.5, -2.9]
        );
    }
}
