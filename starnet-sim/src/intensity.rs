//! What the sensor reports as a return's reflectance (KITTI's fourth float).
//!
//! Real HDL-64E scans (`../shared/kitti-real-dev`, measured with `starnet compare-data`) show
//! two things a plain Lambertian model misses. Many returns carry *exactly* 0: the received
//! power was too weak to be given a value, yet the range was measured. The share of such zeros
//! grows with range and with grazing incidence (road: 2 % at 10–20 m, 74 % at 30–40 m; walls
//! and vegetation: 4 % and 14 %; everything beyond 60 m: 93 %), and car paint is mostly zero
//! even near (51 % at 10–20 m): clear coat sends the laser away, not back. The values that are
//! reported stay about the surface's reflectance, slowly darkening with range.
//!
//! So a return has a *strength*, `K(finish) · albedo · cos(incidence)^q · (r₀ / r)² · gain`,
//! whose inverse-square fall-off and finish decide whether it is reported at all (below 1 it
//! reads 0; a glossy finish adds a narrow mirror lobe around a randomly tilted normal), and a
//! *value*, `albedo · (0.55 + 0.45 cos) / (1 + (r / r_v)²)` plus noise.
//! The gain is one draw per frame times one per beam (the 64 lasers' gains differ), so a
//! model trained on the simulator meets many sensor scales and none of them fixed.

use rand::Rng;
use rand_distr::{Distribution, LogNormal, Normal};
use serde::{Deserialize, Serialize};
use starnet_data::settings::{Checked, non_negative, positive, within};

/// How a surface sends the laser back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Finish {
    /// Diffuse: asphalt, walls, foliage, clothes, tyres.
    Matte,
    /// Clear-coated paint: a weak diffuse part and a narrow mirror lobe, so only panels facing
    /// the sensor return strongly.
    Gloss,
    /// Retro-reflective: number plates, signs, lamps; always reported, and bright.
    Retro,
    /// Foliage (crowns, hedges, bushes): porous, so a ray goes a random depth in before it
    /// returns, or passes through ([`IntensityModel::foliage_depth`]); diffuse otherwise.
    Foliage,
    /// Window glass: most rays pass through ([`IntensityModel::glass_transmission`]); those
    /// that return behave as gloss.
    Glass,
}

/// A surface: its reflectance seen head-on and its finish.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surface {
    /// Diffuse reflectance in [0, 1] seen head-on.
    pub albedo: f32,
    /// How it sends the laser back.
    pub finish: Finish,
}

impl Surface {
    /// A diffuse surface.
    pub const fn matte(albedo: f32) -> Self {
        Self {
            albedo,
            finish: Finish::Matte,
        }
    }

    /// Clear-coated paint.
    pub const fn gloss(albedo: f32) -> Self {
        Self {
            albedo,
            finish: Finish::Gloss,
        }
    }

    /// A retro-reflector.
    pub const fn retro(albedo: f32) -> Self {
        Self {
            albedo,
            finish: Finish::Retro,
        }
    }

    /// Foliage.
    pub const fn foliage(albedo: f32) -> Self {
        Self {
            albedo,
            finish: Finish::Foliage,
        }
    }

    /// Window glass.
    pub const fn glass(albedo: f32) -> Self {
        Self {
            albedo,
            finish: Finish::Glass,
        }
    }
}

/// The sensor's intensity channel. Defaults fitted to `../shared/kitti-real-dev`
/// (BENCHMARKS.md, "Realism").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IntensityModel {
    /// Strength factor K of a matte surface.
    pub matte_strength: f32,
    /// Strength factor K of the diffuse part of a glossy surface.
    pub gloss_strength: f32,
    /// Peak strength of the mirror lobe of a glossy surface (added as `cos^mirror_power`).
    pub mirror_strength: f32,
    /// Sharpness of the mirror lobe.
    pub mirror_power: f32,
    /// Standard deviation (radians) of the tilt of a glossy panel's normal at each return:
    /// car bodies curve, so a flat part of the model is not one mirror.
    pub gloss_tilt: f32,
    /// Share of rays that pass through window glass (and go on to what lies behind).
    pub glass_transmission: f32,
    /// Mean depth (m) a ray goes into foliage before it returns (exponential); deeper than
    /// the foliage, it passes through.
    pub foliage_depth: f32,
    /// Exponent q on the cosine of incidence in the strength.
    pub incidence_power: f32,
    /// Range r₀ (m) at which the inverse-square factor is 1.
    pub reference_range: f32,
    /// Range r_v (m) over which reported values darken: `1 / (1 + (r / r_v)²)`.
    pub value_falloff_range: f32,
    /// Standard deviation of the log of the frame's gain.
    pub frame_gain_sd: f32,
    /// Standard deviation of the log of each beam's gain (drawn per frame).
    pub beam_gain_sd: f32,
}

impl Default for IntensityModel {
    fn default() -> Self {
        Self {
            matte_strength: 80.0,
            gloss_strength: 4.0,
            mirror_strength: 12.0,
            mirror_power: 20.0,
            gloss_tilt: 0.35,
            glass_transmission: 0.7,
            foliage_depth: 0.6,
            incidence_power: 0.4,
            reference_range: 10.0,
            value_falloff_range: 60.0,
            frame_gain_sd: 0.15,
            beam_gain_sd: 0.3,
        }
    }
}

impl IntensityModel {
    /// Checks every factor and range is positive (keys relative to the intensity table).
    pub fn validate(&self) -> Checked {
        for (key, v) in [
            ("matte_strength", self.matte_strength),
            ("gloss_strength", self.gloss_strength),
            ("mirror_power", self.mirror_power),
            ("reference_range", self.reference_range),
            ("value_falloff_range", self.value_falloff_range),
            ("foliage_depth", self.foliage_depth),
        ] {
            positive(key, v as f64)?;
        }
        within("glass_transmission", self.glass_transmission as f64, 0.0, 1.0)?;
        for (key, v) in [
            ("mirror_strength", self.mirror_strength),
            ("gloss_tilt", self.gloss_tilt),
            ("incidence_power", self.incidence_power),
            ("frame_gain_sd", self.frame_gain_sd),
            ("beam_gain_sd", self.beam_gain_sd),
        ] {
            non_negative(key, v as f64)?;
        }
        Ok(())
    }

    /// One frame's gain per beam: the frame's draw times each beam's.
    pub fn draw_gains(&self, beams: usize, rng: &mut impl Rng) -> Vec<f32> {
        let frame = log_normal(self.frame_gain_sd, rng);
        (0..beams).map(|_| frame * log_normal(self.beam_gain_sd, rng)).collect()
    }

    /// The strength of a return from `surface` at range `r` (m) with cosine of incidence
    /// `cos`, under `gain`: below 1 the sensor reports 0.
    pub fn strength(&self, surface: Surface, cos: f32, r: f32, gain: f32) -> f32 {
        let cos = cos.clamp(0.0, 1.0);
        let diffuse = cos.powf(self.incidence_power);
        let k = match surface.finish {
            Finish::Matte | Finish::Foliage => self.matte_strength * surface.albedo * diffuse,
            Finish::Gloss | Finish::Glass => {
                self.gloss_strength * surface.albedo * diffuse + self.mirror_strength * cos.powf(self.mirror_power)
            }
            Finish::Retro => return f32::INFINITY,
        };
        let fall = (self.reference_range / r.max(1e-3)).powi(2);
        k * fall * gain
    }

    /// The value reported for a return that is strong enough, before noise and quantisation.
    pub fn value(&self, surface: Surface, cos: f32, r: f32) -> f32 {
        let cos = cos.clamp(0.0, 1.0);
        surface.albedo * (0.55 + 0.45 * cos) / (1.0 + (r / self.value_falloff_range).powi(2))
    }

    /// What the sensor writes: 0 for a weak return, else the value with uniform noise of
    /// ±0.04, clamped to [0, 0.99] and quantised to 0.01 like KITTI's.
    pub fn observe(&self, surface: Surface, cos: f32, r: f32, gain: f32, rng: &mut impl Rng) -> f32 {
        let noise = rng.random_range(-0.04..0.04);
        let cos = match surface.finish {
            Finish::Gloss | Finish::Glass => self.tilted(cos, rng),
            Finish::Matte | Finish::Foliage | Finish::Retro => cos,
        };
        if self.strength(surface, cos, r, gain) < 1.0 {
            return 0.0;
        }
        let v = self.value(surface, cos, r) + noise;
        (v.clamp(0.0, 0.99) * 100.0).round() / 100.0
    }

    /// The cosine of incidence once the panel's normal is tilted by N(0, gloss_tilt) in the
    /// plane of incidence: towards the sensor or away, never past grazing.
    fn tilted(&self, cos: f32, rng: &mut impl Rng) -> f32 {
        if self.gloss_tilt == 0.0 {
            return cos;
        }
        let tilt: f32 = Normal::new(0.0, self.gloss_tilt).expect("finite sd").sample(rng);
        let angle = (cos.clamp(0.0, 1.0).acos() + tilt)
            .abs()
            .min(std::f32::consts::FRAC_PI_2);
        // cos(π/2) is −4e-8 in f32.
        angle.cos().max(0.0)
    }

    /// How far into foliage a ray goes before it returns: Exp(mean `foliage_depth`).
    pub fn foliage_penetration(&self, rng: &mut impl Rng) -> f32 {
        -self.foliage_depth * (1.0 - rng.random::<f32>()).ln()
    }
}

fn log_normal(sd: f32, rng: &mut impl Rng) -> f32 {
    if sd == 0.0 {
        return 1.0;
    }
    // Median 1: the gains scale the strength around the fitted one.
    LogNormal::new(0.0, sd).expect("finite, non-negative sd").sample(rng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn strength_falls_with_the_square_of_range() {
        let m = IntensityModel::default();
        let s = Surface::matte(0.3);
        let (near, far) = (m.strength(s, 1.0, 10.0, 1.0), m.strength(s, 1.0, 40.0, 1.0));
        // Hand-computed: 80 · 0.3 · 1^0.4 · (10 / 10)² = 24, and a sixteenth of it at 40 m.
        assert!((near - 24.0).abs() < 1e-4, "{near}");
        assert!((near / far - 16.0).abs() < 1e-3);
    }

    #[test]
    fn grazing_and_glossy_returns_read_zero_sooner() {
        let m = IntensityModel::default();
        let asphalt = Surface::matte(0.28);
        // The road seen at 40 m from 1.73 m up: cos = 1.73 / 40.
        let road_far = m.strength(asphalt, 1.73 / 40.0, 40.0, 1.0);
        let wall_far = m.strength(asphalt, 0.8, 40.0, 1.0);
        assert!(road_far < 1.0 && wall_far > 1.0, "{road_far} {wall_far}");
        let paint = Surface::gloss(0.2);
        // A panel at 45° at 20 m is weak; the same panel facing the sensor returns.
        assert!(m.strength(paint, 0.707, 20.0, 1.0) < 1.0);
        assert!(m.strength(paint, 1.0, 20.0, 1.0) > 1.0);
        assert!(m.strength(Surface::retro(0.9), 0.1, 100.0, 0.1).is_infinite());
    }

    #[test]
    fn observed_values_are_zero_or_quantised_and_positive() {
        let m = IntensityModel::default();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut zeros = 0;
        for i in 0..2000 {
            let r = 5.0 + i as f32 * 0.05;
            let v = m.observe(Surface::matte(0.3), 0.05, r, 1.0, &mut rng);
            assert!((0.0..=0.99).contains(&v) && (v * 100.0 - (v * 100.0).round()).abs() < 1e-3);
            zeros += usize::from(v == 0.0);
        }
        // Strength 80 · 0.3 · 0.05^0.4 · (10 / r)² ≥ 1 up to r ≈ 26.91 m: 1561 of the 2000 ranges
        // (5 m + 0.05 m · i) lie beyond.
        assert!((1556..1566).contains(&zeros), "{zeros}");
    }

    #[test]
    fn validation_names_the_bad_key() {
        assert!(IntensityModel::default().validate().is_ok());
        let bad = IntensityModel {
            beam_gain_sd: -0.1,
            ..Default::default()
        };
        assert_eq!(bad.validate().unwrap_err().key, "beam_gain_sd");
        let bad = IntensityModel {
            glass_transmission: 1.5,
            ..Default::default()
        };
        assert_eq!(bad.validate().unwrap_err().key, "glass_transmission");
    }

    #[test]
    fn foliage_depth_is_exponential_with_the_set_mean() {
        let m = IntensityModel::default();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let d: Vec<f32> = (0..20_000).map(|_| m.foliage_penetration(&mut rng)).collect();
        let mean = d.iter().sum::<f32>() / d.len() as f32;
        assert!((mean - 0.6).abs() < 0.02, "{mean}");
        // P(depth > mean) = e^-1 for an exponential.
        let beyond = d.iter().filter(|x| **x > 0.6).count() as f32 / d.len() as f32;
        assert!((beyond - (-1.0f32).exp()).abs() < 0.015, "{beyond}");
        assert!(d.iter().all(|x| x.is_finite() && *x >= 0.0));
    }

    #[test]
    fn glossy_normals_tilt_both_ways_but_not_past_head_on_or_grazing() {
        let m = IntensityModel::default();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
        let head_on: Vec<f32> = (0..500).map(|_| m.tilted(1.0, &mut rng)).collect();
        assert!(head_on.iter().all(|t| (0.0..=1.0).contains(t)) && head_on.iter().any(|t| *t < 0.95));
        let oblique: Vec<f32> = (0..500).map(|_| m.tilted(0.7, &mut rng)).collect();
        assert!(oblique.iter().all(|t| (0.0..=1.0).contains(t)));
        let towards = oblique.iter().filter(|t| **t > 0.7).count();
        assert!(
            (150..350).contains(&towards),
            "{towards} of 500 turned towards the sensor"
        );
    }

    #[test]
    fn gains_have_median_one_and_zero_spread_gives_one() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let flat = IntensityModel {
            frame_gain_sd: 0.0,
            beam_gain_sd: 0.0,
            ..Default::default()
        };
        assert!(flat.draw_gains(64, &mut rng).iter().all(|g| *g == 1.0));
        let mut g = IntensityModel::default().draw_gains(4001, &mut rng);
        g.sort_by(f32::total_cmp);
        assert!(g[2000] > 0.7 && g[2000] < 1.4, "{}", g[2000]);
    }
}
