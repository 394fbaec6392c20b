#!/usr/bin/env bash
# Builds standcal's Debian package from this tree with debhelper (debian/) and checks it
# with lintian:  scripts/package.sh  ->  build/package/standcal_VERSION_ARCH.deb
# Install it on a bench PC with `apt-get install ./standcal_VERSION_ARCH.deb`
# (docs/install.md). The package is built by g++ with Debian's flags (dpkg-buildflags).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
"$root/scripts/setup.sh" debhelper dpkg-dev lintian

out="$root/build/package"
version=$(dpkg-parsechangelog -l "$root/debian/changelog" -S Version)
src="$out/standcal-$version"
rm -rf "$out"
mkdir -p "$src"
# dpkg-buildpackage works in the source tree and writes beside it: build from a copy of
# the tracked files (as they are in the working tree), so the checkout stays clean.
git -C "$root" ls-files -z --cached --others --exclude-standard | (cd "$root" && xargs -0 cp --parents -t "$src")
# The commit, marked -dirty when the copied files differ from it (uncommitted changes or
# untracked files), so --version never claims a commit the package was not built from.
export STANDCAL_GIT_COMMIT
STANDCAL_GIT_COMMIT=$(git -C "$root" rev-parse --short=12 HEAD)
if [ -n "$(git -C "$root" status --porcelain)" ]; then STANDCAL_GIT_COMMIT="$STANDCAL_GIT_COMMIT-dirty"; fi
(cd "$src" && dpkg-buildpackage --build=binary --no-sign -j"$(nproc)")

# Errors and warnings fail the build. No tag is overridden (docs/install.md lists the
# informational ones).
lintian --fail-on error,warning --info "$out"/standcal_"$version"_*.changes
ls -l "$out"/standcal_"$version"_*.deb
