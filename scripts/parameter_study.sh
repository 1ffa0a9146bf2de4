#!/usr/bin/env bash
# Regenerates the tables of docs/accuracy.md: runs digilap-convergence over parameter values and
# prints, for each run, the relative max error at the finest h and the fitted slopes.
# Usage: scripts/parameter_study.sh [build dir] > study.md     (about 2 minutes on 2 cores)
set -euo pipefail
app="${1:-build}/apps/digilap-convergence"
[ -x "$app" ] || { echo "build first: $app not found" >&2; exit 1; }
out=$(mktemp -d)
run() {  # run <label> <args...>: one table row per operator
  local label="$1"; shift
  "$app" -q --out "$out" "$@" | sed -n '/rel max err at/,/^$/p' | tail -n +3 | sed '/^$/d' |
    while IFS= read -r line; do echo "| $label $line"; done
}
header() { echo; echo "$1"; echo; echo "| setting | operator | rel max err at h = 0.001 | slope (0.1 .. 0.001) | slope (finest 3) |"; echo "|---|---|---|---|---|"; }

ops=(geodesic euclidean richardson-geodesic richardson-euclidean)
for fn in x2 xy cos1 cos3; do
  header "### Flower, g = $fn: heat time constant c_t (k_R = 1, k = 6)"
  for ct in 0.01 0.03 0.1 0.3; do run "c_t = $ct" --function "$fn" --ct "$ct" --operators "${ops[@]}"; done
done
header "### Flower, g = x2: II radius constant k_R (c_t = 0.03)"
for kr in 0.5 1 1.5 2; do run "k_R = $kr" --function x2 --kR "$kr" --operators geodesic geodesic-exact richardson-euclidean; done
header "### Flower, g = x2: kernel cut k (c_t = 0.03)"
for k in 3 4.24 6 8; do run "k = $k" --function x2 --k "$k" --operators geodesic euclidean; done
header "### All reference shapes at the defaults (c_t = 0.03, k_R = 1, k = 6)"
for shape in circle ellipse flower accflower; do
  for fn in x2 cos1; do run "$shape, $fn" --shape "$shape" --function "$fn" --operators geodesic richardson-euclidean dgtal dec-naive; done
done
header "### Sampling: closest point vs radial projection (flower, x2)"
for s in closest radial; do run "$s" --function x2 --sampling "$s" --operators geodesic dgtal; done
rm -rf "$out"
