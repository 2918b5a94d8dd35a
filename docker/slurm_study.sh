#!/bin/bash
# Example SLURM job: one rollsim study spread over N nodes from the Apptainer image.
# Submit:  sbatch --nodes=4 docker/slurm_study.sh studies/examples/analytic_indentation_cases.toml out/study
# Re-submitting the same command after a time-out or a kill resumes the study.
#SBATCH --job-name=rollsim-study
#SBATCH --ntasks-per-node=32
#SBATCH --cpus-per-task=1
#SBATCH --time=04:00:00
#SBATCH --output=rollsim-%j.log
# Two minutes before the time limit every rank gets SIGUSR1: the running cases stop at their next
# step boundary with status "interrupted" (not recorded as done), so a re-submission redoes them.
#SBATCH --signal=USR1@120
set -euo pipefail

study=${1:?usage: sbatch docker/slurm_study.sh STUDY.toml OUT_DIR}
out=${2:?usage: sbatch docker/slurm_study.sh STUDY.toml OUT_DIR}
image=${ROLLSIM_IMAGE:-rollsim.sif}

export OMP_NUM_THREADS=1
# Hybrid model: the host's MPI launches one container process per rank. The image's
# Open MPI (Debian bookworm, 4.1) must be ABI-compatible with the host's PMI/Open MPI;
# with a different host MPI, bind it in or use `srun --mpi=pmix`.
srun --mpi=pmix apptainer exec --bind "$PWD" "$image" \
  rollsim study "$study" --out "$out"
# The report is written by rank 0 at the end; regenerate it at any time with
#   apptainer exec rollsim.sif rollsim report "$out"
