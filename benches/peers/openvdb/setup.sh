#!/usr/bin/env bash
# OpenVDB / NanoVDB peer (issue 33): Debian packages and the vdbpeer program.
#
#   benches/peers/openvdb/setup.sh          installs what is missing, builds build/vdbpeer
#
# Debian 12 (bookworm) ships OpenVDB 10.0.1: libopenvdb-dev (the library, TBB, Blosc, Imath),
# libnanovdb-dev (NanoVDB's headers). OpenVDB 10's headers include Boost's numeric conversion
# headers but libopenvdb-dev does not depend on libboost-dev, so it is listed here. The report
# needs numpy, matplotlib and Pillow of the system Python (/usr/bin/python3).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
PKGS=(libopenvdb-dev libnanovdb-dev libboost-dev libpng-dev g++ python3-numpy python3-matplotlib python3-pil)
missing=()
for p in "${PKGS[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2> /dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
    echo "[openvdb setup] apt-get install ${missing[*]}" >&2
    SUDO=""; [ "$(id -u)" = 0 ] || SUDO=sudo
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" > /dev/null
fi
mkdir -p "$HERE/build"
BIN="$HERE/build/vdbpeer"
if [ ! -x "$BIN" ] || [ "$HERE/vdbpeer.cpp" -nt "$BIN" ]; then
    echo "[openvdb setup] g++ -O2 vdbpeer.cpp (about a minute)" >&2
    nice -n "${VDB_NICE:-10}" g++ -O2 -std=c++17 -o "$BIN.tmp" "$HERE/vdbpeer.cpp" \
        -lopenvdb -ltbb -lpng -lImath-3_1 -lblosc -lz -lpthread
    mv "$BIN.tmp" "$BIN"
fi
echo "$BIN"
