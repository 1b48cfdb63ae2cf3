#!/usr/bin/env bash
# Installs the Debian 12 packages pliant needs, only those missing (idempotent: a second run
# installs nothing and does not touch apt). Runs apt through sudo when not root.
set -euo pipefail
packages=(
  g++ cmake ninja-build pkg-config
  libeigen3-dev libtbb-dev libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libcli11-dev nlohmann-json3-dev libfmt-dev zlib1g-dev
  libosmesa6-dev libpng-dev libembree-dev
  parallel  # GNU parallel: tests/cli/cli_study_jobs.sh runs a study's job list through it
)
missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then missing+=("$p"); fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
echo "install-deps: installing ${missing[*]}"
$sudo apt-get update -qq
DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
