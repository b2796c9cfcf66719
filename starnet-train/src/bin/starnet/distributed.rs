//! `starnet train --distributed mpi`: the MPI job a process joins, and how it ends on an error.

use std::sync::Arc;

/// How the processes of a distributed run talk.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum Distributed {
    /// MPI (`mpirun`), over the system's MPI library.
    Mpi,
}

#[cfg(feature = "mpi")]
pub type World = starnet_train::distributed::mpi::MpiWorld;

/// The MPI job this process belongs to.
#[cfg(feature = "mpi")]
pub fn join_world() -> anyhow::Result<Arc<World>> {
    Ok(Arc::new(World::init()?))
}

/// A build without MPI has no world to join.
#[cfg(not(feature = "mpi"))]
#[derive(Debug)]
pub enum World {}

#[cfg(not(feature = "mpi"))]
impl starnet_train::distributed::Replicas for World {
    fn rank(&self) -> usize {
        match *self {}
    }
    fn size(&self) -> usize {
        match *self {}
    }
    fn sum_f64(&self, _: &mut [f64]) {
        match *self {}
    }
    fn sum_f32(&self, _: &mut [f32]) {
        match *self {}
    }
}

#[cfg(not(feature = "mpi"))]
pub fn join_world() -> anyhow::Result<Arc<World>> {
    anyhow::bail!(
        "--distributed mpi: this starnet was built without MPI; build it with `cargo build --release --features mpi` \
         (Debian: apt install libopenmpi-dev openmpi-bin libclang-dev)"
    )
}

/// Ends the MPI job after an error on this process, naming it, so no other process waits forever.
#[cfg(feature = "mpi")]
pub fn abort_job(world: &World, err: &anyhow::Error) -> ! {
    use starnet_train::distributed::Replicas;
    eprintln!("rank {} of {}: error: {err:#}", world.rank(), world.size());
    world.abort(1)
}

#[cfg(not(feature = "mpi"))]
pub fn abort_job(world: &World, _: &anyhow::Error) -> ! {
    match *world {}
}
