#!/usr/bin/env bash
# bench render --target-ms (frame-time control, docs/runtime.md): every frame reports its GPU time
# and the tau the controller chose, within the bounds; bad targets and configurations it cannot
# time are one line, exit 2. Also the foveation flags (--fovea, --fovea-radius). Usage: frame_time.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

"$mirage" gen blob --size 4 -o "$tmp/blob.glb" >/dev/null || { echo "FAIL gen"; exit 1; }
"$mirage" build "$tmp/blob.glb" -o "$tmp/blob.mrg" --quiet >/dev/null || { echo "FAIL build"; exit 1; }

"$mirage" bench render "$tmp/blob.mrg" --size 48x32 --path orbit:5 --target-ms 3 --raster compute --json >"$tmp/stdout" 2>"$tmp/stderr"
check json-runs test $? -eq 0 -a ! -s "$tmp/stderr" # validation layers silent
check json-frames test "$(grep -c '"gpu_ms_frame"' "$tmp/stdout")" -eq 5
check json-share grep -q '"share_within_10_percent"' "$tmp/stdout"
# Every chosen tau inside 1..16 px.
taus=$(grep '"tau_pixels"' "$tmp/stdout" | sed 's/.*: *\([0-9.e+-]*\).*/\1/')
check json-tau-bounds awk -v t="$taus" 'BEGIN { n = split(t, v, "\n"); for (i = 1; i <= n; ++i) if (v[i] < 1 || v[i] > 16) exit 1; exit n == 5 ? 0 : 1 }'

"$mirage" bench render "$tmp/blob.mrg" --size 48x32 --frames 4 --target-ms 3 --raster compute >"$tmp/stdout" 2>"$tmp/stderr"
check text-runs test $? -eq 0
check text-frames test "$(grep -c '^frame ' "$tmp/stdout")" -eq 3
check text-summary grep -q 'within +-10 %' "$tmp/stdout"

expect_fail zero-target "--target-ms must be" "" -- bench render "$tmp/blob.mrg" --size 32x32 --target-ms 0
expect_fail negative-target "--target-ms must be" "" -- bench render "$tmp/blob.mrg" --size 32x32 --target-ms -2
expect_fail sweep "--target-ms times one configuration" "" -- bench render "$tmp/blob.mrg" --size 32x32 --target-ms 2 --selection all
expect_fail scene-file "--target-ms applies to .mrg" "" -- bench render "$tmp/blob.glb" --size 32x32 --target-ms 2

# Foveation flags (bound with the config): a gaze point renders; bad ones are one line.
"$mirage" render "$tmp/blob.mrg" -o "$tmp/fovea.png" --size 48x32 --fovea 0.5,0.5 --fovea-radius 5 >"$tmp/stdout" 2>"$tmp/stderr"
check fovea-renders test $? -eq 0 -a -f "$tmp/fovea.png" -a ! -s "$tmp/stderr"
expect_fail fovea-range "--fovea must be" "" -- render "$tmp/blob.mrg" -o "$tmp/f.png" --size 32x32 --fovea 2,0.5
expect_fail fovea-syntax "--fovea" "" -- render "$tmp/blob.mrg" -o "$tmp/f.png" --size 32x32 --fovea middle
expect_fail fovea-radius "--fovea-radius must be" "" -- render "$tmp/blob.mrg" -o "$tmp/f.png" --size 32x32 --fovea 0.5,0.5 --fovea-radius 200
check fovea-no-output test ! -e "$tmp/f.png"

finish frame_time
