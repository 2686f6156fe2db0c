#!/usr/bin/env bash
# Builds the Debian package: lidarfuse and lidarfused in Release (build-release/, as
# scripts/demo.sh builds them), then cpack -> build-release/lidarfuse_<version>_<arch>.deb.
# Install it with `sudo apt install ./build-release/lidarfuse_*.deb`, write
# /etc/lidarfuse/station.yaml (from /usr/share/lidarfuse/config/station.example.yaml), then
# `sudo systemctl enable --now lidarfused`.
set -euo pipefail
top="$(cd "$(dirname "$0")/.." && pwd)"
bin="${1:-$top/build-release}"
"$top/scripts/build.sh" "$bin" -DCMAKE_BUILD_TYPE=Release -DLIDARFUSE_BUILD_TESTS=OFF \
    -DLIDARFUSE_BUILD_BENCH=OFF -- lidarfuse lidarfused
(cd "$bin" && cpack -G DEB)
ls "$bin"/lidarfuse_*.deb
