#!/usr/bin/env bash
# render --stereo: a .mrg (cluster LOD, surfels or both) and a scene file (forward renderer) render both eyes side by
# side (2W x H PNG), the .mrg with occlusion culling too; bad --ipd values get one line, exit 2 and no output;
# --stereo-mode shows in the JSON.
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
  # --stereo-mode: the mode that ran is in the JSON (viewports when forced; multiview or viewports under auto).
  for mode in viewports auto; do
    if "$mirage" render "$tmp/blob.mrg" --stereo --stereo-mode $mode --raster indirect --size 48x32 -o "$tmp/m.png" \
      --json >"$tmp/m.json" 2>"$tmp/m.err"; then
      want='"stereo_mode": "viewports"'
      [ $mode = auto ] && want='"stereo_mode": "(multiview|viewports)"'
      grep -Eq "$want" "$tmp/m.json" || { echo "FAIL stereo-mode-$mode: no $want in the JSON"; failures=$((failures + 1)); }
    else
      echo "FAIL stereo-mode-$mode: exit $?: $(cat "$tmp/m.err")"
      failures=$((failures + 1))
    fi
  done
  expect_fail stereo-mode-bad "--stereo-mode" "$tmp/bad.png" -- render "$tmp/blob.mrg" --stereo --stereo-mode sideways --size 48x32 -o "$tmp/bad.png"
fi
# Scene files through the forward renderer: both eyes side by side too, in render and bench render.
if expect_ok render-stereo-forward render gen:city --stereo --size 48x32 -o "$tmp/f.png"; then
  size=$(png_size "$tmp/f.png")
  [ "$size" = "96x32" ] || { echo "FAIL render-stereo-forward: PNG is $size, expected 96x32"; failures=$((failures + 1)); }
fi
if expect_ok bench-stereo-forward bench render "$tmp/blob.glb" --stereo --ipd 0.1 --size 48x32 --frames 2 --warmup-ms 0 --json; then
  grep -q '"stereo_ipd"' "$tmp/stdout" || { echo "FAIL bench-stereo-forward: no stereo_ipd in the JSON"; failures=$((failures + 1)); }
fi
expect_fail ipd-negative-forward "--ipd" "$tmp/f2.png" -- render "$tmp/blob.glb" --stereo --ipd=-1 --size 48x32 -o "$tmp/f2.png"

finish "stereo"
