//! The shape of the background: how much of it is volumetric (foliage, clutter) rather than
//! planar (walls, road), measured on the covariance of each sampled point's neighbours.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use starnet_data::Point;
use starnet_data::geometry::{GatherMetric, SpatialGrid};

/// Neighbourhood radius, metres.
pub const SURFACE_RADIUS_M: f32 = 0.5;
/// Neighbours needed for a shape to be measured.
pub const SURFACE_MIN_NEIGHBOURS: usize = 8;
/// Smallest over largest eigenvalue above which a neighbourhood is volumetric.
pub const VOLUMETRIC_SCATTER: f64 = 0.1;
/// |normal z| below which a planar neighbourhood is a vertical surface.
pub const VERTICAL_NORMAL_Z: f64 = 0.3;

/// The shape of one neighbourhood.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalShape {
    /// λ₃ / λ₁ of the covariance (0 on a plane or a line, 1/1 on an isotropic ball).
    pub scatter: f64,
    /// |z| of the normal (the eigenvector of λ₃): 1 on a horizontal surface, 0 on a wall.
    pub normal_z: f64,
}

impl LocalShape {
    /// Volumetric: scattered in all three directions.
    pub fn volumetric(&self) -> bool {
        self.scatter > VOLUMETRIC_SCATTER
    }

    /// A planar, vertical surface (a wall, a car's side).
    pub fn vertical(&self) -> bool {
        !self.volumetric() && self.normal_z < VERTICAL_NORMAL_Z
    }
}

/// The shape of the points `indices` of `cloud`; `None` for fewer than
/// [`SURFACE_MIN_NEIGHBOURS`].
pub fn local_shape(cloud: &[Point], indices: &[u32]) -> Option<LocalShape> {
    if indices.len() < SURFACE_MIN_NEIGHBOURS {
        return None;
    }
    let n = indices.len() as f64;
    let mean = indices.iter().fold(Vector3::zeros(), |m: Vector3<f64>, &i| {
        let p = cloud[i as usize];
        m + Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64) / n
    });
    let cov = indices.iter().fold(Matrix3::zeros(), |c: Matrix3<f64>, &i| {
        let p = cloud[i as usize];
        let d = Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64) - mean;
        c + d * d.transpose() / n
    });
    let eig = SymmetricEigen::new(cov);
    let (lo, hi) = (eig.eigenvalues.imin(), eig.eigenvalues.imax());
    let largest = eig.eigenvalues[hi];
    (largest > 0.0).then(|| LocalShape {
        scatter: eig.eigenvalues[lo].max(0.0) / largest,
        normal_z: eig.eigenvectors.column(lo)[2].abs(),
    })
}

/// The shapes of every `stride`-th point of `cloud` that `keep` accepts.
pub fn sampled_shapes(cloud: &[Point], stride: usize, keep: impl Fn(usize) -> bool) -> Vec<LocalShape> {
    let grid = SpatialGrid::new(cloud, SURFACE_RADIUS_M);
    let mut near = Vec::new();
    (0..cloud.len())
        .step_by(stride.max(1))
        .filter(|&i| keep(i))
        .filter_map(|i| {
            near.clear();
            let p = cloud[i];
            grid.within([p[0], p[1], p[2]], SURFACE_RADIUS_M, GatherMetric::Ball, &mut near);
            local_shape(cloud, &near)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lattice(f: impl Fn(f32, f32, f32) -> [f32; 3], n: usize, third: usize) -> Vec<Point> {
        let mut out = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in 0..third {
                    let [x, y, z] = f(i as f32 * 0.1, j as f32 * 0.1, k as f32 * 0.1);
                    out.push([x, y, z, 0.0]);
                }
            }
        }
        out
    }

    #[test]
    fn a_wall_is_planar_and_vertical_a_bush_volumetric_a_road_horizontal() {
        let all = |c: &[Point]| (0..c.len() as u32).collect::<Vec<_>>();
        let wall = lattice(|a, b, _| [5.0, a, b], 6, 1);
        let s = local_shape(&wall, &all(&wall)).unwrap();
        assert!(s.scatter < 1e-9 && s.normal_z < 1e-6 && s.vertical(), "{s:?}");
        let road = lattice(|a, b, _| [a, b, -1.7], 6, 1);
        let s = local_shape(&road, &all(&road)).unwrap();
        assert!((s.normal_z - 1.0).abs() < 1e-6 && !s.vertical() && !s.volumetric());
        // A cube of points: all three eigenvalues equal.
        let bush = lattice(|a, b, c| [a, b, c], 5, 5);
        let s = local_shape(&bush, &all(&bush)).unwrap();
        assert!((s.scatter - 1.0).abs() < 1e-6 && s.volumetric());
        assert_eq!(local_shape(&bush, &[0, 1, 2]), None);
    }
}
