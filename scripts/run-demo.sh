#!/usr/bin/env bash
# Installs what is missing, builds (release), and opens the demo viewer. With no argument it
# shows the built-in sample slide (generated once into ~/.cache/iris-viewer/); pass a slide
# path to open that instead.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
cmake --preset release >/dev/null
cmake --build --preset release
exec build/release/bin/iris-viewer "$@"
