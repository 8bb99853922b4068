#!/usr/bin/env bash
# Runs every fuzz target of a sanitized build (make fuzz / make fuzz-ci): usage
#   fuzz/run.sh BUILD_DIR [libFuzzer flags...]      e.g. -runs=2000 or -max_total_time=600
# Seeds come from make_seeds.sh (BUILD_DIR/fuzz-seeds, made once per set of targets); what a target finds new goes to
# BUILD_DIR/fuzz-corpus/<target> (kept between runs), crashes to BUILD_DIR/fuzz-findings/<target>/.
# FUZZ_TARGETS (space separated) picks targets; JOBS targets run at once; SEED_BUILD names a plain
# build whose mirage makes the seeds. Exit 1 if any target failed.
set -uo pipefail
build=$1
shift
src=$(cd "$(dirname "$0")/.." && pwd)
# The list may span several lines of fuzz/CMakeLists.txt.
targets=${FUZZ_TARGETS:-$(sed -n '/^set(MIRAGE_FUZZ_TARGETS/,/)/p' "$src/fuzz/CMakeLists.txt" | tr -s '\n ' ' ' |
  sed 's/^set(MIRAGE_FUZZ_TARGETS \([^)]*\)).*/\1/')}
jobs=${JOBS:-$(nproc)}
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$src/cmake/sanitize/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

# Seeds are made with the plain build's mirage when there is one (faster than the sanitized one).
seed_build=${SEED_BUILD:-$build}
[ -x "$seed_build/mirage" ] && [ -x "$seed_build/fuzz/seed_tool" ] || seed_build=$build
# Made again when a target has no seeds yet (a target added since they were made).
for t in $targets; do [ -d "$build/fuzz-seeds/$t" ] || rm -rf "$build/fuzz-seeds"; done
if [ ! -d "$build/fuzz-seeds" ]; then
  rm -rf "$build/fuzz-seeds.tmp"
  bash "$src/fuzz/make_seeds.sh" "$seed_build" "$build/fuzz-seeds.tmp" && mv "$build/fuzz-seeds.tmp" "$build/fuzz-seeds" || exit 1
fi

run_one() {
  local t=$1
  shift
  local corpus=$build/fuzz-corpus/$t findings=$build/fuzz-findings/$t log=$build/fuzz-logs/$t.log
  mkdir -p "$corpus" "$findings" "$(dirname "$log")"
  local start=$SECONDS dirs=("$corpus" "$build/fuzz-seeds/$t")
  [ -d "$src/fuzz/regressions/$t" ] && dirs+=("$src/fuzz/regressions/$t")
  # -timeout: an input taking longer is a hang (a finding); -rss_limit_mb: runaway allocations are too.
  "$build/fuzz/fuzz_$t" -timeout=30 -rss_limit_mb=2560 -print_final_stats=1 -artifact_prefix="$findings/" \
    "$@" "${dirs[@]}" >"$log" 2>&1
  local rc=$?
  local runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  local cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1)
  if [ $rc -eq 0 ]; then
    echo "fuzz_$t: ok, ${runs:-?} executions, ${cov:-cov: ?}, $((SECONDS - start)) s"
  else
    echo "fuzz_$t: FAILED (exit $rc) after $((SECONDS - start)) s; log $log; input in $findings/"
    grep -m1 -E '^==[0-9]+==ERROR|runtime error|invariant broken|ALARM|out-of-memory|deadly signal' "$log" | sed 's/^/  /'
    # The first frames below libFuzzer's and the sanitizers' own: where it went wrong.
    grep -E '^ +#[0-9]+ ' "$log" | grep -v -E 'fuzzer::|__sanitizer|libc\.so|pthread_kill|raise\.c|abort\.c|fuzz::fail' |
      head -6 | sed -E 's/^ +/    /; s/ \(BuildId: [0-9a-f]+\)//'
  fi
  return $rc
}
export -f run_one
export build src

printf '%s\n' $targets | xargs -P "$jobs" -I{} bash -c 'run_one "$@"' _ {} "$@"
status=$?
[ $status -eq 0 ] && echo "fuzz: every target ran clean" || echo "fuzz: some targets failed (see above)"
exit $((status != 0))
