#!/usr/bin/env bash
# Installs the Debian 12 packages diachron needs, only those that are missing; runs
# 'apt-get update' only when something has to be installed. Needs root (or sudo) for the install.
set -euo pipefail

packages=(build-essential cmake libeigen3-dev libnanoflann-dev catch2 libopencv-dev libceres-dev libgdal-dev)
missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "diachron: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
"${sudo_cmd[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
