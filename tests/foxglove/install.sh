#!/usr/bin/env bash
# Installs the Foxglove client that tests/daemon/lidarfused_foxglove_test.cpp runs into
# BUILD/foxglove-client with `npm ci`: exactly the versions of package-lock.json beside this
# file, from the npm registry; node_modules lives in the build folder, never in the repo.
# Usage: tests/foxglove/install.sh BUILD_DIR
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
dest="$1/foxglove-client"
mkdir -p "$dest"
cp "$here/package.json" "$here/package-lock.json" "$dest/"
cd "$dest"
npm ci --no-audit --no-fund --loglevel=error
