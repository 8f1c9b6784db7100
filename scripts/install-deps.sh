#!/usr/bin/env bash
# Install the Debian packages listed in scripts/deps.txt that are missing.
# Idempotent: when everything is installed it changes nothing and touches no
# network (no apt-get update), so `make build` stays fast and works offline.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
list="$here/deps.txt"

# Package names: deps.txt without comments and blank lines.
mapfile -t wanted < <(sed -e 's/#.*//' -e 's/[[:space:]]//g' "$list" | grep -v '^$')

missing=()
for pkg in "${wanted[@]}"; do
    # "install ok installed" only; a removed package keeps a "deinstall ... config-files" status.
    status="$(dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null || true)"
    if [ "$status" != "install ok installed" ]; then
        missing+=("$pkg")
    fi
done

if [ "${#missing[@]}" -eq 0 ]; then
    echo "install-deps: all ${#wanted[@]} packages are installed"
    exit 0
fi

echo "install-deps: installing ${missing[*]}"

# Root runs apt-get directly; otherwise sudo when it exists (and fail clearly when it does not).
sudo=()
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then
        sudo=(sudo -n env DEBIAN_FRONTEND=noninteractive)
    else
        echo "install-deps: not root and no sudo; install as root: ${missing[*]}" >&2
        exit 1
    fi
fi

export DEBIAN_FRONTEND=noninteractive
# No stdin: CI runs without a terminal and apt must never wait for an answer.
"${sudo[@]}" apt-get update </dev/null
"${sudo[@]}" apt-get install -y --no-install-recommends "${missing[@]}" </dev/null
