#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main demo: the convergence experiment (the
# paper's Figure 5) on the flower, then the spectrum and a heat flow. Results go to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/build.sh
echo "== Convergence of the digital Laplace-Beltrami operator (flower, g = x^2) =="
build/apps/digilap-convergence --out out/convergence
echo
echo "== Smallest eigenvalues on the flower, h = 0.005 =="
build/apps/digilap-spectrum --h 0.005 --out out/spectrum --quiet
echo
echo "== Heat flow of a bump on the flower =="
build/apps/digilap-heat --initial bump --tau 2 --steps 200 --out out/heat --quiet
echo
echo "Open out/convergence/convergence.svg, out/spectrum/eigenvectors.svg and out/heat/heat.svg."
