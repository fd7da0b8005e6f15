#!/usr/bin/env bash
# Digests of small renders at a fixed seed, for "images unchanged" checks
# across a refactor: run it before and after, then diff the two outputs.
#   scripts/image_digests.sh [SNELL_BINARY] > digests.txt
# Every shipped nested, reference and medium scene, each nested scene with
# every strategy, the glass scenes also with the Whitted integrator.
set -euo pipefail
cd "$(dirname "$0")/.."
# Honours CARGO_TARGET_DIR (a worktree building into its own target).
target=${CARGO_TARGET_DIR:-target}
bin=${1:-$target/release/snell}
cargo build --release --quiet --example image_digest
digest=$target/release/examples/image_digest
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
r() { # name out-tag extra-args...
  local scene=$1 tag=$2; shift 2
  "$bin" render "scenes/$scene.toml" -o "$tmp/$scene.$tag.exr" --width 96 --height 72 --spp 8 \
    --seed 7 --threads 2 --quiet "$@" >/dev/null
  "$digest" "$tmp/$scene.$tag.exr" | sed "s|$tmp/||"
}
for s in three_spheres glass_of_water cylinder_refraction heat_shimmer mirage_road mirage_sea; do
  r $s path
done
for s in glass_of_water_nested glass_ice_bubbles deep_nesting nested_spheres_a nested_spheres_b; do
  for m in filter recast toggle off; do r $s $m --nested $m; done
done
for s in glass_of_water glass_of_water_nested nested_spheres_a; do
  r $s whitted --set integrator.type=whitted
done
