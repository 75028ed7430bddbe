#!/usr/bin/python3
"""Checks that every Debian package the build and the tests use is declared.

A machine that already has extra packages hides a missing install step: the build finds what an
earlier project installed, CI stays green, and a newcomer's fresh machine fails (that is how
libqt6opengl6-dev went missing). This check does not trust the machine. It collects every file
under /usr that configuring, building and running read:

  cmake    the CMake files configuring executed (a scratch configure with
           --trace-expand --trace-format=json-v1): CMake's own modules and every package's
           Config/Targets files, including those pulled in through find_dependency;
  pkgconf  the .pc file of every pkg_check_modules() module and the modules it requires;
  cache    every program the configure found and cached (compilers, binutils, pkg-config,
           glslangValidator, ccache) that something runs: the configure itself (execute_process),
           a build command, or a test (the clang configure runs CMAKE_LINKER, ld.lld where lld
           is installed, for `--help`); CMake also caches tools it never runs (CMAKE_OBJDUMP,
           CMAKE_READELF, …), which do not count, and cached libraries count when a command links them, since modules such as FindOpenGL cache
           optional ones (GLU, EGL) that nothing uses;
  header   every header the compiler read (Ninja's deps log: `ninja -t deps`);
  command  every file under /usr named in a build command (moc, uic, glslangValidator, the
           libraries linked by path), and each -lNAME resolved as the linker would;
  runtime  every file opened or executed while iris-sample, iris-render (validation layers on)
           and the viewer under xvfb-run run once (strace -f): the Vulkan loader, lavapipe, the
           validation layer, Qt's platform plugins, fonts, Xvfb and xauth.

It maps each file to its Debian package with dpkg's own file lists (the database `dpkg -S`
searches; one read instead of one `dpkg -S` per file, which would take minutes), and fails unless
that package is in the closure of scripts/install-deps.sh's list under Depends/Pre-Depends
(`apt-cache depends --recurse`, no Recommends or Suggests, which --no-install-recommends does not
install) together with the Essential packages. The failure names each file, its package and the
line to add. A file under /usr that no package owns also fails (something installed by hand).

Usage: scripts/check-deps.py [--preset NAME]... [--no-runtime] [--reuse] [--without PKG]...
  --preset NAME   build tree build/NAME of CMakePresets.json's preset NAME (default: dev); repeat
                  for several. Build it first: headers and commands come from its Ninja files.
  --no-runtime    skip the strace probe (for presets without the viewer, or without a display)
  --reuse         reuse the files collected by the last run (build/<first preset>/deps/used.tsv)
  --without PKG   check as if PKG were not in the list (tests/deps drops one package of each kind)
Exit status: 0 all declared, 1 something is not, 2 the check itself could not run.
"""

import argparse
import glob
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
INSTALL_DEPS = os.path.join("scripts", "install-deps.sh")

# Files under /usr that no package owns because maintainer scripts or triggers generate them on
# every machine (caches of installed fonts, MIME types, loaders, locales). Each is regenerated
# from what packages ship, so it says nothing about which package is missing.
GENERATED = [
    re.compile(r"^/usr/lib/locale/locale-archive$"),
    re.compile(r"^/usr/lib/x86_64-linux-gnu/gconv/gconv-modules\.cache$"),
    re.compile(r"^/usr/lib/x86_64-linux-gnu/gdk-pixbuf-2\.0/.*/loaders\.cache$"),
    re.compile(r"^/usr/share/mime/mime\.cache$|^/usr/share/mime/[a-z0-9.]+$"),
    re.compile(r"^/usr/share/fonts/.*/(fonts\.(dir|scale)|\.uuid)$|^/usr/share/fonts/\.uuid$"),
    re.compile(r"^/usr/lib/python3/dist-packages/.*\.pyc$|/__pycache__/"),
    re.compile(r"^/usr/share/applications/mimeinfo\.cache$"),
    re.compile(r"^/usr/share/icons/[^/]+/icon-theme\.cache$"),
]

# At run time fontconfig offers every installed font, Qt reads every installed icon theme and
# glibc every locale file it finds: the programs use these packages when a machine has them and
# work without them. What they need is declared (fonts-dejavu-core for the engine's labels, Qt's
# built-in fallback icons). Files of these packages seen at run time are listed, not failed.
OPTIONAL_AT_RUNTIME = re.compile(r"^fonts-|-icon-theme$|^locales(-all)?$")

HOW = {
    "cmake": "CMake file executed while configuring",
    "pkgconf": "pkg-config file of a pkg_check_modules() module",
    "cache": "program or library the configure found and cached",
    "header": "header the compiler read",
    "command": "file a build command runs or links",
    "runtime": "file the programs open at run time",
}


def fail(msg, code=2):
    print(f"check-deps: {msg}", file=sys.stderr)
    sys.exit(code)


def run(cmd, **kw):
    return subprocess.run(cmd, check=True, text=True, capture_output=True, cwd=ROOT, **kw).stdout


def under_usr(path):
    return path.startswith("/usr/") and not path.startswith("/usr/local/src/")


# ---------------------------------------------------------------------------------------------
# Collecting what was used: {path: (how, example of who used it)}

def collect_configure(preset, out_dir, used):
    """A scratch configure of the preset, traced, so that every Config file is read again
    (a re-configure of the real tree would skip nothing either, but must not disturb it)."""
    tree = os.path.join(out_dir, f"configure-{preset}")
    trace = os.path.join(out_dir, f"trace-{preset}.json")
    shutil.rmtree(tree, ignore_errors=True)
    try:
        run(["cmake", "--preset", preset, "-B", tree, "--trace-expand",
             "--trace-format=json-v1", f"--trace-redirect={trace}"])
    except subprocess.CalledProcessError as e:
        fail(f"configuring preset {preset} failed, so nothing can be checked:\n{e.stdout}{e.stderr}")
    modules = []
    executed = []  # the expanded arguments of every execute_process the configure ran
    with open(trace, encoding="utf-8", errors="replace") as f:
        for line in f:
            try:
                entry = json.loads(line)
            except json.JSONDecodeError:
                continue
            path = entry.get("file", "")
            if under_usr(path) and os.path.isfile(path):  # (not "file.cmake:58:EVAL")
                used.setdefault(path, ("cmake", f"configure ({preset})"))
            cmd = entry.get("cmd", "").lower()
            if cmd == "pkg_check_modules":
                modules += pkg_modules(entry.get("args", []))
            elif cmd == "execute_process":
                executed += entry.get("args", [])
    runs = set(executed) | run_text(preset)
    with open(os.path.join(tree, "CMakeCache.txt"), encoding="utf-8", errors="replace") as f:
        for line in f:
            m = re.match(r"^([^#/][^:]*):FILEPATH=(/usr/.+)$", line.strip())
            if m and os.path.isfile(m.group(2)) and is_program(m.group(2)) \
                    and any(m.group(2) in text for text in runs):
                used.setdefault(m.group(2), ("cache", m.group(1)))
    collect_pkgconfig(modules, used)
    shutil.rmtree(tree, ignore_errors=True)


def run_text(preset):
    """What the real tree's build and tests run: its Ninja files and CTest scripts, as text."""
    build = os.path.join(ROOT, "build", preset)
    texts = set()
    files = [os.path.join(build, "build.ninja"), os.path.join(build, "CMakeFiles", "rules.ninja")]
    files += glob.glob(os.path.join(build, "**", "CTestTestfile.cmake"), recursive=True)
    for name in files:
        if os.path.isfile(name):
            with open(name, encoding="utf-8", errors="replace") as f:
                texts.add(f.read())
    return texts


def is_program(path):
    return os.access(path, os.X_OK) and not re.search(r"\.so(\.|$)", path)


def pkg_modules(args):
    """pkg_check_modules(PREFIX [REQUIRED] [QUIET] [IMPORTED_TARGET [GLOBAL]] mod>=ver...)"""
    keywords = {"REQUIRED", "QUIET", "IMPORTED_TARGET", "GLOBAL", "NO_CMAKE_PATH",
                "NO_CMAKE_ENVIRONMENT_PATH"}
    return [re.split(r"[<>=]", a)[0] for a in args[1:] if a not in keywords]


def collect_pkgconfig(modules, used):
    seen = set()
    todo = list(dict.fromkeys(modules))
    while todo:
        mod = todo.pop()
        if mod in seen:
            continue
        seen.add(mod)
        try:
            path = run(["pkg-config", "--path", mod]).strip()
            reqs = run(["pkg-config", "--print-requires", "--print-requires-private", mod])
        except subprocess.CalledProcessError:
            continue  # configure would have failed on a required module already
        if under_usr(path):
            used.setdefault(path, ("pkgconf", mod))
        todo += [r.split()[0] for r in reqs.splitlines() if r.strip()]


def collect_build(preset, used):
    build = os.path.join(ROOT, "build", preset)
    if not os.path.isfile(os.path.join(build, "build.ninja")):
        fail(f"build/{preset} is not configured: build it first (cmake --build --preset {preset})")
    target = None
    for line in run(["ninja", "-C", build, "-t", "deps"]).splitlines():
        if line and not line[0].isspace():
            target = line.split(":")[0]
        elif under_usr(line.strip()):
            used.setdefault(os.path.normpath(line.strip()), ("header", target))
    libdirs = linker_search_dirs()
    for cmd in run(["ninja", "-C", build, "-t", "commands"]).splitlines():
        try:
            words = shlex.split(cmd)
        except ValueError:
            words = cmd.split()
        who = next((w for i, w in enumerate(words) if i and words[i - 1] == "-o"), words[0] if words else "")
        for word in words:
            for token in word.split(","):  # -Wl,a,b
                if under_usr(token) and os.path.isfile(token):
                    used.setdefault(os.path.normpath(token), ("command", who))
                elif token.startswith("-l") and len(token) > 2:
                    lib = find_library(token[2:], libdirs)
                    if lib:
                        used.setdefault(lib, ("command", who))


def linker_search_dirs():
    out = run(["cc", "-print-search-dirs"])
    m = re.search(r"^libraries: =(.*)$", out, re.M)
    return [os.path.normpath(d) for d in m.group(1).split(":")] if m else []


def find_library(name, dirs):
    for d in dirs:
        for candidate in (f"lib{name}.so", f"lib{name}.a"):
            path = os.path.join(d, candidate)
            if os.path.exists(path):
                return path if under_usr(path) else None
    return None


def collect_runtime(preset, out_dir, used):
    """Runs the programs once under strace -f and keeps every file opened or executed."""
    bindir = os.path.join(ROOT, "build", preset, "bin")
    for tool in ("iris-sample", "iris-render", "iris-viewer"):
        if not os.access(os.path.join(bindir, tool), os.X_OK):
            fail(f"{tool} is not built in build/{preset}: the run-time probe needs it (or pass --no-runtime)")
    if not shutil.which("strace"):
        fail("strace is not installed (scripts/install-deps.sh installs it)")
    slide = os.path.join(out_dir, "probe.tiff")
    env = dict(os.environ)
    env.pop("QT_QPA_PLATFORM", None)  # the viewer uses the xcb plugin, as a user's would
    env.pop("DISPLAY", None)          # xvfb-run gives it one
    env.pop("WAYLAND_DISPLAY", None)
    env.setdefault("XDG_RUNTIME_DIR", tempfile.mkdtemp())
    probes = [
        [f"{bindir}/iris-sample", "--out", slide, "--width", "1024", "--height", "768", "--seed", "3"],
        [f"{bindir}/iris-render", slide, "--out", os.path.join(out_dir, "probe.png"), "--size", "256x192",
         "--validation"],
        ["xvfb-run", "-a", "-s", "-screen 0 1024x768x24", f"{bindir}/iris-viewer", slide,
         "--exit-after-ms", "3000"],
    ]
    for i, probe in enumerate(probes):
        log = os.path.join(out_dir, f"strace-{i}.txt")
        res = subprocess.run(["strace", "-f", "-qq", "-e", "trace=open,openat,execve", "-o", log] + probe,
                             cwd=ROOT, env=env, text=True, capture_output=True, timeout=300)
        if res.returncode != 0:
            fail(f"the run-time probe {' '.join(probe)} failed ({res.returncode}):\n{res.stdout}{res.stderr}")
        name = os.path.basename(probe[0]) if i < 2 else "iris-viewer under xvfb-run"
        pattern = re.compile(r'(?:openat\([^,]+, |open\(|execve\()"([^"]+)"[^=]*= (-?\d+)')
        with open(log, encoding="utf-8", errors="replace") as f:
            for line in f:
                m = pattern.search(line)
                if m and int(m.group(2)) >= 0:
                    path = os.path.normpath(m.group(1))
                    if under_usr(path) and os.path.isfile(path):
                        used.setdefault(path, ("runtime", name))


# ---------------------------------------------------------------------------------------------
# Mapping files to packages, and the declared closure

def dpkg_owners():
    """{path: {package}} from dpkg's file lists, the database `dpkg -S` searches."""
    owners = {}
    for lst in glob.glob("/var/lib/dpkg/info/*.list"):
        pkg = os.path.basename(lst)[:-5].split(":")[0]
        with open(lst, encoding="utf-8", errors="replace") as f:
            for line in f:
                owners.setdefault(line.rstrip("\n"), set()).add(pkg)
    return owners


def aliases(path):
    """The names dpkg may know a file by: Debian 12 merges /bin, /sbin and /lib into /usr, but
    packages still list files under /lib or /bin."""
    names = [path]
    for top in ("/usr/lib", "/usr/bin", "/usr/sbin", "/usr/lib64"):
        if path.startswith(top + "/"):
            names.append(path[4:])
    return names


def owners_of(path, owners):
    found = set()
    for name in aliases(path):
        found |= owners.get(name, set())
    if not found:  # diversions and anything the lists miss: ask dpkg itself
        res = subprocess.run(["dpkg", "-S", path], text=True, capture_output=True)
        for line in res.stdout.splitlines():
            if ": " in line and not line.startswith("diversion"):
                found |= {p.strip().split(":")[0] for p in line.split(": ")[0].split(",")}
    return found


def is_alternative(path):
    while os.path.islink(path):
        target = os.path.join(os.path.dirname(path), os.readlink(path))
        if target.startswith("/etc/alternatives/"):
            return True
        path = target
    return False


def declared_closure(without):
    listed = run([os.path.join(ROOT, INSTALL_DEPS), "--list"]).split()
    for pkg in without:
        if pkg not in listed:
            fail(f"--without {pkg}: {pkg} is not in {INSTALL_DEPS}'s list")
    listed = [p for p in listed if p not in without]
    essential = [line.split()[0] for line in
                 run(["dpkg-query", "-W", "-f", "${Package} ${Essential}\n"]).splitlines()
                 if line.endswith(" yes")]
    out = run(["apt-cache", "depends", "--recurse", "--no-recommends", "--no-suggests",
               "--no-conflicts", "--no-breaks", "--no-replaces", "--no-enhances"] + listed + essential)
    closure = {line.strip("<>").split(":")[0] for line in out.splitlines() if line and not line[0].isspace()}
    missing = [p for p in listed if p not in closure]
    if missing:
        fail(f"apt-cache knows nothing of {' '.join(missing)}: run 'apt-get update' (or fix the name)")
    return listed, closure


# ---------------------------------------------------------------------------------------------

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", action="append")
    ap.add_argument("--no-runtime", action="store_true")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("--without", action="append", default=[])
    args = ap.parse_args()
    presets = args.preset or ["dev"]

    out_dir = os.path.join(ROOT, "build", presets[0], "deps")
    os.makedirs(out_dir, exist_ok=True)
    used_file = os.path.join(out_dir, "used.tsv")
    used = {}
    if args.reuse and os.path.isfile(used_file):
        with open(used_file, encoding="utf-8") as f:
            for line in f:
                path, how, who = line.rstrip("\n").split("\t")
                used[path] = (how, who)
    else:
        for preset in presets:
            collect_configure(preset, out_dir, used)
            collect_build(preset, used)
            if not args.no_runtime:
                collect_runtime(preset, out_dir, used)
        with open(used_file, "w", encoding="utf-8") as f:
            for path in sorted(used):
                f.write(f"{path}\t{used[path][0]}\t{used[path][1]}\n")

    # A symlink a package ships (libfoo.so from libfoo-dev) and the file it points to (from
    # libfoo1) are both needed: check both.
    # update-alternatives' links (/usr/bin/c++ -> /etc/alternatives/c++ -> /usr/bin/g++-12)
    # belong to no package: the file they choose is what is checked.
    for path in list(used):
        real = os.path.realpath(path)
        if real != path and under_usr(real):
            used.setdefault(real, used[path])
            if is_alternative(path):
                del used[path]

    listed, closure = declared_closure(args.without)
    owners = dpkg_owners()
    by_package, unowned, optional = {}, [], set()
    for path in sorted(used):
        pkgs = owners_of(path, owners)
        if not pkgs:
            if not any(g.search(path) for g in GENERATED):
                unowned.append(path)
            continue
        if pkgs & closure:
            continue
        if used[path][0] == "runtime" and all(OPTIONAL_AT_RUNTIME.search(p) for p in pkgs):
            optional |= pkgs
            continue
        for pkg in sorted(pkgs):
            by_package.setdefault(pkg, []).append(path)
    if optional:
        print(f"check-deps: used at run time because this machine has them, not needed: {' '.join(sorted(optional))}")

    if not by_package and not unowned:
        print(f"check-deps: {len(used)} files under /usr, used by {', '.join(presets)}, come from packages "
              f"that {INSTALL_DEPS}'s {len(listed)} packages bring in (or Essential ones)")
        return 0
    order = list(HOW)  # a package's files as the build met them: configure, then build, then run
    for pkg, paths in sorted(by_package.items()):
        paths.sort(key=lambda path: (order.index(used[path][0]), path))
        print(f"check-deps: package {pkg} is used but {INSTALL_DEPS} does not bring it in:")
        for path in paths[:5]:
            how, who = used[path]
            print(f"  {path}  ({HOW[how]}: {who})")
        if len(paths) > 5:
            print(f"  ... and {len(paths) - 5} more of its files")
        print(f"  add this line to PACKAGES in {INSTALL_DEPS}:\n    {pkg}")
    for path in unowned:
        how, who = used[path]
        print(f"check-deps: {path} ({HOW[how]}: {who}) belongs to no Debian package: "
              f"installed by hand? Use a packaged one and declare it in {INSTALL_DEPS}")
    return 1


if __name__ == "__main__":
    sys.exit(main())
