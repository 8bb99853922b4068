#!/usr/bin/env bash
# Assets over HTTP (docs/asset.md, "Sources"): a real web server started here (Debian's
# nginx-light on a local port; it serves byte ranges) holds .mrg files, and `info`, `verify` and
# `render` of their URLs give what the local files give (the same PNG, byte for byte), plain and
# paged. Errors name the URL: a missing file (HTTP 404), a refused connection, a corrupt file (its
# checksum), and a server that ignores ranges (Python's http.server) for a file past the first read.
# Skips (exit 0, with a message) when nginx is not installed.
# Usage: http_source.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

www=$tmp/www
start_nginx "$www" || exit 0

if expect_ok build-plain build gen:blob:4 -o "$www/plain.mrg" --quiet &&
   expect_ok build-paged build gen:blob:5 -o "$www/paged.mrg" --quiet --page-size 16KB; then
  chmod 644 "$www"/*.mrg
  for name in plain paged; do
    expect_ok "info-local-$name" info "$www/$name.mrg"
    sed "s|$www/$name.mrg|FILE|" "$tmp/stdout" >"$tmp/info-local-$name.txt"
    expect_ok "info-http-$name" info "$url/$name.mrg"
    sed "s|$url/$name.mrg|FILE|" "$tmp/stdout" >"$tmp/info-http-$name.txt"
    check "info-same-$name" cmp -s "$tmp/info-local-$name.txt" "$tmp/info-http-$name.txt"
    expect_ok "verify-http-$name" verify "$url/$name.mrg" --cuts 10
    expect_ok "render-local-$name" render "$www/$name.mrg" -o "$tmp/local-$name.png" --size 96x64
    expect_ok "render-http-$name" render "$url/$name.mrg" -o "$tmp/http-$name.png" --size 96x64
    check "render-same-$name" cmp -s "$tmp/local-$name.png" "$tmp/http-$name.png"
  done

  ascii_only=1 expect_fail missing "$url/missing.mrg: HTTP 404" "$tmp/x.png" -- render "$url/missing.mrg" -o "$tmp/x.png"
  # Port 1: nothing listens there (connection refused).
  expect_fail refused "http://127.0.0.1:1/plain.mrg: " "" -- info "http://127.0.0.1:1/plain.mrg"

  # One byte flipped inside the CDAG payload: rejected by its checksum, the URL named.
  python3 - "$www/plain.mrg" "$www/flipped.mrg" <<'PY'
import struct, sys
data = bytearray(open(sys.argv[1], 'rb').read())
count = struct.unpack_from('<I', data, 16)[0]
table = struct.unpack_from('<Q', data, 24)[0]
for i in range(count):
    e = table + 64 * i
    if data[e:e + 4] == b'CDAG':
        offset, stored = struct.unpack_from('<QQ', data, e + 8)
        data[offset + stored // 2] ^= 0x10
open(sys.argv[2], 'wb').write(data)
PY
  chmod 644 "$www/flipped.mrg"
  also_fixed="CDAG" expect_fail corrupt "$url/flipped.mrg: .*checksum" "$tmp/y.png" -- \
    render "$url/flipped.mrg" -o "$tmp/y.png"

  # A server without ranges: a file within the first read (64 KiB) still loads, a larger one is refused.
  noranges=$((${url##*:} + 1))
  (cd "$www" && exec python3 -m http.server "$noranges" --bind 127.0.0.1 >/dev/null 2>&1) &
  server_pids+=("$!")
  for _ in $(seq 1 50); do
    python3 -c "import socket; socket.create_connection(('127.0.0.1', $noranges), 0.2)" 2>/dev/null && break
    sleep 0.1
  done
  if [ "$(stat -c %s "$www/paged.mrg")" -gt 65536 ]; then
    expect_fail no-ranges "does not serve byte ranges" "" -- info "http://127.0.0.1:$noranges/paged.mrg"
  else
    fail "no-ranges: paged.mrg is too small to need a second read"
  fi
fi

finish http_source
