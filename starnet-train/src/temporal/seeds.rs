//! Seeds from the previous frame: which detections, moved where, and how close to the objects
//! they seek they land.

use serde::{Deserialize, Serialize};
use serde_with::{DeserializeFromStr, SerializeDisplay};
use starnet_data::Box3d;
use starnet_data::geometry::Pose;
use starnet_model::nms::Detection;

/// How many of a frame's centers come from the previous frame's detections.
#[derive(Debug, Clone, Copy, PartialEq, SerializeDisplay, DeserializeFromStr)]
pub enum PrevCenters {
    /// K centers (at most N); written `K`.
    Count(usize),
    /// A share of N, rounded down; written `P%`.
    Percent(u32),
}

impl PrevCenters {
    /// K for a frame of `n` centers.
    pub fn of(self, n: usize) -> usize {
        match self {
            Self::Count(k) => k.min(n),
            Self::Percent(p) => n * p.min(100) as usize / 100,
        }
    }
}

impl std::str::FromStr for PrevCenters {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("`{s}`: expected a count (32) or a share of the centers (50%)");
        match s.strip_suffix('%') {
            Some(p) => p.parse().ok().filter(|&p| p <= 100).map(Self::Percent).ok_or_else(bad),
            None => s.parse().map(Self::Count).map_err(|_| bad()),
        }
    }
}

impl std::fmt::Display for PrevCenters {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Count(k) => write!(f, "{k}"),
            Self::Percent(p) => write!(f, "{p}%"),
        }
    }
}

/// Seeds per detection of frame t − 1 ([`temporal_seeds`]).
pub const SEEDS_PER_DETECTION: usize = 3;

/// At most `k` seeds from frame t − 1's `detections` (its final boxes: the confident ones), best
/// score first (ties in input order), [`SEEDS_PER_DETECTION`] each: the box centre and the
/// points a third of its length ahead of and behind it, moved into frame t by `prev_to_now`
/// (see `Pose::between`). Several centers on one object let its boxes vote; a frame with few
/// objects takes few seeds and leaves the rest of the budget to FPS, which is what it would
/// have had without seeds.
pub fn temporal_seeds(detections: &[Detection], k: usize, prev_to_now: &Pose) -> Vec<[f32; 3]> {
    let mut order: Vec<usize> = (0..detections.len()).collect();
    order.sort_by(|&i, &j| detections[j].score.total_cmp(&detections[i].score).then(i.cmp(&j)));
    order
        .into_iter()
        .flat_map(|i| {
            let b = detections[i].b;
            let (ax, ay) = (b.heading.cos() * b.dx / 3.0, b.heading.sin() * b.dx / 3.0);
            [[b.x, b.y, b.z], [b.x + ax, b.y + ay, b.z], [b.x - ax, b.y - ay, b.z]]
                .into_iter()
                .take(SEEDS_PER_DETECTION)
        })
        .take(k)
        .map(|p| prev_to_now.apply(p))
        .collect()
}

/// Moves each seed onto the nearest (bird's-eye view) of `points[pool]`, the frame's candidate
/// centers, when one lies within `reach` metres. The detector was trained on centers that are
/// LiDAR returns (FPS over the pool), mostly on an object's visible surface; a box centre has no
/// return around it and is a center it never saw.
pub fn snap_seeds(seeds: &[[f32; 3]], points: &[starnet_data::Point], pool: &[usize], reach: f32) -> Vec<[f32; 3]> {
    seeds
        .iter()
        .map(|s| {
            let best = pool
                .iter()
                .map(|&i| (i, (points[i][0] - s[0]).hypot(points[i][1] - s[1])))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            match best {
                Some((i, d)) if d <= reach => [points[i][0], points[i][1], points[i][2]],
                _ => *s,
            }
        })
        .collect()
}

/// Bird's-eye-view distance from each seed to the nearest of `objects` (infinite without any).
pub fn seed_distances(seeds: &[[f32; 3]], objects: &[Box3d]) -> Vec<f32> {
    seeds
        .iter()
        .map(|s| {
            objects
                .iter()
                .map(|o| (o.x - s[0]).hypot(o.y - s[1]))
                .fold(f32::INFINITY, f32::min)
        })
        .collect()
}

/// How close seeds land to objects, over a run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SeedStats {
    /// Seeds placed.
    pub seeds: usize,
    /// Frames that could take seeds (every frame but a sequence's first).
    pub frames: usize,
    /// Share of seeds within 1 m of a labelled object of the model's classes.
    pub within_1m: f64,
    /// Median distance from a seed to the nearest object, metres.
    pub median_m: f64,
    /// The same without the pose correction (seeds left at their frame t − 1 coordinates).
    pub uncorrected_median_m: f64,
}

impl SeedStats {
    /// From each seed's distance with and without the pose correction, over `frames` frames.
    pub fn of(corrected: &[f32], uncorrected: &[f32], frames: usize) -> Self {
        let median = |v: &[f32]| {
            let mut v: Vec<f32> = v.iter().copied().filter(|d| d.is_finite()).collect();
            v.sort_by(f32::total_cmp);
            v.get(v.len() / 2).map_or(0.0, |&d| f64::from(d))
        };
        Self {
            seeds: corrected.len(),
            frames,
            within_1m: corrected.iter().filter(|&&d| d <= 1.0).count() as f64 / corrected.len().max(1) as f64,
            median_m: median(corrected),
            uncorrected_median_m: median(uncorrected),
        }
    }

    /// Mean seeds per frame that could take them.
    pub fn per_frame(&self) -> f64 {
        self.seeds as f64 / self.frames.max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(x: f32, score: f32) -> Detection {
        Detection {
            b: Box3d::new(x, 1.0, -1.0, 4.0, 1.6, 1.5, 0.0),
            class: starnet_data::kitti::ObjectClass::Car,
            score,
        }
    }

    #[test]
    fn seeds_are_the_best_detections_moved_by_the_pose() {
        let prev = [det(10.0, 0.5), det(20.0, 0.9), det(30.0, 0.7)];
        // The ego drove 2 m forward: everything is 2 m closer.
        let moved = Pose::between(&Pose::IDENTITY, &Pose::from_xyz_yaw([2.0, 0.0, 0.0], 0.0));
        let seeds = temporal_seeds(&prev, 4, &moved);
        // The best box's centre, then a third of its 4 m length ahead and behind (heading 0:
        // along x), then the next box's centre.
        let want = [
            [18.0, 1.0, -1.0],
            [18.0 + 4.0 / 3.0, 1.0, -1.0],
            [18.0 - 4.0 / 3.0, 1.0, -1.0],
            [28.0, 1.0, -1.0],
        ];
        assert_eq!(seeds.len(), 4);
        for (s, w) in seeds.iter().zip(want) {
            assert!(s.iter().zip(w).all(|(a, b)| (a - b).abs() < 1e-5), "{s:?} vs {w:?}");
        }
        assert!(temporal_seeds(&prev, 0, &moved).is_empty());
        assert_eq!(temporal_seeds(&prev, 99, &moved).len(), 3 * SEEDS_PER_DETECTION);
        // Turned boxes put their seeds along their own axis.
        let mut turned = det(0.0, 0.9);
        turned.b.heading = std::f32::consts::FRAC_PI_2;
        let s = temporal_seeds(&[turned], 3, &Pose::IDENTITY);
        assert!(
            (s[1][0] - 0.0).abs() < 1e-5 && (s[1][1] - (1.0 + 4.0 / 3.0)).abs() < 1e-5,
            "{s:?}"
        );
        let d = seed_distances(&seeds[..1], &[Box3d::new(18.5, 1.0, -1.0, 4.0, 1.6, 1.5, 0.0)]);
        assert_eq!(d, vec![0.5]);
        let stats = SeedStats::of(&[0.5, 9.5], &[2.5, 7.5], 4);
        assert_eq!((stats.seeds, stats.within_1m, stats.per_frame()), (2, 0.5, 0.5));
        assert_eq!((stats.median_m, stats.uncorrected_median_m), (9.5, 7.5));
    }

    #[test]
    fn prev_centers_parse_and_apply() {
        assert_eq!("32".parse::<PrevCenters>(), Ok(PrevCenters::Count(32)));
        assert_eq!("50%".parse::<PrevCenters>().map(|p| p.of(384)), Ok(192));
        assert_eq!(PrevCenters::Count(512).of(384), 384);
        assert!("150%".parse::<PrevCenters>().is_err() && "x".parse::<PrevCenters>().is_err());
        assert_eq!(PrevCenters::Percent(50).to_string(), "50%");
    }
}
