#!/bin/bash
# Fuzzes all targets at once on a machine of many cores, in libFuzzer's fork mode (README.md,
# "Fuzzing on many cores"). It runs from the folder scripts/fuzz-bundle.sh fills (bundle.tar.xz:
# the fuzzers, their Debian libraries, DCMTK's dictionary, the seeds; dict/; regressions/; this
# script), so that it needs nothing of the checkout it runs in:
#   bash BUNDLE/fork-run.sh trial|main SECONDS [OUT]
# trial: every target alone for 5 s (does it start, with these libraries?), then SECONDS of
# fork-mode fuzzing; main: SECONDS of fork-mode fuzzing. Each target gets the workers of TABLE,
# -timeout=10 -rss_limit_mb=2048 and the dictionary as CI fuzzes it, crashes, timeouts and OOMs
# kept and ignored. Corpora grow in /tmp/fz/corpus/<target>, kept between calls on one machine.
# Into OUT ($OUT by default): res-MODE.tar.xz (logs with each target's CPU time, at most 30
# artifacts of each kind per target) and, after main, the corpora as corp.tar.xz.0, .1, …
# (15 MiB pieces). FZ_ONLY="t1 t2" keeps some targets, FZ_N=n forces n workers (tests).
set -u
mode=$1
secs=$2
out=${3:-$OUT}
D=$(cd "$(dirname "$0")" && pwd)
B=/tmp/fzb
W=/tmp/fz
if [ ! -d $B/bin ]; then
  rm -rf $B && mkdir -p $B && tar xJf "$D/bundle.tar.xz" -C $B || exit 3
fi
mkdir -p $W/log $W/art
export DCMDICTPATH=$B/share/dicom.dic:$B/share/private.dic
# The bundle's libraries for the fuzzers only: the host's own tools keep the host's.
run() {
  local t=$1
  shift
  LD_LIBRARY_PATH=$B/lib exec "$B/bin/fuzz_$t" "$@"
}
echo "host: $(nproc) cpus, $(free -g | awk '/Mem/{print $2}') GiB; /dev/shm: $(df -h /dev/shm | tail -1)"
# TARGET DICTIONARY WORKERS: 68 workers for 64 cores (the fork-mode parents mostly wait).
TABLE="iris_reader iris.dict 7
tiff_reader tiff.dict 4
jp2k jp2k.dict 5
pyramid - 6
icc_profile icc.dict 6
dicom_file dicom.dict 5
multipart - 7
dicom_json - 7
geojson geojson.dict 7
asap_xml asap_xml.dict 7
qido - 7
raster_map raster.dict 7"
[ -n "${FZ_ONLY:-}" ] && TABLE=$(grep -wE "^(${FZ_ONLY// /|})" <<<"$TABLE")
[ -n "${FZ_N:-}" ] && TABLE=$(awk -v n="$FZ_N" '{print $1, $2, n}' <<<"$TABLE")
args() { # TARGET DICTIONARY
  [ "$2" = - ] || echo "-dict=$D/dict/$2"
  echo "-timeout=10 -rss_limit_mb=2048 -artifact_prefix=$W/art/$1/ $W/corpus/$1 $B/seeds/$1 $D/regressions/$1"
}
while read -r t d n; do mkdir -p $W/corpus/$t $W/art/$t; done <<<"$TABLE"
if [ "$mode" = trial ]; then
  while read -r t d n; do
    (
      timeout 40 bash -c "$(declare -f run); B=$B; run $t $(args $t $d | tr '\n' ' ') -max_total_time=5 -print_final_stats=1" \
        >$W/log/check-$t.log 2>&1
      echo "check $t rc=$? $(grep -E '^#[0-9]+.*DONE' $W/log/check-$t.log | tail -1)"
    ) &
  done <<<"$TABLE"
  wait
fi
start=$(date +%s)
while read -r t d n; do
  # bash's time: user and sys of the fork-mode parent and every job it ran and waited for.
  (
    TIMEFORMAT="%U %S %R"
    time timeout -k 5 $((secs + 40)) bash -c "$(declare -f run); B=$B; run $t $(args $t $d | tr '\n' ' ') -fork=$n \
      -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 -max_total_time=$secs" >$W/log/$mode-$t.log 2>&1
  ) 2>$W/log/$mode-$t.time &
done <<<"$TABLE"
wait
echo "fork phase: $(($(date +%s) - start)) s wall"
while read -r t d n; do
  L=$W/log/$mode-$t.log
  a=$W/art/$t
  echo "== $t x$n cpu(user sys wall)=$(tail -1 $W/log/$mode-$t.time) corpus=$(ls $W/corpus/$t | wc -l)" \
    "art: crash=$(ls $a | grep -c '^crash-') timeout=$(ls $a | grep -c '^timeout-') oom=$(ls $a | grep -c '^oom-')" \
    "leak=$(ls $a | grep -c '^leak-') slow=$(ls $a | grep -c '^slow-unit-')"
  grep -E '^#[0-9]+: cov:' $L | tail -1
  grep -E 'INFO: exiting|INFO: fuzzed for' $L | tail -2
done <<<"$TABLE"
for a in $W/art/*; do
  for k in crash timeout oom leak slow-unit; do
    ls -S -r $a | grep "^$k-" | tail -n +31 | while read -r f; do rm -f "$a/$f"; done
  done
done
(cd $W && tar cf - log art | xz -T0 -6 >"$out/res-$mode.tar.xz")
if [ "$mode" = main ]; then
  (cd $W && tar cf - corpus | xz -T0 -6 >$W/corp.tar.xz)
  split -b 15M -d -a 1 $W/corp.tar.xz "$out/corp.tar.xz."
fi
ls -la "$out"
