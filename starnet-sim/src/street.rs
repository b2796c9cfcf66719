//! The street every scene is built around, and the terrain under it.
//!
//! World frame: the LiDAR frame of the scene's first frame (x along the street, the ego in a
//! right-hand travel lane at y = 0, ground 1.73 m below the sensor at the origin).

use super::street_kind::{Layout, StreetKind, draw};
use super::{Surface, Terrain};
use rand::Rng;

/// Cross-section of the street; the road runs along world x.
#[derive(Debug, Clone, PartialEq)]
pub struct Street {
    /// The kind of street, whose [`Layout`] the rest was drawn from.
    pub kind: StreetKind,
    /// y of the centre line.
    pub centre_y: f32,
    /// Travel lanes per direction.
    pub lanes_per_side: usize,
    /// Lane width (m).
    pub lane_width: f32,
    /// The parking along each kerb.
    pub parking: Parking,
    /// Sidewalk width (m).
    pub sidewalk: f32,
    /// Kerb height (m).
    pub kerb: f32,
    /// x of a crossing street's centre line, and its half-width, if there is one.
    pub crossing: Option<(f32, f32)>,
}

/// How cars park along a street's kerbs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Parking {
    /// No parking: the travel lanes reach the kerb.
    None,
    /// A row along the kerb, in a strip `width` metres wide.
    Row {
        /// Strip width (m).
        width: f32,
    },
    /// Angled bays, `angle` radians from the kerb's line (π/2: perpendicular), in a strip
    /// `width` metres deep, so that the sensor sees parked cars three-quarter on.
    Angled {
        /// Strip depth (m).
        width: f32,
        /// Angle between a parked car's axis and the kerb (radians).
        angle: f32,
    },
}

impl Parking {
    /// The strip's width across the street (0 without parking).
    pub fn width(self) -> f32 {
        match self {
            Parking::None => 0.0,
            Parking::Row { width } | Parking::Angled { width, .. } => width,
        }
    }

    fn sample(layout: &Layout, rng: &mut impl Rng) -> Self {
        if rng.random::<f32>() >= layout.parking_share {
            Parking::None
        } else if rng.random::<f32>() < layout.angled_share {
            Parking::Angled {
                width: rng.random_range(4.9..5.6),
                angle: rng.random_range(40.0f32..90.0).to_radians(),
            }
        } else {
            Parking::Row {
                width: rng.random_range(2.0..2.6),
            }
        }
    }
}

impl Street {
    /// Draws a street of a kind drawn by [`StreetKind::SHARES`]; the ego's lane (one of the
    /// right-hand lanes) is centred on y = 0.
    pub fn sample(rng: &mut impl Rng) -> Self {
        let kind = StreetKind::sample(rng);
        Self::sample_of(kind, rng)
    }

    /// Draws a street of `kind`; the ego's lane (one of the right-hand lanes) is centred on y = 0.
    pub fn sample_of(kind: StreetKind, rng: &mut impl Rng) -> Self {
        let layout = kind.layout();
        let lanes_per_side = rng.random_range(layout.lanes_per_side[0]..=layout.lanes_per_side[1]);
        let lane_width = draw(rng, layout.lane_width);
        let ego_lane = rng.random_range(0..lanes_per_side);
        let crossing = (rng.random::<f32>() < layout.crossing_share).then(|| {
            let x = rng.random_range(15.0..70.0) * if rng.random::<f32>() < 0.7 { 1.0 } else { -1.0 };
            (x, rng.random_range(4.0..7.0))
        });
        Self {
            kind,
            centre_y: lane_width * (ego_lane as f32 + 0.5),
            lanes_per_side,
            lane_width,
            parking: Parking::sample(&layout, rng),
            sidewalk: draw(rng, layout.sidewalk),
            kerb: rng.random_range(0.12..0.16),
            crossing,
        }
    }

    /// Half-width of the carriageway, kerb to kerb.
    pub fn half_width(&self) -> f32 {
        self.lanes_per_side as f32 * self.lane_width + self.parking.width()
    }

    /// Signed distance across the street from the centre line (+ to the left).
    pub fn lateral(&self, y: f32) -> f32 {
        y - self.centre_y
    }

    /// y of the centre of travel lane `i` (0 = nearest the centre) on side `side` (+1 left, −1 right).
    pub fn lane_y(&self, side: f32, i: usize) -> f32 {
        self.centre_y + side * self.lane_width * (i as f32 + 0.5)
    }

    /// Whether x lies within the crossing street (plus its sidewalks).
    pub fn in_crossing(&self, x: f32) -> bool {
        self.crossing
            .is_some_and(|(cx, hw)| (x - cx).abs() < hw + self.sidewalk)
    }
}

/// The ground: camber falling 2 % from the centre line to the kerbs, a vertical curve along the
/// street (real streets climb and dip: on `kitti-real-dev` the road 40 m ahead lies 0.26 m above
/// the sensor's reference at the median frame), embankments beside it, and gentle undulation.
///
/// The grade under the sensor is zero. A constant grade is invisible to a sensor that rides on
/// it, and objects stand level in the world rather than pitched with the road: a grade would
/// show them all leaning against it.
#[derive(Debug, Clone, PartialEq)]
pub struct Ground {
    /// The street it carries.
    pub street: Street,
    /// `(kx, ky, amplitude, phase)` of each undulation wave.
    waves: Vec<[f32; 4]>,
    /// Change of grade per metre along x (the vertical curve, 1/m); the grade is 0 at x = 0.
    bend: f32,
    /// Per side (right, left): the embankment's slope beyond the sidewalk (rise over run,
    /// negative where the ground falls away) and the height at which it levels off.
    banks: [Bank; 2],
    /// Added so that the ground under the sensor at the origin is at −mount height.
    offset: f32,
}

/// The ground beside a street, beyond its sidewalk: flat, or rising (falling) to a terrace.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Bank {
    slope: f32,
    height: f32,
}

impl Bank {
    /// Flat, or (with chance `share`) an embankment.
    fn sample(share: f32, rng: &mut impl Rng) -> Self {
        if rng.random::<f32>() >= share {
            return Self {
                slope: 0.0,
                height: 0.0,
            };
        }
        let sign = if rng.random::<f32>() < 0.7 { 1.0 } else { -1.0 };
        Self {
            slope: sign * rng.random_range(0.08..0.45),
            height: rng.random_range(0.4..3.0),
        }
    }

    /// Height gained `run` metres beyond the sidewalk.
    fn rise(self, run: f32) -> f32 {
        (self.slope * run.max(0.0)).clamp(-self.height, self.height)
    }
}

/// Draws a zero-mean normal value with standard deviation `sd`, clamped to ±`limit`.
fn clamped_normal(rng: &mut impl Rng, sd: f32, limit: f32) -> f32 {
    let n: f32 = rng.sample(rand_distr::StandardNormal);
    (n * sd).clamp(-limit, limit)
}

impl Ground {
    /// Draws the terrain for `street`, with the ground `mount_height` below the origin.
    pub fn sample(street: Street, mount_height: f32, rng: &mut impl Rng) -> Self {
        let waves = (0..3)
            .map(|_| {
                let wavelength = rng.random_range(40.0..150.0);
                let dir: f32 = rng.random_range(-0.3..0.3);
                let k = std::f32::consts::TAU / wavelength;
                [
                    k * dir.cos(),
                    k * dir.sin(),
                    rng.random_range(0.02..0.12),
                    rng.random_range(0.0..6.3),
                ]
            })
            .collect();
        let share = street.kind.layout().bank_share;
        let banks = [Bank::sample(share, rng), Bank::sample(share, rng)];
        let mut g = Self {
            street,
            waves,
            // 1/4000 m⁻¹: the grade changes by 2.5 % over 100 m; the road 40 m ahead leaves
            // the tangent at the sensor by 0.2 m.
            bend: clamped_normal(rng, 1.0 / 4000.0, 1.0 / 1000.0),
            banks,
            offset: 0.0,
        };
        g.offset = -mount_height - g.raw(0.0, 0.0);
        g
    }

    fn raw(&self, x: f32, y: f32) -> f32 {
        let s = &self.street;
        let lat = s.lateral(y);
        let camber = -0.02 * lat.abs().min(s.half_width());
        let waves: f32 = self
            .waves
            .iter()
            .map(|w| w[2] * (w[0] * x + w[1] * y + w[3]).sin())
            .sum();
        camber + 0.5 * self.bend * x * x + self.bank(x, lat) + waves
    }

    /// The embankment's rise at `x`, `lat` across the street; none in a crossing street, and
    /// eased in over 10 m either side of it.
    fn bank(&self, x: f32, lat: f32) -> f32 {
        let s = &self.street;
        let bank = self.banks[usize::from(lat > 0.0)];
        let run = lat.abs() - s.half_width() - s.sidewalk;
        let ease = s.crossing.map_or(1.0, |(cx, hw)| {
            (((x - cx).abs() - hw - s.sidewalk) / 10.0).clamp(0.0, 1.0)
        });
        ease * bank.rise(run)
    }

    /// Ground height at world `(x, y)` (sidewalk slabs are solids on top of it).
    pub fn height(&self, x: f32, y: f32) -> f32 {
        self.raw(x, y) + self.offset
    }

    /// The lowest ground height along world x ∈ `[x0, x1]` at `y` (sampled every metre at
    /// most): where a long solid's base goes so that no gap opens under it on a grade.
    pub fn floor(&self, x0: f32, x1: f32, y: f32) -> f32 {
        let n = ((x1 - x0).abs().ceil() as usize).max(1);
        (0..=n)
            .map(|i| self.height(x0 + (x1 - x0) * i as f32 / n as f32, y))
            .fold(f32::INFINITY, f32::min)
    }

    /// The grade along world x at `x` (rise over run) of the vertical curve.
    pub fn grade_at(&self, x: f32) -> f32 {
        self.bend * x
    }

    /// Splits world x ∈ `[x0, x1]` into pieces short enough that a level solid on each, based at
    /// its [`Ground::floor`], stands at most about 5 cm proud of the grade at its ends (2 m
    /// at least, 10 m at most).
    pub fn pieces(&self, x0: f32, x1: f32) -> Vec<[f32; 2]> {
        let mut out = Vec::new();
        let mut x = x0;
        while x < x1 - 1e-3 {
            let len = (0.1 / self.grade_at(x).abs().max(1e-3)).clamp(2.0, 10.0);
            let end = (x + len).min(x1);
            out.push([x, end]);
            x = end;
        }
        out
    }

    /// Ground surface: asphalt, dashed lane markings, and soil or grass off the street.
    pub fn surface(&self, x: f32, y: f32) -> Surface {
        let s = &self.street;
        let lat = s.lateral(y);
        if lat.abs() > s.half_width() && !s.in_crossing(x) {
            return Surface::matte(0.45);
        }
        // Dashed lines between lanes and on the centre line, a solid line along the edge of
        // the travel lanes.
        let dash = x.rem_euclid(9.0) < 3.0;
        let on_line = (0..=s.lanes_per_side).any(|i| {
            let solid = i == s.lanes_per_side;
            (lat.abs() - i as f32 * s.lane_width).abs() < 0.08 && (solid || dash)
        });
        Surface::matte(if on_line { 0.75 } else { 0.28 })
    }
}

/// The ground seen from the sensor at a given pose: world height shifted and rotated.
#[derive(Debug, Clone, Copy)]
pub struct GroundView<'a> {
    /// The world's ground.
    pub ground: &'a Ground,
    /// Sensor pose in the world: `[x, y, z, yaw]`.
    pub pose: [f32; 4],
}

impl GroundView<'_> {
    fn world_xy(&self, x: f32, y: f32) -> (f32, f32) {
        let (s, c) = self.pose[3].sin_cos();
        (self.pose[0] + c * x - s * y, self.pose[1] + s * x + c * y)
    }
}

impl Terrain for GroundView<'_> {
    fn height(&self, x: f32, y: f32) -> f32 {
        let (wx, wy) = self.world_xy(x, y);
        self.ground.height(wx, wy) - self.pose[2]
    }

    fn surface(&self, x: f32, y: f32) -> Surface {
        let (wx, wy) = self.world_xy(x, y);
        self.ground.surface(wx, wy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn ground_is_mount_height_below_the_origin_and_drivable() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        for _ in 0..20 {
            let street = Street::sample(&mut rng);
            // The ego's lane is one of the right-hand ones: the nearest lane right of the centre
            // line lies at most (lanes − 1) lane widths to the ego's left.
            let most = (street.lanes_per_side - 1) as f32 * street.lane_width;
            assert!(street.lane_y(-1.0, 0).abs() <= most + 1e-4);
            let g = Ground::sample(street, 1.73, &mut rng);
            assert!((g.height(0.0, 0.0) + 1.73).abs() < 1e-5);
            // Along the lane, within 100 m: the vertical curve (under 1/1000 m⁻¹) and the
            // undulation's three waves (each under 0.12 · 2π / 40 m).
            for i in 0..200 {
                let x = -100.0 + i as f32;
                let dz = g.height(x + 0.5, 3.0) - g.height(x - 0.5, 3.0);
                assert!(g.grade_at(x).abs() < 100.0 / 1000.0);
                assert!((dz - g.grade_at(x)).abs() < 0.057, "{dz} against {}", g.grade_at(x));
            }
        }
    }

    #[test]
    fn streets_are_drawn_from_their_kinds_layouts() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut angled = 0;
        for _ in 0..400 {
            let s = Street::sample(&mut rng);
            let l = s.kind.layout();
            assert!(
                (l.lanes_per_side[0]..=l.lanes_per_side[1]).contains(&s.lanes_per_side),
                "{s:?}"
            );
            assert!(
                s.lane_width >= l.lane_width[0] && s.lane_width <= l.lane_width[1],
                "{s:?}"
            );
            assert!(s.sidewalk >= l.sidewalk[0] && s.sidewalk <= l.sidewalk[1], "{s:?}");
            // The ego's lane is one of the right-hand lanes, centred on y = 0.
            assert!(
                s.centre_y > 0.0 && s.centre_y < s.lanes_per_side as f32 * s.lane_width,
                "{s:?}"
            );
            match s.parking {
                Parking::None => {}
                Parking::Row { width } => assert!((2.0..2.6).contains(&width)),
                Parking::Angled { width, angle } => {
                    angled += 1;
                    assert!(l.angled_share > 0.0, "{s:?}");
                    assert!((40f32.to_radians()..=90f32.to_radians()).contains(&angle), "{s:?}");
                    // Deep enough for a 4.5 m × 1.8 m car at the bays' angle.
                    assert!(width >= 4.5 * angle.sin() + 1.8 * angle.cos(), "{s:?}");
                }
            }
        }
        assert!(angled > 10, "{angled}");
    }

    #[test]
    fn banks_rise_beyond_the_sidewalk_and_level_off() {
        let bank = Bank {
            slope: 0.3,
            height: 2.0,
        };
        assert_eq!(bank.rise(-1.0), 0.0);
        assert!((bank.rise(2.0) - 0.6).abs() < 1e-6);
        assert_eq!(bank.rise(50.0), 2.0);
        let fall = Bank {
            slope: -0.2,
            height: 1.0,
        };
        assert_eq!(fall.rise(20.0), -1.0);
    }

    #[test]
    fn floor_and_pieces_follow_the_grade() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let mut g = Ground::sample(Street::sample(&mut rng), 1.73, &mut rng);
        // A crest: the grade falls by 1 % every 10 m.
        (g.bend, g.waves) = (-0.001, Vec::new());
        g.banks = [Bank {
            slope: 0.0,
            height: 0.0,
        }; 2];
        g.offset = -1.73 - g.raw(0.0, 0.0);
        // The lowest point of [10, 20] is its far end; of [-20, 20] either end.
        assert!((g.floor(10.0, 20.0, 0.0) - g.height(20.0, 0.0)).abs() < 1e-5);
        assert!((g.floor(-20.0, 20.0, 0.0) - g.height(20.0, 0.0)).abs() < 1e-5);
        assert!((g.grade_at(50.0) + 0.05).abs() < 1e-6);
        // At 50 m the grade is 5 %: pieces of 2 m; near the crest, of 10 m.
        let far = g.pieces(50.0, 59.0);
        assert_eq!((far.first().unwrap()[0], far.last().unwrap()[1]), (50.0, 59.0));
        assert!(far.iter().all(|[a, b]| (b - a) <= 2.0 + 1e-5), "{far:?}");
        assert_eq!(g.pieces(-5.0, 5.0), vec![[-5.0, 5.0]]);
    }

    #[test]
    fn view_shifts_and_rotates() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(10);
        let g = Ground::sample(Street::sample(&mut rng), 1.73, &mut rng);
        let pose = [20.0, 1.0, g.height(20.0, 1.0) + 1.73, 0.3];
        let v = GroundView { ground: &g, pose };
        assert!((v.height(0.0, 0.0) + 1.73).abs() < 1e-4);
        let (s, c) = 0.3f32.sin_cos();
        let want = g.height(20.0 + 5.0 * c, 1.0 + 5.0 * s) - pose[2];
        assert!((v.height(5.0, 0.0) - want).abs() < 1e-5);
    }
}
