#!/usr/bin/env bash
# Installs the Debian packages named on the command line when any is missing.
# As root it runs apt-get; otherwise it says exactly what to run and fails,
# because tests that silently skip the real driver paths would prove nothing.
set -euo pipefail
missing=()
for pkg in "$@"; do
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done
# Debian's nodejs has no npm of its own; NodeSource's bundles it.
if printf '%s\n' "$@" | grep -qx nodejs && ! command -v npm >/dev/null; then missing+=(npm); fi
[ ${#missing[@]} -eq 0 ] && exit 0
if [ "$(id -u)" -eq 0 ]; then
  echo "installing system packages: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "missing system packages: ${missing[*]}" >&2
  echo "run: sudo apt-get install ${missing[*]}   (or: sudo make sysdeps)" >&2
  exit 1
fi
