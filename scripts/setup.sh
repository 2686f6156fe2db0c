#!/usr/bin/env bash
# Installs every Debian 12 package lidarfuse needs to build, test and run. Idempotent and
# non-interactive; uses sudo when not run as root. Nothing is downloaded outside apt.
# Usage: scripts/setup.sh [--demo] [--with-pcl]
#   --demo      only what building and running `lidarfuse` and `lidarfused` needs (the
#               README's first command): no test, benchmark or fuzzing tools
#   --with-pcl  also libpcl-dev, for the PCL comparison in bench/ built with
#               -DLIDARFUSE_WITH_PCL=ON; nothing else needs PCL
set -euo pipefail

# Building and running the tools and the daemon.
packages=(
    build-essential cmake ninja-build ccache pkg-config
    libeigen3-dev libnanoflann-dev libceres-dev
    libpcap-dev nlohmann-json3-dev libembree-dev libssl-dev liblzf-dev
    libspdlog-dev libyaml-cpp-dev libcpp-httplib-dev
    cyclonedds-dev libsystemd-dev procps
    libwebsocketpp-dev libasio-dev
)
# Tests, sanitizers, fuzzers and benchmarks on top.
test_packages=(
    git clang libclang-rt-dev clang-format clang-tidy cyclonedds-tools systemd
    libgtest-dev libgmock-dev libbenchmark-dev iproute2 lintian
    nodejs npm
)
demo=0
for arg in "$@"; do
    case "$arg" in
        --demo) demo=1 ;;
        --with-pcl) packages+=(libpcl-dev) ;;
        *) echo "setup: unknown option $arg (expected --demo or --with-pcl)" >&2; exit 2 ;;
    esac
done
[ "$demo" -eq 1 ] || packages+=("${test_packages[@]}")

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi

missing=()
for p in "${packages[@]}"; do
    # A node from elsewhere (e.g. NodeSource's nodejs, which bundles npm and conflicts with
    # Debian's npm package) serves the live view's test client as well.
    case "$p" in
        nodejs) command -v node >/dev/null && continue ;;
        npm) command -v npm >/dev/null && continue ;;
    esac
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -eq 0 ]; then
    echo "setup: all ${#packages[@]} packages already installed"
    exit 0
fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -q
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
