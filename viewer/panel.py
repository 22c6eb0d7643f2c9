"""The ImGui panel: generated from the parameter table (:data:`cellgl.texture.params.PARAMS`).

Every parameter gets a widget from its type: a slider per float / int (its ``lo`` / ``hi``; a
logarithmic slider where the range spans decades), a checkbox per bool, a combo per enum, a
colour editor per colour. The combination coefficients are shown as structured editors (the
c_i row and the 4 x 4 c_ij matrix) and the colour ramp as a list of keys with colour pickers;
they are still one widget per table entry. Each widget's rectangle is recorded in
``viewer.widget_rects[name]`` (window pixels: x0, y0, x1, y1) so the tests can aim simulated
mouse drags at it.

A parameter that changes nothing with the current values (:func:`cellgl.texture.params.inactive`:
``minkowski_p`` unless the metric is Minkowski, ``stretch_z`` in 2D, ...) is drawn greyed out and
takes no input; its tooltip says what turns it on. ``viewer.inactive_widgets`` holds this
frame's ``{name: reason}``.
"""

from __future__ import annotations

from imgui_bundle import imgui

from .modes import MODE_LABELS, MODES, PANEL_WIDTH
from cellgl.texture.params import GROUPS, LINEAR, PRODUCTS

__all__ = ["draw_panel", "param_widget"]

_STRUCTURED = set(LINEAR) | set(PRODUCTS)
_GROUP_TITLES = {
    "basis": "Basis", "combination": "Combination", "fractal": "Fractal", "domain": "Domain",
    "noise": "Noise", "mapping": "Mapping (height, bump)", "color": "Colour",
    "material": "Material (roughness, ao, metallic channels)",
}


def _record(viewer, name: str) -> None:
    a, b = imgui.get_item_rect_min(), imgui.get_item_rect_max()
    viewer.widget_rects[name] = (a.x, a.y, b.x, b.y)
    if viewer.scroll_to == name:  # bring a widget into view (tests, keyboard users)
        imgui.set_scroll_here_y(0.5)
        viewer.scroll_to = None


def _is_log(p) -> bool:
    return p.type == "float" and p.lo is not None and p.lo > 0 and p.hi / p.lo >= 100


def _inactive(viewer, name: str) -> str | None:
    return getattr(viewer, "inactive_widgets", {}).get(name)


def _tooltip(p, why: str | None, text: str) -> None:
    """The hovered widget's tooltip (also over a greyed-out one): ``why`` first, if inactive."""
    if imgui.is_item_hovered(imgui.HoveredFlags_.allow_when_disabled.value) and text:
        imgui.set_tooltip(f"inactive: {why}\n{text}" if why else text)


def param_widget(viewer, p, label: str | None = None, width: float | None = None) -> bool:
    """One widget for table entry ``p``; returns True if the value changed this frame."""
    model = viewer.model
    value = model.get(p.name)
    label = label if label is not None else p.name
    wid = f"{label}##{p.name}"
    if width is not None:
        imgui.set_next_item_width(width)
    why = _inactive(viewer, p.name)
    if why:
        imgui.begin_disabled()
    try:
        changed, new = _widget(p, wid, value)
    finally:
        if why:
            imgui.end_disabled()
    if changed is None:
        return False
    _record(viewer, p.name)
    _tooltip(p, why, f"{p.name}: {p.doc}\n{p.range_text()}"
             + ("\n(compile-time: recompiles the shader)" if p.compile_time else "") if p.doc else "")
    if changed and not why:
        try:
            model.set(p.name, new)
        except ValueError as exc:
            viewer.status = str(exc)
            return False
        return True
    return False


def _widget(p, wid: str, value):
    """The ImGui widget of one table entry: (changed, new value); (None, None) for none."""
    changed, new = False, value
    if p.type == "float":
        lo, hi = float(p.lo), float(p.hi)
        if hi - lo > 1000 and not _is_log(p):
            changed, new = imgui.drag_float(wid, float(value), max(1e-3, abs(float(value)) * 0.01 + 0.01),
                                            lo, hi, "%.4g")
        else:
            flags = imgui.SliderFlags_.logarithmic.value if _is_log(p) else 0
            changed, new = imgui.slider_float(wid, float(value), lo, hi, "%.4g", flags)
    elif p.type == "int":
        lo, hi = int(p.lo), int(p.hi)
        if hi - lo > 100000:
            changed, new = imgui.input_int(wid, int(value))
            new = max(lo, min(hi, new))
        else:
            changed, new = imgui.slider_int(wid, int(value), lo, hi)
    elif p.type == "bool":
        changed, new = imgui.checkbox(wid, bool(value))
    elif p.type == "enum":
        choices = list(p.choices)
        idx = choices.index(value) if value in choices else 0
        changed, idx = imgui.combo(wid, idx, choices)
        new = choices[idx]
    elif p.type == "color":
        changed, new = imgui.color_edit3(wid, list(value))
        new = tuple(float(v) for v in new)
    else:  # pragma: no cover - the table's types are closed
        imgui.text(f"{p.name}: {value!r}")
        return None, None
    return changed, new


def _coefficients(viewer) -> None:
    by_name = {p.name: p for p in viewer.model.params}
    imgui.text("c_i (value += c_i F_i)")
    w = (imgui.get_content_region_avail().x - 3 * imgui.get_style().item_spacing.x) / 4
    for i, name in enumerate(LINEAR):
        if i % 4:
            imgui.same_line()
        _drag_coef(viewer, by_name[name], f"##{name}", w, f"{name} %.3g")
    imgui.text("c_ij (value += c_ij F_i F_j)")
    for i in range(4):
        for j in range(4):
            if j:
                imgui.same_line()
            name = PRODUCTS[i * 4 + j]
            _drag_coef(viewer, by_name[name], f"##{name}", w, f"{name} %.3g")
    for p in viewer.model.params:       # c_noise, the cell features, smoothness, the range
        if p.group == "combination" and p.name not in _STRUCTURED:
            param_widget(viewer, p)
    if hasattr(viewer.model, "measure_range") and imgui.button("measure range"):
        viewer.model.measure_range()


def _drag_coef(viewer, p, wid, width, fmt) -> None:
    imgui.set_next_item_width(width)
    why = _inactive(viewer, p.name)
    if why:
        imgui.begin_disabled()
    changed, new = imgui.drag_float(wid, float(viewer.model.get(p.name)), 0.01, float(p.lo), float(p.hi), fmt)
    if why:
        imgui.end_disabled()
    _record(viewer, p.name)
    _tooltip(p, why, p.doc)
    if changed and not why:
        viewer.model.set(p.name, new)


def _ramp(viewer) -> None:
    model = viewer.model
    keys = [list(k) for k in model.ramp]
    changed = False
    remove = None
    for k, key in enumerate(keys):
        imgui.push_id(k)
        imgui.set_next_item_width(70)
        c1, t = imgui.drag_float("##t", key[0], 0.005, 0.0, 1.0, "t %.3f")
        imgui.same_line()
        c2, rgb = imgui.color_edit3("##rgb", key[1:4], imgui.ColorEditFlags_.no_inputs.value)
        imgui.same_line()
        if len(keys) > 1 and imgui.small_button("x"):
            remove = k
        imgui.pop_id()
        if c1 or c2:
            keys[k] = [t, *rgb]
            changed = True
    if remove is not None:
        keys.pop(remove)
        changed = True
    if len(keys) < getattr(model, "max_ramp_keys", 16) and imgui.small_button("+ key"):
        a, b = keys[-2] if len(keys) > 1 else keys[-1], keys[-1]
        keys.append([min(1.0, (a[0] + b[0]) / 2 + 0.5 * (1 - b[0])), *b[1:4]])
        changed = True
    if changed:
        model.set_ramp(keys)


def _group(viewer, group: str) -> None:
    params = [p for p in viewer.model.params if p.group == group]
    if not params:
        return
    flags = imgui.TreeNodeFlags_.default_open.value if group in ("basis", "combination", "fractal", "pattern", "points", "weights") else 0
    if not imgui.collapsing_header(_GROUP_TITLES.get(group, group), flags):
        return
    if group == "combination" and not viewer.model.is_pups:
        _coefficients(viewer)
        return
    for p in params:
        param_widget(viewer, p)
    if group == "color" and hasattr(viewer.model, "ramp") and not viewer.model.is_pups:
        imgui.separator_text("ramp")
        _ramp(viewer)


def _view_section(viewer) -> None:
    for i, m in enumerate(MODES):
        if i % 2:
            imgui.same_line(170)
        if imgui.radio_button(MODE_LABELS[m], viewer.mode == m):
            viewer.set_mode(m)
        _record(viewer, f"mode:{m}")
    if viewer.mode == "3d":
        from .meshes import SHAPES

        names = list(SHAPES)
        changed, idx = imgui.combo("object", names.index(viewer.shape), names)
        if changed:
            viewer.shape = names[idx]
        _, viewer.bump_view = imgui.slider_float("bump (view)", viewer.bump_view, 0.0, 4.0)
        imgui.text_disabled("drag: orbit   wheel: distance")
    elif viewer.mode == "tiled":
        _, viewer.tile_borders = imgui.checkbox("show tile borders", viewer.tile_borders)
    if viewer.mode != "3d":
        from cellgl.texture.recipe import CHANNELS

        chans = list(CHANNELS)
        imgui.set_next_item_width(120)
        changed, idx = imgui.combo("channel", chans.index(viewer.channel), chans)
        if changed:
            viewer.channel = chans[idx]
    if viewer.mode in ("2d", "anim"):
        if imgui.button("fit"):
            viewer.panzoom.fitted = False
        imgui.same_line()
        imgui.text_disabled("drag: pan   wheel: zoom")
    if viewer.mode == "anim":
        if imgui.button("pause" if viewer.playing else "play"):
            viewer.playing = not viewer.playing
        _record(viewer, "play")
        imgui.same_line()
        imgui.set_next_item_width(150)
        _, viewer.speed = imgui.slider_float("speed", viewer.speed, 0.0, 4.0, "%.2f cells/s")


def _readouts(viewer) -> None:
    imgui.text(f"frame {viewer.frame_ms:5.1f} ms   render {viewer.render_ms:6.1f} ms  "
               f"(1/{viewer.renderer.last_scale})")
    r = viewer.readout
    if not r:
        imgui.text_disabled("F1..F4, ID: hover the view")
    elif "error" in r:
        imgui.text_colored(imgui.ImVec4(1, 0.4, 0.3, 1), r["error"][:80])
    else:
        F = r.get("F", [])
        imgui.text("  ".join(f"F{i + 1} {v:.4f}" for i, v in enumerate(F[:4])))
        imgui.text(f"ID {r.get('id', '?')}   at {', '.join(f'{v:.3f}' for v in r.get('pos', ()))}")


def _actions(viewer) -> None:
    from . import actions

    actions.draw(viewer)


def draw_panel(viewer) -> None:
    """The whole panel, docked to the left edge."""
    w, h = viewer.size
    imgui.set_next_window_pos(imgui.ImVec2(0, 0))
    imgui.set_next_window_size(imgui.ImVec2(min(PANEL_WIDTH, w - 64), h))
    flags = (imgui.WindowFlags_.no_move.value | imgui.WindowFlags_.no_resize.value
             | imgui.WindowFlags_.no_collapse.value | imgui.WindowFlags_.no_title_bar.value)
    imgui.begin("cellgl", None, flags)
    imgui.push_item_width(-110)
    viewer.inactive_widgets = viewer.model.inactive()
    _preset_picker(viewer)
    _view_section(viewer)
    _readouts(viewer)
    _actions(viewer)
    if viewer.status:
        imgui.text_wrapped(viewer.status)
    imgui.separator()
    groups = GROUPS
    if viewer.model.is_pups:
        groups = tuple(dict.fromkeys(p.group for p in viewer.model.params))
        imgui.text_wrapped("PUPs recipe: 2D texture (3D object and 4D animation views are not "
                           "available); channels color, height")
    for g in groups:
        _group(viewer, g)
    imgui.pop_item_width()
    imgui.end()


def _preset_picker(viewer) -> None:
    presets = viewer.model.presets()
    name = viewer.model.name
    if presets:
        idx = presets.index(name) if name in presets else -1
        imgui.set_next_item_width(-1)
        if imgui.begin_combo("##preset", name if idx < 0 else presets[idx]):
            for i, pname in enumerate(presets):
                if imgui.selectable(pname, i == idx)[0]:
                    viewer.load(pname)
            imgui.end_combo()
        _record(viewer, "preset")
    else:
        imgui.text(name)
