#!/usr/bin/env bash
# Fetches motion clips for training from the package registries and writes them as BVH
# clips (each with a <stem>.joints.toml mapping its joints onto the cmu_mb rig) into OUT_DIR.
#
#   fetch_clips.sh OUT_DIR
#
# Source: PyPI `pybullet` 3.2.7 (zlib licence), whose pybullet_data/data/motions/ holds the
# DeepMimic humanoid3d motions (JSON keyframes); deepmimic2bvh.py, beside this script,
# converts them (stdlib Python 3 only). See CLIPS.md for each clip, its origin and licence.
#
# OUT_DIR/            upright motions (walking, running, turning, jumping, dancing, spinning,
#                     kicking, punching): the ones meant for training
# OUT_DIR/ground/     motions on or over the floor (backflip, cartwheel, crawl, roll, getting
#                     up): they retarget, but a skirt or top turns upside down or lies on the
#                     floor; use them only deliberately
#
# Needs: bash, pip (any Python 3; the wheel is fetched for a fixed platform, never
# installed), python3. Downloads about 100 MB once into a temporary folder.
set -euo pipefail

if [ $# -ne 1 ]; then
    echo "usage: $0 OUT_DIR" >&2
    exit 2
fi
here="$(cd "$(dirname "$0")" && pwd)"
out="$1"
mkdir -p "$out/ground"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

wheel=pybullet-3.2.7-cp311-cp311-manylinux_2_17_x86_64.manylinux2014_x86_64.whl
sha=5d858abf7c12a21ef3ed351cf81dac1b5e486ec25c9ab59bfc84beb89034edff
python3 -m pip download -q --no-deps --only-binary=:all: --platform manylinux2014_x86_64 \
    --python-version 311 --implementation cp --abi cp311 pybullet==3.2.7 -d "$work"
echo "$sha  $work/$wheel" | sha256sum -c --quiet -

# Only the motion files (and the licence) come out of the wheel.
python3 - "$work/$wheel" "$work/x" <<'EOF'
import sys, zipfile
z = zipfile.ZipFile(sys.argv[1])
for n in z.namelist():
    if n.startswith("pybullet_data/data/motions/") or n == "pybullet-3.2.7.dist-info/LICENSE.txt":
        z.extract(n, sys.argv[2])
EOF
m="$work/x/pybullet_data/data/motions"

convert() { # SOURCE (relative to motions/) OUT_NAME
    python3 "$here/deepmimic2bvh.py" "$m/$1" "$out/$2.bvh"
}
# Upright motions.
convert humanoid3d_walk.txt deepmimic_walk
convert humanoid3d_run.txt deepmimic_run
convert humanoid3d_jump.txt deepmimic_jump
convert humanoid3d_dance_a.txt deepmimic_dance_a
convert humanoid3d_dance_b.txt deepmimic_dance_b
convert humanoid3d_spin.txt deepmimic_spin
convert humanoid3d_spinkick.txt deepmimic_spinkick
convert humanoid3d_kick.txt deepmimic_kick
convert humanoid3d_punch.txt deepmimic_punch
convert walker/0walk_forward.txt deepmimic_walker_forward
convert walker/turn_left0.txt deepmimic_walker_turn_left0
convert walker/turn_left1.txt deepmimic_walker_turn_left1
convert walker/turn_right0.txt deepmimic_walker_turn_right0
convert walker/turn_right1.txt deepmimic_walker_turn_right1
# On or over the floor.
convert humanoid3d_backflip.txt ground/deepmimic_backflip
convert humanoid3d_cartwheel.txt ground/deepmimic_cartwheel
convert humanoid3d_crawl.txt ground/deepmimic_crawl
convert humanoid3d_roll.txt ground/deepmimic_roll
convert humanoid3d_getup_facedown.txt ground/deepmimic_getup_facedown
convert humanoid3d_getup_faceup.txt ground/deepmimic_getup_faceup

cp "$work/x/pybullet-3.2.7.dist-info/LICENSE.txt" "$out/LICENSE.pybullet.txt"
echo "wrote $(ls "$out"/*.bvh "$out"/ground/*.bvh | wc -l) clips to $out"
