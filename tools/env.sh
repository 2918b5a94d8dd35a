# Sourced by the wrappers: runs the install step, then puts the venv first on PATH.
# shellcheck shell=bash
_rollsim_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$_rollsim_root/tools/install.sh"
export PATH="${ROLLSIM_VENV:-$_rollsim_root/.venv}/bin:$PATH"
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}            # one thread per MPI rank
export OPENBLAS_NUM_THREADS=${OPENBLAS_NUM_THREADS:-1}
export MPLBACKEND=${MPLBACKEND:-Agg}
if [ "$(id -u)" -eq 0 ]; then  # Open MPI refuses root without these
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fi
