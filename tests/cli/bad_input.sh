#!/usr/bin/env bash
# CLI behaviour: bad input gets one clear line naming the file, exit 2 and no output file;
# good input renders. Usage: cli_test.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

printf 'not a glb at all' >"$tmp/garbage.glb"
printf 'ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\nproperty float y\nproperty float z\nelement face 10\nproperty list uchar int vertex_indices\nend_header\n\x00\x00' >"$tmp/truncated.ply"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n' >"$tmp/range.obj"
printf 'v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n' >"$tmp/nan.obj"
printf 'solid x\n' >"$tmp/scene.xyz"

expect_fail render-missing "missing.glb" "$tmp/out.png" -- render "$tmp/missing.glb" -o "$tmp/out.png"
expect_fail render-unknown-ext "scene.xyz" "$tmp/out.png" -- render "$tmp/scene.xyz" -o "$tmp/out.png"
expect_fail render-garbage-glb "garbage.glb" "$tmp/out.png" -- render "$tmp/garbage.glb" -o "$tmp/out.png"
expect_fail render-truncated-ply "truncated.ply" "$tmp/out.png" -- render "$tmp/truncated.ply" -o "$tmp/out.png"
expect_fail render-index-range "range.obj" "$tmp/out.png" -- render "$tmp/range.obj" -o "$tmp/out.png"
expect_fail render-nan "nan.obj" "$tmp/out.png" -- render "$tmp/nan.obj" -o "$tmp/out.png"
expect_fail render-bad-size "--size" "$tmp/out.png" -- render "$tmp/range.obj" -o "$tmp/out.png" --size 0x10
expect_fail render-bad-camera "--camera" "$tmp/out.png" -- render "$tmp/range.obj" -o "$tmp/out.png" --camera eye=1,2
expect_fail render-no-folder "nofolder" "$tmp/nofolder/out.png" -- render "$tmp/range.obj" -o "$tmp/nofolder/out.png"
expect_fail render-bad-ext "out.jpg" "$tmp/out.jpg" -- render "$tmp/range.obj" -o "$tmp/out.jpg"
expect_fail info-missing "missing.obj" "" -- info "$tmp/missing.obj"
expect_fail compare-missing "missing.png" "" -- compare "$tmp/missing.png" "$tmp/missing.png"
expect_fail gen-unknown "volcano" "$tmp/v.glb" -- gen volcano -o "$tmp/v.glb"
expect_fail gen-no-folder "nofolder" "$tmp/nofolder/b.glb" -- gen blob -o "$tmp/nofolder/b.glb"
expect_fail no-subcommand "" "" -- 

# The good path: generate, inspect, render, compare with itself.
if expect_ok gen-blob gen blob --size 3 -o "$tmp/blob.glb"; then
  expect_ok info-blob info "$tmp/blob.glb" --json
  grep -q '"triangles"' "$tmp/stdout" || { echo "FAIL info-blob: no triangle count"; failures=$((failures + 1)); }
  if expect_ok render-blob render "$tmp/blob.glb" -o "$tmp/blob.png" --size 96x64 --stats; then
    [ -s "$tmp/blob.png" ] || { echo "FAIL render-blob: no PNG"; failures=$((failures + 1)); }
    ls "$tmp" | grep -q tmp- && { echo "FAIL render-blob: temp file left"; failures=$((failures + 1)); }
    expect_ok compare-same compare "$tmp/blob.png" "$tmp/blob.png" --json
    grep -q '"ssim": *1' "$tmp/stdout" || { echo "FAIL compare-same: ssim not 1: $(cat "$tmp/stdout")"; failures=$((failures + 1)); }
  fi
fi
# Cluster LOD: build, inspect, verify; corrupt assets are rejected with one line.
if expect_ok build-blob build "$tmp/blob.glb" -o "$tmp/blob.mrg" --quiet; then
  expect_ok info-mrg info "$tmp/blob.mrg" --json
  grep -q '"bytes_per_input_triangle"' "$tmp/stdout" || { echo "FAIL info-mrg: no size figure"; failures=$((failures + 1)); }
  expect_ok verify-mrg verify "$tmp/blob.mrg" --cuts 20
  head -c 200 "$tmp/blob.mrg" >"$tmp/short.mrg"
  expect_fail verify-truncated "short.mrg" "" -- verify "$tmp/short.mrg"
  cp "$tmp/blob.mrg" "$tmp/flipped.mrg"
  flip_byte "$tmp/flipped.mrg" 300
  expect_fail verify-flipped "flipped.mrg" "" -- verify "$tmp/flipped.mrg"
  expect_fail verify-not-mrg "blob.glb" "" -- verify "$tmp/blob.glb"
  # The seed's baselines beside the cluster-LOD renderer, in one run.
  if expect_ok bench-baselines bench render "$tmp/blob.mrg" --size 48x32 --frames 2 --raster indirect --baselines --grid 2; then
    grep -q "discrete-lod" "$tmp/stdout" && grep -q "brute-force" "$tmp/stdout" || { echo "FAIL bench-baselines: missing rows"; failures=$((failures + 1)); }
  fi
  # Camera paths: one image per camera; a bad path file is one line naming it, nothing written.
  if expect_ok render-path render "$tmp/blob.mrg" -o "$tmp/frame.png" --size 48x32 --path orbit:3; then
    [ "$(ls "$tmp" | grep -c '^frame_000[0-2].png$')" -eq 3 ] || { echo "FAIL render-path: expected 3 frames"; failures=$((failures + 1)); }
  fi
  printf '[{"eye": [1, 2], "target": [0, 0, 0]}]' >"$tmp/cams.json"
  expect_fail render-bad-path "cams.json: camera 0" "$tmp/bad_0000.png" -- render "$tmp/blob.mrg" -o "$tmp/bad.png" --size 48x32 --path "$tmp/cams.json"
  expect_fail render-path-not-json "blob.glb: not valid JSON" "$tmp/bad_0000.png" -- render "$tmp/blob.mrg" -o "$tmp/bad.png" --size 48x32 --path "$tmp/blob.glb"
  expect_fail render-bad-occlusion "--occlusion" "$tmp/o.png" -- render "$tmp/blob.mrg" -o "$tmp/o.png" --size 32x32 --occlusion maybe
  expect_fail render-bad-selection "--selection" "$tmp/o.png" -- render "$tmp/blob.mrg" -o "$tmp/o.png" --size 32x32 --selection tree
  expect_ok render-flat-selection render "$tmp/blob.mrg" -o "$tmp/flat.png" --size 32x32 --selection flat --stats
  expect_fail render-bad-hybrid "--hybrid-threshold" "$tmp/o.png" -- render "$tmp/blob.mrg" -o "$tmp/o.png" --size 32x32 --hybrid-threshold -1
  expect_ok render-hybrid-stats render "$tmp/blob.mrg" -o "$tmp/o.png" --size 32x32 --raster hybrid --cones off --stats
  # The flag binding (apps/mirage/render_options.cpp): bench-only words are refused by render; a
  # cluster-LOD flag given on a scene file is an error even at its default value (given, not compared).
  expect_fail render-raster-all "--raster" "$tmp/flags.png" -- render "$tmp/blob.mrg" -o "$tmp/flags.png" --size 32x32 --raster all
  expect_fail render-occlusion-both "--occlusion" "$tmp/flags.png" -- render "$tmp/blob.mrg" -o "$tmp/flags.png" --size 32x32 --occlusion both
  expect_fail render-default-tau-on-glb "cluster-LOD assets only" "$tmp/flags.png" -- render "$tmp/blob.glb" -o "$tmp/flags.png" --size 32x32 --tau 1
  if expect_ok bench-occlusion-both bench render "$tmp/blob.mrg" --size 32x32 --frames 2 --raster indirect --occlusion both --json; then
    [ "$(grep -c '"occlusion": \(true\|false\)' "$tmp/stdout")" -eq 2 ] || { echo "FAIL bench-occlusion-both: expected 2 runs"; failures=$((failures + 1)); }
  fi
  expect_fail render-lean-both "--lean-raster" "$tmp/flags.png" -- render "$tmp/blob.mrg" -o "$tmp/flags.png" --size 32x32 --lean-raster both
  if expect_ok bench-lean-both bench render "$tmp/blob.mrg" --size 32x32 --frames 2 --raster compute --lean-raster both --json; then
    [ "$(grep -c '"lean_raster": \(true\|false\)' "$tmp/stdout")" -eq 2 ] || { echo "FAIL bench-lean-both: expected 2 runs"; failures=$((failures + 1)); }
  fi
fi
expect_fail build-missing "missing.ply" "$tmp/m.mrg" -- build "$tmp/missing.ply" -o "$tmp/m.mrg"
expect_fail build-bad-ext "out.glb" "$tmp/out.glb" -- build "$tmp/range.obj" -o "$tmp/out.glb"
expect_fail build-no-folder "nofolder" "$tmp/nofolder/x.mrg" -- build "$tmp/range.obj" -o "$tmp/nofolder/x.mrg"
expect_fail build-bad-group "--group-clusters" "$tmp/g.mrg" -- build "$tmp/range.obj" -o "$tmp/g.mrg" --group-clusters 1
# Cluster size: build takes exactly what the renderer draws (MIRAGE_CLUSTER_MAX_TRIANGLES, one
# definition in shaderio/cluster.h) and refuses more with one line naming the flag and the limit.
max_tris=$(sed -n 's/^#define MIRAGE_CLUSTER_MAX_TRIANGLES \([0-9]*\).*/\1/p' "$2/include/mirage/shaderio/cluster.h")
[ -n "$max_tris" ] || { echo "FAIL cluster-limit: no MIRAGE_CLUSTER_MAX_TRIANGLES in cluster.h"; failures=$((failures + 1)); }
if [ -n "$max_tris" ] && expect_ok build-max-cluster build gen:blob:4 -o "$tmp/max.mrg" --quiet --cluster-triangles "$max_tris" --cluster-vertices 255; then
  expect_ok render-max-cluster render "$tmp/max.mrg" -o "$tmp/max.png" --size 32x32
  expect_fail build-cluster-too-big "--cluster-triangles.*4\.\.$max_tris" "$tmp/big.mrg" -- build gen:blob:4 -o "$tmp/big.mrg" --cluster-triangles $((max_tris + 4))
fi
# PVS culling at render time: a camera outside every cell is a clear error.
if expect_ok pvs-bake pvs gen:city:1 --cell-grid 1x1x1 --cell-region -10,1,-10,10,3,10 -o "$tmp/c.mrg" --rays 20000 --budget 100000; then
  expect_fail render-pvs-outside "none of its" "$tmp/p.png" -- render gen:city:1 -o "$tmp/p.png" --size 64x48 --pvs "$tmp/c.mrg" --camera eye=500,500,500,target=0,0,0
  expect_ok render-pvs-inside render gen:city:1 -o "$tmp/p.png" --size 64x48 --pvs "$tmp/c.mrg" --camera eye=0,2,0,target=5,2,0
fi
# Blend rasters: a bad name or queue threshold is one clear line (inf turns the queue off); bench
# --blend-raster all times each one (compute, hybrid, hardware) on a scene with glass, in one run.
if expect_ok build-city build gen:city:1 -o "$tmp/city.mrg"; then
  expect_fail render-bad-blend-raster "--blend-raster" "$tmp/b.png" -- render "$tmp/city.mrg" -o "$tmp/b.png" --size 32x32 --blend-raster gpu
  expect_fail render-bad-blend-queue "--blend-queue-pixels" "$tmp/b.png" -- render "$tmp/city.mrg" -o "$tmp/b.png" --size 32x32 --blend-queue-pixels -1
  expect_ok render-blend-queue-off render "$tmp/city.mrg" -o "$tmp/b.png" --size 32x32 --blend-queue-pixels inf
  expect_fail render-bad-oit-pool "--oit-nodes-per-pixel" "$tmp/c.png" -- render "$tmp/city.mrg" -o "$tmp/c.png" --size 32x32 --oit-nodes-per-pixel 65
  expect_ok render-oit-pool render "$tmp/city.mrg" -o "$tmp/b.png" --size 32x32 --oit-nodes-per-pixel 8
  if expect_ok bench-blend-all bench render "$tmp/city.mrg" --size 64x36 --frames 2 --raster compute --blend-raster all --camera eye=0,2,0,target=5,2,0; then
    for blend in compute hybrid hardware; do
      grep -q "^blend ($blend raster)" "$tmp/stdout" || { echo "FAIL bench-blend-all: no $blend blend row"; failures=$((failures + 1)); }
    done
  fi
fi
expect_ok help --help

finish cli
