#!/usr/bin/env bash
# mirage client without --record: an unreachable server or a bad --ipd exits 2 with one line before
# any window; under Xvfb against `mirage serve`, a window run (--frames) prints its summary line with
# frames applied, --stereo --record writes 2W x H images, and test_viewer's StreamWindow tests (a
# scripted window session against an in-process server, mono and stereo) pass.
# Usage: client_window.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"
mirage_prefix=(env -u DISPLAY -u WAYLAND_DISPLAY) # the errors must come before any window

expect_fail unreachable "ws://127.0.0.1:1/" "" -- client ws://127.0.0.1:1/ --token secret
expect_fail ipd-without-stereo "--ipd" "" -- client ws://127.0.0.1:1/ --token secret --ipd 0.1
expect_fail ipd-negative "--ipd" "" -- client ws://127.0.0.1:1/ --token secret --stereo --ipd=-1

xrun=()
if ! x_server; then
  echo "skip window tests: no X server (install xvfb)"
  finish "cli client window"
  exit
fi
mirage_prefix=(env MIRAGE_VALIDATION=1 timeout 300)

# A server on a free port (its first line names it), stopped on exit.
printf 'window-token\n' >"$tmp/token"
MIRAGE_VALIDATION=1 "$mirage" serve gen:blob:1 --port 0 --host 127.0.0.1 --token-file "$tmp/token" --codec zstd \
  --atlas-size 512 >"$tmp/serve.out" 2>"$tmp/serve.err" &
server=$!
trap 'kill $server 2>/dev/null; wait $server 2>/dev/null; lib_cleanup' EXIT
url=""
for _ in $(seq 1 300); do
  url=$(grep -o 'ws://[0-9.]*:[0-9]*/' "$tmp/serve.out" | head -1)
  [ -n "$url" ] && break
  sleep 0.1
done
if [ -z "$url" ]; then
  fail "serve did not start: $(cat "$tmp/serve.err")"
  finish "cli client window"
  exit
fi

run_mirage_x() { "${mirage_prefix[@]}" "${xrun[@]}" "$mirage" "$@" >"$tmp/stdout" 2>"$tmp/stderr"; }
if run_mirage_x client "$url" --token window-token --frames 40 --min-server-frames 2 --size 96x64 --present immediate; then
  check window-summary grep -q "poses sent, [1-9][0-9]* frames applied" "$tmp/stdout"
  check window-stderr-empty test ! -s "$tmp/stderr"
else
  fail "window run: $(cat "$tmp/stderr")"
fi
if run_mirage_x client "$url" --token window-token --frames 20 --min-server-frames 1 --size 96x64 --stereo --present immediate; then
  check stereo-window-summary grep -q "poses sent, [1-9][0-9]* frames applied" "$tmp/stdout"
else
  fail "stereo window run: $(cat "$tmp/stderr")"
fi
expect_ok stereo-record client "$url" --token window-token --path orbit:2 --size 96x64 --stereo --record "$tmp/s.png"
for i in 0000 0001; do
  check "stereo-record-size-$i" test "$(png_size "$tmp/s_$i.png")" = 192x64
done

test_viewer="$(dirname "$mirage")/tests/test_viewer"
if [ -x "$test_viewer" ]; then
  if "${xrun[@]}" "$test_viewer" --gtest_filter='StreamWindow.*' >"$tmp/stdout" 2>"$tmp/stderr" &&
    grep -q "2 tests.*PASSED\|PASSED.*2 tests" "$tmp/stdout" && ! grep -q "SKIPPED" "$tmp/stdout"; then
    pass=$((pass + 1))
  else
    fail "stream-window tests:"; cat "$tmp/stdout" "$tmp/stderr"
  fi
fi
finish "cli client window"
