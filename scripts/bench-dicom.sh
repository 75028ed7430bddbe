#!/usr/bin/env bash
# The DICOM / DICOMweb benchmark of docs/BENCHMARKS.md ("DICOM and DICOMweb", issue 15): the same
# fields read from the sample TIFF, from a DICOM copy of it made by OrthancWSIDicomizer (JPEG
# tiles copied, not re-encoded) and from that copy served by a real Orthanc on 127.0.0.1,
# each beside OpenSlide's read of the TIFF (the baseline), three iris-bench runs back to back;
# then two more of the DICOMweb series with a frame cache on disk: filling it, and read from it.
#
#   scripts/bench-dicom.sh [--bin DIR] [--work DIR] [--out DIR] [--tag NAME] [-- IRIS-BENCH OPTIONS]
#
#   --bin   the release build's bin folder (default build/release/bin: iris-bench, iris-sample)
#   --work  where the slide, its DICOM copy and Orthanc's storage go (default build/bench-dicom);
#           the slide and its DICOM copy are kept there and reused by the next run
#   --out   where the JSON goes (default docs/benchmarks)
#   --tag   the JSON names: <out>/<tag>-{tiff,dicom,dicomweb,dicomweb-fill,dicomweb-kept}.json
#           (default dicom-lavapipe)
#   --max-load L  before the runs, wait (at most --max-wait seconds, default 600) until the
#           1-minute load average is below L: on a machine shared with builds the three runs then
#           start, back to back, in a quiet moment (each run's load is printed either way)
#   after --: iris-bench's options (default --size 1920x1080 --moves 10 --magnifications 40,10
#           --color-managed off: the dicomizer gives the DICOM copy an sRGB ICC profile that the
#           TIFF lacks, so with colour management on only the DICOM runs would pay for the
#           colour transform)
#
# Needs Debian orthanc, orthanc-dicomweb, orthanc-wsi, curl and python3 (scripts/install-deps.sh).
# Orthanc runs with a generated configuration, no DICOM port, no remote access, and is stopped by
# its PID when the script ends, however it ends.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
bin=$root/build/release/bin
work=$root/build/bench-dicom
out=$root/docs/benchmarks
tag=dicom-lavapipe
max_load=
max_wait=600
bench_opts=(--size 1920x1080 --moves 10 --magnifications 40,10 --color-managed off)
while [ $# -gt 0 ]; do
    case $1 in
    --bin) bin=$(realpath "$2"); shift 2 ;;
    --work) work=$(realpath -m "$2"); shift 2 ;;
    --out) out=$(realpath -m "$2"); shift 2 ;;
    --tag) tag=$2; shift 2 ;;
    --max-load) max_load=$2; shift 2 ;;
    --max-wait) max_wait=$2; shift 2 ;;
    --) shift; bench_opts=("$@"); break ;;
    *) echo "bench-dicom.sh: unknown option $1 (see the comment at the top)" >&2; exit 2 ;;
    esac
done
for tool in "$bin/iris-bench" "$bin/iris-sample"; do
    [ -x "$tool" ] || { echo "bench-dicom.sh: $tool is not built (cmake --build build/release --target iris-bench iris-sample)" >&2; exit 1; }
done
for cmd in Orthanc OrthancWSIDicomizer curl python3; do
    command -v "$cmd" >/dev/null || { echo "bench-dicom.sh: $cmd is not installed (scripts/install-deps.sh)" >&2; exit 1; }
done
# ORTHANC_DICOMWEB_PLUGIN: the plugin elsewhere than Debian puts it (a machine given the binaries).
plugin=${ORTHANC_DICOMWEB_PLUGIN:-$(ls /usr/lib/orthanc/libOrthancDicomWeb.so* 2>/dev/null | head -n1)}
[ -n "$plugin" ] || { echo "bench-dicom.sh: the Orthanc DICOMweb plugin (orthanc-dicomweb) is missing" >&2; exit 1; }
mkdir -p "$work" "$out"

# The slide: the benchmark's sample (50000×40000, 40×, JPEG tiles), and its DICOM copy.
slide=$work/sample.tiff
if [ ! -s "$slide" ]; then
    echo "bench-dicom.sh: making $slide" >&2
    "$bin/iris-sample" --out "$slide.part" && mv "$slide.part" "$slide"
fi
dicom=$work/sample-dicom
if [ ! -e "$dicom/.complete-mpp-0.25" ]; then
    echo "bench-dicom.sh: dicomizing into $dicom (JPEG tiles copied)" >&2
    rm -rf "$dicom" && mkdir -p "$dicom"
    # The dicomizer does not read the TIFF's resolution: it writes Pixel Spacing from the imaged
    # size (15 mm × 15 mm unless told), and no Objective Lens Power. The sample is 50000 × 40000
    # px at 0.25 µm (iris-sample's defaults). OrthancWSIDicomizer 1.1 divides --imaged-width by
    # the rows and --imaged-height by the columns (measured: 12.5 and 10 gave 0.3125 \ 0.2 µm),
    # so 10 and 12.5 give the DICOM copy 0.25 µm both ways, and iris-bench maps 40× and 10× to
    # the same downsamples as on the TIFF and walks the same fields.
    OrthancWSIDicomizer --threads=2 --reencode=0 --imaged-width=10 --imaged-height=12.5 --folder="$dicom" \
        "$slide" >"$work/dicomizer.log" 2>&1
    touch "$dicom/.complete-mpp-0.25"
fi

# Orthanc on a free loopback port, storage of its own, stopped by its PID on exit.
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
orthanc_dir=$work/orthanc
rm -rf "$orthanc_dir" && mkdir -p "$orthanc_dir/storage"
cat >"$orthanc_dir/orthanc.json" <<EOF
{
  "Name": "iris-bench-dicom",
  "StorageDirectory": "$orthanc_dir/storage",
  "IndexDirectory": "$orthanc_dir/storage",
  "HttpPort": $port,
  "RemoteAccessAllowed": false,
  "DicomServerEnabled": false,
  "AuthenticationEnabled": false,
  "Plugins": ["$plugin"],
  "DicomWeb": {"Enable": true, "Root": "/dicom-web/", "EnableWado": false},
  "HttpThreadsCount": 16
}
EOF
Orthanc "$orthanc_dir/orthanc.json" >"$orthanc_dir/orthanc.log" 2>&1 &
orthanc_pid=$!
stop_orthanc() {
    if kill -0 "$orthanc_pid" 2>/dev/null; then
        kill -TERM "$orthanc_pid"
        wait "$orthanc_pid" 2>/dev/null || true
    fi
}
trap stop_orthanc EXIT
base=http://127.0.0.1:$port
for _ in $(seq 1 300); do
    curl -sf -o /dev/null "$base/system" && break
    kill -0 "$orthanc_pid" 2>/dev/null || { echo "bench-dicom.sh: Orthanc exited (see $orthanc_dir/orthanc.log)" >&2; exit 1; }
    sleep 0.1
done
curl -sf -o /dev/null "$base/system" || { echo "bench-dicom.sh: Orthanc did not answer on port $port" >&2; exit 1; }
echo "bench-dicom.sh: uploading $(ls "$dicom"/*.dcm | wc -l) files to Orthanc on port $port" >&2
for f in "$dicom"/*.dcm; do
    curl -sf -o /dev/null -H 'Content-Type: application/dicom' --data-binary "@$f" "$base/instances"
done
# The series' UIDs, from Orthanc's own REST API.
series_url=$(curl -sf "$base/series?expand" | python3 -c '
import json, sys, urllib.request
series = json.load(sys.stdin)
assert len(series) == 1, "expected one series, found %d" % len(series)
base = sys.argv[1]
study = json.load(urllib.request.urlopen(base + "/studies/" + series[0]["ParentStudy"]))
print("%s/dicom-web/studies/%s/series/%s" % (base, study["MainDicomTags"]["StudyInstanceUID"],
                                             series[0]["MainDicomTags"]["SeriesInstanceUID"]))
' "$base")
echo "bench-dicom.sh: series $series_url" >&2

# Three runs back to back, each with OpenSlide's read of the TIFF as its baseline.
if [ -n "$max_load" ]; then
    for _ in $(seq 1 "$max_wait"); do
        awk -v max="$max_load" '{ exit !($1 < max) }' /proc/loadavg && break
        sleep 1
    done
fi
quiet() { echo "bench-dicom.sh: starting $1 at load $(cut -d' ' -f1-3 /proc/loadavg)" >&2; }
quiet "the TIFF run"
"$bin/iris-bench" "$slide" "${bench_opts[@]}" --json "$out/$tag-tiff.json"
quiet "the local DICOM run"
"$bin/iris-bench" "$dicom" --baseline "$slide" "${bench_opts[@]}" --json "$out/$tag-dicom.json"
quiet "the DICOMweb run"
"$bin/iris-bench" "$series_url" --baseline "$slide" "${bench_opts[@]}" --json "$out/$tag-dicomweb.json"
# The frame cache on disk (NetworkOptions::frameCacheDirectory): a run that fills an empty one
# (what keeping the frames costs a first visit), then the same walk again, every frame kept
# (a series opened again: only its metadata comes from the server).
rm -rf "$work/frame-cache"
quiet "the DICOMweb run filling a frame cache"
"$bin/iris-bench" "$series_url" --baseline "$slide" --frame-cache "$work/frame-cache" "${bench_opts[@]}" \
    --json "$out/$tag-dicomweb-fill.json"
quiet "the DICOMweb run from the frame cache"
"$bin/iris-bench" "$series_url" --baseline "$slide" --frame-cache "$work/frame-cache" "${bench_opts[@]}" \
    --json "$out/$tag-dicomweb-kept.json"
echo "bench-dicom.sh: done at load $(cut -d' ' -f1-3 /proc/loadavg)" >&2
