#!/usr/bin/env bash
# Prepares, in a new checkout, the ignored folders that a device block carries (experiments/README.md,
# "device time"): .clips/ (a copy of ../shared/deepmimic/motions) and the wheels the GPU machine
# lacks (gpu-warp.sh's warp-lang, gpu-wheels.sh's others but the render-only mujoco-studio and
# PyOpenGL), unpacked into one xz tar split in parts, one part a folder (.wp0, .wp1, ... .wp9,
# .wpa, ...), each small enough to go in one transfer call beside the tracked tree (a call carries
# at most 64 MiB). Folders already there are made again. Prints the parts' count and the tar's md5,
# to check on the machine after the last part, where
# `cat /tmp/wp/part.* | xz -d | tar xf - -C /tmp/site` installs them.
#   bash experiments/device_prepare.sh
set -euo pipefail
cd "$(git rev-parse --show-toplevel)"
shared=${SHARED:-../shared}

rm -rf .clips && cp -r "$shared/deepmimic/motions" .clips

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# gpu-warp.sh fetches and checks warp-lang's wheel in four parts (.wl1 to .wl4)
bash "$shared/tools/gpu-warp.sh" > /dev/null
mkdir "$tmp/whl" "$tmp/site"
cat .wl1/part.* .wl2/part.* .wl3/part.* .wl4/part.* > "$tmp/whl/warp_lang-1.18.0-py3-none-manylinux_2_28_x86_64.whl"
rm -rf .wl1 .wl2 .wl3 .wl4
bash "$shared/tools/gpu-wheels.sh" > /dev/null
rm .whl/mujoco_studio-*.whl .whl/pyopengl-*.whl
mv .whl/*.whl "$tmp/whl/" && rmdir .whl
# the wheels unpacked as pip --target would lay them out, in an xz tar: 118 MB against 166 MB
# of wheels (their deflate packs warp's libraries loosely), so fewer parts to carry
for wheel in "$tmp"/whl/*.whl; do unzip -q -o "$wheel" -d "$tmp/site"; done
tar cf - -C "$tmp/site" . | xz -T0 -6 > "$tmp/site.tar.xz"

# what a call's 64 MiB counts is about the tracked tree as a tar (on 2026-11-30 a tree of
# 61,950 KiB as a tar, 59,994 KiB of files, was refused with a part of 4,747 KiB); 100 KiB spare
tree_kib=$(( $(git ls-files -z | tar cf - --null -T - | wc -c) / 1024 ))
part_kib=$(( 64 * 1024 - tree_kib - 100 ))
names=(0 1 2 3 4 5 6 7 8 9 a b c d e f g h i j k l m n o p q r s t u v w x y z)
tar_kib=$(( $(stat -c %s "$tmp/site.tar.xz") / 1024 ))
[ "$part_kib" -gt 0 ] && [ $(( part_kib * ${#names[@]} )) -gt "$tar_kib" ] || {
  echo "device_prepare.sh: the tracked tree ($tree_kib KiB as a tar) leaves too little room for the wheels ($tar_kib KiB) in ${#names[@]} parts" >&2; exit 1; }
rm -rf .wp?
split -b "${part_kib}K" -d -a 2 "$tmp/site.tar.xz" "$tmp/part."
i=0
for part in "$tmp"/part.*; do
  mkdir ".wp${names[$i]}" && mv "$part" ".wp${names[$i]}/"
  i=$((i + 1))
done
echo "$i parts (.wp0 to .wp${names[$((i - 1))]}) of at most $part_kib KiB; md5 of the tar: $(md5sum < "$tmp/site.tar.xz" | cut -c 1-32)"
git status --short --ignored .clips .wp? | head -n 1 | grep -q '^!!' || echo "device_prepare.sh: these folders are not ignored by git" >&2
