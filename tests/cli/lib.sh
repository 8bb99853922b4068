# Shared by the CLI test scripts (sourced, not a test itself: tests/CMakeLists.txt skips it).
# `source "$(dirname "$0")/lib.sh" "$@"` in a script run as SCRIPT MIRAGE_BINARY SOURCE_DIR sets
# $mirage, $source_dir, a scratch folder $tmp removed on exit, and the $pass / $failures counts;
# `finish NAME` prints them and gives the script's exit status.
mirage=$1
source_dir=${2:-}
tmp=$(mktemp -d)
xvfb_pid=""
server_pids=() # servers a script started (start_nginx, or its own): stopped on exit
lib_cleanup() { # the X server of x_server, the servers, the scratch folder (a script's own EXIT trap calls it last)
  if [ -n "$xvfb_pid" ]; then
    kill "$xvfb_pid" 2>/dev/null
    wait "$xvfb_pid" 2>/dev/null
  fi
  for pid in "${server_pids[@]}"; do kill "$pid" 2>/dev/null && wait "$pid" 2>/dev/null; done
  rm -rf "$tmp"
}
trap lib_cleanup EXIT
failures=0
pass=0
# Put before the binary on every run (e.g. `timeout 120`, or `env -u DISPLAY` for the viewer).
mirage_prefix=()

# x_server: an X server for the window tests. A private Xvfb (Debian xvfb) on a display number it
# picks itself (-displayfd), shared by the script's commands and stopped on exit; DISPLAY names it.
# Unlike `xvfb-run -a` around each command, scripts run in parallel cannot race for a display
# number or for xvfb-run's temporary folder, whose failed clean-up replaced the command's exit
# status. Without Xvfb, the display given; returns 1 when there is neither.
x_server() {
  if command -v Xvfb >/dev/null; then
    Xvfb -displayfd 3 -screen 0 1280x720x24 -nolisten tcp 3>"$tmp/xvfb.display" >"$tmp/xvfb.log" 2>&1 &
    xvfb_pid=$!
    for _ in $(seq 1 200); do
      if grep -qx '[0-9][0-9]*' "$tmp/xvfb.display" 2>/dev/null; then # written once it accepts clients
        export DISPLAY=":$(head -1 "$tmp/xvfb.display")"
        return 0
      fi
      kill -0 "$xvfb_pid" 2>/dev/null || break
      sleep 0.1
    done
    echo "Xvfb did not start: $(head -c 300 "$tmp/xvfb.log")"
    return 1
  fi
  [ -n "${DISPLAY:-}" ]
}

# start_nginx WWW: a real web server for the HTTP tests (Debian's nginx-light, which serves byte
# ranges) holding the folder WWW (made readable by all), on a free local port; sets $url
# (http://127.0.0.1:PORT) and stops on exit. Returns 1 with a SKIP line when nginx is not installed;
# exits the script with a FAIL line when it does not start.
start_nginx() {
  local www=$1 nginx_bin
  nginx_bin=$(command -v nginx || echo /usr/sbin/nginx)
  if [ ! -x "$nginx_bin" ]; then
    echo "SKIP $(basename "$0" .sh): nginx not installed (scripts/setup installs nginx-light)"
    return 1
  fi
  # The workers may run as another user (nginx started by root drops to nobody): the served folder
  # and files are readable by all.
  mkdir -p "$www" "$tmp/nginx"
  chmod 755 "$tmp" "$www"
  # Ports are tried until one binds (the config names every path nginx writes, so it needs no root
  # and leaves nothing outside $tmp).
  local port="" try pid
  for _ in $(seq 1 20); do
    try=$((20000 + RANDOM % 20000))
    cat >"$tmp/nginx/nginx.conf" <<EOF
daemon off;
worker_processes 1;
pid $tmp/nginx/nginx.pid;
error_log $tmp/nginx/error.log;
events { worker_connections 64; }
http {
  access_log off;
  client_body_temp_path $tmp/nginx/body;
  proxy_temp_path $tmp/nginx/proxy;
  fastcgi_temp_path $tmp/nginx/fastcgi;
  uwsgi_temp_path $tmp/nginx/uwsgi;
  scgi_temp_path $tmp/nginx/scgi;
  default_type application/octet-stream;
  server { listen 127.0.0.1:$try; root $www; }
}
EOF
    "$nginx_bin" -e "$tmp/nginx/error.log" -p "$tmp/nginx" -c "$tmp/nginx/nginx.conf" 2>>"$tmp/nginx/start.log" &
    pid=$!
    for _ in $(seq 1 50); do
      if python3 -c "import socket; socket.create_connection(('127.0.0.1', $try), 0.2)" 2>/dev/null; then
        port=$try
        break
      fi
      kill -0 "$pid" 2>/dev/null || break
      sleep 0.1
    done
    if [ -n "$port" ]; then
      server_pids+=("$pid")
      break
    fi
    kill "$pid" 2>/dev/null
    wait "$pid" 2>/dev/null
  done
  if [ -z "$port" ]; then
    echo "FAIL nginx did not start: $(tail -c 400 "$tmp/nginx/error.log" "$tmp/nginx/start.log" 2>/dev/null)"
    exit 1
  fi
  url=http://127.0.0.1:$port
}

fail() { # MESSAGE: count a failure
  echo "FAIL $*"
  failures=$((failures + 1))
}

# flip_byte FILE OFFSET: inverts every bit of one byte in place. Inverting, not writing a fixed value,
# always changes the file: the byte may hold any value (a checksum of content that names a temp path).
flip_byte() {
  local byte
  byte=$(od -An -tu1 -j"$2" -N1 "$1")
  printf "\\$(printf '%03o' $((255 - byte)))" | dd of="$1" bs=1 seek="$2" conv=notrunc 2>/dev/null
}

run_mirage() { # ARGS...: the binary's exit status; its stdout and stderr in $tmp/stdout, $tmp/stderr
  "${mirage_prefix[@]}" "$mirage" "$@" >"$tmp/stdout" 2>"$tmp/stderr"
}

# expect_fail NAME WANTED_TEXT OUTPUT_FILE -- ARGS...: exit 2, exactly one stderr line matching
# WANTED_TEXT (a grep pattern), and nothing named OUTPUT_FILE* left behind (no temporary beside it
# either; "" when the command writes no file). A caller may set, as locals, `also_fixed` (a fixed
# string the line must hold too) and `ascii_only=1` (printable ASCII only: no raw input bytes).
expect_fail() {
  local name=$1 wanted=$2 output=$3
  shift 4
  run_mirage "$@"
  local rc=$?
  if [ $rc -ne 2 ]; then
    fail "$name: exit $rc, expected 2: $(head -c 300 "$tmp/stderr")"
    return 1
  fi
  if [ "$(grep -c . "$tmp/stderr")" -ne 1 ] || ! grep -q -- "$wanted" "$tmp/stderr" ||
     { [ -n "${also_fixed:-}" ] && ! grep -qF -- "$also_fixed" "$tmp/stderr"; }; then
    fail "$name: stderr should be one line naming '$wanted'${also_fixed:+ and '$also_fixed'}, got: $(cat "$tmp/stderr")"
    return 1
  fi
  if [ -n "${ascii_only:-}" ] && LC_ALL=C grep -q '[^ -~]' "$tmp/stderr"; then
    fail "$name: raw bytes in the message"
    return 1
  fi
  if [ -n "$output" ] && ls "$output"* >/dev/null 2>&1; then
    fail "$name: left output behind: $(ls "$output"*)"
    return 1
  fi
  pass=$((pass + 1))
}

expect_ok() { # NAME ARGS...: the command exits 0 (stderr shown otherwise)
  local name=$1
  shift
  if ! run_mirage "$@"; then
    fail "$name: exit non-zero: $(cat "$tmp/stderr")"
    return 1
  fi
  pass=$((pass + 1))
}

check() { # NAME COMMAND...: the command succeeds (the last run's output shown otherwise)
  local name=$1
  shift
  if "$@"; then
    pass=$((pass + 1))
  else
    fail "$name"
    cat "$tmp/stdout" "$tmp/stderr" 2>/dev/null
    return 1
  fi
}

png_size() { # FILE: a PNG's width and height from the IHDR chunk (bytes 16..23, big-endian), as WxH
  od -An -tu1 -j16 -N8 "$1" | awk '{ printf "%dx%d", (($1*256+$2)*256+$3)*256+$4, (($5*256+$6)*256+$7)*256+$8 }'
}

finish() { # NAME: the summary line; the script's status
  echo "$1: $pass passed, $failures failed"
  [ $failures -eq 0 ]
}
