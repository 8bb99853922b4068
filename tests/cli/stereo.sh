#!/usr/bin/env bash
# render --stereo: a .mrg renders both eyes side by side (2W x H PNG), with occlusion culling too; bad --ipd values and
# --stereo on a forward scene (no .mrg) get one line, exit 2 and no output.
# Usage: stereo.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

if expect_ok gen-blob gen blob --size 3 -o "$tmp/blob.glb" && expect_ok build-blob build "$tmp/blob.glb" -o "$tmp/blob.mrg" --quiet; then
  if expect_ok render-stereo render "$tmp/blob.mrg" --stereo --size 48x32 -o "$tmp/s.png"; then
    size=$(png_size "$tmp/s.png")
    [ "$size" = "96x32" ] || { echo "FAIL render-stereo: PNG is $size, expected 96x32"; failures=$((failures + 1)); }
  fi
  expect_ok render-stereo-ipd render "$tmp/blob.mrg" --stereo --ipd 0.5 --size 48x32 -o "$tmp/s2.png" &&
    { [ "$(png_size "$tmp/s2.png")" = "96x32" ] || { echo "FAIL render-stereo-ipd: size"; failures=$((failures + 1)); }; }
  expect_fail ipd-negative "--ipd" "$tmp/bad.png" -- render "$tmp/blob.mrg" --stereo --ipd=-0.1 --size 48x32 -o "$tmp/bad.png"
  expect_fail ipd-nan "--ipd" "$tmp/bad.png" -- render "$tmp/blob.mrg" --stereo --ipd nan --size 48x32 -o "$tmp/bad.png"
  expect_fail ipd-without-stereo "--ipd" "$tmp/bad.png" -- render "$tmp/blob.mrg" --ipd 0.1 --size 48x32 -o "$tmp/bad.png"
  expect_ok render-stereo-occlusion render "$tmp/blob.mrg" --stereo --occlusion on --size 48x32 -o "$tmp/s3.png" &&
    { [ "$(png_size "$tmp/s3.png")" = "96x32" ] || { echo "FAIL render-stereo-occlusion: size"; failures=$((failures + 1)); }; }
  expect_fail bench-ipd-nan "--ipd" "" -- bench render "$tmp/blob.mrg" --stereo --ipd nan --size 48x32 --frames 2
fi
expect_fail stereo-forward "--stereo" "$tmp/f.png" -- render "$tmp/blob.glb" --stereo --size 48x32 -o "$tmp/f.png"

finish "stereo"
