#!/usr/bin/env bash
# Writes the seed corpus of every fuzz target, one folder each: OUT_DIR/<target>/.
#
#   tests/fuzz/make-seeds.sh [--seeds-tool PATH] [--tool PATH] BUILD_DIR OUT_DIR
#
# iris_reader   BUILD_DIR's iris-encode (the dev build: build/dev) writes a few tiny synthetic
#               slides with different sizes, quality and chroma subsampling; --seeds-tool (the
#               fuzz build's fuzz_iris_seeds) writes files with every optional block and corner
#               of the format that an encoder does not produce; the small .iris fixtures of the
#               shared test data are added.
# tiff_reader   --tool (fuzz_seeds) writes TIFF/SVS files, sound and broken; the small TIFF and
#               SVS slides of the shared test data are added.
# jp2k          fuzz_seeds writes codestreams and extracts the JPEG 2000 tiles of the shared
#               Aperio slides.
# pyramid       fuzz_seeds writes broken-source descriptions.
# icc_profile   fuzz_seeds writes LittleCMS profiles and extracts the profiles embedded in the
#               shared slides (TIFF tag 34675, DICOM (0028,2000)).
# dicom_file    fuzz_seeds writes DICOM files and series; OrthancWSIDicomizer (where installed)
#               converts a TIFF seed three ways; the shared DICOM files are added, one by one
#               and as a series.
#
# The shared test data is $IRIS_TESTDATA, $IRIS_TESTDATA_DEFAULT, or ../shared/testdata beside
# the checkout; of its slides only the small ones are copied (IRIS_FUZZ_SEED_MAX_BYTES, 256 KiB
# by default: mutating a bigger file mostly hits pixel data, slowly). Copies land in OUT_DIR
# only, never in the repository.
#
# Fails when a target gets no seed at all, and when iris-encode or a seeds tool fails.
set -euo pipefail

usage() {
  echo "usage: $0 [--seeds-tool PATH] [--tool PATH] BUILD_DIR OUT_DIR" >&2
  exit 2
}
seeds_tool=""
tool=""
while [ $# -gt 0 ]; do
  case "$1" in
    --seeds-tool) [ $# -ge 2 ] || usage; seeds_tool=$2; shift 2 ;;
    --tool) [ $# -ge 2 ] || usage; tool=$2; shift 2 ;;
    -*) usage ;;
    *) break ;;
  esac
done
[ $# -eq 2 ] || usage
build=$1
out=$2
max_bytes=${IRIS_FUZZ_SEED_MAX_BYTES:-262144}
here="$(cd "$(dirname "$0")" && pwd)"
targets="iris_reader tiff_reader jp2k pyramid icc_profile dicom_file multipart dicom_json qido"

for t in $targets; do
  rm -rf "${out:?}/$t"
  mkdir -p "$out/$t"
done

slides=""
for d in "${IRIS_TESTDATA:-}" "${IRIS_TESTDATA_DEFAULT:-}" "$here/../../../shared/testdata"; do
  if [ -n "$d" ] && [ -d "$d/slides" ]; then
    slides="$d/slides"
    break
  fi
done
# The shared slides whose names end in one of the given extensions, every folder.
shared() {
  [ -n "$slides" ] || return 0
  local pattern=()
  for ext in "$@"; do pattern+=(-o -name "*.$ext"); done
  find "$slides" -type f \( "${pattern[@]:1}" \) | sort
}
# Copies the small ones of the given files into a target's folder, named after their folder.
copy_small() {
  local target=$1
  shift
  for f in "$@"; do
    if [ "$(stat -c %s "$f")" -le "$max_bytes" ]; then
      local dst
      dst="$out/$target/shared-$(basename "$(dirname "$f")")-$(basename "$f")"
      cp "$f" "$dst"
      chmod u+w "$dst"
    fi
  done
}

# --- iris_reader ------------------------------------------------------------------------
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
    dst="$out/iris_reader/encode-${size}-q${quality}-${subsampling}.iris"
    "$encoder" "synthetic:$size" -o "$dst" --quality "$quality" --subsampling "$subsampling" --threads 1 >/dev/null
  done <<'EOF'
300x200 30 420
700x300 50 444
520x260 20 422
EOF
else
  echo "make-seeds: no iris-encode in $build (build the dev preset first): no encoder seeds" >&2
fi
if [ -n "$seeds_tool" ]; then
  "$seeds_tool" "$out/iris_reader"
fi
mapfile -t files < <(shared iris)
copy_small iris_reader "${files[@]}"

# --- the other targets ----------------------------------------------------------------------
if [ -n "$tool" ]; then
  mapfile -t tiffs < <(shared svs tif tiff)
  mapfile -t dicoms < <(shared dcm)
  "$tool" tiff "$out/tiff_reader"
  copy_small tiff_reader "${tiffs[@]}"
  "$tool" jp2k "$out/jp2k" "${tiffs[@]}"
  "$tool" pyramid "$out/pyramid"
  "$tool" icc "$out/icc_profile" "${tiffs[@]}" "${dicoms[@]}"
  "$tool" dicom "$out/dicom_file"
  copy_small dicom_file "${dicoms[@]}"
  # Several files as one input (fuzz_dicom_file.cpp): the series marker, then the files with
  # the separator between them.
  as_series() {
    local dst=$1
    shift
    {
      printf 'IRIS-FUZZ-DICOM-SERIES\n'
      local first=1
      for f in "$@"; do
        [ $first -eq 1 ] || printf '\n--iris-fuzz-next-file--\n'
        first=0
        cat "$f"
      done
    } >"$dst"
  }
  if [ ${#dicoms[@]} -gt 1 ]; then
    as_series "$out/dicom_file/shared-series.bin" "${dicoms[@]}"
  fi
  # OrthancWSIDicomizer on a TIFF seed (150x100 and two levels, JPEG tiles of 48 px).
  svs="$out/tiff_reader/generic-7.tiff"
  if command -v OrthancWSIDicomizer >/dev/null; then
    tmp=$(mktemp -d)
    # OPTIONS: JPEG frames copied from the TIFF (JPEG 2000 and uncompressed frames come from
    # fuzz_seeds, smaller).
    n=0
    while read -r options; do
      n=$((n + 1))
      mkdir "$tmp/$n"
      # shellcheck disable=SC2086 # the options are words
      OrthancWSIDicomizer --threads=1 --folder="$tmp/$n" $options "$svs" >"$tmp/$n.log" 2>&1 ||
        { cat "$tmp/$n.log" >&2; echo "make-seeds: OrthancWSIDicomizer failed" >&2; exit 1; }
      mapfile -t made < <(find "$tmp/$n" -name '*.dcm' | sort)
      cp "${made[0]}" "$out/dicom_file/dicomizer-$n.dcm"
      [ ${#made[@]} -lt 2 ] || as_series "$out/dicom_file/dicomizer-$n-series.bin" "${made[@]}"
    done <<'EOF'
--reencode=0
EOF
    rm -rf "$tmp"
  fi
else
  echo "make-seeds: no --tool: no seeds for the TIFF, JPEG 2000, pyramid, ICC and DICOM targets" >&2
fi

# --- the DICOMweb source's parsers (multipart, dicom_json) -------------------------------
# Written here: a frame answer as Orthanc sends one (the first line is the message's
# Content-Type, the body follows), with one and with two parts, quoted and bare boundaries, and
# the answer to a frame list whose parts name their frames (Content-Location);
# and a WADO-RS metadata answer of a two-level TILED_FULL series with a label, series 1.2.3.4.
crlf() { sed 's/$/\r/'; }
{
  echo 'multipart/related; type="application/octet-stream"; transfer-syntax=1.2.840.10008.1.2.4.50; boundary=b0un'
  { echo '--b0un'; echo 'Content-Type: application/octet-stream; transfer-syntax=1.2.840.10008.1.2.4.50'; echo
    echo 'JPEGBYTES'; echo '--b0un--'; } | crlf
} > "$out/multipart/one-part.bin"
{
  echo 'multipart/related; type=application/octet-stream; boundary="a b"'
  { echo 'preamble'; echo '--a b'; echo 'Content-Type: application/octet-stream'; echo 'Content-Length: 5'; echo
    echo 'frame'; echo '--a b'; echo 'Content-Type: image/jpeg'; echo; echo 'second'; echo '--a b--'
    echo 'epilogue'; } | crlf
} > "$out/multipart/two-parts.bin"
{ # a frame list's answer (…/frames/3,1): each part names its frame, as Orthanc's do
  echo 'multipart/related; type="image/jpeg; transfer-syntax=1.2.840.10008.1.2.4.50"; boundary=f1'
  { echo '--f1'; echo 'Content-Location: http://h/dicom-web/studies/1/series/2/instances/3/frames/3'
    echo 'Content-Type: image/jpeg; transfer-syntax=1.2.840.10008.1.2.4.50'; echo; echo 'THIRD'
    echo '--f1'; echo 'Content-Location: http://h/dicom-web/studies/1/series/2/instances/3/frames/1'
    echo 'Content-Type: image/jpeg; transfer-syntax=1.2.840.10008.1.2.4.50'; echo; echo 'FIRST'
    echo '--f1--'; } | crlf
} > "$out/multipart/frame-list.bin"
instance() { # SOP instance, image type, total W, total H, frames
  cat <<JSON
{"00080016":{"vr":"UI","Value":["1.2.840.10008.5.1.4.1.1.77.1.6"]},
 "00080018":{"vr":"UI","Value":["$1"]},"00080008":{"vr":"CS","Value":["ORIGINAL","PRIMARY","$2","NONE"]},
 "00080070":{"vr":"LO","Value":["Iris"]},"0020000E":{"vr":"UI","Value":["1.2.3.4"]},
 "00209311":{"vr":"CS","Value":["TILED_FULL"]},"00280002":{"vr":"US","Value":[3]},
 "00280004":{"vr":"CS","Value":["YBR_FULL_422"]},"00280008":{"vr":"IS","Value":["$5"]},
 "00280010":{"vr":"US","Value":[256]},"00280011":{"vr":"US","Value":[256]},
 "00280100":{"vr":"US","Value":[8]},"00280101":{"vr":"US","Value":[8]},"00280103":{"vr":"US","Value":[0]},
 "00480006":{"vr":"UL","Value":[$3]},"00480007":{"vr":"UL","Value":[$4]},
 "00480112":{"vr":"DS","Value":[20]},
 "52009229":{"vr":"SQ","Value":[{"00289110":{"vr":"SQ","Value":[{"00280030":{"vr":"DS","Value":[0.0005,0.0005]}}]}}]},
 "00282000":{"vr":"OB","BulkDataURI":"http://fuzz/instances/$1/bulk/00282000"}}
JSON
}
{
  echo '['; instance 1.2.3.4.1 VOLUME 1000 600 12; echo ','; instance 1.2.3.4.2 VOLUME 250 150 1
  echo ','; instance 1.2.3.4.3 LABEL 240 200 1; echo ']'
} > "$out/dicom_json/series.json"
echo '[]' > "$out/dicom_json/empty-array.json"
# QIDO-RS (fuzz_qido.cpp: the first byte picks studies 'S', series 'E' or query fields 'Q'):
# answers as Orthanc 1.10 writes them, and search fields one a line.
{
  printf 'S[{"00080020":{"vr":"DA","Value":["20240103"]},"00080050":{"vr":"SH","Value":["ACC-3"]},'
  printf '"00080061":{"vr":"CS","Value":["SM"]},"00081030":{"vr":"LO","Value":["Slide study 3"]},'
  printf '"00100010":{"vr":"PN","Value":[{"Alphabetic":"Doe^Jane3"}]},"00100020":{"vr":"LO","Value":["PID3"]},'
  printf '"00100030":{"vr":"DA"},"0020000D":{"vr":"UI","Value":["1.2.276.0.7230010.3.1.2.1"]},'
  printf '"00201206":{"vr":"IS","Value":[1]},"00201208":{"vr":"IS","Value":[2]}}]'
} > "$out/qido/studies.json"
{
  printf 'E[{"00080060":{"vr":"CS","Value":["SM"]},"0008103E":{"vr":"LO","Value":["Slide 3"]},'
  printf '"0020000D":{"vr":"UI","Value":["1.2.3"]},"0020000E":{"vr":"UI","Value":["1.2.3.1"]},'
  printf '"00200011":{"vr":"IS"},"00201209":{"vr":"IS","Value":["2"]}}]'
} > "$out/qido/series.json"
printf 'QDoe^J*ne?\nPID 3\nACC-3\n20240101\n20241231\nSlide study 3\nSM\n\003' > "$out/qido/query.txt"

# --- annotations (geojson, asap_xml): the small files committed in annotation-seeds/ -------
for t in geojson asap_xml; do
  rm -rf "${out:?}/$t" && mkdir -p "$out/$t" && cp "$here/annotation-seeds/$t"/* "$out/$t/"
  echo "make-seeds: $(find "$out/$t" -maxdepth 1 -type f | wc -l) seed(s) in $out/$t"
done

status=0
for t in $targets; do
  count=$(find "$out/$t" -maxdepth 1 -type f | wc -l)
  if [ "$count" -eq 0 ]; then
    echo "make-seeds: no seeds for $t" >&2
    status=1
  else
    echo "make-seeds: $count seed(s) in $out/$t"
  fi
done
exit $status
