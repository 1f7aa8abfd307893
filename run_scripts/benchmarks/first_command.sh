#!/bin/bash
# Benchmark: the README's first command as a new user meets it, each part timed.
#
#     bash run_scripts/benchmarks/first_command.sh [REV] [PIP_OPTIONS]
#
# Clones this repository at REV (default HEAD) into a temporary folder, creates the venv, runs
# `pip install PIP_OPTIONS -e .` (pip's own cache as it is), the 2-rank quick run with an empty
# numba cache (NUMBA_CACHE_DIR in the temporary folder) and `pardem plot`, and prints the
# seconds of each part. Alternate REVs or options in one invocation to compare them.
set -euo pipefail
rev=${1:-HEAD}
pip_options=${2:-}
repo=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
git clone -q "$repo" "$tmp/clone" && cd "$tmp/clone" && git checkout -q "$rev"
export NUMBA_CACHE_DIR="$tmp/numba"
t0=$(date +%s.%N)
python3 -m venv .venv && . .venv/bin/activate
pip install -q $pip_options -e . > "$tmp/pip.log" 2>&1 || { cat "$tmp/pip.log"; exit 1; }
t1=$(date +%s.%N)
scene=run_scripts/scenes/couette_quick.toml  # run_scripts/ before its folders: REV older
[ -f "$scene" ] || scene=run_scripts/couette_quick.toml
mpiexec -n 2 pardem run "$scene" --out runs/quick --overwrite 2> "$tmp/run.err"
t2=$(date +%s.%N)
ready=$(grep -o "ready in [0-9.]* s" "$tmp/run.err" || echo "ready: ?")
pardem plot runs/quick > /dev/null
t3=$(date +%s.%N)
python3 -c "print(f'$rev [${pip_options:-no options}]: install {$t1 - $t0:.1f} s, run {$t2 - $t1:.1f} s \
($ready), plot {$t3 - $t2:.1f} s, total {$t3 - $t0:.1f} s')"
