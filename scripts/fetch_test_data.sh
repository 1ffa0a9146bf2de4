#!/usr/bin/env bash
# Puts scikit-image's horse silhouette (a real segmented image shipped by Debian's
# python3-skimage) into build/test-data/horse.png for the image tests. Downloads the package
# with apt-get and extracts that one file: none of the package's dependencies are installed.
# Never fails the build: without the file the test is skipped with a message.
set -uo pipefail
cd "$(dirname "$0")/.."
dest=build/test-data/horse.png
system=/usr/lib/python3/dist-packages/skimage/data/horse.png
[ -f "$dest" ] && exit 0
mkdir -p build/test-data
if [ -f "$system" ]; then cp "$system" "$dest"; exit 0; fi
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
SUDO=""
if [ "$(id -u)" -ne 0 ] && command -v sudo > /dev/null; then SUDO="sudo"; fi
download() { (cd "$tmp" && apt-get download python3-skimage > /dev/null 2>&1); }
if ! download; then $SUDO apt-get update -qq > /dev/null 2>&1; download; fi
deb=$(ls "$tmp"/python3-skimage_*.deb 2>/dev/null | head -n 1)
if [ -z "$deb" ]; then
  echo "fetch_test_data: could not download python3-skimage; the horse test will be skipped" >&2
  exit 0
fi
dpkg-deb --fsys-tarfile "$deb" | tar -x -C "$tmp" ./usr/lib/python3/dist-packages/skimage/data/horse.png &&
  cp "$tmp/usr/lib/python3/dist-packages/skimage/data/horse.png" "$dest" &&
  echo "fetch_test_data: extracted horse.png from $(basename "$deb")" >&2
exit 0
