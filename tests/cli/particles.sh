#!/usr/bin/env bash
# `mirage bench particles` and `mirage particles` (docs/particles.md): a bad effect file gets one
# line naming file, line and key, exit 2, and no image; both simulations run a small effect and
# report the live particles they hold; rendering writes a PNG of the asked size (numbered frames
# with --every), over a scene file and over a .mrg asset.
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
expect_fail bench-missing "missing.toml: file not found" "" -- bench particles "$tmp/missing.toml" --count 10

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
# bench --render: simulation and drawing timed together (GPU only).
if expect_ok bench-render bench particles "$source_dir/examples/particles/fire.toml" --count 2000 --steps 2 --sim gpu \
  --render --size 64x36 --json; then
  grep -q '"render_ms"' "$tmp/stdout" || fail "bench-render: no render_ms: $(cat "$tmp/stdout")"
  grep -q '"msl"' "$tmp/stdout" || fail "bench-render: no msl: $(cat "$tmp/stdout")"
  grep -q '"splat_ms"' "$tmp/stdout" || fail "bench-render: no splat_ms: $(cat "$tmp/stdout")"
fi
# Small sparks seen from afar are splatted (few billboards left); --no-splat draws them all.
sparks="$source_dir/examples/particles/sparks.toml"
if expect_ok bench-render-splat bench particles "$sparks" --count 2000 --steps 2 --sim gpu --render --size 96x54 \
  --camera eye=0,1,40,target=0,1,0 --json; then
  grep -q '"billboards": [0-9]\{1,2\},' "$tmp/stdout" || fail "bench-render-splat: billboards: $(cat "$tmp/stdout")"
fi
if expect_ok bench-render-nosplat bench particles "$sparks" --count 2000 --steps 2 --sim gpu --render --size 96x54 \
  --camera eye=0,1,40,target=0,1,0 --no-splat --json; then
  grep -q '"billboards": 2000,' "$tmp/stdout" || fail "bench-render-nosplat: $(cat "$tmp/stdout")"
fi
# The splat binned by screen tiles and by per-pixel atomics leave the same billboards; the JSON
# names the one that ran.
for method in binned atomic; do
  if expect_ok "bench-render-$method" bench particles "$sparks" --count 2000 --steps 2 --sim gpu --render \
    --size 96x54 --camera eye=0,1,40,target=0,1,0 --splat-method "$method" --separate-output --json; then
    grep -q "\"splat_method\": \"$method\"" "$tmp/stdout" || fail "bench-render-$method: $(cat "$tmp/stdout")"
    grep -q '"fused_output": false' "$tmp/stdout" || fail "bench-render-$method: fused: $(cat "$tmp/stdout")"
    grep -q '"billboards": [0-9]\{1,2\},' "$tmp/stdout" || fail "bench-render-$method: billboards: $(cat "$tmp/stdout")"
  fi
done
expect_fail bench-render-method "--splat-method" "" -- bench particles "$sparks" --count 10 --sim gpu --render \
  --splat-method quantum
expect_fail bench-render-camera "--camera 'nowhere'" "" -- bench particles "$sparks" --count 10 --sim gpu --render \
  --camera nowhere
expect_fail bench-render-cpu "--render needs --sim gpu" "" -- bench particles "$source_dir/examples/particles/fire.toml" \
  --count 10 --render

# mirage particles: bad effects and bad options, one line, exit 2, no image left.
for bad in typo negative module syntax; do
  expect_fail "render-$bad" "error: $tmp/$bad.toml:[0-9]*: " "$tmp/bad_$bad.png" -- particles "$tmp/$bad.toml" \
    --frames 2 --size 32x32 -o "$tmp/bad_$bad.png"
done
expect_fail render-missing "missing.toml: file not found" "$tmp/missing.png" -- particles "$tmp/missing.toml" \
  -o "$tmp/missing.png"
fire="$source_dir/examples/particles/fire.toml"
expect_fail render-dt "--dt 'fast'" "$tmp/dt.png" -- particles "$fire" --dt fast -o "$tmp/dt.png"
expect_fail render-sim "--sim" "$tmp/sim.png" -- particles "$fire" --sim quantum -o "$tmp/sim.png"
expect_fail render-ext "must be a .png\\|png" "$tmp/out.jpg" -- particles "$fire" -o "$tmp/out.jpg"
expect_fail render-scene "nothing.obj" "$tmp/scene.png" -- particles "$fire" --scene "$tmp/nothing.obj" \
  -o "$tmp/scene.png"

for sim in cpu gpu; do
  if expect_ok "render-$sim" particles "$fire" --frames 20 --dt 1/60 --sim "$sim" --size 48x32 \
    -o "$tmp/fire_$sim.png" --json; then
    check "render-$sim-size" test "$(png_size "$tmp/fire_$sim.png")" = 48x32
    grep -q '"live": [1-9]' "$tmp/stdout" || fail "render-$sim: no live particles: $(cat "$tmp/stdout")"
  fi
done
expect_ok render-nosplat particles "$fire" --frames 6 --size 32x32 --no-splat -o "$tmp/nosplat.png"
if expect_ok render-every particles "$fire" --frames 6 --every 3 --size 32x32 -o "$tmp/seq.png"; then
  check render-every-files test -f "$tmp/seq_0000.png" -a -f "$tmp/seq_0001.png" -a ! -e "$tmp/seq.png"
fi
# mirage render SCENE --particles FX.toml: the effect drawn with a forward scene.
if expect_ok render-scene-particles render gen:blob:8 --particles "$fire" --particle-frames 10 --size 40x30 \
  -o "$tmp/scene_fx.png" --json; then
  check render-scene-particles-size test "$(png_size "$tmp/scene_fx.png")" = 40x30
  grep -q '"oit_fragments": [1-9]' "$tmp/stdout" || fail "render-scene-particles: no particle fragments"
fi
expect_fail render-scene-bad "error: $tmp/typo.toml:[0-9]*: " "$tmp/scene_bad.png" -- render gen:blob:8 \
  --particles "$tmp/typo.toml" --size 40x30 -o "$tmp/scene_bad.png"
# mirage render ASSET.mrg --particles: the cluster-LOD renderer appends them to its transparency lists.
if expect_ok build-blob-mrg build gen:blob:4 -o "$tmp/blob.mrg" --quiet; then
  if expect_ok render-mrg-particles render "$tmp/blob.mrg" --particles "$fire" --particle-frames 10 \
    --particle-sim gpu --size 40x30 -o "$tmp/mrg_fx.png" --json; then
    check render-mrg-particles-size test "$(png_size "$tmp/mrg_fx.png")" = 40x30
    grep -q '"oit_fragments": [1-9]' "$tmp/stdout" || fail "render-mrg-particles: no particle fragments"
  fi
fi
finish particles
