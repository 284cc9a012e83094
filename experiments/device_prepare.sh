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

rm -rf .clips && cp -r "$shared/deepmimic/motions" .clips

# gpu-warp.sh fetches and checks the wheel in four parts (.wl1 to .wl4); split it again in twelve
bash "$shared/tools/gpu-warp.sh" > /dev/null
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cat .wl1/part.* .wl2/part.* .wl3/part.* .wl4/part.* > "$tmp/wheel" && rm -rf .wl1 .wl2 .wl3 .wl4
split -n 12 -d -a 2 "$tmp/wheel" "$tmp/part."
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
