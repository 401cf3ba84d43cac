#!/usr/bin/env bash
# The GPU figures of docs/GPU.md in one go, on a machine with an NVIDIA GPU and the `gpu` extra
# importable (run from the repository's root):
#
#     bash bench/gpu_suite.sh OUTDIR [seconds]
#
# Runs bench/bench_gpu.py five times on one kernel cache: the compile from an empty cache, the
# 200-variation study of `tuned` on Warp and on the lanes of every core (end to end against the
# goal of 60 s, and the pass verdicts' agreement), 1 800 and 900 variations on Warp alone (the
# steps/s at 16 209 and 8 109 worlds) and a closed-loop study of `robust` against the lanes
# (about 5 minutes on an H200 with 16 cores, docs/GPU.md "Speed"). Each writes
# OUTDIR/<step>.json; all print into OUTDIR/log. A step is cut when it outlasts its limit or the
# time left of [seconds] (default 590), and the next one still gets its turn.
set -u
out=${1:?usage: bash bench/gpu_suite.sh OUTDIR [seconds]}
deadline=$((SECONDS + ${2:-590}))
cache=${WARP_CACHE_PATH:-/tmp/artro-warp-cache}
python=${PYTHON:-python3}
cores=$(nproc)
mkdir -p "$out"

step() {
    local name=$1 limit=$2
    shift 2
    local left=$((deadline - SECONDS - 5))
    ((left < limit)) && limit=$left
    if ((limit < 20)); then
        echo "== $name: skipped, ${left} s left" | tee -a "$out/log"
        return
    fi
    echo "== $name (at most ${limit} s): $*" | tee -a "$out/log"
    timeout "$limit" "$python" bench/bench_gpu.py --device cuda --cache "$cache" \
        --json "$out/$name.json" "$@" 2>&1 | tee -a "$out/log"
    echo "== $name: exit ${PIPESTATUS[0]} at ${SECONDS} s" | tee -a "$out/log"
}

{
    nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv
    echo "cores ${cores}; /dev/shm: $(df -h --output=size /dev/shm | tail -1)"
} 2>&1 | tee -a "$out/log"
step compile 200 --samples 1 --duration 0.5 --warmup 0.1 --skip-lanes
step study200 240 --samples 200 --duration 20 --warmup 5 --threads "$cores"
step study1800 150 --samples 1800 --duration 20 --warmup 5 --skip-lanes
step study900 100 --samples 900 --duration 20 --warmup 5 --skip-lanes
step closed_loop 100 --preset robust --samples 5 --duration 4 --warmup 1 --threads "$cores"
