//! The design thread's side of a live design: after each accepted iteration it publishes the
//! design, runs the script's items that are due, and serves the window's requests (steering,
//! scratches added or removed, loss weights, save, pause, stop).
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use scratchart_design::live::Live;

use super::{Control, ScriptCmd, Update};

/// After each accepted iteration: publish the design, run the script's items for this
/// iteration, save when asked, wait while paused, and say whether to go on.
#[allow(clippy::too_many_arguments)] // the thread's state, named at its one call
pub(super) fn hook(
    live: &mut Live,
    loss: f32,
    scene_due: bool,
    window: bool,
    control: &Arc<Mutex<Control>>,
    tx: &Sender<Update>,
    script: &mut std::iter::Peekable<std::vec::IntoIter<(u32, ScriptCmd)>>,
) -> Result<bool, scratchart_optim::error::OptimError> {
    let k = live.iteration();
    let step = |live: &Live, with_scene: bool| -> Result<(), scratchart_optim::error::OptimError> {
        let scene = if with_scene {
            Some(Box::new(live.scene()?))
        } else {
            None
        };
        let _ = tx.send(Update::Step {
            iteration: k,
            loss,
            scene,
        });
        Ok(())
    };
    step(live, scene_due)?;
    // The script's items of iterations up to this one (an item of an iteration a rollback
    // skipped runs at the next).
    while script.peek().is_some_and(|(at, _)| *at <= k) {
        let (_, c) = script.next().expect("peeked");
        let mut ctl = control.lock().unwrap();
        match c {
            ScriptCmd::Pause => ctl.paused = true,
            ScriptCmd::Resume => ctl.paused = false,
            ScriptCmd::Save => ctl.save = true,
            ScriptCmd::Stop => ctl.stop = true,
            ScriptCmd::Lamp(az, el) => {
                let _ = tx.send(Update::Lamp(az, el));
            }
            ScriptCmd::Steer(view, dx, dy, scale) => ctl.steer.push((view, [dx, dy], scale)),
            ScriptCmd::Weight(p, g) => ctl.weights.push((p, g)),
            ScriptCmd::Add(n) => ctl.scratches.push(n as i64),
            ScriptCmd::Remove(n) => ctl.scratches.push(-(n as i64)),
            ScriptCmd::Wait(s) => {
                drop(ctl);
                std::thread::sleep(Duration::from_secs_f64(s.clamp(0.0, 60.0)));
                continue;
            }
        }
        drop(ctl);
        serve(live, control, tx, false)?;
    }
    // A pause shows the design where it stopped.
    if window && !scene_due && control.lock().unwrap().paused {
        step(live, true)?;
    }
    serve(live, control, tx, true)
}

/// Saves when asked; with `block`, waits while paused. Returns false when the window stops the
/// run.
fn serve(
    live: &mut Live,
    control: &Arc<Mutex<Control>>,
    tx: &Sender<Update>,
    block: bool,
) -> Result<bool, scratchart_optim::error::OptimError> {
    loop {
        let (save, stop, paused, steer, weights, scratches) = {
            let mut c = control.lock().unwrap();
            let s = (
                c.save,
                c.stop,
                c.paused,
                std::mem::take(&mut c.steer),
                std::mem::take(&mut c.weights),
                std::mem::take(&mut c.scratches),
            );
            c.save = false;
            s
        };
        for n in scratches {
            let before = live.n_scratches();
            let r = if n > 0 {
                live.add_scratches(n as u32)
            } else {
                live.remove_scratches(n.unsigned_abs().min(u32::MAX as u64) as u32)
            };
            let r = match r {
                Ok(()) => Ok(format!(
                    "{before} -> {} scratches from iteration {}",
                    live.n_scratches(),
                    live.iteration()
                )),
                Err(scratchart_optim::error::OptimError::Usage(m)) => Err(m),
                Err(e) => return Err(e),
            };
            let _ = tx.send(Update::Note(r));
        }
        for (p, g) in weights {
            let r = match live.steer_weights(Some(p), Some(g)) {
                Ok(()) => Ok(format!(
                    "loss weights pixel {p}, Gram {g} from iteration {}",
                    live.iteration()
                )),
                Err(scratchart_optim::error::OptimError::Usage(m)) => Err(m),
                Err(e) => return Err(e),
            };
            let _ = tx.send(Update::Note(r));
        }
        for (view, shift, scale) in steer {
            let r = match live.steer(&view, shift, scale) {
                Ok(()) => {
                    let v = live
                        .problem
                        .scene
                        .views
                        .iter()
                        .position(|x| x.name == view)
                        .expect("steered");
                    Ok((v, live.iteration(), live.problem.targets[v].clone()))
                }
                // A picture that cannot move is the user's to hear about; the run goes on.
                Err(scratchart_optim::error::OptimError::Usage(m)) => Err(m),
                Err(e) => return Err(e),
            };
            let _ = tx.send(Update::Steered(r));
        }
        if save {
            let r = live.save().map(|_| live.iteration()).map_err(|e| e.to_string());
            let _ = tx.send(Update::Saved(r));
        }
        if stop {
            return Ok(false);
        }
        if !paused || !block {
            return Ok(true);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}
