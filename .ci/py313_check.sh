#!/usr/bin/env bash
# The other end of the supported range: Python 3.13 with the newest Drake on PyPI.
#
# Builds (once) a Debian 13 "trixie" root filesystem with debootstrap (Python 3.13), installs
# this checkout into a venv there with the newest Drake, and runs the default test suite and
# `drake-tooluse demo` inside it (chroot). With PY313_WHEEL_CHECK=1 it also runs
# .ci/wheel_check.sh there (a wheel of the checkout installed with its requirements into a fresh
# venv, from the wheelhouse).
#
# Cache: everything lives under PY313_ROOT (default /var/cache/drake_tooluse_py313) and is
# reused: the root filesystem, its Debian packages, a wheelhouse of every requirement and the
# venv. A run copies the checkout in afresh, downloads what PyPI has newer (Drake above all) and
# installs it. PY313_FRESH=1 deletes the root filesystem first.
#
# Needs root (debootstrap, chroot, mount), debootstrap (installed with apt-get if missing),
# Debian's mirror and PyPI. PyPI's torch for Linux is a CUDA build (2.7 GB with its nvidia
# packages): the first run downloads it, later runs reuse the wheelhouse and the venv. The
# wheelhouse keeps superseded releases too (PY313_FRESH=1 starts over).
#
# Measured on the CI machine (2 cores shared with a training run), with PY313_WHEEL_CHECK=1:
# the first run 614 s, 3.4 GB downloaded, 9.9 GB on disk; a later run 348–549 s (the suite
# 110–140 s, the wheel check 175–300 s, as loaded as the machine was), ~50 MB downloaded.
#
# Prints the time of each stage, the bytes this machine received meanwhile and the disk used;
# exits non-zero if the suite, the demo or (when asked) the wheel check failed.
set -euo pipefail

REPO="$(cd "$(dirname "$0")/.." && pwd -P)"
ROOT="${PY313_ROOT:-/var/cache/drake_tooluse_py313}"
MIRROR="${DEBIAN_MIRROR:-http://deb.debian.org/debian}"
SUITE=trixie
# python3 (3.13) and venv; what `import pydrake.all` loads (glib, X11, SM) and what Drake's VTK
# renderer needs headless (EGL with Mesa's drivers); CA certificates for pip's HTTPS.
PACKAGES="python3 python3-venv ca-certificates libglib2.0-0t64 libx11-6 libsm6 libegl1 libegl-mesa0 libgl1-mesa-dri"
VENV=/opt/venv   # inside the root filesystem
WHEELHOUSE=/opt/wheelhouse
SRC=/src/drake-tooluse

[[ "$(id -u)" == 0 ]] || { echo "py313_check: needs root (debootstrap, chroot, mount)" >&2; exit 1; }
case "$ROOT" in /*) ;; *) echo "py313_check: PY313_ROOT must be absolute" >&2; exit 1 ;; esac
[[ "$ROOT" != / ]] || { echo "py313_check: PY313_ROOT is /" >&2; exit 1; }

START=$SECONDS
STAGE_START=$SECONDS
stage() {  # prints the time the previous stage took and names the next
    echo "== py313_check [+$((SECONDS - STAGE_START)) s, total $((SECONDS - START)) s] $*"
    STAGE_START=$SECONDS
}
received() {  # bytes received on every network interface but loopback
    awk -F'[: ]+' 'NR > 2 && $2 != "lo" { s += $3 } END { printf "%.0f\n", s }' /proc/net/dev
}
RX0="$(received)"

mounted_below() {  # the mount points at or below $ROOT (none may remain before a delete)
    awk -v r="$ROOT" '$2 == r || index($2, r "/") == 1 { print $2 }' /proc/self/mounts
}
unmount_all() {
    local m
    for m in $(mounted_below | sort -r); do umount -l "$m" || true; done
}
trap unmount_all EXIT
# Runs a command in the root filesystem with a clean environment (the host's pip settings,
# certificates and Python variables must not leak in).
in_root() {
    chroot "$ROOT" /usr/bin/env -i PATH="$VENV/bin:/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin" \
        HOME=/root LANG=C.UTF-8 DEBIAN_FRONTEND=noninteractive PIP_DISABLE_PIP_VERSION_CHECK=1 \
        MPLBACKEND=Agg "$@"
}

# 1. The root filesystem (debootstrap, once).
if [[ "${PY313_FRESH:-0}" == 1 || ! -f "$ROOT/.py313_base" ]]; then
    stage "debootstrap $SUITE into $ROOT"
    unmount_all
    [[ -z "$(mounted_below)" ]] || { echo "py313_check: mounts remain under $ROOT" >&2; exit 1; }
    rm -rf "$ROOT"
    command -v debootstrap >/dev/null || apt-get install -y -q debootstrap
    mkdir -p "$ROOT"
    debootstrap --variant=minbase "$SUITE" "$ROOT" "$MIRROR" >"$ROOT.debootstrap.log" 2>&1 \
        || { tail -20 "$ROOT.debootstrap.log" >&2; exit 1; }
    touch "$ROOT/.py313_base"
fi

# 2. Mounts: proc, sys (read-only), a private /dev/shm (multiprocessing); the device nodes are
#    debootstrap's own, not the host's /dev.
stage "mount"
unmount_all   # what a killed run left
mount -t proc proc "$ROOT/proc"
mount -t sysfs -o ro sysfs "$ROOT/sys"
mkdir -p "$ROOT/dev/shm"
mount -t tmpfs -o mode=1777,size=2g tmpfs "$ROOT/dev/shm"
for n in null:1:3 zero:1:5 full:1:7 random:1:8 urandom:1:9; do
    IFS=: read -r name major minor <<<"$n"
    [[ -c "$ROOT/dev/$name" ]] || { rm -f "$ROOT/dev/$name"; mknod -m 666 "$ROOT/dev/$name" c "$major" "$minor"; }
done
cp -L /etc/resolv.conf "$ROOT/etc/resolv.conf" 2>/dev/null || true

# 3. The host's local CA certificates (a proxy that re-signs HTTPS needs them for pip), then the
#    Debian packages (again only when the list changes).
stage "certificates and Debian packages"
mkdir -p "$ROOT/usr/local/share/ca-certificates"
if compgen -G "/usr/local/share/ca-certificates/*.crt" >/dev/null; then
    cp /usr/local/share/ca-certificates/*.crt "$ROOT/usr/local/share/ca-certificates/"
fi
if [[ "$(cat "$ROOT/.py313_packages" 2>/dev/null)" != "$PACKAGES" ]]; then
    # shellcheck disable=SC2086
    { in_root apt-get update -q && in_root apt-get install -y -q --no-install-recommends $PACKAGES \
        && in_root apt-get clean; } >"$ROOT.apt.log" 2>&1 || { tail -20 "$ROOT.apt.log" >&2; exit 1; }
    echo "$PACKAGES" >"$ROOT/.py313_packages"
fi
in_root update-ca-certificates >/dev/null
in_root python3 --version

# 4. The checkout, copied in afresh: its tracked files and untracked files that git does not
#    ignore (as the wheel check builds from).
stage "copy the checkout to $SRC"
rm -rf "${ROOT:?}$SRC" "${ROOT:?}/tmp"   # and what the last run's tests left in /tmp
mkdir -m 1777 "$ROOT/tmp"
mkdir -p "$ROOT$SRC"
if git -C "$REPO" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    (cd "$REPO" && git ls-files -z --cached --others --exclude-standard \
        | while IFS= read -r -d '' f; do if [[ -f "$f" ]]; then printf '%s\0' "$f"; fi; done \
        | tar --null -T - -cf -) | tar -xf - -C "$ROOT$SRC"
else
    tar -C "$REPO" --exclude=.git --exclude=.venv --exclude=build --exclude='*.egg-info' \
        --exclude=runs --exclude=__pycache__ -cf - . | tar -xf - -C "$ROOT$SRC"
fi

# 5. The wheelhouse (kept between runs): the newest release of every requirement (Drake
#    included), the build's requirements and pip, resolved on PyPI; a file already there is not
#    downloaded again (pip's own HTTP cache keeps nothing behind this machine's proxy). Then the
#    venv (kept too) installs from the wheelhouse alone: the project with its test extra, Drake
#    upgraded to the newest.
stage "download into $WHEELHOUSE, install into $VENV (newest drake)"
[[ -x "$ROOT$VENV/bin/python" ]] || in_root python3 -m venv "$VENV"
# pyproject's build requirements, quoted for sh (setuptools>=77).
BUILD_REQUIRES="$(in_root python3 -c "import shlex, tomllib; print(shlex.join(tomllib.load(open('$SRC/pyproject.toml', 'rb'))['build-system']['requires']))")"
in_root sh -c "cd /tmp && python -m pip download -q -d $WHEELHOUSE pip $BUILD_REQUIRES drake '$SRC[test]'"
OFFLINE=(env PIP_NO_INDEX=1 PIP_FIND_LINKS="$WHEELHOUSE")
in_root "${OFFLINE[@]}" python -m pip install -q --upgrade pip
in_root "${OFFLINE[@]}" python -m pip install -q --upgrade drake -e "$SRC[test]"
# The kept venv holds nothing the project does not ask for (a package left by an earlier run
# would hide a requirement missing from pyproject.toml): what a fresh resolution would not
# install goes.
in_root "${OFFLINE[@]}" python -m pip install -q --dry-run --ignore-installed \
    --report /tmp/resolved.json drake -e "$SRC[test]"
EXTRA="$(in_root python - <<'EOF'
import json, re, subprocess, sys
norm = lambda name: re.sub(r"[-_.]+", "-", name).lower()
report = json.load(open("/tmp/resolved.json"))
wanted = {norm(i["metadata"]["name"]) for i in report["install"]} | {"pip", "setuptools"}
pip_list = [sys.executable, "-m", "pip", "list", "--format=json"]
have = json.loads(subprocess.run(pip_list, capture_output=True, text=True, check=True).stdout)
print(" ".join(p["name"] for p in have if norm(p["name"]) not in wanted))
EOF
)"
if [[ -n "$EXTRA" ]]; then
    echo "py313_check: removing from the venv what the project does not ask for: $EXTRA"
    # shellcheck disable=SC2086
    in_root python -m pip uninstall -q -y $EXTRA
fi
in_root python -m pip list 2>/dev/null | grep -i -E '^(drake|torch|numpy|stable.baselines3|gymnasium|drake-tooluse) '

FAILED=()
# 6. The default suite (pyproject's addopts: not slow).
stage "pytest (default suite)"
# A time limit: a test that hangs (a forked child deadlocked on a lock another thread held)
# must not take CI's whole budget; normally it takes 2–3 min.
in_root timeout -k 30 "${PY313_PYTEST_TIMEOUT_S:-1200}" sh -c "cd $SRC && python -m pytest -q -p no:cacheprovider" \
    || FAILED+=(pytest)

# 7. The demo, from a folder outside the checkout.
stage "drake-tooluse demo"
in_root timeout -k 30 300 sh -c "mkdir -p /tmp/py313_demo && cd /tmp/py313_demo && drake-tooluse demo --out demo --no-progress" \
    || FAILED+=(demo)

# 8. Optionally, the wheel check (a wheel built from the copy, installed in a fresh venv).
if [[ "${PY313_WHEEL_CHECK:-0}" == 1 ]]; then
    stage "wheel check"
    in_root timeout -k 30 1200 "${OFFLINE[@]}" PYTHON=/usr/bin/python3 bash "$SRC/.ci/wheel_check.sh" \
        || FAILED+=(wheel_check)
fi

stage "done"
unmount_all
echo "py313_check: $(( SECONDS - START )) s, $(( ($(received) - RX0) / 1000000 )) MB received, $(du -sxm "$ROOT" | cut -f1) MB on disk in $ROOT"
if (( ${#FAILED[@]} )); then echo "py313_check: FAILED: ${FAILED[*]}"; exit 1; fi
echo "py313_check: passed"
