#!/usr/bin/env bash
# Records the hashes of the apps' outputs (operators, spectra, heat flow, convergence tables; 2D
# and 3D; Python) for a fixed set of small runs, so that a refactoring can be checked to change
# nothing: run it at the commit before and after, and diff the two lists.
#   ./scripts/output_hashes.sh [BUILD_DIR] > hashes.txt
# Each line: <sha256> <run>/<file>. Stdout tables are hashed too (the timing lines removed).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
apps=$build/apps
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
run() {  # name, app, args...
  local name=$1 app=$2; shift 2
  "$apps/$app" "$@" --out "$work/$name" -q > "$work/$name.stdout" 2>/dev/null || echo "exit $?" >> "$work/$name.stdout"
  grep -v -iE "seconds| s$|time:|[0-9] s[ ,)]|wrote " "$work/$name.stdout" | untimed '|' '\\(s\\)' > "$work/$name.table" || true
}
# Drops the columns whose header matches $2 (timings) from a table separated by $1.
untimed() {
  awk -F"$1" -v OFS="$1" -v pat="$2" '
    NF > 1 && !seen { for (i = 1; i <= NF; ++i) if ($i ~ pat) seen = 1; if (seen) for (i = 1; i <= NF; ++i) drop[i] = ($i ~ pat) }
    { line = ""; for (i = 1; i <= NF; ++i) if (!drop[i]) line = line (line == "" && i == 1 ? "" : OFS) $i; print line }'
}
run spectrum2d digilap-spectrum --h 0.01
run spectrum2d_pc digilap-spectrum --h 0.02 --shape ellipse --per-contour
run spectrum2d_mf digilap-spectrum --h 0.005 --matrix-free
run operator2d digilap-operator --h 0.02
run operator2d_npz digilap-operator --h 0.02 --format npz
run heat2d digilap-heat --h 0.02 --initial bump --tau 1 --steps 20
run convergence2d digilap-convergence --shape circle --h 0.05 0.035 0.025
run convergence3d digilap-convergence --shape sphere --h 0.2 0.15
run spectrum3d digilap-spectrum --shape sphere --h 0.1 --count 9
run operator3d digilap-operator --shape torus --h 0.1
run heat3d digilap-heat --shape sphere --h 0.1 --tau 0.1 --steps 5
run volume3d digilap-spectrum --volume tests/data/ball.nii.gz --count 6
[ -f ../shared/data/JHU-WhiteMatter-labels-2mm.nii.gz ] && run label3d digilap-spectrum --volume ../shared/data/JHU-WhiteMatter-labels-2mm.nii.gz --label 3 --largest --count 6
for d in "$work"/*/; do
  name=$(basename "$d")
  for f in $(cd "$d" && find . -type f ! -name '*.svg' | sort); do
    case "$f" in
      *.csv) h=$(untimed , '^seconds' < "$d/$f" | sha256sum | cut -d' ' -f1) ;;
      *) h=$(sha256sum < "$d/$f" | cut -d' ' -f1) ;;
    esac
    echo "$h  $name/${f#./}"
  done
done
for f in "$work"/*.table; do
  echo "$(sha256sum < "$f" | cut -d' ' -f1)  $(basename "$f")"
done
if [ -d "$build/python/digilap" ]; then
  PYTHONPATH=$build/python /usr/bin/python3 - <<'PY'
import hashlib, numpy as np, digilap
yy, xx = np.mgrid[0:120, 0:160]
mask = (xx - 80) ** 2 / 60**2 + (yy - 60) ** 2 / 30**2 < 1
L, M = digilap.laplacian(mask)
h = hashlib.sha256(L.data.tobytes() + L.indices.tobytes() + M.diagonal().tobytes()).hexdigest()
print(h, " python/laplacian_2d")
PY
fi
