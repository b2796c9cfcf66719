//! Seeds from the previous frame: which detections, moved where, and how close to the objects
//! they seek they land.

use serde::{Deserialize, Serialize};
use starnet_data::Box3d;
use starnet_data::geometry::Pose;
use starnet_model::nms::Detection;

/// How many of a frame's centers come from the previous frame's detections.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
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

impl TryFrom<String> for PrevCenters {
    type Error = String;
    fn try_from(s: String) -> Result<Self, String> {
        s.parse()
    }
}

impl From<PrevCenters> for String {
    fn from(p: PrevCenters) -> String {
        p.to_string()
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

/// The centres of the `k` highest-scoring detections of frame t − 1 (ties in input order),
/// moved into frame t by `prev_to_now` (see `Pose::between`).
pub fn temporal_seeds(prev: &[Detection], k: usize, prev_to_now: &Pose) -> Vec<[f32; 3]> {
    let mut order: Vec<usize> = (0..prev.len()).collect();
    order.sort_by(|&i, &j| prev[j].score.total_cmp(&prev[i].score).then(i.cmp(&j)));
    order
        .into_iter()
        .take(k)
        .map(|i| prev_to_now.apply([prev[i].b.x, prev[i].b.y, prev[i].b.z]))
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
    /// Share of seeds within 1 m of a labelled object of the model's classes.
    pub within_1m: f64,
    /// Seeds from confident boxes (scoring above the final NMS threshold): the ones that seek
    /// an object; the others are mostly background guesses.
    pub confident: usize,
    /// Median distance from a confident seed to the nearest object, metres.
    pub median_m: f64,
    /// The same without the pose correction (seeds left at their frame t − 1 coordinates).
    pub uncorrected_median_m: f64,
}

impl SeedStats {
    /// From each seed's distance with and without the pose correction, and whether it came
    /// from a confident box.
    pub fn of(corrected: &[f32], uncorrected: &[f32], confident: &[bool]) -> Self {
        let median = |v: &[f32]| {
            let mut v: Vec<f32> = v
                .iter()
                .zip(confident)
                .filter(|(d, c)| **c && d.is_finite())
                .map(|(d, _)| *d)
                .collect();
            v.sort_by(f32::total_cmp);
            v.get(v.len() / 2).map_or(0.0, |&d| f64::from(d))
        };
        Self {
            seeds: corrected.len(),
            within_1m: corrected.iter().filter(|&&d| d <= 1.0).count() as f64 / corrected.len().max(1) as f64,
            confident: confident.iter().filter(|c| **c).count(),
            median_m: median(corrected),
            uncorrected_median_m: median(uncorrected),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(x: f32, score: f32) -> Detection {
        Detection {
            b: Box3d::new(x, 1.0, -1.0, 4.0, 1.6, 1.5, 0.0),
            class: 0,
            score,
        }
    }

    #[test]
    fn seeds_are_the_best_detections_moved_by_the_pose() {
        let prev = [det(10.0, 0.5), det(20.0, 0.9), det(30.0, 0.7)];
        // The ego drove 2 m forward: everything is 2 m closer.
        let moved = Pose::between(&Pose::IDENTITY, &Pose::from_xyz_yaw([2.0, 0.0, 0.0], 0.0));
        let seeds = temporal_seeds(&prev, 2, &moved);
        assert_eq!(seeds, vec![[18.0, 1.0, -1.0], [28.0, 1.0, -1.0]]);
        assert!(temporal_seeds(&prev, 0, &moved).is_empty());
        assert_eq!(temporal_seeds(&prev, 9, &moved).len(), 3);
        let d = seed_distances(&seeds, &[Box3d::new(18.5, 1.0, -1.0, 4.0, 1.6, 1.5, 0.0)]);
        assert_eq!(d, vec![0.5, 9.5]);
        let stats = SeedStats::of(&d, &[2.5, 7.5], &[true, false]);
        assert_eq!((stats.seeds, stats.confident, stats.within_1m), (2, 1, 0.5));
        assert_eq!((stats.median_m, stats.uncorrected_median_m), (0.5, 2.5));
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
