#!/usr/bin/env bash
# Formats the C++ sources with clang-format 14 and the repository's .clang-format (Google style,
# 120 columns); --check changes nothing and fails listing the files that differ (CI runs it).
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-format-14 > /dev/null || scripts/deps.sh clang-format-14
mapfile -t files < <(git ls-files '*.cpp' '*.hpp' '*.inc')
if [ "${1:-}" = "--check" ]; then
  differ=()
  for f in "${files[@]}"; do
    clang-format-14 --dry-run -Werror "$f" > /dev/null 2>&1 || differ+=("$f")
  done
  if [ ${#differ[@]} -gt 0 ]; then
    printf 'not formatted (scripts/format.sh fixes them): %s\n' "${differ[@]}" >&2
    exit 1
  fi
  echo "format: ${#files[@]} files as .clang-format wants them"
else
  clang-format-14 -i "${files[@]}"
fi
