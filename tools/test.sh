#!/usr/bin/env bash
# The test command: installs on first use, then runs the suite serially and on 2 MPI ranks.
# Both passes always run; the exit status is non-zero if either failed.
# Extra arguments go to pytest (e.g. tools/test.sh -k bearing).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$_rollsim_root"
# The serial run spreads the tests over ROLLSIM_TEST_WORKERS processes (pytest-xdist; 0: one process).
workers=${ROLLSIM_TEST_WORKERS:-2}
start=$SECONDS
echo "== serial ($workers workers)" >&2
serial=0
# The end_to_end tests run once, in the mpirun pass (pyproject.toml's markers).
export ROLLSIM_MPI_PASS_FOLLOWS=1
if [ "$workers" -gt 0 ]; then python -m pytest -n "$workers" "$@" || serial=$?
else python -m pytest "$@" || serial=$?; fi
echo "== serial pass: exit $serial, $((SECONDS - start)) s" >&2
# Under mpirun only the tests that take the communicator run (tests/conftest.py): the others
# cannot depend on the partition.  Each rank writes to its own file: Open MPI's forwarding of a
# busy stdout/stderr can make a rank's write fail and kill it. Rank 0's log (ending in pytest's
# summary) is printed afterwards; the other rank's log is shown when the run fails.
start=$SECONDS
echo "== mpirun -n 2" >&2
logs=$(mktemp -d -t rollsim-mpi.XXXXXX)
parallel=0
mpirun -n 2 --oversubscribe bash -c '
    if [ "${OMPI_COMM_WORLD_RANK:-0}" = 0 ]; then exec python -m pytest "$@" > "'"$logs"'/rank0.log" 2>&1;
    else exec python -m pytest -q -p no:cacheprovider "$@" > "'"$logs"'/rank1.log" 2>&1; fi' _ "$@" || parallel=$?
if [ "$parallel" -ne 0 ]; then
  echo "== rank 1 log ($logs/rank1.log):" >&2; tail -n 60 "$logs/rank1.log" >&2; echo >&2
  echo "== rank 0 log ($logs/rank0.log):" >&2
fi
cat "$logs/rank0.log"
if [ "$parallel" -eq 5 ]; then  # pytest's "no tests collected": none of those asked for takes the communicator
  echo "== mpirun -n 2: no selected test takes the communicator" >&2; parallel=0
fi
echo "== mpirun -n 2 pass: exit $parallel, $((SECONDS - start)) s" >&2
if [ "$serial" -ne 0 ] || [ "$parallel" -ne 0 ]; then
  echo "== failed: serial pass exit $serial, mpirun -n 2 pass exit $parallel" >&2
  exit 1
fi
