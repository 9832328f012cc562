#!/usr/bin/env bash
# Peer comparison of lifted against SIPPY (sippy-unipi) and nfoursid; see
# benches/README.md. Not part of the test suite. Usage (from the repository root):
#   benches/peers/run.sh [N ...]        # default 10000 100000 1000000
# Environment: VENV (default benches/peers/.venv), LIFTED_CLI (a lifted binary to
# include, optional).
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=${VENV:-benches/peers/.venv}
if [ ! -x "$VENV/bin/python" ]; then
  python3 -m venv "$VENV"
  "$VENV/bin/pip" install -q numpy scipy pandas sippy-unipi nfoursid
  # python-control / slycot: slycot 0.7 has wheels but wraps no IB01AD/IB01BD
  # (SLICOT's subspace routines), so it cannot identify; installed for reference.
  "$VENV/bin/pip" install -q control slycot || echo "slycot: no wheel for this platform"
fi
# a venv created by sim_run.sh (scipy/control/slycot only) lacks the identification peers
"$VENV/bin/python" -c "import sippy_unipi, nfoursid, pandas" 2>/dev/null \
  || "$VENV/bin/pip" install -q numpy scipy pandas sippy-unipi nfoursid
"$VENV/bin/python" -c "import slycot; print('slycot', slycot.__version__, 'has ib01ad:', hasattr(slycot, 'ib01ad'))" || true
cargo build --release -p lifted-benches --example peer_lifted
echo "date: $(date -u +%FT%TZ)  nproc: $(nproc)  uptime: $(uptime)"
CLI_ARGS=()
if [ -n "${LIFTED_CLI:-}" ]; then CLI_ARGS=(--cli "$LIFTED_CLI"); fi
OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 OMP_NUM_THREADS=1 \
  exec "$VENV/bin/python" benches/peers/peers.py --lifted target/release/examples/peer_lifted \
  "${CLI_ARGS[@]}" "$@"
