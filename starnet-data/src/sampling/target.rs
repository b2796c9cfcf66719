//! Targeting: spending the center budget where it matters. `nearest:N` keeps the N sampled
//! centers closest to the sensor (bird's-eye-view range), the StarNet workshop paper's §4.2
//! experiment: near objects keep their full coverage while the compute falls with N.

use super::Centers;
use serde_with::{DeserializeFromStr, SerializeDisplay};

/// Which of the sampled centers the model sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, SerializeDisplay, DeserializeFromStr)]
pub enum CenterTarget {
    /// Every sampled center.
    #[default]
    All,
    /// The N centers nearest the sensor; written `nearest:N`.
    Nearest(usize),
}

impl CenterTarget {
    /// Centers the model sees when `sampled` were drawn.
    pub fn count(self, sampled: usize) -> usize {
        match self {
            Self::All => sampled,
            Self::Nearest(n) => n.min(sampled),
        }
    }

    /// Applies the target to sampled centers: `Nearest(n)` keeps the `n` nearest (ties by
    /// sampling order), seeds and repeats included, in order of range.
    pub fn apply(self, centers: Centers) -> Centers {
        let Self::Nearest(n) = self else {
            return centers;
        };
        if n >= centers.len() {
            return centers;
        }
        let range = |i: usize| {
            let [x, y, _] = centers.xyz[i];
            x.hypot(y)
        };
        let mut order: Vec<usize> = (0..centers.len()).collect();
        order.sort_by(|&a, &b| range(a).total_cmp(&range(b)).then(a.cmp(&b)));
        order.truncate(n);
        Centers {
            xyz: order.iter().map(|&i| centers.xyz[i]).collect(),
            valid: order.iter().map(|&i| centers.valid[i]).collect(),
            // Seeds lose their leading place once reordered by range.
            num_seeded: 0,
        }
    }
}

impl std::str::FromStr for CenterTarget {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("unknown center target `{s}` (expected `all` or `nearest:N` with N ≥ 1)");
        match s.split_once(':') {
            None if s == "all" => Ok(Self::All),
            Some(("nearest", n)) => n.parse().ok().filter(|&n| n > 0).map(Self::Nearest).ok_or_else(bad),
            _ => Err(bad()),
        }
    }
}

impl std::fmt::Display for CenterTarget {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::All => write!(f, "all"),
            Self::Nearest(n) => write!(f, "nearest:{n}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_prints_round_trip() {
        for s in ["all", "nearest:1", "nearest:128"] {
            assert_eq!(s.parse::<CenterTarget>().unwrap().to_string(), s);
        }
        for bad in ["", "nearest", "nearest:0", "nearest:x", "farthest:3", "all:2"] {
            assert!(bad.parse::<CenterTarget>().is_err(), "{bad}");
        }
    }

    #[test]
    fn nearest_keeps_the_closest_by_bev_range() {
        let centers = Centers {
            xyz: vec![[30.0, 0.0, 9.0], [0.0, -5.0, 0.0], [3.0, 4.0, -9.0], [10.0, 0.0, 0.0]],
            valid: vec![true, true, false, true],
            num_seeded: 1,
        };
        let kept = CenterTarget::Nearest(2).apply(centers.clone());
        // Ranges 30, 5, 5, 10: the two at 5 m, in sampling order (z is ignored).
        assert_eq!(kept.xyz, vec![[0.0, -5.0, 0.0], [3.0, 4.0, -9.0]]);
        assert_eq!(kept.valid, vec![true, false]);
        assert_eq!(CenterTarget::Nearest(9).apply(centers.clone()), centers);
        assert_eq!(CenterTarget::All.apply(centers.clone()), centers);
        assert_eq!(CenterTarget::Nearest(2).count(4), 2);
        assert_eq!(CenterTarget::Nearest(9).count(4), 4);
    }
}
