//! Augmenting a frame: the settings, what was drawn, and the order the transforms run in; ring dropout.

use super::{
    box_scaling::BoxScale, box_scaling::scale_boxes, gtdb::GTDB_CAPTURE_MARGIN, gtdb::GtDatabase, paste::DbPasteConfig,
    paste::paste_from_database, reflectance::ReflectanceAugment, reflectance::ReflectanceDraw,
    reflectance::augment_reflectance, transforms::Scene, transforms::flip_y, transforms::rotate_boxes,
    transforms::rotate_z, transforms::scale, transforms::shift_z,
};
use crate::Point;
use crate::settings::{Checked, InvalidSetting, non_negative, ordered_range, positive, within};
use rand::Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};
use std::f32::consts::{FRAC_PI_4, PI};

/// A step with a symmetric uniform range `U(−max, max)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UniformStep {
    /// Whether the step runs.
    pub enabled: bool,
    /// Half-width of the range.
    pub max: f32,
}

/// A per-object stretch whose factor along each box axis is drawn from that axis's range
/// `U(min, max)` (a range of one value draws nothing).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScalingStep {
    /// Whether the step runs.
    pub enabled: bool,
    /// Along the heading, `[min, max]`.
    pub length: [f32; 2],
    /// Across the heading.
    pub width: [f32; 2],
    /// Up, from the box's bottom.
    pub height: [f32; 2],
}

/// Augmentation settings; the defaults are the authors' KITTI car settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct AugmentConfig {
    /// Ground-truth database paste.
    pub db_paste: DbPasteConfig,
    /// How far beyond its box an object's points reach, metres (sides and top,
    /// [`crate::Box3d::grown`]): the points that the per-box rotation turns and the paste step
    /// copies and clears. Range noise scatters some of an object's returns a few centimetres
    /// outside its box (a simulated car has 3.5 % more returns within 10 cm of its box than
    /// inside it; on KITTI, mirrors stick out too), so the box itself (0.0, lingvo's) tears
    /// objects apart. Default 0.1; at most [`GTDB_CAPTURE_MARGIN`].
    pub object_margin: f32,
    /// Per-box rotation about the box centre, radians (π/20).
    pub box_rotation: UniformStep,
    /// Per-object scaling ([`BoxScale`], ST3D's random object scaling; not in the paper, off):
    /// each box's length, width and height stretched by its own factor from that axis's range,
    /// its points with it, after the per-box rotation.
    pub box_scaling: ScalingStep,
    /// Whether to mirror y, and with which probability (0.5).
    pub flip_y: bool,
    /// Probability of the flip.
    pub flip_probability: f32,
    /// Global rotation about z, radians (π/4).
    pub global_rotation: UniformStep,
    /// Global scaling: enabled, and the range `[min, max]` ([0.95, 1.05]).
    pub global_scaling: bool,
    /// Scaling range.
    pub scaling_range: [f32; 2],
    /// Global z shift: enabled, and its standard deviation in metres (0.35).
    pub z_shift: bool,
    /// Standard deviation of the z shift.
    pub z_shift_sigma: f32,
    /// One-ring dropout after center selection.
    pub ring_dropout: bool,
    /// Width in radians of the dropped band of inclination (0.03, about one laser ring).
    pub ring_dropout_width: f32,
    /// Sensor-scale augmentation of the reflectance channel (not in the paper; off).
    pub reflectance: ReflectanceAugment,
}

impl Default for AugmentConfig {
    fn default() -> Self {
        Self {
            db_paste: DbPasteConfig::default(),
            object_margin: 0.1,
            box_rotation: UniformStep {
                enabled: true,
                max: PI / 20.0,
            },
            box_scaling: ScalingStep {
                enabled: false,
                length: [0.9, 1.1],
                width: [0.9, 1.1],
                height: [0.9, 1.1],
            },
            flip_y: true,
            flip_probability: 0.5,
            global_rotation: UniformStep {
                enabled: true,
                max: FRAC_PI_4,
            },
            global_scaling: true,
            scaling_range: [0.95, 1.05],
            z_shift: true,
            z_shift_sigma: 0.35,
            ring_dropout: true,
            ring_dropout_width: 0.03,
            reflectance: ReflectanceAugment::default(),
        }
    }
}

impl AugmentConfig {
    /// Checks every range and sign (keys relative to the augmentation table).
    pub fn validate(&self) -> Checked {
        within(
            "object_margin",
            self.object_margin as f64,
            0.0,
            GTDB_CAPTURE_MARGIN as f64,
        )
        .map_err(|e| {
            InvalidSetting::new(
                e.key,
                format!("{} (the ground-truth database holds points that far out)", e.message),
            )
        })?;
        non_negative("box_rotation.max", self.box_rotation.max as f64)?;
        for (key, range) in self.box_scaling.ranges() {
            positive(key, range[0] as f64)?;
            ordered_range(key, range)?;
        }
        within("flip_probability", self.flip_probability as f64, 0.0, 1.0)?;
        non_negative("global_rotation.max", self.global_rotation.max as f64)?;
        let [lo, hi] = self.scaling_range;
        positive("scaling_range", lo as f64)?;
        positive("scaling_range", hi as f64)?;
        ordered_range("scaling_range", self.scaling_range)?;
        non_negative("z_shift_sigma", self.z_shift_sigma as f64)?;
        within("ring_dropout_width", self.ring_dropout_width as f64, 0.0, PI as f64)?;
        self.reflectance.validate().map_err(|e| e.within("reflectance"))
    }

    /// Every step off: the identity.
    pub fn none() -> Self {
        Self {
            db_paste: DbPasteConfig {
                enabled: false,
                ..Default::default()
            },
            box_rotation: UniformStep {
                enabled: false,
                max: 0.0,
            },
            box_scaling: ScalingStep {
                enabled: false,
                length: [1.0, 1.0],
                width: [1.0, 1.0],
                height: [1.0, 1.0],
            },
            flip_y: false,
            global_rotation: UniformStep {
                enabled: false,
                max: 0.0,
            },
            global_scaling: false,
            z_shift: false,
            ring_dropout: false,
            ..Self::default()
        }
    }
}

impl ScalingStep {
    /// One box's factors, length, width, then height (the identity when the step is off).
    pub fn draw(&self, rng: &mut impl Rng) -> BoxScale {
        if !self.enabled {
            return BoxScale::IDENTITY;
        }
        let mut factor = |[lo, hi]: [f32; 2]| if lo < hi { rng.random_range(lo..=hi) } else { lo };
        BoxScale {
            length: factor(self.length),
            width: factor(self.width),
            height: factor(self.height),
        }
    }

    /// Each axis's range with its key (relative to the augmentation table).
    fn ranges(&self) -> [(&'static str, [f32; 2]); 3] {
        [
            ("box_scaling.length", self.length),
            ("box_scaling.width", self.width),
            ("box_scaling.height", self.height),
        ]
    }
}

/// What one call of [`augment`] drew (identity values for disabled steps).
#[derive(Debug, Clone, PartialEq)]
pub struct AugmentDraw {
    /// Database entries pasted.
    pub pasted: Vec<usize>,
    /// Per-box rotations, after pasting (one per box).
    pub box_rotations: Vec<f32>,
    /// Per-box stretches, after the rotations (one per box).
    pub box_scales: Vec<BoxScale>,
    /// Whether y was mirrored.
    pub flipped: bool,
    /// Global rotation.
    pub rotation: f32,
    /// Global scale.
    pub scale: f32,
    /// Global z shift.
    pub z_shift: f32,
    /// The reflectance step's draw, when it ran.
    pub reflectance: Option<ReflectanceDraw>,
}

impl AugmentDraw {
    /// `points` of the augmented scene moved back by the inverse of the global steps (z shift,
    /// scaling, rotation, flip), in the same order: where the sensor recorded them. What depends
    /// on the recording rather than on the augmentation (the camera frustum that bounds the
    /// labels, the ground band) is decided there.
    pub fn undo_global(&self, points: &[Point]) -> Vec<Point> {
        let mut s = Scene {
            points: points.to_vec(),
            boxes: Vec::new(),
            classes: Vec::new(),
        };
        shift_z(&mut s, -self.z_shift);
        scale(&mut s, 1.0 / self.scale);
        rotate_z(&mut s, -self.rotation);
        if self.flipped {
            flip_y(&mut s);
        }
        s.points
    }
}

/// Augments a scene in place (all steps but the ring dropout, which [`ring_dropout`] applies
/// after center selection).
pub fn augment(scene: &mut Scene, cfg: &AugmentConfig, db: Option<&GtDatabase>, rng: &mut impl Rng) -> AugmentDraw {
    let pasted = match db {
        Some(db) if cfg.db_paste.enabled => paste_from_database(scene, db, &cfg.db_paste, cfg.object_margin, rng),
        _ => Vec::new(),
    };
    let uniform = |step: &UniformStep, rng: &mut dyn rand::RngCore| {
        if step.enabled && step.max > 0.0 {
            rng.random_range(-step.max..step.max)
        } else {
            0.0
        }
    };
    let box_rotations: Vec<f32> = (0..scene.boxes.len())
        .map(|_| uniform(&cfg.box_rotation, rng))
        .collect();
    rotate_boxes(scene, &box_rotations, cfg.object_margin);
    let box_scales: Vec<BoxScale> = (0..scene.boxes.len()).map(|_| cfg.box_scaling.draw(rng)).collect();
    scale_boxes(scene, &box_scales, cfg.object_margin);
    let flipped = cfg.flip_y && rng.random::<f32>() < cfg.flip_probability;
    if flipped {
        flip_y(scene);
    }
    let rotation = uniform(&cfg.global_rotation, rng);
    rotate_z(scene, rotation);
    let s = if cfg.global_scaling {
        rng.random_range(cfg.scaling_range[0]..=cfg.scaling_range[1])
    } else {
        1.0
    };
    scale(scene, s);
    let dz = if cfg.z_shift {
        Normal::new(0.0, cfg.z_shift_sigma).expect("finite sigma").sample(rng)
    } else {
        0.0
    };
    shift_z(scene, dz);
    let reflectance = cfg.reflectance.enabled.then(|| {
        let draw = cfg.reflectance.draw(rng);
        augment_reflectance(&mut scene.points, draw, cfg.reflectance.noise, rng);
        draw
    });
    AugmentDraw {
        pasted,
        box_rotations,
        box_scales,
        flipped,
        rotation,
        scale: s,
        z_shift: dz,
        reflectance,
    }
}

/// Drops every point whose inclination `acos(z / r)` lies within `width / 2` of a randomly
/// chosen point's (lingvo's `frustum_dropout`): about one laser ring. Returns the kept points
/// and the dropped band's centre.
pub fn ring_dropout(points: &[Point], width: f32, rng: &mut impl Rng) -> (Vec<Point>, f32) {
    if points.is_empty() {
        return (Vec::new(), 0.0);
    }
    let incl = |p: &Point| {
        let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt().max(1e-6);
        (p[2] / r).clamp(-1.0, 1.0).acos()
    };
    let centre = incl(&points[rng.random_range(0..points.len())]);
    // acos falls from π to 0 over [−1, 1]: |acos(c) − centre| ≥ width / 2 is c ≤ cos(centre +
    // width / 2) or c ≥ cos(centre − width / 2), each side only where its angle is in [0, π].
    // Comparing cosines spares an acos per point.
    let half = 0.5 * width;
    let below = if centre + half <= PI {
        (centre + half).cos()
    } else {
        f32::NEG_INFINITY
    };
    let above = if centre - half >= 0.0 {
        (centre - half).cos()
    } else {
        f32::INFINITY
    };
    let kept = points
        .iter()
        .filter(|p| {
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt().max(1e-6);
            let c = (p[2] / r).clamp(-1.0, 1.0);
            c <= below || c >= above
        })
        .copied()
        .collect();
    (kept, centre)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Box3d;
    use crate::augment::{rotate_box, scale_box};
    use crate::kitti::ObjectClass;
    use rand::SeedableRng;

    #[test]
    fn identity_config_changes_nothing_and_draws_identity() {
        let mut s = Scene {
            points: vec![[1.0, 2.0, 3.0, 0.5]],
            boxes: vec![Box3d::new(1.0, 2.0, 3.0, 1.0, 1.0, 1.0, 0.3)],
            classes: vec![ObjectClass::Car],
        };
        let before = s.clone();
        let d = augment(
            &mut s,
            &AugmentConfig::none(),
            None,
            &mut rand_chacha::ChaCha8Rng::seed_from_u64(1),
        );
        assert_eq!(s, before);
        assert_eq!((d.flipped, d.rotation, d.scale, d.z_shift), (false, 0.0, 1.0, 0.0));
    }

    #[test]
    fn draws_stay_in_their_ranges_and_replay() {
        let cfg = AugmentConfig {
            box_scaling: ScalingStep {
                enabled: true,
                ..AugmentConfig::default().box_scaling
            },
            ..AugmentConfig::default()
        };
        let mut flips = 0;
        for seed in 0..200 {
            let mut s = Scene {
                points: vec![[5.0, 1.0, -1.0, 0.5]],
                boxes: vec![Box3d::new(5.0, 1.0, -1.0, 4.0, 2.0, 1.5, 0.0)],
                classes: vec![ObjectClass::Car],
            };
            let d = augment(&mut s, &cfg, None, &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed));
            assert!(
                d.rotation.abs() <= FRAC_PI_4
                    && (0.95..=1.05).contains(&d.scale)
                    && d.box_rotations[0].abs() <= PI / 20.0
            );
            let f = d.box_scales[0];
            assert!([f.length, f.width, f.height].iter().all(|x| (0.9..=1.1).contains(x)));
            flips += d.flipped as usize;
            // Replaying the draw with the pure transforms gives the same scene.
            let mut r = Scene {
                points: vec![[5.0, 1.0, -1.0, 0.5]],
                boxes: vec![Box3d::new(5.0, 1.0, -1.0, 4.0, 2.0, 1.5, 0.0)],
                classes: vec![ObjectClass::Car],
            };
            rotate_box(&mut r, 0, d.box_rotations[0], cfg.object_margin);
            scale_box(&mut r, 0, d.box_scales[0], cfg.object_margin);
            if d.flipped {
                flip_y(&mut r);
            }
            rotate_z(&mut r, d.rotation);
            scale(&mut r, d.scale);
            shift_z(&mut r, d.z_shift);
            assert_eq!(r, s);
        }
        assert!((70..130).contains(&flips), "p = 0.5 flips: {flips}");
    }

    #[test]
    fn undoing_the_global_steps_restores_the_recorded_points() {
        // Only the global steps, the flip certain.
        let d = AugmentConfig::default();
        let cfg = AugmentConfig {
            flip_y: true,
            flip_probability: 1.0,
            global_rotation: d.global_rotation,
            global_scaling: true,
            z_shift: true,
            ..AugmentConfig::none()
        };
        let points = vec![[12.0, 3.0, -1.0, 0.5], [-4.0, 7.5, 0.2, 0.1]];
        let mut s = Scene {
            points: points.clone(),
            boxes: vec![],
            classes: vec![],
        };
        let d = augment(&mut s, &cfg, None, &mut rand_chacha::ChaCha8Rng::seed_from_u64(4));
        assert!(d.flipped && d.rotation != 0.0 && d.scale != 1.0 && d.z_shift != 0.0);
        assert!(s.points.iter().zip(&points).all(|(a, b)| (a[0] - b[0]).abs() > 1e-3));
        for (a, b) in d.undo_global(&s.points).iter().zip(&points) {
            assert!(a.iter().zip(b).all(|(u, v)| (u - v).abs() < 1e-4), "{a:?} vs {b:?}");
        }
    }

    #[test]
    fn ring_dropout_removes_one_band() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        // 64 rings, 0.4° apart, 100 points each.
        let pts: Vec<Point> = (0..64)
            .flat_map(|r| {
                let e = (2.0 - 0.4 * r as f32).to_radians();
                (0..100).map(move |k| {
                    let a = k as f32 * 0.0628;
                    [20.0 * e.cos() * a.cos(), 20.0 * e.cos() * a.sin(), 20.0 * e.sin(), 0.1]
                })
            })
            .collect();
        let (kept, _) = ring_dropout(&pts, 0.003, &mut rng);
        assert_eq!(pts.len() - kept.len(), 100, "exactly one ring of 100 points");
    }

    #[test]
    fn ring_dropout_keeps_what_the_inclination_rule_keeps() {
        // Every direction, and bands reaching past 0 and π (widths up to 2).
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
        let pts: Vec<Point> = (0..4000)
            .map(|_| std::array::from_fn(|k| if k < 3 { rng.random_range(-5.0..5.0) } else { 0.0 }))
            .collect();
        let incl = |p: &Point| {
            (p[2] / (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt())
                .clamp(-1.0, 1.0)
                .acos()
        };
        for width in [0.0, 0.03, 0.5, 2.0] {
            for seed in 0..20 {
                let (kept, centre) = ring_dropout(&pts, width, &mut rand_chacha::ChaCha8Rng::seed_from_u64(seed));
                let mut kept = kept.into_iter().peekable();
                for p in &pts {
                    let off = (incl(p) - centre).abs() - 0.5 * width;
                    let was_kept = kept.next_if_eq(p).is_some();
                    // Within rounding of the band's edge either answer is the rule's.
                    assert!(
                        off.abs() < 1e-5 || was_kept == (off >= 0.0),
                        "width {width}: {p:?} off {off}"
                    );
                }
            }
        }
    }
}
