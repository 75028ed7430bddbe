#!/usr/bin/env bash
# Writes the seed corpus of fuzz_iris_reader: small valid .iris files.
#
#   tests/fuzz/make-seeds.sh [--seeds-tool PATH] BUILD_DIR OUT_DIR
#
# BUILD_DIR is a build tree holding iris-encode (the dev build: build/dev); it writes a few
# tiny synthetic slides with different sizes, quality and chroma subsampling.
# --seeds-tool is the fuzz build's fuzz_iris_seeds, which writes files with every optional
# block and corner of the format that an encoder does not produce. The reference
# fixtures of the shared test data ($IRIS_TESTDATA, $IRIS_TESTDATA_DEFAULT, or
# ../shared/testdata beside the checkout) are added when present, the small ones only
# (IRIS_FUZZ_SEED_MAX_BYTES, 256 KiB by default: mutating a bigger file mostly hits tile
# data, slowly). Copies land in OUT_DIR only, never in the repository.
#
# Fails when it finds no seed at all, and when iris-encode or the seeds tool fails.
set -euo pipefail

usage() {
  echo "usage: $0 [--seeds-tool PATH] BUILD_DIR OUT_DIR" >&2
  exit 2
}
seeds_tool=""
while [ $# -gt 0 ]; do
  case "$1" in
    --seeds-tool) [ $# -ge 2 ] || usage; seeds_tool=$2; shift 2 ;;
    -*) usage ;;
    *) break ;;
  esac
done
[ $# -eq 2 ] || usage
build=$1
out=$2
max_bytes=${IRIS_FUZZ_SEED_MAX_BYTES:-262144}
here="$(cd "$(dirname "$0")" && pwd)"

mkdir -p "$out"
rm -f "$out"/*.iris

# --- iris-encode ----------------------------------------------------------------------
encoder=""
for c in "$build/bin/iris-encode" "$build/tools/encode/iris-encode" "$build/iris-encode"; do
  if [ -x "$c" ]; then
    encoder=$c
    break
  fi
done
if [ -n "$encoder" ]; then
  # SIZE QUALITY SUBSAMPLING: a few tiles each, partial at the edges (1x1 and other corners
  # come from fuzz_iris_seeds).
  while read -r size quality subsampling; do
    dst="$out/encode-${size}-q${quality}-${subsampling}.iris"
    "$encoder" "synthetic:$size" -o "$dst" --quality "$quality" --subsampling "$subsampling" --threads 1 >/dev/null
  done <<'EOF'
300x200 30 420
700x300 50 444
520x260 20 422
EOF
else
  echo "make-seeds: no iris-encode in $build (build the dev preset first): no encoder seeds" >&2
fi

# --- fuzz_iris_seeds ------------------------------------------------------------------
if [ -n "$seeds_tool" ]; then
  "$seeds_tool" "$out"
fi

# --- the shared reference fixtures ------------------------------------------------------
fixtures=""
for d in "${IRIS_TESTDATA:-}" "${IRIS_TESTDATA_DEFAULT:-}" "$here/../../../shared/testdata"; do
  if [ -n "$d" ] && [ -d "$d/slides/iris" ]; then
    fixtures="$d/slides/iris"
    break
  fi
done
if [ -n "$fixtures" ]; then
  for f in "$fixtures"/*.iris; do
    [ -f "$f" ] || continue
    if [ "$(stat -c %s "$f")" -le "$max_bytes" ]; then
      cp "$f" "$out/fixture-$(basename "$f")"
      chmod u+w "$out/fixture-$(basename "$f")"
    fi
  done
fi

count=$(find "$out" -maxdepth 1 -name '*.iris' | wc -l)
if [ "$count" -eq 0 ]; then
  echo "make-seeds: no seeds: no iris-encode in $build, no --seeds-tool, no small fixtures in the shared test data" >&2
  exit 1
fi
echo "make-seeds: $count seed(s) in $out"
