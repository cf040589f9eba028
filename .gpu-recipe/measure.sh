#!/usr/bin/env bash
# Every GPU figure of engine/BENCHMARKS.md's H100 section in one device call. prepare.sh (beside
# this file) copies it into .gpu/ with the binaries; run.sh sets up the machine and calls it.
# Everything goes to $OUT (at most 8 files come back): one log per step, then summary.md
# (7 files; run.sh adds validation.log).
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
#    The backward with each round's lists built by thread 0 alone (the CPU drivers' build, the
#    GPUs' before 2026-11-29), for the comparison with the default's lists by every thread.
echo "### backward with --links one" >> "$OUT/bench.md"
"$BIN/scratchart" bench --sizes "$SIZES" --iters 0 --compare-backward --links one >> "$OUT/bench.md" 2>&1
#    and with --links every (the masks walked by one thread per scratch: the CPU build's sums;
#    the GPUs' default since 2026-11-30 is --links split, two threads per scratch).
echo "### backward with --links every" >> "$OUT/bench.md"
"$BIN/scratchart" bench --sizes "$SIZES" --iters 0 --compare-backward --links every >> "$OUT/bench.md" 2>&1
#    and four times L's scratches (640,000 on 3 x 1024^2, 290 M pairs), the largest figure kept.
if [ "$QUICK" != quick ]; then
  "$BIN/scratchart" bench --sizes 640000x3x1024 --iters 3 --repeats 3 --warmup 1 >> "$OUT/bench.md" 2>&1
#    and issue 51's bigger plate: a million scratches on 3 x 2048^2 (its device memory, stated
#    before it starts and held after, is the table's last column).
  "$BIN/scratchart" bench --sizes 1000000x3x2048 --iters 3 --repeats 3 --warmup 1 >> "$OUT/bench.md" 2>&1
fi
# 2. The pair search in the groups mode (a thread per 64-scratch group and band: the GPUs'
#    default before the pairs mode), then without bands, for the comparison.
"$BIN/scratchart" bench --sizes "$SIZES" --iters 0 --binning groups > "$OUT/bench_nobands.md" 2>&1
"$BIN/scratchart" bench --sizes "$SIZES" --iters 0 --binning groups --binning-bands 0 >> "$OUT/bench_nobands.md" 2>&1
# 3. The paper's scale end to end: wall time split into start-up, iterations, pruning, reports
#    (summary.json's wall_s), twice: the second run finds the pipeline cache warm.
for run in 1 2; do
  rm -rf "/tmp/design$run"
  TIMEFORMAT="wall %R s"
  echo "run $run:" >> "$OUT/design.log"
  { time "$BIN/scratchart" design $DESIGN --quiet --out "/tmp/design$run"; } >> "$OUT/design.log" 2>&1
  # (summary.json is pretty-printed: one line first)
  tr -d '\n ' < "/tmp/design$run/summary.json" | grep -o '"wall_s":{[^}]*}\|"device_memory_bytes":[0-9]*' >> "$OUT/design.log" 2>/dev/null
done
# 3b. Issue 50's GPU preset on the default pictures: wall time, and each view's correlation
#     against its cap (the bar: every view within 0.015 of it).
if [ "$QUICK" != quick ]; then
  rm -rf /tmp/paper
  { echo "preset paper:"; time "$BIN/scratchart" design --preset paper --quiet --out /tmp/paper; } >> "$OUT/design.log" 2>&1
  grep -o '"corr_final": [0-9.]*\|"corr_perfect": [0-9.]*' /tmp/paper/summary.json >> "$OUT/design.log" 2>/dev/null
fi
# 4. The viewer, headless (no display there): the demo plate (8,171 scratches) at 1920x1080, then
#    issue 32's cases, 100,000 scratches at 1920x1080 and 400,000 at 3840x2160 (unoptimized,
#    unpruned designs of random scratches).
{ echo "### 1920x1080, the demo plate"; "$BIN/scratchart-view" --benchmark --size 1920x1080; } > "$OUT/viewer.md" 2>&1
if [ "$QUICK" = quick ]; then CASES="5000:64:320x180 20000:64:640x360"; else CASES="100000:256:1920x1080 400000:256:3840x2160"; fi
for c in $CASES; do
  IFS=: read -r N R SIZE <<< "$c"
  rm -rf /tmp/big && "$BIN/scratchart" design --scratches "$N" --res "$R" --iters 0 --prune-tol 0 --quiet --out /tmp/big > /dev/null 2>&1
  { echo; echo "### $SIZE, $N scratches"; "$BIN/scratchart-view" /tmp/big/design.json --benchmark --size "$SIZE"; } >> "$OUT/viewer.md" 2>&1
  { echo; echo "### $SIZE, $N scratches, --binning groups"; "$BIN/scratchart-view" /tmp/big/design.json --benchmark --size "$SIZE" --binning groups --bench-frames 10; } >> "$OUT/viewer.md" 2>&1
done
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
# 7. Issue 47's fit time: the README's calibration walk-through (the card, `simulate`'s defaults,
#    `fit --kind v-bit`), into design.log (8 files at most come back).
CAL="$BIN/scratchart-cal"
if [ -x "$CAL" ] && [ "$QUICK" != quick ]; then
  rm -rf /tmp/cal && mkdir -p /tmp/cal
  echo '{"kind":"v-bit","angle_deg":75,"tip_flat_mm":0.015,"z_offset_mm":0.007}' > /tmp/cal/truth.json
  "$CAL" card --out /tmp/cal/card > /dev/null 2>&1
  "$CAL" simulate --card /tmp/cal/card/card.json --tool /tmp/cal/truth.json --out /tmp/cal/photos > /dev/null 2>&1
  { echo "calibration fit:"; time "$CAL" fit --quiet --card /tmp/cal/card/card.json /tmp/cal/photos/cam_south.png \
      /tmp/cal/photos/cam_west.png --kind v-bit --out /tmp/cal/fit/tool.json; } >> "$OUT/design.log" 2>&1
fi

{
  echo "# GPU measurements ($(date -u +%F))"
  echo; echo "## bench (default bands)"; grep -E '^\||^device|^###' "$OUT/bench.md"
  echo; echo "## bench, pair search in the groups mode (with the GPU's bands, then none)"; grep -E '^\| [A-Z]' "$OUT/bench_nobands.md" | head -10
  echo; echo "## design $DESIGN, then --preset paper; the calibration fit"; grep -E 'wall|preset|corr_|device_memory|calibration|fitted' "$OUT/design.log"
  echo; echo "## viewer"; grep -E '^###|^mode|^headless|^device|^  [0-9]' "$OUT/viewer.md"
  echo; echo "## adaptive against the closed form; the backward's replay against search"; cat "$OUT/adaptive.md" 2>/dev/null
  echo; echo "## study verdict"; tail -n 4 "$OUT/study_verdict.txt" 2>/dev/null
} > "$OUT/summary.md"
cat "$OUT/summary.md"
