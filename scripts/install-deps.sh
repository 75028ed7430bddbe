#!/usr/bin/env bash
# Installs what Iris View needs to build, run and test, from Debian/Ubuntu packages.
# Idempotent: does nothing (and needs no network) when everything is already installed.
# `install-deps.sh --list` prints the list, one package a line, and installs nothing:
# scripts/check-deps.sh checks that everything the build reads comes from this list.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build ccache pkg-config
  qt6-base-dev qt6-base-dev-tools qt6-tools-dev qt6-tools-dev-tools libgl-dev
  libxcb1-dev  # the widget reads the X11 display's ICC profile (_ICC_PROFILE) on Qt's connection
  libvulkan-dev vulkan-tools mesa-vulkan-drivers vulkan-validationlayers glslang-tools
  libopenslide-dev openslide-tools libturbojpeg0-dev libtiff-dev libopenjp2-7-dev libpng-dev
  liblcms2-dev  # colour management (engine/src/color): the ICC transform, baked into a table
  # DICOM WSI (engine/src/slide/dicom_source): DCMTK parses, libjpeg decodes frames whose colour
  # space the dataset states; the tests make DICOM slides with OrthancWSIDicomizer.
  libdcmtk-dev libjpeg62-turbo-dev orthanc-wsi
  # DICOMweb (engine/src/slide/dicomweb_source, engine/src/net): libcurl speaks HTTP(S). Its tests
  # (tests/dicomweb) run a real Orthanc with the DICOMweb plugin, make a CA and certificates with
  # openssl, and terminate TLS in their own proxy with libssl (Debian 12's Orthanc cannot serve HTTPS);
  # nghttpx (nghttp2-proxy) puts HTTP/2 in front of it, since Orthanc speaks HTTP/1.1 only.
  libcurl4-openssl-dev orthanc orthanc-dicomweb openssl libssl-dev nghttp2-proxy
  zlib1g-dev  # the DICOMweb frame cache on disk checks its files with zlib's CRC-32
  libfreetype-dev libfontconfig-dev fonts-dejavu-core
  xvfb xauth gnuplot-nox
  # The fuzz preset (clang, libFuzzer). lld: configuring with clang, CMake picks ld.lld as
  # CMAKE_LINKER where it is installed and runs it (Platform/Linux.cmake, `ld.lld --help`), so
  # without it a fresh machine would configure with another linker than this one.
  clang libclang-rt-dev llvm lld
  libcli11-dev nlohmann-json3-dev
  # Annotations (engine/src/annotations): Boost.Geometry's R-tree (headers only), GEOS's C API
  # for fill triangulation (libgeos-c1v5 at run time), pugixml for ASAP XML and for the
  # OpenSlide guard's Ventana and Leica XML (libpugixml1v5).
  libboost-dev libgeos-dev libpugixml-dev
  dpkg-dev file help2man desktop-file-utils shared-mime-info
  python3 strace
)
if [ "${1:-}" = "--list" ]; then
  printf '%s\n' "${PACKAGES[@]}"
  exit 0
fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

echo "Installing: ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
