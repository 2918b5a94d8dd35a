#!/usr/bin/env bash
# The test command: installs on first use, then runs the suite serially and on 2 MPI ranks.
# Extra arguments go to pytest (e.g. tools/test.sh -k bearing).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$_rollsim_root"
echo "== serial" >&2
python -m pytest "$@"
echo "== mpirun -n 2" >&2
# Both ranks run the suite; rank 0 reports, the other rank's log is kept for failures.
log=$(mktemp -t rollsim-rank1.XXXXXX)
if ! mpirun -n 2 --oversubscribe bash -c '
    if [ "${OMPI_COMM_WORLD_RANK:-0}" = 0 ]; then exec python -m pytest "$@";
    else exec python -m pytest -q -p no:cacheprovider "$@" > "'"$log"'" 2>&1; fi' _ "$@"; then
  echo "== rank 1 log ($log):" >&2; tail -n 60 "$log" >&2; exit 1
fi
