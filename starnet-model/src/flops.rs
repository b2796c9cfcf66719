//! The exact multiply-add count of one forward pass at (C, P), the compute axis of every
//! budget report. Counted: every matrix product (fc0, both layers of each block, the projector,
//! the heads (class, box, and the direction bins when present), and for the streaming variant the LSTM step and its projection, once per call). Not counted: BatchNorm, ReLU, max, mean and concatenation, which are linear in
//! the activations and small beside the products.

use crate::nn::StarNetConfig;

/// Multiply-adds of one forward pass for one frame with `c` centers of `p` points.
pub fn forward_macs(cfg: &StarNetConfig, c: usize, p: usize) -> u64 {
    let f = &cfg.featurizer;
    let (c, p) = (c as u64, p as u64);
    let mut per_point = (f.d_input * f.d_fc0) as u64;
    let mut d = f.d_fc0;
    for &[hidden, out] in &f.blocks {
        per_point += (2 * d * hidden + hidden * out) as u64;
        d = out;
    }
    let offsets = (cfg.anchors.grid * cfg.anchors.grid) as u64;
    let per = cfg.anchors_per_offset() as u64;
    let projector = f.cell_dim() as u64 * offsets * cfg.d_offset as u64;
    let outputs = cfg.num_classes as u64 + 7 + if cfg.direction_classifier { 2 } else { 0 };
    let heads = offsets * cfg.d_offset as u64 * per * outputs
        + if cfg.shared_size {
            f.cell_dim() as u64 * per * 3
        } else {
            0
        };
    // One LSTM step per call: four gates over [input, hidden], then the projection back.
    let lstm = cfg.lstm_hidden.map_or(0, |h| {
        let (d, h) = (f.cell_dim() as u64, h as u64);
        4 * (d + h) * h + h * d
    });
    c * p * per_point + c * (projector + heads) + lstm
}

/// GFLOP of one forward pass (2 FLOP per multiply-add).
pub fn forward_gflop(cfg: &StarNetConfig, c: usize, p: usize) -> f64 {
    2.0 * forward_macs(cfg, c, p) as f64 / 1e9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_preset_hand_count() {
        // Per point: fc0 4·64 = 256; block 1: 128·256 + 256·64 = 49,152; blocks 2–5 the same
        // (their input is 64 wide too): 5 · 49,152 = 245,760; total 246,016.
        // Per center: projector 384 · 25 · 128 = 1,228,800; heads 25 · 128 · 4 · (1 + 7) = 102,400.
        let cfg = StarNetConfig::paper_car();
        let (c, p) = (1024, 64);
        let want = 1024 * 64 * 246_016u64 + 1024 * (1_228_800 + 102_400);
        assert_eq!(forward_macs(&cfg, c, p), want);
        assert!((forward_gflop(&cfg, c, p) - 2.0 * want as f64 / 1e9).abs() < 1e-12);
        // About 35 GFLOP per frame at (1024, 64).
        assert!(
            (forward_gflop(&cfg, c, p) - 34.97).abs() < 0.01,
            "{}",
            forward_gflop(&cfg, c, p)
        );
    }
}
