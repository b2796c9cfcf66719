//! [`WildPoints`]: finite points far beyond any sensor's range (a corrupt file, a faulty driver:
//! one point at x = 1e20) are dropped and counted, or refused, as the config says, before any
//! grid, FPS or gather sees them. Every frame a dataset loads and every sweep `starnet detect`
//! reads passes through it.

use crate::{DataError, Point, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What to do with a point beyond the limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WildAction {
    /// Drop it and count it in the frame's report.
    #[default]
    Drop,
    /// Refuse the file, naming the point.
    Refuse,
}

/// The limit on a point's coordinates (`pipeline.wild_points`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WildPoints {
    /// The largest |x|, |y| or |z| a point may have, metres (1 km: beyond every automotive
    /// LiDAR's range by 3×).
    pub limit: f32,
    /// What happens to a point beyond it.
    pub action: WildAction,
}

impl Default for WildPoints {
    fn default() -> Self {
        Self {
            limit: 1000.0,
            action: WildAction::Drop,
        }
    }
}

/// The points of a cloud within the limit, and how many were dropped.
#[derive(Debug, Clone, PartialEq)]
pub struct Kept {
    /// The points within the limit, in their order.
    pub points: Vec<Point>,
    /// Points beyond it, dropped.
    pub dropped: usize,
}

impl WildPoints {
    /// Whether `p` lies within the limit on every axis.
    pub fn admits(&self, p: &Point) -> bool {
        p[..3].iter().all(|v| v.abs() <= self.limit)
    }

    /// `points` (read from `path`) without those beyond the limit, or with
    /// [`WildAction::Refuse`] an error naming the first of them.
    pub fn apply(&self, mut points: Vec<Point>, path: &Path) -> Result<Kept> {
        let Some(index) = points.iter().position(|p| !self.admits(p)) else {
            return Ok(Kept { points, dropped: 0 });
        };
        if self.action == WildAction::Refuse {
            return Err(DataError::WildPoint {
                path: path.to_path_buf(),
                index,
                point: points[index][..3].try_into().expect("a point has x, y and z"),
                limit: self.limit,
            });
        }
        let before = points.len();
        points.retain(|p| self.admits(p));
        Ok(Kept {
            dropped: before - points.len(),
            points,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud() -> Vec<Point> {
        vec![
            [1.0, 2.0, -1.0, 0.1],
            [1e20, 0.0, 0.0, 0.2],
            [-999.0, 1000.0, 0.0, 0.3],
            [0.0, 0.0, -1000.5, 0.4],
        ]
    }

    #[test]
    fn points_beyond_the_limit_on_any_axis_are_dropped_and_counted_in_order() {
        let kept = WildPoints::default().apply(cloud(), Path::new("a.bin")).unwrap();
        assert_eq!(kept.dropped, 2);
        assert_eq!(kept.points, vec![[1.0, 2.0, -1.0, 0.1], [-999.0, 1000.0, 0.0, 0.3]]);
    }

    #[test]
    fn refusing_names_the_file_the_point_and_the_key() {
        let wild = WildPoints {
            action: WildAction::Refuse,
            ..Default::default()
        };
        let err = wild.apply(cloud(), Path::new("scan.bin")).unwrap_err().to_string();
        assert!(
            err.contains("scan.bin") && err.contains("point 1") && err.contains("pipeline.wild_points"),
            "{err}"
        );
        let tame = vec![[1.0, 2.0, 3.0, 0.0]];
        assert_eq!(wild.apply(tame.clone(), Path::new("x")).unwrap().points, tame);
    }
}
