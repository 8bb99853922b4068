#!/usr/bin/env bash
# `mirage bench particles` (docs/particles.md): a bad effect file gets one line naming file, line
# and key, exit 2; both simulations run a small effect and report the live particles they hold.
# Usage: particles.sh MIRAGE_BINARY SOURCE_DIR
set -u
source "$(dirname "$0")/lib.sh" "$@"

printf '[[system]]\nname = "a"\nspeed = 1\n' >"$tmp/typo.toml"
printf '[[system]]\nmax_particles = -3\n' >"$tmp/negative.toml"
printf '[[system]]\n[system.wind]\nx = 1\n' >"$tmp/module.toml"
printf '[[system]\n' >"$tmp/syntax.toml"
for bad in typo negative module syntax; do
  expect_fail "bench-$bad" "error: $tmp/$bad.toml:[0-9]*: " "" -- bench particles "$tmp/$bad.toml" --count 10 --steps 1
done
also_fixed='unknown key "speed"' expect_fail bench-typo-line "typo.toml:3: system \"a\"" "" -- \
  bench particles "$tmp/typo.toml" --count 10 --steps 1
also_fixed='"max_particles" = -3' expect_fail bench-negative-line "negative.toml:2: system 1" "" -- \
  bench particles "$tmp/negative.toml" --count 10 --steps 1
expect_fail bench-missing "missing.toml: no such file" "" -- bench particles "$tmp/missing.toml" --count 10

# A count no memory holds: one line, no attempt (2^30 particles need some 90 GB).
expect_fail bench-too-many "GB, more than the" "" -- bench particles "$source_dir/examples/particles/fire.toml" \
  --count 1073741824 --steps 1

for sim in cpu gpu; do
  if expect_ok "bench-$sim" bench particles "$source_dir/examples/particles/fire.toml" --count 3000 --steps 3 \
    --sim "$sim" --json; then
    grep -q '"live": 3000' "$tmp/stdout" || fail "bench-$sim: expected 3000 live particles: $(cat "$tmp/stdout")"
    grep -q '"median_step_ms"' "$tmp/stdout" || fail "bench-$sim: no median_step_ms: $(cat "$tmp/stdout")"
  fi
done
finish particles
