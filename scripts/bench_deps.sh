#!/usr/bin/env bash
# Installs the optional packages of the benchmarks, when any is missing: OMPL (bench_plan_ompl,
# the comparison with OMPL's PRM) and Embree 3 (its second exact collision checker).
# The normal build needs neither: bench/CMakeLists.txt skips bench_plan_ompl without OMPL.
set -euo pipefail
exec "$(dirname "$0")/deps.sh" libompl-dev libembree-dev
