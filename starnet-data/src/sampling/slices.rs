//! Streaming input (the streaming-detection paper, §3.1–3.2): a sweep cut into `n` azimuth
//! slices of 360°/n, non-overlapping, in the order the laser sweeps them. Each slice is
//! prepared from what the sensor has delivered when it completes ([`SweepSlicer`]): its
//! neighbourhoods never read a point of a later slice, and what else they may read, and where
//! the centers go, is the [`SliceContext`].
//!
//! Azimuth is `atan2(y, x)` in the LiDAR frame (0° = +x, forward; 90° = +y, left). A slice is
//! the azimuth interval `[start + s·w, start + (s+1)·w)` (w = 360°/n), measured in the rotation
//! sense.

use super::arrival::distance_to_undelivered;
use super::centers::{continue_centers, padded, spaced_centers};
use super::{
    Augmentation, Centers, PipelineConfig, PreparedFrame, Sampler, center_pool, gather, level_centers, sample_centers,
};
use crate::augment::{augment, ring_dropout};
use crate::geometry::GroundModel;
use crate::kitti::{Frame, ObjectClass};
use crate::seed::sub_seed;
use crate::settings::{Checked, positive, within};
use crate::{Box3d, Point};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// How a sweep is cut, what a slice may see and how its centers are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SliceConfig {
    /// Azimuth at which a sweep starts, degrees (180: directly behind the vehicle, where a
    /// Waymo-style spin begins and ends).
    pub start_azimuth_deg: f32,
    /// The laser turns clockwise seen from above (azimuth decreasing); false: counter-clockwise.
    pub clockwise: bool,
    /// What a slice's neighbourhoods read, and where its centers may go.
    pub context: SliceContext,
    /// Whether FPS in a slice starts afresh or continues from the earlier slices' centers, and
    /// how many centers a slice takes.
    pub centers: SliceCenters,
    /// [`SliceCenters::Spaced`]: FPS stops before a center closer than this to another, m
    /// (about where one FPS of the quickstart's 512 centers over a simulated sweep's pool ends:
    /// 0.53–0.73 m).
    pub spacing: f32,
    /// [`SliceCenters::Spaced`]: a step's most centers, as a multiple of the even share
    /// `ceil(K / n)`: the peak compute per slice against the sweep's.
    pub peak: f32,
}

/// What a slice's neighbourhoods may read and where its centers may go. Never a point of a
/// slice still to come.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SliceContext {
    /// The paper's localized receptive field: centers and neighbourhoods from the slice's own
    /// points, so a neighbourhood near either edge is cut.
    Own,
    /// Centers in the slice; neighbourhoods also read the previous slice's points (the edge
    /// behind is whole where a slice is wider than the gather radius, the edge ahead is cut).
    Previous,
    /// Centers wait until their neighbourhood has arrived: a slice places its centers on the
    /// points that lie at least the gather radius from every azimuth still to come and did not
    /// before, and gathers from every delivered point within reach of them (kept in memory
    /// while within twice the radius of what is to come). No neighbourhood is cut; a center
    /// lags the laser by at most the radius; the last slice takes what borders the seam.
    Arrived,
}

/// How a slice draws its centers (with [`super::Sampler::Fps`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SliceCenters {
    /// FPS from a random first point, as if the slice were alone: the first picks are its
    /// corners, so adjacent slices crowd their shared edge.
    Fresh,
    /// FPS continues from the centers the earlier slices placed (those still within four gather
    /// radii of what is to come), as one FPS over the sweep drawn in arrival order would.
    Continued,
    /// FPS continued as [`Self::Continued`], each slice taking as many centers as its new points
    /// need, until the next would lie within `spacing` of another, at most `peak` times the even
    /// share. What the last slice still needs then runs in further steps of at most as many
    /// centers over the last slice's view, once the sweep is complete: with
    /// [`SliceContext::Arrived`] a slice's new points vary from a few percent of the even share
    /// (the first slice, whose points wait for the next) to several times it (the last, which
    /// takes the band along the seam). At n = 1 the sweep is one step of K centers, as
    /// [`Self::Continued`].
    Spaced,
}

impl Default for SliceConfig {
    fn default() -> Self {
        Self {
            start_azimuth_deg: 180.0,
            clockwise: false,
            context: SliceContext::Own,
            centers: SliceCenters::Fresh,
            spacing: 0.6,
            peak: 1.25,
        }
    }
}

impl SliceConfig {
    /// Checks that the start azimuth lies within one turn either way, degrees (keys relative to
    /// the slicing table).
    pub fn validate(&self) -> Checked {
        within("start_azimuth_deg", self.start_azimuth_deg as f64, -360.0, 360.0)?;
        positive("spacing", self.spacing as f64)?;
        within("peak", self.peak as f64, 1.0, 1e6)
    }

    /// How far BEV position `(x, y)` lies from every azimuth still to come once slice `s` of
    /// `n` has been delivered ([`distance_to_undelivered`]; infinite after the last slice).
    pub fn distance_to_undelivered(&self, x: f32, y: f32, s: usize, n: usize) -> f32 {
        distance_to_undelivered(self.along_deg(x, y), x.hypot(y), delivered_after(s, n))
    }

    /// How far behind what is to come a center waits: the gather radius `radius` with
    /// [`SliceContext::Arrived`], else nothing.
    pub fn lag(&self, radius: f32) -> f32 {
        match self.context {
            SliceContext::Arrived => radius,
            SliceContext::Own | SliceContext::Previous => 0.0,
        }
    }

    /// A step's most centers when a sweep's `k` are spread over `n` slices: the even share,
    /// times `peak` for [`SliceCenters::Spaced`] (n > 1).
    pub fn step_capacity(&self, k: usize, n: usize) -> usize {
        let even = centers_per_slice(k, n);
        match self.centers {
            SliceCenters::Spaced if n > 1 => (even as f32 * self.peak).ceil() as usize,
            _ => even,
        }
    }

    /// The slice (of `n`) that holds BEV position `(x, y)`.
    pub fn slice_of(&self, x: f32, y: f32, n: usize) -> usize {
        let s = (self.along_deg(x, y) / (360.0 / n as f32)) as usize;
        s.min(n - 1)
    }

    /// The azimuth of BEV position `(x, y)` in degrees from the sweep's start, in the rotation
    /// sense, in `[0, 360)`: when the laser reaches it.
    pub fn along_deg(&self, x: f32, y: f32) -> f32 {
        let az = y.atan2(x).to_degrees();
        let along = if self.clockwise {
            self.start_azimuth_deg - az
        } else {
            az - self.start_azimuth_deg
        };
        // rem_euclid rounds a tiny negative angle up to 360 itself: just before the start is
        // the end of the turn.
        along.rem_euclid(360.0).min(360f32.next_down())
    }

    /// The inverse of [`SliceConfig::slice_of`]: slice `s`'s azimuth interval `[first, last)`,
    /// degrees in `(-180, 180]`, listed in the rotation sense (so for a clockwise laser `first`
    /// is the larger angle, modulo 360°).
    pub fn slice_bounds(&self, s: usize, n: usize) -> (f32, f32) {
        let w = 360.0 / n as f32;
        let sign = if self.clockwise { -1.0 } else { 1.0 };
        let at = |k: f32| wrap_deg(self.start_azimuth_deg + sign * k * w);
        (at(s as f32), at(s as f32 + 1.0))
    }
}

/// Degrees of the turn delivered once slice `s` of `n` has been (exactly 360 after the last).
fn delivered_after(s: usize, n: usize) -> f32 {
    if s + 1 >= n {
        360.0
    } else {
        (s + 1) as f32 * 360.0 / n as f32
    }
}

/// An angle in degrees, wrapped to `(-180, 180]`.
fn wrap_deg(a: f32) -> f32 {
    let w = a.rem_euclid(360.0);
    if w > 180.0 { w - 360.0 } else { w }
}

/// The points of each of `n` slices, in sweep order (each point in exactly one slice, in its
/// original order within the slice): what the sensor delivers, slice after slice.
pub fn slice_points(points: &[Point], n: usize, cfg: &SliceConfig) -> Vec<Vec<Point>> {
    let mut slices = vec![Vec::new(); n];
    for p in points {
        slices[cfg.slice_of(p[0], p[1], n)].push(*p);
    }
    slices
}

/// Centers per slice when a sweep's budget is `total` centers over `n` slices.
pub fn centers_per_slice(total: usize, n: usize) -> usize {
    total.div_ceil(n).max(1)
}

/// A sweep delivered slice by slice: each call to [`SweepSlicer::next_slice`] prepares the
/// next slice from what the sensor has delivered by then, as its [`SliceConfig`] allows,
/// keeping between slices only what a later slice may still read (the [`SliceContext::Arrived`]
/// band of points near what is to come, the centers FPS continues from).
#[derive(Debug, Clone)]
pub struct SweepSlicer<'a> {
    slices: Vec<Vec<Point>>,
    slicing: &'a SliceConfig,
    pipeline: &'a PipelineConfig,
    next: usize,
    /// Delivered points that a later slice may still read.
    pending: Vec<Pending>,
    /// Centers placed so far that FPS continues from.
    placed: Vec<[f32; 3]>,
    /// What the spaced last slice still needs ([`SliceCenters::Spaced`]).
    tail: Option<Tail>,
}

/// The steps after the last slice: its cloud, and the centers of each step.
#[derive(Debug, Clone)]
struct Tail {
    points: Vec<Point>,
    steps: VecDeque<Centers>,
}

/// A delivered point kept for later slices, with its azimuth from the sweep's start and its
/// range (bird's-eye view), computed once.
#[derive(Debug, Clone, Copy)]
struct Pending {
    point: Point,
    along: f32,
    range: f32,
}

/// What one slice reads: `points`, and which of them may hold a center.
struct SliceView {
    points: Vec<Point>,
    ready: Vec<bool>,
}

impl<'a> SweepSlicer<'a> {
    /// `points` cut into `n` slices (the sensor's work), none prepared yet.
    pub fn new(points: &[Point], n: usize, slicing: &'a SliceConfig, pipeline: &'a PipelineConfig) -> Self {
        Self {
            slices: slice_points(points, n, slicing),
            slicing,
            pipeline,
            next: 0,
            pending: Vec::new(),
            placed: Vec::new(),
            tail: None,
        }
    }

    /// Slices n.
    pub fn len(&self) -> usize {
        self.slices.len()
    }

    /// Whether the sweep has no slice (never: n ≥ 1).
    pub fn is_empty(&self) -> bool {
        self.slices.is_empty()
    }

    /// The next step, prepared from what has been delivered with it: centers from the pool
    /// (range and z filters; no camera frustum) among the points the context lets hold a center,
    /// as many as [`SliceConfig::step_capacity`] of the sweep's `sweep_centers` (slots a
    /// [`SliceCenters::Spaced`] step leaves unused are invalid repeats), neighbourhoods gathered
    /// from what the context lets read. `boxes`/`classes` are the sweep's labels, for target
    /// assignment. The frame's `points` are exactly the points its neighbourhoods read from.
    /// After the n slices come the spaced last slice's further steps, if any; then `None`.
    pub fn next_slice(
        &mut self,
        id: &str,
        labels: (&[Box3d], &[ObjectClass]),
        sweep_centers: usize,
        rng: &mut impl Rng,
    ) -> Option<PreparedFrame> {
        let capacity = self.slicing.step_capacity(sweep_centers, self.len());
        let (points, centers) = match self.next {
            s if s < self.len() => self.slice_centers(s, capacity, rng),
            _ => self.tail_centers()?,
        };
        self.next += 1;
        let neighbourhoods = gather(&points, &centers, &self.pipeline.gather, rng);
        Some(PreparedFrame {
            id: id.to_string(),
            points,
            centers,
            neighbourhoods,
            boxes: labels.0.to_vec(),
            classes: labels.1.to_vec(),
            draw: None,
        })
    }

    /// Whether every step has been prepared (the n slices and any further steps).
    pub fn is_finished(&self) -> bool {
        self.next >= self.len() && self.tail.as_ref().is_none_or(|t| t.steps.is_empty())
    }

    /// Slice `s`'s cloud and its `capacity` centers (levelled on the ground of what it reads).
    fn slice_centers(&mut self, s: usize, capacity: usize, rng: &mut impl Rng) -> (Vec<Point>, Centers) {
        let view = self.view(s);
        let cfg = self.pipeline;
        // The ground from what has been delivered, never from slices still to come.
        let ground = cfg.fit_ground(&view.points);
        let pool: Vec<usize> = center_pool(&view.points, &cfg.pool, None, ground.as_ref())
            .into_iter()
            .filter(|&i| view.ready[i])
            .collect();
        let (points, z) = (&view.points, cfg.center_z);
        let mut centers = match self.slicing.centers {
            SliceCenters::Fresh => sample_centers(points, &pool, capacity, cfg.sampler, &[], z, rng),
            SliceCenters::Spaced if self.len() > 1 && cfg.sampler == Sampler::Fps => {
                let last = s + 1 == self.len();
                let most = if last { pool.len() } else { capacity };
                let mut xyz = spaced_centers(points, &pool, most, &self.placed, self.slicing.spacing, z, rng);
                let rest = xyz.split_off(xyz.len().min(capacity));
                if last {
                    self.queue_tail(rest, &view.points, ground.as_ref(), capacity);
                }
                padded(xyz, capacity, 0)
            }
            _ => continue_centers(points, &pool, capacity, cfg.sampler, &self.placed, z, rng),
        };
        self.remember(&centers, s);
        if let Some(ground) = &ground {
            level_centers(&mut centers, cfg.center_z, ground);
        }
        (view.points, centers)
    }

    /// Keeps what the last slice still needs, in steps of at most `capacity` centers (levelled
    /// now: the ground is the last slice's).
    fn queue_tail(&mut self, rest: Vec<[f32; 3]>, points: &[Point], ground: Option<&GroundModel>, capacity: usize) {
        let steps = rest
            .chunks(capacity)
            .map(|chunk| {
                let mut centers = padded(chunk.to_vec(), capacity, 0);
                if let Some(ground) = ground {
                    level_centers(&mut centers, self.pipeline.center_z, ground);
                }
                centers
            })
            .collect();
        self.tail = Some(Tail {
            points: points.to_vec(),
            steps,
        });
    }

    /// The next of the last slice's further steps, if any.
    fn tail_centers(&mut self) -> Option<(Vec<Point>, Centers)> {
        let tail = self.tail.as_mut()?;
        let centers = tail.steps.pop_front()?;
        Some((tail.points.clone(), centers))
    }

    /// What slice `s` reads and where its centers may go.
    fn view(&mut self, s: usize) -> SliceView {
        let current = &self.slices[s];
        let everywhere = |points: Vec<Point>| SliceView {
            ready: vec![true; points.len()],
            points,
        };
        match self.slicing.context {
            SliceContext::Own => everywhere(current.clone()),
            SliceContext::Previous if s == 0 => everywhere(current.clone()),
            SliceContext::Previous => {
                let previous = &self.slices[s - 1];
                let mut ready = vec![false; previous.len()];
                ready.resize(previous.len() + current.len(), true);
                let points = previous.iter().chain(current).copied().collect();
                SliceView { points, ready }
            }
            SliceContext::Arrived => self.arrived_view(s),
        }
    }

    /// [`SliceContext::Arrived`]: the delivered points within twice the gather radius R of
    /// what was to come before slice `s` (every neighbour of a center that becomes whole now
    /// lies there), ready where they lie within R of it then and at least R from what is still
    /// to come. Points no later slice can read (2 R or more from what is to come) are dropped.
    fn arrived_view(&mut self, s: usize) -> SliceView {
        let reach = self.pipeline.gather.radius;
        let before = s as f32 * 360.0 / self.len() as f32;
        let after = delivered_after(s, self.len());
        let slicing = self.slicing;
        let arrived = self.slices[s].iter().map(|p| Pending {
            point: *p,
            along: slicing.along_deg(p[0], p[1]),
            range: p[0].hypot(p[1]),
        });
        self.pending.extend(arrived);
        let mut view = SliceView {
            points: Vec::new(),
            ready: Vec::new(),
        };
        let mut kept = Vec::with_capacity(self.pending.len());
        for q in self.pending.drain(..) {
            let was = distance_to_undelivered(q.along, q.range, before);
            let now = distance_to_undelivered(q.along, q.range, after);
            if was < 2.0 * reach {
                view.points.push(q.point);
                view.ready.push(was < reach && now >= reach);
            }
            if now < 2.0 * reach {
                kept.push(q);
            }
        }
        self.pending = kept;
        view
    }

    /// Keeps the valid centers of slice `s` for FPS to continue from, and forgets those four
    /// gather radii or more from what is still to come.
    fn remember(&mut self, centers: &Centers, s: usize) {
        if self.slicing.centers == SliceCenters::Fresh {
            return;
        }
        let valid = centers.xyz.iter().zip(&centers.valid).filter(|(_, v)| **v);
        self.placed.extend(valid.map(|(c, _)| *c));
        let after = delivered_after(s, self.len());
        let far = 4.0 * self.pipeline.gather.radius;
        let slicing = self.slicing;
        self.placed
            .retain(|c| distance_to_undelivered(slicing.along_deg(c[0], c[1]), c[0].hypot(c[1]), after) < far);
    }
}

/// The RNG of slice `s` of a sweep whose randomness derives from `seed`: a slice's draws do
/// not depend on any other slice's points.
pub fn slice_rng(seed: u64, s: usize) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(sub_seed(seed, 41, s as u64))
}

/// A whole sweep as `n` prepared slices (training and offline use): augments the sweep when
/// `augmentation` is given (then drops a ring), cuts it, and prepares every slice with a
/// [`SweepSlicer`] (n frames, and a spaced last slice's further steps).
pub fn prepare_sweep(
    frame: &Frame,
    cfg: &PipelineConfig,
    slicing: &SliceConfig,
    n: usize,
    augmentation: Option<Augmentation<'_>>,
    rng: &mut impl Rng,
) -> Vec<PreparedFrame> {
    let (boxes, classes): (Vec<Box3d>, Vec<ObjectClass>) =
        frame.labelled_boxes().into_iter().map(|(o, b)| (b, o.class)).unzip();
    let mut scene = crate::augment::Scene {
        points: frame.points.clone(),
        boxes,
        classes,
    };
    if let Some(a) = augmentation {
        augment(&mut scene, a.config, a.database, rng);
        if a.config.ring_dropout {
            scene.points = ring_dropout(&scene.points, a.config.ring_dropout_width, rng).0;
        }
    }
    let seed: u64 = rng.random();
    let mut slicer = SweepSlicer::new(&scene.points, n, slicing, cfg);
    (0..)
        .map_while(|s| {
            slicer.next_slice(
                &frame.id,
                (&scene.boxes, &scene.classes),
                cfg.num_centers,
                &mut slice_rng(seed, s),
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(n: usize) -> Vec<Point> {
        (0..n)
            .map(|i| {
                let a = (i as f32 + 0.5) / n as f32 * std::f32::consts::TAU;
                let r = 5.0 + (i % 7) as f32;
                [r * a.cos(), r * a.sin(), -0.5, 0.3]
            })
            .collect()
    }

    #[test]
    fn slices_follow_the_rotation_from_the_start_azimuth() {
        let ccw = SliceConfig::default();
        // Starting behind (180°), counter-clockwise: -170° (behind, right) comes first, +170° last.
        let at = |deg: f32, c: &SliceConfig, n| c.slice_of(deg.to_radians().cos(), deg.to_radians().sin(), n);
        assert_eq!(at(-170.0, &ccw, 4), 0);
        assert_eq!(at(-80.0, &ccw, 4), 1);
        assert_eq!(at(10.0, &ccw, 4), 2);
        assert_eq!(at(100.0, &ccw, 4), 3);
        assert_eq!(at(170.0, &ccw, 4), 3);
        let cw = SliceConfig { clockwise: true, ..ccw };
        assert_eq!(at(170.0, &cw, 4), 0);
        assert_eq!(at(-170.0, &cw, 4), 3);
        assert_eq!(at(45.0, &ccw, 1), 0);
    }

    #[test]
    fn bounds_invert_slice_of() {
        for clockwise in [false, true] {
            let cfg = SliceConfig {
                start_azimuth_deg: 37.0,
                clockwise,
                ..SliceConfig::default()
            };
            for n in [1, 2, 3, 8, 32] {
                for s in 0..n {
                    let (first, _) = cfg.slice_bounds(s, n);
                    // Just inside the slice, in the rotation sense, from its first edge.
                    let step = if clockwise { -1e-2 } else { 1e-2 } * 360.0 / n as f32;
                    let a = (first + step).to_radians();
                    assert_eq!(cfg.slice_of(a.cos(), a.sin(), n), s, "n {n} s {s} cw {clockwise}");
                }
                let (_, last) = cfg.slice_bounds(n - 1, n);
                assert!(
                    (wrap_deg(last - 37.0)).abs() < 1e-3,
                    "the last slice ends where the sweep began"
                );
            }
        }
    }

    #[test]
    fn every_point_lands_in_one_slice_in_order() {
        let pts = ring(1000);
        let slices = slice_points(&pts, 8, &SliceConfig::default());
        assert_eq!(slices.iter().map(Vec::len).sum::<usize>(), 1000);
        let cfg = SliceConfig::default();
        for (s, slice) in slices.iter().enumerate() {
            assert!(slice.iter().all(|p| cfg.slice_of(p[0], p[1], 8) == s));
            assert!(!slice.is_empty());
        }
    }

    /// Every context with both center rules.
    fn every_slicing() -> Vec<SliceConfig> {
        let contexts = [SliceContext::Own, SliceContext::Previous, SliceContext::Arrived];
        let rules = [SliceCenters::Fresh, SliceCenters::Continued];
        let at = |(context, centers)| SliceConfig {
            context,
            centers,
            ..SliceConfig::default()
        };
        contexts.into_iter().flat_map(|c| rules.map(|r| at((c, r)))).collect()
    }

    /// The slices a slice may read: itself, the one before, or every one delivered.
    fn readable(context: SliceContext, s: usize) -> std::ops::RangeInclusive<usize> {
        match context {
            SliceContext::Own => s..=s,
            SliceContext::Previous => s.saturating_sub(1)..=s,
            SliceContext::Arrived => 0..=s,
        }
    }

    #[test]
    fn a_slice_reads_no_later_point() {
        let mut frame = Frame {
            id: "000000".into(),
            points: ring(4000),
            objects: Vec::new(),
            calib: crate::kitti::Calib::kitti_000000(),
            image_size: crate::kitti::ImageSize::KITTI,
        };
        let cfg = PipelineConfig {
            pool: crate::sampling::CenterPoolConfig::all_around(50.0),
            num_centers: 64,
            ..PipelineConfig::default()
        };
        for slicing in every_slicing() {
            let n = 8;
            let slices = prepare_sweep(&frame, &cfg, &slicing, n, None, &mut ChaCha8Rng::seed_from_u64(3));
            assert_eq!(slices.len(), n);
            for (s, slice) in slices.iter().enumerate() {
                assert_eq!(slice.centers.len(), 8);
                // The cloud a slice gathers from holds only the slices its context allows, and
                // every gathered index points into it.
                let allowed = readable(slicing.context, s);
                assert!(
                    slice
                        .points
                        .iter()
                        .all(|p| allowed.contains(&slicing.slice_of(p[0], p[1], n)))
                );
                assert!(
                    slice
                        .neighbourhoods
                        .indices
                        .iter()
                        .flatten()
                        .all(|&i| (i as usize) < slice.points.len())
                );
                let placed = |c: &[f32; 3]| slicing.slice_of(c[0], c[1], n);
                match slicing.context {
                    SliceContext::Arrived => assert!(slice.centers.xyz.iter().all(|c| placed(c) <= s)),
                    _ => assert!(slice.centers.xyz.iter().all(|c| placed(c) == s)),
                }
            }
            // Moving every point of the last four slices changes nothing in the first four.
            let later = |p: &Point| slicing.slice_of(p[0], p[1], n) >= 4;
            let original = frame.points.clone();
            for p in frame.points.iter_mut().filter(|p| later(p)) {
                p[2] += 0.7;
                p[3] = 0.9;
            }
            let moved = prepare_sweep(&frame, &cfg, &slicing, n, None, &mut ChaCha8Rng::seed_from_u64(3));
            assert_eq!(&moved[..4], &slices[..4], "{slicing:?}");
            assert_ne!(&moved[4..], &slices[4..], "{slicing:?}");
            frame.points = original;
        }
    }

    /// A sweep of points all around at 1–45 m, irregular in range and azimuth.
    fn scatter(n: usize, seed: u64) -> Vec<Point> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let (a, r) = (
                    rng.random_range(0.0..std::f32::consts::TAU),
                    rng.random_range(1.0f32..45.0),
                );
                [r * a.cos(), r * a.sin(), rng.random_range(-1.5..0.5), 0.3]
            })
            .collect()
    }

    #[test]
    fn arrived_centers_see_whole_neighbourhoods_and_every_point_is_ready_once() {
        let points = scatter(6000, 11);
        let cfg = PipelineConfig::default();
        let r = cfg.gather.radius;
        for n in [1, 3, 8, 32] {
            let slicing = SliceConfig {
                context: SliceContext::Arrived,
                start_azimuth_deg: 37.0,
                ..SliceConfig::default()
            };
            let mut slicer = SweepSlicer::new(&points, n, &slicing, &cfg);
            let mut ready = Vec::new();
            for s in 0..n {
                let view = slicer.view(s);
                for (p, _) in view.points.iter().zip(&view.ready).filter(|(_, r)| **r) {
                    ready.push(*p);
                    // Oracle: every point of the sweep within R (bird's-eye view) of a ready
                    // point is in the view, and was delivered by slice s.
                    for q in points.iter().filter(|q| (q[0] - p[0]).hypot(q[1] - p[1]) < r) {
                        assert!(view.points.contains(q), "n {n} s {s}: a neighbour of {p:?} is missing");
                        assert!(slicing.slice_of(q[0], q[1], n) <= s);
                    }
                }
            }
            let key = |p: &Point| p.map(f32::to_bits);
            let mut got: Vec<_> = ready.iter().map(key).collect();
            let mut all: Vec<_> = points.iter().map(key).collect();
            got.sort_unstable();
            all.sort_unstable();
            assert_eq!(got, all, "n {n}: every point ready exactly once");
            // What stays in memory is the band near what is to come, not the sweep.
            assert!(slicer.pending.is_empty(), "n {n}: nothing is kept after the last slice");
        }
    }

    #[test]
    fn continued_centers_do_not_crowd_the_slice_edges() {
        let points = scatter(20000, 5);
        let cfg = PipelineConfig {
            pool: crate::sampling::CenterPoolConfig::all_around(50.0),
            ..PipelineConfig::default()
        };
        // The closest pair of centers over the whole sweep, at 16 centers per slice of 32.
        let closest = |centers: SliceCenters| {
            let slicing = SliceConfig {
                centers,
                ..SliceConfig::default()
            };
            let mut slicer = SweepSlicer::new(&points, 32, &slicing, &cfg);
            let mut all: Vec<[f32; 3]> = Vec::new();
            let mut rng = ChaCha8Rng::seed_from_u64(1);
            while let Some(f) = slicer.next_slice("", (&[], &[]), 512, &mut rng) {
                all.extend(f.centers.xyz);
            }
            let mut best = f32::INFINITY;
            for (i, a) in all.iter().enumerate() {
                for b in &all[i + 1..] {
                    best = best.min((a[0] - b[0]).hypot(a[1] - b[1]));
                }
            }
            best
        };
        let (fresh, continued) = (closest(SliceCenters::Fresh), closest(SliceCenters::Continued));
        assert!(
            continued > 2.0 * fresh,
            "closest pair: continued {continued} m, fresh {fresh} m"
        );
    }

    #[test]
    fn spaced_steps_cover_every_pool_point_within_the_spacing_and_keep_the_peak() {
        let points = scatter(8000, 2);
        let cfg = PipelineConfig {
            pool: crate::sampling::CenterPoolConfig::all_around(50.0),
            ..PipelineConfig::default()
        };
        for peak in [1.25, 50.0] {
            let slicing = SliceConfig {
                context: SliceContext::Arrived,
                centers: SliceCenters::Spaced,
                spacing: 2.0,
                peak,
                ..SliceConfig::default()
            };
            let (n, k) = (16, 256);
            let capacity = slicing.step_capacity(k, n);
            assert_eq!(capacity, (16.0 * peak).ceil() as usize);
            let mut slicer = SweepSlicer::new(&points, n, &slicing, &cfg);
            let mut rng = ChaCha8Rng::seed_from_u64(4);
            let mut centers = Vec::new();
            let mut steps = 0;
            while let Some(f) = slicer.next_slice("", (&[], &[]), k, &mut rng) {
                assert_eq!(f.centers.len(), capacity, "every step has the same shape: the peak");
                centers.extend(
                    f.centers
                        .xyz
                        .iter()
                        .zip(&f.centers.valid)
                        .filter(|(_, v)| **v)
                        .map(|(c, _)| *c),
                );
                steps += 1;
            }
            assert!(slicer.is_finished());
            assert!(steps >= n);
            // Spaced: no two centers closer than the spacing.
            for (i, a) in centers.iter().enumerate() {
                assert!(centers[i + 1..].iter().all(|b| (a[0] - b[0]).hypot(a[1] - b[1]) >= 2.0));
            }
            if peak > 10.0 {
                // Never short of capacity: every pool point ends within the spacing of a center.
                let pool = center_pool(&points, &cfg.pool, None, None);
                let covered = |p: &Point| centers.iter().any(|c| (c[0] - p[0]).hypot(c[1] - p[1]) < 2.0);
                assert!(pool.iter().all(|&i| covered(&points[i])));
                assert_eq!(steps, n, "the last slice fits in one step");
            } else {
                assert!(steps > n, "the last slice's band needs further steps at 1.25");
            }
        }
    }
}
