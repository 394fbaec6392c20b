#!/usr/bin/env bash
# Installs every Debian package standcal builds, tests or runs with. Idempotent:
# packages already present are skipped, so a second run is fast and offline-safe.
#   scripts/setup.sh [EXTRA_PACKAGE...]   also installs tools one script needs (soak: gdb)
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev
  libmodbus-dev libsystemd-dev
  # systemd-analyze verifies the installed units (test install_tree); systemd's pkg-config
  # file says where units, sysusers.d and tmpfiles.d go (below for Debian 13).
  systemd
  libplplot-dev libsqlite3-dev libpq-dev libxml2-dev
  # zlib's CRC-32: the compensation file's checksum, and the C example that checks it.
  zlib1g-dev
  # Boost.Math (header-only): the exact χ² tail of the consistency verdicts.
  libboost-dev
  # utfcpp (header-only): is a text field, a header value or a request UTF-8, and where not.
  libutfcpp-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  socat
  # Man pages (docs/CMakeLists.txt): standcal(1) and standcald(8) from --help-all,
  # standcald.json(5) from Markdown.
  help2man lowdown
  # scripts/build.sh and the fuzzers use clang and lld: clang compiles this tree's
  # Eigen-heavy code in about half the CPU time of g++ (scripts/build.sh says more).
  clang-14 libclang-rt-14-dev lld-14
  # scripts/test.sh checks the formatting (.clang-format) before it builds.
  clang-format-14
  # `standcal certificate -o FILE.pdf` renders with WeasyPrint; the tests read the PDF back
  # with poppler's pdftotext and pdfinfo.
  weasyprint poppler-utils
  # The PostgreSQL records tests start a throw-away server on a loopback port.
  postgresql
  "$@"
)
# From Debian 13 on (and in testing, which has no VERSION_ID), systemd's pkg-config file
# is in systemd-dev.
release=$(. /etc/os-release && echo "${ID:-} ${VERSION_ID:-99}")
if [ "${release% *}" = debian ] && [ "${release#* }" -ge 13 ] 2>/dev/null; then
  packages+=(systemd-dev)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${missing[*]}" >&2
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
