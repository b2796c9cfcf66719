//! Object coverage by sampled centers (the StarNet paper's figure 5): the share of objects with
//! at least `min_points` points that have BEV IoU above `iou` with at least one anchor placed
//! around the first `n` sampled centers, for each sampler and each `n`.
//!
//! Both samplers are prefix-consistent (the first n of an FPS run, or of a random permutation,
//! are what a run asked for n would pick), so one run per frame at the largest `n` serves all.

use super::{AnchorGrid, CenterPoolConfig, CenterZ, Sampler, center_pool, sample_centers};
use crate::Result;
use crate::geometry::{GroundConfig, GroundModel, iou_bev};
use crate::kitti::{KittiDataset, ObjectClass};
use crate::par::parallel_for;
use crate::seed::sub_seed;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::sync::Mutex;

/// What to measure.
#[derive(Debug, Clone, PartialEq)]
pub struct CoverageConfig {
    /// Center counts, ascending.
    pub samples: Vec<usize>,
    /// Samplers to compare.
    pub samplers: Vec<Sampler>,
    /// The center pool.
    pub pool: CenterPoolConfig,
    /// The local ground the pool's z band is measured from (`None`: the sensor's z).
    pub ground: Option<GroundConfig>,
    /// Objects need at least this many points to count (5 in the paper).
    pub min_points: usize,
    /// IoU above which an anchor covers an object (0.5).
    pub iou: f32,
    /// Classes counted; each uses its [`AnchorGrid::for_class`] anchors.
    pub classes: Vec<ObjectClass>,
}

/// Coverage per sampler (rows) and center count (columns), in percent.
#[derive(Debug, Clone, PartialEq)]
pub struct CoverageTable {
    /// Center counts.
    pub samples: Vec<usize>,
    /// Per sampler, the share of objects covered at each count.
    pub rows: Vec<(Sampler, Vec<f64>)>,
    /// Objects counted.
    pub objects: usize,
}

/// For each object, the index of the first center whose anchors cover it, if one does.
fn first_cover(centers: &[[f32; 3]], objects: &[(crate::Box3d, AnchorGrid)], iou: f32) -> Vec<Option<usize>> {
    objects
        .iter()
        .map(|(b, grid)| {
            let reach = b.bev_radius() + grid.extent * std::f32::consts::SQRT_2 + grid.max_radius();
            centers.iter().position(|c| {
                (c[0] - b.x).hypot(c[1] - b.y) <= reach && grid.anchors_around(*c).iter().any(|a| iou_bev(a, b) > iou)
            })
        })
        .collect()
}

/// Measures coverage over every frame of `dataset`, in parallel; deterministic for `seed`.
pub fn coverage(dataset: &KittiDataset, cfg: &CoverageConfig, seed: u64) -> Result<CoverageTable> {
    let max_n = cfg.samples.iter().copied().max().unwrap_or(0);
    // Per sampler and count: objects covered; plus the object total.
    let tally = Mutex::new((vec![vec![0usize; cfg.samples.len()]; cfg.samplers.len()], 0usize));
    parallel_for(dataset.ids().len(), |f| {
        let frame = dataset.load(&dataset.ids()[f])?;
        let objects: Vec<_> = frame
            .labelled_boxes()
            .into_iter()
            .filter(|(o, b)| cfg.classes.contains(&o.class) && b.count_points_inside(&frame.points) >= cfg.min_points)
            .map(|(o, b)| (b, AnchorGrid::for_class(o.class)))
            .collect();
        let ground = cfg.ground.as_ref().map(|g| GroundModel::fit(&frame.points, g));
        let pool = center_pool(
            &frame.points,
            &cfg.pool,
            Some((&frame.calib, frame.image_size)),
            ground.as_ref(),
        );
        let mut local = vec![vec![0usize; cfg.samples.len()]; cfg.samplers.len()];
        for (s, &sampler) in cfg.samplers.iter().enumerate() {
            let mut rng = ChaCha8Rng::seed_from_u64(sub_seed(seed, s as u64, f as u64));
            let centers = sample_centers(&frame.points, &pool, max_n, sampler, &[], CenterZ::Zero, &mut rng);
            let real = centers.valid.iter().filter(|v| **v).count();
            let first = first_cover(&centers.xyz[..real], &objects, cfg.iou);
            for (k, &n) in cfg.samples.iter().enumerate() {
                local[s][k] = first.iter().filter(|i| i.is_some_and(|i| i < n)).count();
            }
        }
        let mut t = tally.lock().expect("no panics while holding it");
        t.1 += objects.len();
        for (s, row) in local.iter().enumerate() {
            for (k, v) in row.iter().enumerate() {
                t.0[s][k] += v;
            }
        }
        Ok(())
    })?;
    let (counts, objects) = tally.into_inner().expect("no panics while holding it");
    let rows = cfg
        .samplers
        .iter()
        .zip(counts)
        .map(|(s, c)| {
            (
                *s,
                c.into_iter()
                    .map(|v| 100.0 * v as f64 / objects.max(1) as f64)
                    .collect(),
            )
        })
        .collect();
    Ok(CoverageTable {
        samples: cfg.samples.clone(),
        rows,
        objects,
    })
}

impl std::fmt::Display for CoverageTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "object coverage (%), {} objects", self.objects)?;
        write!(f, "| sampler |")?;
        self.samples.iter().try_for_each(|n| write!(f, " {n} |"))?;
        writeln!(f)?;
        write!(f, "|---|")?;
        self.samples.iter().try_for_each(|_| write!(f, "---|"))?;
        writeln!(f)?;
        for (s, row) in &self.rows {
            write!(f, "| {s:?} |")?;
            row.iter().try_for_each(|v| write!(f, " {v:.1} |"))?;
            writeln!(f)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Box3d;

    #[test]
    fn a_center_on_the_object_covers_it_a_far_one_does_not() {
        let car = Box3d::new(10.0, 5.0, -1.0, 3.9, 1.6, 1.5, 0.05);
        let objs = vec![(car, AnchorGrid::kitti_car())];
        assert_eq!(
            first_cover(&[[50.0, 0.0, 0.0], [10.3, 5.2, 0.0]], &objs, 0.5),
            vec![Some(1)]
        );
        assert_eq!(first_cover(&[[50.0, 0.0, 0.0]], &objs, 0.5), vec![None]);
        // 1.5 m off: the grid's ±1.294 m offsets still reach it.
        assert_eq!(first_cover(&[[11.5, 5.0, 0.0]], &objs, 0.5), vec![Some(0)]);
    }
}
