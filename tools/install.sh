#!/usr/bin/env bash
# The one install step used by the README commands, .ci/run and docker/Dockerfile.
# Idempotent: installs the Debian packages that are missing, creates the project
# venv (with the system site-packages, so DOLFINx/PETSc/gmsh come from Debian)
# and installs rollsim into it. A second run does nothing and takes a second.
#
#   ROLLSIM_VENV   venv location (default: <repo>/.venv)
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
venv=${ROLLSIM_VENV:-$here/.venv}

apt_packages=(
  python3-dolfinx-real python3-petsc4py-real python3-mpi4py python3-gmsh
  openmpi-bin python3-numpy python3-scipy python3-matplotlib python3-pint
  python3-pytest python3-pytest-xdist python3-pytest-timeout python3-hypothesis python3-sphinx python3-myst-parser python3-venv python3-pip python3-wheel
  libegl1 libegl-mesa0 libgl1-mesa-dri   # off-screen rendering (VTK via EGL, llvmpipe)
  libopenblas0-pthread                   # optimised BLAS for MUMPS (reference BLAS is ~2x slower)
)

missing=()
for p in "${apt_packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "rollsim install: Debian packages: ${missing[*]}" >&2
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "rollsim install: need root or sudo to install ${missing[*]}" >&2; exit 1; }
    sudo=sudo
  fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if [ ! -x "$venv/bin/python" ]; then
  echo "rollsim install: creating venv $venv" >&2
  /usr/bin/python3 -m venv --system-site-packages "$venv"
fi

# Reinstall only when the packaging inputs change (the install is editable).
stamp="$venv/.rollsim-install-stamp"
want=$(cat "$here/pyproject.toml" "$here/tools/install.sh" | sha256sum | cut -c1-16)
if [ "$(cat "$stamp" 2>/dev/null)" != "$want" ]; then
  # Pin numpy to the system version: pip packages must never replace it. Keep markdown-it-py
  # below 3 for Debian's myst-parser (the docs build); pyvista's rich pulls it in.
  constraints="$venv/constraints.txt"
  /usr/bin/python3 -c 'import numpy; print(f"numpy=={numpy.__version__}")' > "$constraints"
  echo "markdown-it-py<3" >> "$constraints"
  echo "rollsim install: pip install -e $here" >&2
  "$venv/bin/pip" install -q --disable-pip-version-check --no-build-isolation \
    -c "$constraints" -e "$here"
  echo "$want" > "$stamp"
fi
