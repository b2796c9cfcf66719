//! Ground-truth database paste (lingvo `GroundTruthAugmentor`, OpenPCDet `database_sampler`):
//! objects of the database are added to the scene at their original pose, as many per class
//! as needed to reach the class's target, skipping any whose footprint would touch an existing
//! or already-pasted box (rotated BEV IoU must be exactly 0).

use super::near::{near_grid, points_near};
use super::{GtDatabase, Scene};
use crate::geometry::iou_bev;
use crate::kitti::ObjectClass;
use crate::{Box3d, Point};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Paste settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DbPasteConfig {
    /// Whether the step runs.
    pub enabled: bool,
    /// Per class, the number of objects the scene is filled up to (lingvo car: 15).
    pub max_per_class: BTreeMap<ObjectClass, usize>,
    /// Per class, the fewest points a database object needs to be used (lingvo car: 5).
    pub min_points: BTreeMap<ObjectClass, usize>,
    /// Remove the scene's points inside a pasted box (OpenPCDet does; lingvo keeps them).
    pub remove_covered_points: bool,
}

impl Default for DbPasteConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            max_per_class: BTreeMap::from([(ObjectClass::Car, 15)]),
            min_points: BTreeMap::from([
                (ObjectClass::Car, 5),
                (ObjectClass::Pedestrian, 7),
                (ObjectClass::Cyclist, 7),
            ]),
            remove_covered_points: true,
        }
    }
}

/// Pastes database objects into `scene` (each with its points within `margin` of its box,
/// [`crate::Box3d::grown`]); returns the indices of the pasted entries.
pub fn paste_from_database(
    scene: &mut Scene,
    db: &GtDatabase,
    cfg: &DbPasteConfig,
    margin: f32,
    rng: &mut impl Rng,
) -> Vec<usize> {
    let mut pasted = Vec::new();
    // Per pasted object, where its points start in the cloud and the grown box that covers
    // the points already there.
    let mut covers: Vec<(usize, Box3d)> = Vec::new();
    for (&class, &target) in &cfg.max_per_class {
        let have = scene.classes.iter().filter(|c| **c == class).count();
        let want = target.saturating_sub(have);
        if want == 0 {
            continue;
        }
        let min_points = cfg.min_points.get(&class).copied().unwrap_or(0);
        let mut candidates: Vec<usize> = (0..db.entries.len())
            // Counting stops at `min_points`: an entry's points are mostly inside its box, so this
            // reads a handful of points per entry instead of all of them (it was a third of the
            // loader's time).
            .filter(|&i| {
                let e = &db.entries[i];
                e.class == class && e.points_within(margin).take(min_points).count() >= min_points
            })
            .collect();
        // Try up to three candidates per wanted object, in random order, without replacement.
        let tries = candidates.len().min(3 * want);
        for t in 0..tries {
            let j = rng.random_range(t..candidates.len());
            candidates.swap(t, j);
        }
        let mut added = 0;
        for &i in &candidates[..tries] {
            if added == want {
                break;
            }
            let e = &db.entries[i];
            if scene.boxes.iter().any(|b| iou_bev(b, &e.b) > 0.0) {
                continue;
            }
            covers.push((scene.points.len(), e.b.grown(margin)));
            scene.points.extend(e.points_within(margin));
            scene.boxes.push(e.b);
            scene.classes.push(class);
            pasted.push(i);
            added += 1;
        }
    }
    if cfg.remove_covered_points {
        remove_covered(&mut scene.points, &covers);
    }
    pasted
}

/// Removes the points each pasted object covers, in one pass: what removing, as each object
/// is pasted, the points then in the cloud inside its grown box would leave. A point is
/// dropped when a box pasted after it arrived holds it: the scene's own points by any pasted
/// box, a pasted object's points by the boxes pasted after it. `covers` holds per pasted
/// object, in paste order, the index its points start at and its grown box.
fn remove_covered(points: &mut Vec<Point>, covers: &[(usize, Box3d)]) {
    // Each box looks at the points near it only.
    let grid = near_grid(points);
    let mut covered = vec![false; points.len()];
    let mut near = Vec::new();
    for (start, b) in covers {
        let holds = b.point_test();
        points_near(&grid, b, &mut near);
        for k in near.iter().map(|&k| k as usize) {
            // Only the points there before this object was pasted.
            if k < *start && holds(&points[k]) {
                covered[k] = true;
            }
        }
    }
    let mut k = 0;
    points.retain(|_| {
        k += 1;
        !covered[k - 1]
    });
}

#[cfg(test)]
mod tests {
    use super::super::GtEntry;
    use super::*;
    use crate::Box3d;
    use rand::SeedableRng;

    fn db() -> GtDatabase {
        // A row of cars 3 m apart: neighbours overlap, so not all of them can be pasted together.
        let entries = (0..40)
            .map(|i| {
                let b = Box3d::new(
                    5.0 + 3.0 * i as f32,
                    (i % 3) as f32 * 2.0 - 2.0,
                    -1.0,
                    3.9,
                    1.6,
                    1.5,
                    0.1 * i as f32,
                );
                let pts = (0..if i % 5 == 0 { 3 } else { 20 })
                    .map(|k| {
                        let q = b.from_local([0.1 * (k % 7) as f32 - 0.3, 0.0, 0.0]);
                        [q[0], q[1], q[2], 0.4]
                    })
                    .collect();
                GtEntry {
                    frame: format!("{i:06}"),
                    class: ObjectClass::Car,
                    difficulty: None,
                    b,
                    points: pts,
                }
            })
            .collect();
        GtDatabase { entries }
    }

    #[test]
    fn covered_points_are_those_a_later_box_holds() {
        // The rule itself, point by point, as the oracle: drop point k if a box pasted after
        // it arrived holds it.
        let naive = |points: &[Point], covers: &[(usize, Box3d)]| -> Vec<Point> {
            let later = |k: usize| covers.iter().filter(move |(start, _)| *start > k);
            (0..points.len())
                .filter(|&k| !later(k).any(|(_, b)| b.point_test()(&points[k])))
                .map(|k| points[k])
                .collect()
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
        let mut points: Vec<Point> = (0..3000)
            .map(|_| {
                [
                    rng.random_range(-20.0..20.0),
                    rng.random_range(-20.0..20.0),
                    rng.random_range(-2.0..1.0),
                    0.0,
                ]
            })
            .collect();
        let mut covers = Vec::new();
        for i in 0..6 {
            let b = Box3d::new(
                -10.0 + 4.0 * i as f32,
                (i % 2) as f32,
                -0.5,
                4.5,
                2.0,
                2.0,
                0.3 * i as f32,
            );
            covers.push((points.len(), b));
            // The object's own points, partly inside the next box.
            points.extend((0..50).map(|_| {
                let q = b.from_local([
                    rng.random_range(-0.5..0.5) * 6.0,
                    rng.random_range(-0.5..0.5) * 2.0,
                    0.0,
                ]);
                [q[0], q[1], q[2], 1.0]
            }));
        }
        let want = naive(&points, &covers);
        assert!(
            want.len() + 50 < points.len() && want.len() > 2000,
            "{} kept",
            want.len()
        );
        remove_covered(&mut points, &covers);
        assert_eq!(points, want);
    }

    #[test]
    fn paste_never_creates_overlapping_boxes() {
        let db = db();
        for seed in 0..50 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let existing = Box3d::new(20.0, 0.0, -1.0, 3.9, 1.6, 1.5, 0.0);
            let mut scene = Scene {
                points: vec![[20.0, 0.0, -1.0, 0.1], [80.0, 0.0, -1.0, 0.1]],
                boxes: vec![existing],
                classes: vec![ObjectClass::Car],
            };
            let pasted = paste_from_database(&mut scene, &db, &DbPasteConfig::default(), 0.1, &mut rng);
            assert!(!pasted.is_empty() && scene.boxes.len() <= 15);
            for (i, a) in scene.boxes.iter().enumerate() {
                for b in &scene.boxes[i + 1..] {
                    assert_eq!(iou_bev(a, b), 0.0, "seed {seed}");
                }
            }
            assert!(
                pasted.iter().all(|&i| db.entries[i].points.len() >= 5),
                "min points respected"
            );
            let n_pts: usize = pasted.iter().map(|&i| db.entries[i].points.len()).sum();
            assert_eq!(
                scene.points.len(),
                2 + n_pts
                    - pasted
                        .iter()
                        .filter(|&&i| db.entries[i].b.contains([80.0, 0.0, -1.0]))
                        .count()
            );
        }
    }

    #[test]
    fn full_scene_pastes_nothing() {
        let mut scene = Scene {
            points: vec![],
            boxes: vec![Box3d::new(0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0); 15],
            classes: vec![ObjectClass::Car; 15],
        };
        assert!(
            paste_from_database(
                &mut scene,
                &db(),
                &DbPasteConfig::default(),
                0.1,
                &mut rand_chacha::ChaCha8Rng::seed_from_u64(1)
            )
            .is_empty()
        );
    }
}
