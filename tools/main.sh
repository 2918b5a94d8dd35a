#!/usr/bin/env bash
# The main job: installs on first use, runs the default study and ends in a report.
#   tools/main.sh [OUT_DIR]          finite-element study studies/examples/main.toml (default out/main)
#   tools/main.sh design [OUT_DIR]   the analytic design study (default out/design)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
if [ "${1:-}" = design ]; then
  out=${2:-$_rollsim_root/out/design}
  rollsim design --out "$out"
else
  out=${1:-$_rollsim_root/out/main}
  # nproc obeys OMP_NUM_THREADS, which env.sh sets to 1 (one thread per rank): count the cores without it
  ranks=$(env -u OMP_NUM_THREADS -u OMP_THREAD_LIMIT nproc); [ "$ranks" -gt 4 ] && ranks=4  # four cases
  mpirun -n "$ranks" --oversubscribe rollsim study "$_rollsim_root/studies/examples/main.toml" --out "$out"
fi
echo "report: $out/report.md"
