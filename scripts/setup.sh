#!/usr/bin/env bash
# Installs every Debian 12 package seavio needs, only when something is missing.
# Called by both README commands, so each works as root on a fresh machine.
set -euo pipefail
PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libopencv-dev libeigen3-dev libnanoflann-dev
  liblcm-dev liblcm-bin
  libaravis-dev aravis-tools-cli libusb-1.0-0-dev
  libsystemd-dev libyaml-cpp-dev libspdlog-dev libcli11-dev
  libgtest-dev libgmock-dev libbenchmark-dev libreaderwriterqueue-dev
  libcamera-dev
  can-utils iproute2 valgrind clang libclang-rt-14-dev systemd
)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "seavio setup: installing ${missing[*]}"
  SUDO=""; [[ $(id -u) -eq 0 ]] || SUDO="sudo"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
