//! Fine-tuning: a new model that starts from another model's weights (`train --init`), as
//! OpenPCDet's `--pretrained_model` and mmdetection3d's `load_from` do. Tensors are matched by
//! name; a tensor whose shape differs (the classification head when the classes differ, the box
//! heads when the anchors do) or that the source lacks keeps its fresh initialisation, and the
//! report names it. The optimizer starts fresh.

use burn::store::ModuleSnapshot;
use burn::store::burn_pack::Tensor as PackTensor;
use serde::Serialize;
use starnet_model::nn::StarNet;
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;

/// The model a fine-tuning run starts from, loaded by the caller (e.g. with
/// [`crate::trained::TrainedModel::load`], from a checkpoint or an export).
#[derive(Debug, Clone)]
pub struct InitSource {
    /// Where it was loaded from (named in the run's `init.json` and log).
    pub path: PathBuf,
    /// Its network, with the weights it evaluates with.
    pub model: StarNet,
}

/// Why a tensor of the new model kept its fresh initialisation.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Reinitialised {
    /// The source model has no tensor of this name (e.g. a head it was built without).
    Absent,
    /// The source's tensor has another shape.
    Shape {
        /// The source's shape.
        source: Vec<usize>,
        /// The new model's shape.
        target: Vec<usize>,
    },
}

/// One tensor that was not taken from the source.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct FreshTensor {
    /// Its path in the module, e.g. `cls_head.weight`.
    pub name: String,
    /// Why.
    pub reason: Reinitialised,
}

/// What a fine-tuning start took from its source.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct InitReport {
    /// The checkpoint or export the weights came from.
    pub source: PathBuf,
    /// The tensors copied from the source, by name.
    pub loaded: Vec<String>,
    /// The tensors that kept their fresh initialisation.
    pub reinitialised: Vec<FreshTensor>,
    /// Tensors of the source the new model has no place for.
    pub unused: Vec<String>,
}

/// `target` with every tensor of `source` whose name and shape it shares; the rest of
/// `target` is left as initialised. The copied tensors keep `target`'s parameter ids.
pub fn init_from(mut target: StarNet, source: &StarNet, source_path: PathBuf) -> (StarNet, InitReport) {
    let wanted: HashMap<String, Vec<usize>> = target
        .collect(None, None, false)
        .into_iter()
        .map(|t| (t.name.clone(), t.shape.to_vec()))
        .collect();
    let mut report = InitReport {
        source: source_path,
        loaded: Vec::new(),
        reinitialised: Vec::new(),
        unused: Vec::new(),
    };
    let mut fitting = Vec::new();
    let mut in_source = HashSet::new();
    for t in source.collect(None, None, false) {
        in_source.insert(t.name.clone());
        match wanted.get(&t.name) {
            None => report.unused.push(t.name.clone()),
            Some(shape) if *shape != t.shape.to_vec() => report.reinitialised.push(FreshTensor {
                name: t.name.clone(),
                reason: Reinitialised::Shape {
                    source: t.shape.to_vec(),
                    target: shape.clone(),
                },
            }),
            Some(_) => fitting.push(without_id(t)),
        }
    }
    let applied = target.apply(fitting, None, None, false);
    report.loaded = applied.applied;
    let absent = wanted.keys().filter(|n| !in_source.contains(*n));
    report.reinitialised.extend(absent.map(|n| FreshTensor {
        name: n.clone(),
        reason: Reinitialised::Absent,
    }));
    report.loaded.sort();
    report.reinitialised.sort_by(|a, b| a.name.cmp(&b.name));
    report.unused.sort();
    (target, report)
}

/// The tensor without its parameter id, so that applying it keeps the target's.
fn without_id(t: PackTensor) -> PackTensor {
    let (name, dtype, shape, _, bytes) = t.into_parts().expect("a collected tensor reads back");
    PackTensor::new(name, dtype, shape, None, bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::ExperimentConfig;
    use burn::module::{Module, ModuleVisitor, Param};
    use burn::prelude::Tensor;
    use starnet_data::kitti::ObjectClass;

    fn model(classes: &[&str], seed: u64) -> StarNet {
        let mut cfg = ExperimentConfig::default();
        cfg.model.blocks = vec![[8, 4]];
        cfg.model.d_fc0 = 8;
        cfg.model.d_offset = 4;
        cfg.data.classes = classes.iter().map(|c| ObjectClass::from_name(c).unwrap()).collect();
        cfg.model_config()
            .init_seeded(&starnet_model::backend::default_device(), seed)
    }

    /// Every float parameter's values, by module path order.
    fn values(m: &StarNet) -> Vec<Vec<f32>> {
        struct Collect(Vec<Vec<f32>>);
        impl ModuleVisitor for Collect {
            fn visit_float<const D: usize>(&mut self, p: &Param<Tensor<D>>) {
                self.0.push(p.val().into_data().iter::<f32>().collect());
            }
        }
        let mut c = Collect(Vec::new());
        m.visit(&mut c);
        c.0
    }

    #[test]
    fn the_same_architecture_copies_every_tensor() {
        let (source, target) = (model(&["Car"], 1), model(&["Car"], 2));
        assert_ne!(values(&source), values(&target));
        let (tuned, report) = init_from(target, &source, "src".into());
        assert!(
            report.reinitialised.is_empty() && report.unused.is_empty(),
            "{report:?}"
        );
        assert_eq!(values(&tuned), values(&source));
    }

    #[test]
    fn other_classes_reinitialise_the_classification_head_alone() {
        let source = model(&["Car"], 1);
        let target = model(&["Car", "Cyclist"], 2);
        let fresh = values(&target);
        let (tuned, report) = init_from(target, &source, "src".into());
        let names: Vec<&str> = report.reinitialised.iter().map(|f| f.name.as_str()).collect();
        assert!(names.iter().all(|n| n.starts_with("cls_head.")), "{names:?}");
        assert!(names.contains(&"cls_head.weight"), "{names:?}");
        assert!(matches!(report.reinitialised[0].reason, Reinitialised::Shape { .. }));
        assert!(report.loaded.iter().any(|n| n.starts_with("featurizer.")));
        // The featurizer is the source's; the classification head is the fresh model's.
        let (tuned, source, fresh) = (values(&tuned), values(&source), fresh);
        assert_eq!(tuned[0], source[0]);
        assert!(tuned.iter().zip(&fresh).any(|(t, f)| t == f && t != &source[0]));
    }
}
