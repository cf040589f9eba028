//! The optimizer's state as a whole: written to and restored from a checkpoint, and carried
//! over to a new scene whose scratches were added or removed (a live design).
use std::path::Path;

use super::*;

impl Driver<'_> {
    /// Every buffer of the optimizer's state, named as in checkpoints: each block's parameters
    /// and moments, and the good copies of them.
    fn state_chunks(&self) -> Vec<(String, &Buffer)> {
        let mut out = Vec::new();
        for (b, s) in self.inner.params.blocks(&self.gs).into_iter().zip(&self.inner.blocks) {
            out.push((b.name.to_string(), b.params));
            out.push((format!("{}/adam m", b.name), &s.moments.m));
            out.push((format!("{}/adam v", b.name), &s.moments.v));
            out.push((format!("good/{}", b.name), &s.good.params));
            out.push((format!("good/{}/adam m", b.name), &s.good.m));
            out.push((format!("good/{}/adam v", b.name), &s.good.v));
        }
        out
    }

    /// Writes `dir/checkpoint.bin` atomically: a serde header (host state, fingerprint, the
    /// named chunks with their checksums) and the raw GPU state (current and good copies).
    pub fn save_checkpoint(&self, dir: &Path) -> Result<(), OptimError> {
        let ctx = &self.inner.ctx;
        let mut chunks = Vec::new();
        for (name, buf) in self.state_chunks() {
            chunks.push(Chunk {
                name,
                data: ctx.download::<u8>(buf)?,
            });
        }
        checkpoint::write(dir, &self.inner.fingerprint, &self.inner.st, &chunks)
    }

    /// The number of scratches of the checkpoint in `dir` (None: the problem's own), and how many
    /// times its run replaced the scene ([`replace_scene`](Self::replace_scene)). A caller whose
    /// scene has another number replaces it before [`load_checkpoint`](Self::load_checkpoint).
    pub fn checkpoint_scratches(&self, dir: &Path) -> Result<(Option<u32>, u32), OptimError> {
        let (st, _) = checkpoint::read::<HostState>(dir, &self.inner.fingerprint)?;
        Ok((st.n_scratches, st.resized))
    }

    /// How many times this run replaced the scene (see [`replace_scene`](Self::replace_scene)).
    pub fn times_resized(&self) -> u32 {
        self.inner.st.resized
    }

    /// Replaces the scene by `gs`, whose scratch i is the current scratch `remap[i]` or, where
    /// that is None, a new scratch as uploaded in `gs`, between two iterations (a live design's
    /// added or removed scratches). The block named `per_scratch.0` holds `per_scratch.1` floats
    /// per scratch: its parameters, Adam moments and good copy (the state a rollback returns to)
    /// are carried over by `remap`, new scratches starting with zero moments; every other block
    /// must keep its length and is carried over whole. Deterministic: a replayed run that
    /// replaces the scene at the same iteration with the same `gs` and `remap` continues with the
    /// same bits.
    pub fn replace_scene(
        &mut self,
        gs: GpuScene,
        remap: &[Option<u32>],
        per_scratch: (&str, u32),
    ) -> Result<(), OptimError> {
        assert_eq!(
            remap.len(),
            gs.n_scratches() as usize,
            "one entry of remap per new scratch"
        );
        let ctx = self.inner.ctx.clone();
        let n_old = self.gs.n_scratches();
        let read = |b: &Buffer, len: u32| -> Result<Vec<f32>, GpuError> {
            let mut v: Vec<f32> = ctx.download(b)?;
            v.truncate(len as usize);
            Ok(v)
        };
        // The current state on the host: per block (params, m, v, good params, good m, good v).
        let mut old = Vec::new();
        for (b, s) in self.inner.params.blocks(&self.gs).iter().zip(&self.inner.blocks) {
            old.push((
                b.name,
                b.len,
                [
                    read(b.params, b.len)?,
                    read(&s.moments.m, b.len)?,
                    read(&s.moments.v, b.len)?,
                    read(&s.good.params, b.len)?,
                    read(&s.good.m, b.len)?,
                    read(&s.good.v, b.len)?,
                ],
            ));
        }
        let mut blocks = Vec::new();
        let mut rec = Recorder::new(&ctx)?;
        rec.begin()?;
        let mut temps = Vec::new();
        for (b, (name, len, data)) in self.inner.params.blocks(&gs).iter().zip(&old) {
            assert_eq!(b.name, *name, "the parameter set's blocks keep their order");
            let new: [Vec<f32>; 6] = if b.name == per_scratch.0 {
                let k = per_scratch.1 as usize;
                assert_eq!(*len as usize, k * n_old as usize, "{} floats per scratch", k);
                let fresh = read(b.params, b.len)?;
                let mut out: [Vec<f32>; 6] = Default::default();
                for (c, o) in out.iter_mut().enumerate() {
                    *o = vec![0f32; b.len as usize];
                    for (i, m) in remap.iter().enumerate() {
                        let dst = &mut o[i * k..(i + 1) * k];
                        match m {
                            Some(j) => dst.copy_from_slice(&data[c][*j as usize * k..(*j as usize + 1) * k]),
                            // A new scratch: as uploaded, now and in the good copy; no moments.
                            None if c == 0 || c == 3 => dst.copy_from_slice(&fresh[i * k..(i + 1) * k]),
                            None => {}
                        }
                    }
                }
                out
            } else {
                if b.len != *len {
                    return Err(OptimError::Usage(format!(
                        "the parameter block `{}` changes its length ({len} -> {}) with the scratches: it cannot be carried over",
                        b.name, b.len
                    )));
                }
                data.clone()
            };
            let moments = Moments {
                m: ctx.upload(&format!("{} adam m", b.name), &padded(&new[1]))?,
                v: ctx.upload(&format!("{} adam v", b.name), &padded(&new[2]))?,
            };
            let snap = Copy3::new(&ctx, "snapshot", b, &moments)?;
            let good = Copy3::new(&ctx, "good copy", b, &moments)?;
            for (src, dst) in [
                (&new[3], &good.params),
                (&new[4], &good.m),
                (&new[5], &good.v),
                (&new[0], b.params),
            ] {
                let tmp = ctx.upload("carried state", &padded(src))?;
                rec.copy(&tmp, dst, tmp.size().min(dst.size()));
                temps.push(tmp);
            }
            blocks.push(BlockState {
                groups: Adam::group_buffer(&ctx, b)?,
                snap,
                good,
                moments,
            });
        }
        rec.barrier();
        rec.submit_and_wait()?;
        drop(temps);
        self.gs = gs;
        self.inner.blocks = blocks;
        self.inner.st.n_scratches = Some(self.gs.n_scratches());
        self.inner.st.resized += 1;
        Ok(())
    }

    /// Restores the state saved by [`save_checkpoint`](Self::save_checkpoint) in `dir`.
    pub fn load_checkpoint(&mut self, dir: &Path) -> Result<(), OptimError> {
        let (st, chunks) = checkpoint::read(dir, &self.inner.fingerprint)?;
        let ctx = self.inner.ctx.clone();
        let path = checkpoint::path(dir);
        let mut rec = Recorder::new(&ctx)?;
        rec.begin()?;
        // Temporary uploads must live until the copies have run.
        let mut temps = Vec::new();
        {
            for (name, buf) in self.state_chunks() {
                let data = chunks
                    .iter()
                    .find(|c| c.name == name)
                    .ok_or_else(|| OptimError::damaged(&path, format!("chunk `{name}` is missing")))?;
                if data.data.len() as u64 != buf.size() {
                    return Err(OptimError::damaged(
                        &path,
                        format!("chunk `{name}` has {} bytes, expected {}", data.data.len(), buf.size()),
                    ));
                }
                let tmp = ctx.upload::<u8>(&format!("checkpoint {name}"), &data.data)?;
                rec.copy(&tmp, buf, buf.size());
                temps.push(tmp);
            }
        }
        rec.barrier();
        rec.submit_and_wait()?;
        drop(temps);
        self.inner.st = st;
        Ok(())
    }
}
