//! Prepared frames and their anchor targets → the tensors of a batch, and back from the
//! model's outputs to detections per frame.

use crate::assign::{AnchorTargets, AssignConfig, NeighbourRule, assign_targets, ignore_neighbours};
use crate::coder::{decode, with_direction};
use crate::loss::LossTargets;
use crate::nms::{Detection, NmsConfig, nms};
use crate::nn::{ModelInput, ModelOutput};
use burn::prelude::*;
use burn::tensor::TensorData;
use starnet_data::Box3d;
use starnet_data::kitti::ObjectClass;
use starnet_data::sampling::{AnchorGrid, CenterViews, NUM_FEATURES, PreparedFrame, view_features};

/// A batch ready for the model and the loss.
#[derive(Debug, Clone)]
pub struct StarNetBatch {
    /// Model inputs.
    pub input: ModelInput,
    /// Loss targets.
    pub targets: LossTargets,
}

/// The anchors of a frame's centers, center-major (`[C · A]`).
pub fn frame_anchors(frame: &PreparedFrame, grid: &AnchorGrid) -> Vec<Box3d> {
    frame.centers.xyz.iter().flat_map(|c| grid.anchors_around(*c)).collect()
}

/// Assigns a frame's targets for the model's `classes`. Objects of other classes are dropped,
/// so they count as background, as in lingvo; under [`NeighbourRule::Ignored`] the anchors on a
/// target class's neighbour (a Van for Car) are left out of the classification loss instead.
pub fn frame_targets(
    frame: &PreparedFrame,
    grid: &AnchorGrid,
    classes: &[ObjectClass],
    cfg: &AssignConfig,
) -> AnchorTargets {
    let (boxes, ids): (Vec<Box3d>, Vec<usize>) = frame
        .boxes
        .iter()
        .zip(&frame.classes)
        .filter_map(|(b, c)| classes.iter().position(|k| k == c).map(|k| (*b, k)))
        .unzip();
    let anchors = frame_anchors(frame, grid);
    let mut targets = assign_targets(&anchors, grid.len(), &frame.centers.valid, &boxes, &ids, cfg);
    if cfg.neighbours == NeighbourRule::Ignored {
        let neighbours: Vec<Box3d> = frame
            .boxes
            .iter()
            .zip(&frame.classes)
            .filter(|(_, c)| !classes.contains(c) && classes.iter().any(|k| k.neighbour() == Some(**c)))
            .map(|(b, _)| *b)
            .collect();
        ignore_neighbours(&mut targets, &anchors, grid.len(), &neighbours, cfg);
    }
    targets
}

/// A tensor of `shape` that takes `values` over (no copy).
fn tensor<const D: usize>(values: Vec<f32>, shape: [usize; D], device: &Device) -> Tensor<D> {
    Tensor::from_data(TensorData::new(values, shape), device)
}

/// Every item's `part`, mapped by `f` and laid end to end, in one allocation of the final size.
fn stacked<T, U: Copy>(items: &[&T], part: impl Fn(&T) -> &[U], f: impl Fn(U) -> f32) -> Vec<f32> {
    let mut out = Vec::with_capacity(items.iter().map(|i| part(i).len()).sum());
    for i in items {
        out.extend(part(i).iter().map(|&u| f(u)));
    }
    out
}

/// Stacks frames (all with the same C and P) into model inputs on `device`.
pub fn make_input(frames: &[&PreparedFrame], device: &Device) -> ModelInput {
    make_viewed_input(frames, CenterViews::AsSeen, device)
}

/// [`make_input`] with each frame's centers seen as `views` says (a mirrored center's
/// offsets mirrored; [`view_features`]). Decode its output with [`decode_viewed_detections`].
pub fn make_viewed_input(frames: &[&PreparedFrame], views: CenterViews, device: &Device) -> ModelInput {
    let b = frames.len();
    let (c, p) = (
        frames[0].neighbourhoods.num_centers,
        frames[0].neighbourhoods.num_points,
    );
    let flag = |v: bool| v as u8 as f32;
    let mut points = stacked(frames, |f| &f.neighbourhoods.features, |v| v);
    for frame in points.chunks_exact_mut(c * p * NUM_FEATURES) {
        view_features(frame, p, views);
    }
    ModelInput {
        points: tensor(points, [b, c, p, NUM_FEATURES], device),
        mask: tensor(stacked(frames, |f| &f.neighbourhoods.mask, flag), [b, c, p], device),
        center_valid: tensor(stacked(frames, |f| &f.centers.valid, flag), [b, c], device),
    }
}

/// Stacks frames (all with the same C and P) and their targets into a batch on `device`.
pub fn make_batch(
    frames: &[&PreparedFrame],
    targets: &[&AnchorTargets],
    num_classes: usize,
    device: &Device,
) -> StarNetBatch {
    let b = frames.len();
    let c = frames[0].neighbourhoods.num_centers;
    let a = targets[0].class.len() / c;
    let mut one_hot = vec![0.0; b * c * a * num_classes];
    let classes = targets.iter().flat_map(|t| &t.class);
    for (row, &k) in one_hot.chunks_mut(num_classes.max(1)).zip(classes) {
        if let Some(hot) = k.and_then(|k| row.get_mut(k)) {
            *hot = 1.0;
        }
    }
    let residuals = stacked(targets, |t| t.residuals.as_flattened(), |v| v);
    let per_anchor = |v: Vec<f32>| tensor(v, [b, c, a], device);
    StarNetBatch {
        input: make_input(frames, device),
        targets: LossTargets {
            classes: tensor(one_hot, [b, c, a, num_classes], device),
            cls_weight: per_anchor(stacked(targets, |t| &t.cls_weight, |v| v)),
            residuals: tensor(residuals, [b, c, a, 7], device),
            reg_weight: per_anchor(stacked(targets, |t| &t.reg_weight, |v| v)),
            direction: per_anchor(stacked(targets, |t| &t.direction, f32::from)),
        },
    }
}

/// Detections of frame `i` of a batch: scores through a sigmoid, boxes decoded around the frame's
/// anchors, invalid centers dropped, then per-class NMS.
pub fn decode_frame(
    out: &ModelOutput,
    i: usize,
    frame: &PreparedFrame,
    grid: &AnchorGrid,
    cfg: &NmsConfig,
) -> Vec<Detection> {
    nms(&decode_detections(out, i, frame, grid, cfg), cfg)
}

/// [`decode_frame`] before NMS: every anchor of a valid center whose class score reaches the
/// class's score threshold, in anchor order (for NMS across frames or slices). With direction
/// logits, each heading is turned into the half-turn of its more likely bin.
pub fn decode_detections(
    out: &ModelOutput,
    i: usize,
    frame: &PreparedFrame,
    grid: &AnchorGrid,
    cfg: &NmsConfig,
) -> Vec<Detection> {
    decode_viewed_detections(out, i, frame, grid, cfg, CenterViews::AsSeen)
}

/// [`decode_detections`] of an output computed from [`make_viewed_input`]`(views)`: a mirrored
/// center's residuals decode around the anchors of its mirror image, and its boxes are mirrored
/// back, so every box is in `frame`'s own (as seen) LiDAR frame.
pub fn decode_viewed_detections(
    out: &ModelOutput,
    i: usize,
    frame: &PreparedFrame,
    grid: &AnchorGrid,
    cfg: &NmsConfig,
    views: CenterViews,
) -> Vec<Detection> {
    let [_, c, a, k] = out.cls_logits.dims();
    let logits: Vec<f32> = out
        .cls_logits
        .clone()
        .slice_dim(0, i..i + 1)
        .into_data()
        .iter::<f32>()
        .collect();
    let res: Vec<f32> = out
        .box_residuals
        .clone()
        .slice_dim(0, i..i + 1)
        .into_data()
        .iter::<f32>()
        .collect();
    let second_bin: Option<Vec<bool>> = out.dir_logits.as_ref().map(|d| {
        let v: Vec<f32> = d.clone().slice_dim(0, i..i + 1).into_data().iter::<f32>().collect();
        v.chunks_exact(2).map(|l| l[1] > l[0]).collect()
    });
    let mut dets = Vec::new();
    for ci in (0..c).filter(|&ci| frame.centers.valid[ci]) {
        let view = views.of(ci);
        let anchors = grid.anchors_around(view.point(frame.centers.xyz[ci]));
        for (ai, anchor) in anchors.iter().enumerate().take(a) {
            let n = ci * a + ai;
            for (ki, t) in cfg.per_class.iter().enumerate().take(k) {
                let score = 1.0 / (1.0 + (-logits[n * k + ki]).exp());
                if score >= t.score {
                    let r: [f32; 7] = res[n * 7..n * 7 + 7].try_into().expect("7 residuals");
                    let mut b = decode(&r, anchor);
                    if let Some(f) = &second_bin {
                        b.heading = with_direction(b.heading, usize::from(f[n]));
                    }
                    dets.push(Detection {
                        b: view.boxed(&b),
                        class: t.class,
                        score,
                    });
                }
            }
        }
    }
    dets
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backend::default_device;
    use starnet_data::sampling::{Centers, Neighbourhoods};

    /// A frame of two centers with two point slots each; feature values count up from `base`.
    fn frame(base: f32) -> PreparedFrame {
        PreparedFrame {
            id: "000000".into(),
            points: Vec::new(),
            centers: Centers {
                xyz: vec![[0.0; 3]; 2],
                valid: vec![true, false],
                num_seeded: 0,
            },
            neighbourhoods: Neighbourhoods {
                num_centers: 2,
                num_points: 2,
                features: (0..2 * 2 * NUM_FEATURES).map(|i| base + i as f32).collect(),
                mask: vec![true, false, true, true],
                indices: vec![Some(0), None, Some(1), Some(2)],
            },
            boxes: Vec::new(),
            classes: Vec::new(),
            draw: None,
        }
    }

    /// Two anchors per center; anchor `i` of the frame has class `class[i]`.
    fn targets(class: [Option<usize>; 4]) -> AnchorTargets {
        AnchorTargets {
            class: class.to_vec(),
            matched: class.to_vec(),
            cls_weight: vec![1.0, 0.5, 0.0, 1.0],
            reg_weight: class.iter().map(|k| f32::from(u8::from(k.is_some()))).collect(),
            residuals: (0..4).map(|i| [i as f32; 7]).collect(),
            direction: vec![0, 1, 1, 0],
        }
    }

    fn values<const D: usize>(t: Tensor<D>) -> (Vec<usize>, Vec<f32>) {
        (t.dims().to_vec(), t.into_data().iter::<f32>().collect())
    }

    #[test]
    fn a_batch_stacks_frames_in_order_with_one_hot_classes() {
        let (f0, f1) = (frame(0.0), frame(100.0));
        let (t0, t1) = (
            targets([None, Some(0), Some(1), None]),
            targets([Some(1), Some(1), None, Some(0)]),
        );
        let b = make_batch(&[&f0, &f1], &[&t0, &t1], 2, &default_device());
        let (dims, points) = values(b.input.points);
        assert_eq!(dims, [2, 2, 2, NUM_FEATURES]);
        assert_eq!(points[..3], [0.0, 1.0, 2.0]);
        assert_eq!(points[16..19], [100.0, 101.0, 102.0]);
        assert_eq!(values(b.input.mask).1, [1.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0]);
        assert_eq!(values(b.input.center_valid), (vec![2, 2], vec![1.0, 0.0, 1.0, 0.0]));
        let (dims, classes) = values(b.targets.classes);
        assert_eq!(dims, [2, 2, 2, 2]);
        #[rustfmt::skip]
        let want = [0.0, 0.0,  1.0, 0.0,  0.0, 1.0,  0.0, 0.0,
                    0.0, 1.0,  0.0, 1.0,  0.0, 0.0,  1.0, 0.0];
        assert_eq!(classes, want);
        assert_eq!(values(b.targets.cls_weight).1[4..], [1.0, 0.5, 0.0, 1.0]);
        assert_eq!(values(b.targets.reg_weight).1, [0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0]);
        assert_eq!(values(b.targets.direction).1, [0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0]);
        let (dims, residuals) = values(b.targets.residuals);
        assert_eq!(dims, [2, 2, 2, 7]);
        assert_eq!((residuals[7], residuals[27], residuals[28]), (1.0, 3.0, 0.0));
    }

    #[test]
    fn only_a_target_classs_neighbour_is_ignored() {
        let grid = AnchorGrid::kitti_car();
        let mut f = frame(0.0);
        f.centers.xyz = vec![[10.0, 0.0, -1.0], [30.0, 0.0, -1.0]];
        f.centers.valid = vec![true, true];
        let anchors = frame_anchors(&f, &grid);
        let second = grid.len() + grid.len() / 2; // the second center's middle anchor
        f.boxes = vec![anchors[grid.len() / 2], anchors[second]];
        let ignored = AssignConfig {
            neighbours: NeighbourRule::Ignored,
            ..AssignConfig::kitti_car()
        };
        let weight = |classes: &[ObjectClass], other: ObjectClass, cfg: &AssignConfig| {
            let mut g = f.clone();
            g.classes = vec![ObjectClass::Car, other];
            frame_targets(&g, &grid, classes, cfg).cls_weight[second]
        };
        let car = [ObjectClass::Car];
        assert_eq!(
            weight(&car, ObjectClass::Van, &ignored),
            0.0,
            "a van, for a car detector"
        );
        assert!(
            weight(&car, ObjectClass::Van, &AssignConfig::kitti_car()) > 0.0,
            "background by default"
        );
        assert!(
            weight(&car, ObjectClass::Truck, &ignored) > 0.0,
            "a truck is no car's neighbour"
        );
        assert!(
            weight(&car, ObjectClass::PersonSitting, &ignored) > 0.0,
            "nor is a sitting person"
        );
        let both = [ObjectClass::Car, ObjectClass::Van];
        assert!(
            weight(&both, ObjectClass::Van, &ignored) > 0.0,
            "a van is foreground for a van detector"
        );
    }
}
