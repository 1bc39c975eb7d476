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
npm_dir="$dir/npm"
if ! cmp -s tests/gltf_validator/package-lock.json "$npm_dir/package-lock.json" ||
   [ ! -d "$npm_dir/node_modules/gltf-validator" ]; then
  mkdir -p "$npm_dir"
  cp tests/gltf_validator/package.json tests/gltf_validator/package-lock.json "$npm_dir/"
  npm ci --prefix "$npm_dir" --no-audit --no-fund --loglevel=error
fi
ctest --test-dir "$dir" --output-on-failure -j"$(nproc)"
