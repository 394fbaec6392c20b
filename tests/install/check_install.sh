#!/usr/bin/env bash
# check_install.sh CMAKE BUILD_DIR PREFIX SYSCONFDIR EXPECTED_LIST
# Installs BUILD_DIR into a temporary DESTDIR and checks what a bench PC would get:
#  - exactly the files in EXPECTED_LIST (PREFIX written as @PREFIX@), no more, no fewer;
#  - the systemd units pass `systemd-analyze verify` against the staged tree (their
#    ExecStart names the staged binary), and name the state directory standcal;
#  - the staged programs start (--version names version, commit and build type), and the
#    man pages carry each program's options and the exit-status table.
set -euo pipefail
cmake=$1 build=$2 prefix=$3 sysconfdir=$4 expected=$5
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
stage=$work/root
fail() { echo "check_install: $*" >&2; exit 1; }

DESTDIR="$stage" "$cmake" --install "$build" >/dev/null
(cd "$stage" && find . -type f -o -type l | sed 's|^\./|/|' | sort) >"$work/actual"
# systemd's directories as this system's systemd.pc names them (/lib or /usr/lib).
units=$(pkg-config --variable=systemdsystemunitdir systemd)
sed -e "s|@PREFIX@|$prefix|g" -e "s|@SYSCONF@|$sysconfdir|g" -e "s|@UNITDIR@|$units|g" \
    -e "s|@SYSUSERSDIR@|$(pkg-config --variable=sysusersdir systemd)|g" \
    -e "s|@TMPFILESDIR@|$(pkg-config --variable=tmpfilesdir systemd)|g" "$expected" |
  grep -v '^#' | sort >"$work/expected"
diff -u "$work/expected" "$work/actual" || fail "the installed files differ from $expected (- expected, + installed)"

grep -qx "ExecStart=$prefix/bin/standcald --config .*standcal/standcald.json" "$stage$units/standcald.service" ||
  fail "standcald.service: ExecStart does not run $prefix/bin/standcald with the installed config"
grep -qx "StateDirectory=standcal" "$stage$units/standcald.service" || fail "standcald.service: StateDirectory is not standcal"
# --man=no: the man pages are checked below, in the staged tree (man(1) looks in /usr).
# --recursive-errors=no: the host's own targets are not ours to check.
# Any output is a finding too (an unknown key is only a warning to systemd, and ignored).
verify=$(systemd-analyze verify --man=no --recursive-errors=no --root="$stage" standcald.service standcald.socket 2>&1) ||
  fail "systemd-analyze verify failed on the installed units: $verify"
[[ -z $verify ]] || fail "systemd-analyze verify warns about the installed units: $verify"

for program in standcal standcald; do
  version=$("$stage$prefix/bin/$program" --version) || fail "$program --version failed"
  [[ $version =~ ^[0-9]+\.[0-9]+\.[0-9]+\ \(commit\ ([0-9a-f]+(-dirty)?|unknown),\ .+\ build\)$ ]] ||
    fail "$program --version says '$version', not 'VERSION (commit C, TYPE build)'"
done
for program in standcal-stand-emu standcal-can-emu; do
  "$stage$prefix/bin/$program" --help >/dev/null || fail "$program --help failed"
done

man=$stage$prefix/share/man
grep -qF -- '\-\-compensation' "$man/man1/standcal.1" || fail "standcal.1 lacks the fit command's options"
grep -qF -- '\-\-config' "$man/man8/standcald.8" || fail "standcald.8 lacks --config"
for page in man1/standcal.1 man8/standcald.8; do
  grep -qi 'exit status' "$man/$page" || fail "$page has no exit-status section"
done
grep -q 'stand.backend' "$man/man5/standcald.json.5" || fail "standcald.json.5 lacks the stand.backend key"
echo "check_install: $(wc -l <"$work/expected") files, units verified, programs and man pages usable"
