#!/usr/bin/env bash
# Prepares, in a new checkout, the ignored folders that a device block carries (experiments/README.md,
# "device time"): .clips/ (a copy of ../shared/deepmimic/motions), warp-lang's wheel in twelve parts
# of 12.4 MB (.wp0 to .wp9, .wpc, .wpd: one a transfer call, so that each call stays under 64 MiB
# with the tree) and gpu-wheels.sh's wheels in two (.wpa: mujoco-core; .wpb: the others but the
# render-only mujoco-studio and PyOpenGL). Folders already there are made again.
#   bash experiments/device_prepare.sh
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
shared=${SHARED:-../shared}
wheel=warp_lang-1.18.0-py3-none-manylinux_2_28_x86_64.whl
md5=47fc34ed07880e32d2964187ad4de4cd

rm -rf .clips && cp -r "$shared/deepmimic/motions" .clips

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
  --platform manylinux_2_28_x86_64 -d "$tmp" warp-lang==1.18.0
echo "$md5  $tmp/$wheel" | md5sum -c --quiet
split -n 12 -d -a 2 "$tmp/$wheel" "$tmp/part."
folders=(.wp0 .wp1 .wp2 .wp3 .wp4 .wp5 .wp6 .wp7 .wp8 .wp9 .wpc .wpd)
for i in "${!folders[@]}"; do
  rm -rf "${folders[$i]}" && mkdir "${folders[$i]}" && mv "$tmp/part.$(printf %02d "$i")" "${folders[$i]}/"
done

bash "$shared/tools/gpu-wheels.sh" > /dev/null
rm -rf .wpa .wpb && mkdir .wpa .wpb
mv .whl/mujoco_core-*.whl .wpa/
rm .whl/mujoco_studio-*.whl .whl/pyopengl-*.whl
mv .whl/*.whl .wpb/ && rmdir .whl
du -sh .clips .wp? | tr '\n' ' '; echo
git status --short --ignored .clips .wp? | head -n 1 | grep -q '^!!' || echo "device_prepare.sh: these folders are not ignored by git" >&2
