#!/usr/bin/env bash
# Builds dsmplan and runs the whole test suite; --sanitize runs it under ASan + UBSan.
set -euo pipefail
cd "$(dirname "$0")/.."
DSMPLAN_BENCH=OFF scripts/build.sh "$@"
# The real structure-from-motion of colmap_test (ColmapBinary.*).
scripts/deps.sh colmap
# The viewer's test (tests/view_test.cpp) screenshots the page with Debian's headless Chromium.
scripts/deps.sh chromium
# The files open where users open them (tests/export_test.cpp, OpensWhereUsersOpenIt):
# CloudCompare, MeshLab and Blender, headless under Xvfb. Blender's glTF importer needs numpy,
# which Debian's blender package leaves out.
scripts/deps.sh cloudcompare meshlab blender python3-numpy xvfb xauth
# The Python module's tests (tests/python): pytest, numpy, and GDAL's own Python bindings as the oracle.
scripts/deps.sh python3-pytest python3-numpy python3-gdal
dir=build
[ "${1:-}" = "--sanitize" ] && dir=build-sanitize
# The Khronos glTF validator for the GLB tests, pinned by tests/gltf_validator/package-lock.json,
# into $dir/npm (again only when the lock file changed).
scripts/npm_pinned.sh tests/gltf_validator "$dir/npm" node_modules/gltf-validator
# CesiumJS for the 3D Tiles test (a tileset of --3dtiles loaded in headless Chromium), pinned by
# tests/cesium/package-lock.json, into $dir/cesium.
scripts/npm_pinned.sh tests/cesium "$dir/cesium" node_modules/cesium/Build/Cesium/Cesium.js
if [ "${1:-}" = "--sanitize" ]; then
  # Under the sanitizers, the suite without the tests that check other programs rather than
  # dsmplan's memory (CloudCompare, MeshLab, Blender and CesiumJS opening its files, Chromium's
  # screenshots of the viewer, a consumer project built against the installed package) and without
  # the whole-tile `data` checks, whose code the unit tests run on smaller inputs: the Release pass
  # (scripts/test.sh) runs them all. Keeps CI under its 40 minutes. Nor the service's memory soak:
  # under ASan a process's resident memory is mostly the allocator's quarantine (freed blocks held
  # back to catch their use), which grows by design; the Release pass measures dsmplan's own.
  # Nor the real COLMAP run (ColmapBinary.RealColmap...: a minute of COLMAP's own work; the
  # COLMAP readers and the fit run under the sanitizers in the other colmap tests and the fuzz pass).
  ctest --test-dir "$dir" --output-on-failure -j"$(nproc)" -LE data \
    -E 'OpensWhereUsersOpenIt|View\.(ScreenshotShows|PathUnderTheGround|PageLoads|PlansOnClick|ShowsTheService|Draws)|InstalledPackage|Serve\.ResidentMemoryStaysFlat|ColmapBinary\.RealColmap'
else
  ctest --test-dir "$dir" --output-on-failure -j"$(nproc)"
fi
