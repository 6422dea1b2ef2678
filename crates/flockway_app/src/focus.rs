//! Keyboard focus on an X server without a window manager (Xvfb, a bare X session).
//!
//! There, the focus stays "pointer root" and winit hands out no key events until the pointer
//! has moved into the window, so the first key presses of someone who has not touched the mouse
//! are lost. Where nothing manages the focus, the window takes it itself: every frame until it
//! has had it once (its own map request travels on winit's connection, so an early attempt may
//! come before the window can take focus), and again when the pointer enters it or clicks in
//! it. Under a window manager (any other focus) nothing is done.

use winit::window::Window;

/// Takes the keyboard focus for a window where no window manager hands it out.
#[cfg_attr(not(all(unix, not(target_os = "macos"))), allow(dead_code))]
pub(crate) struct FocusKeeper {
    #[cfg(all(unix, not(target_os = "macos")))]
    x11: Option<X11>,
    had_focus: bool,
    /// Frames left to try in: a window that never gets the focus stops asking after these.
    tries_left: u32,
}

#[cfg(all(unix, not(target_os = "macos")))]
struct X11 {
    conn: x11rb::rust_connection::RustConnection,
    window: u32,
    root: u32,
}

impl FocusKeeper {
    /// A keeper for `window` (which does nothing off X11).
    pub(crate) fn new(window: &Window) -> FocusKeeper {
        FocusKeeper {
            #[cfg(all(unix, not(target_os = "macos")))]
            x11: X11::connect(window),
            had_focus: false,
            tries_left: 600,
        }
    }

    /// Called every frame: takes the focus until the window has had it once.
    pub(crate) fn frame(&mut self) {
        if !self.had_focus && self.tries_left > 0 {
            self.tries_left -= 1;
            self.take_if_unmanaged();
        }
    }

    /// Takes the focus if nobody has it (or the root window has it): no window manager gives it.
    pub(crate) fn take_if_unmanaged(&mut self) {
        #[cfg(all(unix, not(target_os = "macos")))]
        if let Some(x) = &self.x11
            && let Some(has) = x.take_if_unmanaged()
        {
            self.had_focus |= has;
        }
    }
}

#[cfg(all(unix, not(target_os = "macos")))]
impl X11 {
    fn connect(window: &Window) -> Option<X11> {
        use winit::raw_window_handle::{HasWindowHandle, RawWindowHandle};
        use x11rb::connection::Connection;
        let id = match window.window_handle().ok()?.as_raw() {
            RawWindowHandle::Xlib(h) => h.window as u32,
            RawWindowHandle::Xcb(h) => h.window.get(),
            _ => return None,
        };
        let (conn, screen) = x11rb::connect(None).ok()?;
        let root = conn.setup().roots.get(screen)?.root;
        Some(X11 {
            conn,
            window: id,
            root,
        })
    }

    /// Whether the window has the focus after this: it takes it when nobody has it (0), the
    /// pointer root has it (1), or the root window has it (where focus falls back when a focused
    /// window closes). `None` if the server could not be asked.
    fn take_if_unmanaged(&self) -> Option<bool> {
        use x11rb::connection::Connection;
        use x11rb::protocol::xproto::{ConnectionExt, InputFocus};
        let focus = self.conn.get_input_focus().ok()?.reply().ok()?.focus;
        if focus == self.window {
            return Some(true);
        }
        if focus <= 1 || focus == self.root {
            // When this window closes, the focus goes back to pointer root.
            let cookie = self
                .conn
                .set_input_focus(InputFocus::POINTER_ROOT, self.window, x11rb::CURRENT_TIME)
                .ok()?;
            // A window not yet mapped refuses: the next frame tries again.
            return Some(cookie.check().is_ok());
        }
        let _ = self.conn.flush();
        Some(false)
    }
}
