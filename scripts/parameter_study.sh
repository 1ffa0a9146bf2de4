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
shapes=(flower accflower ellipse circle)

header "### Every reference shape at the defaults (c_t = 0.1, k_R = 2, k = 6, l measured)"
for shape in "${shapes[@]}"; do
  for fn in x2 cos1 cos3; do run "$shape, $fn" --shape "$shape" --function "$fn" --operators geodesic richardson-euclidean dgtal; done
done
header "### The same with the former constants (t = 0.03 h^(2/3), R = h^(1/3): l = 1, c_t = 0.03, k_R = 1)"
for shape in "${shapes[@]}"; do
  for fn in x2 cos1 cos3; do run "$shape, $fn" --shape "$shape" --function "$fn" --operators geodesic --length-scale 1 --ct 0.03 --kR 1; done
done
header "### Shapes the tests do not use, at the defaults (parameters and pose from the command line)"
for spec in "flower:R=1.5,v=0.3,k=4 --rotate 30" "flower:R=2,v=0.6,k=7" "ellipse:a=3,b=0.8 --rotate 15" "accflower:R=2,v=0.3,k=3" "circle:r=5 --centre 0.3,-0.1"; do
  # shellcheck disable=SC2086
  for fn in x2 cos1; do run "${spec%% *}, $fn" --shape $spec --function "$fn" --operators geodesic; done
done
header "### Heat time constant c_t (k_R = 2, l measured), g = x2"
for shape in flower accflower ellipse circle; do
  for ct in 0.03 0.07 0.1 0.15 0.3; do run "$shape, c_t = $ct" --shape "$shape" --ct "$ct" --operators geodesic; done
done
header "### Heat time constant c_t, intrinsic g = cos1 (k_R = 2, l measured)"
for shape in flower accflower; do
  for ct in 0.03 0.1 0.3 1; do run "$shape, c_t = $ct" --shape "$shape" --function cos1 --ct "$ct" --operators geodesic; done
done
header "### II radius constant k_R (c_t = 0.1, l measured), g = x2"
for shape in flower accflower ellipse circle; do
  for kr in 1 1.5 2 2.5 3; do run "$shape, k_R = $kr" --shape "$shape" --kR "$kr" --operators geodesic geodesic-exact; done
done
header "### Quantile of the radii of curvature that l is (c_t = 0.1, k_R = 2), g = x2"
for shape in flower accflower ellipse circle; do
  for q in 0.01 0.02 0.05 0.1; do run "$shape, quantile $q" --shape "$shape" --length-quantile "$q" --operators geodesic; done
done
header "### Kernel cut k (defaults otherwise), flower, g = x2"
for k in 3 4.24 6 8; do run "k = $k" --k "$k" --operators geodesic euclidean; done
header "### Sampling: closest point vs radial projection (flower, x2)"
for s in closest radial; do run "$s" --function x2 --sampling "$s" --operators geodesic dgtal; done
rm -rf "$out"
