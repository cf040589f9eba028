//! Live design: `scratchart-view --design [design flags]` runs the design job's optimizer in
//! the viewer's process, on the same device, and shows the plate as it converges.
//!
//! - The flags after `--design` are `scratchart design`'s ([`DesignArgs`], the same parser and
//!   the same problem: `design_cmd::prepare`), plus the few of this file's [`LiveOpts`]. So a
//!   live design saved at iteration k is the checkpoint `scratchart design [the same flags]
//!   --resume` continues, bit for bit.
//! - The optimizer runs in its own thread ([`Session`]) with the design job's own loop
//!   (`run_design_live`); after each accepted iteration its hook publishes the design as it
//!   stands (scratches and lights read back) and obeys the window: pause, save, stop. The hook
//!   only reads the optimizer's buffers, so the run is the same bits as `scratchart design`'s.
//!   The window renders the published design with its own camera and lamp, which can move
//!   while the optimizer runs (the optimizer's views do not move with them).
//! - `--headless` runs the same without a window (and `--script` drives either, for tests and
//!   demos).
use std::path::PathBuf;
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use scratchart::design_cmd::DesignArgs;
use scratchart_design::design::run_design_live;
use scratchart_model::scene::Scene;
use scratchart_vulkan::Context;

mod worker;
use worker::hook;

/// `scratchart-view --design`: the design's flags and the live view's own.
#[derive(clap::Parser, Debug, Clone)]
#[command(
    name = "scratchart-view --design",
    about = "Live design: the design job runs in the viewer and the plate is shown as it converges.",
    long_about = None,
    after_help = "Every flag of `scratchart design` applies (see `scratchart design --help`): the targets, \
views, scratches, --iters, --out, --resume, ...; the run is the same bits as `scratchart design` with those \
flags, and a design saved here (key K, or at the end) is one `scratchart design [the same flags] --resume` \
continues.\n\nKeys in the window (besides the viewer's own: drag to orbit, shift-drag to move the lamp, 1..9 \
for a design view's camera, T for its target): P pause/resume the optimizer, K save (design.json and the \
checkpoint in --out), Esc/Q stop: the optimization ends there, and the pruning, the final evaluation and the \
outputs follow as after the last iteration.\n\nExit codes: as `scratchart design` (0 done, 1 runtime, 2 bad \
flags, 3 bad input file, 4 GPU)."
)]
pub struct LiveOpts {
    #[command(flatten)]
    pub design: DesignArgs,
    /// No window: run the live design (to --iters, or as --script says) and save it
    #[arg(long)]
    pub headless: bool,
    /// Window size (WxH)
    #[arg(long, value_name = "WxH", value_parser = crate::parse_size)]
    pub size: Option<(u32, u32)>,
    /// Vulkan device: index or part of the name
    #[arg(long)]
    pub device: Option<String>,
    /// Enable the Vulkan validation layer; exit code 1 if it reported anything
    #[arg(long)]
    pub validation: bool,
    /// Start with the optimizer paused (window)
    #[arg(long)]
    pub paused: bool,
    /// Close the window after this many seconds (the optimization stops there and the design
    /// is finished and saved)
    #[arg(long, value_name = "SECS")]
    pub exit_after: Option<f64>,
    /// Start with the design panel on (key V): every view's render beside its target and the
    /// loss curve, beside the interactive render
    #[arg(long)]
    pub panel: bool,
    /// Print one line per presented frame (with the live iteration) to stdout
    #[arg(long)]
    pub log_frames: bool,
    /// Drive the run by script, for tests and demos: `;`-separated `ITER:COMMAND` items, run
    /// after iteration ITER is accepted, in order: `pause`, `resume`, `save`, `stop`, `lamp
    /// AZ EL` (the window's lamp; headless: the preview's), `wait SECS` (while paused: the
    /// window keeps drawing), `steer VIEW DX DY SCALE`, `weight PIXEL GRAM`, `add N` (N more
    /// scratches, drawn as the first ones were), `remove N` (the N that matter least).
    /// Example: `5:pause;5:lamp 30 60;5:save;5:resume;9:stop`
    #[arg(long, value_name = "SCRIPT")]
    pub script: Option<String>,
}

/// One step of a `--script`.
#[derive(Clone, Debug, PartialEq)]
pub enum ScriptCmd {
    /// Move view NAME's picture by (dx, dy) pixels and scale it, from where the design placed it.
    Steer(String, f64, f64, f64),
    /// The loss's weights: the pixel term's and the Gram term's.
    Weight(f64, f64),
    /// Scratches added (drawn as the first ones were).
    Add(u32),
    /// The scratches that matter least removed.
    Remove(u32),
    Pause,
    Resume,
    Save,
    Stop,
    Lamp(f64, f64),
    Wait(f64),
}

/// Parses `--script` into (iteration, command) pairs in order.
pub fn parse_script(s: &str) -> Result<Vec<(u32, ScriptCmd)>, String> {
    let mut out = Vec::new();
    for item in s.split(';').map(str::trim).filter(|i| !i.is_empty()) {
        let (k, cmd) = item
            .split_once(':')
            .ok_or_else(|| format!("--script item `{item}`: write ITER:COMMAND, e.g. 5:pause"))?;
        let k: u32 = k
            .trim()
            .parse()
            .map_err(|_| format!("--script item `{item}`: `{k}` is not an iteration number"))?;
        let words: Vec<&str> = cmd.split_whitespace().collect();
        let num = |w: Option<&&str>| -> Result<f64, String> {
            w.and_then(|w| w.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("--script item `{item}`: a number is missing or malformed"))
        };
        let c = match words.first().copied() {
            Some("pause") => ScriptCmd::Pause,
            Some("resume") => ScriptCmd::Resume,
            Some("save") => ScriptCmd::Save,
            Some("stop") => ScriptCmd::Stop,
            Some("lamp") => ScriptCmd::Lamp(num(words.get(1))?, num(words.get(2))?),
            Some("wait") => ScriptCmd::Wait(num(words.get(1))?),
            Some("weight") => ScriptCmd::Weight(num(words.get(1))?, num(words.get(2))?),
            Some(w @ ("add" | "remove")) => {
                let n = words
                    .get(1)
                    .and_then(|w| w.parse::<u32>().ok())
                    .filter(|&n| n > 0)
                    .ok_or_else(|| format!("--script item `{item}`: {w} N, with N a whole number of scratches above 0"))?;
                if w == "add" {
                    ScriptCmd::Add(n)
                } else {
                    ScriptCmd::Remove(n)
                }
            }
            Some("steer") => ScriptCmd::Steer(
                words
                    .get(1)
                    .ok_or_else(|| format!("--script item `{item}`: steer VIEW DX DY SCALE"))?
                    .to_string(),
                num(words.get(2))?,
                num(words.get(3))?,
                num(words.get(4))?,
            ),
            _ => {
                return Err(format!(
                    "--script item `{item}`: unknown command (pause, resume, save, stop, lamp AZ EL, wait SECS, steer VIEW DX DY SCALE, weight PIXEL GRAM, add N, remove N)"
                ))
            }
        };
        out.push((k, c));
    }
    let mut last = 0;
    for (k, _) in &out {
        if *k < last {
            return Err(format!(
                "--script: iteration {k} comes after {last}; give the items in order"
            ));
        }
        last = *k;
    }
    Ok(out)
}

/// The arguments after `--design` (the program name first), or `None` without `--design`.
pub fn live_args(args: &[String]) -> Option<Vec<String>> {
    let i = args.iter().position(|a| a == "--design")?;
    let mut out = vec!["scratchart-view --design".to_string()];
    out.extend(args[..i].iter().skip(1).cloned());
    out.extend(args[i + 1..].iter().cloned());
    Some(out)
}

/// What the window tells the optimizer thread.
#[derive(Debug, Default)]
pub struct Control {
    pub paused: bool,
    /// Save at the next iteration boundary (cleared when done).
    pub save: bool,
    /// End the optimization at the next iteration boundary.
    pub stop: bool,
    /// Pictures to move: (view, shift in pixels, scale), from where the design placed them.
    pub steer: Vec<(String, [f64; 2], f64)>,
    /// Loss weights to set: (lambda_p, lambda_g).
    pub weights: Vec<(f64, f64)>,
    /// Scratches to add (> 0) or remove (< 0), in order.
    pub scratches: Vec<i64>,
}

/// What the optimizer thread publishes.
pub enum Update {
    /// An accepted iteration, with the design as it stands when the window wants it (at most
    /// every [`SCENE_EVERY`]: a read-back of every scratch; never headless).
    Step {
        iteration: u32,
        loss: f32,
        scene: Option<Box<Scene>>,
    },
    /// A save finished (the iteration saved) or failed.
    Saved(Result<u32, String>),
    /// Every view's render (display values) and the loss so far, a few times a second, for
    /// the design panel (key V).
    Views(Box<ViewsUpdate>),
    /// A `--script` lamp command for the window.
    Lamp(f64, f64),
    /// A picture was moved (the view, the iteration, its new target), or could not be.
    Steered(Result<(usize, u32, Vec<f32>), String>),
    /// Something done (the loss weights changed), or refused, for the user to read.
    Note(Result<String, String>),
    /// The run is over (its summary printed), or failed with this error.
    Done(Option<anyhow::Error>),
}

/// What the design panel shows.
#[derive(Clone, Debug)]
pub struct ViewsUpdate {
    pub iteration: u32,
    /// Per view: width, height and the render's display values.
    pub images: Vec<(u32, u32, Vec<f32>)>,
    /// The total loss of every accepted iteration so far.
    pub losses: Vec<f32>,
}

/// How often the optimizer thread sends the panel's renders.
const VIEWS_EVERY: Duration = Duration::from_millis(250);
/// How often it sends the design itself to the window (about a display's frame rate).
pub const SCENE_EVERY: Duration = Duration::from_millis(30);

/// The design panel (key V): each view's render beside its target, a few views a row, and the
/// loss curve (log scale) under them, as one gray image for the viewer's target slot.
pub fn panel(v: &ViewsUpdate, targets: &[Option<crate::design::Target>]) -> crate::design::Target {
    const GAP: u32 = 4;
    let n = v.images.len().max(1);
    let per_row = (n as f64).sqrt().ceil() as usize;
    let rows = n.div_ceil(per_row);
    let cw = v.images.iter().map(|i| i.0).max().unwrap_or(1);
    let ch = v.images.iter().map(|i| i.1).max().unwrap_or(1);
    let width = per_row as u32 * (2 * cw + 2 * GAP) + GAP;
    let curve_h = ch.max(48);
    let height = rows as u32 * (ch + GAP) + GAP + curve_h + GAP;
    let mut data = vec![0.15f32; (width * height) as usize];
    let mut put = |x: u32, y: u32, val: f32| {
        if x < width && y < height {
            data[(y * width + x) as usize] = val;
        }
    };
    for (k, (w, h, img)) in v.images.iter().enumerate() {
        let (cx, cy) = ((k % per_row) as u32, (k / per_row) as u32);
        let x0 = GAP + cx * (2 * cw + 2 * GAP);
        let y0 = GAP + cy * (ch + GAP);
        for y in 0..*h {
            for x in 0..*w {
                let i = (y * w + x) as usize;
                put(x0 + x, y0 + y, img[i].clamp(0.0, 1.0));
                if let Some(Some(t)) = targets.get(k) {
                    if t.width == *w && t.height == *h {
                        put(x0 + w + GAP + x, y0 + y, t.data[i].clamp(0.0, 1.0));
                    }
                }
            }
        }
    }
    // The loss curve: log10 of the total loss against the iteration, over the whole width.
    let y_top = rows as u32 * (ch + GAP) + GAP;
    let logs: Vec<f64> = v.losses.iter().map(|&l| (l.max(1e-12) as f64).log10()).collect();
    if logs.len() >= 2 {
        let (lo, hi) = logs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &l| (a.min(l), b.max(l)));
        let span = (hi - lo).max(1e-6);
        let y_of = |l: f64| y_top + ((hi - l) / span * (curve_h - 1) as f64).round() as u32;
        let mut prev: Option<u32> = None;
        for x in 0..width {
            let i = (x as f64 / (width - 1).max(1) as f64 * (logs.len() - 1) as f64).round() as usize;
            let y = y_of(logs[i]);
            let (a, b) = match prev {
                Some(p) => (p.min(y), p.max(y)),
                None => (y, y),
            };
            for yy in a..=b {
                put(x, yy, 1.0);
            }
            prev = Some(y);
        }
    }
    crate::design::Target {
        path: PathBuf::from(format!("(design panel, iteration {})", v.iteration)),
        width,
        height,
        data,
    }
}

/// The optimizer thread's side of a live design.
pub struct Session {
    pub control: Arc<Mutex<Control>>,
    pub updates: Receiver<Update>,
    thread: Option<std::thread::JoinHandle<()>>,
    /// Iterations of the run (--iters).
    pub iters: u32,
    pub out: PathBuf,
    /// (iteration, when) of the first and the latest step seen, for the rate.
    first: Option<(u32, Instant)>,
    pub last_iteration: u32,
    pub last_loss: f32,
    /// The run is over: Ok, or its error's message.
    pub done: Option<Result<(), String>>,
    /// The run's error, until taken.
    pub error: Option<anyhow::Error>,
}

impl Session {
    /// Starts the optimizer thread on `problem` (from `design_cmd::prepare`).
    pub fn start(
        ctx: Arc<Context>,
        problem: scratchart_design::Problem,
        cfg: scratchart_design::DesignConfig,
        script: Vec<(u32, ScriptCmd)>,
        quiet: bool,
        paused: bool,
        window: bool,
    ) -> Session {
        let control = Arc::new(Mutex::new(Control {
            paused,
            ..Default::default()
        }));
        let (tx, rx) = std::sync::mpsc::channel();
        let (iters, out) = (cfg.iters, cfg.out.clone());
        let c2 = control.clone();
        let thread = std::thread::spawn(move || {
            // Ctrl-C stops the run with a checkpoint, as in `scratchart design`.
            let obs = scratchart::term::Terminal::new(quiet);
            let mut script = script.into_iter().peekable();
            let (mut views_sent, mut scene_sent): (Option<Instant>, Option<Instant>) = (None, None);
            let result = run_design_live(&ctx, &problem, &cfg, &obs, &mut |live, ev| {
                // The window's news, a few times a second: no read-back for a run nobody watches.
                let scene_due = window && scene_sent.is_none_or(|t| t.elapsed() >= SCENE_EVERY);
                if scene_due {
                    scene_sent = Some(Instant::now());
                }
                if window && views_sent.is_none_or(|t| t.elapsed() >= VIEWS_EVERY) {
                    views_sent = Some(Instant::now());
                    let images = live
                        .images()?
                        .into_iter()
                        .zip(&live.problem.scene.views)
                        .map(|(img, v)| {
                            let d = img.iter().map(|&l| scratchart_render::io::display_value(l)).collect();
                            (v.camera.width, v.camera.height, d)
                        })
                        .collect();
                    let losses = live.driver.history().iter().map(|e| e.total).collect();
                    let _ = tx.send(Update::Views(Box::new(ViewsUpdate {
                        iteration: live.iteration(),
                        images,
                        losses,
                    })));
                }
                hook(live, ev.total, scene_due, window, &c2, &tx, &mut script)
            });
            // Printed as `scratchart design` prints it (the summary on stdout).
            let r = scratchart::design_cmd::finish(result, &cfg);
            let _ = tx.send(Update::Done(r.err()));
        });
        Session {
            control,
            updates: rx,
            thread: Some(thread),
            iters,
            out,
            first: None,
            last_iteration: 0,
            last_loss: f32::NAN,
            done: None,
            error: None,
        }
    }

    /// Iterations a second since the first step seen.
    pub fn rate(&self) -> Option<f64> {
        let (k0, t0) = self.first?;
        let dt = t0.elapsed().as_secs_f64();
        (self.last_iteration > k0 && dt > 0.0).then(|| (self.last_iteration - k0) as f64 / dt)
    }

    /// Takes every pending update; returns the newest design, and the other updates in order.
    pub fn poll(&mut self) -> (Option<Scene>, Vec<Update>) {
        let mut scene = None;
        let mut other = Vec::new();
        while let Ok(u) = self.updates.try_recv() {
            match u {
                Update::Step {
                    iteration,
                    loss,
                    scene: s,
                } => {
                    self.first.get_or_insert((iteration, Instant::now()));
                    self.last_iteration = iteration;
                    self.last_loss = loss;
                    if let Some(s) = s {
                        scene = Some(*s);
                    }
                }
                Update::Done(e) => {
                    self.done = Some(match &e {
                        None => Ok(()),
                        Some(e) => Err(format!("{e:#}")),
                    });
                    self.error = e;
                    other.push(Update::Done(None));
                }
                u => other.push(u),
            }
        }
        (scene, other)
    }

    pub fn toggle_pause(&self) -> bool {
        let mut c = self.control.lock().unwrap();
        c.paused = !c.paused;
        c.paused
    }

    pub fn paused(&self) -> bool {
        self.control.lock().unwrap().paused
    }

    pub fn request_steer(&self, view: &str, shift: [f64; 2], scale: f64) {
        self.control
            .lock()
            .unwrap()
            .steer
            .push((view.to_string(), shift, scale));
    }

    pub fn request_weights(&self, lambda_p: f64, lambda_g: f64) {
        self.control.lock().unwrap().weights.push((lambda_p, lambda_g));
    }

    /// Adds `n` scratches (n > 0) or removes the -n that matter least (n < 0) at the next
    /// iteration boundary.
    pub fn request_scratches(&self, n: i64) {
        self.control.lock().unwrap().scratches.push(n);
    }

    pub fn request_save(&self) {
        self.control.lock().unwrap().save = true;
    }

    pub fn request_stop(&self) {
        let mut c = self.control.lock().unwrap();
        c.stop = true;
        c.paused = false;
    }

    /// Stops the optimization (if it still runs) and waits for the thread: the design is
    /// finished and written as after its last iteration.
    pub fn join(&mut self) -> Option<Result<(), String>> {
        self.request_stop();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        let (_, rest) = self.poll();
        drop(rest);
        self.done.clone()
    }

    /// One line for the title or the log.
    pub fn status(&self) -> String {
        let state = match (&self.done, self.paused()) {
            (Some(Ok(_)), _) => " | done".to_string(),
            (Some(Err(_)), _) => " | FAILED".to_string(),
            (None, true) => " | paused (P)".to_string(),
            (None, false) => String::new(),
        };
        format!(
            "design {}/{} loss {:.5}{}{}",
            self.last_iteration,
            self.iters,
            self.last_loss,
            self.rate().map(|r| format!(" {r:.1} it/s")).unwrap_or_default(),
            state
        )
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        self.join();
    }
}

/// The context of a live design.
pub fn context(
    o: &LiveOpts,
    instance_extensions: Vec<&'static std::ffi::CStr>,
    device_extensions: Vec<&'static std::ffi::CStr>,
    log: &std::cell::RefCell<Option<scratchart_vulkan::ValidationLog>>,
) -> Result<Arc<Context>> {
    crate::headless::context_for(
        o.validation,
        o.device.clone(),
        instance_extensions,
        device_extensions,
        log,
    )
}

/// `--headless`: the live design without a window. Progress goes to the terminal, the script's
/// items run as in the window, the design is saved when asked and at the end.
pub fn run_headless(o: &LiveOpts, log: &std::cell::RefCell<Option<scratchart_vulkan::ValidationLog>>) -> Result<()> {
    let script = match &o.script {
        Some(s) => parse_script(s).map_err(scratchart_exit::UsageError)?,
        None => Vec::new(),
    };
    // Paused, the iterations stand still, so only an item of the same iteration can end a pause.
    for (i, (k, c)) in script.iter().enumerate() {
        if *c == ScriptCmd::Pause
            && !script[i + 1..]
                .iter()
                .take_while(|(k2, _)| k2 == k)
                .any(|(_, c2)| matches!(c2, ScriptCmd::Resume | ScriptCmd::Stop))
        {
            bail!(scratchart_exit::UsageError(format!(
                "--script: the pause at iteration {k} is never resumed: headless, only a `{k}:resume` or \
                 `{k}:stop` after it can end it (the iterations stand still while paused)"
            )));
        }
    }
    if o.paused {
        bail!(scratchart_exit::UsageError(
            "--paused needs the window: headless, nothing would resume it (use --script)".into()
        ));
    }
    scratchart::term::install_interrupt_handler();
    let ctx = context(o, vec![], vec![], log)?;
    let obs = scratchart::term::Terminal::new(o.design.quiet);
    let (problem, cfg) = scratchart::design_cmd::prepare(&ctx, &o.design, &obs)?;
    let mut session = Session::start(ctx, problem, cfg, script, o.design.quiet, false, false);
    loop {
        let (_, updates) = session.poll();
        for u in updates {
            match u {
                Update::Saved(Ok(k)) => eprintln!("live: saved at iteration {k} in {}", session.out.display()),
                Update::Saved(Err(e)) => eprintln!("warning: live: the save failed: {e}"),
                Update::Lamp(az, el) => eprintln!("live: lamp at azimuth {az}, elevation {el}"),
                Update::Steered(Ok((v, k, _))) => eprintln!("live: view {v}'s picture moved at iteration {k}"),
                Update::Steered(Err(e)) | Update::Note(Err(e)) => eprintln!("warning: live: {e}"),
                Update::Note(Ok(m)) => eprintln!("live: {m}"),
                Update::Done(_) => {
                    session.join();
                    return match session.error.take() {
                        Some(e) => Err(e),
                        None => Ok(()),
                    };
                }
                Update::Step { .. } | Update::Views(_) => {}
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_script_parses_in_order_and_refuses_what_it_cannot_read() {
        let s = parse_script("5:pause; 5:lamp 30 60;5:save;7:wait 0.5;9:stop").unwrap();
        assert_eq!(
            s,
            vec![
                (5, ScriptCmd::Pause),
                (5, ScriptCmd::Lamp(30.0, 60.0)),
                (5, ScriptCmd::Save),
                (7, ScriptCmd::Wait(0.5)),
                (9, ScriptCmd::Stop)
            ]
        );
        assert!(parse_script("x:pause").unwrap_err().contains("iteration number"));
        assert!(parse_script("5 pause").unwrap_err().contains("ITER:COMMAND"));
        assert!(parse_script("5:lamp 30").unwrap_err().contains("number"));
        assert!(parse_script("5:fly").unwrap_err().contains("unknown command"));
        assert!(parse_script("5:pause;3:resume").unwrap_err().contains("in order"));
        assert_eq!(
            parse_script("2:add 40;3:remove 7").unwrap(),
            vec![(2, ScriptCmd::Add(40)), (3, ScriptCmd::Remove(7))]
        );
        for bad in ["2:add", "2:add 0", "2:remove -3", "2:add 1.5"] {
            assert!(parse_script(bad).unwrap_err().contains("whole number"), "{bad}");
        }
    }

    #[test]
    fn the_design_flags_are_those_after_design_with_the_viewers_before() {
        let a = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(live_args(&a(&["view", "x.json"])), None);
        assert_eq!(
            live_args(&a(&["view", "--headless", "--design", "--iters", "3"])).unwrap(),
            a(&["scratchart-view --design", "--headless", "--iters", "3"])
        );
    }
}
