#!/usr/bin/env bash
# The command line's own wording and the output flags of long work: an unknown subcommand is named
# as such (with the choices), a missing one says so; `verify --progress` logs plain progress lines
# on stderr, `--quiet` prints nothing but errors, and without either (stderr not a terminal) the
# progress stays silent. Usage: commands_output.sh MIRAGE_BINARY SOURCE_DIR
set -u
mirage=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
failures=0
pass=0
fail() { echo "FAIL $1"; failures=$((failures + 1)); }

# run NAME EXPECTED_EXIT ARGS...: the exit code; stdout and stderr kept in $tmp.
run() {
  local name=$1 want=$2
  shift 2
  "$mirage" "$@" >"$tmp/stdout" 2>"$tmp/stderr"
  local rc=$?
  if [ $rc -ne "$want" ]; then fail "$name: exit $rc, expected $want: $(cat "$tmp/stderr")"; return 1; fi
  pass=$((pass + 1))
}
# one_line NAME TEXT: stderr is exactly one line containing TEXT.
one_line() {
  if [ "$(grep -c . "$tmp/stderr")" -ne 1 ] || ! grep -qF -- "$2" "$tmp/stderr"; then
    fail "$1: stderr should be one line with '$2', got: $(cat "$tmp/stderr")"
  fi
}

run unknown-subcommand 2 frobnicate && one_line unknown-subcommand "unknown subcommand 'frobnicate'"
grep -q "required" "$tmp/stderr" && fail "unknown-subcommand: says a subcommand is required"
grep -q "render" "$tmp/stderr" || fail "unknown-subcommand: does not list the subcommands"
run unknown-subcommand-args 2 frobnicate scene.glb -o x.png && one_line unknown-subcommand-args "unknown subcommand 'frobnicate'"
run unknown-bench-subcommand 2 bench frobnicate && one_line unknown-bench-subcommand "unknown subcommand 'frobnicate'"
grep -q "surfels-sampler" "$tmp/stderr" || fail "unknown-bench-subcommand: does not list bench's subcommands"
grep -q "mirage bench --help" "$tmp/stderr" || fail "unknown-bench-subcommand: no pointer to mirage bench --help"
run control-bytes 2 $'bad\x1b[2Jname' && one_line control-bytes "unknown subcommand 'bad\\x1b[2Jname'"
run no-subcommand 2 && one_line no-subcommand "a subcommand is required"
run no-bench-subcommand 2 bench && one_line no-bench-subcommand "a subcommand is required"

if run build-blob 0 build gen:blob:1 -o "$tmp/b.mrg" --quiet; then
  # --progress: plain lines (no carriage returns) with counts, times and a last "done" line.
  if run verify-progress 0 verify "$tmp/b.mrg" --cuts 5 --progress; then
    grep -q $'\r' "$tmp/stderr" && fail "verify-progress: carriage returns in log lines"
    grep -qE '^verify: 0/[0-9]+ \(0%\)' "$tmp/stderr" || fail "verify-progress: no first line: $(cat "$tmp/stderr")"
    grep -qE '^verify: done ([0-9]+)/\1 in [0-9.]+ s$' "$tmp/stderr" || fail "verify-progress: no done line: $(cat "$tmp/stderr")"
    grep -qE ': ok: .* \([0-9.]+ s wall, load [0-9.]+ s\)$' "$tmp/stdout" || fail "verify-progress: no wall time: $(cat "$tmp/stdout")"
  fi
  # Not a terminal and no --progress: the result only.
  if run verify-plain 0 verify "$tmp/b.mrg" --cuts 5; then
    [ -s "$tmp/stderr" ] && fail "verify-plain: stderr not empty: $(cat "$tmp/stderr")"
    grep -q ": ok:" "$tmp/stdout" || fail "verify-plain: no result on stdout"
  fi
  # --quiet wins over --progress and silences the result: nothing but errors.
  if run verify-quiet 0 verify "$tmp/b.mrg" --cuts 5 --quiet --progress; then
    [ -s "$tmp/stderr" ] && fail "verify-quiet: stderr not empty"
    [ -s "$tmp/stdout" ] && fail "verify-quiet: stdout not empty"
  fi
  head -c 200 "$tmp/b.mrg" >"$tmp/short.mrg"
  run verify-quiet-error 2 verify "$tmp/short.mrg" --quiet && one_line verify-quiet-error "short.mrg"
fi

echo "commands_output: $pass passed, $failures failed"
[ $failures -eq 0 ]
