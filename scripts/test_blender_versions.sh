#!/usr/bin/env bash
# The Blender version matrix: one venv per release with that release's bpy wheel, and the add-on's
# torch-free tier of the tests on each (register/unregister, rig placement, capture with Cycles, panel
# drawing, viewport preview and its restore, export of an existing result, the extension build,
# validate and install), plus the bpy-free core tests that need no torch (numpy 1 vs 2, OpenCV 4.11 vs 4.12).
#
# Usage: bash scripts/test_blender_versions.sh [--setup-only] [--full] [--newest | RELEASE ...]
#   RELEASE       bpy versions to test (default: all of MATRIX below); --newest: the last of them
#   --setup-only  only create the venvs
#   --full        a venv bpy-RELEASE-full with torch and the rest of requirements.txt: the whole suite
# Environment: LAPIG_VENVS (default .venvs, git-ignored), PYTHON311 / PYTHON313 (interpreters to use),
#   LAPIG_WHEELS (--full only: install from this folder of wheels, made by pip download, not the index).
# Results: $LAPIG_VENVS/results/bpy-<release>[-full].txt (pytest's output), .row (one line) and a
# Markdown table at the end. Exit status 0 only when every release passed.
set -uo pipefail
cd "$(dirname "$0")/.."

# release  python  numpy                opencv-contrib-python-headless
MATRIX=(
  "4.2.23 3.11 numpy==1.26.4 4.11.0.86"
  "4.3.0  3.11 numpy==1.26.4 4.11.0.86"
  "4.4.0  3.11 numpy==1.26.4 4.11.0.86"
  "4.5.15 3.11 numpy==1.26.4 4.11.0.86"
  "5.0.1  3.11 numpy==1.26.4 4.11.0.86"
  "5.1.2  3.13 numpy==2.2.6  4.12.0.88"
  "5.2.3  3.13 numpy==2.2.6  4.12.0.88"
  "5.3.0  3.13 numpy==2.2.6  4.12.0.88"
)
PYTEST="pytest==9.2.0"
VENVS="${LAPIG_VENVS:-.venvs}"
SETUP_ONLY=0
FULL=0
WANTED=()
for arg in "$@"; do
  case "$arg" in
    --setup-only) SETUP_ONLY=1 ;;
    --full) FULL=1 ;;
    --newest) WANTED+=("$(echo "${MATRIX[-1]}" | cut -d' ' -f1)") ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) WANTED+=("$arg") ;;
  esac
done

find_python() {  # find_python 3.11|3.13 -> path of an interpreter of that version
  local want="$1" candidate
  local var="PYTHON${want/./}"
  for candidate in "${!var:-}" "python$want" \
      "$(pyenv prefix "$want" 2>/dev/null | head -1)/bin/python$want" \
      "$(pyenv prefix "$want.0" 2>/dev/null | head -1)/bin/python$want" \
      "${PYENV_ROOT:-$HOME/.pyenv}"/versions/"$want".*/bin/python"$want"; do
    [ -n "$candidate" ] || continue
    if command -v "$candidate" >/dev/null 2>&1 && "$candidate" -c \
        "import sys; sys.exit(0 if '%d.%d' % sys.version_info[:2] == '$want' else 1)" 2>/dev/null; then
      command -v "$candidate"; return 0
    fi
  done
  return 1
}

quiet_pip() {  # quiet_pip PYTHON ARGS...: pip install, without this machine's "Location ... is ignored" warnings
  local python="$1"; shift
  "$python" -m pip install --quiet --disable-pip-version-check --no-cache-dir "$@" \
      2> >(grep -v "^WARNING: Location '.*' is ignored" >&2)
}

make_venv() {  # make_venv RELEASE PY NUMPY OPENCV -> creates $VENVS/bpy-RELEASE (idempotent)
  local release="$1" py="$2" numpy="$3" opencv="$4"
  local venv="$VENVS/bpy-$release"
  local wants="bpy==$release $numpy opencv-contrib-python-headless==$opencv $PYTEST"
  if [ -f "$venv/.lapig-requirements" ] && [ "$(cat "$venv/.lapig-requirements")" = "$wants" ]; then
    return 0
  fi
  local interpreter
  if ! interpreter="$(find_python "$py")"; then
    echo "error: bpy $release needs Python $py (set PYTHON${py/./} or install it with pyenv)" >&2
    return 1
  fi
  local start=$SECONDS
  echo "creating $venv with $("$interpreter" --version) and $wants"
  rm -rf "$venv"
  "$interpreter" -m venv "$venv" || return 1
  quiet_pip "$venv/bin/python" $wants || return 1
  "$venv/bin/python" -c "import bpy, numpy, cv2; print('bpy', bpy.app.version_string, 'numpy', numpy.__version__, 'cv2', cv2.__version__)" || return 1
  echo "$wants" > "$venv/.lapig-requirements"
  echo "$venv: $((SECONDS - start)) s, $(du -sm "$venv" | cut -f1) MB"
}

full_deps() {  # the rest of requirements.txt (torch, the style and text models, InstructPix2Pix's libraries)
  grep -vE '^(#|bpy|numpy|opencv|scipy|$)' requirements.txt | tr '\n' ' '
}

make_full_venv() {  # make_full_venv RELEASE PY NUMPY OPENCV -> $VENVS/bpy-RELEASE-full, with torch
  local release="$1" py="$2" numpy="$3" opencv="$4"
  local venv="$VENVS/bpy-$release-full"
  local wants="bpy==$release $numpy opencv-contrib-python-headless==$opencv $(full_deps)"
  if [ -f "$venv/.lapig-requirements" ] && [ "$(cat "$venv/.lapig-requirements")" = "$wants" ]; then
    return 0
  fi
  local interpreter start=$SECONDS
  interpreter="$(find_python "$py")" || { echo "error: bpy $release needs Python $py" >&2; return 1; }
  echo "creating $venv with $("$interpreter" --version) and $wants"
  rm -rf "$venv"
  "$interpreter" -m venv "$venv" || return 1
  # torch first and alone, as scripts/setup_env.sh does: nothing after it may pull another torch.
  # On Python 3.11 pip takes the CPU build that lies on this machine's disk; on Python 3.13 the package
  # index only has Linux CUDA builds (torch plus its nvidia-* wheels, several GB).
  local torch_pin
  torch_pin="$(full_deps | tr ' ' '\n' | grep '^torch==')"
  quiet_pip "$venv/bin/python" \
      ${LAPIG_WHEELS:+--no-index --find-links "$LAPIG_WHEELS"} "$torch_pin" || return 1
  quiet_pip "$venv/bin/python" \
      ${LAPIG_WHEELS:+--no-index --find-links "$LAPIG_WHEELS"} $wants || return 1
  "$venv/bin/python" -c "import bpy, numpy, cv2, torch; print('bpy', bpy.app.version_string, 'numpy', numpy.__version__, 'cv2', cv2.__version__, 'torch', torch.__version__)" || return 1
  echo "$wants" > "$venv/.lapig-requirements"
  echo "$venv: $((SECONDS - start)) s, $(du -sm "$venv" | cut -f1) MB"
}

versions_of() {  # versions_of VENV -> "python numpy opencv torch"
  "$1/bin/python" - <<'PY' 2>/dev/null
import importlib.metadata as md, sys
def v(name):
    try:
        return md.version(name)
    except md.PackageNotFoundError:
        return "-"
print("%d.%d" % sys.version_info[:2], v("numpy"), v("opencv-contrib-python-headless"), v("torch"))
PY
}

run_tier() {  # run_tier RELEASE VENV MODE -> pytest into $VENVS/results/bpy-RELEASE[-full].txt
  local release="$1" venv="$2" mode="$3"
  local name="bpy-$release"; [ "$mode" = full ] && name="$name-full"
  local log="$VENVS/results/$name.txt" selection=(-m "not torch")
  [ "$mode" = full ] && selection=()
  mkdir -p "$VENVS/results"
  echo "== $name: pytest ${selection[*]} (log: $log)"
  local start=$SECONDS
  "$venv/bin/python" -m pytest -q -p no:cacheprovider -rfE "${selection[@]}" tests > "$log" 2>&1
  local status=$?
  local summary
  summary="$(grep -E '^(=+ )?[0-9]+ (passed|failed|error)' "$log" | tail -1 | sed 's/=//g; s/ in [0-9.]*s.*//; s/^ *//; s/ *$//')"
  echo "$release|$mode|$(versions_of "$venv")|${summary:-no summary, status $status}|$((SECONDS - start)) s" \
    > "$VENVS/results/$name.row"
  ROWS+=("$VENVS/results/$name.row")
  echo "   $summary ($((SECONDS - start)) s)"
  grep -E '^(FAILED|ERROR) ' "$log" | head -20
  if [ -z "$summary" ]; then  # pytest ended without its summary (a crash, or a hung test's stacks): its last lines
    tail -n 60 "$log"
  fi
  return $status
}

overall=0
ROWS=()
for row in "${MATRIX[@]}"; do
  read -r release py numpy opencv <<< "$row"
  if [ ${#WANTED[@]} -gt 0 ] && [[ ! " ${WANTED[*]} " =~ " $release " ]]; then
    continue
  fi
  if [ "$FULL" = 1 ]; then
    make_full_venv "$release" "$py" "$numpy" "$opencv" || { overall=1; continue; }
    [ "$SETUP_ONLY" = 1 ] || run_tier "$release" "$VENVS/bpy-$release-full" full || overall=1
  else
    make_venv "$release" "$py" "$numpy" "$opencv" || { overall=1; continue; }
    [ "$SETUP_ONLY" = 1 ] || run_tier "$release" "$VENVS/bpy-$release" torch-free || overall=1
  fi
done

if [ ${#ROWS[@]} -gt 0 ]; then
  echo
  echo "| release | tier | Python | numpy | OpenCV | torch | tests | time |"
  echo "|---|---|---|---|---|---|---|---|"
  while IFS='|' read -r release mode versions summary took; do
    read -r python numpy opencv torch <<< "$versions"
    echo "| $release | $mode | $python | $numpy | $opencv | $torch | $summary | $took |"
  done < <(cat "${ROWS[@]}")
fi
exit $overall
