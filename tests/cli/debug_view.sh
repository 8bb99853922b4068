#!/usr/bin/env bash
# render --debug-view: a .mrg renders each debug view to a PNG of the asked size; a bad view name,
# --debug-view with --stereo and --debug-view on a scene without cluster DAGs get one line, exit 2
# and no output. Usage: debug_view.sh MIRAGE_BINARY SOURCE_DIR
set -u
mirage=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0
pass=0

expect_fail() {
  local name=$1 wanted=$2 output=$3
  shift 4
  "$mirage" "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  local rc=$?
  if [ $rc -ne 2 ]; then
    echo "FAIL $name: exit $rc, expected 2"; cat "$tmp/stderr"; failures=$((failures + 1)); return
  fi
  if [ "$(grep -c . "$tmp/stderr")" -ne 1 ] || ! grep -q -- "$wanted" "$tmp/stderr"; then
    echo "FAIL $name: stderr should be one line naming '$wanted', got:"; cat "$tmp/stderr"; failures=$((failures + 1)); return
  fi
  if [ -n "$output" ] && [ -e "$output" ]; then
    echo "FAIL $name: left $output behind"; failures=$((failures + 1)); return
  fi
  pass=$((pass + 1))
}

expect_ok() {
  local name=$1
  shift
  if ! "$mirage" "$@" >"$tmp/stdout" 2>"$tmp/stderr"; then
    echo "FAIL $name: exit non-zero"; cat "$tmp/stderr"; failures=$((failures + 1)); return 1
  fi
  pass=$((pass + 1))
}

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
  expect_fail stereo "--stereo" "$tmp/bad.png" -- render "$tmp/blob.mrg" --debug-view lod --stereo --size 48x32 -o "$tmp/bad.png"
fi
expect_fail forward "--debug-view" "$tmp/f.png" -- render "$tmp/blob.glb" --debug-view clusters --size 48x32 -o "$tmp/f.png"

echo "debug_view: $pass passed, $failures failed"
[ $failures -eq 0 ]
