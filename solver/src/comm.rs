//! The communication layer: the only module that touches MPI.

use mpi::topology::Communicator;

/// The MPI world this process belongs to.
pub struct World {
    _universe: mpi::environment::Universe,
    world: mpi::topology::SimpleCommunicator,
}

impl World {
    /// Initialises MPI (as a singleton when started without mpirun).
    pub fn initialize() -> anyhow::Result<Self> {
        let universe = mpi::initialize().ok_or_else(|| anyhow::anyhow!("MPI was already initialised"))?;
        let world = universe.world();
        Ok(Self { _universe: universe, world })
    }

    pub fn size(&self) -> i32 {
        self.world.size()
    }
}
