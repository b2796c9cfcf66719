//! A replica's role in data-parallel training, and the sums every replica takes part in.

use super::Shard;
use starnet_model::replicas::Replicas;
use std::sync::Arc;

/// A process's (or thread's) part in a run: its replica group, if any, and its [`Shard`].
#[derive(Debug, Clone)]
pub struct Role {
    /// The group (`None`: training alone).
    pub group: Option<Arc<dyn Replicas>>,
    /// The items it loads.
    pub shard: Shard,
}

impl Role {
    /// The role of a member of `group` (alone without one).
    pub fn of(group: Option<Arc<dyn Replicas>>) -> Self {
        let shard = group.as_ref().map_or(Shard::whole(), |g| Shard {
            rank: g.rank(),
            ranks: g.size(),
        });
        Self { group, shard }
    }

    /// Whether this member writes the run's files (the data, the log, the checkpoints).
    pub fn writes(&self) -> bool {
        self.shard.writes()
    }

    /// Returns once every member has called it (after the writer has prepared what the others
    /// read).
    pub fn barrier(&self) {
        if let Some(g) = &self.group {
            any(false, g.as_ref());
        }
    }

    /// Whether any member says yes (`flag` itself alone).
    pub fn any(&self, flag: bool) -> bool {
        self.group.as_ref().map_or(flag, |g| any(flag, g.as_ref()))
    }
}

/// The mean of `values` over the group's members (in place).
pub fn average(values: &mut [f32], group: &dyn Replicas) {
    let mut wide: Vec<f64> = values.iter().map(|&v| f64::from(v)).collect();
    group.sum_f64(&mut wide);
    let n = group.size() as f64;
    values.iter_mut().zip(wide).for_each(|(v, w)| *v = (w / n) as f32);
}

/// Whether any member says yes (a stop request on one replica stops them all at the same step).
pub fn any(flag: bool, group: &dyn Replicas) -> bool {
    let mut v = [f64::from(u8::from(flag))];
    group.sum_f64(&mut v);
    v[0] > 0.0
}
