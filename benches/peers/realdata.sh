#!/usr/bin/env bash
# Real-data benchmark (issue 26): lifted beside SIPPY (and Octave's control package
# when installed) on DaISy records; see benches/results/real-records.md, "Real records beside SIPPY".
# Not part of the test suite. Usage (from the repository root):
#   LIFTED_CLI=/path/to/lifted benches/peers/realdata.sh [--json out.json] [--md out.md] [...]
# Environment: LIFTED_CLI (default: $CARGO_TARGET_DIR/release/lifted, built here if
# absent), REALDATA_DIR (the .dat files, default /work/realdata), VENV (default
# benches/peers/.venv-real). Octave is used when `octave-cli` with the control package
# is on PATH (e.g. apt-get install octave octave-control); --no-octave skips it.
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=${VENV:-benches/peers/.venv-real}
if [ ! -x "$VENV/bin/python" ]; then
  python3 -m venv "$VENV"
fi
"$VENV/bin/python" -c "import numpy, scipy, sippy_unipi, control" 2>/dev/null \
  || "$VENV/bin/pip" install -q numpy scipy sippy-unipi control
if [ -z "${LIFTED_CLI:-}" ]; then
  LIFTED_CLI=${CARGO_TARGET_DIR:-target}/release/lifted
  [ -x "$LIFTED_CLI" ] || cargo build --release -p lifted-cli
fi
export LIFTED_CLI
echo "date: $(date -u +%FT%TZ)  nproc: $(nproc)  lifted: $LIFTED_CLI ($(git rev-parse --short HEAD 2>/dev/null || echo '?'))" >&2
OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 OMP_NUM_THREADS=1 RAYON_NUM_THREADS=1 \
  exec "$VENV/bin/python" benches/peers/realdata.py --lifted-cli "$LIFTED_CLI" "$@"
