#!/usr/bin/env bash
# The README's promise checked on a machine with nothing installed: a minimal Debian 12
# (debootstrap --variant=minbase, from the mirror this machine's apt uses) in a chroot, where
#   1. install-deps.sh, the dev configure and build, and scripts/check-deps.py (every file used
#      comes from a declared package) all pass with the list as committed;
#   2. the README's demo command (scripts/run-demo.sh) builds and opens the viewer on a sample
#      slide under Xvfb, which saves a screenshot.
# Not part of CI (it downloads a Debian base and ~1 GB of packages); run it after changing
# the dependency list. Needs root, debootstrap and network access to the Debian mirror.
#   scripts/fresh-debian-check.sh [DIR]     (default /var/tmp/iris-fresh-debian; removed first)
set -euo pipefail
cd "$(dirname "$0")/.."
src=$(pwd)
root=${1:-/var/tmp/iris-fresh-debian}
[ "$(id -u)" -eq 0 ] || { echo "fresh-debian-check: needs root (debootstrap, chroot)" >&2; exit 2; }
command -v debootstrap >/dev/null || apt-get install -y -qq --no-install-recommends debootstrap

mirror=$(sed -n 's/^URIs: *//p' /etc/apt/sources.list.d/debian.sources 2>/dev/null | head -n 1)
[ -n "$mirror" ] || mirror=$(awk '$1 == "deb" { print $2; exit }' /etc/apt/sources.list)
[ -n "$mirror" ] || { echo "fresh-debian-check: cannot tell this machine's Debian mirror" >&2; exit 2; }

cleanup() {
  for m in "$root/root/.cache/ccache" "$root/sys" "$root/dev/pts" "$root/dev" "$root/proc"; do
    mountpoint -q "$m" && umount -l "$m"
  done
  return 0
}
trap cleanup EXIT
cleanup
rm -rf "$root"

echo "== debootstrap bookworm (minbase) into $root"
debootstrap --variant=minbase bookworm "$root" "$mirror" >"$src/build/fresh-debootstrap.log" 2>&1 ||
  { tail -20 "$src/build/fresh-debootstrap.log"; exit 1; }
[ -f /etc/apt/sources.list.d/debian.sources ] && cp /etc/apt/sources.list.d/debian.sources "$root/etc/apt/sources.list.d/"
mount -t proc proc "$root/proc"
mount --bind /dev "$root/dev"
mount --bind /dev/pts "$root/dev/pts"
mount --bind /sys "$root/sys"
echo "packages in the fresh system: $(chroot "$root" dpkg-query -W -f='.\n' | wc -l)"

# The project at the same path as here, so that the compiler cache (shared below) hits.
mkdir -p "$root$src"
git ls-files -co --exclude-standard -z | tar --null -T - -cf - | tar -xf - -C "$root$src"
if [ -d "$HOME/.cache/ccache" ]; then
  mkdir -p "$root/root/.cache/ccache"
  mount --bind "$HOME/.cache/ccache" "$root/root/.cache/ccache"
fi
in_chroot() { chroot "$root" /usr/bin/env -i HOME=/root PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 bash -c "cd '$src' && $1"; }

echo "== 1. install-deps, dev configure and build, dependency check"
rm -rf "$root$src/build"
in_chroot "scripts/install-deps.sh && cmake --preset dev >/dev/null && cmake --build --preset dev -j \$(nproc) >/dev/null && scripts/check-deps.py" \
  2>&1 | tee "$src/build/fresh-with.log" | grep -E '^check-deps|Error|error:' || true
grep -q '^check-deps: [0-9]* files under /usr' "$src/build/fresh-with.log" ||
  { tail -40 "$src/build/fresh-with.log"; echo "fresh-debian-check: build or check failed"; exit 1; }

echo "== 2. the demo: scripts/run-demo.sh (release build) on a sample slide under Xvfb"
in_chroot "build/dev/bin/iris-sample --out /tmp/sample.tiff --width 8000 --height 6000 --seed 2 >/dev/null &&
  XDG_RUNTIME_DIR=\$(mktemp -d) xvfb-run -a -s '-screen 0 1280x900x24' scripts/run-demo.sh /tmp/sample.tiff \
    --exit-after-ms 8000 --screenshot /tmp/viewer.png" >"$src/build/fresh-demo.log" 2>&1 ||
  { tail -30 "$src/build/fresh-demo.log"; echo "fresh-debian-check: the demo failed"; exit 1; }
cp "$root/tmp/viewer.png" "$src/build/fresh-viewer.png"
echo "fresh-debian-check: passed; the viewer's screenshot is build/fresh-viewer.png"
