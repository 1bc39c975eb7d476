#!/usr/bin/env bash
# Builds dsmplan and runs the whole test suite; --sanitize runs it under ASan + UBSan.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh "$@"
# The viewer's test (tests/view_test.cpp) screenshots the page with Debian's headless Chromium.
scripts/deps.sh chromium
dir=build
[ "${1:-}" = "--sanitize" ] && dir=build-sanitize
# The Khronos glTF validator for the GLB tests, pinned by tests/gltf_validator/package-lock.json,
# into $dir/npm (again only when the lock file changed).
scripts/npm_pinned.sh tests/gltf_validator "$dir/npm" node_modules/gltf-validator
ctest --test-dir "$dir" --output-on-failure -j"$(nproc)"
