#!/usr/bin/env bash
# The cost of splitting a render for a farm: one `snell render` against the
# same render as NX x NY regions x N sample chunks (one process each, run one
# after another, then `snell merge`), as total CPU time (user + system) of all
# processes, measured in one run, twice, interleaved. docs/farm.md quotes it.
#   jobs/overhead.sh [SCENE] [NX] [NY] [CHUNKS]      (needs target/release/snell)
set -euo pipefail
S=${SNELL:-target/release/snell}
SCENE=${1:-scenes/glass_of_water_nested.toml}
NX=${2:-4}; NY=${3:-4}; N=${4:-4}
THREADS=${THREADS:-1}
D=$(mktemp -d /tmp/snell-overhead.XXXXXX)
trap 'rm -rf "$D"' EXIT
t() { /usr/bin/time -f '%e %U %S' -o "$D/t" "$@" >/dev/null; awk '{printf "%.2f %.2f\n", $1, $2 + $3}' "$D/t"; }
single() { t "$S" render "$SCENE" -o "$D/single.exr" --threads "$THREADS" --quiet; }
split() {
  rm -rf "$D/parts"
  cat > "$D/split.sh" <<SPLIT
for x in \$(seq $NX); do for y in \$(seq $NY); do for k in \$(seq $N); do
  "$S" render "$SCENE" -o "$D/parts/p_\${x}_\${y}_\${k}.exr" --mkdir --threads $THREADS --quiet \\
    --region-cell \$x/$NX,\$y/$NY --sample-chunk \$k/$N
done; done; done
"$S" merge -o "$D/merged.exr" "$D/parts" --quiet
SPLIT
  t bash -e "$D/split.sh"
}
echo "$("$S" --version | tr '\n' ' ')"
echo "scene $SCENE, $NX x $NY regions x $N chunks, $THREADS thread(s) per process"
for round in 1 2; do
  read -r sw sc < <(single)
  read -r pw pc < <(split)
  echo "round $round: single ${sc} s CPU (${sw} s wall); split ${pc} s CPU (${pw} s wall, $((NX * NY * N)) tasks + merge); overhead $(awk "BEGIN{printf \"%.1f\", 100 * ($pc / $sc - 1)}")%"
done
