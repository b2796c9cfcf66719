//! [`MpiWorld`]: the replicas of an `mpirun` job, over the system's MPI library (rsmpi).

use crate::{Result, TrainError};
use mpi::Threading;
use mpi::collective::SystemOperation;
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator, CommunicatorCollectives};
use starnet_model::replicas::Replicas;
use std::sync::{Mutex, MutexGuard};

/// Every process of the job (`MPI_COMM_WORLD`), one replica each. MPI is finalised when it is
/// dropped.
pub struct MpiWorld {
    world: Mutex<SimpleCommunicator>,
    rank: usize,
    size: usize,
    _universe: Universe,
}

// SAFETY: MPI is initialised at `MPI_THREAD_SERIALIZED` or above (checked in `init`): any thread
// may call it as long as no two do at once, which the mutex around the communicator ensures.
// The communicator is a handle of the MPI library, not tied to the thread that made it.
unsafe impl Send for MpiWorld {}
// SAFETY: as for `Send`: every call goes through the mutex.
unsafe impl Sync for MpiWorld {}

impl std::fmt::Debug for MpiWorld {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "MpiWorld {{ rank: {}, size: {} }}", self.rank, self.size)
    }
}

fn mpi_error(message: String) -> TrainError {
    TrainError::InvalidArgument {
        name: "distributed".into(),
        message,
    }
}

impl MpiWorld {
    /// Initialises MPI for this process (the training step calls it from its compute thread,
    /// so the library must allow serialised calls from any thread).
    pub fn init() -> Result<Self> {
        let (universe, threading) = mpi::initialize_with_threading(Threading::Serialized)
            .ok_or_else(|| mpi_error("MPI is already initialised in this process".into()))?;
        if matches!(threading, Threading::Single | Threading::Funneled) {
            return Err(mpi_error(format!(
                "the MPI library offers only {threading:?} threading; training needs Serialized"
            )));
        }
        let world = universe.world();
        let (rank, size) = (world.rank() as usize, world.size() as usize);
        Ok(Self {
            world: Mutex::new(world),
            rank,
            size,
            _universe: universe,
        })
    }

    fn world(&self) -> MutexGuard<'_, SimpleCommunicator> {
        self.world.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Ends every process of the job with `code` (`MPI_Abort`): after an error on this one, so
    /// that no other waits forever in its next sum.
    pub fn abort(&self, code: i32) -> ! {
        self.world().abort(code)
    }
}

impl Replicas for MpiWorld {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn sum_f64(&self, values: &mut [f64]) {
        let send = values.to_vec();
        self.world().all_reduce_into(&send[..], values, SystemOperation::sum());
    }

    fn sum_f32(&self, values: &mut [f32]) {
        let send = values.to_vec();
        self.world().all_reduce_into(&send[..], values, SystemOperation::sum());
    }
}
