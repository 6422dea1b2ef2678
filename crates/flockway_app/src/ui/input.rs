//! The scene's input: mouse presses, drags and the wheel on the part of the window no panel
//! covers, and the keyboard shortcuts; plus what is drawn over the scene (the road-drawing hint
//! and the scale bar).
//!
//! Input is read from egui's event list in the order it arrived, with each event's own pointer
//! position, and tested against the panels as they are laid out this frame: a click on a button
//! or a text field never reaches the scene, however many events one frame brings.

use crate::app::{AppState, Selection};
use egui::{Event, Key, Modifiers, PointerButton, Pos2, Rect};
use glam::Vec2;

/// Which buttons went down on the scene (and are still down), and where the pointer was last.
#[derive(Debug, Clone, Copy, Default)]
struct ScenePointer {
    down: [bool; 3],
    last: Option<Pos2>,
}

fn scene_rect_id() -> egui::Id {
    egui::Id::unique("flockway_scene_rect")
}

fn pointer_id() -> egui::Id {
    egui::Id::unique("flockway_scene_pointer")
}

/// Whether `pos` is on the scene: inside the area the panels leave free, with no window, menu,
/// popup or dialog over it.
fn on_scene(ctx: &egui::Context, app: &AppState, scene: Rect, pos: Pos2) -> bool {
    scene.contains(pos)
        && app.pending.is_none()
        && app.recovered.is_none()
        && ctx
            .layer_id_at(pos)
            .is_none_or(|l| l.order == egui::Order::Background)
}

/// The window in physical pixels, which the camera works in.
fn viewport_px(ctx: &egui::Context) -> (Vec2, f32) {
    let ppp = ctx.pixels_per_point();
    let r = ctx.content_rect();
    (Vec2::new(r.width() * ppp, r.height() * ppp), ppp)
}

fn px(pos: Pos2, ppp: f32) -> Vec2 {
    Vec2::new(pos.x * ppp, pos.y * ppp)
}

/// Mouse input on the scene, then the overlays. Runs after the panels, so the scene is what they
/// left free.
pub(super) fn scene(ui: &mut egui::Ui, app: &mut AppState) {
    let rect = ui.available_rect_before_wrap();
    let ctx = ui.ctx().clone();
    ctx.data_mut(|d| d.insert_temp(scene_rect_id(), rect));
    let (size, ppp) = viewport_px(&ctx);
    app.set_view_area(size, px(rect.min, ppp), px(rect.max, ppp));
    let mut state: ScenePointer = ctx.data(|d| d.get_temp(pointer_id())).unwrap_or_default();
    let events = ctx.input(|i| i.events.clone());
    for event in events {
        match event {
            Event::PointerMoved(pos) => {
                let delta = state.last.map_or(Vec2::ZERO, |l| px(pos, ppp) - px(l, ppp));
                state.last = Some(pos);
                if state.down[0] {
                    app.drag_to(px(pos, ppp), size);
                }
                if state.down[1] {
                    app.camera.orbit(delta, size);
                }
                if state.down[2] {
                    app.camera.pan(delta, size);
                }
            }
            Event::PointerButton {
                pos,
                button,
                pressed,
                ..
            } => {
                let k = match button {
                    PointerButton::Primary => 0,
                    PointerButton::Secondary => 1,
                    PointerButton::Middle => 2,
                    _ => continue,
                };
                state.last = Some(pos);
                tracing::debug!(
                    "button {button:?} pressed {pressed} at {pos:?}: scene {rect:?}, layer {:?}",
                    ctx.layer_id_at(pos)
                );
                if pressed {
                    if on_scene(&ctx, app, rect, pos) {
                        state.down[k] = true;
                        // Clicking the scene ends typing in a field, so the keys are the
                        // scene's again.
                        ctx.memory_mut(|m| m.stop_text_input());
                        if k == 0 {
                            app.press(px(pos, ppp), size);
                        }
                    }
                } else if state.down[k] {
                    state.down[k] = false;
                    if k == 0 {
                        app.release();
                    }
                }
            }
            Event::PointerGone => state.last = None,
            Event::MouseWheel { unit, delta, .. } => {
                let over = state.last.is_some_and(|p| on_scene(&ctx, app, rect, p));
                if over {
                    let lines = match unit {
                        egui::MouseWheelUnit::Point => delta.y / 40.0,
                        egui::MouseWheelUnit::Line => delta.y,
                        egui::MouseWheelUnit::Page => delta.y * 10.0,
                    };
                    app.camera.zoom(0.9f32.powf(lines));
                }
            }
            _ => {}
        }
    }
    ctx.data_mut(|d| d.insert_temp(pointer_id(), state));
    let painter = ui.painter_at(rect);
    draw_junction(&painter, app, size, ppp);
    draw_hint(&painter, app, size, ppp);
    draw_scale_bar(&painter, app, rect, size, ppp);
}

/// The selected junction's paths outlined, each numbered as the inspector's connections (and
/// phase table's columns) are, 60 % of the way along: past the shared entry of paths from one
/// lane, short of the shared exit of paths onto one lane.
fn draw_junction(painter: &egui::Painter, app: &AppState, size: Vec2, ppp: f32) {
    let paths = app.selected_junction_paths();
    let on_screen = |p: glam::Vec3| {
        app.camera
            .to_screen(p, size)
            .map(|s| Pos2::new(s.x / ppp, s.y / ppp))
    };
    for path in &paths {
        let line: Vec<Pos2> = path.iter().filter_map(|&p| on_screen(p)).collect();
        painter.add(egui::Shape::line(
            line,
            egui::Stroke::new(1.5, egui::Color32::from_white_alpha(200)),
        ));
    }
    for (k, path) in paths.iter().enumerate() {
        let Some(at) = path.get(path.len() * 3 / 5).and_then(|&p| on_screen(p)) else {
            continue;
        };
        let galley = painter.layout_no_wrap(
            k.to_string(),
            egui::FontId::proportional(12.0),
            egui::Color32::WHITE,
        );
        let r = 0.5 * galley.size().x.max(galley.size().y) + 2.0;
        painter.circle_filled(at, r, egui::Color32::from_black_alpha(190));
        painter.galley(at - 0.5 * galley.size(), galley, egui::Color32::WHITE);
    }
}

/// The keyboard shortcuts. They act whenever the pointer is over the scene (taking the keys
/// from a text field that had them), and elsewhere unless a text field is being typed in.
pub(super) fn shortcuts(ctx: &egui::Context, app: &mut AppState) {
    let scene: Option<Rect> = ctx.data(|d| d.get_temp(scene_rect_id()));
    let over_scene = match (scene, ctx.input(|i| i.pointer.latest_pos())) {
        (Some(rect), Some(pos)) => on_scene(ctx, app, rect, pos),
        _ => false,
    };
    let typing = ctx.memory(|m| m.focused()).is_some() && ctx.text_edit_focused();
    if typing && !over_scene {
        return;
    }
    let (size, _) = viewport_px(ctx);
    let aspect = size.x / size.y.max(1.0);
    let mut taken = Vec::new();
    ctx.input_mut(|i| {
        // egui-winit sends a key's text right after the key: drop the text of a taken key.
        let mut text_of_taken: Option<char> = None;
        i.events.retain(|e| match e {
            Event::Key {
                key,
                pressed: true,
                modifiers,
                ..
            } if is_shortcut(*key, *modifiers, typing) => {
                taken.push((*key, *modifiers));
                text_of_taken = key_char(*key);
                false
            }
            Event::Text(t) => {
                let drop = text_of_taken.is_some_and(|c| t.to_lowercase() == c.to_string());
                text_of_taken = None;
                !drop
            }
            _ => true,
        });
    });
    if !taken.is_empty() && typing {
        ctx.memory_mut(|m| m.stop_text_input());
    }
    for (key, modifiers) in taken {
        shortcut(app, key, modifiers, aspect);
    }
}

/// The character a key types, for the keys whose text a shortcut swallows.
fn key_char(key: Key) -> Option<char> {
    match key {
        Key::R => Some('r'),
        Key::V => Some('v'),
        Key::F => Some('f'),
        Key::Space => Some(' '),
        Key::Num1 => Some('1'),
        Key::Num2 => Some('2'),
        Key::Num3 => Some('3'),
        Key::Num4 => Some('4'),
        Key::Num5 => Some('5'),
        Key::Num6 => Some('6'),
        Key::Num7 => Some('7'),
        Key::Num8 => Some('8'),
        Key::Num9 => Some('9'),
        _ => None,
    }
}

/// Whether a key is a shortcut. While a text field is being typed in (with the pointer over the
/// scene), the keys that edit text or would load another level stay with the field.
fn is_shortcut(key: Key, m: Modifiers, typing: bool) -> bool {
    if m.command {
        return matches!(key, Key::Z | Key::Y | Key::S);
    }
    let letters = matches!(
        key,
        Key::R | Key::O | Key::C | Key::V | Key::F | Key::Escape
    );
    let scene_keys = matches!(
        key,
        Key::Space
            | Key::Delete
            | Key::Backspace
            | Key::Tab
            | Key::Enter
            | Key::Num1
            | Key::Num2
            | Key::Num3
            | Key::Num4
            | Key::Num5
            | Key::Num6
            | Key::Num7
            | Key::Num8
            | Key::Num9
    );
    letters || (scene_keys && !typing)
}

fn shortcut(app: &mut AppState, key: Key, m: Modifiers, aspect: f32) {
    use crate::app::Tool;
    match key {
        Key::Z if m.command && m.shift => app.redo(),
        Key::Z if m.command => app.undo(),
        Key::Y if m.command => app.redo(),
        Key::S if m.command => {
            let _ = app.save();
        }
        Key::R => app.set_tool(Tool::Road),
        Key::O => app.set_tool(Tool::Roundabout),
        Key::C => app.set_tool(Tool::Crossroads),
        Key::V => app.set_tool(Tool::Select),
        Key::F => app.follow = !app.follow,
        Key::Space => {
            if app.play.is_some() {
                app.toggle_pause();
            } else {
                app.play();
            }
        }
        Key::Escape => app.end_run(),
        Key::Delete | Key::Backspace => app.delete_selected(),
        Key::Tab => app.toggle_camera(aspect),
        Key::Enter => app.finish_road(),
        Key::Num1 => app.load_shipped(1),
        Key::Num2 => app.load_shipped(2),
        Key::Num3 => app.load_shipped(3),
        Key::Num4 => app.load_shipped(4),
        Key::Num5 => app.load_shipped(5),
        Key::Num6 => app.load_shipped(6),
        Key::Num7 => app.load_shipped(7),
        Key::Num8 => app.load_shipped(8),
        Key::Num9 => app.load_shipped(9),
        _ => {}
    }
}

/// "click to add the next point, Enter to finish" beside the road being drawn.
fn draw_hint(painter: &egui::Painter, app: &AppState, size: Vec2, ppp: f32) {
    let Some((at, text)) = app
        .join_hint()
        .or_else(|| app.drawing_hint().map(|(at, t)| (at, t.to_owned())))
    else {
        return;
    };
    let Some(s) = app.camera.to_screen(at, size) else {
        return;
    };
    let pos = Pos2::new(s.x / ppp + 14.0, s.y / ppp - 8.0);
    let galley =
        painter.layout_no_wrap(text, egui::FontId::proportional(14.0), egui::Color32::WHITE);
    let bg = Rect::from_min_size(pos, galley.size()).expand(4.0);
    painter.rect_filled(bg, 4.0, egui::Color32::from_black_alpha(170));
    painter.galley(pos, galley, egui::Color32::WHITE);
    if matches!(app.selection, Selection::Road(_) | Selection::Point(..)) {
        painter.circle_stroke(
            Pos2::new(s.x / ppp, s.y / ppp),
            9.0,
            egui::Stroke::new(2.0, egui::Color32::WHITE),
        );
    }
}

/// A scale bar in metres in the scene's lower left corner: 1, 2 or 5 × 10ⁿ m, about 120 points
/// long, measured on the ground at the middle of the view.
fn draw_scale_bar(painter: &egui::Painter, app: &AppState, rect: Rect, size: Vec2, ppp: f32) {
    let Some(metres) = app.metres_per_pixel(size) else {
        return;
    };
    let per_point = metres * ppp;
    let wanted = 120.0 * per_point;
    let scale = 10f32.powf(wanted.log10().floor());
    let nice = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|k| k * scale)
        .rfind(|&m| m <= wanted)
        .unwrap_or(scale);
    let width = nice / per_point;
    let left = rect.left_bottom() + egui::vec2(16.0, -20.0);
    let right = left + egui::vec2(width, 0.0);
    let stroke = egui::Stroke::new(2.0, egui::Color32::WHITE);
    let shadow = egui::Stroke::new(4.0, egui::Color32::from_black_alpha(150));
    for s in [shadow, stroke] {
        painter.line_segment([left, right], s);
        painter.line_segment([left, left - egui::vec2(0.0, 6.0)], s);
        painter.line_segment([right, right - egui::vec2(0.0, 6.0)], s);
    }
    let label = if nice >= 1000.0 {
        format!("{} km", nice / 1000.0)
    } else {
        format!("{nice} m")
    };
    painter.text(
        left + egui::vec2(0.5 * width, -10.0),
        egui::Align2::CENTER_BOTTOM,
        label,
        egui::FontId::proportional(13.0),
        egui::Color32::WHITE,
    );
}
