#!/usr/bin/env bash
# mirage view: a scene that fails to load exits 2 with one line before any window opens (run
# without a display, so opening one would fail differently); bad flags exit 2; under Xvfb the
# headless path mode (--path --screenshot --exit-after-path) writes OUT_0000.png ... that match
# `mirage render --path` (PSNR >= 45 dB per frame) with silent validation layers, and the swapchain
# follows a window resize and present-mode switches (test_viewer's SwapchainWindow test).
# Usage: view.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
mirage_prefix=(env -u DISPLAY -u WAYLAND_DISPLAY) # the errors must come before any window

expect_fail missing-scene "missing.mrg" "" -- view "$tmp/missing.mrg"
head -c 300 /dev/urandom >"$tmp/corrupt.mrg"
expect_fail corrupt-scene "corrupt.mrg" "" -- view "$tmp/corrupt.mrg"
printf 'not a mesh\n' >"$tmp/bad.obj"
expect_fail bad-obj "bad.obj" "" -- view "$tmp/bad.obj"
expect_fail bad-present "--present" "" -- view "$tmp/missing.mrg" --present vsync
expect_fail bad-size "--size" "" -- view "$tmp/missing.mrg" --size 0x10
expect_fail exit-needs-screenshot "--exit-after-path" "" -- view "$tmp/missing.mrg" --path orbit:2 --exit-after-path
expect_fail screenshot-extension "unsupported output extension" "" -- view "$tmp/missing.mrg" --path orbit:2 --screenshot "$tmp/a.jpg"

# The window tests need an X server: Xvfb through xvfb-run (Debian xvfb), else the display given.
xrun=()
if command -v xvfb-run >/dev/null && xvfb-run -a -s "-screen 0 1280x720x24" true 2>/dev/null; then
  xrun=(xvfb-run -a -s "-screen 0 1280x720x24")
elif [ -z "${DISPLAY:-}" ]; then
  echo "skip window tests: no X server (install xvfb)"
  finish "cli view"
  exit
fi

# The swapchain on a window: present, resize, present modes (test_viewer beside the binary).
test_viewer="$(dirname "$mirage")/tests/test_viewer"
if [ -x "$test_viewer" ]; then
  if "${xrun[@]}" "$test_viewer" --gtest_filter='SwapchainWindow.*' >"$tmp/stdout" 2>"$tmp/stderr" &&
    grep -q "1 test.*PASSED\|PASSED.*1 test" "$tmp/stdout" && ! grep -q "SKIPPED" "$tmp/stdout"; then
    pass=$((pass + 1))
  else
    echo "FAIL swapchain-window:"; cat "$tmp/stdout" "$tmp/stderr"; failures=$((failures + 1))
  fi
fi

if "$mirage" build gen:blob:2 -o "$tmp/blob.mrg" --quiet 2>"$tmp/stderr"; then
  cat >"$tmp/cams.json" <<'JSON'
[
  "eye=2.5,1.5,3,target=0,0,0,fov=50",
  {"eye": [-2, 0.5, 2.5], "target": [0, 0.2, 0], "fov": 60},
  {"eye": [0.3, 3, 0.2], "target": [0, 0, 0], "up": [0, 0, -1], "fov": 70}
]
JSON
  "$mirage" render "$tmp/blob.mrg" --path "$tmp/cams.json" -o "$tmp/render.png" --size 160x120 >/dev/null 2>"$tmp/stderr" ||
    { echo "FAIL render-path:"; cat "$tmp/stderr"; failures=$((failures + 1)); }
  if "${xrun[@]}" "$mirage" view "$tmp/blob.mrg" --path "$tmp/cams.json" --screenshot "$tmp/view.png" \
      --exit-after-path --size 160x120 >"$tmp/stdout" 2>"$tmp/stderr"; then
    if grep -q . "$tmp/stderr"; then echo "FAIL view-path: stderr not empty:"; cat "$tmp/stderr"; failures=$((failures + 1)); fi
    for i in 0000 0001 0002; do
      if [ ! -f "$tmp/view_$i.png" ]; then echo "FAIL view-path: no view_$i.png"; failures=$((failures + 1)); continue; fi
      psnr=$("$mirage" compare "$tmp/render_$i.png" "$tmp/view_$i.png" --json | sed 's/.*"psnr":\([^,]*\),.*/\1/')
      if [ "$psnr" = null ] || awk -v p="$psnr" 'BEGIN { exit !(p >= 45) }'; then
        pass=$((pass + 1))
      else
        echo "FAIL view-path frame $i: PSNR $psnr dB < 45 vs render --path"; failures=$((failures + 1))
      fi
    done
    [ -e "$tmp/view_0003.png" ] && { echo "FAIL view-path: wrote a fourth frame"; failures=$((failures + 1)); }
  else
    echo "FAIL view-path:"; cat "$tmp/stderr"; failures=$((failures + 1))
  fi
  # A cluster-LOD scene through frames in flight (record, GPU sRGB pass, no readback): more frames
  # than slots, so slots are reused and collected; validation (environment) stays silent.
  if "${xrun[@]}" "$mirage" view "$tmp/blob.mrg" --frames 5 --size 200x150 >"$tmp/stdout" 2>"$tmp/stderr" &&
    ! grep -q . "$tmp/stderr" && grep -q "viewed 5 frames" "$tmp/stdout"; then
    pass=$((pass + 1))
  else
    echo "FAIL view-frames-in-flight:"; cat "$tmp/stderr"; failures=$((failures + 1))
  fi
  # A scene file through the forward renderer, a few interactive frames (smoke: opens, draws, closes).
  "$mirage" gen blob -o "$tmp/blob.glb" --size 2 >/dev/null 2>&1
  if "${xrun[@]}" "$mirage" view "$tmp/blob.glb" --frames 3 --size 200x150 >"$tmp/stdout" 2>"$tmp/stderr" &&
    ! grep -q . "$tmp/stderr"; then
    pass=$((pass + 1))
  else
    echo "FAIL view-forward:"; cat "$tmp/stderr"; failures=$((failures + 1))
  fi
else
  echo "FAIL build:"; cat "$tmp/stderr"; failures=$((failures + 1))
fi

finish "cli view"
