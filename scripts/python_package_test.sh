#!/usr/bin/env bash
# The Python package as a user installs it (issue 22): a fresh venv over Debian's NumPy and SciPy,
# pip install --no-build-isolation --no-index (offline), then the Python tests run against the
# installed package, from outside the source tree. Reuses ./build when it exists.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh python3-venv python3-pip python3-setuptools python3-wheel
venv=$(mktemp -d)/venv
/usr/bin/python3 -m venv --system-site-packages "$venv"
DIGILAP_BUILD_DIR=${DIGILAP_BUILD_DIR:-build} "$venv/bin/pip" install --quiet --no-build-isolation --no-index .
tests=$(pwd)/tests/python
cd "$(dirname "$venv")"
"$venv/bin/python" -c "import digilap, digilap.surface; print('installed digilap from', digilap.__file__)"
case "$("$venv/bin/python" -c 'import digilap; print(digilap.__file__)')" in
  "$venv"/*) ;;
  *) echo "python_package_test: digilap was not imported from the venv" >&2; exit 1 ;;
esac
"$venv/bin/python" -m pytest -q -p no:cacheprovider "$tests"
