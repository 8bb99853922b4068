#!/usr/bin/env bash
# mirage serve / mirage client (docs/stream.md) as a user runs them: a server on a free port with a
# token file; the native client records a camera path (one PNG per camera, matching `mirage render`
# of the same camera); a wrong token, a missing token file, a bad codec, a bad visibility method, a
# missing particle effect and a bad --particle-patches are one-line errors (exit 2); SIGTERM stops the server cleanly (exit 0); the browser client (web/)
# in headless Chromium against the same server matches `mirage render` too (skipped without chromium).
# Usage: stream.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
mirage_prefix=(timeout 300)

echo "stream-test-token" >"$tmp/token"
cameras=("eye=60,45,60,target=0,5,0,fov=50" "eye=-50,35,55,target=0,8,0,fov=50")
printf '["%s", "%s"]\n' "${cameras[0]}" "${cameras[1]}" >"$tmp/cams.json"

expect_fail serve-no-token-file "missing: file not found" "" -- serve gen:city:2 --token-file "$tmp/missing" --port 0
expect_fail serve-bad-codec "--codec" "" -- serve gen:city:2 --token-file "$tmp/token" --codec vp9 --port 0
expect_fail serve-bad-visibility "--visibility" "" -- serve gen:city:2 --token-file "$tmp/token" --visibility gpu --port 0
expect_fail serve-missing-particles "fx.toml: file not found" "" -- serve gen:city:2 --token-file "$tmp/token" \
  --particles "$tmp/fx.toml" --port 0
expect_fail bench-bad-particle-patches "--particle-patches" "" -- bench stream gen:city:2 --particles "$tmp/fx.toml" \
  --particle-patches all
expect_fail client-bad-codec "--codec" "$tmp/bad.png" -- client ws://127.0.0.1:9/ --token x --codec vp9 --record "$tmp/bad.png"

# The browser client's files and the camera path, served by the server itself.
mkdir -p "$tmp/web"
if [ -n "$source_dir" ]; then cp "$source_dir"/web/*.html "$source_dir"/web/*.js "$tmp/web/"; fi
cp "$tmp/cams.json" "$tmp/web/"

timeout 300 "$mirage" serve gen:city:2 --token-file "$tmp/token" --port 0 --web "$tmp/web" >"$tmp/serve.log" 2>&1 &
server=$!
port=""
for _ in $(seq 1 600); do # the scene is generated and uploaded first (lavapipe: seconds)
  port=$(sed -n 's|.*on ws://127.0.0.1:\([0-9]*\)/.*|\1|p' "$tmp/serve.log")
  [ -n "$port" ] && break
  kill -0 $server 2>/dev/null || break
  sleep 0.2
done
if [ -z "$port" ]; then
  fail "serve: no port announced: $(cat "$tmp/serve.log")"
else
  url="ws://127.0.0.1:$port/"
  expect_fail client-wrong-token "token" "$tmp/wrong.png" -- client "$url" --token nope --path "$tmp/cams.json" \
    --size 160x90 --record "$tmp/wrong.png"
  for codec in zstd h264; do
    if expect_ok client-$codec client "$url" --token stream-test-token --codec $codec --path "$tmp/cams.json" \
      --size 160x90 --record "$tmp/$codec.png"; then
      for i in 0 1; do
        "$mirage" render gen:city:2 --camera "${cameras[$i]}" --size 160x90 -o "$tmp/local_$i.png" >/dev/null 2>&1
        ssim=$("$mirage" compare "$tmp/${codec}_000$i.png" "$tmp/local_$i.png" --json | sed -n 's/.*"ssim": *\([0-9.]*\).*/\1/p')
        check "client-$codec-camera-$i-ssim-$ssim" awk -v s="$ssim" 'BEGIN { exit !(s >= 0.98) }'
      done
    fi
  done
  # The browser client: WebGL2 in headless Chromium, H.264 through WebCodecs (or JPEG tiles).
  if command -v chromium >/dev/null && command -v python3 >/dev/null && [ -n "$source_dir" ]; then
    if timeout 240 python3 "$source_dir/scripts/browser_client.py" \
      "http://127.0.0.1:$port/?path=cams.json&record=1&width=160&height=90#token=stream-test-token" \
      --out "$tmp/browser" >"$tmp/browser.log" 2>&1; then
      for i in 0 1; do
        ssim=$("$mirage" compare "$tmp/browser/frame_000$i.png" "$tmp/local_$i.png" --json |
          sed -n 's/.*"ssim": *\([0-9.]*\).*/\1/p')
        # The browser blends transparent patches in sRGB, sorted per patch (docs/stream.md): a little
        # below the native client.
        check "browser-camera-$i-ssim-$ssim" awk -v s="$ssim" 'BEGIN { exit !(s >= 0.95) }'
      done
    else
      fail "browser client: $(tail -5 "$tmp/browser.log")"
    fi
  else
    echo "skip browser client: chromium or python3 missing"
  fi
  kill -TERM $server
  wait $server
  rc=$?
  check "serve-sigterm-exit-$rc" [ $rc -eq 0 ]
  check serve-stopped-line grep -q "server stopped" "$tmp/serve.log"
fi

finish stream
