#!/usr/bin/env bash
# Refreshes requirements.lock, the exact, hashed set of every Python package the set-up installs
# (pyproject.toml's dependencies with the `test` extra, and pip, setuptools and wheel themselves):
# the newest releases that satisfy pyproject.toml, resolved by uv in a throwaway venv, with pip's
# find-links folders (this machine's CPU build of torch) searched as pip would. Run `make lock`,
# then `make test` (the set-up rebuilds .venv from the new lock), and commit the lock with the change
# that needed it.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
uv_version=0.13.9  # the resolver used to write the lock; any recent uv gives the same pins
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python=$(command -v python3.11 || command -v python3)
"$python" -m venv "$work/venv"
"$work/venv/bin/pip" install --quiet "uv==$uv_version" 2> >(grep -v "WARNING: Location" >&2)
printf 'pip\nsetuptools\nwheel\n' > "$work/installers.in"
links=()
for folder in $(pip config get global.find-links 2>/dev/null || true) ${PIP_FIND_LINKS:-}; do
  links+=(--find-links "$folder")
done
"$work/venv/bin/uv" pip compile pyproject.toml "$work/installers.in" --extra test --generate-hashes \
  --python-version 3.11 --upgrade "${links[@]}" --no-header --quiet -o "$work/requirements.lock"
{
  echo "# Every Python package the set-up installs (scripts/setup.sh: pip --require-hashes), exactly."
  echo "# Written by scripts/lock.sh (\`make lock\`) with uv $uv_version from pyproject.toml + its test extra"
  echo "# and pip, setuptools, wheel; do not edit by hand."
  sed "s#$work/installers.in#scripts/lock.sh#" "$work/requirements.lock"
} > requirements.lock
echo "lock: requirements.lock pins $(grep -cE '^[A-Za-z0-9]' requirements.lock) packages"
