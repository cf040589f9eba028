#!/usr/bin/env bash
# Run on the device machine (prepare.sh put it in .gpu/): the loader, a validation-layer check,
# then measure.sh. About 35 s of command time on an H100; 8 files come back from $OUT.
#   bash .gpu/run.sh [quick]
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
mkdir -p /tmp/vl && dpkg -x .gpu/vl/*.deb /tmp/vl
export XDG_RUNTIME_DIR=/tmp
# prepare.sh gzips the binaries to stay under the 64 MiB a call carries.
for z in .gpu/bin/*.gz; do [ -e "$z" ] && gunzip -f "$z"; done; chmod +x .gpu/bin/*
OUT=${OUT:-/tmp/gpu-out}; mkdir -p "$OUT"
B=.gpu/bin
nvidia-smi --query-gpu=name,driver_version,clocks.max.sm --format=csv > "$OUT/validation.log" 2>&1
( export VK_LAYER_PATH=/tmp/vl/usr/share/vulkan/explicit_layer.d LD_LIBRARY_PATH=/tmp/vl/usr/lib/x86_64-linux-gnu SCRATCHART_VALIDATION=1
  $B/scratchart design --scratches 4000 --res 128 --iters 20 --quiet --out /tmp/vd; a=$?
  $B/scratchart bench --sizes S --iters 3 --validation; b=$?
  $B/scratchart-view --benchmark --size 640x360 --bench-frames 5; c=$?
  echo "EXITS design $a bench $b view $c" ) > /tmp/val.txt 2>&1
{ grep EXITS /tmp/val.txt
  echo "validation messages: $(grep -ciE 'VUID|validation' /tmp/val.txt) (a missing layer says 'validation requested but ... not installed')"
  grep -iE 'VUID|validation|error' /tmp/val.txt | head -40; } >> "$OUT/validation.log"
bash .gpu/measure.sh "$B" "${1:-}"
