#!/usr/bin/env bash
# Installs what is missing, builds, and runs every test:
#   0. after the debug build, the dependency check (scripts/check-deps.py): every file under /usr
#      that configuring, building and running read must come from a package that
#      scripts/install-deps.sh brings in, so that a machine with extra packages cannot hide a
#      missing one; it runs again over the sanitizer, fuzz and release trees at the end;
#   1. the debug build (dev preset): every suite, with the Vulkan validation layers on
#      (lavapipe is the device; widget suites run under Xvfb);
#   2. the AddressSanitizer + UBSan build (asan preset): the suites labelled "asan"
#      (open/close/reopen cycles, bad input, the API storm), where LeakSanitizer reports leaks;
#   3. the ThreadSanitizer build (tsan preset, engine only): the suites labelled "tsan"
#      (the lock-free tile map under concurrent pin/reclaim, the API storm, DICOM reads);
#   4. the fuzz build (fuzz preset: clang, libFuzzer, ASan + UBSan, the readers and decoders
#      only): every target's seed corpus and committed regression inputs replayed (CTest label
#      "fuzz"), then IRIS_FUZZ_SECONDS (120) of fuzzing per target, one target per core; any crash, leak, timeout,
#      sanitizer report or broken promise fails (see tests/fuzz/README.md);
#   5. the Debian packages (scripts/test-deb.sh): the release build packed by cpack, installed
#      with apt-get, its programs run, outside projects built against /usr, then purged.
# Exits non-zero if anything fails.
set -euo pipefail
cd "$(dirname "$0")/.."

# Each stage's wall time, printed at the end (also when a stage fails), so that CI's output
# says where its time went (CI must stay under 45 minutes on a warm machine).
stage_name="" stage_start=$SECONDS stage_log=""
stage() {
  [ -z "$stage_name" ] || stage_log+="$(printf '%6d s  %s' $((SECONDS - stage_start)) "$stage_name")"$'\n'
  stage_name="$1" stage_start=$SECONDS
  [ -z "$1" ] || echo "== $1"
}
stage_report() {
  stage ""
  printf '== stage times\n%s%6d s  in all\n' "$stage_log" "$SECONDS"
}
trap stage_report EXIT

# Five build trees (dev, asan, tsan, fuzz, release) share one compiler cache, and it holds all
# five (ccache's default 5 GB evicted some between runs). Clones at other paths hit it only with
# both settings: CCACHE_BASEDIR makes the command lines' paths relative, and CCACHE_NOHASHDIR
# keeps the build directory out of the hash, which ccache otherwise adds for every -g compile
# (without it a clone at a new path rebuilt all five trees cold: 833 s + 2253 s for dev + asan).
# The price is that an object's debug info may name the directory of the clone that compiled it.
export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}" CCACHE_MAXSIZE="${CCACHE_MAXSIZE:-10G}" CCACHE_NOHASHDIR=1

stage "install dependencies"
scripts/install-deps.sh

export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
JOBS="$(nproc)"
# Suites run two at a time: most of them keep one core busy (a CPU reference, a parser, a test
# thread waiting on lavapipe), so two at once nearly halve the test stages on CI's two cores.
# What must not overlap says so in CTest: RESOURCE_LOCK iris_x_display (windows read back from
# the X server), RESOURCE_LOCK <program> (suites of one program share its files), PROCESSORS 2
# (suites whose threads use both cores) and RUN_SERIAL (the soak's memory bounds). Not more
# than two: that is what those properties were checked with, on two cores.
TEST_JOBS=$(( JOBS < 2 ? JOBS : 2 ))

stage "dev build"
cmake --preset dev >/dev/null
cmake --build --preset dev -j "$JOBS"
stage "dependency check"
scripts/check-deps.py
stage "dev tests"
xvfb-run -a -s "-screen 0 1920x1080x24" ctest --preset dev -j "$TEST_JOBS"

# The programs the suites labelled $2 run in build tree $1, read from the CTestTestfile.cmake
# files its configure wrote (CTest itself leaves out a test whose program is not built yet),
# so that a new suite with the label is built with no list here to forget: a hand-kept list
# once left iris.bytes, dicomweb.qido and the annotation suites configured but unbuilt.
suite_targets() {
  python3 - "$1" "$2" <<'PY'
import os, re, sys
tree, label = sys.argv[1], sys.argv[2]
commands, labels = {}, {}
for d, _, files in os.walk(tree):
    if "CTestTestfile.cmake" not in files:
        continue
    text = open(os.path.join(d, "CTestTestfile.cmake"), encoding="utf-8").read()
    for name, args in re.findall(r'add_test\(\[=\[(.+?)\]=\]\s+(.*)\)\s*$', text, re.M):
        commands[name] = re.findall(r'"([^"]*)"', args)
    for name, labs in re.findall(r'set_tests_properties\(\[=\[(.+?)\]=\] PROPERTIES .*?LABELS "([^"]*)"', text):
        labels[name] = labs.split(";")
names = {os.path.basename(a) for t, cmd in commands.items() if label in labels.get(t, [])
         for a in cmd if "/bin/" in a and os.path.basename(a).startswith(("tst_", "iris-"))}
if not names:
    sys.exit("run-tests.sh: no programs found for the suites labelled " + label + " in " + tree)
print(" ".join(sorted(names)))
PY
}

stage "asan build"
cmake --preset asan >/dev/null
# Only what the "asan" suites run (and their fixtures), to keep CI short.
asan_targets=$(suite_targets build/asan asan)
cmake --build --preset asan -j "$JOBS" --target iris_no_dlclose iris-sample $asan_targets
stage "asan tests"
# (the sanitizer options and the LeakSanitizer suppressions come from tests/CMakeLists.txt)
xvfb-run -a -s "-screen 0 1920x1080x24" ctest --preset asan -L asan -j "$TEST_JOBS"

stage "tsan build"
cmake --preset tsan >/dev/null
tsan_targets=$(suite_targets build/tsan tsan)
cmake --build --preset tsan -j "$JOBS" --target iris-sample $tsan_targets
stage "tsan tests"
ctest --preset tsan -L tsan -j "$TEST_JOBS"

stage "fuzz build"
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz -j "$JOBS"
stage "fuzz tests"
# fuzz.seeds writes each target's seed corpus to build/fuzz/tests/fuzz/seeds/<target> (the seed
# tools, iris-encode of the dev build above, the small shared slides); the replays run it and
# tests/fuzz/regressions/<target> through the target once.
ctest --preset fuzz -L fuzz -j 1
stage "fuzzing"
FUZZ_SECONDS="${IRIS_FUZZ_SECONDS:-120}"
FUZZ=build/fuzz
# TARGET DICTIONARY SHARE (- for no dictionary): each fuzzed for SHARE × FUZZ_SECONDS (every
# target the whole time, as issue 14 asks; the share is there to give one less when CI's time
# needs it); corpus/<target> (kept between runs of this build tree) takes what a run finds new.
# libFuzzer fuzzes in one process on one core, so the targets run $JOBS at a time, each into
# its own log, reported when it ends. A failing target does not stop the others; the stage
# fails at the end, naming them.
fuzz_one() {
  local target="$1" dict="$2" seconds="$3"
  mkdir -p "$FUZZ/corpus/$target" "$FUZZ/artifacts/$target"
  local dict_arg=()
  [ "$dict" = "-" ] || dict_arg=(-dict="$dict")
  "$FUZZ/bin/fuzz_$target" "${dict_arg[@]}" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
      -artifact_prefix="$FUZZ/artifacts/$target/" -print_final_stats=1 \
      "$FUZZ/corpus/$target" "$FUZZ/tests/fuzz/seeds/$target" "tests/fuzz/regressions/$target" \
      >"$FUZZ/fuzz-$target.log" 2>&1 </dev/null
}
fuzz_failed=""
declare -A fuzz_pids=()
# Reports and forgets every target whose fuzzer has ended.
fuzz_reap() {
  local t rc log
  for t in "${!fuzz_pids[@]}"; do
    kill -0 "${fuzz_pids[$t]}" 2>/dev/null && continue
    rc=0
    wait "${fuzz_pids[$t]}" || rc=$?
    unset "fuzz_pids[$t]"
    log="$FUZZ/fuzz-$t.log"
    echo "== fuzzed $t"
    if [ "$rc" -eq 0 ]; then
      grep -E "INITED|DONE|^Done|stat::" "$log" || true
    else
      tail -n 100 "$log"
      echo "fuzz_$t failed (log: $log). The input that did it is in $FUZZ/artifacts/$t/;"
      echo "reproduce with: $FUZZ/bin/fuzz_$t $FUZZ/artifacts/$t/FILE"
      fuzz_failed="$fuzz_failed $t"
    fi
  done
}
while read -r target dict share; do
  while [ "${#fuzz_pids[@]}" -ge "$JOBS" ]; do
    wait -n || true
    fuzz_reap
  done
  seconds=$(( FUZZ_SECONDS * ${share%/*} / ${share#*/} ))
  echo "== fuzzing $target (${seconds} s)"
  fuzz_one "$target" "$dict" "$seconds" &
  fuzz_pids[$target]=$!
done <<'EOF'
iris_reader tests/fuzz/iris.dict 1/1
tiff_reader tests/fuzz/tiff.dict 1/1
jp2k tests/fuzz/jp2k.dict 1/1
pyramid - 1/1
icc_profile tests/fuzz/icc.dict 1/1
dicom_file tests/fuzz/dicom.dict 1/1
multipart - 1/1
dicom_json - 1/1
geojson tests/fuzz/geojson.dict 1/1
asap_xml tests/fuzz/asap_xml.dict 1/1
qido - 1/1
raster_map tests/fuzz/raster.dict 1/1
EOF
while [ "${#fuzz_pids[@]}" -gt 0 ]; do
  wait -n || true
  fuzz_reap
done
if [ -n "$fuzz_failed" ]; then
  echo "fuzzing failed:$fuzz_failed"
  exit 1
fi

stage "Debian packages"
scripts/test-deb.sh

stage "dependency check of the sanitizer, fuzz and release builds"
scripts/check-deps.py --preset asan --preset tsan --preset fuzz --preset release --no-runtime
