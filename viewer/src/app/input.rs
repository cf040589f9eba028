//! Keyboard and mouse: the key bindings of `crate::KEYS`, orbit / pan / zoom of the camera,
//! shift-drag of the light, and the actions behind them (views, target, walk, reset).
use std::time::Instant;

use anyhow::Result;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::ActiveEventLoop;
use winit::keyboard::{Key, NamedKey};

use super::App;
use crate::headless;
use crate::setup::SetupInfo;
use crate::state::{LightRig, OrbitCamera};
use crate::walk::Walk;

impl App {
    /// Key W: the walk on or off (on resumes where it stopped, or at the view last jumped to).
    fn toggle_walk(&mut self) -> Result<()> {
        if self.walk.is_none() {
            eprintln!(
                "no walk: it needs a design with at least 2 views, {} has {}",
                self.design.name(),
                self.design.scene.views.len()
            );
            return Ok(());
        }
        self.walking = !self.walking;
        self.last_title = None;
        if self.walking {
            eprintln!(
                "walk on: {} views, {:.1} deg/s",
                self.design.scene.views.len(),
                self.opts.walk_speed
            );
            self.follow_walk()
        } else {
            eprintln!("walk off");
            self.bump();
            Ok(())
        }
    }

    /// Mouse input that moves the camera or the light stops the walk.
    fn stop_walk(&mut self, why: &str) {
        if self.walking {
            self.walking = false;
            self.last_title = None;
            eprintln!("walk stopped ({why})");
        }
    }

    /// While the walk plays: the camera at its position now, the light of the nearest view, and
    /// that view's index (and target, when one is shown).
    pub(super) fn follow_walk(&mut self) -> Result<()> {
        let Some(w) = &self.walk else {
            self.walking = false;
            return Ok(());
        };
        let pos = w.position();
        let near = w.nearest(pos);
        self.cam = w.camera_at(pos);
        self.light = LightRig::from_light(&self.design.scene.views[near].light);
        if near != self.view_idx {
            self.view_idx = near;
            if self.show_target {
                match self.design.targets.get(near).and_then(|t| t.as_ref()) {
                    Some(t) => self.fr.set_target(Some(t))?,
                    None => {
                        eprintln!(
                            "view '{}' has no target image: target hidden",
                            self.design.scene.views[near].name
                        );
                        self.show_target = false;
                        self.fr.set_target(None)?;
                    }
                }
            }
        }
        self.bump();
        Ok(())
    }

    /// After a reload: the walk along the new views, from the current view (stopped when the
    /// design has fewer than 2 views now).
    pub(super) fn rebuild_walk(&mut self) {
        self.walk = Walk::new(&self.design.scene.views, self.opts.walk_speed);
        match self.walk.as_mut() {
            Some(w) => w.start_at(self.view_idx),
            None => self.stop_walk("the design has fewer than 2 views now"),
        }
    }

    pub(super) fn toggle_target(&mut self) -> Result<()> {
        if self.show_target {
            self.show_target = false;
            self.fr.set_target(None)?;
        } else {
            match self.design.targets.get(self.view_idx).and_then(|t| t.as_ref()) {
                Some(t) => {
                    self.fr.set_target(Some(t))?;
                    self.show_target = true;
                    eprintln!("target: {}", t.path.display());
                }
                None => eprintln!(
                    "view '{}' has no target image (add \"target\": \"file.png\" to the view, or \
                     put {}_target.png next to the design)",
                    self.design.scene.views[self.view_idx].name, self.design.scene.views[self.view_idx].name
                ),
            }
        }
        self.bump();
        Ok(())
    }

    /// Key S: the set-up overlay on or off; turning it on prints the numbers to stdout.
    pub(super) fn toggle_setup(&mut self) {
        if self.setup.take().is_none() {
            let s = SetupInfo::of(&self.design.scene);
            println!("{}", s.report());
            self.setup = Some(s);
        } else {
            println!("set-up overlay off");
        }
        self.last_title = None;
        self.bump();
    }

    fn jump_to_view(&mut self, idx: usize) -> Result<()> {
        let Some(v) = self.design.scene.views.get(idx) else {
            eprintln!("the design has only {} views", self.design.scene.views.len());
            return Ok(());
        };
        eprintln!("view {idx}: '{}'", v.name);
        self.cam = OrbitCamera::from_camera(&v.camera);
        self.light = LightRig::from_light(&v.light);
        self.view_idx = idx;
        // The walk goes on from here (W starts it here when off).
        if let Some(w) = self.walk.as_mut() {
            w.start_at(idx);
        }
        if self.show_target {
            // Show the new view's target (or none).
            self.show_target = false;
            self.fr.set_target(None)?;
            self.toggle_target()?;
        }
        self.bump();
        Ok(())
    }

    fn reset(&mut self) -> Result<()> {
        let idx = self
            .opts
            .view
            .as_deref()
            .and_then(|s| self.design.view_index(s).ok())
            .unwrap_or(0);
        let (cam, light) = headless::initial_state(&self.opts, &self.design, idx);
        self.cam = cam;
        self.light = light;
        self.view_idx = idx;
        self.exposure = self.opts.exposure;
        self.light_orbit = false;
        self.light_speed = self.opts.light_speed;
        if let Some(w) = self.walk.as_mut() {
            w.start_at(idx);
        }
        self.walking = self.opts.walk && self.walk.is_some();
        self.last_title = None;
        if self.show_target {
            self.toggle_target()?;
        }
        self.bump();
        Ok(())
    }

    fn on_key(&mut self, key: &Key, repeat: bool, event_loop: &ActiveEventLoop) -> Result<()> {
        if repeat && !key_repeats(key) {
            // A held toggle (S, L, T, ...) would flicker on and off with the keyboard's
            // auto-repeat, and a busy X server can turn one slow press into several.
            return Ok(());
        }
        let step = if self.shift { 8.0 } else { 2.0 };
        let ch = match key {
            Key::Named(NamedKey::Escape) => {
                event_loop.exit();
                return Ok(());
            }
            Key::Named(NamedKey::ArrowLeft) => {
                self.steer_picture(-step, 0.0, 1.0);
                return Ok(());
            }
            Key::Named(NamedKey::ArrowRight) => {
                self.steer_picture(step, 0.0, 1.0);
                return Ok(());
            }
            Key::Named(NamedKey::ArrowUp) => {
                self.steer_picture(0.0, -step, 1.0);
                return Ok(());
            }
            Key::Named(NamedKey::ArrowDown) => {
                self.steer_picture(0.0, step, 1.0);
                return Ok(());
            }
            Key::Character(s) => s.to_lowercase(),
            _ => return Ok(()),
        };
        match ch.as_str() {
            "q" => event_loop.exit(),
            "l" => {
                self.light_orbit = !self.light_orbit;
                eprintln!("light orbit {}", if self.light_orbit { "on" } else { "off" });
                self.bump();
            }
            "+" | "=" => {
                self.light_speed *= 1.5;
                eprintln!("light orbit speed {:.1} deg/s", self.light_speed);
            }
            "-" | "_" => {
                self.light_speed /= 1.5;
                eprintln!("light orbit speed {:.1} deg/s", self.light_speed);
            }
            "t" => {
                if self.panel {
                    self.toggle_panel()?;
                }
                self.toggle_target()?
            }
            "v" => self.toggle_panel()?,
            "g" => self.steer_gram(if self.shift { 0.5 } else { 2.0 }),
            "c" => self.steer_count(!self.shift),
            "[" => self.steer_picture(0.0, 0.0, 1.0 / 1.05),
            "]" => self.steer_picture(0.0, 0.0, 1.05),
            "w" => self.toggle_walk()?,
            "p" => {
                if let Some(l) = &self.live {
                    let paused = l.toggle_pause();
                    eprintln!("live design {}", if paused { "paused" } else { "running" });
                    self.bump();
                }
            }
            "k" => {
                if let Some(l) = &self.live {
                    l.request_save();
                    eprintln!("live design: saving at the next iteration boundary");
                }
            }
            "s" => self.toggle_setup(),
            "e" => {
                if self.shift {
                    self.exposure /= 1.25;
                } else {
                    self.exposure *= 1.25;
                }
                eprintln!("exposure {:.3}", self.exposure);
                self.bump();
            }
            "n" => {
                self.nearest = !self.nearest;
                eprintln!("upscaling: {}", if self.nearest { "nearest" } else { "bilinear" });
                self.bump();
            }
            "a" => {
                self.adaptive = !self.adaptive;
                eprintln!("adaptive resolution {}", if self.adaptive { "on" } else { "off" });
                self.bump();
            }
            "r" => self.reset()?,
            "h" => eprintln!("{}", crate::KEYS),
            d if d.len() == 1 && ("1"..="9").contains(&d) => self.jump_to_view(d.parse::<usize>().unwrap() - 1)?,
            _ => {}
        }
        Ok(())
    }

    fn on_drag(&mut self, dx: f64, dy: f64) {
        self.stop_walk("mouse");
        let h = self
            .window
            .as_ref()
            .map(|w| w.inner_size().height as f64)
            .unwrap_or(720.0);
        if self.buttons[0] {
            if self.light_drag {
                self.light.drag(dx, dy);
            } else {
                self.cam.orbit(dx, dy);
            }
        } else {
            self.cam.pan(dx, dy, h);
        }
        self.bump();
    }

    /// The input events of [`winit::application::ApplicationHandler::window_event`] (keys,
    /// modifiers, buttons, cursor, wheel); other events are ignored here.
    pub(super) fn on_input(&mut self, event_loop: &ActiveEventLoop, event: WindowEvent) -> Result<()> {
        match event {
            WindowEvent::ModifiersChanged(m) => {
                self.shift = m.state().shift_key();
                Ok(())
            }
            // winit makes up a press for every key already held when the window gains focus
            // (is_synthetic): a key pressed just as the window was focused would then act twice.
            WindowEvent::KeyboardInput {
                event, is_synthetic, ..
            } if event.state == ElementState::Pressed && !is_synthetic => {
                self.on_key(&event.logical_key, event.repeat, event_loop)
            }
            WindowEvent::MouseInput { state, button, .. } => {
                let i = match button {
                    MouseButton::Left => Some(0),
                    MouseButton::Right => Some(1),
                    MouseButton::Middle => Some(2),
                    _ => None,
                };
                if let Some(i) = i {
                    let down = state == ElementState::Pressed;
                    if i == 0 && down {
                        self.light_drag = self.shift;
                    }
                    self.buttons[i] = down;
                    self.last_change = Instant::now();
                }
                Ok(())
            }
            WindowEvent::CursorMoved { position, .. } => {
                let (x, y) = (position.x, position.y);
                if let (Some((px, py)), true) = (self.cursor, self.dragging()) {
                    self.on_drag(x - px, y - py);
                }
                self.cursor = Some((x, y));
                Ok(())
            }
            WindowEvent::CursorLeft { .. } => {
                self.cursor = None;
                Ok(())
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                self.stop_walk("mouse");
                self.cam.zoom(steps);
                self.bump();
                Ok(())
            }
            _ => Ok(()),
        }
    }
}

/// Whether holding `key` repeats it: steps (arrows, exposure, orbit speed, picture scale) do;
/// toggles and one-shot actions (S, L, T, V, W, P, K, C, N, A, R, Q, view numbers) act once per
/// press.
pub(crate) fn key_repeats(key: &Key) -> bool {
    match key {
        Key::Named(n) => matches!(
            n,
            NamedKey::ArrowLeft | NamedKey::ArrowRight | NamedKey::ArrowUp | NamedKey::ArrowDown
        ),
        Key::Character(s) => matches!(s.to_lowercase().as_str(), "+" | "=" | "-" | "_" | "e" | "[" | "]" | "g"),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toggles_ignore_auto_repeat_and_steps_repeat() {
        for t in ["s", "S", "l", "t", "v", "w", "p", "k", "c", "n", "a", "r", "q", "1"] {
            assert!(!key_repeats(&Key::Character(t.into())), "{t} repeats");
        }
        assert!(!key_repeats(&Key::Named(NamedKey::Escape)));
        for t in ["e", "E", "+", "-", "[", "]"] {
            assert!(key_repeats(&Key::Character(t.into())), "{t} does not repeat");
        }
        assert!(key_repeats(&Key::Named(NamedKey::ArrowUp)));
    }
}
