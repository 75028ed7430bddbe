#!/usr/bin/env bash
# Builds the Debian packages (release preset, cpack), installs them on this machine with apt-get,
# checks what a user gets, and removes them again:
#   - Depends computed by dpkg-shlibdeps, with a Vulkan driver and Qt's platform plugins added;
#   - /usr/bin/iris-render renders the sample slide; every program answers --version, the
#     viewer with no display;
#   - a man page for each program; the .desktop entry is valid and the file manager's caches
#     (shared-mime-info, desktop-file-utils, via dpkg triggers) map .svs, .ndpi, .mrxs, .scn,
#     .tif(f) and .iris files to the viewer;
#   - outside projects build against /usr (tests/install/consumers.sh: CMake and pkg-config)
#     and run;
#   - after removal nothing of the packages is left.
# scripts/run-tests.sh runs it last. It needs root (or sudo) and refuses to touch an iris-view
# that was installed by something else.
set -euo pipefail
cd "$(dirname "$0")/.."
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
# (as a desktop session would give it; without one libwayland, which the Vulkan loader's
# surface probing loads, complains on every start)
if [ -z "${XDG_RUNTIME_DIR:-}" ] || [ ! -d "$XDG_RUNTIME_DIR" ]; then
  XDG_RUNTIME_DIR=$(mktemp -d)
  export XDG_RUNTIME_DIR
fi

fail() { echo "test-deb: $*" >&2; exit 1; }

for pkg in iris-view iris-view-dev; do
  if dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    fail "$pkg is already installed on this machine; remove it first (this test installs and removes its own build)"
  fi
done

echo "== release build and cpack"
cmake --preset release >/dev/null
cmake --build --preset release -j "$(nproc)"
rm -rf build/packages
cpack --preset release >build/release/cpack.log 2>&1 || { cat build/release/cpack.log; fail "cpack failed"; }
version=$(sed -n 's/^CMAKE_PROJECT_VERSION:STATIC=//p' build/release/CMakeCache.txt)
deb=build/packages/iris-view_${version}_amd64.deb
devdeb=build/packages/iris-view-dev_${version}_amd64.deb
[ -f "$deb" ] && [ -f "$devdeb" ] || fail "cpack made $(ls build/packages), expected $(basename "$deb") and $(basename "$devdeb")"

echo "== package metadata"
depends=$(dpkg-deb -f "$deb" Depends)
echo "iris-view Depends: $depends"
for want in "libc6" "libvulkan1" "libqt6widgets6" "libopenslide0" "libturbojpeg0" "mesa-vulkan-drivers | vulkan-icd" "qt6-qpa-plugins"; do
  case ", $depends," in *", $want"*) ;; *) fail "iris-view's Depends lack $want" ;; esac
done
echo "iris-view-dev Depends: $(dpkg-deb -f "$devdeb" Depends)"

cleanup() {
  $SUDO apt-get purge -y -qq iris-view iris-view-dev >/dev/null 2>&1 || true
}
trap cleanup EXIT

echo "== apt-get install"
$SUDO apt-get install -y -qq --no-install-recommends "./$deb" "./$devdeb" >build/packages/install.log 2>&1 ||
  { cat build/packages/install.log; fail "apt-get install failed"; }

echo "== the installed programs"
for prog in iris-render iris-bench iris-encode iris-sample iris-viewer; do
  [ "$(command -v $prog)" = "/usr/bin/$prog" ] || fail "$prog is not /usr/bin/$prog"
  out=$(env -u DISPLAY -u WAYLAND_DISPLAY -u QT_QPA_PLATFORM "/usr/bin/$prog" --version)
  [ "$out" = "$prog (Iris View) $version" ] || fail "$prog --version printed '$out'"
  [ -f "/usr/share/man/man1/$prog.1.gz" ] || fail "no man page for $prog"
  zcat "/usr/share/man/man1/$prog.1.gz" | grep -qF '\fB\-\-version\fR' || fail "$prog's man page has no options"
done
work=build/packages/work
mkdir -p "$work"
/usr/bin/iris-sample --out "$work/sample.tiff" --width 4000 --height 3000 --seed 5 >/dev/null
/usr/bin/iris-render "$work/sample.tiff" --out "$work/render.png" --size 640x480
[ "$(head -c 8 "$work/render.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a" ] ||
  fail "iris-render wrote no PNG"
# Installed in the loader's own folders, nothing needs a RUNPATH (Debian's lintian rejects one).
for f in $(dpkg -L iris-view iris-view-dev); do
  if [ -f "$f" ] && [ "$(head -c 4 "$f" | od -An -tx1 | tr -d ' ')" = "7f454c46" ] &&
     readelf -d "$f" | grep -qE "RUNPATH|RPATH"; then
    fail "$f has a RUNPATH"
  fi
done

echo "== desktop integration"
desktop-file-validate /usr/share/applications/iris-viewer.desktop
# (a glob may name several types, .scn also Godot's scenes: the file's magic decides, so one of
# them must be the viewer's)
for ext in svs ndpi mrxs scn tif tiff iris; do
  types=$(awk -F: -v g="*.$ext" '$3 == g { print $2 }' /usr/share/mime/globs2)
  [ -n "$types" ] || fail "no MIME type is registered for .$ext"
  opens=""
  for type in $types; do
    if grep -q "^$type=.*iris-viewer.desktop" /usr/share/applications/mimeinfo.cache; then opens=$type; fi
  done
  [ -n "$opens" ] || fail ".$ext ($(echo $types)) does not open in iris-viewer (mimeinfo.cache)"
done
[ -f /usr/share/icons/hicolor/scalable/apps/iris-viewer.svg ] || fail "no icon"

echo "== outside projects against /usr"
xvfb-run -a -s "-screen 0 1280x1024x24" tests/install/consumers.sh --prefix /usr --work "$work/consumers" \
  --slide "$work/sample.tiff"

echo "== apt-get purge"
files=$(dpkg -L iris-view iris-view-dev | grep -E '^/usr/(bin|lib|include|share/(man|applications|mime/packages|icons))/.+\.' || true)
$SUDO apt-get purge -y -qq iris-view iris-view-dev >/dev/null
trap - EXIT
for f in $files; do
  [ ! -e "$f" ] || fail "$f is still there after purge"
done
! grep -q "iris-viewer.desktop" /usr/share/applications/mimeinfo.cache || fail "mimeinfo.cache still names the viewer"
! grep -q "image/x-aperio-svs" /usr/share/mime/globs2 || fail "the MIME types are still registered"
echo "test-deb: $(basename "$deb") and $(basename "$devdeb") installed, ran, built consumers and uninstalled cleanly"
