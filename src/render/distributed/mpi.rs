//! The MPI transport of distributed renders (`--features mpi`): the ranks of `MPI_COMM_WORLD`
//! through the `mpi` crate over the system's MPI library (Debian's OpenMPI). Image pieces go
//! as byte messages; a rank that must end the run ends every rank (`MPI_Abort`), so no rank
//! waits for a message that will never come.

use super::exchange::Exchange;
use crate::error::{Error, Result};
use mpi::environment::Universe;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use std::sync::Mutex;

/// This process's rank of `MPI_COMM_WORLD`.
pub struct MpiExchange {
    // MPI runs with MPI_THREAD_SERIALIZED: calls may come from any thread, one at a time.
    world: Mutex<SimpleCommunicator>,
    rank: usize,
    size: usize,
    // Finalises MPI when dropped, after `world` (fields drop in order).
    _universe: Universe,
}

// SAFETY: the communicator is a handle of MPI_COMM_WORLD, valid in every thread; every call
// through it is serialised by the mutex, as the MPI_THREAD_SERIALIZED level requires.
unsafe impl Send for MpiExchange {}
unsafe impl Sync for MpiExchange {}

impl MpiExchange {
    /// Initialises MPI (once per process) and returns this process's rank of the world.
    pub fn init() -> Result<MpiExchange> {
        let (universe, _) = mpi::initialize_with_threading(mpi::Threading::Serialized)
            .ok_or_else(|| Error::invalid("mpi", "MPI was initialised already in this process"))?;
        let world = universe.world();
        let (rank, size) = (world.rank() as usize, world.size() as usize);
        Ok(MpiExchange {
            world: Mutex::new(world),
            rank,
            size,
            _universe: universe,
        })
    }

    /// Ends every rank of the run with `code` (MPI_Abort); the caller has printed why.
    pub fn abort(&self, code: i32) -> ! {
        let world = self.world.lock().unwrap_or_else(|p| p.into_inner());
        world.abort(code)
    }

    fn with_world<T>(&self, f: impl FnOnce(&SimpleCommunicator) -> T) -> T {
        let world = self.world.lock().unwrap_or_else(|p| p.into_inner());
        f(&world)
    }
}

fn rank_of(r: usize) -> i32 {
    r as i32
}

impl Exchange for MpiExchange {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn send(&self, to: usize, data: &[u8]) -> Result<()> {
        check_count(data)?;
        self.with_world(|w| w.process_at_rank(rank_of(to)).send(data));
        Ok(())
    }

    fn recv(&self, from: usize) -> Result<Vec<u8>> {
        Ok(self.with_world(|w| w.process_at_rank(rank_of(from)).receive_vec::<u8>().0))
    }

    fn send_recv(&self, to: usize, data: &[u8], from: usize) -> Result<Vec<u8>> {
        check_count(data)?;
        Ok(self.with_world(|w| {
            mpi::request::scope(|scope| {
                let sent = w.process_at_rank(rank_of(to)).immediate_send(scope, data);
                let (got, _) = w.process_at_rank(rank_of(from)).receive_vec::<u8>();
                sent.wait();
                got
            })
        }))
    }

    fn transport(&self) -> &'static str {
        "MPI"
    }
}

/// MPI counts are C ints: one message holds less than 2 GiB.
fn check_count(data: &[u8]) -> Result<()> {
    if data.len() > i32::MAX as usize {
        return Err(Error::invalid(
            "distributed",
            format!(
                "an image piece of {} bytes exceeds MPI's 2 GiB message limit; render a smaller image or with more ranks",
                data.len()
            ),
        ));
    }
    Ok(())
}
