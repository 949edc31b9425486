"""How hardrod is started on several MPI ranks: the mpirun prefix and its environment.

One launcher for the bench harnesses and the test scripts (tests/parallel/run_case.py,
tests/scripts/*.py), so that running as root, oversubscribing the cores and binding ranks are
spelled once. OpenMPI is assumed (the MCA variables and flags are OpenMPI's). It builds
command lines; it does not run them.
"""

import os

NPROC = os.cpu_count() or 1

# OpenMPI refuses to start as root (containers, CI) without both of these.
ROOT_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
# Ranks that share cores with each other and with other work: let a waiting rank (or OpenMP
# thread) give its core away instead of spinning.
SHARED_CORES_ENV = {**ROOT_ENV, "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMPI_MCA_mpi_yield_when_idle": "1",
                    "OMP_WAIT_POLICY": "passive"}


def prefix(ranks, bind=False, always=False, mpirun="mpirun"):
    """The mpirun words before `hardrod ...`: none on one rank (unless `always`); ranks bound
    one per core when asked and there are cores enough, otherwise oversubscribed."""
    if ranks == 1 and not always:
        return []
    if bind and ranks <= NPROC:
        return [mpirun, "-np", str(ranks), "--bind-to", "core", "--map-by", "core"]
    return [mpirun, "--oversubscribe", "-np", str(ranks)]


def environment(shared_cores=True, base=None):
    """The environment for a run: `base` (default os.environ) with the MPI settings added."""
    return {**(os.environ if base is None else base), **(SHARED_CORES_ENV if shared_cores else ROOT_ENV)}
