#!/usr/bin/env bash
# Run here, in the repository root, before a device call: fetches the Vulkan loader (and the
# validation layer) for the device machine, builds the release binaries and copies what the call
# needs into .gpu/ (ignored by git; binaries gzipped, about 30 MB, under the 64 MiB a call carries).
set -eu
cd "$(git rev-parse --show-toplevel)"
mkdir -p .git/info; touch .git/info/exclude
for p in /.gl/ /.gpu/; do grep -qxF "$p" .git/info/exclude || echo "$p" >> .git/info/exclude; done
mkdir -p .gl .gpu/vl .gpu/bin /tmp/amd64/partial
o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
if ! ls .gl/libglvnd0_*.deb > /dev/null 2>&1; then
  apt-get $o update > /dev/null
  # The NVIDIA ICD (libGLX_nvidia.so.0) needs glvnd's dispatch library beside the loader:
  # without libglvnd0 the loader finds the ICD but "Could not get 'vkCreateInstance'".
  (cd .gl && apt-get $o download libvulkan1 libglvnd0 libegl1 libgl1 libglx0 libopengl0 libgles2)
  (cd .gpu/vl && apt-get $o download vulkan-validationlayers)
fi
# (--examples alone builds no binary: name both)
cargo build --release --workspace --bins --examples
rm -rf .gpu/bin && mkdir -p .gpu/bin
for b in scratchart scratchart-view scratchart-cal examples/adaptive_gain examples/replay_gain; do
  cp target/release/$b .gpu/bin/
done
strip .gpu/bin/*
# The five binaries pass 60 MB stripped: they travel gzipped (run.sh unpacks them there).
gzip -9 .gpu/bin/*
cp .gpu-recipe/measure.sh .gpu-recipe/run.sh .gpu-recipe/probe.sh .gpu/
du -sh .gl .gpu
# A call carries at most 64 MiB: say so here rather than have the device call refuse it.
total=$(du -sbc .gl .gpu | tail -1 | cut -f1)
if [ "$total" -gt $((64 * 1024 * 1024)) ]; then
  echo "error: .gl and .gpu hold $total bytes, over the 64 MiB a device call carries: leave a binary out of prepare.sh" >&2
  exit 1
fi
echo 'now: device run, command "bash .gpu/run.sh", carry [".gl", ".gpu"], timeout_s 300'
