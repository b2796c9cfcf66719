//! [`HeadingLoss`]: how the heading residual is penalised (the `[loss] heading` key).

use serde::{Deserialize, Serialize};

/// How the heading residual is compared.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeadingLoss {
    /// Huber(sin Δ): a box and its 180° turn cost the same.
    Sin,
    /// Huber(wrap Δ), Δ wrapped to [−π, π): the direction matters.
    Wrap,
}
