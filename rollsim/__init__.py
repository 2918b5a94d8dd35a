"""rollsim: test-rolling simulation (bearing-capacity model and finite-element solver)."""
import os
from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("rollsim")
except PackageNotFoundError:  # a source tree that was not installed
    __version__ = "unknown"

# One BLAS thread per MPI rank unless the user says otherwise (set before numpy loads BLAS).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
