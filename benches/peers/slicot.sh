#!/usr/bin/env bash
# lifted vs SLICOT (IB01AD/IB01BD, built from source) vs SIPPY, interleaved runs;
# see benches/results/slicot.md ("SLICOT, SIPPY and lifted side by side"). Not part of
# the test suite. Usage (from anywhere):
#   benches/peers/slicot.sh [N ...] [--runs 5] [--sippy-max N] [--json FILE] ...
# (N defaults to 1e4 1e5 1e6; every option goes to benches/peers/compare.py,
# see its --help.)
# Environment:
#   SLICOT_SRC    SLICOT-Reference checkout (default ../SLICOT-Reference beside
#                 the repository); without it the SLICOT rows are skipped
#   SLICOT_BUILD  cache of libslicot.a and the driver (default
#                 benches/peers/.slicot-build, gitignored); rebuilt when missing
#                 or when SLICOT_SRC's commit or slicot_ib01.f90 changed
#   SLICOT_ALL=1  compile every src/*.f instead of IB01AD, IB01BD and the
#                 routines they call (found from the objects' undefined symbols)
#   FFLAGS        gfortran flags (default -O2)
#   LIFTED_PEER, LIFTED_CLI  prebuilt peer_lifted / lifted binaries (otherwise
#                 built with cargo build --release)
#   VENV          Python venv (default benches/peers/.venv; created if missing)
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$PWD
SLICOT_SRC=${SLICOT_SRC:-$ROOT/../SLICOT-Reference}
BUILD=${SLICOT_BUILD:-benches/peers/.slicot-build}
FFLAGS=${FFLAGS:--O2}
VENV=${VENV:-benches/peers/.venv}

# ---- system packages: gfortran and OpenBLAS (Debian names)
have_toolchain() {
  command -v gfortran >/dev/null 2>&1 &&
    { ldconfig -p 2>/dev/null | grep -q 'libopenblas\.so ' ||
      ls /usr/lib/*/libopenblas.so /usr/lib/libopenblas.so >/dev/null 2>&1; }
}
SLICOT_NOTE=""
if ! have_toolchain; then
  if [ "$(id -u)" = 0 ]; then SUDO=""; elif sudo -n true 2>/dev/null; then SUDO=sudo; else SUDO=none; fi
  if [ "$SUDO" != none ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing gfortran libopenblas-dev" >&2
    $SUDO apt-get update -q >&2
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q gfortran libopenblas-dev >&2
  else
    SLICOT_NOTE="skipped: gfortran/OpenBLAS missing (apt-get install gfortran libopenblas-dev as root)"
    echo "slicot.sh: gfortran or libopenblas missing and no root/sudo/apt-get:" \
      "run 'apt-get install gfortran libopenblas-dev' as root; SLICOT rows skipped" >&2
  fi
fi

# ---- SLICOT: libslicot.a (IB01AD, IB01BD and their callees) and the driver
slicot_file() { # routine name (upper case) -> its source file, if SLICOT has one
  local lower
  lower=$(echo "$1" | tr 'A-Z' 'a-z')
  for f in "$SLICOT_SRC/src/$1.f" "$SLICOT_SRC/src/lapack_aux/$lower.f"; do
    if [ -f "$f" ]; then echo "$f"; return; fi
  done
}

build_lib() {
  local obj=$BUILD/obj todo next done_ f s
  rm -rf "$obj" "$BUILD/libslicot.a"
  mkdir -p "$obj"
  if [ "${SLICOT_ALL:-0}" = 1 ]; then
    for f in "$SLICOT_SRC"/src/*.f "$SLICOT_SRC"/src/lapack_aux/*.f; do
      gfortran $FFLAGS -c "$f" -o "$obj/$(basename "${f%.f}").o"
    done
  else
    # transitive closure from IB01AD and IB01BD: compile, read the undefined
    # symbols (name_), keep those SLICOT has a source file for, repeat
    todo="IB01AD IB01BD"; done_=" "
    while [ -n "$todo" ]; do
      next=""
      for s in $todo; do
        gfortran $FFLAGS -c "$(slicot_file "$s")" -o "$obj/$s.o"
        done_="$done_$s "
      done
      for s in $(for r in $todo; do nm -u "$obj/$r.o"; done | awk '{print $2}' |
                 sed -n 's/_$//p' | tr 'a-z' 'A-Z' | sort -u); do
        case "$done_ $next " in *" $s "*) continue ;; esac
        [ -n "$(slicot_file "$s")" ] && next="$next $s"
      done
      todo=$next
    done
    echo "SLICOT routines compiled:$done_" >&2
  fi
  ar cr "$BUILD/libslicot.a" "$obj"/*.o
  ranlib "$BUILD/libslicot.a"
  rm -rf "$obj"
}

SLICOT_BIN=""
if [ -z "$SLICOT_NOTE" ]; then
  if [ ! -f "$SLICOT_SRC/src/IB01AD.f" ]; then
    SLICOT_NOTE="skipped: no SLICOT source at $SLICOT_SRC (git clone https://github.com/SLICOT/SLICOT-Reference ../SLICOT-Reference)"
    echo "slicot.sh: SLICOT source not found at $SLICOT_SRC; get it beside the repository with" >&2
    echo "  git clone https://github.com/SLICOT/SLICOT-Reference ../SLICOT-Reference" >&2
    echo "(or set SLICOT_SRC); the SLICOT rows are skipped." >&2
  else
    mkdir -p "$BUILD"
    COMMIT=$(git -C "$SLICOT_SRC" rev-parse HEAD 2>/dev/null || echo unknown)
    STAMP="$COMMIT $FFLAGS all=${SLICOT_ALL:-0}"
    if [ ! -f "$BUILD/libslicot.a" ] || [ "$(cat "$BUILD/stamp" 2>/dev/null)" != "$STAMP" ]; then
      echo "building $BUILD/libslicot.a from $SLICOT_SRC ($COMMIT), gfortran $FFLAGS, one job" >&2
      build_lib
      echo "$STAMP" >"$BUILD/stamp"
      rm -f "$BUILD/slicot_ib01"
    fi
    DRIVER=benches/peers/slicot_ib01.f90
    if [ ! -x "$BUILD/slicot_ib01" ] || [ "$DRIVER" -nt "$BUILD/slicot_ib01" ]; then
      # LAPACK comes from OpenBLAS on Debian; add the reference LAPACK if not
      gfortran $FFLAGS -J "$BUILD" -o "$BUILD/slicot_ib01" "$DRIVER" "$BUILD/libslicot.a" -lopenblas ||
        gfortran $FFLAGS -J "$BUILD" -o "$BUILD/slicot_ib01" "$DRIVER" "$BUILD/libslicot.a" \
          -llapack -lopenblas
    fi
    SLICOT_BIN=$BUILD/slicot_ib01
  fi
fi

# ---- lifted binaries
if [ -z "${LIFTED_PEER:-}" ]; then
  cargo build --release -p lifted-benches --example peer_lifted
  LIFTED_PEER=target/release/examples/peer_lifted
fi
if [ -z "${LIFTED_CLI:-}" ]; then
  cargo build --release -p lifted-cli
  LIFTED_CLI=target/release/lifted
fi

# run private copies, so that a rebuild of the workspace during the (minutes
# long) run cannot mix two versions of lifted in one table
SNAP=$BUILD/lifted-snapshot
mkdir -p "$SNAP"
for b in "$LIFTED_PEER" "$LIFTED_CLI"; do
  echo "lifted binary: $b ($(date -u -r "$b" +%FT%TZ), sha256 $(sha256sum "$b" | cut -c1-12)," \
    "HEAD of its repository now: $(git -C "$(dirname "$b")" rev-parse --short HEAD 2>/dev/null || echo '?'))"
done
cp "$LIFTED_PEER" "$SNAP/peer_lifted"
cp "$LIFTED_CLI" "$SNAP/lifted"
LIFTED_PEER=$SNAP/peer_lifted
LIFTED_CLI=$SNAP/lifted

# ---- Python: numpy, scipy, pandas, SIPPY
if [ ! -x "$VENV/bin/python" ]; then python3 -m venv "$VENV"; fi
"$VENV/bin/python" -c "import numpy, scipy, pandas, sippy_unipi" 2>/dev/null ||
  "$VENV/bin/pip" install -q numpy scipy pandas sippy-unipi

ARGS=(--lifted "$LIFTED_PEER" --cli "$LIFTED_CLI" --slicot-src "$SLICOT_SRC")
if [ -n "$SLICOT_BIN" ]; then ARGS+=(--slicot "$SLICOT_BIN"); else ARGS+=(--slicot-note "$SLICOT_NOTE"); fi
exec "$VENV/bin/python" benches/peers/compare.py "${ARGS[@]}" "$@"
