#!/usr/bin/env bash
# Configures and builds dsmplan into build/ (Release), or with --sanitize into build-sanitize/
# (AddressSanitizer + UndefinedBehaviorSanitizer, tests only). DSMPLAN_TARGETS="a b" builds those
# targets only (scripts/sample.sh: what it runs), without the viewer's npm packages.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
dir=build
[ "${1:-}" = "--sanitize" ] && dir=build-sanitize
targets=()
[ -n "${DSMPLAN_TARGETS:-}" ] && read -r -a targets <<< "--target $DSMPLAN_TARGETS"
if [ ${#targets[@]} -eq 0 ]; then
  # three for the 3D viewer (dsmplan view), pinned by web/viewer/package-lock.json, into
  # $dir/web/viewer/node_modules beside the page the build copies there (only when the lock changed).
  scripts/deps.sh --npm
  scripts/npm_pinned.sh web/viewer "$dir/web/viewer" node_modules/three/build/three.module.js
fi
if [ "${1:-}" = "--sanitize" ]; then
  # -O1 -g1: the optimisation AddressSanitizer's manual advises, and line tables only, enough for
  # the sanitizers' reports. -O1 compiles in two thirds of -O2's time under the sanitizers
  # (export_test.cpp: 89 s, not 135 s; xy3_delaunay.cpp: 22 s, not 31 s), and CI was past its
  # 60 minutes.
  # UBSan without its alignment and null checks: those two instrument every access through a
  # pointer and doubled the build (xy3_delaunay.cpp: 33 s, 16 s without them), which took CI past
  # its 40 minutes. ASan reports a null access itself (SEGV on address 0, with the stack), and the
  # fuzz pass (scripts/fuzz.sh: clang, full UBSan, alignment included) runs every parser and the
  # whole pipeline with them.
  cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDSMPLAN_BUILD_BENCH=OFF \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
    -DCMAKE_CXX_FLAGS="-fsanitize=address,undefined -fno-sanitize=alignment,null -fno-sanitize-recover=undefined -fno-omit-frame-pointer" >/dev/null
  cmake --build build-sanitize -j"$(nproc)"
else
  # DSMPLAN_BENCH=OFF (scripts/test.sh): the test suite does not need the benchmarks.
  cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DDSMPLAN_BUILD_BENCH="${DSMPLAN_BENCH:-ON}" >/dev/null
  cmake --build build -j"$(nproc)" "${targets[@]}"
fi
