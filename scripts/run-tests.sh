#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test:
#   1. the debug build (dev preset): every suite, with the Vulkan validation layers on
#      (lavapipe is the device; widget suites run under Xvfb);
#   2. the AddressSanitizer + UBSan build (asan preset): the suites labelled "asan"
#      (open/close/reopen cycles, bad input, the API storm), where LeakSanitizer reports leaks;
#   3. the ThreadSanitizer build (tsan preset, engine only): the suites labelled "tsan"
#      (the lock-free tile map under concurrent pin/reclaim, the API storm).
# Exits non-zero if anything fails.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh

export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
JOBS="$(nproc)"

echo "== dev build"
cmake --preset dev >/dev/null
cmake --build --preset dev -j "$JOBS"
echo "== dev tests"
xvfb-run -a -s "-screen 0 1920x1080x24" ctest --preset dev -j 1

echo "== asan build"
cmake --preset asan >/dev/null
# Only what the "asan" suites run (and their fixtures), to keep CI short.
cmake --build --preset asan -j "$JOBS" --target iris_no_dlclose iris-sample tst_bad_input tst_lifecycle tst_tile_map tst_storm \
  tst_iris_reader tst_irisslideview tst_quit_midzoom
echo "== asan tests"
# (the sanitizer options and the LeakSanitizer suppressions come from tests/CMakeLists.txt)
xvfb-run -a -s "-screen 0 1920x1080x24" ctest --preset asan -L asan -j 1

echo "== tsan build"
cmake --preset tsan >/dev/null
cmake --build --preset tsan -j "$JOBS" --target iris-sample tst_tile_map tst_storm
echo "== tsan tests"
ctest --preset tsan -L tsan -j 1
