#!/usr/bin/env bash
# Builds and runs three outside projects against an installed Iris View:
#   engine   find_package(IrisView COMPONENTS Engine), headless: renders a frame, checks pixels
#   pkgconf  the same program built with `pkg-config iris-engine` alone
#   widget   find_package(IrisView COMPONENTS Widget): an IrisSlideView on screen (needs DISPLAY)
#
#   consumers.sh --prefix P --work DIR --slide SLIDE [--install-from BUILD]
# --install-from installs BUILD into P first (cmake --install) and checks that nothing was
# written outside P. Used by CTest (install.consumers, a temporary prefix) and by
# scripts/test-deb.sh (P=/usr, the installed .deb).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
prefix="" work="" slide="" build=""
while [ $# -gt 0 ]; do
  case $1 in
    --prefix) prefix=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --slide) slide=$2; shift 2 ;;
    --install-from) build=$2; shift 2 ;;
    *) echo "consumers.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done
[ -n "$prefix" ] && [ -n "$work" ] && [ -n "$slide" ] || { echo "consumers.sh: --prefix, --work and --slide are required" >&2; exit 2; }
[ -n "${DISPLAY:-}" ] || { echo "consumers.sh: no DISPLAY for the widget consumer (run under xvfb-run)"; exit 77; }

rm -rf "$work"
mkdir -p "$work"
if [ -n "$build" ]; then
  rm -rf "$prefix"
  echo "== cmake --install $build --prefix $prefix"
  cmake --install "$build" --prefix "$prefix" >"$work/install.log"
  # Every file lands under the prefix (a staged install must not leak onto the system).
  outside=$(grep -v "^$prefix/" "$build/install_manifest.txt" || true)
  if [ -n "$outside" ]; then
    echo "consumers.sh: cmake --install wrote outside the prefix:"; echo "$outside"; exit 1
  fi
fi

for name in engine widget; do
  echo "== $name consumer: configure and build against $prefix"
  cmake -S "$here/consumers/$name" -B "$work/$name" -G Ninja -DCMAKE_BUILD_TYPE=Release \
        -DCMAKE_PREFIX_PATH="$prefix" >"$work/$name.configure.log" || { cat "$work/$name.configure.log"; exit 1; }
  cmake --build "$work/$name" >"$work/$name.build.log" || { cat "$work/$name.build.log"; exit 1; }
done
echo "== pkg-config consumer"
pc_path=$(find "$prefix" -path '*/pkgconfig/iris-engine.pc' -printf '%h\n' -quit)
[ -n "$pc_path" ] || { echo "consumers.sh: no iris-engine.pc under $prefix"; exit 1; }
"$here/consumers/engine/pkgconfig-build.sh" "$work/pkgconfig_consumer" "$pc_path"

echo "== run"
"$work/engine/engine_consumer" "$slide"
"$work/pkgconfig_consumer" "$slide"
env -u QT_QPA_PLATFORM "$work/widget/widget_consumer" "$slide"
echo "consumers.sh: the engine (CMake and pkg-config) and widget consumers built and ran against $prefix"
