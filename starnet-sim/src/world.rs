//! A scene: street, terrain, scenery, labelled actors and the ego's drive, and what the
//! sensor sees of it at time `t` (everything moved into that moment's LiDAR frame).

use super::actor::Actor;
use super::placement::Placer;
use super::scenery::build_scenery;
use super::solids::Scenery;
use super::street::{Ground, GroundView, Street};
use super::{LidarConfig, Primitive, Shape, Tilt};
use rand::Rng;
use rand_distr::{Distribution, Normal};
use starnet_data::{Box3d, wrap_angle};

/// Moves a solid from a frame posed at `p = [x, y, z, yaw]` into the frame that holds it.
fn place(shape: &Shape, p: [f32; 4]) -> Shape {
    shape.moved(p[3], [p[0], p[1], p[2]])
}

/// Moves a box the same way.
fn place_box(centre: [f32; 3], dims: [f32; 3], heading: f32, p: [f32; 4]) -> Box3d {
    let (s, c) = p[3].sin_cos();
    let (x, y) = (
        p[0] + c * centre[0] - s * centre[1],
        p[1] + s * centre[0] + c * centre[1],
    );
    Box3d::new(x, y, p[2] + centre[2], dims[0], dims[1], dims[2], heading + p[3])
}

/// The inverse of a pose: the pose of the world in the posed frame.
fn inverse(p: [f32; 4]) -> [f32; 4] {
    let (s, c) = p[3].sin_cos();
    [-(c * p[0] + s * p[1]), s * p[0] - c * p[1], -p[2], -p[3]]
}

/// A level-frame box in the tilted sensor frame. Its centre and heading turn with the sensor;
/// it stays upright there, as KITTI labels cars on a sloping road.
fn tilted_box(b: Box3d, tilt: Tilt) -> Box3d {
    let [x, y, z] = tilt.to_sensor([b.x, b.y, b.z]);
    Box3d::new(x, y, z, b.dx, b.dy, b.dz, wrap_angle(tilt.heading_to_sensor(b.heading)))
}

/// The sensor's tilt on a car at rest, per scene: pitched nose down by 0.25° on average (so a
/// level road rises ahead, as it does on `kitti-real-dev`), with the spread of other cars,
/// loads and mountings.
fn sample_mount(rng: &mut impl Rng) -> Tilt {
    let pitch = Normal::new(-0.25f32, 0.3).expect("finite sigma").sample(rng);
    let roll = Normal::new(0.0f32, 0.25).expect("finite sigma").sample(rng);
    Tilt {
        pitch: pitch.clamp(-1.2, 0.8).to_radians(),
        roll: roll.clamp(-0.8, 0.8).to_radians(),
    }
}

/// Everything that moves or stays in one scene.
#[derive(Debug, Clone)]
pub struct World {
    /// Terrain (and the street it carries).
    pub ground: Ground,
    /// Unlabelled solids.
    pub scenery: Scenery,
    /// Labelled objects.
    pub actors: Vec<Actor>,
    /// Ego speed, m/s.
    pub ego_speed: f32,
    /// Lateral weave of the ego's path: amplitude (m) and wavelength (m).
    weave: [f32; 2],
    mount_height: f32,
    /// The sensor's tilt on the car at rest (mounting and load).
    mount: Tilt,
    /// The suspension's sway.
    sway: Sway,
}

/// The suspension's slow sway of the sensor about its mounting.
#[derive(Debug, Clone, Copy)]
struct Sway {
    /// Pitch amplitude, radians.
    pitch: f32,
    /// Roll amplitude, radians.
    roll: f32,
    /// Angular frequency, rad/s.
    omega: f32,
    /// Phase at t = 0, radians.
    phase: f32,
}

/// What the sensor sees at one moment, in its own LiDAR frame.
#[derive(Debug, Clone)]
pub struct Moment {
    /// Every solid, actors' parts tagged with the actor index.
    pub prims: Vec<Primitive>,
    /// The actors' labelled boxes, indexed like [`World::actors`].
    pub boxes: Vec<Box3d>,
    /// Ego (sensor) pose in the world frame: `[x, y, z, yaw]`.
    pub pose: [f32; 4],
    /// The sensor's tilt from the level frame of `pose`; `prims` are in that level frame,
    /// `boxes` in the tilted sensor frame.
    pub tilt: Tilt,
}

impl World {
    /// Draws a scene the ego drives through for `duration` seconds, on a street of a kind
    /// drawn by [`super::StreetKind::SHARES`].
    pub fn generate(lidar: &LidarConfig, duration: f32, rng: &mut impl Rng) -> Self {
        let street = Street::sample(rng);
        Self::generate_on(street, lidar, duration, rng)
    }

    /// Draws a scene along `street` (say, one of [`Street::sample_of`] a chosen kind).
    pub fn generate_on(street: Street, lidar: &LidarConfig, duration: f32, rng: &mut impl Rng) -> Self {
        let ground = Ground::sample(street, lidar.mount_height, rng);
        let ego_speed = rng.random_range(5.0..12.0);
        let scenery = build_scenery(
            &ground,
            -lidar.max_range - 10.0,
            lidar.max_range + 10.0 + ego_speed * duration,
            rng,
        );
        let actors = Placer::new(&ground.street, &scenery.obstacles, rng).place_all(rng);
        let weave = [rng.random_range(0.0..0.4), rng.random_range(60.0..150.0)];
        Self {
            ground,
            scenery,
            actors,
            ego_speed,
            weave,
            mount_height: lidar.mount_height,
            mount: sample_mount(rng),
            sway: Sway {
                pitch: rng.random_range(0.0..0.2f32).to_radians(),
                roll: rng.random_range(0.0..0.15f32).to_radians(),
                omega: rng.random_range(1.5..4.0),
                phase: rng.random_range(0.0..std::f32::consts::TAU),
            },
        }
    }

    /// The sensor's tilt at `t` from the level world: its mounting and the suspension's sway.
    /// The car itself stands level, as every object of the simulator does (a car pitched with
    /// the road under it would see the others leaning).
    pub fn tilt(&self, t: f32) -> Tilt {
        let Sway {
            pitch,
            roll,
            omega,
            phase,
        } = self.sway;
        Tilt {
            pitch: self.mount.pitch + pitch * (omega * t + phase).sin(),
            roll: self.mount.roll + roll * (0.7 * omega * t + 2.0 * phase).sin(),
        }
    }

    /// Ego (sensor) pose in the world at `t`: `[x, y, z, yaw]`; the identity at t = 0.
    pub fn ego_pose(&self, t: f32) -> [f32; 4] {
        let x = self.ego_speed * t;
        let k = std::f32::consts::TAU / self.weave[1];
        let y = self.weave[0] * (1.0 - (k * x).cos());
        let yaw = (self.weave[0] * k * (k * x).sin()).atan();
        [x, y, self.ground.height(x, y) + self.mount_height, yaw]
    }

    /// The scene at `t` in the sensor's frame, and the terrain as the sensor sees it.
    pub fn moment(&self, t: f32) -> (Moment, GroundView<'_>) {
        let pose = self.ego_pose(t);
        let inv = inverse(pose);
        let mut prims: Vec<Primitive> = self
            .scenery
            .solids
            .iter()
            .map(|(s, r)| Primitive {
                shape: place(s, inv),
                surface: *r,
                owner: None,
            })
            .collect();
        let tilt = self.tilt(t);
        let mut boxes = Vec::with_capacity(self.actors.len());
        for (i, a) in self.actors.iter().enumerate() {
            let ap = self.to_frame(a.pose(t, &self.ground), inv);
            prims.extend(a.parts.iter().map(|(s, r)| Primitive {
                shape: place(s, ap),
                surface: *r,
                owner: Some(i as u32),
            }));
            boxes.push(tilted_box(place_box(a.local_box.0, a.local_box.1, 0.0, ap), tilt));
        }
        (
            Moment {
                prims,
                boxes,
                pose,
                tilt,
            },
            GroundView {
                ground: &self.ground,
                pose,
            },
        )
    }

    /// Composes a world pose with the world-to-sensor pose `inv`.
    fn to_frame(&self, p: [f32; 4], inv: [f32; 4]) -> [f32; 4] {
        let (s, c) = inv[3].sin_cos();
        [
            inv[0] + c * p[0] - s * p[1],
            inv[1] + s * p[0] + c * p[1],
            inv[2] + p[2],
            wrap_angle(inv[3] + p[3]),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn inverse_pose_round_trip() {
        let p = [3.0, -2.0, 0.5, 0.7];
        let b = place_box([1.0, 0.5, 0.2], [4.0, 2.0, 1.5], 0.1, p);
        let back = place_box([b.x, b.y, b.z], [b.dx, b.dy, b.dz], b.heading, inverse(p));
        assert!((back.x - 1.0).abs() < 1e-5 && (back.y - 0.5).abs() < 1e-5 && (back.z - 0.2).abs() < 1e-5);
        assert!((back.heading - 0.1).abs() < 1e-5);
    }

    #[test]
    fn ego_starts_at_the_origin_and_drives_forward() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        let w = World::generate(&LidarConfig::default(), 5.0, &mut rng);
        let p0 = w.ego_pose(0.0);
        assert!(p0.iter().all(|v| v.abs() < 1e-5), "{p0:?}");
        let p1 = w.ego_pose(1.0);
        assert!((p1[0] - w.ego_speed).abs() < 1e-4 && p1[3].abs() < 0.05);
        // At t = 0 the sensor's level frame is the world frame: boxes, turned back by the
        // sensor's tilt, stand where the actors stand.
        let (m, view) = w.moment(0.0);
        use super::super::Terrain;
        assert!((view.height(0.0, 0.0) + 1.73).abs() < 1e-4);
        assert!(m.tilt.pitch.abs() < 0.1 && m.tilt.roll.abs() < 0.1, "{:?}", m.tilt);
        for (a, b) in w.actors.iter().zip(&m.boxes) {
            let [x, y, z] = m.tilt.to_level([b.x, b.y, b.z]);
            let pose = a.pose(0.0, &w.ground);
            assert!((x - pose[0]).hypot(y - pose[1]) < 3.0, "{:?} moved", a.class);
            // On the ground; a vehicle's labelled box reaches up to 9 cm under it
            // (AnnotationMargin).
            let below = pose[2] - (z - 0.5 * b.dz);
            assert!(
                (-0.02..0.02 + 0.09).contains(&below),
                "{:?} stands on the ground",
                a.class
            );
        }
    }
}
