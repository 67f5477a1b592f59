#!/bin/bash
# The GPU figures in docs/measurements.md#measured-on-a-gpu-nvidia-h200, as one prepared run on a GPU machine that has
# an NVIDIA driver but no Vulkan loader and no Rust toolchain. Here, first:
#   cargo build --release && mkdir -p .gpu && cp target/release/globe scripts/gpu_figures.sh .gpu/
#   and the loader packages into .gl/ (docs/measurements.md#on-a-gpu-machine).
# There, from the copy's root: OUT=results LIMIT=500 bash .gpu/gpu_figures.sh
# Each step has a time limit so that the whole run ends within LIMIT seconds; results (one JSON
# line per bench run, the report's files, a log) go under $OUT.
set -u
mkdir -p "$OUT"
for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig
export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
G=.gpu/globe; chmod +x $G
LIMIT=${LIMIT:-500}
log() { echo "[$SECONDS s] $*" | tee -a $OUT/log.txt; }
nvidia-smi -L | tee -a $OUT/log.txt; nproc | tee -a $OUT/log.txt
step() { # step NAME TIMEOUT args...
  local name=$1 t=$2; shift 2
  local left=$((LIMIT - SECONDS)); [ $left -lt 20 ] && { log "skip $name (time)"; return; }
  [ $t -gt $left ] && t=$left
  log "start $name: $*"
  timeout $t $G "$@" >> $OUT/bench.jsonl 2>> $OUT/stderr.txt; log "end $name rc=$?"
}
W="--width 1920 --height 1080"
step probe 40 bench --scene space --width 320 --height 180 --frames 5 --json --no-error
grep -qi nvidia $OUT/bench.jsonl || { log "no NVIDIA adapter"; cat $OUT/stderr.txt; exit 1; }
ALL="space aircraft ground everest north-pole antimeridian"
# GPU times first (no error measurement: the reference ray caster is CPU work).
# --vertex-stage: the vertex pre-pass against the vertex stage placing, in the same run (on a GPU
# the pre-pass may cost more than it saves; render::placement).
for s in $ALL; do step "$s-on" 40 bench --scene $s $W --frames 100 --passthrough --plain-look --vertex-stage --json --no-error; done
step flight 60 bench --scene flight $W --frames 300 --passthrough --json --no-error
for s in space aircraft ground; do step "$s-off" 30 bench --scene $s $W --frames 100 --passthrough --json --detail off --no-error; done
for s in space aircraft ground; do step "$s-540" 30 bench --scene $s --width 960 --height 540 --frames 100 --passthrough --json --no-error; done
for s in $ALL; do step "$s-b4" 30 bench --scene $s $W --frames 100 --passthrough --json --no-error --error-budget 4; done
# ρ of the settled frame rendered on the GPU, every pixel (ground and north-pole take minutes
# with the detail on: their reference steps are short), then the knob sweep on a sample.
for s in space aircraft everest antimeridian; do step "$s-rho" 60 bench --scene $s $W --frames 5 --json; done
left=$((LIMIT - SECONDS - 10)); log "report with ${left}s"
[ $left -gt 60 ] && timeout $left $G report --out $OUT/report --scenes space,aircraft,ground,everest,north-pole,antimeridian $W --every 8 --frames 20 2>> $OUT/stderr.txt
log "report rc=$?"
