#!/usr/bin/env bash
# Issue 12's GPU figures in one device call. The machine set-up (Vulkan loader, binaries in
# .gpu/bin, `carry: [".gl", ".gpu"]`) is ../shared/DEVICE.md's recipe; copy this script into
# .gpu/ with the binaries and call `bash .gpu/measure.sh` after its first lines. Everything goes
# to $OUT (at most 8 files come back): one log per step, then summary.md (8 files).
#   bash measure.sh [BIN_DIR] [quick]      (quick: the S scene only, to try the script anywhere)
set -u
BIN=${1:-.gpu/bin}
QUICK=${2:-}
OUT=${OUT:-/tmp/gpu-measure}
mkdir -p "$OUT"
SIZES=S,M,P,L
DESIGN="--scratches 40000 --res 512 --iters 100"
if [ "$QUICK" = quick ]; then SIZES=S; DESIGN="--scratches 2000 --res 64 --iters 5"; fi

# 1. Binning, forward and backward per view, with the backward/forward ratios (default bands).
"$BIN/scratchart" bench --sizes "$SIZES" --iters 10 --compare-backward > "$OUT/bench.md" 2>&1
# 2. The same pair search without bands (one thread per 64-scratch group), for the comparison.
"$BIN/scratchart" bench --sizes "$SIZES" --iters 0 --binning-bands 0 > "$OUT/bench_nobands.md" 2>&1
# 3. The paper's scale end to end: wall time split into start-up, iterations, pruning, reports
#    (summary.json's wall_s), twice: the second run finds the pipeline cache warm.
for run in 1 2; do
  rm -rf "/tmp/design$run"
  TIMEFORMAT="wall %R s"
  { time "$BIN/scratchart" design $DESIGN --quiet --out "/tmp/design$run"; } > "$OUT/design$run.log" 2>&1
  grep -o '"wall_s":{[^}]*}' "/tmp/design$run/summary.json" >> "$OUT/design$run.log" 2>/dev/null
done
# 4. The viewer, headless (no display there).
"$BIN/scratchart-view" --benchmark --size 1920x1080 > "$OUT/viewer.md" 2>&1
# 5. Issue 11 on the GPU: the study (its verdict) and what `adaptive` gains over the closed form
#    on whole scenes (target/release/examples/adaptive_gain, copied into BIN with the others).
"$BIN/scratchart" study --out /tmp/study > /dev/null 2>&1 && cp /tmp/study/verdict.txt "$OUT/study_verdict.txt"
AGB="$BIN/adaptive_gain"; [ -x "$AGB" ] || AGB="$BIN/examples/adaptive_gain"
if [ "$QUICK" = quick ]; then AG="S"; else AG="S M P"; fi
if [ -x "$AGB" ]; then
  "$AGB" $AG --repeats 7 > "$OUT/adaptive.md" 2>&1
fi
# 6. What the backward's replay of the forward's pair queues gains over searching the pairs again
#    (target/release/examples/replay_gain; its table goes into adaptive.md: 8 files at most).
RGB="$BIN/replay_gain"; [ -x "$RGB" ] || RGB="$BIN/examples/replay_gain"
if [ -x "$RGB" ]; then
  { echo; echo "### replay against search"; "$RGB" $AG --repeats 7; } >> "$OUT/adaptive.md" 2>&1
fi

{
  echo "# GPU measurements ($(date -u +%F))"
  echo; echo "## bench (default bands)"; grep -E '^\||^device' "$OUT/bench.md"
  echo; echo "## bench, pair search without bands"; grep -E '^\| [A-Z]' "$OUT/bench_nobands.md" | head -8
  echo; echo "## design $DESIGN"; cat "$OUT/design1.log" "$OUT/design2.log" | grep -E 'wall'
  echo; echo "## viewer 1920x1080"; tail -n 12 "$OUT/viewer.md"
  echo; echo "## adaptive against the closed form; the backward's replay against search"; cat "$OUT/adaptive.md" 2>/dev/null
  echo; echo "## study verdict"; tail -n 4 "$OUT/study_verdict.txt" 2>/dev/null
} > "$OUT/summary.md"
cat "$OUT/summary.md"
