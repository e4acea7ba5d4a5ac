//! Running under an MPI launcher (cargo feature `mpi`): `mpirun -np N rendr turn ...`
//! deals the frames to the ranks (sort-first; every rank reads the whole volume) and
//! rank 0 writes them; `mpirun -np N rendr go ...` renders the volume in N bricks
//! (sort-last, `rnd_core::brick`), composites the partials (one all-to-all exchange:
//! each rank composites a band of rows) and rank 0 writes the image. Started without a
//! launcher, rendr does not initialize MPI and behaves as a build without the feature.

use mpi::collective::SystemOperation;
use mpi::datatype::{Partition, PartitionMut};
use mpi::topology::{Communicator, SimpleCommunicator};
use mpi::traits::*;
use mpi::Count;

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

    /// Sends `parts[j]` to rank j, for every j (every rank must call it), and returns
    /// what each rank sent this one, by rank (one MPI all-to-all).
    pub fn exchange(&self, parts: &[Vec<u8>]) -> anyhow::Result<Vec<Vec<u8>>> {
        let count = |n: usize| {
            Count::try_from(n)
                .map_err(|_| anyhow::anyhow!("{n} bytes is more than one MPI message may carry"))
        };
        let counts = parts
            .iter()
            .map(|p| count(p.len()))
            .collect::<anyhow::Result<Vec<Count>>>()?;
        let mut rcounts: Vec<Count> = vec![0; self.size];
        self.world.all_to_all_into(&counts[..], &mut rcounts[..]);
        let offsets = |c: &[Count]| -> anyhow::Result<Vec<Count>> {
            let mut at = 0usize;
            c.iter()
                .map(|&n| {
                    let here = count(at);
                    at += n as usize;
                    here
                })
                .collect()
        };
        let (sdispl, rdispl) = (offsets(&counts)?, offsets(&rcounts)?);
        count(rcounts.iter().map(|&n| n as usize).sum())?;
        let send = parts.concat();
        let mut recv = vec![0u8; rcounts.iter().map(|&n| n as usize).sum()];
        {
            let sp = Partition::new(&send[..], &counts[..], &sdispl[..]);
            let mut rp = PartitionMut::new(&mut recv[..], &rcounts[..], &rdispl[..]);
            self.world.all_to_all_varcount_into(&sp, &mut rp);
        }
        Ok(rcounts
            .iter()
            .zip(&rdispl)
            .map(|(&n, &d)| recv[d as usize..(d + n) as usize].to_vec())
            .collect())
    }
}
