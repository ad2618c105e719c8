#!/usr/bin/env bash
# Fetches the C++ source of JSBSim 1.3.3 from PyPI's source distribution of
# the `jsbsim` package, checks it against a pinned hash and unpacks it into
# vendor/jsbsim-src/ (git-ignored). The `jsbsim` cargo feature builds from
# there, or from the folder named by JSBSIM_SRC_DIR.
#
# `--no-binary jsbsim` (not `:all:`) asks for the sdist of jsbsim alone; the
# build dependencies that pip prepares for the metadata step stay wheels.
set -euo pipefail
cd "$(dirname "$0")/.."

version=1.3.3
sha256=7b2b1f5dc3728f9c5fd98dc95da23c0b12fc31306142373f6d612ebf1a49f899
dest=vendor/jsbsim-src
unpacked="$dest/jsbsim-$version"

if [ -f "$unpacked/src/FGFDMExec.cpp" ]; then
  echo "JSBSim $version source already in $unpacked"
  exit 0
fi

command -v python3 >/dev/null 2>&1 || { echo "fetch-jsbsim: python3 (with pip) is needed" >&2; exit 1; }

download=$(mktemp -d)
trap 'rm -rf "$download"' EXIT
python3 -m pip download --quiet --no-deps --no-binary jsbsim "jsbsim==$version" -d "$download"
archive="$download/jsbsim-$version.tar.gz"
[ -f "$archive" ] || { echo "fetch-jsbsim: pip did not produce $archive" >&2; exit 1; }

echo "$sha256  $archive" | sha256sum --check --quiet - || {
  echo "fetch-jsbsim: hash mismatch for $archive" >&2; exit 1; }

mkdir -p "$dest"
tar -xzf "$archive" -C "$dest"
[ -f "$unpacked/src/FGFDMExec.cpp" ] || { echo "fetch-jsbsim: $unpacked/src/FGFDMExec.cpp missing after unpacking" >&2; exit 1; }
echo "JSBSim $version source unpacked into $unpacked"
