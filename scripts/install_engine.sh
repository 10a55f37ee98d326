#!/usr/bin/env bash
# Builds gfootball from its PyPI source with simgen's keypoint export (engine/gfootball-keypoints.patch)
# and installs it into the venv.  The wheel is cached outside the clone, keyed by the gfootball
# version and the patch's hash, so a second set-up (or a fresh clone) installs it in seconds.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
venv=${VENV:-$root/.venv}
version=2.10.2
sdist_sha256=1b0fdcfa78b7fadc3730585ee7f0f412ba825c27e422b2b85ea0cf7ba57800b6  # PyPI's gfootball-2.10.2.tar.gz
patch_file=$root/engine/gfootball-keypoints.patch
key=$version-$(sha256sum "$patch_file" | cut -c1-12)
cache=${SIMGEN_CACHE:-$HOME/.cache/simgen}/engine/gfootball-$key
marker=$venv/.gfootball-$key

if [ -f "$marker" ]; then
  echo "engine: gfootball $key already installed"
  exit 0
fi

if ! ls "$cache"/gfootball-*.whl >/dev/null 2>&1; then
  echo "engine: building gfootball $version with the keypoint export (7-9 minutes on 2 cores; cached in $cache)"
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
  echo "gfootball==$version --hash=sha256:$sdist_sha256" > "$work/engine.txt"
  "$venv/bin/pip" download --quiet --no-deps --no-binary :all: --require-hashes -r "$work/engine.txt" -d "$work"
  tar xzf "$work/gfootball-$version.tar.gz" -C "$work"
  src=$work/gfootball-$version
  patch --quiet -p1 -d "$src" < "$patch_file"
  # The engine's build script runs `python3 -c 'import psutil'`: the venv must come first on PATH.
  # Show cmake's progress lines and keep the rest in a log for when the build fails.
  if ! PATH="$venv/bin:$PATH" "$venv/bin/pip" wheel -v --no-deps --no-build-isolation \
        -w "$work/wheel" "$src" > "$work/build.log" 2>&1 & then :; fi
  build_pid=$!
  last=""
  while kill -0 "$build_pid" 2>/dev/null; do
    sleep 5
    line=$(grep -oE '\[ *[0-9]+%\].*' "$work/build.log" | tail -n 1 || true)
    if [ -n "$line" ] && [ "$line" != "$last" ]; then echo "engine: $line"; last=$line; fi
  done
  if ! wait "$build_pid"; then
    tail -n 40 "$work/build.log" >&2
    echo "engine: gfootball build failed (log above)" >&2
    exit 1
  fi
  mkdir -p "$(dirname "$cache")"
  rm -rf "$cache.tmp" && mkdir "$cache.tmp" && cp "$work"/wheel/gfootball-*.whl "$cache.tmp/"
  rm -rf "$cache" && mv "$cache.tmp" "$cache"
fi

echo "engine: installing $(basename "$cache"/gfootball-*.whl) into $venv"
# --no-deps: gfootball asks for opencv-python (we use opencv-python-headless) and a gym whose
# wrappers break its env; what it really imports is listed in pyproject.toml.
"$venv/bin/pip" install --quiet --no-deps --force-reinstall "$cache"/gfootball-*.whl
rm -f "$venv"/.gfootball-*
touch "$marker"
