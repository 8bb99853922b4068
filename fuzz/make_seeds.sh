#!/usr/bin/env bash
# Seed corpora of the fuzz targets: usage make_seeds.sh BUILD_DIR OUT_DIR.
# Small files only: the hand-written ones in fuzz/seeds/, files made here with `mirage gen`, `build`,
# `surfels` and `pvs` (then split into chunk payloads by seed_tool), and small files from
# ../shared/data when it is there (copied at run time: that data may not be committed).
set -euo pipefail
build=$1 out=$2
src=$(cd "$(dirname "$0")/.." && pwd)
mirage=$build/mirage seed_tool=$build/fuzz/seed_tool
data=$src/../shared/data
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$out"
cp -r "$src"/fuzz/seeds/. "$out"/
for t in ply obj gltf scen cdag pages surf pvs tmap meta mrg cells gvs_config camera_path material_file effect_file stream_message tile_delta journal stream_resume; do
  mkdir -p "$out/$t"
done
cp "$src"/examples/particles/*.toml "$out/effect_file/"
cp "$src"/fuzz/regressions/tile_delta/* "$out/tile_delta/" # lossless atlas frames: keyframes and deltas

q() { "$mirage" "$@" >/dev/null; }
"$seed_tool" stream-messages "$out/stream_message"
"$seed_tool" stream-journal "$out/journal" "$out/stream_resume"
q gen blob --size 1 -o "$out/gltf/blob1.glb"
q gen terrain --size 6 -o "$out/gltf/terrain6.glb"
"$seed_tool" meshopt-glb "$out/gltf/meshopt.glb"
"$seed_tool" scen "$out/gltf/blob1.glb" "$out/scen/blob1.SCEN"
q gen blob --size 1 -o "$out/ply/blob1.ply"
q gen points --mesh gen:blob:1 --points 40 -o "$out/ply/points40.ply"

q build gen:blob:2 -o "$tmp/lod.mrg" --quiet
# A SCEN with a material file's fields and point lights (build --materials bakes them in).
printf '[[material]]\nname = "m"\nmodel = "blinn-phong"\nglossiness = 0.7\n[[assign]]\nmesh = "*"\nuse = "m"\n[[light]]\nposition = [0, 2, 0]\n' >"$tmp/m.toml"
q build gen:blob:1 -o "$tmp/lod_materials.mrg" --materials "$tmp/m.toml" --quiet
# Paged DAGs (CPAG, several pages): the paged loader, page decoder and reassembly.
q build gen:blob:2 -o "$tmp/lod_paged.mrg" --page-size 4KB --quiet
q surfels gen:blob:1 -o "$tmp/surfels.mrg" --count 32 --resolution 32 --views 4 --quiet
# Several SURF blocks (256, 256, 88 surfels): the progressive decoder's multi-block paths.
q surfels gen:blob:1 -o "$tmp/surfels_blocks.mrg" --count 600 --resolution 32 --views 4 --surfel-blocks 256:256 --quiet
q surfels gen:blob:1 -o "$out/ply/surfels.ply" --count 32 --resolution 32 --views 4 --quiet
q pvs gen:blob:1 --cells "$src/fuzz/seeds/cells/boxes.json" -o "$tmp/pvs.mrg" --rays 2000 --budget 20000
"$seed_tool" pages "$tmp/lod.mrg" "$out/pages"
for f in "$tmp"/*.mrg; do
  cp "$f" "$out/mrg/"
  "$seed_tool" chunks "$f" "$tmp/chunks"
done
mv "$tmp"/chunks/*.chunks "$out/mrg/"
for kind in SCEN CDAG SURF PVS TMAP META; do
  lower=$(echo "$kind" | tr 'A-Z' 'a-z')
  for f in "$tmp"/chunks/*."$kind"; do
    if [ -e "$f" ]; then mv "$f" "$out/$lower/"; fi
  done
done

# Small real files (the large scans would slow every run down).
if [ -d "$data" ]; then
  cp "$data"/fuzz-regressions/blob2.glb "$out/gltf/" 2>/dev/null || true
  cp "$data"/khronos-suzanne/glTF/Suzanne.gltf "$out/gltf/" 2>/dev/null || true
  cp "$data"/khronos-alpha-blend-mode-test/glTF/AlphaBlendModeTest.gltf "$out/gltf/" 2>/dev/null || true
else
  echo "make_seeds.sh: $data absent: generated and hand-written seeds only" >&2
fi
echo "seeds in $out: $(find "$out" -type f | wc -l) files"
