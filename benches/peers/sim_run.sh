#!/usr/bin/env bash
# Simulation throughput of lifted-sim against scipy.signal.dlsim,
# python-control forced_response, SLICOT TF01MD (slycot) and a numpy loop on
# the closed loop of crates/sim/benches/sim.rs; see benches/results/peers-simulated.md
# ("Simulation throughput vs peers"). Not part of the test suite.
# Usage (from anywhere):
#   benches/peers/sim_run.sh [N ...] [--reps K] [--budget S] [--json FILE]
#   (default N: 1e4 1e5 1e6)
# Environment: VENV (default benches/peers/.venv, shared with run.sh).
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=${VENV:-benches/peers/.venv}
if [ ! -x "$VENV/bin/python" ]; then
  python3 -m venv "$VENV"
fi
if ! "$VENV/bin/python" -c "import numpy, scipy, control" 2>/dev/null; then
  "$VENV/bin/pip" install -q numpy scipy control
fi
if ! "$VENV/bin/python" -c "import slycot" 2>/dev/null; then
  "$VENV/bin/pip" install -q slycot || echo "slycot: no wheel for this platform (SLICOT peer left out)"
fi
cargo build --release -p lifted-benches --example peer_sim
echo "uptime before: $(uptime)"
OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 OMP_NUM_THREADS=1 \
  "$VENV/bin/python" benches/peers/sim_peers.py --lifted target/release/examples/peer_sim "$@"
echo "uptime after: $(uptime)"
