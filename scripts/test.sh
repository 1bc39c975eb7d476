#!/usr/bin/env bash
# Builds dsmplan and runs the whole test suite; --sanitize runs it under ASan + UBSan.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh "$@"
dir=build
[ "${1:-}" = "--sanitize" ] && dir=build-sanitize
ctest --test-dir "$dir" --output-on-failure -j"$(nproc)"
