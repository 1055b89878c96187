#!/bin/sh
# Build the optional ViSP harness (benchmarks/visp/visp_step.cpp; ViSP is GPL: a separate
# program, never needed by redservo or `make test`). Needs g++, pkg-config and ViSP 3.5's
# development files (Debian: `apt-get install libvisp-dev`).
#
#     sh benchmarks/visp/build.sh [OUTPUT]     # default: benchmarks/visp/visp_step
set -eu
here=$(cd "$(dirname "$0")" && pwd)
out=${1:-"$here/visp_step"}
if ! pkg-config --exists visp; then
    echo "build.sh: ViSP's pkg-config file not found (Debian: apt-get install libvisp-dev)" >&2
    exit 2
fi
# shellcheck disable=SC2046  # pkg-config's flags are words
g++ -O2 -DNDEBUG -o "$out" "$here/visp_step.cpp" $(pkg-config --cflags --libs visp)
echo "built $out (ViSP $(pkg-config --modversion visp))"
