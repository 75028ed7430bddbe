#!/bin/sh
# Builds the engine consumer with pkg-config alone (no CMake), as a Makefile-based project would.
#   pkgconfig-build.sh OUTPUT [PKG_CONFIG_PATH]
set -eu
out=$1
[ $# -ge 2 ] && export PKG_CONFIG_PATH="$2"
flags=$(pkg-config --cflags --libs iris-engine)
libdir=$(pkg-config --variable=libdir iris-engine)
# shellcheck disable=SC2086 # the flags are words
c++ -std=c++20 -o "$out" "$(dirname "$0")/main.cpp" $flags -Wl,-rpath,"$libdir"
