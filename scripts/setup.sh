#!/usr/bin/env bash
# The whole set-up, idempotent: Debian packages, the .venv with simgen and its dependencies,
# and the football engine (built once, cached outside the clone). A second run takes seconds.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
venv=$root/.venv

# 1. Debian packages: the engine's build and runtime needs, Open3D's libusb, and chromium (the
#    QA report's browser test).
packages=(build-essential cmake libgl1-mesa-dev libsdl2-dev libsdl2-image-dev libsdl2-ttf-dev
  libsdl2-gfx-dev libboost-python-dev libboost-system-dev libboost-filesystem-dev
  libboost-thread-dev libdirectfb-dev libst-dev mesa-utils xvfb libusb-1.0-0 patch chromium)
missing=()
for package in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${#missing[@]} Debian packages: ${missing[*]}"
  sudo_cmd=""; [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "setup: Debian packages present"
fi

# 2. The virtual environment: exactly requirements.lock (every package pinned and hashed; refreshed by
#    `make lock`), then simgen itself, editable. It is rebuilt from scratch whenever the lock or
#    pyproject.toml changes, so it never keeps a package the lock no longer names.
python=$(command -v python3.11 || command -v python3)
deps_key=$(cat requirements.lock pyproject.toml | sha256sum | cut -c1-12)
if [ ! -f "$venv/.deps-$deps_key" ]; then
  [ -d "$venv" ] && echo "setup: requirements.lock or pyproject.toml changed: rebuilding $venv" && rm -rf "$venv"
  echo "setup: creating $venv with $($python --version) and installing requirements.lock (first time: a few minutes)"
  "$python" -m venv "$venv"
  "$venv/bin/python" -m pip install --quiet --require-hashes -r requirements.lock 2> >(grep -v "WARNING: Location" >&2)
  PYTHONWARNINGS=ignore "$venv/bin/python" -m pip install --quiet --no-deps --no-build-isolation -e . 2> >(grep -v "WARNING: Location" >&2)
  touch "$venv/.deps-$deps_key"
else
  echo "setup: Python dependencies match requirements.lock"
fi

# 3. The football engine with the keypoint export.
VENV=$venv bash scripts/install_engine.sh
