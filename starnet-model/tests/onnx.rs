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
        let real = |s: usize| s < p - p / 4;
        let mut pts = Vec::with_capacity(c * p * 4);
        let mut mask = Vec::with_capacity(c * p);
        for i in 0..c * p {
            let on = real(i % p);
            mask.push(if on { 1.0f32 } else { 0.0 });
            for f in 0..4 {
                let v = ((i * 7 + f * 13) % 17) as f32 / 8.0 - 1.0;
                pts.push(if on { v } else { 0.0 });
            }
        }
        let burn = model.forward(ModelInput {
            points: BurnTensor::<1>::from_floats(pts.as_slice(), &dev).reshape([1, c, p, 4]),
            mask: BurnTensor::<1>::from_floats(mask.as_slice(), &dev).reshape([1, c, p]),
            center_valid: BurnTensor::ones([1, c], &dev),
        });
        let plan = tract_onnx::onnx()
            .model_for_read(&mut bytes.as_slice())
            .unwrap()
            .with_input_fact(0, f32::fact([c, p, 4]).into())
            .unwrap()
            .with_input_fact(1, f32::fact([c, p]).into())
            .unwrap()
            .into_optimized()
            .unwrap()
            .into_runnable()
            .unwrap();
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
