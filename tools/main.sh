#!/usr/bin/env bash
# The main job: installs on first use, then runs the default study and ends in a report.
# Until the finite-element study lands, this is the analytic design study.
#   tools/main.sh [OUT_DIR]      (default out/design)
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
out=${1:-$_rollsim_root/out/design}
rollsim design --out "$out"
echo "report: $out/report.md"
