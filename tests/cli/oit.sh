#!/usr/bin/env bash
# --oit: every mode renders a scene file of stacked blended quads (gen:layers) with msl and oit_dropped in
# --json and --stats, and bench render reports them (msl = N^2 when the camera puts all N layers over every
# pixel); bad values and modes a .mrg refuses get one line, exit 2, no output.
# Usage: oit.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

for mode in linked-list weighted sorted; do
  if "$mirage" render gen:layers:4 --oit $mode --size 32x24 -o "$tmp/$mode.png" --json >"$tmp/$mode.json" 2>"$tmp/err"; then
    for key in '"msl"' '"oit_dropped"' "\"oit\": \"$mode\""; do
      grep -q "$key" "$tmp/$mode.json" || fail "render-$mode: no $key in the JSON"
    done
    [ -s "$tmp/$mode.png" ] || fail "render-$mode: no PNG"
    pass=$((pass + 1))
  else
    fail "render-$mode: exit $?: $(cat "$tmp/err")"
  fi
done
# Linked lists: about 4 layers per covered pixel (neighbours intersect, the quads' edges differ).
msl=$(sed -n 's/.*"msl": \([0-9.e+-]*\).*/\1/p' "$tmp/linked-list.json")
awk -v m="$msl" 'BEGIN { exit !(m > 4 && m <= 16) }' || fail "render-linked-list: msl $msl, expected about 16 (4 layers)"
expect_ok render-stats render gen:layers:4 --size 32x24 -o "$tmp/s.png" --stats &&
  { grep -q "msl .*oit_dropped 0" "$tmp/stdout" || fail "render-stats: no msl / oit_dropped line: $(cat "$tmp/stdout")"; }
expect_ok bench-oit bench render gen:layers:4 --oit linked-list --size 32x24 --frames 2 --json &&
  { grep -q '"msl"' "$tmp/stdout" && grep -q '"composite"' "$tmp/stdout" || fail "bench-oit: no msl or composite time"; }
# A camera close in front: all 4 layers over every pixel, msl exactly 16.
expect_ok bench-oit-camera bench render gen:layers:4 --camera eye=0,0,0.6,target=0,0,0,fov=60 --size 32x24 --frames 2 \
  --json && { grep -q '"msl": 16.0' "$tmp/stdout" || fail "bench-oit-camera: msl not 16: $(grep msl "$tmp/stdout")"; }

expect_fail oit-bad "--oit" "$tmp/bad.png" -- render gen:layers:2 --oit bogus --size 32x24 -o "$tmp/bad.png"
expect_fail bench-oit-bad "--oit" "" -- bench render gen:layers:2 --oit bogus --size 32x24 --frames 2
if expect_ok gen-layers gen layers --size 3 -o "$tmp/layers.glb" &&
  expect_ok build-layers build "$tmp/layers.glb" -o "$tmp/layers.mrg" --quiet; then
  expect_ok render-mrg-lists render "$tmp/layers.mrg" --oit linked-list --size 32x24 -o "$tmp/m.png" --json &&
    { grep -q '"msl"' "$tmp/stdout" && grep -q '"oit_dropped"' "$tmp/stdout" || fail "render-mrg-lists: no msl / oit_dropped"; }
  expect_fail mrg-weighted "--oit weighted" "$tmp/bad.png" -- render "$tmp/layers.mrg" --oit weighted --size 32x24 -o "$tmp/bad.png"
  # Fixed slots: the pool's 8 keys per pixel, reported, and the image of packed storage's ranges.
  expect_ok render-mrg-packed render "$tmp/layers.mrg" --oit packed --oit-nodes-per-pixel 8 --size 32x24 -o "$tmp/p.png"
  expect_ok render-mrg-fixed render "$tmp/layers.mrg" --oit fixed --oit-nodes-per-pixel 8 --size 32x24 -o "$tmp/f.png" \
    --json && { grep -q '"oit_fixed_slots"' "$tmp/stdout" || fail "render-mrg-fixed: no oit_fixed_slots"; }
  check render-mrg-fixed-image cmp -s "$tmp/p.png" "$tmp/f.png"
fi
expect_fail fixed-forward "--oit fixed" "$tmp/bad.png" -- render gen:layers:2 --oit fixed --size 32x24 -o "$tmp/bad.png"
finish oit
