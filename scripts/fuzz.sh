#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ (clang, ASan + UBSan) in build-fuzz and runs each for
# SECONDS (default 60: the short smoke run of CI) on its committed corpus fuzz/corpus/<target>/.
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]
#   TARGET: las xyz mesh roadmap waypoints_csv waypoints_geojson pipeline laz index cameras colmap rpc airspace
#
# Environment: JOBS (build jobs, default 2), PARALLEL (targets fuzzed at once, default 2),
# MERGE=1 (afterwards, minimise the corpus plus what the run found back into fuzz/corpus/<target>;
# commit that), FUZZ_ARGS (more libFuzzer flags).
# Each run works on a copy of the corpus in build-fuzz/fuzz-runs/<target>/ (log.txt, artifacts/).
# Exit status 1 when any target found a crash, a leak, a timeout or an out-of-memory: its input is
# in build-fuzz/fuzz-runs/<target>/artifacts/; reproduce with build-fuzz/fuzz/fuzz_<target> FILE.
# libFuzzer's slow-unit-* files (inputs slower than -report_slow_units, 10 s by default, that still
# finished) are listed but are no finding: on a loaded CI machine any input can be slow once. An
# input past -timeout is a timeout-* file and a finding.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
[[ ${#targets[@]} -gt 0 ]] || targets=(las xyz mesh roadmap waypoints_csv waypoints_geojson pipeline laz index cameras colmap rpc airspace)
jobs=${JOBS:-2}
parallel=${PARALLEL:-2}
build=build-fuzz

# The build's own packages, then clang and its libFuzzer runtime (Debian 12: clang 14).
scripts/deps.sh
scripts/deps.sh clang libclang-rt-14-dev

if [[ ! -f $build/CMakeCache.txt ]]; then
  launcher=()
  command -v ccache > /dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  CC=clang CXX=clang++ cmake -S . -B "$build" -DDSMPLAN_FUZZ=ON -DDSMPLAN_BUILD_TESTS=OFF \
    -DDSMPLAN_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo "${launcher[@]}"
fi
cmake --build "$build" -j "$jobs" --target "${targets[@]/#/fuzz_}"

run() {  # target: one fuzzing session on a copy of the committed corpus
  local t=$1 dir=$build/fuzz-runs/$1
  rm -rf "$dir" && mkdir -p "$dir/corpus" "$dir/artifacts"
  cp fuzz/corpus/"$t"/* "$dir/corpus/"
  local status=0
  # -rss_limit_mb: the readers refuse, before allocating, what the machine cannot hold, and a
  # few-kB input must never need 2 GB; -timeout: no input of this size may take 10 s.
  (cd "$dir" && "../../fuzz/fuzz_$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix=artifacts/ ${FUZZ_ARGS:-} corpus > log.txt 2>&1) || status=$?
  echo "$status" > "$dir/status"
}

summary() {  # target
  local t=$1 dir=$build/fuzz-runs/$1 execs line findings slow
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/log.txt" | tail -n 1)
  line=$(grep -E '^#[0-9]+.*cov: ' "$dir/log.txt" | tail -n 1 | grep -oE 'cov: [0-9]+ ft: [0-9]+ corp: [0-9]+/[0-9]+[a-zA-Z]*' || true)
  findings=$(find "$dir/artifacts" -type f ! -name 'slow-unit-*' | wc -l)
  slow=$(find "$dir/artifacts" -type f -name 'slow-unit-*' | wc -l)
  printf '%-22s %4ss  exit %s  execs %-10s %s  findings %s%s\n' "$t" "$seconds" "$(cat "$dir/status")" "${execs:-?}" \
    "${line:-?}" "$findings" "$( ((slow)) && echo " (and $slow slow units, not counted)" || true)"
  [[ $(cat "$dir/status") == 0 && $findings == 0 ]]
}

for ((i = 0; i < ${#targets[@]}; i += parallel)); do
  for t in "${targets[@]:i:parallel}"; do run "$t" & done
  wait
done

failed=0
echo "target                  time  exit   execs       coverage                         findings"
for t in "${targets[@]}"; do summary "$t" || failed=1; done

if [[ ${MERGE:-0} == 1 ]]; then
  for t in "${targets[@]}"; do
    dir=$build/fuzz-runs/$t
    rm -rf "$dir/merged" && mkdir -p "$dir/merged"
    "$build/fuzz/fuzz_$t" -merge=1 -rss_limit_mb=2048 -timeout=10 "$dir/merged" fuzz/corpus/"$t" "$dir/corpus" \
      > "$dir/merge.txt" 2>&1
    rm -f fuzz/corpus/"$t"/* && cp "$dir/merged"/* fuzz/corpus/"$t"/
    echo "$t: corpus minimised to $(ls fuzz/corpus/"$t" | wc -l) files, $(du -sh fuzz/corpus/"$t" | cut -f1)"
  done
fi
exit $failed
