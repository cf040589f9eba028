#!/usr/bin/env bash
# Where the time goes on a GPU (issue 51 and issue 47's fit time), in one short device call after
# prepare.sh: `bash .gpu/probe.sh [backward] [design] [fit]` (carry [".gl", ".gpu"]; all three,
# the default, take about 70 s of command time on an H200).
#   1. the backward's parts: `bench --compare-backward` with the timing builds of
#      SCRATCHART_GRAD_DIAG (engine/render/src/kernels.rs: lists not walked, neither built nor
#      walked, 256 queue entries per round);
#   2. the paper-scale design's wall split, the set-up sheet's searches and their renders;
#   3. the calibration fit of calibration/README.md, with its seconds in the engine's calls.
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
export XDG_RUNTIME_DIR=/tmp
for z in .gpu/bin/*.gz; do [ -e "$z" ] && gunzip -f "$z"; done; chmod +x .gpu/bin/*
OUT=${OUT:-/tmp/gpu-out}; mkdir -p "$OUT"
B=.gpu/bin
SIZES=${PROBE_SIZES:-S,M,P,L}  # S first: it brings the clocks up
PARTS="${*:-backward design fit}"
touch "$OUT/backward_parts.md" "$OUT/probe.log"
if [[ " $PARTS " == *" backward "* ]]; then
for d in "" "links=one" "links=every" no-accum; do
  echo "### SCRATCHART_GRAD_DIAG=$d"
  case $d in
    links=*) $B/scratchart bench --sizes "$SIZES" --iters 0 --repeats 7 --warmup 2 --compare-backward --links "${d#links=}" ;;
    *) SCRATCHART_GRAD_DIAG=$d $B/scratchart bench --sizes "$SIZES" --iters 0 --repeats 7 --warmup 2 --compare-backward ;;
  esac 2>&1 | grep -E '^\| [A-Z]'
done > "$OUT/backward_parts.md" 2>&1
fi
if [[ " $PARTS " == *" design "* ]]; then
for run in 1 2; do
  rm -rf /tmp/design
  { echo "run $run:"; $B/scratchart design --scratches 40000 --res 512 --iters 100 --quiet --out /tmp/design 2>&1 | grep 'wall time'
    tr -d '\n ' < /tmp/design/summary.json | grep -o '"wall_s":{[^}]*}'; echo; } >> "$OUT/probe.log"
done
fi
if [[ " $PARTS " == *" fit "* ]]; then
rm -rf /tmp/cal && mkdir -p /tmp/cal
echo '{"kind":"v-bit","angle_deg":75,"tip_flat_mm":0.015,"z_offset_mm":0.007}' > /tmp/cal/truth.json
$B/scratchart-cal card --out /tmp/cal/card > /dev/null 2>&1
$B/scratchart-cal simulate --card /tmp/cal/card/card.json --tool /tmp/cal/truth.json --out /tmp/cal/photos > /dev/null 2>&1
for run in 1 2; do
  { echo "calibration fit, run $run:"; $B/scratchart-cal fit --quiet --card /tmp/cal/card/card.json /tmp/cal/photos/cam_south.png \
      /tmp/cal/photos/cam_west.png --kind v-bit --out /tmp/cal/fit$run/tool.json 2>&1 | grep fitted; } >> "$OUT/probe.log"
done
fi
cat "$OUT/backward_parts.md" "$OUT/probe.log"
