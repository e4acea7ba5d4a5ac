//! Running under an MPI launcher (cargo feature `mpi`): `mpirun -np N rendr turn ...`
//! deals the frames to the ranks (sort-first; every rank reads the whole volume) and
//! rank 0 writes them. Started without a launcher, rendr does not initialize MPI and
//! behaves as a build without the feature.

use mpi::collective::SystemOperation;
use mpi::topology::{Communicator, SimpleCommunicator};
use mpi::traits::*;

/// Whether an MPI launcher started this process (Open MPI, or a PMI/PMIx launcher).
fn launched() -> bool {
    ["OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"]
        .iter()
        .any(|v| std::env::var_os(v).is_some())
}

/// Initializes MPI when launched by `mpirun`; the universe ends MPI when dropped.
pub fn start() -> Option<mpi::environment::Universe> {
    if launched() {
        mpi::initialize()
    } else {
        None
    }
}

/// This process's place in a job of more than one process.
pub struct Ranks {
    world: SimpleCommunicator,
    /// This process's rank.
    pub rank: usize,
    /// Processes in the job.
    pub size: usize,
}

/// The job, when MPI runs with more than one process.
pub fn ranks() -> Option<Ranks> {
    if !mpi::environment::is_initialized() {
        return None;
    }
    let world = SimpleCommunicator::world();
    let (rank, size) = (world.rank() as usize, world.size() as usize);
    (size > 1).then_some(Ranks { world, rank, size })
}

impl Ranks {
    /// Whether any rank's `failed` is true (every rank must call it).
    pub fn any(&self, failed: bool) -> bool {
        let mut any = 0i32;
        self.world
            .all_reduce_into(&i32::from(failed), &mut any, SystemOperation::max());
        any != 0
    }

    /// Sends `bytes` to rank 0.
    pub fn send_to_root(&self, bytes: &[u8]) {
        self.world.process_at_rank(0).send(bytes);
    }

    /// Receives the next bytes rank `from` sends to this rank.
    pub fn receive_from(&self, from: usize) -> Vec<u8> {
        self.world
            .process_at_rank(from as i32)
            .receive_vec::<u8>()
            .0
    }
}
