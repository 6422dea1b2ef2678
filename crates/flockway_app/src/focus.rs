//! Keyboard focus on an X server without a window manager (Xvfb, a bare X session).
//!
//! There, the focus stays "pointer root" and winit hands out no key events until the pointer
//! has moved into the window, so the first key presses of someone who has not touched the mouse
//! are lost. Where nothing manages the focus, the window takes it itself: when it opens and when
//! the pointer enters it. Under a window manager (any other focus) nothing is done.

use winit::window::Window;

/// Gives the window the keyboard focus if no window manager hands focus out.
#[cfg(all(unix, not(target_os = "macos")))]
pub(crate) fn take_if_unmanaged(window: &Window) {
    use winit::raw_window_handle::{HasWindowHandle, RawWindowHandle};
    use x11rb::connection::Connection;
    use x11rb::protocol::xproto::{ConnectionExt, InputFocus};
    let Ok(handle) = window.window_handle() else {
        return;
    };
    let id = match handle.as_raw() {
        RawWindowHandle::Xlib(h) => h.window as u32,
        RawWindowHandle::Xcb(h) => h.window.get(),
        _ => return,
    };
    let Ok((conn, screen)) = x11rb::connect(None) else {
        return;
    };
    let root = conn.setup().roots.get(screen).map(|s| s.root);
    let focus = conn
        .get_input_focus()
        .ok()
        .and_then(|cookie| cookie.reply().ok());
    // No focus (0), pointer root (1) or the root window (where focus falls back when a focused
    // window closes): nothing gave the focus to anyone. When this window closes, the focus goes
    // back to pointer root.
    if focus.is_some_and(|f| f.focus <= 1 || Some(f.focus) == root) {
        let _ = conn.set_input_focus(InputFocus::POINTER_ROOT, id, x11rb::CURRENT_TIME);
        let _ = conn.flush();
    }
}

/// Elsewhere the window system gives the focus.
#[cfg(not(all(unix, not(target_os = "macos"))))]
pub(crate) fn take_if_unmanaged(_: &Window) {}
