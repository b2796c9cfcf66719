//! The unlabelled world along a street: sidewalk slabs (their edges are the kerbs), building
//! façades with gaps, poles and signs, porous trees, bushes and hedges, fences and low walls
//! along the property line, street furniture (bins, cabinets, bollards, benches), grass mounds,
//! car-sized clutter (skips, sheds, stacked goods) and parked trailers off the road, façades with
//! bays, porches and balconies, and the hard negatives of `negatives.rs`. Everything in the world
//! frame. Real streets are cluttered (BENCHMARKS.md, "Realism": 19 % of real background
//! neighbourhoods are volumetric against 5 % here before the clutter), and the clutter is
//! what a detector must learn not to call a car.

use super::negatives::hard_negatives;
use super::solids::{Scenery, cuboid_at, turned_cuboid_at};
use super::street::Ground;
use super::street_kind::draw;
use super::{Part, Shape, Surface};
use rand::Rng;
use starnet_data::Box3d;

/// Builds the scenery of a street over world x ∈ `[x0, x1]`.
pub fn build_scenery(ground: &Ground, x0: f32, x1: f32, rng: &mut impl Rng) -> Scenery {
    let mut out = Scenery::default();
    let layout = ground.street.kind.layout();
    for side in [-1.0f32, 1.0] {
        sidewalks(&mut out, ground, side, x0, x1);
        let edge = ground.street.half_width() + ground.street.sidewalk;
        if rng.random::<f32>() < layout.building_share {
            buildings(&mut out, ground, side, edge, x0, x1, rng);
        } else {
            bushes(&mut out, ground, side, edge + 1.0, (x0, x1), 0.3, rng);
        }
        poles(&mut out, ground, side, x0, x1, rng);
        hard_negatives(&mut out, ground, side, (x0, x1), rng);
        if rng.random::<f32>() < layout.tree_share {
            trees(&mut out, ground, side, x0, x1, rng);
        }
        boundaries(&mut out, ground, side, edge, (x0, x1), rng);
        furniture(&mut out, ground, side, (x0, x1), rng);
        off_road(&mut out, ground, side, edge, (x0, x1), rng);
    }
    out
}

/// Raised slabs in pieces of up to 10 m, shorter on a grade (short solids keep the azimuth
/// bins small).
fn sidewalks(out: &mut Scenery, ground: &Ground, side: f32, x0: f32, x1: f32) {
    let s = &ground.street;
    let y = s.centre_y + side * (s.half_width() + 0.5 * s.sidewalk);
    for [a, b] in ground.pieces(x0, x1) {
        let mid = 0.5 * (a + b);
        if !s.in_crossing(mid) {
            let z = ground.height(mid, y);
            // The slab reaches down into the ground so undulation leaves no gap below it.
            out.add(
                Shape::Cuboid {
                    c: [mid, y, z - 0.2 + 0.5 * (s.kerb + 0.2)],
                    half: [0.5 * (b - a), 0.5 * s.sidewalk, 0.5 * (s.kerb + 0.2)],
                    heading: 0.0,
                },
                Surface::matte(0.36),
            );
        }
    }
}

/// Building blocks along one side, set back and as tall as the street's kind draws them.
fn buildings(out: &mut Scenery, ground: &Ground, side: f32, edge: f32, x0: f32, x1: f32, rng: &mut impl Rng) {
    let s = &ground.street;
    let layout = s.kind.layout();
    let mut x = x0;
    while x < x1 {
        let len = rng.random_range(8.0..35.0);
        let (mid, setback) = (x + 0.5 * len, draw(rng, layout.setback));
        let depth = rng.random_range(8.0..20.0);
        let y = s.centre_y + side * (edge + setback + 0.5 * depth);
        if !s.in_crossing(x) && !s.in_crossing(x + len) {
            let h = draw(rng, layout.height);
            // Based below the lowest ground under its front and back, so no gap opens under
            // it on a grade or an embankment.
            let (front, back) = (y - side * 0.5 * depth, y + side * 0.5 * depth);
            let z = ground.floor(x, x + len, front).min(ground.floor(x, x + len, back)) - 0.5;
            let heading = rng.random_range(-0.04..0.04);
            let wall = Surface::matte(rng.random_range(0.2..0.45));
            out.add_obstacle(
                Shape::Cuboid {
                    c: [mid, y, z + 0.5 * h],
                    half: [0.5 * len, 0.5 * depth, 0.5 * h],
                    heading,
                },
                wall,
            );
            let face = Facade {
                x: [x, x + len],
                y: front,
                side,
                base: z + 0.5,
                height: h,
                room: setback,
            };
            relief(out, &face, wall, rng);
            if setback > 1.5 && rng.random::<f32>() < 0.5 {
                bushes(out, ground, side, edge + 0.6, (x, x + len), 0.6, rng);
            }
        }
        x += len
            + if rng.random::<f32>() < 0.4 {
                rng.random_range(2.0..15.0)
            } else {
                0.3
            };
    }
}

/// The street face of a building: its x extent, y, which side it faces from, its base and
/// height, and the room in front of it before the sidewalk.
struct Facade {
    x: [f32; 2],
    y: f32,
    side: f32,
    base: f32,
    height: f32,
    room: f32,
}

/// Bays, porches and balconies standing out of a façade: real façades are not planes (75 % of
/// the simulator's vertical background was planar against 41 % on the real street).
fn relief(out: &mut Scenery, face: &Facade, wall: Surface, rng: &mut impl Rng) {
    let [x0, x1] = face.x;
    for _ in 0..rng.random_range(0..=4) {
        let width = rng.random_range(1.0..4.0f32).min(x1 - x0);
        let depth = rng.random_range(0.3..1.2f32).min(face.room + 0.3);
        let x = rng.random_range(x0..=x1 - width) + 0.5 * width;
        let y = face.y - face.side * 0.5 * depth;
        if rng.random::<f32>() < 0.5 || face.height < 5.0 {
            // A bay or porch from the ground up.
            let h = rng.random_range(2.5..face.height.clamp(2.6, 8.0));
            out.add_obstacle(cuboid_at([x, y, face.base - 0.5], [width, depth, h + 0.5]), wall);
        } else {
            // A balcony: a slab and its parapet on an upper floor.
            let z = rng.random_range(3.0..face.height - 1.0);
            out.add(cuboid_at([x, y, z], [width, depth, rng.random_range(0.9..1.2)]), wall);
        }
    }
}

fn bushes(
    out: &mut Scenery,
    ground: &Ground,
    side: f32,
    at: f32,
    (x0, x1): (f32, f32),
    density: f32,
    rng: &mut impl Rng,
) {
    let s = &ground.street;
    let mut x = x0;
    while x < x1 {
        let radii = [
            rng.random_range(0.5..2.0),
            rng.random_range(0.4..1.0),
            rng.random_range(0.4..1.0),
        ];
        let y = s.centre_y + side * (at + radii[1]);
        if !s.in_crossing(x) && rng.random::<f32>() < density {
            let z = ground.height(x, y) + s.kerb + 0.6 * radii[2];
            out.add(
                Shape::Ellipsoid {
                    c: [x, y, z],
                    radii,
                    heading: rng.random_range(-0.3..0.3),
                },
                Surface::foliage(rng.random_range(0.4..0.6)),
            );
        }
        x += 2.0 * radii[0] + rng.random_range(0.5..6.0);
    }
}

fn poles(out: &mut Scenery, ground: &Ground, side: f32, x0: f32, x1: f32, rng: &mut impl Rng) {
    let s = &ground.street;
    let y = s.centre_y + side * (s.half_width() + 0.4);
    let mut x = x0 + rng.random_range(0.0..20.0);
    while x < x1 {
        if !s.in_crossing(x) {
            let (z, h) = (ground.height(x, y) + s.kerb, rng.random_range(5.0..9.0));
            out.add_obstacle(
                Shape::Cylinder {
                    base: [x, y, z],
                    r: rng.random_range(0.08..0.15),
                    h,
                },
                Surface::matte(0.3),
            );
            if rng.random::<f32>() < 0.3 {
                // A retro-reflective sign facing the traffic.
                out.add(
                    Shape::Cuboid {
                        c: [x, y - side * 0.3, z + 2.6],
                        half: [0.02, 0.35, 0.3],
                        heading: 0.0,
                    },
                    Surface::retro(0.9),
                );
            }
        }
        x += rng.random_range(15.0..35.0);
    }
}

fn trees(out: &mut Scenery, ground: &Ground, side: f32, x0: f32, x1: f32, rng: &mut impl Rng) {
    let s = &ground.street;
    let y = s.centre_y + side * (s.half_width() + 0.5 * s.sidewalk + 0.3);
    let mut x = x0 + rng.random_range(0.0..10.0);
    while x < x1 {
        if !s.in_crossing(x) {
            let z = ground.height(x, y) + s.kerb;
            let (trunk, r) = (rng.random_range(2.0..3.5), rng.random_range(0.12..0.3));
            out.add_obstacle(
                Shape::Cylinder {
                    base: [x, y, z],
                    r,
                    h: trunk,
                },
                Surface::matte(0.35),
            );
            let cr = rng.random_range(1.2..2.8);
            let radii = [cr, cr * rng.random_range(0.8..1.0), rng.random_range(1.5..2.5)];
            out.add(
                Shape::Ellipsoid {
                    c: [x, y, z + trunk + 0.7 * radii[2]],
                    radii,
                    heading: 0.0,
                },
                Surface::foliage(rng.random_range(0.4..0.55)),
            );
        }
        x += rng.random_range(8.0..20.0);
    }
}

/// Along the property line, in segments: a hedge, a low wall, a fence of posts and rails, or
/// nothing.
fn boundaries(out: &mut Scenery, ground: &Ground, side: f32, edge: f32, (x0, x1): (f32, f32), rng: &mut impl Rng) {
    let s = &ground.street;
    let mut x = x0;
    while x < x1 {
        let len = rng.random_range(5.0..25.0);
        let depth = rng.random_range(0.5..1.2);
        let y = s.centre_y + side * (edge + 0.3 + 0.5 * depth);
        let u: f32 = rng.random();
        if !s.in_crossing(x) && !s.in_crossing(x + len) {
            if u < 0.3 {
                let h = rng.random_range(0.7..1.8);
                let surface = Surface::foliage(rng.random_range(0.3..0.55));
                for [a, b] in ground.pieces(x, x + len) {
                    let foot = [0.5 * (a + b), y, ground.floor(a, b, y)];
                    out.add(cuboid_at(foot, [b - a, depth, h]), surface);
                }
            } else if u < 0.45 {
                let h = rng.random_range(0.4..1.2);
                let surface = Surface::matte(rng.random_range(0.15..0.45));
                for [a, b] in ground.pieces(x, x + len) {
                    let foot = [0.5 * (a + b), y, ground.floor(a, b, y)];
                    out.add_obstacle(cuboid_at(foot, [b - a, 0.3, h]), surface);
                }
            } else if u < 0.65 {
                fence(out, ground, [x, x + len], y, rng);
            }
        }
        x += len + rng.random_range(0.0..8.0);
    }
}

/// Posts every 2–3 m and two rails.
fn fence(out: &mut Scenery, ground: &Ground, [x0, x1]: [f32; 2], y: f32, rng: &mut impl Rng) {
    let h = rng.random_range(1.0..1.8);
    let surface = Surface::matte(rng.random_range(0.15..0.5));
    let step = rng.random_range(2.0..3.0);
    let mut x = x0;
    while x <= x1 {
        out.add(cuboid_at([x, y, ground.height(x, y)], [0.08, 0.08, h]), surface);
        x += step;
    }
    for [a, b] in ground.pieces(x0, x1) {
        let z = ground.height(0.5 * (a + b), y);
        for rail in [0.35 * h, 0.9 * h] {
            out.add(cuboid_at([0.5 * (a + b), y, z + rail], [b - a, 0.05, 0.08]), surface);
        }
    }
}

/// Bins, utility cabinets, bollards and benches on the sidewalk.
fn furniture(out: &mut Scenery, ground: &Ground, side: f32, (x0, x1): (f32, f32), rng: &mut impl Rng) {
    let s = &ground.street;
    let mut x = x0 + rng.random_range(0.0..15.0);
    while x < x1 {
        let y = s.centre_y + side * (s.half_width() + rng.random_range(0.4..(s.sidewalk - 0.4).max(0.5)));
        if !s.in_crossing(x) {
            let z = ground.height(x, y) + s.kerb;
            let size = match rng.random_range(0..4) {
                0 => [0.6, 0.6, rng.random_range(0.9..1.2)], // bin
                1 => [1.2, 0.5, rng.random_range(1.1..1.6)], // utility cabinet
                2 => [0.2, 0.2, rng.random_range(0.8..1.1)], // bollard
                _ => [1.8, 0.6, rng.random_range(0.7..0.9)], // bench
            };
            let shape = turned_cuboid_at([x, y, z], size, rng.random_range(-0.2..0.2));
            out.add_obstacle(shape, Surface::matte(rng.random_range(0.08..0.5)));
        }
        x += rng.random_range(6.0..30.0);
    }
}

/// Beyond the sidewalk: grass mounds and car-sized clutter (skips, sheds, stacked goods,
/// machinery), unlabelled.
fn off_road(out: &mut Scenery, ground: &Ground, side: f32, edge: f32, (x0, x1): (f32, f32), rng: &mut impl Rng) {
    let s = &ground.street;
    let mut x = x0 + rng.random_range(0.0..20.0);
    while x < x1 {
        let y = s.centre_y + side * (edge + rng.random_range(1.0..8.0));
        if !s.in_crossing(x) {
            let z = ground.height(x, y);
            let u: f32 = rng.random();
            if u < 0.4 {
                let radii = [
                    rng.random_range(2.0..5.0),
                    rng.random_range(1.5..4.0),
                    rng.random_range(0.5..1.5),
                ];
                let sunk = rng.random_range(0.3..0.7) * radii[2];
                let mound = Shape::Ellipsoid {
                    c: [x, y, z - sunk],
                    radii,
                    heading: rng.random_range(-0.5..0.5),
                };
                out.add(mound, Surface::matte(rng.random_range(0.25..0.5)));
            } else if u < 0.8 {
                let size = [
                    rng.random_range(1.5..4.5),
                    rng.random_range(1.0..2.4),
                    rng.random_range(0.8..2.3),
                ];
                let shape = turned_cuboid_at([x, y, z], size, rng.random_range(-0.6..0.6));
                out.add_obstacle(shape, Surface::matte(rng.random_range(0.08..0.5)));
            } else {
                trailer(out, [x, y, z], rng.random_range(-0.3..0.3), rng);
            }
        }
        x += rng.random_range(8.0..40.0);
    }
}

/// A parked, unhitched trailer: a flat bed or a box on two wheels, a drawbar to the front.
fn trailer(out: &mut Scenery, foot: [f32; 3], heading: f32, rng: &mut impl Rng) {
    let [l, w] = [rng.random_range(2.0..4.0), rng.random_range(1.4..2.1)];
    let boxed = rng.random::<f32>() < 0.5;
    let h = if boxed { rng.random_range(1.0..1.8) } else { 0.35 };
    let paint = Surface::matte(rng.random_range(0.1..0.5));
    let dark = Surface::matte(0.1);
    let local = [
        (cuboid_at([0.0, 0.0, 0.5], [l, w, h]), paint),
        (cuboid_at([0.0, 0.5 * w - 0.1, 0.0], [0.6, 0.18, 0.6]), dark),
        (cuboid_at([0.0, -0.5 * w + 0.1, 0.0], [0.6, 0.18, 0.6]), dark),
        (cuboid_at([0.5 * l + 0.6, 0.0, 0.35], [1.2, 0.08, 0.08]), dark),
    ];
    let parts: Vec<Part> = local.iter().map(|(s, r)| (s.moved(heading, foot), *r)).collect();
    let footprint = Box3d::new(
        foot[0],
        foot[1],
        foot[2] + 0.5 * (0.5 + h),
        l + 1.2,
        w,
        0.5 + h,
        heading,
    );
    out.add_group(parts, footprint);
}

#[cfg(test)]
mod tests {
    use super::super::street::Street;
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn scenery_stays_off_the_carriageway() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for _ in 0..10 {
            let street = Street::sample(&mut rng);
            let g = Ground::sample(street.clone(), 1.73, &mut rng);
            let sc = build_scenery(&g, -130.0, 130.0, &mut rng);
            assert!(sc.solids.len() > 50);
            for b in &sc.obstacles {
                // Every obstacle's footprint lies beyond the kerb.
                let near = b
                    .corners_bev()
                    .iter()
                    .map(|c| street.lateral(c[1]).abs())
                    .fold(f32::MAX, f32::min);
                assert!(near >= street.half_width() - 0.3, "{b:?} intrudes on the road");
            }
        }
    }
}
