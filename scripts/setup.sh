#!/usr/bin/env bash
# One-step set-up of dem-orchestrator on Debian 12 (bookworm):
#   1. the engines and build tools from Debian's packages (apt-get; sudo when not root),
#   2. the Python package in ./.venv (editable, with test dependencies),
#   3. the bilinear contact-law plugin for LIGGGHTS, and LIGGGHTS rebuilt from Debian's source with
#      superquadric particles (about 6 min once), built once and cached in
#      ${DEMORCH_CACHE:-~/.cache/dem-orchestrator} (keyed by source hash and engine version).
# Every step is skipped when already done, so rerunning it costs a few seconds.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(liggghts libliggghts-dev yade python3-yade openmpi-bin mpi-default-dev g++ cmake python3-venv python3-pip)
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

missing=()
for package in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing Debian packages: ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# LIGGGHTS's own source (for the build with superquadric bricks) comes through apt-get source.
SOURCES_ENTRY=/etc/apt/sources.list.d/dem-orchestrator-src.sources
if ! grep -rqs "^Types: deb-src" /etc/apt/sources.list.d/ && ! grep -qs "^deb-src" /etc/apt/sources.list; then
  echo "setup: adding a deb-src entry for bookworm ($SOURCES_ENTRY)"
  printf 'Types: deb-src\nURIs: http://deb.debian.org/debian\nSuites: bookworm\nComponents: main\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\n' | $SUDO tee "$SOURCES_ENTRY" >/dev/null
  $SUDO apt-get update -qq
fi

PYTHON="${PYTHON:-python3}"
stamp=".venv/.installed-$(sha256sum pyproject.toml | cut -c1-16)"
if [ ! -f "$stamp" ]; then
  echo "setup: installing the Python package into .venv"
  [ -x .venv/bin/python ] || "$PYTHON" -m venv .venv
  .venv/bin/python -m pip install -q -e '.[test]' >.venv/pip.log 2>&1 || { cat .venv/pip.log; exit 1; }
  rm -f .venv/.installed-*
  touch "$stamp"
fi

if [ -x .venv/bin/demorch ]; then
  echo "setup: the compiled contact law and LIGGGHTS with superquadrics (about 6 min the first time, then cached)"
  .venv/bin/demorch build-contact >/dev/null
fi
echo "setup: ready (.venv/bin/demorch doctor shows the details)"
