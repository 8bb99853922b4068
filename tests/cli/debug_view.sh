#!/usr/bin/env bash
# render --debug-view: a .mrg renders each debug view to a PNG of the asked size, in stereo both
# eyes side by side; a bad view name, --stereo debug views on an image raster backend and
# --debug-view on a scene without cluster DAGs get one line, exit 2 and no output.
# Usage: debug_view.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

if expect_ok gen-blob gen blob --size 3 -o "$tmp/blob.glb" && expect_ok build-blob build "$tmp/blob.glb" -o "$tmp/blob.mrg" --quiet; then
  for view in none clusters lod density overdraw; do
    expect_ok "render-$view" render "$tmp/blob.mrg" --debug-view "$view" --size 48x32 -o "$tmp/$view.png" &&
      { [ -s "$tmp/$view.png" ] || { echo "FAIL render-$view: no PNG"; failures=$((failures + 1)); }; }
  done
  # Each view colours the blob differently from the shaded image.
  for view in clusters lod density overdraw; do
    cmp -s "$tmp/none.png" "$tmp/$view.png" && { echo "FAIL $view: same PNG as the shaded image"; failures=$((failures + 1)); }
  done
  expect_ok bench-debug-view bench render "$tmp/blob.mrg" --debug-view overdraw --raster compute --size 48x32 --frames 2 --warmup-ms 0
  expect_fail bad-name "--debug-view" "$tmp/bad.png" -- render "$tmp/blob.mrg" --debug-view wireframe --size 48x32 -o "$tmp/bad.png"
  expect_fail bench-bad-name "--debug-view" "" -- bench render "$tmp/blob.mrg" --debug-view all --size 48x32 --frames 2
  # Stereo: both eyes' debug views side by side (compute and hybrid); the image backends refuse.
  if expect_ok stereo render "$tmp/blob.mrg" --debug-view overdraw --raster compute --stereo --size 48x32 -o "$tmp/s.png"; then
    size=$(od -An -tu1 -j16 -N8 "$tmp/s.png" | awk '{ printf "%dx%d", (($1*256+$2)*256+$3)*256+$4, (($5*256+$6)*256+$7)*256+$8 }')
    [ "$size" = "96x32" ] || { echo "FAIL stereo: PNG is $size, expected 96x32"; failures=$((failures + 1)); }
  fi
  expect_fail stereo-indirect "--stereo" "$tmp/bad.png" -- render "$tmp/blob.mrg" --debug-view lod --stereo --raster indirect --size 48x32 -o "$tmp/bad.png"
fi
expect_fail forward "--debug-view" "$tmp/f.png" -- render "$tmp/blob.glb" --debug-view clusters --size 48x32 -o "$tmp/f.png"

finish "debug_view"
