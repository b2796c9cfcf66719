//! Center sampling (StarNet §3.1): uniform random, farthest point sampling in bird's-eye view
//! (x, y) from a random first point, and seeded FPS, whose first centers are given positions
//! (e.g. the previous frame's detections) from which FPS continues.
//!
//! When the pool holds fewer points than centers requested, every pool point is used once and
//! the remaining slots repeat earlier centers with `valid = false`, so batch shapes stay fixed
//! and the model and loss can ignore the repeats (lingvo pads the same way).

use super::fps::fps;
use crate::Point;
use crate::geometry::GroundModel;
use rand::Rng;
use serde::{Deserialize, Serialize};

/// How centers are picked from the pool.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sampler {
    /// Uniformly at random without replacement.
    Random,
    /// Farthest point sampling in bird's-eye view.
    Fps,
}

impl Sampler {
    /// The name in figures and tables: `FPS` or `random`.
    pub fn label(self) -> &'static str {
        match self {
            Self::Random => "random",
            Self::Fps => "FPS",
        }
    }
}

impl std::str::FromStr for Sampler {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "random" => Ok(Self::Random),
            "fps" => Ok(Self::Fps),
            _ => Err(format!("unknown sampler `{s}` (expected `random` or `fps`)")),
        }
    }
}

/// The z given to centers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CenterZ {
    /// z = 0, as the authors' code (`fix_z_to_zero`); anchors carry a per-class z.
    Zero,
    /// The sampled point's own z.
    Point,
    /// z = 0 lifted by the local ground's rise under the center ([`level_centers`], with
    /// `pipeline.ground`): the center sits as high above a road that is not flat as [`Self::Zero`]
    /// sits above the flat reference ground, and the anchors with it.
    Ground,
}

/// Sampled centers `[C, 3]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Centers {
    /// Center positions.
    pub xyz: Vec<[f32; 3]>,
    /// False for the repeats that fill slots beyond the pool's size.
    pub valid: Vec<bool>,
    /// How many leading centers came from seeds.
    pub num_seeded: usize,
}

impl Centers {
    /// Number of centers C.
    pub fn len(&self) -> usize {
        self.xyz.len()
    }

    /// Whether there is no center.
    pub fn is_empty(&self) -> bool {
        self.xyz.is_empty()
    }
}

/// Picks `n` centers: the seeds first (at most `n`), then `n − seeds` from the pool points
/// `pool` (indices into `points`) with `sampler`, drawn as if there were no seeds. FPS does not
/// continue from the seeds: it would leave the ground around each seed to it alone, and a seed
/// placed on one car takes the centers of the cars parked beside it (temporal context at 128
/// centers lost 5-8 AP that way, and gains 5-9 with the FPS drawn on its own; issue #34).
pub fn sample_centers(
    points: &[Point],
    pool: &[usize],
    n: usize,
    sampler: Sampler,
    seeds: &[[f32; 3]],
    z: CenterZ,
    rng: &mut impl Rng,
) -> Centers {
    let seeds = &seeds[..seeds.len().min(n)];
    let want = n - seeds.len();
    let picked = match sampler {
        Sampler::Random => random_subset(pool.len(), want, rng),
        Sampler::Fps => fps(points, pool, want, &[], rng),
    };
    let mut xyz: Vec<[f32; 3]> = seeds.iter().map(|s| [s[0], s[1], center_z(s, z)]).collect();
    xyz.extend(picked.iter().map(|&k| {
        let p = &points[pool[k]];
        [p[0], p[1], center_z(p, z)]
    }));
    padded(xyz, n, seeds.len())
}

/// Picks `n` centers from `pool` as FPS would had it already placed `placed` (the centers of
/// the slices before this one, say): distances start from them, so the new centers fill what
/// they leave open instead of crowding against them. `placed` are not returned. The random
/// sampler ignores them.
pub fn continue_centers(
    points: &[Point],
    pool: &[usize],
    n: usize,
    sampler: Sampler,
    placed: &[[f32; 3]],
    z: CenterZ,
    rng: &mut impl Rng,
) -> Centers {
    let picked = match sampler {
        Sampler::Random => random_subset(pool.len(), n, rng),
        Sampler::Fps => fps(points, pool, n, placed, rng),
    };
    let xyz = picked
        .iter()
        .map(|&k| {
            let p = &points[pool[k]];
            [p[0], p[1], center_z(p, z)]
        })
        .collect();
    padded(xyz, n, 0)
}

/// FPS over `pool` continued from `placed` (not returned), at most `max` picks, stopping before
/// the first pick that would lie closer than `spacing` (bird's-eye view) to a center already
/// there: the positions, unpadded, z as [`CenterZ`] says. FPS picks ever closer to their
/// nearest center, so the stop leaves every pool point within `spacing` of a center unless
/// `max` ran out.
pub fn spaced_centers(
    points: &[Point],
    pool: &[usize],
    max: usize,
    placed: &[[f32; 3]],
    spacing: f32,
    z: CenterZ,
    rng: &mut impl Rng,
) -> Vec<[f32; 3]> {
    let picks = fps(points, pool, max, placed, rng);
    let mut kept: Vec<[f32; 3]> = Vec::with_capacity(picks.len());
    for &k in &picks {
        let p = &points[pool[k]];
        let near = |c: &[f32; 3]| (c[0] - p[0]).hypot(c[1] - p[1]) < spacing;
        if placed.iter().chain(&kept).any(near) {
            break;
        }
        kept.push([p[0], p[1], center_z(p, z)]);
    }
    kept
}

/// A center's z before levelling: the point's own for [`CenterZ::Point`], else 0.
fn center_z(p: &[f32], z: CenterZ) -> f32 {
    if z == CenterZ::Point { p[2] } else { 0.0 }
}

/// `xyz` filled to `n` centers: the slots beyond the real ones repeat them (the sensor origin
/// when there is none) and are marked invalid.
pub(crate) fn padded(mut xyz: Vec<[f32; 3]>, n: usize, num_seeded: usize) -> Centers {
    let mut valid = vec![true; xyz.len()];
    let real = xyz.len();
    for i in real..n {
        xyz.push(if real > 0 { xyz[i % real] } else { [0.0; 3] });
        valid.push(false);
    }
    Centers { xyz, valid, num_seeded }
}

/// Lifts [`CenterZ::Ground`] centers by the ground's rise under each, so that they sit as high
/// above a road that is not flat as z = 0 sits above the reference ground (and the anchors,
/// whose z is relative to the center, with them). Other centers keep their z.
pub fn level_centers(centers: &mut Centers, z: CenterZ, ground: &GroundModel) {
    if z == CenterZ::Ground {
        for c in &mut centers.xyz {
            c[2] = ground.rise_at(c[0], c[1]);
        }
    }
}

/// `k` distinct indices of `0..n` (all of them, shuffled, if `k ≥ n`).
fn random_subset(n: usize, k: usize, rng: &mut impl Rng) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..n).collect();
    let k = k.min(n);
    for i in 0..k {
        let j = rng.random_range(i..n);
        idx.swap(i, j);
    }
    idx.truncate(k);
    idx
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn cloud(n: usize, seed: u64) -> Vec<Point> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                [
                    rng.random_range(-40.0..40.0),
                    rng.random_range(-40.0..40.0),
                    rng.random_range(-1.0..1.0),
                    0.2,
                ]
            })
            .collect()
    }

    fn min_pairwise(c: &Centers) -> f32 {
        let mut m = f32::INFINITY;
        for i in 0..c.len() {
            for j in i + 1..c.len() {
                m = m.min((c.xyz[i][0] - c.xyz[j][0]).hypot(c.xyz[i][1] - c.xyz[j][1]));
            }
        }
        m
    }

    #[test]
    fn fps_picks_no_point_twice_and_spreads_better_than_random() {
        let pts = cloud(3000, 1);
        let pool: Vec<usize> = (0..pts.len()).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let f = sample_centers(&pts, &pool, 256, Sampler::Fps, &[], CenterZ::Point, &mut rng);
        let r = sample_centers(&pts, &pool, 256, Sampler::Random, &[], CenterZ::Point, &mut rng);
        let mut seen = f
            .xyz
            .iter()
            .map(|p| (p[0].to_bits(), p[1].to_bits()))
            .collect::<Vec<_>>();
        seen.sort();
        seen.dedup();
        assert_eq!(seen.len(), 256);
        assert!(
            min_pairwise(&f) > 2.0 * min_pairwise(&r),
            "{} vs {}",
            min_pairwise(&f),
            min_pairwise(&r)
        );
        assert!(f.valid.iter().all(|v| *v));
    }

    #[test]
    fn fps_never_repeats_even_with_coincident_points() {
        let mut pts = cloud(50, 3);
        pts.extend(pts.clone()); // every point twice
        let pool: Vec<usize> = (0..pts.len()).collect();
        let picks = fps(&pts, &pool, 100, &[], &mut ChaCha8Rng::seed_from_u64(4));
        let mut sorted = picks.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), 100, "all 100 pool points, none twice");
    }

    #[test]
    fn continued_fps_fills_what_the_placed_centers_leave_open() {
        // A line of points along x from 0 to 40 m; centers already placed at 0 and 20 m.
        let pts: Vec<Point> = (0..=400).map(|i| [i as f32 * 0.1, 0.0, 0.0, 0.0]).collect();
        let pool: Vec<usize> = (0..pts.len()).collect();
        let placed = [[0.0, 0.0, 0.0], [20.0, 0.0, 0.0]];
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let c = continue_centers(&pts, &pool, 3, Sampler::Fps, &placed, CenterZ::Point, &mut rng);
        // Hand-computed: 40 m (20 from the nearest), then 10 m and 30 m (10 from the nearest;
        // ties go to the lower pool index).
        let xs: Vec<f32> = c.xyz.iter().map(|p| p[0]).collect();
        assert_eq!(xs.len(), 3);
        for (x, want) in xs.iter().zip([40.0, 10.0, 30.0]) {
            assert!((x - want).abs() < 1e-4, "{xs:?}");
        }
        assert_eq!(c.num_seeded, 0, "the placed centers are not returned");
        // More centers than pool points: the rest are invalid repeats.
        let few = continue_centers(&pts[..2], &[0, 1], 4, Sampler::Fps, &placed, CenterZ::Zero, &mut rng);
        assert_eq!(few.valid, [true, true, false, false]);
    }

    #[test]
    fn fps_matches_a_brute_force_oracle() {
        let pts = cloud(500, 5);
        let pool: Vec<usize> = (0..pts.len()).collect();
        let picks = fps(&pts, &pool, 40, &[[0.0, 0.0, 0.0]], &mut ChaCha8Rng::seed_from_u64(6));
        // Oracle: the point maximising the distance to its nearest chosen center, naively.
        let mut chosen = vec![[0.0f32, 0.0]];
        for &p in &picks {
            let far = (0..pts.len())
                .map(|i| {
                    (
                        i,
                        chosen
                            .iter()
                            .map(|c| (pts[i][0] - c[0]).powi(2) + (pts[i][1] - c[1]).powi(2))
                            .fold(f32::INFINITY, f32::min),
                    )
                })
                .fold((0, f32::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
            assert_eq!(p, far.0);
            chosen.push([pts[p][0], pts[p][1]]);
        }
    }

    #[test]
    fn seeded_fps_returns_the_seeds_first() {
        let pts = cloud(1000, 7);
        let pool: Vec<usize> = (0..pts.len()).collect();
        let seeds = [[1.0, 2.0, -0.5], [-3.0, 4.0, 0.5]];
        let c = sample_centers(
            &pts,
            &pool,
            10,
            Sampler::Fps,
            &seeds,
            CenterZ::Point,
            &mut ChaCha8Rng::seed_from_u64(8),
        );
        assert_eq!(c.num_seeded, 2);
        assert_eq!(&c.xyz[..2], &seeds);
        // The rest is FPS drawn as if there were no seeds: the same picks as eight unseeded
        // centers from the same generator.
        let plain = sample_centers(
            &pts,
            &pool,
            8,
            Sampler::Fps,
            &[],
            CenterZ::Point,
            &mut ChaCha8Rng::seed_from_u64(8),
        );
        assert_eq!(&c.xyz[2..], &plain.xyz[..]);
        let z0 = sample_centers(
            &pts,
            &pool,
            10,
            Sampler::Fps,
            &seeds,
            CenterZ::Zero,
            &mut ChaCha8Rng::seed_from_u64(8),
        );
        assert!(z0.xyz.iter().all(|p| p[2] == 0.0));
    }

    #[test]
    fn levelled_centers_sit_on_the_ground_rise() {
        use crate::geometry::GroundConfig;
        let road: Vec<Point> = (0..100)
            .map(|i| [i as f32 * 0.4, 0.0, -1.73 + 0.02 * i as f32 * 0.4, 0.1])
            .collect();
        let ground = GroundModel::fit(&road, &GroundConfig::default());
        let pool: Vec<usize> = (0..road.len()).collect();
        for z in [CenterZ::Zero, CenterZ::Point, CenterZ::Ground] {
            let mut c = sample_centers(&road, &pool, 8, Sampler::Fps, &[], z, &mut ChaCha8Rng::seed_from_u64(3));
            let before = c.clone();
            level_centers(&mut c, z, &ground);
            for (a, b) in c.xyz.iter().zip(&before.xyz) {
                let want = match z {
                    CenterZ::Ground => ground.height_at(a[0], a[1]) + 1.73,
                    CenterZ::Zero | CenterZ::Point => b[2],
                };
                assert!((a[2] - want).abs() < 1e-5, "{z:?}: {} vs {want}", a[2]);
            }
        }
    }

    #[test]
    fn small_pool_repeats_and_masks() {
        let pts = cloud(5, 9);
        for sampler in [Sampler::Fps, Sampler::Random] {
            let c = sample_centers(
                &pts,
                &[0, 1, 2],
                8,
                sampler,
                &[],
                CenterZ::Point,
                &mut ChaCha8Rng::seed_from_u64(1),
            );
            assert_eq!(c.len(), 8);
            assert_eq!(c.valid, [true, true, true, false, false, false, false, false]);
            assert_eq!(c.xyz[3], c.xyz[0]);
        }
        let none = sample_centers(
            &pts,
            &[],
            4,
            Sampler::Fps,
            &[],
            CenterZ::Point,
            &mut ChaCha8Rng::seed_from_u64(1),
        );
        assert_eq!((none.len(), none.valid.iter().any(|v| *v)), (4, false));
    }
}
