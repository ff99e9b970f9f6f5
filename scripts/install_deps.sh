#!/usr/bin/env bash
# Installs the Debian 12 packages diachron needs, only those that are missing; runs
# 'apt-get update' only when something has to be installed. Needs root (or sudo) for the install.
#
# Usage: scripts/install_deps.sh [--peers] [--clang]
#   --peers  also try the optional packages of the peer tools (colmap, sqlite3): the COLMAP test in
#            tests/io runs when colmap is there and is skipped otherwise, bench/peers/ needs both.
#            A peer package that cannot be installed is reported and never fails the script.
#   --clang  also install clang (scripts/clang.sh builds with it).
set -euo pipefail

packages=(build-essential cmake libeigen3-dev libnanoflann-dev catch2 libopencv-dev libceres-dev libgdal-dev libcli11-dev)
optional=()
for arg in "$@"; do
  case "$arg" in
    --peers) optional=(colmap sqlite3) ;;
    --clang) packages+=(clang) ;;
    *) echo "install_deps.sh: unknown option $arg" >&2; exit 1 ;;
  esac
done

installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }

missing=()
for p in "${packages[@]}"; do
  installed "$p" || missing+=("$p")
done
missing_optional=()
for p in "${optional[@]}"; do
  installed "$p" || missing_optional+=("$p")
done
if [ ${#missing[@]} -eq 0 ] && [ ${#missing_optional[@]} -eq 0 ]; then
  exit 0
fi
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
updated=0
if [ ${#missing[@]} -gt 0 ]; then
  echo "diachron: installing ${missing[*]}"
  "${sudo_cmd[@]}" apt-get update -qq
  updated=1
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
if [ ${#missing_optional[@]} -gt 0 ]; then
  echo "diachron: installing the optional ${missing_optional[*]}"
  {
    if [ "$updated" = 0 ]; then "${sudo_cmd[@]}" apt-get update -qq; fi
    # One at a time, so that one that cannot be installed does not keep the other out.
    for p in "${missing_optional[@]}"; do
      DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "$p" ||
        echo "diachron: the optional package $p could not be installed; what needs it is skipped"
    done
  } || echo "diachron: the optional packages could not be installed; what needs them is skipped"
fi
exit 0
