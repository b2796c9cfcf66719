//! Prepared frames and their anchor targets → the tensors of a batch, and back from the
//! model's outputs to detections per frame.

use crate::assign::{AnchorTargets, AssignConfig, assign_targets};
use crate::coder::{decode, with_direction};
use crate::loss::LossTargets;
use crate::nms::{Detection, NmsConfig, nms};
use crate::nn::{ModelInput, ModelOutput};
use burn::prelude::*;
use starnet_data::Box3d;
use starnet_data::kitti::ObjectClass;
use starnet_data::sampling::{AnchorGrid, NUM_FEATURES, PreparedFrame};

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

/// Assigns a frame's targets for the model's `classes` (objects of other classes are dropped,
/// so they count as background, as in lingvo).
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
    assign_targets(
        &frame_anchors(frame, grid),
        grid.len(),
        &frame.centers.valid,
        &boxes,
        &ids,
        cfg,
    )
}

/// Stacks frames (all with the same C and P) into model inputs on `device`.
pub fn make_input(frames: &[&PreparedFrame], device: &Device) -> ModelInput {
    let b = frames.len();
    let (c, p) = (
        frames[0].neighbourhoods.num_centers,
        frames[0].neighbourhoods.num_points,
    );
    let floats = |v: Vec<f32>| Tensor::<1>::from_floats(v.as_slice(), device);
    let points = floats(
        frames
            .iter()
            .flat_map(|f| f.neighbourhoods.features.iter().copied())
            .collect(),
    );
    let mask = floats(
        frames
            .iter()
            .flat_map(|f| f.neighbourhoods.mask.iter().map(|m| *m as u8 as f32))
            .collect(),
    );
    let valid = floats(
        frames
            .iter()
            .flat_map(|f| f.centers.valid.iter().map(|v| *v as u8 as f32))
            .collect(),
    );
    ModelInput {
        points: points.reshape([b, c, p, NUM_FEATURES]),
        mask: mask.reshape([b, c, p]),
        center_valid: valid.reshape([b, c]),
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
    let floats = |v: Vec<f32>| Tensor::<1>::from_floats(v.as_slice(), device);
    let one_hot: Vec<f32> = targets
        .iter()
        .flat_map(|t| {
            t.class
                .iter()
                .flat_map(move |&k| (0..num_classes).map(move |j| (k == j as i32) as u8 as f32))
        })
        .collect();
    StarNetBatch {
        input: make_input(frames, device),
        targets: LossTargets {
            classes: floats(one_hot).reshape([b, c, a, num_classes]),
            cls_weight: floats(targets.iter().flat_map(|t| t.cls_weight.iter().copied()).collect()).reshape([b, c, a]),
            residuals: floats(
                targets
                    .iter()
                    .flat_map(|t| t.residuals.iter().flatten().copied())
                    .collect(),
            )
            .reshape([b, c, a, 7]),
            reg_weight: floats(targets.iter().flat_map(|t| t.reg_weight.iter().copied()).collect()).reshape([b, c, a]),
            direction: floats(
                targets
                    .iter()
                    .flat_map(|t| t.direction.iter().map(|&d| f32::from(d)))
                    .collect(),
            )
            .reshape([b, c, a]),
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
    let anchors = frame_anchors(frame, grid);
    let mut dets = Vec::new();
    for ci in (0..c).filter(|&ci| frame.centers.valid[ci]) {
        for ai in 0..a {
            let n = ci * a + ai;
            for class in 0..k {
                let score = 1.0 / (1.0 + (-logits[n * k + class]).exp());
                if cfg.per_class.get(class).is_some_and(|t| score >= t.score) {
                    let r: [f32; 7] = res[n * 7..n * 7 + 7].try_into().expect("7 residuals");
                    let mut b = decode(&r, &anchors[n]);
                    if let Some(f) = &second_bin {
                        b.heading = with_direction(b.heading, usize::from(f[n]));
                    }
                    dets.push(Detection { b, class, score });
                }
            }
        }
    }
    dets
}
