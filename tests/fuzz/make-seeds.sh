#!/usr/bin/env bash
# Writes the seed corpus of fuzz_iris_reader: small valid .iris files.
#
#   tests/fuzz/make-seeds.sh [--allow-empty] BUILD_DIR OUT_DIR
#
# BUILD_DIR is a build tree holding iris-encode (the dev build: build/dev); it writes a few
# tiny synthetic slides with different sizes, quality and chroma subsampling. The reference
# fixtures of the shared test data ($IRIS_TESTDATA, $IRIS_TESTDATA_DEFAULT, or
# ../shared/testdata beside the checkout) are added when present, the small ones only
# (IRIS_FUZZ_SEED_MAX_BYTES, 256 KiB by default: mutating a bigger file mostly hits tile
# data, slowly). Copies land in OUT_DIR only, never in the repository.
#
# Fails when it finds no seed at all, unless --allow-empty (CTest's replay of the committed
# regression inputs does not need seeds). Fails when iris-encode is there but fails.
set -euo pipefail

usage() {
  echo "usage: $0 [--allow-empty] BUILD_DIR OUT_DIR" >&2
  exit 2
}
allow_empty=0
if [ "${1:-}" = "--allow-empty" ]; then
  allow_empty=1
  shift
fi
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
  # SIZE QUALITY SUBSAMPLING: one tile; a tile and a bit (edge padding, a second layer);
  # a row of partial tiles; 1 pixel.
  while read -r size quality subsampling; do
    dst="$out/encode-${size}-q${quality}-${subsampling}.iris"
    "$encoder" "synthetic:$size" -o "$dst" --quality "$quality" --subsampling "$subsampling" --threads 1 >/dev/null
  done <<'EOF'
300x200 30 420
700x300 50 444
256x256 20 422
1x1 90 444
EOF
else
  echo "make-seeds: no iris-encode in $build (build the dev preset first); using the shared fixtures only" >&2
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
  echo "make-seeds: no seeds: neither iris-encode in $build nor small fixtures in the shared test data" >&2
  [ "$allow_empty" -eq 1 ] || exit 1
fi
echo "make-seeds: $count seed(s) in $out"
