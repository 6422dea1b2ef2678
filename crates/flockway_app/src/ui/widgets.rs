//! Small form widgets the inspector and the level panel share. Each shows a value of the level
//! and says whether the user changed it; the caller turns a change into an editor command.

use std::ops::RangeInclusive;

/// A labelled row of a two-column form grid.
/// The closure gets the label's id, to name the widget after it (`by` in the helpers below), as
/// screen readers and the UI tests find widgets by their names.
pub(super) fn row<R>(
    ui: &mut egui::Ui,
    label: &str,
    add: impl FnOnce(&mut egui::Ui, egui::Id) -> R,
) -> R {
    let name = ui.label(label).id;
    let r = add(ui, name);
    ui.end_row();
    r
}

/// A one-line text field whose text is committed when it loses focus (Enter, Tab, a click
/// elsewhere). Returns the new text when it differs from `current`. What is typed is kept
/// between frames while the field has focus, since the level only changes on commit.
pub(super) fn text(
    ui: &mut egui::Ui,
    by: egui::Id,
    salt: impl egui::AsIdSalt,
    current: &str,
) -> Option<String> {
    text_sized(ui, by, salt, current, f32::INFINITY)
}

/// [`text`] of a given width, points (for fields that share a grid row with others).
pub(super) fn text_sized(
    ui: &mut egui::Ui,
    by: egui::Id,
    salt: impl egui::AsIdSalt,
    current: &str,
    width: f32,
) -> Option<String> {
    let id = ui.make_persistent_id(salt);
    let draft_id = id.with("draft");
    let mut text: String = ui
        .data(|d| d.get_temp(draft_id))
        .unwrap_or_else(|| current.to_owned());
    let edit = egui::TextEdit::singleline(&mut text).id(id);
    // A grid cell offers only last frame's column width: a sized field keeps its width.
    let r = if width.is_finite() {
        ui.add(edit.desired_width(width).min_size(egui::vec2(width, 0.0)))
    } else {
        ui.add(edit.desired_width(f32::INFINITY))
    }
    .labelled_by(by);
    if r.lost_focus() || !r.has_focus() {
        ui.data_mut(|d| d.remove::<String>(draft_id));
        return (r.lost_focus() && text != current).then_some(text);
    }
    ui.data_mut(|d| d.insert_temp(draft_id, text));
    None
}

/// A number dragged or typed, within `range`, with a unit after it. True when it changed.
pub(super) fn number(
    ui: &mut egui::Ui,
    by: egui::Id,
    value: &mut f64,
    range: RangeInclusive<f64>,
    speed: f64,
    unit: &str,
) -> bool {
    ui.add(
        egui::DragValue::new(value)
            .range(range)
            .speed(speed)
            .max_decimals(3)
            .suffix(unit),
    )
    .labelled_by(by)
    .changed()
}

/// A weight dragged or typed (0 to 1000), and the share of `total` it is, in per cent. True
/// when it changed.
pub(super) fn weight(ui: &mut egui::Ui, by: egui::Id, value: &mut f64, total: f64) -> bool {
    let changed = number(ui, by, value, 0.0..=1000.0, 0.01, "");
    let pct = if total > 0.0 {
        100.0 * value.max(0.0) / total
    } else {
        0.0
    };
    ui.weak(format!("{pct:.0} %"));
    changed
}

/// A whole number dragged or typed, within `range`. True when it changed.
pub(super) fn count(
    ui: &mut egui::Ui,
    by: egui::Id,
    value: &mut u32,
    range: RangeInclusive<u32>,
) -> bool {
    ui.add(egui::DragValue::new(value).range(range).speed(0.1))
        .labelled_by(by)
        .changed()
}

/// A choice among `options` (shown as they are). True when another one was chosen.
pub(super) fn choice(
    ui: &mut egui::Ui,
    by: egui::Id,
    salt: impl egui::AsIdSalt,
    value: &mut String,
    options: &[String],
) -> bool {
    let before = value.clone();
    egui::ComboBox::from_id_salt(ui.make_persistent_id(salt))
        .selected_text(value.as_str())
        .width(ui.available_width().clamp(80.0, 200.0))
        .show_ui(ui, |ui| {
            for o in options {
                ui.selectable_value(value, o.clone(), o);
            }
        })
        .response
        .labelled_by(by);
    *value != before
}

/// A lane of a road with `lanes` lanes; lane 0 is named the rightmost. True when it changed.
pub(super) fn lane(
    ui: &mut egui::Ui,
    by: egui::Id,
    salt: impl egui::AsIdSalt,
    value: &mut u32,
    lanes: u32,
) -> bool {
    let before = *value;
    let name = |k: u32| match (k, lanes) {
        (0, 1) => "0 (the only lane)".to_owned(),
        (0, _) => "0 (rightmost)".to_owned(),
        (k, n) if k + 1 == n => format!("{k} (leftmost)"),
        (k, _) => k.to_string(),
    };
    egui::ComboBox::from_id_salt(ui.make_persistent_id(salt))
        .selected_text(name(*value))
        .show_ui(ui, |ui| {
            for k in 0..lanes.max(1) {
                ui.selectable_value(value, k, name(k));
            }
        })
        .response
        .labelled_by(by);
    *value != before
}

/// An error or a warning under a field, in red and wrapped.
pub(super) fn error(ui: &mut egui::Ui, text: &str) {
    ui.add(egui::Label::new(egui::RichText::new(text).color(ui.visuals().error_fg_color)).wrap());
}
