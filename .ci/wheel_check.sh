#!/usr/bin/env bash
# Wheel check: build the wheel from this checkout, install it with its dependencies into a fresh
# venv, and run the CLI from a temporary folder outside the checkout, so that every data file
# (models, policies, scenarios, hyperparameters) must come from the installed wheel.
# Prints one line per command with its exit status; exits non-zero if any failed.
# Environment: PYTHON (default python3) makes the venv; WHEEL_CHECK_KEEP=1 keeps the temp folder.
set -euo pipefail

REPO="$(cd "$(dirname "$0")/.." && pwd -P)"
PYTHON="${PYTHON:-python3}"
TMP="$(cd "$(mktemp -d -t drake_tooluse_wheel.XXXXXX)" && pwd -P)"
case "$TMP/" in "$REPO"/*) echo "wheel_check: temp folder $TMP is inside the checkout" >&2; exit 1 ;; esac
if [[ "${WHEEL_CHECK_KEEP:-0}" == 1 ]]; then echo "wheel_check: keeping $TMP"
else trap 'rm -rf "$TMP"' EXIT; fi
# Nothing may lead Python back to the checkout.
unset PYTHONPATH PYTHONHOME PYTHONSTARTUP
export PYTHONNOUSERSITE=1

# 1. Build from a copy of the project's own files (tracked, and untracked but not ignored), so no
#    stale build/ or egg-info of the checkout can leak into the wheel.
echo "== build"
mkdir "$TMP/src" "$TMP/dist"
if git -C "$REPO" rev-parse --is-inside-work-tree >/dev/null 2>&1; then
    (cd "$REPO" && git ls-files -z --cached --others --exclude-standard \
        | while IFS= read -r -d '' f; do if [[ -f "$f" ]]; then printf '%s\0' "$f"; fi; done \
        | tar --null -T - -cf -) | tar -xf - -C "$TMP/src"
else
    tar -C "$REPO" --exclude=.git --exclude=.venv --exclude=build --exclude='*.egg-info' \
        --exclude=runs --exclude=__pycache__ -cf - . | tar -xf - -C "$TMP/src"
fi
"$PYTHON" -m venv "$TMP/venv"
VPY="$TMP/venv/bin/python"
"$VPY" -m pip wheel --no-deps -w "$TMP/dist" "$TMP/src"
WHEELS=("$TMP"/dist/drake_tooluse-*.whl)
[[ ${#WHEELS[@]} == 1 && -f "${WHEELS[0]}" ]] || { echo "wheel_check: no single wheel built" >&2; exit 1; }
WHEEL="${WHEELS[0]}"

# The wheel carries the data (checked before the long install).
"$VPY" - "$WHEEL" <<'EOF'
import sys, zipfile
names = set(zipfile.ZipFile(sys.argv[1]).namelist())
need = ["drake_tooluse/models/package.xml", "drake_tooluse/models/baxter/baxter.urdf",
        "drake_tooluse/scenarios/push.yaml", "drake_tooluse/scenarios/reality.yaml",
        "drake_tooluse/scenarios/pull.yaml",
        "drake_tooluse/paths.py"]
need += [f"drake_tooluse/models/policies/{p}/{f}" for p in ("ppo_toolpush", "ppo_toolpush_tip", "ppo_toolpush_paper_action",
                                                           "ppo_toolpush_tip_far", "ppo_toolpull")
         for f in ("policy.json", "policy.safetensors", "normalization.json", "metrics.json")]
missing = [n for n in need if n not in names]
if not any(n.startswith("drake_tooluse/") and "/hyperparams/" in n and n.endswith(".yaml") for n in names):
    missing.append("drake_tooluse/**/hyperparams/*.yaml")
print(f"wheel: {sys.argv[1].rsplit('/', 1)[-1]}, {len(names)} files")
sys.exit(f"wheel_check: the wheel lacks {missing}" if missing else 0)
EOF

# 2. Install the wheel with its dependencies (the pins of its own metadata).
echo "== install"
"$VPY" -m pip install "$WHEEL"
"$VPY" -m pip list 2>/dev/null | grep -i -E '^(drake|torch|drake-tooluse) ' || true

# 3. Run from a fresh folder outside the checkout.
mkdir "$TMP/work"
cd "$TMP/work"
export PATH="$TMP/venv/bin:$PATH"
[[ "$(command -v drake-tooluse)" == "$TMP/venv/bin/drake-tooluse" ]] \
    || { echo "wheel_check: drake-tooluse is not the venv's: $(command -v drake-tooluse)" >&2; exit 1; }
"$VPY" - "$REPO" <<'EOF'
import importlib.util, os, sys, sysconfig
repo = os.path.realpath(sys.argv[1])
leaks = [p for p in sys.path
         if (os.path.realpath(p or os.getcwd()) + os.sep).startswith(repo + os.sep)]
site = os.path.realpath(sysconfig.get_paths()["purelib"])
spec = importlib.util.find_spec("drake_tooluse")  # where it would come from, before running it
where = os.path.realpath(spec.origin) if spec and spec.origin else None
print(f"drake_tooluse: {where}")
if leaks or not where or not where.startswith(site + os.sep):
    sys.exit(f"wheel_check: not the installed wheel (site-packages {site}; checkout on sys.path: {leaks})")
import drake_tooluse
assert os.path.realpath(drake_tooluse.__file__) == where, drake_tooluse.__file__
EOF
TRANSFER_POLICY="$("$VPY" -c 'from drake_tooluse.paths import TRANSFER_POLICY; print(TRANSFER_POLICY)')"
echo "TRANSFER_POLICY: $TRANSFER_POLICY"

SUMMARY=()
FAILED=0
check() {  # runs one command, records its exit status
    echo "== $*"
    local rc=0
    "$@" || rc=$?
    if (( rc != 0 )); then FAILED=1; fi
    SUMMARY+=("exit $rc: $*")
}
check drake-tooluse --version
check drake-tooluse demo --out demo --no-progress
check drake-tooluse ik --tool-length 0.175 --position 0.65 -0.25 -0.10 --json
check drake-tooluse evaluate --policy "$TRANSFER_POLICY" --episodes 2 --json
check drake-tooluse measure --tool-length 0.15 --json
check drake-tooluse measure-box --json
check drake-tooluse transfer --tools 0.15 --runs 1 --out transfer
check drake-tooluse transfer --mode open-loop --tools 0.15 --runs 1 --episodes 2 --out transfer-open
check drake-tooluse record-video --out episode.gif --render-size 160 120 --every 10
# The pull with the shipped hook policy, and the choice (the far-push policy) with its recording.
check drake-tooluse demo --task pull --out demo-pull --no-progress
check drake-tooluse choose-tool --task push-far --seed 2 --rollouts 1 --record choice.html
# A tool the robot has never seen (the held-out family), measured by its shape, and the push.
check drake-tooluse demo --tool random --seed 0 --out demo-random --no-progress
check drake-tooluse measure-shape --family two_bend --tool-seed 3 --json

echo "== wheel check"
printf '%s\n' "${SUMMARY[@]}"
exit "$FAILED"
