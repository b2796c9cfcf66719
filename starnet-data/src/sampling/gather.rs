//! Neighbourhoods (StarNet §3.2): for each center, P points drawn uniformly at random without
//! replacement among those within R of it (3D distance as in the paper, or the horizontal
//! distance: [`GatherMetric`]), re-centred, padded and masked. Points
//! are found through a spatial hash grid of R-sized cells in (x, y), never a dense C × N
//! distance matrix.

use super::Centers;
use crate::Point;
use crate::geometry::{GatherMetric, SpatialGrid};
use crate::settings::{Checked, at_least_one, positive};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// Per-point input features F: `(x − cx, y − cy, z − cz, reflectance)`.
pub const NUM_FEATURES: usize = 4;

/// What the fourth feature carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReflectanceInput {
    /// The point's reflectance as the sensor reported it (the paper's).
    #[default]
    Measured,
    /// Always 0: a geometry-only model, for sensors whose reflectance scale differs from the
    /// training data's (the feature count, and so the weights' shapes, stay those of the paper).
    Ignored,
}

impl ReflectanceInput {
    /// The feature for a point with reflectance `r`.
    pub fn feature(self, r: f32) -> f32 {
        match self {
            Self::Measured => r,
            Self::Ignored => 0.0,
        }
    }
}

impl GatherConfig {
    /// Checks P ≥ 1 and R > 0 (keys relative to the gather table).
    pub fn validate(&self) -> Checked {
        at_least_one("num_points", self.num_points)?;
        positive("radius", self.radius as f64)
    }
}

/// Neighbourhood size, radius and metric.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GatherConfig {
    /// Points per center P.
    pub num_points: usize,
    /// Radius R (m).
    pub radius: f32,
    /// The distance R bounds (`ball`, the paper's, or `cylinder`).
    #[serde(default)]
    pub metric: GatherMetric,
    /// What the fourth feature carries (`measured`, the paper's, or `ignored`).
    #[serde(default)]
    pub reflectance: ReflectanceInput,
}

/// The gathered neighbourhoods of C centers, ready to batch.
#[derive(Debug, Clone, PartialEq)]
pub struct Neighbourhoods {
    /// C.
    pub num_centers: usize,
    /// P.
    pub num_points: usize,
    /// `[C, P, F]` features, zeros in padded slots.
    pub features: Vec<f32>,
    /// `[C, P]`, true for real points.
    pub mask: Vec<bool>,
    /// `[C, P]` indices into the cloud, `None` in padded slots.
    pub indices: Vec<Option<u32>>,
}

impl Neighbourhoods {
    /// Real points of center `c`.
    pub fn count(&self, c: usize) -> usize {
        self.mask[c * self.num_points..(c + 1) * self.num_points]
            .iter()
            .filter(|m| **m)
            .count()
    }
}

/// Gathers the neighbourhood of every center.
pub fn gather(points: &[Point], centers: &Centers, cfg: &GatherConfig, rng: &mut impl Rng) -> Neighbourhoods {
    // Half-radius cells: a query scans about (2.5 R)² instead of (3 R)² around the center.
    let grid = SpatialGrid::new(points, 0.5 * cfg.radius);
    gather_with_grid(points, &grid, centers, cfg, rng)
}

/// [`gather`] with a prebuilt grid (cells of R/2 are fastest).
pub fn gather_with_grid(
    points: &[Point],
    grid: &SpatialGrid,
    centers: &Centers,
    cfg: &GatherConfig,
    rng: &mut impl Rng,
) -> Neighbourhoods {
    let (c_n, p_n) = (centers.len(), cfg.num_points);
    let mut out = Neighbourhoods {
        num_centers: c_n,
        num_points: p_n,
        features: vec![0.0; c_n * p_n * NUM_FEATURES],
        mask: vec![false; c_n * p_n],
        indices: vec![None; c_n * p_n],
    };
    let mut candidates = Vec::new();
    for (c, center) in centers.xyz.iter().enumerate() {
        candidates.clear();
        grid.within(*center, cfg.radius, cfg.metric, &mut candidates);
        // A uniform random subset without replacement: the first k of a partial shuffle.
        let k = candidates.len().min(p_n);
        for i in 0..k {
            let j = rng.random_range(i..candidates.len());
            candidates.swap(i, j);
        }
        for (slot, &pi) in candidates[..k].iter().enumerate() {
            let p = &points[pi as usize];
            let at = c * p_n + slot;
            out.mask[at] = true;
            out.indices[at] = Some(pi);
            out.features[at * NUM_FEATURES..(at + 1) * NUM_FEATURES].copy_from_slice(&[
                p[0] - center[0],
                p[1] - center[1],
                p[2] - center[2],
                cfg.reflectance.feature(p[3]),
            ]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{CenterZ, Sampler, sample_centers};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn cloud(n: usize) -> Vec<Point> {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        (0..n)
            .map(|_| {
                [
                    rng.random_range(-20.0..20.0),
                    rng.random_range(-20.0..20.0),
                    rng.random_range(-2.0..1.0),
                    rng.random_range(0.0..1.0),
                ]
            })
            .collect()
    }

    #[test]
    fn grid_query_equals_brute_force() {
        let pts = cloud(5000);
        let grid = SpatialGrid::new(&pts, 0.7);
        let mut got = Vec::new();
        for c in [[0.0, 0.0, 0.0], [19.5, -19.5, -1.0], [3.3, 7.1, 0.5]] {
            got.clear();
            grid.within(c, 2.0, GatherMetric::Ball, &mut got);
            got.sort();
            let want: Vec<u32> = (0..pts.len() as u32)
                .filter(|&i| {
                    let p = pts[i as usize];
                    (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2) <= 4.0
                })
                .collect();
            assert_eq!(got, want);
        }
    }

    #[test]
    fn queries_beyond_the_grid_find_nothing() {
        let pts = cloud(500);
        let grid = SpatialGrid::new(&pts, 0.7);
        let mut got = Vec::new();
        // Beyond every side, and past the far corner (this used to index out of bounds).
        for c in [
            [0.0, 60.0, 0.0],
            [0.0, -60.0, 0.0],
            [60.0, 0.0, 0.0],
            [-60.0, 0.0, 0.0],
            [60.0, 60.0, 0.0],
            [20.5, 20.5, 0.0],
        ] {
            grid.within(c, 0.3, GatherMetric::Ball, &mut got);
        }
        assert!(got.is_empty(), "{got:?}");
        // Just inside the edge still finds the edge points.
        grid.within([19.9, 19.9, 0.0], 3.0, GatherMetric::Ball, &mut got);
        let want = pts
            .iter()
            .filter(|p| (p[0] - 19.9).powi(2) + (p[1] - 19.9).powi(2) + p[2].powi(2) <= 9.0)
            .count();
        assert_eq!(got.len(), want);
    }

    #[test]
    fn the_cylinder_ignores_height() {
        let pts = cloud(5000);
        let grid = SpatialGrid::new(&pts, 1.0);
        let c = [2.0, -3.0, 4.0];
        let mut got = Vec::new();
        grid.within(c, 1.5, GatherMetric::Cylinder, &mut got);
        got.sort();
        let want: Vec<u32> = (0..pts.len() as u32)
            .filter(|&i| (pts[i as usize][0] - 2.0).hypot(pts[i as usize][1] + 3.0) <= 1.5)
            .collect();
        // The cloud lies 3–6 m below c: the ball would hold nothing.
        assert!(want.len() > 20);
        assert_eq!(got, want);
        got.clear();
        grid.within(c, 1.5, GatherMetric::Ball, &mut got);
        assert!(got.is_empty());
    }

    #[test]
    fn gathered_points_lie_within_r_and_masks_match_counts() {
        let pts = cloud(20000);
        let pool: Vec<usize> = (0..pts.len()).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let centers = sample_centers(&pts, &pool, 64, Sampler::Fps, &[], CenterZ::Point, &mut rng);
        let cfg = GatherConfig {
            num_points: 32,
            radius: 1.0,
            metric: GatherMetric::Ball,
            reflectance: ReflectanceInput::Measured,
        };
        let n = gather(&pts, &centers, &cfg, &mut rng);
        let grid = SpatialGrid::new(&pts, 1.0);
        let mut all = Vec::new();
        for c in 0..64 {
            all.clear();
            grid.within(centers.xyz[c], 1.0, GatherMetric::Ball, &mut all);
            assert_eq!(n.count(c), all.len().min(32), "center {c}");
            let mut idx: Vec<u32> = (0..32)
                .filter(|&s| n.mask[c * 32 + s])
                .filter_map(|s| n.indices[c * 32 + s])
                .collect();
            for (s, &i) in idx.iter().enumerate() {
                let f = &n.features[(c * 32 + s) * 4..(c * 32 + s + 1) * 4];
                assert!(f[0] * f[0] + f[1] * f[1] + f[2] * f[2] <= 1.0 + 1e-5);
                assert_eq!(f[3], pts[i as usize][3]);
            }
            idx.sort();
            idx.dedup();
            assert_eq!(idx.len(), n.count(c), "no point twice");
            // Padded slots hold zeros.
            assert!((n.count(c)..32).all(|s| n.features[(c * 32 + s) * 4..(c * 32 + s + 1) * 4] == [0.0; 4]));
        }
    }

    #[test]
    fn ignored_reflectance_gathers_the_same_points_with_a_zero_fourth_feature() {
        let pts: Vec<Point> = cloud(5000).into_iter().map(|p| [p[0], p[1], p[2], 0.37]).collect();
        let pool: Vec<usize> = (0..pts.len()).collect();
        let centers = sample_centers(
            &pts,
            &pool,
            16,
            Sampler::Fps,
            &[],
            CenterZ::Point,
            &mut ChaCha8Rng::seed_from_u64(3),
        );
        let measured = GatherConfig {
            num_points: 16,
            radius: 1.0,
            metric: GatherMetric::Ball,
            reflectance: ReflectanceInput::Measured,
        };
        let ignored = GatherConfig {
            reflectance: ReflectanceInput::Ignored,
            ..measured
        };
        let a = gather(&pts, &centers, &measured, &mut ChaCha8Rng::seed_from_u64(4));
        let b = gather(&pts, &centers, &ignored, &mut ChaCha8Rng::seed_from_u64(4));
        assert_eq!((&a.mask, &a.indices), (&b.mask, &b.indices));
        for (fa, fb) in a.features.chunks(4).zip(b.features.chunks(4)) {
            assert_eq!(fa[..3], fb[..3]);
            assert_eq!(fb[3], 0.0);
        }
        assert!(a.features.chunks(4).any(|f| f[3] == 0.37));
    }

    #[test]
    fn sampling_is_uniform_among_the_candidates() {
        // 10 points within R, 5 slots: each point should be picked about half the time.
        let pts: Vec<Point> = (0..10).map(|i| [0.05 * i as f32, 0.0, 0.0, 0.0]).collect();
        let centers = Centers {
            xyz: vec![[0.0; 3]],
            valid: vec![true],
            num_seeded: 0,
        };
        let cfg = GatherConfig {
            num_points: 5,
            radius: 1.0,
            metric: GatherMetric::Ball,
            reflectance: ReflectanceInput::Measured,
        };
        let mut hits = [0u32; 10];
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..4000 {
            let n = gather(&pts, &centers, &cfg, &mut rng);
            n.indices.iter().flatten().for_each(|&i| hits[i as usize] += 1);
        }
        assert!(hits.iter().all(|&h| (1800..2200).contains(&h)), "{hits:?}");
    }
}
