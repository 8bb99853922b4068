#!/usr/bin/env bash
# mirage render --surfels / mirage bench surfels: a small cloud renders and benches; a .mrg without
# a SURF chunk (a cluster-LOD asset) and bad flags exit 2 with one line and write nothing; per-mesh
# SURF chunks appended to a cluster-LOD .mrg render and bench as a mixed scene (meshes near, surfels far);
# both render --stereo as 2W x H PNGs.
# Usage: surfel_render.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

if expect_ok build-lod build gen:blob:2 -o "$tmp/lod.mrg" --quiet; then
  expect_fail surfels-no-surf "no SURF chunk" "$tmp/a.png" -- render "$tmp/lod.mrg" -o "$tmp/a.png" --surfels
  expect_fail bench-no-surf "no SURF chunk" "" -- bench surfels "$tmp/lod.mrg" --size 32x32 --frames 2
  # Mixed scenes: per-mesh SURF chunks appended to the DAGs; meshes near, surfels far in one frame.
  expect_fail append-without-per-mesh "--per-mesh" "" -- surfels gen:blob:2 --append -o "$tmp/lod.mrg" --count 400 --resolution 32 --views 6
  if expect_ok append-surfels surfels gen:blob:2 --per-mesh --append -o "$tmp/lod.mrg" --count 400 --resolution 32 --views 6; then
    expect_ok render-mixed render "$tmp/lod.mrg" -o "$tmp/mixed.png" --surfels --size 64x64 --stats --json
    grep -q '"surfel_instances"' "$tmp/stdout" || { echo "FAIL render-mixed: no surfel stats"; failures=$((failures + 1)); }
    [ -s "$tmp/mixed.png" ] || { echo "FAIL render-mixed: no PNG"; failures=$((failures + 1)); }
    expect_ok bench-mixed bench render "$tmp/lod.mrg" --surfels --raster compute --size 64x64 --frames 2 --grid 2
    expect_fail mixed-mesh-raster "compute or hybrid" "$tmp/mm.png" -- render "$tmp/lod.mrg" -o "$tmp/mm.png" --surfels --raster mesh --size 64x64
    expect_ok render-mixed-stereo render "$tmp/lod.mrg" -o "$tmp/ms.png" --surfels --raster compute --stereo --size 48x32 &&
      { [ "$(png_size "$tmp/ms.png")" = "96x32" ] || { echo "FAIL render-mixed-stereo: size"; failures=$((failures + 1)); }; }
  fi
fi
if expect_ok sample surfels gen:blob:3 -o "$tmp/s.mrg" --count 800 --resolution 48 --views 6; then
  expect_ok render-surfels render "$tmp/s.mrg" -o "$tmp/s.png" --surfels --size 64x64 --stats
  [ -s "$tmp/s.png" ] || { echo "FAIL render-surfels: no PNG"; failures=$((failures + 1)); }
  expect_ok render-surfels-raster render "$tmp/s.mrg" -o "$tmp/r.png" --surfels --surfel-raster raster --size 64x64
  # --stereo: both eyes side by side (2W x H) from one prefix selection; the raster fallback refuses it.
  expect_ok render-surfels-stereo render "$tmp/s.mrg" -o "$tmp/st.png" --surfels --stereo --size 48x32 &&
    { [ "$(png_size "$tmp/st.png")" = "96x32" ] || { echo "FAIL render-surfels-stereo: size"; failures=$((failures + 1)); }; }
  expect_fail surfels-stereo-raster "--stereo" "$tmp/sr.png" -- render "$tmp/s.mrg" -o "$tmp/sr.png" --surfels --stereo --surfel-raster raster --size 48x32
  expect_ok bench-surfels-stereo bench surfels "$tmp/s.mrg" --size 48x32 --frames 2 --copies 4 --order blue --stereo
  grep -q "per eye (stereo" "$tmp/stdout" || { echo "FAIL bench-surfels-stereo: no stereo header"; failures=$((failures + 1)); }
  expect_fail bench-surfels-stereo-raster "--stereo" "" -- bench surfels "$tmp/s.mrg" --size 48x32 --frames 2 --stereo --surfel-raster raster
  expect_ok bench-surfels bench surfels "$tmp/s.mrg" --size 64x64 --frames 2 --copies 4
  grep -q "G surfels/s" "$tmp/stdout" || { echo "FAIL bench-surfels: no throughput line"; failures=$((failures + 1)); }
  # Default --order all: both splat orders timed in one run, the coherent one against the blue one.
  grep -q "coherent vs blue order: speedup" "$tmp/stdout" || { echo "FAIL bench-surfels: no order comparison"; failures=$((failures + 1)); }
  grep -q "coherent order: a 32-surfel warp touches" "$tmp/stdout" || { echo "FAIL bench-surfels: no locality estimate"; failures=$((failures + 1)); }
  grep -q "coherent256 vs blue order: speedup" "$tmp/stdout" || { echo "FAIL bench-surfels: no coherent256 row"; failures=$((failures + 1)); }
  expect_ok bench-surfels-list bench surfels "$tmp/s.mrg" --size 64x64 --frames 2 --order coherent256,blue --surfel-raster compute
  grep -q "blue vs coherent256 order: speedup" "$tmp/stdout" || { echo "FAIL bench-surfels-list: first order is not the baseline"; failures=$((failures + 1)); }
  expect_fail bench-repeated-order "--order" "" -- bench surfels "$tmp/s.mrg" --size 64x64 --frames 2 --order blue,blue
  expect_ok bench-surfels-blue bench surfels "$tmp/s.mrg" --size 64x64 --frames 2 --order blue --surfel-raster compute --all
  grep -q "blue order" "$tmp/stdout" && ! grep -q "coherent order" "$tmp/stdout" || { echo "FAIL bench-surfels-blue: wrong orders"; failures=$((failures + 1)); }
  expect_ok bench-surfels-merge bench surfels "$tmp/s.mrg" --size 64x64 --frames 2 --surfel-raster compute --merge all
  [ "$(grep -c "compute, subgroup merge on," "$tmp/stdout")" -eq 3 ] || { echo "FAIL bench-surfels-merge: no merged rows for the three orders"; failures=$((failures + 1)); }
  [ "$(grep -c "compute, subgroup merge auto," "$tmp/stdout")" -eq 3 ] || { echo "FAIL bench-surfels-merge: no auto rows for the three orders"; failures=$((failures + 1)); }
  expect_fail bench-bad-merge "--merge" "" -- bench surfels "$tmp/s.mrg" --size 64x64 --frames 2 --merge maybe
  expect_ok bench-surfels-discs bench surfels "$tmp/s.mrg" --size 64x64 --frames 2 --surfel-raster compute --order blue --discs both
  [ "$(grep -c "oriented discs" "$tmp/stdout")" -eq 1 ] && [ "$(grep -c "facing discs" "$tmp/stdout")" -eq 1 ] || { echo "FAIL bench-surfels-discs: no row per disc shape"; failures=$((failures + 1)); }
  expect_fail bench-bad-discs "--discs" "" -- bench surfels "$tmp/s.mrg" --size 64x64 --frames 2 --discs round
  expect_ok render-surfels-blue render "$tmp/s.mrg" -o "$tmp/blue.png" --surfels --surfel-order blue --size 64x64
  expect_fail bench-bad-order "--order" "" -- bench surfels "$tmp/s.mrg" --size 64x64 --frames 2 --order morton
  expect_fail surfels-bad-order "--surfel-order" "$tmp/b.png" -- render "$tmp/s.mrg" -o "$tmp/b.png" --surfels --surfel-order all
  expect_fail surfel-order-without-surfels "--surfels" "$tmp/b.png" -- render "$tmp/s.mrg" -o "$tmp/b.png" --surfel-order blue
  expect_fail surfels-bad-size "--surfel-size" "$tmp/b.png" -- render "$tmp/s.mrg" -o "$tmp/b.png" --surfels --surfel-size 0
  expect_fail surfels-bad-raster "--surfel-raster" "$tmp/b.png" -- render "$tmp/s.mrg" -o "$tmp/b.png" --surfels --surfel-raster mesh
  expect_fail surfel-size-without-surfels "--surfels" "$tmp/b.png" -- render "$tmp/s.mrg" -o "$tmp/b.png" --surfel-size 3
fi
expect_fail surfels-missing "missing.mrg" "$tmp/m.png" -- render "$tmp/missing.mrg" -o "$tmp/m.png" --surfels

finish "cli surfel render"
