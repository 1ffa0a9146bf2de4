#!/usr/bin/env bash
# The unit-free defaults on digital surfaces (issue 14's rule in 3D): relative max error of the
# operator against the exact Laplace-Beltrami operator (SPEC §7) for the reference surfaces and
# two of our own that the tests do not use, two ambient functions, the default c_t = 0.1 and
# its neighbours 0.03 and 0.3, II and exact normals. Prints markdown tables (docs/accuracy.md).
# Usage: scripts/surface_study.sh   (after scripts/build.sh; about 5 minutes on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
app=build/apps/digilap-convergence
steps="0.1 0.07 0.05 0.035 0.025"
echo "| surface | function | c_t | normals | h = 0.1 | 0.07 | 0.05 | 0.035 | 0.025 | slope |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for shape in sphere ellipsoid torus ellipsoid:a=1.5,b=1,c=0.5 torus:R=1,r=0.25; do
  for function in x2 xy; do
    for ct in 0.03 0.1 0.3; do
      if [ "$function" = xy ] && [ "$ct" != 0.1 ]; then continue; fi
      out=$(mktemp -d)
      "$app" --quiet --shape "$shape" --function "$function" --ct "$ct" --h $steps --out "$out" > "$out/table.md"
      for normals in ii exact; do
        errors=$(awk -F'|' -v n="$normals" '$3 ~ "^ "n" $" && $2 ~ /[0-9]/ {gsub(/ /, "", $8); printf "%s | ", $8}' "$out/table.md")
        slope=$(awk -F'|' -v n="$normals" '$2 ~ "^ "n" $" {gsub(/ /, "", $4); print $4}' "$out/table.md")
        echo "| $shape | $function | $ct | $normals | $errors$slope |"
      done
      rm -rf "$out"
    done
  done
done
