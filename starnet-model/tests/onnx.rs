//! The exported ONNX graph, run by an independent runtime (tract), against Burn's forward.

use starnet_model::backend::default_device;
use starnet_model::export::{load_weights, named_tensors};
use starnet_model::nn::{ModelInput, StarNetConfig};
use starnet_model::onnx::onnx_model;
use tract_onnx::prelude::*;

/// Burn's tensor (tract's prelude has its own `Tensor`).
type BurnTensor<const D: usize> = burn::tensor::Tensor<D>;

/// A small model with every weight and running statistic random (the box head starts at zero).
fn random_model(cfg: &StarNetConfig) -> starnet_model::nn::StarNet {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32 // [0, 1)
    };
    let tensors = named_tensors(&cfg.init(&default_device()))
        .into_iter()
        .map(|mut t| {
            let var = t.name.ends_with("running_var");
            t.data
                .iter_mut()
                .for_each(|v| *v = if var { 0.5 + next() } else { next() - 0.5 });
            (t.name.clone(), t)
        })
        .collect();
    load_weights(cfg.init(&default_device()), &tensors).unwrap()
}

/// tract's optimised plan of the ONNX `bytes`, its f32 inputs of these shapes.
fn tract_plan(bytes: &[u8], shapes: &[&[usize]]) -> TypedRunnableModel<TypedModel> {
    let mut model = tract_onnx::onnx().model_for_read(&mut &bytes[..]).unwrap();
    for (i, shape) in shapes.iter().enumerate() {
        model = model.with_input_fact(i, f32::fact(shape.to_vec()).into()).unwrap();
    }
    model.into_optimized().unwrap().into_runnable().unwrap()
}

#[test]
fn tract_matches_burn_for_several_budgets() {
    // With the direction classifier (its third output is checked too) and shared sizes.
    for shared_size in [false, true] {
        check_budgets(
            &StarNetConfig::small_car()
                .with_direction_classifier(true)
                .with_shared_size(shared_size),
        );
    }
}

fn check_budgets(cfg: &StarNetConfig) {
    let cfg = cfg.clone();
    let model = random_model(&cfg);
    let bytes = onnx_model(&model, &cfg);
    let dev = default_device();
    for (c, p) in [(3, 5), (16, 32), (40, 8)] {
        // Points in the first ~3/4 of each neighbourhood; padded slots zero.
        let (pts, mask, _) = slice_input(0, c, p);
        let burn = model.forward(ModelInput {
            points: BurnTensor::<1>::from_floats(pts.as_slice(), &dev).reshape([1, c, p, 4]),
            mask: BurnTensor::<1>::from_floats(mask.as_slice(), &dev).reshape([1, c, p]),
            center_valid: BurnTensor::ones([1, c], &dev),
        });
        let plan = tract_plan(&bytes, &[&[c, p, 4], &[c, p]]);
        let inputs = tvec!(
            tract_ndarray::Array3::from_shape_vec((c, p, 4), pts.clone())
                .unwrap()
                .into_tensor()
                .into(),
            tract_ndarray::Array2::from_shape_vec((c, p), mask.clone())
                .unwrap()
                .into_tensor()
                .into(),
        );
        let out = plan.run(inputs).unwrap();
        for (k, (name, want)) in [
            ("cls_logits", burn.cls_logits.clone()),
            ("box_residuals", burn.box_residuals.clone()),
            ("dir_logits", burn.dir_logits.clone().expect("direction logits")),
        ]
        .into_iter()
        .enumerate()
        {
            let got = out[k].to_array_view::<f32>().unwrap();
            let want_dims = want.dims();
            assert_eq!(got.shape(), &want_dims[1..], "{name} at C={c} P={p}");
            let want: Vec<f32> = want.into_data().iter::<f32>().collect();
            let worst = got.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert!(worst < 1e-4, "{name} at C={c} P={p}: max |diff| {worst}");
            assert!(want.iter().any(|v| v.abs() > 1e-3), "{name} should not be trivial");
        }
    }
}

/// Slice `s`'s input: `c` centers of `p` points (the last quarter padded), and on odd slices
/// the last three centers marked as repeats (invalid), as a small slice pool is padded.
fn slice_input(s: usize, c: usize, p: usize) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let mut pts = Vec::with_capacity(c * p * 4);
    let mut mask = Vec::with_capacity(c * p);
    for i in 0..c * p {
        let on = i % p < p - p / 4;
        mask.push(if on { 1.0f32 } else { 0.0 });
        for f in 0..4 {
            let v = ((i * 7 + f * 13 + s * 5) % 17) as f32 / 8.0 - 1.0;
            pts.push(if on { v } else { 0.0 });
        }
    }
    let valid = (0..c)
        .map(|i| if s % 2 == 1 && i + 3 >= c { 0.0 } else { 1.0 })
        .collect();
    (pts, mask, valid)
}

#[test]
fn tract_streams_the_lstm_slice_by_slice_as_burn_does() {
    let cfg = StarNetConfig::small_car()
        .with_direction_classifier(true)
        .with_lstm_hidden(Some(16));
    let model = random_model(&cfg);
    let bytes = onnx_model(&model, &cfg);
    let dev = default_device();
    let (c, p, h) = (12, 8, 16);
    let plan = tract_plan(&bytes, &[&[c, p, 4], &[c, p], &[c], &[1, h], &[1, h]]);
    // The reset rule: zeros at the sweep's first slice; then each slice's state feeds the next.
    let (mut state_h, mut state_c) = (vec![0.0f32; h], vec![0.0f32; h]);
    let mut burn_state = None;
    for s in 0..5 {
        let (pts, mask, valid) = slice_input(s, c, p);
        let (burn, next) = model.forward_slices(
            ModelInput {
                points: BurnTensor::<1>::from_floats(pts.as_slice(), &dev).reshape([1, c, p, 4]),
                mask: BurnTensor::<1>::from_floats(mask.as_slice(), &dev).reshape([1, c, p]),
                center_valid: BurnTensor::<1>::from_floats(valid.as_slice(), &dev).reshape([1, c]),
            },
            1,
            burn_state,
        );
        let next = next.expect("an LSTM state");
        let inputs = tvec!(
            tract_ndarray::Array3::from_shape_vec((c, p, 4), pts)
                .unwrap()
                .into_tensor()
                .into(),
            tract_ndarray::Array2::from_shape_vec((c, p), mask)
                .unwrap()
                .into_tensor()
                .into(),
            tract_ndarray::Array1::from_vec(valid).into_tensor().into(),
            tract_ndarray::Array2::from_shape_vec((1, h), state_h.clone())
                .unwrap()
                .into_tensor()
                .into(),
            tract_ndarray::Array2::from_shape_vec((1, h), state_c.clone())
                .unwrap()
                .into_tensor()
                .into(),
        );
        let out = plan.run(inputs).unwrap();
        let flat = |t: BurnTensor<4>| t.into_data().iter::<f32>().collect::<Vec<f32>>();
        let state = |t: BurnTensor<2>| t.into_data().iter::<f32>().collect::<Vec<f32>>();
        let want = [
            ("cls_logits", flat(burn.cls_logits)),
            ("box_residuals", flat(burn.box_residuals)),
            ("dir_logits", flat(burn.dir_logits.expect("direction logits"))),
            ("state_h_out", state(next.hidden.clone())),
            ("state_c_out", state(next.cell.clone())),
        ];
        for (k, (name, want)) in want.iter().enumerate() {
            let got: Vec<f32> = out[k].to_array_view::<f32>().unwrap().iter().copied().collect();
            assert_eq!(got.len(), want.len(), "{name} at slice {s}");
            let worst = got.iter().zip(want).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert!(worst < 1e-4, "{name} at slice {s}: max |diff| {worst}");
            assert!(want.iter().any(|v| v.abs() > 1e-3), "{name} should not be trivial");
        }
        state_h = out[3].to_array_view::<f32>().unwrap().iter().copied().collect();
        state_c = out[4].to_array_view::<f32>().unwrap().iter().copied().collect();
        burn_state = Some(next);
    }
}
