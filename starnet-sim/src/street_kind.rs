//! Kinds of street, drawn per scene, each with its own distributions: real drives pass through
//! narrow residential streets, wide arterials, urban canyons and open roads, and a detector
//! fitted to one street's averages meets the others unprepared (issue #47: the simulator-only
//! car detector scored 49.6 on the street it was fitted to and 27 on other streets).
//!
//! Each kind sets the street's cross-section (lanes, parking, sidewalks) and what lines it
//! (buildings, their setback and height, trees, embankments). The ranges are set by hand from
//! what such streets look like, wider than any one street, not fitted to `kitti-real-dev`.

use rand::Rng;

/// The most travel lanes a side any kind draws ([`Layout::lanes_per_side`]).
pub const MAX_LANES_PER_SIDE: usize = 3;

/// The kind of street a scene is built around.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreetKind {
    /// One narrow lane each way, parked rows along both kerbs, houses set back behind front
    /// gardens (hedges, low walls), trees.
    Residential,
    /// Two or three lanes each way, wide sidewalks, parking on some, larger buildings.
    Arterial,
    /// An urban canyon: tall façades at the back of the sidewalk, parking, few trees.
    Canyon,
    /// An open road: rarely parking, few buildings far back, embankments and vegetation.
    OpenRoad,
}

/// What a kind of street draws: the ranges its street and scenery are drawn from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layout {
    /// Travel lanes per direction, inclusive range.
    pub lanes_per_side: [usize; 2],
    /// Lane width (m).
    pub lane_width: [f32; 2],
    /// Chance that the street has parking strips.
    pub parking_share: f32,
    /// Chance that a street with parking parks its cars in angled bays rather than in a row
    /// along the kerb.
    pub angled_share: f32,
    /// Sidewalk width (m): a raised slab along each kerb.
    pub sidewalk: [f32; 2],
    /// Chance of a crossing street.
    pub crossing_share: f32,
    /// Chance, per side, that buildings line the street (otherwise bushes).
    pub building_share: f32,
    /// A building's setback behind the sidewalk (m).
    pub setback: [f32; 2],
    /// A building's height (m).
    pub height: [f32; 2],
    /// Chance, per side, of a row of trees.
    pub tree_share: f32,
    /// Chance, per side, that the ground beyond the sidewalk rises or falls as an embankment.
    pub bank_share: f32,
}

impl StreetKind {
    /// Every kind with its share of scenes.
    pub const SHARES: [(StreetKind, f32); 4] = [
        (StreetKind::Residential, 0.35),
        (StreetKind::Arterial, 0.25),
        (StreetKind::Canyon, 0.2),
        (StreetKind::OpenRoad, 0.2),
    ];

    /// Draws a kind by [`StreetKind::SHARES`].
    pub fn sample(rng: &mut impl Rng) -> Self {
        let mut u: f32 = rng.random();
        for (kind, share) in Self::SHARES {
            if u < share {
                return kind;
            }
            u -= share;
        }
        StreetKind::Residential
    }

    /// The ranges this kind's streets and scenery are drawn from.
    pub fn layout(self) -> Layout {
        match self {
            StreetKind::Residential => Layout {
                lanes_per_side: [1, 1],
                lane_width: [2.9, 3.5],
                parking_share: 0.9,
                angled_share: 0.15,
                sidewalk: [1.5, 3.0],
                crossing_share: 0.35,
                building_share: 0.75,
                setback: [1.0, 9.0],
                height: [4.0, 12.0],
                tree_share: 0.7,
                bank_share: 0.3,
            },
            StreetKind::Arterial => Layout {
                lanes_per_side: [2, 3],
                lane_width: [3.2, 3.8],
                parking_share: 0.5,
                angled_share: 0.15,
                sidewalk: [2.5, 5.0],
                crossing_share: 0.5,
                building_share: 0.75,
                setback: [0.0, 6.0],
                height: [6.0, 22.0],
                tree_share: 0.5,
                bank_share: 0.4,
            },
            StreetKind::Canyon => Layout {
                lanes_per_side: [1, 2],
                lane_width: [3.0, 3.6],
                parking_share: 0.8,
                angled_share: 0.2,
                sidewalk: [2.0, 4.5],
                crossing_share: 0.35,
                building_share: 1.0,
                setback: [0.0, 1.0],
                height: [12.0, 30.0],
                tree_share: 0.25,
                bank_share: 0.0,
            },
            StreetKind::OpenRoad => Layout {
                lanes_per_side: [1, 1],
                lane_width: [3.2, 3.8],
                parking_share: 0.1,
                angled_share: 0.0,
                sidewalk: [1.0, 2.0],
                crossing_share: 0.15,
                building_share: 0.15,
                setback: [5.0, 20.0],
                height: [4.0, 10.0],
                tree_share: 0.8,
                bank_share: 0.8,
            },
        }
    }
}

/// A uniform draw from `[lo, hi]` (`lo` itself when the range is empty).
pub(crate) fn draw(rng: &mut impl Rng, [lo, hi]: [f32; 2]) -> f32 {
    if hi > lo { rng.random_range(lo..hi) } else { lo }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn kinds_are_drawn_by_their_shares() {
        let total: f32 = StreetKind::SHARES.iter().map(|(_, s)| s).sum();
        assert!((total - 1.0).abs() < 1e-6);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let n = 20_000;
        let draws: Vec<StreetKind> = (0..n).map(|_| StreetKind::sample(&mut rng)).collect();
        for (kind, share) in StreetKind::SHARES {
            let got = draws.iter().filter(|k| **k == kind).count() as f32 / n as f32;
            assert!((got - share).abs() < 0.015, "{kind:?}: {got} against {share}");
        }
    }

    #[test]
    fn every_layout_draws_from_ordered_ranges() {
        for (kind, _) in StreetKind::SHARES {
            let l = kind.layout();
            assert!(l.lanes_per_side[0] >= 1 && l.lanes_per_side[0] <= l.lanes_per_side[1]);
            assert!(l.lanes_per_side[1] <= MAX_LANES_PER_SIDE, "{kind:?}");
            for r in [l.lane_width, l.sidewalk, l.setback, l.height] {
                assert!(r[0] <= r[1], "{kind:?}: {r:?}");
            }
            for p in [
                l.parking_share,
                l.angled_share,
                l.crossing_share,
                l.building_share,
                l.tree_share,
                l.bank_share,
            ] {
                assert!((0.0..=1.0).contains(&p), "{kind:?}: {p}");
            }
        }
    }
}
