//! Decoding's last step: per-class greedy non-maximum suppression with oriented 3D IoU
//! (lingvo `NonMaxSuppression3D`), and the stateful variant of the streaming paper (§3.3),
//! which also suppresses against the boxes kept in the previous k slices of a sweep. Optionally each kept
//! box is then refined by box voting ([`vote`]; not in the paper, off by default).

mod deferred;
mod greedy;
mod stateful;
#[cfg(test)]
mod tests;

pub use deferred::DeferredNms;
pub use greedy::{ClassNms, Continued, NmsConfig, Precedence, nms, nms_after, vote};
pub(crate) use greedy::{is_candidate, voted};
pub use stateful::{Emission, StatefulNms};

/// A scored box (defined beside [`starnet_data::Box3d`], so the metrics can score boxes without the model).
pub use starnet_data::geometry::Detection;
