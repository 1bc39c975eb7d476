#!/usr/bin/env bash
# Installs the npm packages pinned by FROM/package.json and FROM/package-lock.json into
# INTO/node_modules (npm ci), again only when the lock file changed or a file the caller needs,
# CHECK (relative to INTO), is missing. Used for the viewer's three and the tests' glTF validator.
#
#   scripts/npm_pinned.sh FROM INTO CHECK
set -euo pipefail
from=$1 into=$2 check=$3
if ! cmp -s "$from/package-lock.json" "$into/package-lock.json" || [ ! -e "$into/$check" ]; then
  mkdir -p "$into"
  cp "$from/package.json" "$from/package-lock.json" "$into/"
  npm ci --prefix "$into" --no-audit --no-fund --loglevel=error
fi
