#!/usr/bin/env bash
# Packs what docs/GPU-RUNS.md runs on the GPU machine into .dev/bundle.tar.xz (ignored): the
# programs and engine suites of a release tree with tests (build/gpu), the libraries they load
# (this machine's Debian 12 ones, found with ldd; glibc stays the host's), the Khronos
# validation layer, the test slides and a font with a fontconfig file. With BASE=DIR, also
# DIR/bin/iris-bench and DIR/lib/libiris_engine.so* under base/, for an A/B in one session
# (BASE="DIR1:NAME1 DIR2:NAME2": several, each under its NAME/).
#   cmake --preset release -B build/gpu -DIRIS_BUILD_TESTS=ON -DIRIS_BUILD_WIDGET=OFF -DIRIS_MAN_PAGES=OFF
#   cmake --build build/gpu && scripts/gpu-bundle.sh
set -euo pipefail
cd "$(dirname "$0")/.."
b=.dev/bundle
rm -rf $b
mkdir -p $b/bin $b/lib $b/layers $b/fonts $b/testdata/slides
cp build/gpu/bin/* $b/bin/
cp -P build/gpu/lib/libiris_engine.so* $b/lib/
programs=($b/bin/*)
# BASE: one or more (space-separated) DIR or DIR:NAME; each goes under NAME/ (default base/).
for spec in ${BASE:-}; do
  dir=${spec%%:*}
  name=base
  [ "$spec" != "$dir" ] && name=${spec#*:}
  mkdir -p $b/$name/bin $b/$name/lib
  cp "$dir/bin/iris-bench" $b/$name/bin/
  cp -P "$dir"/lib/libiris_engine.so* $b/$name/lib/
  programs+=($b/$name/bin/iris-bench)
done
layer=/usr/lib/x86_64-linux-gnu/libVkLayer_khronos_validation.so
for f in "${programs[@]}" $layer; do ldd "$f" | awk '/=> \//{print $3}'; done | sort -u |
  grep -v -E '/(libc|libm|libpthread|libdl|librt|ld-linux-x86-64)\.so|libiris_' |
  while read -r l; do cp -L "$l" $b/lib/; done
cp $layer $b/lib/
cp /usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json $b/layers/
testdata=${IRIS_TESTDATA:-../shared/testdata}
cp -r "$testdata/slides/aperio" "$testdata/slides/generic-tiff" $b/testdata/slides/
cp /usr/share/fonts/truetype/dejavu/DejaVuSans.ttf $b/fonts/
# DCMTK's data dictionary (DCMDICTPATH=/tmp/b/dicom.dic there), for the DICOM reader's suites.
cp /usr/share/libdcmtk17/dicom.dic $b/
cat > $b/fonts/fonts.conf <<'CONF'
<?xml version="1.0"?>
<!DOCTYPE fontconfig SYSTEM "fonts.dtd">
<fontconfig><dir>/tmp/b/fonts</dir><cachedir>/tmp/fc-cache</cachedir></fontconfig>
CONF
tar -C $b -cJf .dev/bundle.tar.xz .
echo "gpu-bundle: $(du -h .dev/bundle.tar.xz | cut -f1) in .dev/bundle.tar.xz; unpack it to /tmp/b there"
