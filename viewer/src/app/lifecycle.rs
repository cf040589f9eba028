//! The winit callbacks: the window and its surface are created on `Resumed` and the surface is
//! dropped on `Suspended` (the pattern of ash's winit example); events are dispatched to the
//! input handlers and the per-frame render; `about_to_wait` decides whether to draw now or
//! sleep until the next poll or the end of the settle time.
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Result;
use raw_window_handle::{HasWindowHandle, RawWindowHandle};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow};
use winit::window::{Window, WindowId};

use super::{App, POLL, SETTLE};
use crate::headless;
use crate::swapchain::Presenter;

impl App {
    fn window_id_text(window: &Window) -> Option<String> {
        match window.window_handle().ok()?.as_raw() {
            RawWindowHandle::Xlib(h) => Some(h.window.to_string()),
            RawWindowHandle::Xcb(h) => Some(h.window.get().to_string()),
            _ => None,
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            let (w, h) = self.opts.size.unwrap_or(headless::DEFAULT_SIZE);
            let attrs = Window::default_attributes()
                .with_title("scratchart-view")
                .with_inner_size(PhysicalSize::new(w, h));
            match event_loop.create_window(attrs) {
                Ok(win) => {
                    if self.opts.log_frames {
                        if let Some(id) = Self::window_id_text(&win) {
                            println!("window-id {id}");
                        }
                    }
                    self.window = Some(Arc::new(win));
                }
                Err(e) => return self.fail(event_loop, anyhow::Error::new(e).context("cannot create the window")),
            }
        }
        let window = self.window.clone().unwrap();
        if self.presenter.is_none() {
            match Presenter::new(self.fr.ctx(), &window, !self.opts.no_vsync) {
                Ok(p) => self.presenter = Some(p),
                Err(e) => return self.fail(event_loop, e),
            }
        }
        self.swap_dirty = true;
        self.presented = None;
        window.request_redraw();
    }

    fn suspended(&mut self, _event_loop: &ActiveEventLoop) {
        // The window's native surface may go away (Android-style lifecycles): drop ours now.
        self.presenter = None;
    }

    fn exiting(&mut self, _event_loop: &ActiveEventLoop) {
        self.presenter = None;
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let r: Result<()> = match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                Ok(())
            }
            WindowEvent::Resized(_) | WindowEvent::ScaleFactorChanged { .. } => {
                self.swap_dirty = true;
                self.presented = None;
                Ok(())
            }
            WindowEvent::RedrawRequested => self.draw(event_loop),
            event => self.on_input(event_loop, event),
        };
        if let Err(e) = r {
            self.fail(event_loop, e);
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let now = Instant::now();
        if let Some(limit) = self.opts.exit_after {
            if now.duration_since(self.start).as_secs_f64() >= limit {
                event_loop.exit();
                return;
            }
        }
        let dt = now.duration_since(self.last_tick).as_secs_f64();
        self.last_tick = now;
        if self.light_orbit {
            self.light.rotate(self.light_speed * dt.min(0.25));
            self.bump();
        }
        if self.walking {
            if let Some(w) = self.walk.as_mut() {
                w.advance(dt.min(0.25));
            }
            if let Err(e) = self.follow_walk() {
                return self.fail(event_loop, e);
            }
        }
        if let Err(e) = self.poll_files() {
            return self.fail(event_loop, e);
        }
        if let Err(e) = self.poll_live() {
            return self.fail(event_loop, e);
        }
        let still = self.still(now);
        let want_level = if still || !self.adaptive { 0 } else { self.level };
        let stale = match self.presented {
            None => true,
            Some((v, l)) => v != self.version || (still && l != 0 && l != want_level),
        };
        // --frames N counts drawn frames: draw until N, even when nothing changes.
        let need = stale
            || self.swap_dirty
            || self.opts.continuous
            || self.bench.is_some()
            || self.opts.frame_count().is_some();
        let minimized = self
            .window
            .as_ref()
            .is_none_or(|w| w.inner_size().width == 0 || w.inner_size().height == 0);
        let mut wake = self.last_poll + POLL;
        if let Some(limit) = self.opts.exit_after {
            wake = wake.min(self.start + Duration::from_secs_f64(limit));
        }
        if !still {
            wake = wake.min(self.last_change + SETTLE);
        }
        if self.live.as_ref().is_some_and(|l| l.done.is_none()) {
            // A live design publishes after every iteration: look often.
            wake = wake.min(now + Duration::from_millis(30));
        }
        if need && !minimized && self.presenter.is_some() {
            if let Some(w) = &self.window {
                w.request_redraw();
            }
            event_loop.set_control_flow(ControlFlow::Poll);
        } else {
            event_loop.set_control_flow(ControlFlow::WaitUntil(wake.max(now + Duration::from_millis(1))));
        }
    }
}
