#!/usr/bin/env bash
# Packs what tests/fuzz/fork-run.sh needs to fuzz on another machine of the same architecture
# (tests/fuzz/README.md, "Fuzzing on many cores") into DIR (default .fuzzbundle, which
# .git/info/exclude should ignore): bundle.tar.xz with the 12 fuzzers of build/fuzz (FZ_TARGETS: some) (debug info
# stripped; reproduce with the build here), the libraries they load (this machine's Debian 12
# ones, found with ldd; glibc stays the host's), DCMTK's data dictionary and the seed corpora of
# `ctest --preset fuzz` (run it first); the dictionaries, the committed regressions, and
# fork-run.sh itself.
#   cmake --preset fuzz && cmake --build --preset fuzz && ctest --preset fuzz -L fuzz
#   scripts/fuzz-bundle.sh [DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
dir=$(realpath -m "${1:-.fuzzbundle}")
targets="${FZ_TARGETS:-iris_reader tiff_reader jp2k pyramid icc_profile dicom_file multipart dicom_json geojson asap_xml qido raster_map}"
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage"/{bin,lib,seeds,share}
for t in $targets; do
  strip --strip-debug -o "$stage/bin/fuzz_$t" "build/fuzz/bin/fuzz_$t"
  [ -d "build/fuzz/tests/fuzz/seeds/$t" ] || { echo "no seeds for $t: run ctest --preset fuzz -L fuzz" >&2; exit 1; }
  cp -r "build/fuzz/tests/fuzz/seeds/$t" "$stage/seeds/"
done
for t in $targets; do ldd "build/fuzz/bin/fuzz_$t" | awk '/=> \//{print $3}'; done | sort -u |
  grep -v -E '/(libc|libm|libpthread|libdl|librt|libresolv|ld-linux-x86-64)\.so' |
  while read -r l; do cp -L "$l" "$stage/lib/"; done
cp /usr/share/libdcmtk17/dicom.dic /usr/share/libdcmtk17/private.dic "$stage/share/"
rm -rf "$dir"
mkdir -p "$dir/dict"
(cd "$stage" && tar cf - bin lib seeds share) | xz -T0 -9 >"$dir/bundle.tar.xz"
cp tests/fuzz/*.dict "$dir/dict/"
cp -r tests/fuzz/regressions "$dir/regressions"
cp tests/fuzz/fork-run.sh "$dir/"
du -sh "$dir"
