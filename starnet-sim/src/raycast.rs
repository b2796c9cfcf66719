//! Casting every ray of one LiDAR turn into a scene. Solids are binned by the azimuth interval
//! their footprint spans as seen from the sensor, so a ray tests only the few solids in its bin.
//! Occlusion is measured, not guessed: for each labelled object the scan counts the rays whose
//! line of sight crosses it and the rays whose first return is on it.

use super::{Finish, IntensityModel, LidarConfig, Ray, Shape, Surface, Tilt};
use rand::Rng;
use rand_distr::{Distribution, Normal};
use starnet_data::Point;
use std::f32::consts::TAU;

/// A solid of the scene with its surface and, for labelled objects, its owner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Primitive {
    /// The solid, in the level frame at the sensor (the sensor frame without its tilt).
    pub shape: Shape,
    /// How it returns the laser.
    pub surface: Surface,
    /// Index of the labelled object it belongs to; `None` for scenery.
    pub owner: Option<u32>,
}

/// The ground under the scene, in the level frame at the sensor.
pub trait Terrain {
    /// Ground height at `(x, y)`.
    fn height(&self, x: f32, y: f32) -> f32;
    /// Ground surface at `(x, y)`.
    fn surface(&self, x: f32, y: f32) -> Surface;
}

/// One turn of the sensor.
#[derive(Debug, Clone, Default)]
pub struct Scan {
    /// Returns `[N, 4]`, sensor frame, ring by ring from the top beam, each ring counter-clockwise
    /// from azimuth 0 (KITTI's order).
    pub points: Vec<Point>,
    /// Per point, the labelled object it lies on.
    pub owners: Vec<Option<u32>>,
    /// Per object, the rays whose line of sight (within range) crosses it.
    pub rays_toward: Vec<u32>,
    /// Per object, the rays whose first return lies on it (before dropout), or that passed
    /// through its windows with nothing nearer: the rays that see it.
    pub rays_hit: Vec<u32>,
}

const BINS: usize = 1024;

/// Azimuth bins → indices of the solids whose footprint spans them.
fn bin_solids(prims: &[Primitive]) -> Vec<Vec<u32>> {
    let mut bins = vec![Vec::new(); BINS];
    for (i, p) in prims.iter().enumerate() {
        let ([cx, cy], r) = p.shape.bounding_circle();
        let d = cx.hypot(cy);
        if d <= r {
            bins.iter_mut().for_each(|b| b.push(i as u32));
            continue;
        }
        let (az, half) = (cy.atan2(cx).rem_euclid(TAU), (r / d).asin());
        let lo = ((az - half) / TAU * BINS as f32).floor() as i64;
        let hi = ((az + half) / TAU * BINS as f32).floor() as i64;
        for b in lo..=hi {
            bins[b.rem_euclid(BINS as i64) as usize].push(i as u32);
        }
    }
    bins
}

/// First intersection with the terrain, by fixed-point iteration on the flat-ground solution
/// (the terrain is gentle, so four steps converge to millimetres).
fn terrain_hit(ray: &Ray, terrain: &impl Terrain, max_range: f32) -> Option<f32> {
    // Marches out along the ray (steps of 1 m, then 8 % of the range: the terrain is smooth
    // on that scale) to the first step that ends below the ground, then refines by regula
    // falsi. Fixed-point iteration alone misses grazing rays on a grade or an embankment.
    let above = |t: f32| {
        let p = ray.at(t);
        p[2] - terrain.height(p[0], p[1])
    };
    let (mut t0, mut f0) = (0.0, above(0.0));
    if f0 <= 0.0 {
        return None;
    }
    while t0 < max_range {
        let t1 = (t0 + (0.08 * t0).max(1.0)).min(max_range);
        let f1 = above(t1);
        if f1 <= 0.0 {
            return Some(refine(&above, (t0, f0), (t1, f1)));
        }
        (t0, f0) = (t1, f1);
    }
    None
}

/// A root of `f` between `a` (above, f > 0) and `b` (below, f ≤ 0) by the Illinois variant of
/// regula falsi.
fn refine(f: &impl Fn(f32) -> f32, (mut a, mut fa): (f32, f32), (mut b, mut fb): (f32, f32)) -> f32 {
    for _ in 0..8 {
        let t = b - fb * (b - a) / (fb - fa);
        let ft = f(t);
        if ft.abs() < 1e-4 {
            return t;
        }
        if ft > 0.0 {
            (a, fa) = (t, ft);
            fb *= 0.5;
        } else {
            (b, fb) = (t, ft);
            fa *= 0.5;
        }
    }
    b - fb * (b - a) / (fb - fa)
}

/// Extra chance of losing a return on a dark or transparent surface (black paint, tyres, glass):
/// real HDL-64 scans are sparse there, and KITTI's points per car show it.
fn dark_surface_dropout(surface: Surface) -> f32 {
    0.6 * ((0.25 - surface.albedo) / 0.25).clamp(0.0, 1.0)
}

/// The nearest return of a ray: distance, normal, surface and owner.
#[derive(Debug, Clone, Copy)]
struct Hit {
    t: f32,
    n: [f32; 3],
    surface: Surface,
    owner: Option<u32>,
}

/// What one ray met besides its return, in buffers reused from ray to ray: the objects whose
/// solids it crossed, those it saw through their windows (with where), and the objects it saw.
#[derive(Debug, Default)]
struct Sightings {
    crossed: Vec<u32>,
    seen_through: Vec<(u32, f32)>,
    seen: Vec<u32>,
}

/// The nearest solid among `candidates` that returns `ray`.
fn nearest_solid(
    ray: &Ray,
    candidates: &[u32],
    prims: &[Primitive],
    lidar: &LidarConfig,
    sight: &mut Sightings,
    rng: &mut impl Rng,
) -> Option<Hit> {
    sight.crossed.clear();
    sight.seen_through.clear();
    let mut best: Option<Hit> = None;
    for &i in candidates {
        let p = &prims[i as usize];
        let Some((t, n)) = p.shape.intersect(ray) else { continue };
        if t > lidar.max_range {
            continue;
        }
        if let Some(o) = p.owner
            && !sight.crossed.contains(&o)
        {
            sight.crossed.push(o);
        }
        let Some(t) = surface_return(p, ray, t, &lidar.intensity, &mut sight.seen_through, rng) else {
            continue;
        };
        if best.is_none_or(|b| t < b.t) {
            best = Some(Hit {
                t,
                n,
                surface: p.surface,
                owner: p.owner,
            });
        }
    }
    best
}

/// Where a ray that reaches solid `p` at `t` comes back from it, if it does: window glass lets
/// most rays through (noting the owner as seen), foliage returns from a random depth inside or
/// lets the ray through, every other surface returns where it is met.
fn surface_return(
    p: &Primitive,
    ray: &Ray,
    t: f32,
    model: &IntensityModel,
    seen_through: &mut Vec<(u32, f32)>,
    rng: &mut impl Rng,
) -> Option<f32> {
    match p.surface.finish {
        Finish::Glass if rng.random::<f32>() < model.glass_transmission => {
            seen_through.extend(p.owner.map(|o| (o, t)));
            None
        }
        Finish::Foliage => {
            let inside = t + model.foliage_penetration(rng);
            p.shape.contains(ray.at(inside)).then_some(inside)
        }
        _ => Some(t),
    }
}

impl Scan {
    /// Counts a ray toward every object it crossed (those behind its return are occluded),
    /// and as a hit on the object it returned from and on those it saw through their windows
    /// with nothing nearer.
    fn count_sightings(&mut self, sight: &mut Sightings, first: Option<Hit>) {
        for &o in &sight.crossed {
            self.rays_toward[o as usize] += 1;
        }
        let (t_first, owner) = first.map_or((f32::INFINITY, None), |h| (h.t, h.owner));
        let seen = &mut sight.seen;
        seen.clear();
        seen.extend(
            sight
                .seen_through
                .iter()
                .filter(|(_, t)| *t < t_first)
                .map(|(o, _)| *o)
                .chain(owner),
        );
        seen.sort_unstable();
        seen.dedup();
        for &o in seen.iter() {
            self.rays_hit[o as usize] += 1;
        }
    }
}

/// Scans the scene from the sensor at the origin, tilted by `tilt` from the level frame that
/// `prims` and `terrain` are given in; the returns are in the sensor's own frame.
pub fn scan(
    prims: &[Primitive],
    terrain: &impl Terrain,
    num_objects: usize,
    lidar: &LidarConfig,
    tilt: Tilt,
    rng: &mut impl Rng,
) -> Scan {
    let bins = bin_solids(prims);
    let noise = Normal::new(0.0, lidar.range_noise.max(1e-9)).expect("finite sigma");
    let clip = 2.5 * lidar.range_noise;
    let gains = lidar.intensity.draw_gains(lidar.elevations_deg.len(), rng);
    let mut out = Scan {
        rays_toward: vec![0; num_objects],
        rays_hit: vec![0; num_objects],
        ..Default::default()
    };
    let mut sight = Sightings::default();
    let tilt = tilt.rotation();
    for (beam, &gain) in gains.iter().enumerate() {
        for step in 0..lidar.azimuth_steps {
            let ray = Ray {
                o: [0.0; 3],
                d: tilt.to_level(lidar.direction(beam, step)),
            };
            let azimuth = ray.d[1].atan2(ray.d[0]).rem_euclid(TAU);
            let bin = ((azimuth / TAU * BINS as f32) as usize).min(BINS - 1);
            let mut first = nearest_solid(&ray, &bins[bin], prims, lidar, &mut sight, rng);
            if let Some(t) = terrain_hit(&ray, terrain, lidar.max_range)
                && first.is_none_or(|h| t < h.t)
            {
                let p = ray.at(t);
                let (n, surface, owner) = ([0.0, 0.0, 1.0], terrain.surface(p[0], p[1]), None);
                first = Some(Hit { t, n, surface, owner });
            }
            out.count_sightings(&mut sight, first);
            let Some(hit) = first else { continue };
            if rng.random::<f32>() < lidar.dropout + dark_surface_dropout(hit.surface) {
                continue;
            }
            let t = hit.t + noise.sample(rng).clamp(-clip, clip);
            let p = tilt.to_sensor(ray.at(t));
            let cos = (ray.d[0] * hit.n[0] + ray.d[1] * hit.n[1] + ray.d[2] * hit.n[2]).abs();
            let reflectance = lidar.intensity.observe(hit.surface, cos, t, gain, rng);
            out.points.push([p[0], p[1], p[2], reflectance]);
            out.owners.push(hit.owner);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    struct Flat;
    impl Terrain for Flat {
        fn height(&self, _: f32, _: f32) -> f32 {
            -1.73
        }
        fn surface(&self, _: f32, _: f32) -> Surface {
            Surface::matte(0.3)
        }
    }

    fn quiet() -> LidarConfig {
        LidarConfig {
            range_noise: 0.0,
            dropout: 0.0,
            ..Default::default()
        }
    }

    #[test]
    fn flat_ground_only() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let s = scan(&[], &Flat, 0, &quiet(), Tilt::default(), &mut rng);
        // A beam reaches flat ground within 120 m below −0.83° (asin(1.73 / 120)): the upper
        // block's beams 9..32 (2° − i/3 ≤ −1°) and all 32 of the lower block, 55 in all.
        assert_eq!(s.points.len(), 55 * 2048);
        assert!(s.points.iter().all(|p| (p[2] + 1.73).abs() < 1e-3));
        // Ring order: the first ring starts straight ahead and turns counter-clockwise.
        let (a, b) = (s.points[0], s.points[1]);
        assert!(a[1].abs() < 1e-3 && b[1] > 0.0, "{a:?} {b:?}");
    }

    #[test]
    fn occluded_object_counts_rays_toward_but_not_hits() {
        let wall = Primitive {
            shape: Shape::Cuboid {
                c: [5.0, 0.0, 0.0],
                half: [0.1, 3.0, 3.0],
                heading: 0.0,
            },
            surface: Surface::matte(0.3),
            owner: None,
        };
        let car = Primitive {
            shape: Shape::Cuboid {
                c: [10.0, 0.0, -1.0],
                half: [2.0, 0.8, 0.7],
                heading: 0.0,
            },
            surface: Surface::matte(0.3),
            owner: Some(0),
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let s = scan(&[car], &Flat, 1, &quiet(), Tilt::default(), &mut rng);
        assert!(s.rays_toward[0] > 100 && s.rays_hit[0] == s.rays_toward[0]);
        let on_car = s.owners.iter().filter(|o| **o == Some(0)).count();
        assert_eq!(on_car as u32, s.rays_hit[0]);
        let hidden = scan(&[wall, car], &Flat, 1, &quiet(), Tilt::default(), &mut rng);
        assert_eq!(hidden.rays_toward[0], s.rays_toward[0]);
        assert_eq!(hidden.rays_hit[0], 0);
    }

    #[test]
    fn noise_is_bounded_and_dropout_drops() {
        let noisy = LidarConfig {
            range_noise: 0.02,
            dropout: 0.1,
            ..Default::default()
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let s = scan(&[], &Flat, 0, &noisy, Tilt::default(), &mut rng);
        let frac = s.points.len() as f32 / (55.0 * 2048.0);
        assert!((frac - 0.9).abs() < 0.01, "{frac}");
        // A range error of at most 5 cm moves a ground point at most 5 cm vertically.
        assert!(s.points.iter().all(|p| (p[2] + 1.73).abs() <= 0.05 + 1e-4));
        assert!(
            s.points
                .iter()
                .all(|p| (0.0..=0.99).contains(&p[3]) && (p[3] * 100.0 - (p[3] * 100.0).round()).abs() < 1e-3)
        );
    }

    #[test]
    fn a_tilted_sensor_sees_the_level_ground_as_a_tilted_plane() {
        let tilt = Tilt {
            pitch: -0.01,
            roll: 0.02,
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let s = scan(&[], &Flat, 0, &quiet(), tilt, &mut rng);
        // In the sensor frame the ground is the plane n · p = −1.73 with n the level up axis.
        let n = tilt.to_sensor([0.0, 0.0, 1.0]);
        assert!(s.points.len() > 50 * 2048);
        for p in &s.points {
            let d = n[0] * p[0] + n[1] * p[1] + n[2] * p[2];
            assert!((d + 1.73).abs() < 1e-3, "{p:?}: {d}");
        }
        // Nose down by 0.01 rad: the road 20–30 m ahead reads 0.2–0.3 m higher than level.
        let ahead: Vec<f32> = s
            .points
            .iter()
            .filter(|p| (20.0..30.0).contains(&p[0]) && p[1].abs() < 1.0)
            .map(|p| p[2] + 1.73)
            .collect();
        assert!(
            !ahead.is_empty() && ahead.iter().all(|z| (0.17..0.33).contains(z)),
            "{ahead:?}"
        );
    }

    /// A level road that meets a 40 % embankment at x = 10 m, rising to 3 m.
    struct Bank;
    impl Terrain for Bank {
        fn height(&self, x: f32, _: f32) -> f32 {
            -1.73 + (0.4 * (x - 10.0)).clamp(0.0, 3.0)
        }
        fn surface(&self, _: f32, _: f32) -> Surface {
            Surface::matte(0.3)
        }
    }

    #[test]
    fn grazing_and_rising_rays_meet_a_steep_embankment_where_it_is() {
        for elevation in [-0.1f32, -0.02, 0.0, 0.05] {
            let ray = Ray {
                o: [0.0; 3],
                d: [elevation.cos(), 0.0, elevation.sin()],
            };
            let t = terrain_hit(&ray, &Bank, 120.0).expect("the bank stops every forward ray");
            let p = ray.at(t);
            assert!((p[2] - Bank.height(p[0], 0.0)).abs() < 1e-3, "{elevation}: {p:?}");
            // The first crossing: every point before it is above the ground.
            assert!((1..100).all(|i| {
                let q = ray.at(t * i as f32 / 100.0);
                q[2] > Bank.height(q[0], 0.0)
            }));
        }
        let up = Ray {
            o: [0.0; 3],
            d: [0.0, 0.0, 1.0],
        };
        assert_eq!(terrain_hit(&up, &Bank, 120.0), None);
    }
}
