//! Data-parallel training (Horovod's model): N replicas of the model, each computing on its shard
//! of every batch, their gradients averaged before each (identical) Adam step, their BatchNorms
//! synchronised ([`starnet_model::replicas`]). `train.batch_size` is the global batch: the same
//! config trains the same model on 1 or N replicas, to float rounding.
//!
//! The replicas are processes launched by MPI (`mpirun -np N starnet train --distributed mpi`,
//! cargo feature `mpi`: `mpi::MpiWorld`) or threads of one process ([`ThreadGroup`], for tests
//! and custom loops). [`crate::train::train`] runs either, given the group in
//! [`crate::train::TrainOptions::replicas`]: each replica loads its [`Shard`]; replica 0 alone
//! writes the log, the checkpoints and the evaluations; every replica resumes from the same
//! checkpoint.

mod gradients;
#[cfg(feature = "mpi")]
pub mod mpi;
mod role;
mod shard;
#[cfg(test)]
mod tests;
mod threads;

pub use gradients::average_gradients;
pub use role::{Role, any, average};
pub use shard::Shard;
pub use starnet_model::replicas::{Replicas, scope};
pub use threads::ThreadGroup;
