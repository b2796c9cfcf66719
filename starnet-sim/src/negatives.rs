//! Hard negatives: unlabelled things on real sidewalks that look, to a LiDAR, like the classes a
//! detector learns. Parked bicycles (alone or in racks) look like cyclists; poles carrying boxes
//! (parking meters, fuse and signal boxes), post boxes, sandwich boards and planters stand at a
//! person's height; bus shelters are car-sized and hollow; trailers parked off the road are
//! car-sized and flat-topped. On `kitti-real-dev`, which has no pedestrian, a model trained on
//! the simulator put 5.9 Pedestrian boxes per frame at score ≥ 0.3 (issue #47): the simulator had
//! too few things it should not call a person.

use super::actors::cuboid;
use super::solids::{Scenery, cuboid_at, turned_cuboid_at};
use super::street::Ground;
use super::{Part, Shape, Surface};
use rand::Rng;
use starnet_data::Box3d;

/// Places hard negatives along one side's sidewalk (`side`: +1 left of the centre line, −1
/// right) over world x ∈ `[x0, x1]`, one every 8–35 m.
pub(super) fn hard_negatives(out: &mut Scenery, ground: &Ground, side: f32, (x0, x1): (f32, f32), rng: &mut impl Rng) {
    let s = &ground.street;
    let mut x = x0 + rng.random_range(0.0..10.0);
    while x < x1 {
        if !s.in_crossing(x) {
            match rng.random_range(0..10) {
                0..=2 => bicycles(out, ground, side, x, rng),
                3..=4 => pole_with_box(out, ground, side, x, rng),
                5..=8 => person_sized(out, ground, side, x, rng),
                _ => bus_shelter(out, ground, side, x, rng),
            }
        }
        x += rng.random_range(8.0..35.0);
    }
}

/// World `[x, y, z]` on the sidewalk, `from_kerb` metres in from the kerb (kept on the slab).
fn on_sidewalk(ground: &Ground, side: f32, x: f32, from_kerb: f32) -> [f32; 3] {
    let s = &ground.street;
    let inward = from_kerb.clamp(0.3, (s.sidewalk - 0.3).max(0.3));
    let y = s.centre_y + side * (s.half_width() + inward);
    [x, y, ground.height(x, y) + s.kerb]
}

/// A parked bicycle in its own frame (along +x, standing on z = 0): wheels, frame, bar, saddle.
fn bicycle(paint: Surface) -> Vec<Part> {
    let tyre = Surface::matte(0.1);
    let (hl, r) = (0.85, 0.34);
    vec![
        cuboid([-hl, -0.025, 0.0], [-hl + 2.0 * r, 0.025, 2.0 * r], tyre),
        cuboid([hl - 2.0 * r, -0.025, 0.0], [hl, 0.025, 2.0 * r], tyre),
        cuboid([-hl + r, -0.03, r + 0.1], [hl - r, 0.03, r + 0.25], paint),
        cuboid([hl - r - 0.1, -0.3, 0.95], [hl - r, 0.3, 1.0], paint),
        cuboid([-0.3, -0.08, 0.85], [-0.05, 0.08, 0.92], Surface::matte(0.1)),
    ]
}

/// One to five bicycles side by side, turned across the sidewalk (a rack) or along it.
fn bicycles(out: &mut Scenery, ground: &Ground, side: f32, x: f32, rng: &mut impl Rng) {
    let across = rng.random::<f32>() < 0.6;
    let count = if across { rng.random_range(1..=5) } else { 1 };
    let foot = on_sidewalk(ground, side, x, if across { 1.1 } else { rng.random_range(0.4..1.5) });
    let heading = if across { std::f32::consts::FRAC_PI_2 } else { 0.0 } + rng.random_range(-0.2..0.2);
    for i in 0..count {
        let at = [foot[0] + 0.7 * i as f32, foot[1], foot[2]];
        let paint = Surface::gloss(rng.random_range(0.1..0.5));
        let parts: Vec<Part> = bicycle(paint).iter().map(|(s, r)| (s.moved(heading, at), *r)).collect();
        out.add_group(parts, Box3d::new(at[0], at[1], at[2] + 0.5, 1.7, 0.6, 1.0, heading));
    }
}

/// A thin pole carrying a box at chest height: a parking meter, a fuse or signal box.
fn pole_with_box(out: &mut Scenery, ground: &Ground, side: f32, x: f32, rng: &mut impl Rng) {
    let foot = on_sidewalk(ground, side, x, rng.random_range(0.3..0.8));
    let h = rng.random_range(1.2..3.5);
    let surface = Surface::matte(rng.random_range(0.1..0.5));
    out.add_obstacle(
        Shape::Cylinder {
            base: foot,
            r: rng.random_range(0.04..0.08),
            h,
        },
        surface,
    );
    let size = [
        rng.random_range(0.2..0.5),
        rng.random_range(0.15..0.35),
        rng.random_range(0.3..0.7),
    ];
    // At chest to head height, where a person's torso would be.
    let z = foot[2] + rng.random_range(0.9..(h - size[2]).clamp(0.95, 1.8));
    let heading = rng.random_range(-0.3..0.3);
    out.add(turned_cuboid_at([foot[0], foot[1], z], size, heading), surface);
}

/// Things at a person's height and width: a post box, a sandwich board, a planter with a shrub.
fn person_sized(out: &mut Scenery, ground: &Ground, side: f32, x: f32, rng: &mut impl Rng) {
    let foot = on_sidewalk(ground, side, x, rng.random_range(0.4..2.5));
    let heading = rng.random_range(-0.4..0.4);
    match rng.random_range(0..3) {
        0 => out.add_obstacle(
            Shape::Cylinder {
                base: foot,
                r: rng.random_range(0.2..0.3),
                h: rng.random_range(1.0..1.4),
            },
            Surface::gloss(rng.random_range(0.15..0.4)),
        ),
        1 => {
            let size = [
                rng.random_range(0.5..0.7),
                rng.random_range(0.3..0.6),
                rng.random_range(0.9..1.2),
            ];
            out.add_obstacle(
                turned_cuboid_at(foot, size, heading),
                Surface::matte(rng.random_range(0.2..0.6)),
            );
        }
        _ => {
            let w = rng.random_range(0.5..1.0);
            let pot = rng.random_range(0.4..0.8);
            out.add_obstacle(turned_cuboid_at(foot, [w, w, pot], heading), Surface::matte(0.3));
            let radii = [0.4 * w, 0.4 * w, rng.random_range(0.3..0.6)];
            let c = [foot[0], foot[1], foot[2] + pot + 0.8 * radii[2]];
            out.add(
                Shape::Ellipsoid { c, radii, heading },
                Surface::foliage(rng.random_range(0.4..0.6)),
            );
        }
    }
}

/// A bus shelter at the back of the sidewalk: a roof on posts, glass back and side panels.
fn bus_shelter(out: &mut Scenery, ground: &Ground, side: f32, x: f32, rng: &mut impl Rng) {
    let s = &ground.street;
    let (len, depth) = (
        rng.random_range(3.0..5.5),
        rng.random_range(1.2..1.6f32).min(s.sidewalk - 0.4),
    );
    let back = on_sidewalk(ground, side, x, s.sidewalk - 0.1);
    let mid = [
        back[0],
        back[1] - side * 0.5 * depth,
        ground.floor(x - 0.5 * len, x + 0.5 * len, back[1]) + s.kerb,
    ];
    let roof_z = mid[2] + rng.random_range(2.3..2.7);
    let frame = Surface::matte(rng.random_range(0.2..0.5));
    let roof = cuboid_at([mid[0], mid[1], roof_z], [len, depth, 0.12]);
    out.add_obstacle(roof, frame);
    let glass = Surface::glass(0.3);
    let panel_h = roof_z - mid[2] - 0.2;
    out.add(cuboid_at([mid[0], back[1], mid[2] + 0.1], [len, 0.03, panel_h]), glass);
    for end in [-0.5f32, 0.5] {
        let ex = mid[0] + end * (len - 0.05);
        out.add(cuboid_at([ex, mid[1], mid[2] + 0.1], [0.03, depth, panel_h]), glass);
        let post = Shape::Cylinder {
            base: [ex, mid[1] - side * 0.5 * depth, mid[2]],
            r: 0.05,
            h: roof_z - mid[2],
        };
        out.add(post, frame);
    }
}

#[cfg(test)]
mod tests {
    use super::super::street::Street;
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn negatives_stand_on_the_sidewalk_at_their_sizes() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..10 {
            let street = Street::sample(&mut rng);
            let g = Ground::sample(street.clone(), 1.73, &mut rng);
            let mut out = Scenery::default();
            hard_negatives(&mut out, &g, 1.0, (-100.0, 100.0), &mut rng);
            assert!(out.solids.len() > 5);
            for (shape, _) in &out.solids {
                let ([x, y], r) = shape.bounding_circle();
                let lat = street.lateral(y);
                // On the left sidewalk (a bicycle across it may reach 0.85 m past its ends).
                assert!(
                    lat + r > street.half_width() && lat - r < street.half_width() + street.sidewalk + 0.9,
                    "{shape:?}"
                );
                let (z0, z1) = shape.z_range();
                let ground = g.height(x, y) + street.kerb;
                // Nothing floats: every solid starts at most 2.7 m above the slab (a shelter's
                // roof) and none is taller than 3.6 m above it.
                assert!(z0 - ground < 2.8 && z1 - ground < 3.6, "{shape:?} at {ground}");
            }
        }
    }

    #[test]
    fn a_parked_bicycle_is_a_cyclist_without_its_rider() {
        let parts = bicycle(Surface::gloss(0.3));
        let (z0, z1) = parts
            .iter()
            .map(|(s, _)| s.z_range())
            .fold((f32::MAX, f32::MIN), |a, b| (a.0.min(b.0), a.1.max(b.1)));
        assert_eq!(z0, 0.0);
        // The labelled cyclist's mean height is 1.74 m (kitti-format.md §2); its bicycle alone 1 m.
        assert!((z1 - 1.0).abs() < 1e-6);
    }
}
