//! The labelled objects of the simulated world, built from parts so that LiDAR returns fill
//! a box the way they do on real objects: a car is wheels, a body and a cabin with windows
//! and number plates; a pedestrian is legs, torso, arms and head; a cyclist a bike and a
//! rider. The labelled box is the tight box of the parts, computed from them, grown for
//! vehicles by an annotator's margin ([`super::AnnotationMargin`]).
//!
//! Labelled sizes follow the KITTI statistics of `kitti-format.md` §2 (mean ± sd per class).

use super::{Shape, Surface};
use rand::Rng;
use rand_distr::{Distribution, Normal};
use starnet_data::kitti::ObjectClass;

/// A part: a solid in the object's own frame (origin on the ground under the footprint
/// centre, x along the heading) and its surface.
pub type Part = (Shape, Surface);

/// Mean and standard deviation of `[length, width, height]` per class (KITTI tracking labels
/// where measured, else 10 % of the Frustum-PointNet mean sizes).
pub fn size_stats(class: ObjectClass) -> ([f32; 3], [f32; 3]) {
    use ObjectClass::*;
    match class {
        Car => ([3.88, 1.63, 1.52], [0.41, 0.11, 0.13]),
        Van => ([4.97, 1.86, 2.16], [0.78, 0.16, 0.32]),
        Truck => ([10.14, 2.59, 3.25], [1.5, 0.2, 0.3]),
        Pedestrian => ([0.90, 0.73, 1.76], [0.20, 0.14, 0.10]),
        PersonSitting => ([0.80, 0.60, 1.28], [0.10, 0.08, 0.10]),
        Cyclist => ([1.75, 0.68, 1.74], [0.12, 0.15, 0.09]),
        Tram => ([16.17, 2.53, 3.53], [1.0, 0.1, 0.2]),
        Misc | DontCare => ([3.64, 1.54, 1.92], [1.2, 0.4, 0.5]),
    }
}

/// Draws `[length, width, height]`: Normal(mean, sd) truncated at ±2.5 sd.
pub fn sample_size(class: ObjectClass, rng: &mut impl Rng) -> [f32; 3] {
    let (mean, sd) = size_stats(class);
    std::array::from_fn(|i| {
        let z: f32 = Normal::new(0.0, 1.0).expect("unit normal").sample(rng);
        mean[i] + sd[i] * z.clamp(-2.5, 2.5)
    })
}

/// An axis-aligned cuboid part from its local bounds.
pub(super) fn cuboid(lo: [f32; 3], hi: [f32; 3], surface: Surface) -> Part {
    let c = std::array::from_fn(|i| 0.5 * (lo[i] + hi[i]));
    let half = std::array::from_fn(|i| 0.5 * (hi[i] - lo[i]));
    (Shape::Cuboid { c, half, heading: 0.0 }, surface)
}

fn head(x: f32, top: f32) -> Part {
    (
        Shape::Ellipsoid {
            c: [x, 0.0, top - 0.12],
            radii: [0.1, 0.085, 0.12],
            heading: 0.0,
        },
        Surface::matte(0.25),
    )
}

/// Wheels, body, cabin, lamps and plates of a car or van; `cabin` is the cabin's share of the
/// length. Paint is glossy (it returns strongly only where it faces the sensor); most rays pass
/// through the windows.
fn car_like(l: f32, w: f32, h: f32, cabin: f32, paint: f32) -> Vec<Part> {
    let (tyre, glass, paint) = (Surface::matte(0.08), Surface::glass(0.06), Surface::gloss(paint));
    let (hl, hw) = (0.5 * l, 0.5 * w);
    let belt = (0.55 * h).max(0.6);
    let mut parts = Vec::new();
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            let (x, y) = (sx * (hl - 0.75).max(0.35), sy * (hw - 0.11));
            parts.push(cuboid([x - 0.32, y - 0.1, 0.0], [x + 0.32, y + 0.1, 0.64], tyre));
        }
    }
    // The body's ends are rounded: a core that stops `nose` short of each end, capped by a
    // half-ellipsoid. Real bumpers curve back at the corners and hoods ramp down to them: the
    // returns within 0.6 m of a car's near end lie a median 0.16–0.23 m behind its box's end
    // on `kitti-real-dev` at 10–40 m, 0.01 m on a flat end face, 0.16 m on these
    // (`starnet compare-data`, "depth of the end's returns").
    let ends = RoundedEnds::new(l, w, 0.22, belt);
    parts.push(cuboid([-hl + ends.nose, -hw, 0.22], [hl - ends.nose, hw, belt], paint));
    parts.extend(ends.caps(paint));
    let (c0, c1) = (-hl + 0.12 * l, -hl + (0.12 + cabin) * l);
    // The windscreen and the rear window slope (runs of 0.7 m and 0.35 m from belt to roof), as
    // three steps each: no car has a vertical glass face over its hood.
    let (front_run, rear_run, steps) = (0.7f32.min(0.3 * (c1 - c0)), 0.35f32.min(0.2 * (c1 - c0)), 3);
    let dz = (h - belt) / steps as f32;
    for k in 0..steps {
        let inset = (k as f32 + 0.5) / steps as f32;
        let z0 = belt + k as f32 * dz;
        parts.push(cuboid(
            [c0 + rear_run * inset, -0.43 * w, z0],
            [c1 - front_run * inset, 0.43 * w, z0 + dz],
            glass,
        ));
    }
    parts.push(cuboid(
        [c0 + rear_run, -0.44 * w, h - 0.06],
        [c1 - front_run, 0.44 * w, h],
        paint,
    )); // roof
    // Plates and the lamps beside them are retro-reflective: the brightest returns of a car.
    let lamp = (belt - 0.18).max(0.3);
    for sx in [-1.0f32, 1.0] {
        parts.push(ends.on_surface(sx, [-0.26, 0.26], [0.35, 0.47], Surface::retro(0.9)));
        for sy in [-1.0f32, 1.0] {
            let y = sy * (hw - 0.2);
            parts.push(ends.on_surface(sx, [y - 0.15, y + 0.15], [lamp, lamp + 0.18], Surface::retro(0.7)));
        }
    }
    parts
}

/// The rounded ends of a car's body between heights `z0` and `z1`: half-ellipsoids of depth
/// `nose` on a core that stops `nose` short of each end.
struct RoundedEnds {
    half_length: f32,
    half_width: f32,
    nose: f32,
    z: [f32; 2],
}

impl RoundedEnds {
    fn new(l: f32, w: f32, z0: f32, z1: f32) -> Self {
        Self {
            half_length: 0.5 * l,
            half_width: 0.5 * w,
            nose: 0.4f32.min(0.1 * l),
            z: [z0, z1],
        }
    }

    /// The two caps.
    fn caps(&self, surface: Surface) -> [Part; 2] {
        let zc = 0.5 * (self.z[0] + self.z[1]);
        let radii = [self.nose, self.half_width, 0.5 * (self.z[1] - self.z[0])];
        [-1.0f32, 1.0].map(|sx| {
            let c = [sx * (self.half_length - self.nose), 0.0, zc];
            (Shape::Ellipsoid { c, radii, heading: 0.0 }, surface)
        })
    }

    /// How far an end reaches along the length at `(y, z)` (either end: they are mirror
    /// images): the cap's surface, or the core's end face beyond the cap.
    fn reach(&self, y: f32, z: f32) -> f32 {
        let (zc, rz) = (0.5 * (self.z[0] + self.z[1]), 0.5 * (self.z[1] - self.z[0]));
        let q = 1.0 - (y / self.half_width).powi(2) - ((z - zc) / rz).powi(2);
        self.half_length - self.nose + self.nose * q.max(0.0).sqrt()
    }

    /// A 1 cm plate on the end at `sx` (±1) spanning `y` and `z`, at the end's surface at its centre.
    fn on_surface(&self, sx: f32, y: [f32; 2], z: [f32; 2], surface: Surface) -> Part {
        let x = self.reach(0.5 * (y[0] + y[1]), 0.5 * (z[0] + z[1]));
        let (x0, x1) = if sx > 0.0 { (x - 0.01, x) } else { (-x, -x + 0.01) };
        cuboid([x0, y[0], z[0]], [x1, y[1], z[1]], surface)
    }
}

fn truck(l: f32, w: f32, h: f32, paint: f32) -> Vec<Part> {
    let (hl, hw) = (0.5 * l, 0.5 * w);
    let (tyre, cargo) = (Surface::matte(0.08), Surface::matte(0.35 + 0.5 * paint));
    let mut parts = Vec::new();
    for x in [-hl + 1.0, -hl + 2.3, hl - 1.2] {
        for sy in [-1.0, 1.0] {
            parts.push(cuboid(
                [x - 0.5, sy * hw - 0.25 * sy - 0.15, 0.0],
                [x + 0.5, sy * hw - 0.25 * sy + 0.15, 1.0],
                tyre,
            ));
        }
    }
    let cab = 2.2f32.min(0.3 * l);
    parts.push(cuboid([hl - cab, -hw, 0.5], [hl, hw, 0.8 * h], Surface::gloss(paint)));
    parts.push(cuboid(
        [hl - cab + 0.3, -0.45 * w, 0.8 * h],
        [hl - 0.3, 0.45 * w, 0.8 * h + 0.05],
        Surface::glass(0.06),
    ));
    parts.push(cuboid([-hl, -hw, 0.9], [hl - cab - 0.3, hw, h], cargo));
    parts
}

fn pedestrian(l: f32, w: f32, h: f32, albedo: f32, stride: f32) -> Vec<Part> {
    let (clothes, shoes) = (Surface::matte(albedo), Surface::matte(0.5 * albedo));
    let (hl, hw) = (0.5 * l, 0.5 * w);
    let hip = 0.47 * h;
    let leg_x = (hl - 0.08) * stride;
    let mut parts = vec![
        cuboid([leg_x - 0.07, 0.03, 0.0], [leg_x + 0.07, 0.16, hip], clothes),
        cuboid([-leg_x - 0.07, -0.16, 0.0], [-leg_x + 0.07, -0.03, hip], clothes),
        cuboid([-0.11, -0.18, hip], [0.11, 0.18, 0.83 * h], clothes),
        head(0.0, h),
    ];
    // Arms swing opposite to the legs and set the width.
    let arm_x = 0.6 * leg_x;
    parts.push(cuboid(
        [-arm_x - 0.05, hw - 0.09, 0.5 * h],
        [-arm_x + 0.05, hw, 0.8 * h],
        clothes,
    ));
    parts.push(cuboid(
        [arm_x - 0.05, -hw, 0.5 * h],
        [arm_x + 0.05, -hw + 0.09, 0.8 * h],
        clothes,
    ));
    // The longer stride leg defines the length when it is longer than the torso.
    parts.push(cuboid([-hl, -0.05, 0.0], [-hl + 0.1, 0.05, 0.08], shoes)); // heel
    parts.push(cuboid([hl - 0.1, -0.05, 0.0], [hl, 0.05, 0.08], shoes)); // toe
    parts
}

fn person_sitting(l: f32, w: f32, h: f32, albedo: f32) -> Vec<Part> {
    let (hl, hw) = (0.5 * l, 0.5 * w);
    let clothes = Surface::matte(albedo);
    vec![
        cuboid([-hl, -0.5 * hw, 0.0], [-hl + 0.35, 0.5 * hw, 0.45], Surface::matte(0.2)), // seat
        cuboid([-hl + 0.05, -0.2, 0.45], [-hl + 0.32, 0.2, h - 0.22], clothes),
        cuboid([-hl + 0.3, -0.18, 0.38], [hl - 0.08, 0.18, 0.52], clothes), // thighs
        cuboid([hl - 0.16, -0.18, 0.0], [hl, 0.18, 0.45], clothes),         // shins
        cuboid([-hl + 0.1, -hw, 0.5], [-hl + 0.25, hw, 0.62], clothes),     // arms on the rests
        head(-hl + 0.18, h),
    ]
}

fn cyclist(l: f32, w: f32, h: f32, clothes: f32, paint: f32) -> Vec<Part> {
    let (hl, hw) = (0.5 * l, 0.5 * w);
    let (clothes, paint, tyre) = (Surface::matte(clothes), Surface::gloss(paint), Surface::matte(0.1));
    let r = 0.34f32.min(0.25 * l);
    let body = 0.2f32.min(hw); // the rider's half-width, never wider than the handlebar
    vec![
        cuboid([-hl, -0.025, 0.0], [-hl + 2.0 * r, 0.025, 2.0 * r], tyre), // rear wheel
        cuboid([hl - 2.0 * r, -0.025, 0.0], [hl, 0.025, 2.0 * r], tyre),   // front wheel
        cuboid([-hl + r, -0.03, r + 0.1], [hl - r, 0.03, r + 0.25], paint), // frame
        cuboid([hl - r - 0.1, -hw, 1.0], [hl - r, hw, 1.05], paint),       // handlebar sets the width
        cuboid([-0.25, -body, 0.75], [0.2, body, 0.8 * h], clothes),       // torso, leaning
        cuboid([0.2, -hw + 0.05, 0.95], [hl - r - 0.1, -hw + 0.15, 1.1], clothes), // arms to the bar
        cuboid([0.2, hw - 0.15, 0.95], [hl - r - 0.1, hw - 0.05, 1.1], clothes),
        cuboid([-0.15, 0.04, 0.3], [0.15, body, 0.85], clothes), // legs
        cuboid([-0.05, -body, 0.25], [0.25, -0.04, 0.85], clothes),
        head(0.15, h),
    ]
}

fn misc(l: f32, w: f32, h: f32, paint: f32) -> Vec<Part> {
    // A trailer or container: a box on a low frame.
    let (hl, hw) = (0.5 * l, 0.5 * w);
    let frame = Surface::matte(0.1);
    vec![
        cuboid([-hl + 0.2, -hw + 0.1, 0.0], [-hl + 0.6, hw - 0.1, 0.3], frame),
        cuboid([hl - 0.6, -hw + 0.1, 0.0], [hl - 0.2, hw - 0.1, 0.3], frame),
        cuboid([-hl, -hw, 0.3], [hl, hw, h], Surface::matte(paint)),
    ]
}

/// Builds the parts of an object of `class` with target size `[l, w, h]`.
pub fn build_parts(class: ObjectClass, [l, w, h]: [f32; 3], rng: &mut impl Rng) -> Vec<Part> {
    use ObjectClass::*;
    // Dark colours are common (black, grey and navy cars and clothes) and return few points.
    let paint = 0.05 + 0.45 * rng.random::<f32>().powi(2);
    let clothes = 0.05 + 0.4 * rng.random::<f32>().powi(2);
    match class {
        Car => car_like(l, w, h, rng.random_range(0.45..0.55), paint),
        Van => car_like(l, w, h, 0.78, paint),
        Truck | Tram => truck(l, w, h, paint),
        Pedestrian => pedestrian(l, w, h, 0.8 * clothes, rng.random_range(0.3..1.0)),
        PersonSitting => person_sitting(l, w, h, clothes),
        Cyclist => cyclist(l, w, h, clothes.max(0.2), paint.max(0.2)),
        Misc | DontCare => misc(l, w, h, paint),
    }
}

/// The tight box of parts in their own frame: `(centre, [dx, dy, dz])`.
pub fn tight_box(parts: &[Part]) -> ([f32; 3], [f32; 3]) {
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for (shape, _) in parts {
        let (a, b) = match *shape {
            Shape::Cuboid { c, half, .. } => (
                std::array::from_fn(|i| c[i] - half[i]),
                std::array::from_fn(|i| c[i] + half[i]),
            ),
            Shape::Ellipsoid { c, radii, .. } => (
                std::array::from_fn(|i| c[i] - radii[i]),
                std::array::from_fn(|i| c[i] + radii[i]),
            ),
            Shape::Cylinder { base, r, h } => (
                [base[0] - r, base[1] - r, base[2]],
                [base[0] + r, base[1] + r, base[2] + h],
            ),
        };
        for i in 0..3 {
            lo[i] = lo[i].min(a[i]);
            hi[i] = hi[i].max(b[i]);
        }
    }
    (
        std::array::from_fn(|i| 0.5 * (lo[i] + hi[i])),
        std::array::from_fn(|i| hi[i] - lo[i]),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn rounded_ends_reach_the_box_end_only_at_their_tip() {
        // A 4 m body between 0.22 and 0.82 m: nose 0.4 m, cap centred at 0.52 m, radii 0.4, 0.8, 0.3.
        let ends = RoundedEnds::new(4.0, 1.6, 0.22, 0.82);
        let close = |a: f32, b: f32| (a - b).abs() < 1e-5;
        assert!(close(ends.reach(0.0, 0.52), 2.0), "the tip");
        // Halfway out across and up: 1 − ¼ − ¼ = ½ of the radius squared.
        assert!(close(ends.reach(0.4, 0.67), 1.6 + 0.4 * 0.5f32.sqrt()));
        // Past the cap (a corner): the core's face.
        assert!(close(ends.reach(0.79, 0.8), 1.6));
        // A plate sits on the surface at its centre, at either end.
        let plate = |sx| match ends.on_surface(sx, [-0.2, 0.2], [0.47, 0.57], Surface::retro(0.9)).0 {
            Shape::Cuboid { c, half, .. } => c[0] + sx * half[0],
            _ => unreachable!("plates are cuboids"),
        };
        assert!(close(plate(1.0), ends.reach(0.0, 0.52)) && close(plate(-1.0), -ends.reach(0.0, 0.52)));
    }

    #[test]
    fn tight_box_matches_the_requested_size() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for class in [
            ObjectClass::Car,
            ObjectClass::Van,
            ObjectClass::Truck,
            ObjectClass::Pedestrian,
            ObjectClass::Cyclist,
            ObjectClass::PersonSitting,
            ObjectClass::Misc,
        ] {
            for _ in 0..50 {
                let size = sample_size(class, &mut rng);
                let parts = build_parts(class, size, &mut rng);
                let (c, d) = tight_box(&parts);
                for i in 0..3 {
                    assert!(
                        (d[i] - size[i]).abs() < 0.02 * size[i] + 0.02,
                        "{class}: {d:?} vs {size:?}"
                    );
                }
                assert!(c[2] - 0.5 * d[2] >= -1e-6, "{class} reaches below the ground");
                assert!(
                    c[0].abs() < 0.05 * size[0] + 0.02 && c[1].abs() < 0.05,
                    "{class} off-centre: {c:?}"
                );
            }
        }
    }

    #[test]
    fn sizes_follow_the_stats() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
        let n = 4000;
        let mean_l = (0..n).map(|_| sample_size(ObjectClass::Car, &mut rng)[0]).sum::<f32>() / n as f32;
        assert!((mean_l - 3.88).abs() < 0.03, "{mean_l}");
    }
}
