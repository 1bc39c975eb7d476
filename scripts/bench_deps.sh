#!/usr/bin/env bash
# Installs the optional packages of the benchmarks, when any is missing: OMPL (bench_plan_ompl,
# the comparison with OMPL's PRM), Embree 3 (its second exact collision checker) and OpenCV
# (bench_sgm and bench_stereo: its StereoSGBM beside dsmplan's SGM).
# The normal build needs none: bench/CMakeLists.txt skips bench_plan_ompl without OMPL, and the
# stereo benches measure dsmplan alone without OpenCV.
set -euo pipefail
exec "$(dirname "$0")/deps.sh" libompl-dev libembree-dev libopencv-dev
