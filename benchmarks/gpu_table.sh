#!/usr/bin/env bash
# The GPU table of docs/performance_gpu.md: the CPU benchmarks' own commands at GPU
# sizes, run in one go on a machine with one GPU and JAX for it already installed.
#
#   bash benchmarks/gpu_table.sh [COPY_TO]        # results: benchmarks/results/gpu_*.json
#   QUICK=1 bash benchmarks/gpu_table.sh           # small sizes, gpu_quick_*: checks it
#
# Each benchmark has its own time limit, so that one that hangs or fails leaves the
# others' results (a benchmark stopped at its limit writes no JSON, only its log
# lines); the script exits 1 if any of them failed. The log goes to benchmarks/results/gpu_table.log; COPY_TO, if given,
# receives the log and the JSON files (a lent machine returns one folder). jax-md is
# not needed: the scenes timed here use jaxdpd's own cell list.
set -u
copy_to=${1:+$(realpath -m "$1")}
cd "$(dirname "$0")"
export PYTHONUNBUFFERED=1 PYTHONPATH="$(realpath ..)${PYTHONPATH:+:$PYTHONPATH}"
# dpd_throughput.py measures each size in a child process: the parent must not hold
# three quarters of the GPU's memory while a child runs.
export XLA_PYTHON_CLIENT_PREALLOCATE=false
if [ "${QUICK:-0}" = 1 ]; then
  dpd="3000 6000" lb="16" mpcd="20000" bd="1000" steps=20 name=gpu_quick
else
  dpd="100000 1000000 10000000" lb="64 128 256" mpcd="1000000 10000000" bd="100000 1000000"
  steps=50 name=gpu
fi
log=results/${name}_table.log

failed=0
run() {  # run SECONDS SCRIPT ARGS...: one benchmark, its output appended to the log
  local limit=$1 status
  shift
  echo "== $(date -u +%H:%M:%S) python $*" | tee -a "$log"
  timeout "$limit" python "$@" 2>&1 | tee -a "$log"
  status=${PIPESTATUS[0]}
  echo "== exit $status" | tee -a "$log"
  [ "$status" = 0 ] || failed=$((failed + 1))
}

{ nvidia-smi --query-gpu=name,memory.total,driver_version,clocks.max.sm --format=csv || true
  python -c "import jax; print('jax', jax.__version__, jax.devices())"; } 2>&1 | tee "$log"
# shellcheck disable=SC2086  # the size lists are word-split on purpose
{
  run 240 dpd_throughput.py --sizes $dpd --precisions float32 --steps $steps \
    --equilibration $((2 * steps)) --chunks 2 --output ${name}_dpd_throughput
  run 90 lattice_boltzmann_throughput.py --sizes $lb --precisions float32 --steps 50 \
    --chain-steps 500 --output ${name}_lattice_boltzmann_throughput
  run 90 solvent_bounds.py --mpcd-sizes $mpcd --bd-sizes $bd --output ${name}_solvent_bounds
}
if [ -n "$copy_to" ]; then
  mkdir -p "$copy_to"
  for part in dpd_throughput lattice_boltzmann_throughput solvent_bounds; do
    cp "results/${name}_$part.json" "$copy_to" || echo "no results/${name}_$part.json"
  done
  cp "$log" "$copy_to"
fi
[ "$failed" = 0 ] || { echo "$failed benchmark(s) failed; see $log"; exit 1; }
