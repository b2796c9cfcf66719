//! Car-sized clusters of background returns: what a detector must learn not to call a car.
//! Background returns (neither ground nor inside a labelled object) are gridded in bird's-eye
//! view; occupied cells that touch (8-neighbours) form a cluster, whose extent is measured along
//! its principal axes.

use super::axis::principal_angle;
use starnet_data::Point;
use std::collections::HashMap;

/// Bird's-eye cell side, metres.
pub const CLUSTER_CELL_M: f32 = 0.3;
/// Length, width and height (m) ranges of a car-sized cluster.
pub const CAR_SIZED: [(f32, f32); 3] = [(2.5, 6.0), (1.2, 2.6), (0.8, 2.4)];
/// Returns a cluster needs to be measured.
pub const CLUSTER_MIN_POINTS: usize = 10;

/// One cluster's size and place.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cluster {
    /// Returns in it.
    pub points: usize,
    /// Extent along its main horizontal axis, metres.
    pub length: f32,
    /// Extent across it, metres.
    pub width: f32,
    /// Vertical extent of its returns, metres.
    pub height: f32,
    /// Bird's-eye distance of its centroid from the sensor, metres.
    pub distance: f32,
    /// Mean reflectance of its returns.
    pub mean_reflectance: f32,
}

impl Cluster {
    /// Whether its size is a car's ([`CAR_SIZED`]).
    pub fn car_sized(&self) -> bool {
        let [l, w, h] = CAR_SIZED;
        (l.0..=l.1).contains(&self.length) && (w.0..=w.1).contains(&self.width) && (h.0..=h.1).contains(&self.height)
    }
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// The clusters (of at least [`CLUSTER_MIN_POINTS`]) of `points`, in a fixed order.
pub fn clusters(points: &[Point]) -> Vec<Cluster> {
    let key = |p: &Point| {
        (
            (p[0] / CLUSTER_CELL_M).floor() as i32,
            (p[1] / CLUSTER_CELL_M).floor() as i32,
        )
    };
    let mut cells: HashMap<(i32, i32), usize> = HashMap::new();
    let cell_of: Vec<usize> = points
        .iter()
        .map(|p| {
            let n = cells.len();
            *cells.entry(key(p)).or_insert(n)
        })
        .collect();
    let mut parent: Vec<usize> = (0..cells.len()).collect();
    for (&(i, j), &c) in &cells {
        for (di, dj) in [(1, -1), (1, 0), (1, 1), (0, 1)] {
            if let Some(&d) = cells.get(&(i + di, j + dj)) {
                let (a, b) = (find(&mut parent, c), find(&mut parent, d));
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); cells.len()];
    for (i, &c) in cell_of.iter().enumerate() {
        members[find(&mut parent, c)].push(i);
    }
    members
        .iter()
        .filter(|m| m.len() >= CLUSTER_MIN_POINTS)
        .map(|m| measure(points, m))
        .collect()
}

/// Size of the points `idx` of `points` along their principal horizontal axes.
fn measure(points: &[Point], idx: &[usize]) -> Cluster {
    let n = idx.len() as f32;
    let (mx, my) = idx
        .iter()
        .fold((0.0, 0.0), |(x, y), &i| (x + points[i][0] / n, y + points[i][1] / n));
    let angle = principal_angle(idx.iter().map(|&i| [points[i][0], points[i][1]]));
    let (s, c) = angle.sin_cos();
    let extent = |f: &dyn Fn(&Point) -> f32| {
        let v = idx.iter().map(|&i| f(&points[i]));
        v.clone().fold(f32::NEG_INFINITY, f32::max) - v.fold(f32::INFINITY, f32::min)
    };
    let along = extent(&|p| c * p[0] + s * p[1]);
    let across = extent(&|p| -s * p[0] + c * p[1]);
    Cluster {
        points: idx.len(),
        length: along.max(across),
        width: along.min(across),
        height: extent(&|p| p[2]),
        distance: mx.hypot(my),
        mean_reflectance: idx.iter().map(|&i| points[i][3]).sum::<f32>() / n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points filling a box `[x0, x1] × [y0, y1] × [z0, z1]` on a 0.1 m lattice.
    fn block(lo: [f32; 3], hi: [f32; 3], reflectance: f32) -> Vec<Point> {
        let steps = |a: f32, b: f32| ((b - a) / 0.1).round() as usize + 1;
        let mut out = Vec::new();
        for i in 0..steps(lo[0], hi[0]) {
            for j in 0..steps(lo[1], hi[1]) {
                for k in 0..steps(lo[2], hi[2]) {
                    let f = |a: f32, t: usize| a + 0.1 * t as f32;
                    out.push([f(lo[0], i), f(lo[1], j), f(lo[2], k), reflectance]);
                }
            }
        }
        out
    }

    #[test]
    fn a_car_sized_block_is_one_car_sized_cluster_and_a_wall_is_not() {
        let mut cloud = block([30.0, 5.0, -1.7], [34.0, 6.8, -0.3], 0.1);
        cloud.extend(block([30.0, 12.0, -1.7], [45.0, 12.2, 1.0], 0.4)); // a wall, 15 m long
        cloud.extend(block([20.0, -3.0, -1.7], [20.1, -2.9, -1.6], 0.2)); // 8 points: too few
        let found = clusters(&cloud);
        assert_eq!(found.len(), 2, "{found:?}");
        let car: Vec<&Cluster> = found.iter().filter(|c| c.car_sized()).collect();
        assert_eq!(car.len(), 1);
        let c = car[0];
        assert!(
            (c.length - 4.0).abs() < 1e-3 && (c.width - 1.8).abs() < 1e-3 && (c.height - 1.4).abs() < 1e-3,
            "{c:?}"
        );
        assert!(
            (c.mean_reflectance - 0.1).abs() < 1e-4 && (c.distance - 32.0f32.hypot(5.9)).abs() < 1e-2,
            "{c:?}"
        );
        // Turned 30°, the same block measures the same.
        let (s, co) = std::f32::consts::FRAC_PI_6.sin_cos();
        let turned: Vec<Point> = block([-2.0, -0.9, -1.7], [2.0, 0.9, -0.3], 0.1)
            .into_iter()
            .map(|p| [20.0 + co * p[0] - s * p[1], s * p[0] + co * p[1], p[2], p[3]])
            .collect();
        let t = clusters(&turned);
        assert_eq!(t.len(), 1);
        assert!(
            (t[0].length - 4.0).abs() < 0.01 && (t[0].width - 1.8).abs() < 0.01,
            "{:?}",
            t[0]
        );
    }
}
