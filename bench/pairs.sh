#!/usr/bin/env bash
# Paired, interleaved runs of two builds of one benchmark (A B A B ...), each run's output kept,
# the load average before each pair printed. Then bench/table3_ratios.py OUT turns bench_table3's
# outputs into the median of the pairs' ratios with their min-max.
#   bench/pairs.sh BEFORE_BINARY AFTER_BINARY [PAIRS=5] [OUT=out/bench/pairs] [ARGS...]
# ARGS go to both binaries (bench_table3 --low: its very-low-altitude section alone).
# e.g. git worktree add /tmp/base <commit> && (cd /tmp/base && cmake -S . -B build && cmake --build build --target bench_table3)
#      bench/pairs.sh /tmp/base/build/bench/bench_table3 build/bench/bench_table3
set -euo pipefail
before=$1 after=$2 pairs=${3:-5} out=${4:-out/bench/pairs}
shift $(($# < 4 ? $# : 4))
mkdir -p "$out"
for i in $(seq 1 "$pairs"); do
  echo "pair $i: $(uptime)"
  "$before" "$@" > "$out/before_$i.txt" 2>&1
  "$after" "$@" > "$out/after_$i.txt" 2>&1
done
