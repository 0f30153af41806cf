#!/usr/bin/env bash
# Installs every Debian package dfo needs (now and for the coming modules).
# Idempotent: prints one line and does nothing when all packages are present.
# Uses sudo when not root. Fails with a clear message when it cannot install.
set -euo pipefail

PACKAGES=(
  build-essential cmake ccache pkg-config make
  libeigen3-dev
  libopencv-dev
  libavformat-dev libavcodec-dev libavutil-dev libswscale-dev  # video files (dfo_io/video_reader.cc)
  libyaml-cpp-dev
  zlib1g-dev        # CRC-32 and inflate of model archives (dfo_frontend/learned/internal/zip_archive.h)
  libceres-dev libsuitesparse-dev
  libtorch-dev
  liblcm-dev liblcm-bin
  python3-torch
  googletest libgtest-dev libgmock-dev
  iproute2
  slurm-wlm munge   # dfo_sweep --slurm and its test (a throw-away local cluster, tools/local_slurm.sh)
)
# Services these packages enable on a systemd machine; the install leaves them stopped and disabled
# (dfo's test starts its own daemons with its own key, socket and ports).
SERVICES_OFF=(slurmctld slurmd munge)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

echo "install_deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO="sudo"
  else
    echo "install_deps: ERROR: not root and sudo is not available; install as root: apt-get install ${missing[*]}" >&2
    exit 1
  fi
fi
if ! command -v apt-get >/dev/null 2>&1; then
  echo "install_deps: ERROR: apt-get not found; dfo's set-up supports Debian 12 (bookworm). Needed: ${missing[*]}" >&2
  exit 1
fi

export DEBIAN_FRONTEND=noninteractive
# Another apt may hold the list lock for a while (DPkg::Lock::Timeout does not cover update): retry.
updated=0
for attempt in 1 2 3 4 5 6; do
  if $SUDO apt-get update -q; then updated=1; break; fi
  echo "install_deps: apt-get update failed (attempt $attempt), retrying in 10 s" >&2
  sleep 10
done
if [ $updated -ne 1 ]; then
  echo "install_deps: ERROR: apt-get update failed repeatedly (network or apt lock); cannot install ${missing[*]}" >&2
  exit 1
fi
if ! $SUDO apt-get install -y -q --no-install-recommends -o DPkg::Lock::Timeout=300 "${missing[@]}"; then
  echo "install_deps: ERROR: apt-get install failed for: ${missing[*]}" >&2
  exit 1
fi
# Debian enables (munge: and starts) these daemons on install; dfo wants none of them running.
if [ -d /run/systemd/system ] && command -v systemctl >/dev/null 2>&1; then
  for unit in "${SERVICES_OFF[@]}"; do
    pkg=$unit; [ "$unit" = munge ] || pkg=slurm-wlm
    if printf '%s\n' "${missing[@]}" | grep -qx "$pkg"; then
      $SUDO systemctl disable --now "$unit" >/dev/null 2>&1 || true
    fi
  done
fi
echo "install_deps: done"
