//! Where the labelled objects go: counts, distances and headings drawn from the KITTI
//! statistics (`kitti-format.md` §2), positions chosen from the street's slots (travel lanes,
//! parking strips, sidewalks, the crossing street), collisions rejected.
//!
//! Counts are drawn for the camera's side (x > 0, inside the image's field of view) and,
//! independently, for the rest of the turn, so the 360° sidecar is as busy as the labels.

use super::AnnotationMargin;
use super::actor::Actor;
use super::actors::{build_parts, sample_size, tight_box};
use super::street::{Parking, Street};
use super::street_kind::MAX_LANES_PER_SIDE;
use rand::Rng;
use rand_distr::{Distribution, LogNormal, Poisson};
use starnet_data::geometry::iou_bev;
use starnet_data::kitti::ObjectClass;
use starnet_data::{Box3d, wrap_angle};
use std::f32::consts::{FRAC_PI_2, PI};

/// Which half of the scene an object is placed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Half {
    /// Ahead of the sensor, inside the camera's field of view (where KITTI labels objects).
    InView,
    /// Everywhere else: behind the sensor and beside the camera's view.
    OutOfView,
}

/// Frames of KITTI's train split with 0, 1, … 17 cars (§2; the tail beyond 8 spread to make up
/// the 392 remaining frames). Mean 3.84 cars per frame.
const CAR_COUNT_HIST: [u32; 18] = [
    452, 720, 491, 349, 388, 341, 259, 200, 120, 110, 85, 65, 45, 32, 22, 15, 10, 8,
];
/// Share of cars per 10 m of distance from the camera (§2).
const CAR_DISTANCE_BINS: [f32; 8] = [0.10, 0.20, 0.24, 0.20, 0.13, 0.07, 0.045, 0.022];
/// Half-angle of the camera's horizontal field of view, with a margin inside the 40.7° edge.
const FOV_HALF: f32 = 0.66;

fn sample_car_count(rng: &mut impl Rng) -> usize {
    let total: u32 = CAR_COUNT_HIST.iter().sum();
    let mut k = rng.random_range(0..total);
    for (n, &c) in CAR_COUNT_HIST.iter().enumerate() {
        if k < c {
            return n;
        }
        k -= c;
    }
    0
}

fn sample_car_distance(rng: &mut impl Rng) -> f32 {
    let total: f32 = CAR_DISTANCE_BINS.iter().sum();
    let mut u = rng.random_range(0.0..total);
    for (i, &p) in CAR_DISTANCE_BINS.iter().enumerate() {
        if u < p {
            return (10.0 * (i as f32 + rng.random::<f32>())).max(4.0);
        }
        u -= p;
    }
    30.0
}

/// Distance from the camera: KITTI's per-class distributions (§2), log-normal fits for
/// pedestrians (median 13.6 m, 5–95 % 6–31 m) and cyclists (20.7 m, 6.7–42 m). The medians are
/// set a little lower because near objects are likelier to find no free slot.
fn sample_distance(class: ObjectClass, rng: &mut impl Rng) -> f32 {
    let d = match class {
        ObjectClass::Pedestrian | ObjectClass::PersonSitting => {
            LogNormal::new(12.5f32.ln(), 0.5).expect("valid").sample(rng)
        }
        ObjectClass::Cyclist => LogNormal::new(19.0f32.ln(), 0.43).expect("valid").sample(rng),
        _ => sample_car_distance(rng),
    };
    d.clamp(4.0, 90.0)
}

/// Distance band of the unlabelled far traffic (becomes DontCare in the camera view).
const FAR_TRAFFIC: (f32, f32) = (80.0, 115.0);

fn poisson(mean: f64, rng: &mut impl Rng) -> usize {
    if mean <= 0.0 {
        0
    } else {
        Poisson::new(mean).expect("positive mean").sample(rng) as usize
    }
}

/// A parked car's heading on the `side` of the street (+1 left, −1 right): with the traffic of
/// its side, one in seven the other way round; in angled bays turned from the kerb's line by the
/// bays' angle, nose towards the street (backed in, as back-in angle parking has it; nose in when
/// turned round). Every vehicle class parks so, vans and trucks included, and a long one
/// overhangs its bay: a known limit of version 5.
fn parked_heading(parking: Parking, side: f32, rng: &mut impl Rng) -> f32 {
    let along = if side < 0.0 { 0.0 } else { PI };
    let turned = if rng.random::<f32>() < 0.15 { PI } else { 0.0 };
    let bay = match parking {
        Parking::Angled { angle, .. } => angle,
        Parking::None | Parking::Row { .. } => 0.0,
    };
    along + bay + turned
}

/// Which road a candidate pose's position is measured along.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Road {
    /// The street: `y` is the lateral position, the distance then sets `x`.
    Street,
    /// The crossing street: `y` is the offset from its axis, the distance then sets `y`.
    Crossing,
}

/// A candidate pose: the road it is on, position, heading, speed along the heading.
struct Pose {
    on: Road,
    x: f32,
    y: f32,
    heading: f32,
    speed: f32,
}

/// Places the labelled objects of a scene.
pub struct Placer<'a> {
    street: &'a Street,
    obstacles: &'a [Box3d],
    actors: Vec<Actor>,
    /// Speed per travel lane, so cars sharing a lane keep their distance over a sequence.
    lane_speed: [[f32; MAX_LANES_PER_SIDE]; 2],
}

impl<'a> Placer<'a> {
    /// A placer for `street` that avoids `obstacles`.
    pub fn new(street: &'a Street, obstacles: &'a [Box3d], rng: &mut impl Rng) -> Self {
        let lane_speed = std::array::from_fn(|_| std::array::from_fn(|_| rng.random_range(5.0..14.0)));
        Self {
            street,
            obstacles,
            actors: Vec::new(),
            lane_speed,
        }
    }

    /// Places every object class in both halves of the scene and returns the actors.
    pub fn place_all(mut self, rng: &mut impl Rng) -> Vec<Actor> {
        for half in [Half::InView, Half::OutOfView] {
            // Some cars end up hidden or unplaceable, so draw a few more than KITTI labels.
            for _ in 0..sample_car_count(rng) + (rng.random::<f32>() < 0.25) as usize {
                self.place(ObjectClass::Car, half, rng);
            }
            // Trucks and seated people find fewer free slots: their means are raised likewise.
            for (class, mean) in [
                (ObjectClass::Van, 0.35),
                (ObjectClass::Truck, 0.15),
                (ObjectClass::Misc, 0.09),
                (ObjectClass::PersonSitting, 0.02),
            ] {
                for _ in 0..poisson(mean, rng) {
                    self.place(class, half, rng);
                }
            }
            // Far traffic beyond the labelled range: KITTI's DontCare regions (1.5 per frame).
            for _ in 0..poisson(2.3, rng) {
                let class = if rng.random::<f32>() < 0.8 {
                    ObjectClass::Car
                } else {
                    ObjectClass::Van
                };
                self.place_at(class, half, Some((FAR_TRAFFIC.0, FAR_TRAFFIC.1)), rng);
            }
            // Pedestrians come in groups: 26 % of frames have any, 2.27 on average then.
            if rng.random::<f32>() < 0.26 {
                self.place_group(ObjectClass::Pedestrian, 1 + poisson(1.27, rng), half, rng);
            }
            if rng.random::<f32>() < 0.14 {
                self.place_group(ObjectClass::Cyclist, 1 + poisson(0.43, rng), half, rng);
            }
        }
        self.actors
    }

    fn place_group(&mut self, class: ObjectClass, n: usize, half: Half, rng: &mut impl Rng) {
        for _ in 0..n {
            self.place(class, half, rng);
        }
    }

    fn place(&mut self, class: ObjectClass, half: Half, rng: &mut impl Rng) {
        self.place_at(class, half, None, rng);
    }

    /// Tries a few candidate poses for one object; gives up quietly on a crowded street (the
    /// count statistics already allow for it). A drawn distance is kept for ten slots before
    /// another is drawn, so crowded near slots do not push the distances outwards.
    fn place_at(&mut self, class: ObjectClass, half: Half, range: Option<(f32, f32)>, rng: &mut impl Rng) {
        let annotation = AnnotationMargin::sample(class, rng);
        let body = annotation.body(sample_size(class, rng));
        let mut distance = 0.0;
        for attempt in 0..30 {
            if attempt % 10 == 0 {
                distance = match range {
                    Some((lo, hi)) => rng.random_range(lo..hi),
                    None => sample_distance(class, rng),
                };
            }
            let pose = match class {
                ObjectClass::Pedestrian | ObjectClass::PersonSitting => self.sidewalk_pose(class, rng),
                ObjectClass::Cyclist => self.cyclist_pose(rng),
                _ => self.vehicle_pose(class, rng),
            };
            let Some(pose) = self.at_distance(pose, distance, half, rng) else {
                continue;
            };
            let parts = build_parts(class, body, rng);
            let (c, d) = tight_box(&parts);
            let margin = if matches!(
                class,
                ObjectClass::Pedestrian | ObjectClass::Cyclist | ObjectClass::PersonSitting
            ) {
                0.15
            } else {
                0.4
            };
            let (s, co) = pose.heading.sin_cos();
            let footprint = Box3d::new(
                pose.x + co * c[0] - s * c[1],
                pose.y + s * c[0] + co * c[1],
                0.0,
                d[0] + margin,
                d[1] + margin,
                1.0,
                pose.heading,
            );
            let clear = self
                .obstacles
                .iter()
                .chain(self.actors.iter().map(|a| &a.footprint))
                .all(|o| iou_bev(o, &footprint) == 0.0);
            if clear {
                let track_id = self.actors.len() as u32;
                self.actors.push(Actor::new(
                    class,
                    track_id,
                    parts,
                    annotation,
                    [pose.x, pose.y],
                    pose.heading,
                    pose.speed,
                    footprint,
                ));
                return;
            }
        }
    }

    /// Moves a pose along the street (or along the crossing street) to the wanted distance.
    fn at_distance(&self, mut pose: Pose, d: f32, half: Half, rng: &mut impl Rng) -> Option<Pose> {
        let front = half == Half::InView;
        let sign = if front { 1.0 } else { -1.0 };
        if pose.on == Road::Crossing {
            // x fixed by the crossing street, distance sets y.
            let (cx, _) = self.street.crossing?;
            pose.x = cx + pose.y;
            let yy = (d * d - pose.x * pose.x).max(0.0).sqrt();
            pose.y = if rng.random::<bool>() { yy } else { -yy };
            if front != (pose.x > 0.0) || d <= pose.x.abs() {
                return None;
            }
        } else {
            if d <= pose.y.abs() + 1.0 {
                return None;
            }
            pose.x = sign * (d * d - pose.y * pose.y).sqrt();
        }
        // Objects meant for the camera's side must be inside the image's field of view.
        let in_view = pose.x > 0.0 && pose.y.atan2(pose.x).abs() < FOV_HALF;
        (front == in_view).then_some(pose)
    }

    fn vehicle_pose(&self, class: ObjectClass, rng: &mut impl Rng) -> Pose {
        let s = self.street;
        let u: f32 = rng.random();
        let jitter = |rng: &mut dyn rand::RngCore, deg: f32| rng.random_range(-deg..deg).to_radians();
        if u < 0.2 {
            // Off the street's axis: turning, in a driveway, or on the crossing street.
            if s.crossing.is_some() && rng.random::<bool>() {
                let lane = rng.random_range(-1.5f32..1.5) * s.lane_width;
                let heading = if lane > 0.0 { FRAC_PI_2 } else { -FRAC_PI_2 } + jitter(rng, 5.0);
                return Pose {
                    on: Road::Crossing,
                    x: 0.0,
                    y: lane,
                    heading,
                    speed: if rng.random::<bool>() {
                        rng.random_range(2.0..8.0)
                    } else {
                        0.0
                    },
                };
            }
            let y = s.centre_y + rng.random_range(-1.0..1.0) * (s.half_width() - 1.0);
            return Pose {
                on: Road::Street,
                x: 0.0,
                y,
                heading: rng.random_range(-PI..PI),
                speed: 0.0,
            };
        }
        let parked = s.parking != Parking::None && (u < 0.55 || matches!(class, ObjectClass::Misc));
        let side = if rng.random::<bool>() { 1.0 } else { -1.0 };
        if parked {
            let y = s.centre_y + side * (s.half_width() - 0.5 * s.parking.width());
            return Pose {
                on: Road::Street,
                x: 0.0,
                y,
                heading: wrap_angle(parked_heading(s.parking, side, rng) + jitter(rng, 4.0)),
                speed: 0.0,
            };
        }
        let lane = rng.random_range(0..s.lanes_per_side);
        let heading = if side < 0.0 { 0.0 } else { PI };
        let speed = self.lane_speed[(side > 0.0) as usize][lane];
        Pose {
            on: Road::Street,
            x: 0.0,
            y: s.lane_y(side, lane),
            heading: wrap_angle(heading + jitter(rng, 2.0)),
            speed,
        }
    }

    fn sidewalk_pose(&self, class: ObjectClass, rng: &mut impl Rng) -> Pose {
        let s = self.street;
        let side = if rng.random::<bool>() { 1.0 } else { -1.0 };
        let crossing_road = class == ObjectClass::Pedestrian && rng.random::<f32>() < 0.2;
        let y = if crossing_road {
            s.centre_y + rng.random_range(-1.0..1.0) * s.half_width()
        } else {
            s.centre_y + side * (s.half_width() + rng.random_range(0.4..(s.sidewalk - 0.4).max(0.5)))
        };
        let aligned = rng.random::<f32>() < 0.55;
        let heading = if crossing_road {
            side * FRAC_PI_2 + rng.random_range(-0.3..0.3)
        } else if aligned {
            (if rng.random::<bool>() { 0.0 } else { PI }) + rng.random_range(-0.15..0.15)
        } else {
            rng.random_range(-PI..PI)
        };
        let walking = class == ObjectClass::Pedestrian && rng.random::<f32>() < 0.7;
        Pose {
            on: Road::Street,
            x: 0.0,
            y,
            heading: wrap_angle(heading),
            speed: if walking { rng.random_range(1.0..1.6) } else { 0.0 },
        }
    }

    fn cyclist_pose(&self, rng: &mut impl Rng) -> Pose {
        let s = self.street;
        let side = if rng.random::<bool>() { 1.0 } else { -1.0 };
        let y = s.centre_y + side * (s.lanes_per_side as f32 * s.lane_width - 0.8);
        let heading = if rng.random::<f32>() < 0.85 {
            if side < 0.0 { 0.0 } else { PI }
        } else {
            rng.random_range(-PI..PI)
        };
        Pose {
            on: Road::Street,
            x: 0.0,
            y,
            heading: wrap_angle(heading + rng.random_range(-0.08..0.08)),
            speed: rng.random_range(3.0..7.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn car_count_histogram_mean() {
        let total: u32 = CAR_COUNT_HIST.iter().sum();
        let mean = CAR_COUNT_HIST
            .iter()
            .enumerate()
            .map(|(n, &c)| n as f64 * c as f64)
            .sum::<f64>()
            / total as f64;
        assert_eq!(total, 3712);
        assert!((mean - 3.84).abs() < 0.01, "{mean}");
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let m = (0..20000).map(|_| sample_car_count(&mut rng)).sum::<usize>() as f64 / 20000.0;
        assert!((m - mean).abs() < 0.1, "{m}");
    }

    #[test]
    fn cars_in_angled_bays_stand_at_the_bays_angle_inside_their_strip() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let angle = 60f32.to_radians();
        let mut street = Street::sample(&mut rng);
        (street.lanes_per_side, street.lane_width, street.centre_y) = (1, 3.5, 1.75);
        street.parking = Parking::Angled { width: 5.4, angle };
        let (mut parked, mut facing_street) = (0, 0);
        for _ in 0..20 {
            let actors = Placer::new(&street, &[], &mut rng).place_all(&mut rng);
            for a in actors.iter().filter(|a| a.class == ObjectClass::Car && a.speed == 0.0) {
                let lateral = street.lateral(a.start[1]).abs();
                if (lateral - (street.half_width() - 2.7)).abs() > 0.01 {
                    continue; // standing on the carriageway, not in a bay
                }
                parked += 1;
                // Off the street's axis by the bays' angle (within the 4° jitter), either way round.
                let off = wrap_angle(a.heading).abs();
                let off = off.min(PI - off);
                assert!((off - angle).abs() < 4.5f32.to_radians(), "{}°", off.to_degrees());
                // Backed in: the nose points away from the car's own kerb (towards the centre line).
                let to_centre = -street.lateral(a.start[1]).signum();
                facing_street += usize::from(a.heading.sin() * to_centre > 0.0);
                // Its footprint (0.4 m larger than the car) stays between the travel lane and the kerb.
                for c in a.footprint.corners_bev() {
                    let l = street.lateral(c[1]).abs();
                    assert!(l > 3.5 - 0.5 && l < street.half_width() + 0.5, "{l}");
                }
            }
        }
        assert!(parked > 20, "{parked}");
        // One in seven is turned round (nose in).
        let share = facing_street as f32 / parked as f32;
        assert!((0.7..0.97).contains(&share), "{facing_street} of {parked}");
    }

    #[test]
    fn placed_objects_do_not_overlap_and_front_ones_are_in_view() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
        let mut placed = 0;
        for _ in 0..20 {
            let street = Street::sample(&mut rng);
            let actors = Placer::new(&street, &[], &mut rng).place_all(&mut rng);
            placed += actors.len();
            for (i, a) in actors.iter().enumerate() {
                for b in &actors[i + 1..] {
                    assert_eq!(iou_bev(&a.footprint, &b.footprint), 0.0);
                }
            }
        }
        assert!(placed > 100, "{placed}");
    }
}
