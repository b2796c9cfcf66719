//! The solids the simulated world is built from, and their ray intersections. Every solid
//! is upright (its only rotation is a heading about +z), which keeps the intersection code
//! short and lets a rigid motion of the world (a yaw and a translation) map solids to solids.

/// A ray with origin `o` and unit direction `d`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub o: [f32; 3],
    /// Unit direction.
    pub d: [f32; 3],
}

impl Ray {
    /// The point at distance `t`.
    pub fn at(&self, t: f32) -> [f32; 3] {
        [
            self.o[0] + t * self.d[0],
            self.o[1] + t * self.d[1],
            self.o[2] + t * self.d[2],
        ]
    }
}

/// An upright solid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A box rotated about +z: centre, half extents (along heading, across, up), heading.
    Cuboid {
        /// Centre.
        c: [f32; 3],
        /// Half extents in the box's own frame.
        half: [f32; 3],
        /// Heading about +z.
        heading: f32,
    },
    /// A vertical cylinder: centre of its base, radius, height.
    Cylinder {
        /// Centre of the bottom disc.
        base: [f32; 3],
        /// Radius.
        r: f32,
        /// Height.
        h: f32,
    },
    /// An ellipsoid with one axis vertical: centre, radii (along heading, across, up), heading.
    Ellipsoid {
        /// Centre.
        c: [f32; 3],
        /// Radii in the solid's own frame.
        radii: [f32; 3],
        /// Heading about +z.
        heading: f32,
    },
}

/// Rotates `(x, y)` by `a` radians.
fn rot(v: [f32; 2], a: f32) -> [f32; 2] {
    let (s, c) = a.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

/// Ray in the frame of a solid centred at `c` with heading `h`.
fn to_local(ray: &Ray, c: [f32; 3], h: f32) -> ([f32; 3], [f32; 3]) {
    let o = rot([ray.o[0] - c[0], ray.o[1] - c[1]], -h);
    let d = rot([ray.d[0], ray.d[1]], -h);
    ([o[0], o[1], ray.o[2] - c[2]], [d[0], d[1], ray.d[2]])
}

fn normalize(v: [f32; 3]) -> [f32; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-12);
    [v[0] / n, v[1] / n, v[2] / n]
}

/// Entry distances below this are ignored, so a ray never hits the solid it starts on.
const T_MIN: f32 = 1e-4;

impl Shape {
    /// The first intersection in front of the ray origin: distance and outward unit normal.
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, [f32; 3])> {
        match *self {
            Shape::Cuboid { c, half, heading } => cuboid_hit(ray, c, half, heading),
            Shape::Cylinder { base, r, h } => cylinder_hit(ray, base, r, h),
            Shape::Ellipsoid { c, radii, heading } => ellipsoid_hit(ray, c, radii, heading),
        }
    }

    /// Whether `p` lies inside (or on) the solid.
    pub fn contains(&self, p: [f32; 3]) -> bool {
        match *self {
            Shape::Cuboid { c, half, heading } => {
                let q = rot([p[0] - c[0], p[1] - c[1]], -heading);
                q[0].abs() <= half[0] && q[1].abs() <= half[1] && (p[2] - c[2]).abs() <= half[2]
            }
            Shape::Cylinder { base, r, h } => {
                (p[0] - base[0]).hypot(p[1] - base[1]) <= r && (base[2]..=base[2] + h).contains(&p[2])
            }
            Shape::Ellipsoid { c, radii, heading } => {
                let q = rot([p[0] - c[0], p[1] - c[1]], -heading);
                let z = p[2] - c[2];
                (q[0] / radii[0]).powi(2) + (q[1] / radii[1]).powi(2) + (z / radii[2]).powi(2) <= 1.0
            }
        }
    }

    /// Centre and radius of a circle containing the solid's footprint.
    pub fn bounding_circle(&self) -> ([f32; 2], f32) {
        match *self {
            Shape::Cuboid { c, half, .. } => ([c[0], c[1]], half[0].hypot(half[1])),
            Shape::Cylinder { base, r, .. } => ([base[0], base[1]], r),
            Shape::Ellipsoid { c, radii, .. } => ([c[0], c[1]], radii[0].max(radii[1])),
        }
    }

    /// Lowest and highest z.
    pub fn z_range(&self) -> (f32, f32) {
        match *self {
            Shape::Cuboid { c, half, .. } => (c[2] - half[2], c[2] + half[2]),
            Shape::Cylinder { base, h, .. } => (base[2], base[2] + h),
            Shape::Ellipsoid { c, radii, .. } => (c[2] - radii[2], c[2] + radii[2]),
        }
    }

    /// The solid moved rigidly: rotated by `yaw` about the origin's z axis, then shifted by `t`.
    pub fn moved(&self, yaw: f32, t: [f32; 3]) -> Shape {
        let mv = |p: [f32; 3]| {
            let q = rot([p[0], p[1]], yaw);
            [q[0] + t[0], q[1] + t[1], p[2] + t[2]]
        };
        match *self {
            Shape::Cuboid { c, half, heading } => Shape::Cuboid {
                c: mv(c),
                half,
                heading: heading + yaw,
            },
            Shape::Cylinder { base, r, h } => Shape::Cylinder { base: mv(base), r, h },
            Shape::Ellipsoid { c, radii, heading } => Shape::Ellipsoid {
                c: mv(c),
                radii,
                heading: heading + yaw,
            },
        }
    }
}

fn cuboid_hit(ray: &Ray, c: [f32; 3], half: [f32; 3], heading: f32) -> Option<(f32, [f32; 3])> {
    let (o, d) = to_local(ray, c, heading);
    let (mut t0, mut t1, mut axis, mut sign) = (f32::NEG_INFINITY, f32::INFINITY, 0, 1.0);
    for i in 0..3 {
        if d[i].abs() < 1e-12 {
            if o[i].abs() > half[i] {
                return None;
            }
            continue;
        }
        let (a, b) = ((-half[i] - o[i]) / d[i], (half[i] - o[i]) / d[i]);
        let (near, far) = if a < b { (a, b) } else { (b, a) };
        if near > t0 {
            t0 = near;
            axis = i;
            sign = if d[i] > 0.0 { -1.0 } else { 1.0 };
        }
        t1 = t1.min(far);
    }
    if t0 > t1 || t0 < T_MIN {
        return None;
    }
    let mut n = [0.0; 3];
    n[axis] = sign;
    let nxy = rot([n[0], n[1]], heading);
    Some((t0, [nxy[0], nxy[1], n[2]]))
}

fn cylinder_hit(ray: &Ray, base: [f32; 3], r: f32, h: f32) -> Option<(f32, [f32; 3])> {
    let (px, py, oz) = (ray.o[0] - base[0], ray.o[1] - base[1], ray.o[2] - base[2]);
    let [dx, dy, dz] = ray.d;
    let a = dx * dx + dy * dy;
    let mut best: Option<(f32, [f32; 3])> = None;
    if a > 1e-12 {
        let b = px * dx + py * dy;
        let disc = b * b - a * (px * px + py * py - r * r);
        if disc >= 0.0 {
            let t = (-b - disc.sqrt()) / a;
            let z = oz + t * dz;
            if t >= T_MIN && (0.0..=h).contains(&z) {
                best = Some((t, [(px + t * dx) / r, (py + t * dy) / r, 0.0]));
            }
        }
    }
    // The caps: the top seen from above, the bottom from below.
    for (zc, nz) in [(h, 1.0f32), (0.0, -1.0)] {
        if dz * nz < 0.0 {
            let t = (zc - oz) / dz;
            let (x, y) = (px + t * dx, py + t * dy);
            if t >= T_MIN && x * x + y * y <= r * r && best.is_none_or(|(bt, _)| t < bt) {
                best = Some((t, [0.0, 0.0, nz]));
            }
        }
    }
    best
}

fn ellipsoid_hit(ray: &Ray, c: [f32; 3], radii: [f32; 3], heading: f32) -> Option<(f32, [f32; 3])> {
    let (o, d) = to_local(ray, c, heading);
    let os = [o[0] / radii[0], o[1] / radii[1], o[2] / radii[2]];
    let ds = [d[0] / radii[0], d[1] / radii[1], d[2] / radii[2]];
    let a = ds[0] * ds[0] + ds[1] * ds[1] + ds[2] * ds[2];
    let b = os[0] * ds[0] + os[1] * ds[1] + os[2] * ds[2];
    let cc = os[0] * os[0] + os[1] * os[1] + os[2] * os[2] - 1.0;
    let disc = b * b - a * cc;
    if disc < 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()) / a;
    if t < T_MIN {
        return None;
    }
    let p = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
    let g = [
        p[0] / (radii[0] * radii[0]),
        p[1] / (radii[1] * radii[1]),
        p[2] / (radii[2] * radii[2]),
    ];
    let gxy = rot([g[0], g[1]], heading);
    Some((t, normalize([gxy[0], gxy[1], g[2]])))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: [f32; 3], d: [f32; 3]) -> Ray {
        Ray { o, d: normalize(d) }
    }

    #[test]
    fn contains_agrees_with_the_entry_and_a_step_inside() {
        let r = ray([0.0; 3], [1.0, 0.2, 0.05]);
        for s in [
            Shape::Cuboid {
                c: [10.0, 2.0, 0.0],
                half: [2.0, 1.0, 0.5],
                heading: 0.3,
            },
            Shape::Cylinder {
                base: [10.0, 2.0, -1.0],
                r: 1.0,
                h: 3.0,
            },
            Shape::Ellipsoid {
                c: [10.0, 2.0, 0.5],
                radii: [2.0, 1.0, 1.5],
                heading: -0.4,
            },
        ] {
            let (t, _) = s.intersect(&r).unwrap();
            assert!(s.contains(r.at(t + 0.05)) && !s.contains(r.at(t - 0.05)), "{s:?}");
            assert!(!s.contains([0.0; 3]));
        }
    }

    #[test]
    fn cuboid_front_face_and_rotation() {
        let b = Shape::Cuboid {
            c: [10.0, 0.0, 0.0],
            half: [2.0, 1.0, 0.5],
            heading: 0.0,
        };
        let (t, n) = b.intersect(&ray([0.0; 3], [1.0, 0.0, 0.0])).unwrap();
        assert!((t - 8.0).abs() < 1e-5 && n == [-1.0, 0.0, 0.0]);
        // Turned 90°: the box is now 2 m deep along x, so the face is at x = 9.
        let b = Shape::Cuboid {
            c: [10.0, 0.0, 0.0],
            half: [2.0, 1.0, 0.5],
            heading: std::f32::consts::FRAC_PI_2,
        };
        let (t, n) = b.intersect(&ray([0.0; 3], [1.0, 0.0, 0.0])).unwrap();
        assert!((t - 9.0).abs() < 1e-5 && (n[0] + 1.0).abs() < 1e-6, "{t} {n:?}");
        assert!(b.intersect(&ray([0.0; 3], [1.0, 0.5, 0.0])).is_none());
        assert!(
            b.intersect(&ray([0.0; 3], [-1.0, 0.0, 0.0])).is_none(),
            "behind the origin"
        );
    }

    #[test]
    fn cylinder_side_and_top() {
        let c = Shape::Cylinder {
            base: [5.0, 0.0, -2.0],
            r: 0.5,
            h: 3.0,
        };
        let (t, n) = c.intersect(&ray([0.0; 3], [1.0, 0.0, 0.0])).unwrap();
        assert!((t - 4.5).abs() < 1e-5 && (n[0] + 1.0).abs() < 1e-6);
        // From above, straight down onto the top cap at z = 1.
        let (t, n) = c.intersect(&ray([5.0, 0.0, 4.0], [0.0, 0.0, -1.0])).unwrap();
        assert!((t - 3.0).abs() < 1e-5 && n == [0.0, 0.0, 1.0]);
        assert!(c.intersect(&ray([0.0; 3], [1.0, 0.0, 1.0])).is_none(), "passes above");
    }

    #[test]
    fn ellipsoid_poles_and_equator() {
        let e = Shape::Ellipsoid {
            c: [10.0, 0.0, 0.0],
            radii: [2.0, 1.0, 3.0],
            heading: 0.0,
        };
        let (t, n) = e.intersect(&ray([0.0; 3], [1.0, 0.0, 0.0])).unwrap();
        assert!((t - 8.0).abs() < 1e-4 && (n[0] + 1.0).abs() < 1e-5);
        let (t, _) = e.intersect(&ray([10.0, 0.0, 10.0], [0.0, 0.0, -1.0])).unwrap();
        assert!((t - 7.0).abs() < 1e-4);
    }

    #[test]
    fn moved_solid_is_hit_where_it_moved() {
        let b = Shape::Cuboid {
            c: [10.0, 0.0, 0.0],
            half: [1.0, 1.0, 1.0],
            heading: 0.0,
        };
        // Rotating the world by +90° puts the box on the +y axis.
        let m = b.moved(std::f32::consts::FRAC_PI_2, [0.0, 0.0, 0.5]);
        let (t, _) = m.intersect(&ray([0.0; 3], [0.0, 1.0, 0.0])).unwrap();
        assert!((t - 9.0).abs() < 1e-4);
        assert_eq!(m.z_range(), (-0.5, 1.5));
    }

    #[test]
    fn hit_point_lies_on_the_surface_for_random_rays() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let shapes = [
            Shape::Cuboid {
                c: [6.0, 1.0, 0.2],
                half: [2.0, 0.8, 0.7],
                heading: 0.4,
            },
            Shape::Ellipsoid {
                c: [6.0, 1.0, 0.2],
                radii: [2.0, 0.8, 0.7],
                heading: 0.4,
            },
        ];
        let mut hits = 0;
        for _ in 0..2000 {
            let r = ray(
                [0.0, 0.0, 0.0],
                [1.0, rng.random_range(-0.5..0.5), rng.random_range(-0.3..0.3)],
            );
            for s in shapes {
                if let Some((t, _)) = s.intersect(&r) {
                    hits += 1;
                    let p = r.at(t);
                    let (o, _) = to_local(
                        &Ray {
                            o: p,
                            d: [0.0, 0.0, 1.0],
                        },
                        [6.0, 1.0, 0.2],
                        0.4,
                    );
                    let on = match s {
                        Shape::Cuboid { half, .. } => {
                            (0..3).map(|i| (o[i].abs() - half[i]).abs()).fold(f32::MAX, f32::min) < 1e-3
                        }
                        Shape::Ellipsoid { radii, .. } => {
                            ((0..3).map(|i| (o[i] / radii[i]).powi(2)).sum::<f32>() - 1.0).abs() < 1e-3
                        }
                        _ => unreachable!(),
                    };
                    assert!(on, "{s:?} hit at {p:?}");
                }
            }
        }
        assert!(hits > 500);
    }
}
