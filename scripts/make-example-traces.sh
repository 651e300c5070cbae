#!/usr/bin/env bash
# Regenerates the traces shipped in src/stiction/sim/examples/ from the built-in
# synthetic strokes (drivers/fake), so they carry no third-party data.
# Run from the repository root with the project's venv: bash scripts/make-example-traces.sh
set -euo pipefail
cd "$(dirname "$0")/.."
STICTION=${STICTION:-.venv/bin/stiction}
for name in stroke circles demo; do
  "$STICTION" trace "synthetic:$name" --out "src/stiction/sim/examples/$name.csv" --force
done
