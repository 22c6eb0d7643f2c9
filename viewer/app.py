"""The viewer window: GLFW + moderngl + Dear ImGui (imgui-bundle).

One :class:`Viewer` owns a GLFW window, a moderngl context made current on it, the ImGui
context and its GLFW/OpenGL3 backends, and the renderers of :mod:`cellgl.viewer.render`. A frame:

1. poll GLFW, start an ImGui frame (scripted mouse events, if any, are fed to ImGui's IO here:
   the tests drag sliders through exactly the path real mouse input takes);
2. the panel (:mod:`cellgl.viewer.panel`) edits the :class:`cellgl.viewer.model.Model`;
3. view input (pan / zoom / orbit) from ImGui's IO when the mouse is not over the panel;
4. the view is rendered into an offscreen framebuffer only when something it depends on
   changed, at reduced resolution while a slider or the view is being dragged (refined once
   input stops); the ImGui draw data goes on top; the frame is copied to the window.

Screenshots read that offscreen framebuffer, so a hidden window (``--screenshot``) gives the
same pixels as a visible one.
"""

from __future__ import annotations

import ctypes
import time
from dataclasses import dataclass, field

import numpy as np

# imgui_bundle first: it points the glfw package at its own GLFW library, so the Python glfw
# calls and ImGui's C++ GLFW backend share one GLFW (one window list, one set of callbacks).
import imgui_bundle  # noqa: F401  (import order matters)
from imgui_bundle import imgui

import glfw  # noqa: E402

from cellgl.gl import context, shadercache, versions

from . import camera, render
from .model import Model
from .modes import MODE_LABELS, MODES, PANEL_WIDTH, PUPS_REFUSED_MODES

__all__ = ["Viewer", "ViewerOptions", "MODES"]

#: Core profile versions asked of GLFW, newest first: cellgl's one ladder (cellgl.gl.versions:
#: 4.6 ... 3.3; some drivers give exactly the version asked, macOS 4.1).
WINDOW_VERSIONS = tuple(versions.major_minor(code) for code in versions.LADDER)


@dataclass
class ViewerOptions:
    recipe: str | None = None
    mode: str = "2d"
    shape: str = "sphere"
    size: tuple[int, int] = (1280, 800)
    sets: list = field(default_factory=list)
    panel: bool = True
    time: float | None = None
    hidden: bool = False
    vsync: bool = True


class Viewer:
    """The interactive viewer. ``Viewer(opts).run()``, or drive it frame by frame (tests)."""

    def __init__(self, opts: ViewerOptions | None = None):
        self.opts = opts = opts or ViewerOptions()
        if opts.mode not in MODES:
            raise ValueError(f"unknown view mode {opts.mode!r}; expected one of: {', '.join(MODES)}")
        self.model = Model.load(opts.recipe)
        for name, value in opts.sets:
            self.model.set_text(name, value)
        self._init_window(*opts.size, hidden=opts.hidden, vsync=opts.vsync)
        self._init_imgui()
        self.renderer = render.Renderer(self.ctx, self.model, self._take_context)
        self.mode = opts.mode
        self.shape = opts.shape
        self.panel_visible = opts.panel
        self.panzoom = camera.PanZoom()
        self.orbit = camera.Orbit()
        self.playing = opts.mode == "anim" and opts.time is None
        self.speed = 0.5  # cells per second
        if opts.time is not None:
            self.model.set("time", float(opts.time))
        if self.mode == "anim":
            self._ensure_4d()
        self.tile_borders = False
        self.bump_view = 1.0
        self.channel = "color"   # 2D / tiled / anim: which channel of the texture to show
        self.status = ""
        if self.model.is_pups and self.mode in PUPS_REFUSED_MODES:
            self.status = (f"{MODE_LABELS[self.mode]}: not available for PUPs recipes; "
                           "showing the 2D texture")
            self.mode = "2d"
        self.frame_ms = 0.0
        self.render_ms = 0.0
        self.readout: dict | None = None
        self.widget_rects: dict[str, tuple[float, float, float, float]] = {}
        self.scroll_to: str | None = None   # panel widget to scroll into view next frame
        self._script: list = []
        self._view_drag = False
        self._last_time = time.perf_counter()
        self._should_close = False

    # ----------------------------------------------------------------------------------------
    # setup / teardown

    def _init_window(self, w: int, h: int, hidden: bool, vsync: bool) -> None:
        # GLFW reports why init or window creation failed through its error callback (pyGLFW's
        # default prints a GLFWError warning): collect the messages into the one clear error.
        errors: list[str] = []
        glfw.set_error_callback(lambda code, text: errors.append(
            text.decode(errors="replace") if isinstance(text, bytes) else str(text)))
        try:
            api = self._open_window(w, h, hidden, errors)
        finally:
            # back to pyGLFW's default reporting: its code takes None for that, its stub omits it
            glfw.set_error_callback(None)  # type: ignore[arg-type]
        self._take_context()
        glfw.swap_interval(1 if vsync and not hidden else 0)
        self.ctx = context.attach_current(context.REQUIRED_GL, api)
        self.hidden = hidden

    def _open_window(self, w: int, h: int, hidden: bool, errors: list) -> str:
        """Open the window with a core forward-compatible context: the newest of
        :data:`WINDOW_VERSIONS` the system gives (macOS: 4.1), on the context API that can share
        the process with cellgl's headless context (:func:`cellgl.gl.context.window_api`: EGL on
        Linux beside an EGL headless context, the platform's own API elsewhere). Returns the
        API used ("egl" or "native")."""
        def why() -> str:
            return f" ({'; '.join(dict.fromkeys(errors))})" if errors else ""

        if not glfw.init():
            raise RuntimeError(f"GLFW could not initialise{why()}: no display? run under xvfb-run, or "
                               "use `cellgl bake` for headless output")
        apis = [context.window_api()]
        if apis[0] == "egl":
            apis.append("native")   # no libEGL: then the headless context is not EGL either
        for api in apis:
            for major, minor in WINDOW_VERSIONS:
                glfw.default_window_hints()
                glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, major)
                glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, minor)
                glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
                glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
                glfw.window_hint(glfw.VISIBLE, not hidden)
                glfw.window_hint(glfw.SCALE_TO_MONITOR, False)
                # One framebuffer pixel per window point on macOS too: the view, the panel and
                # the readout share ImGui's mouse coordinates (points) with the framebuffer.
                glfw.window_hint(glfw.COCOA_RETINA_FRAMEBUFFER, False)
                glfw.window_hint(glfw.CONTEXT_CREATION_API, glfw.EGL_CONTEXT_API if api == "egl"
                                 else glfw.NATIVE_CONTEXT_API)
                shadercache.prepare_environment()   # before a driver loads (docs/performance.md)
                self.window = glfw.create_window(w, h, f"cellgl view: {self.model.name}", None, None)
                if self.window:
                    return api
        glfw.terminate()
        raise RuntimeError(f"GLFW could not create an OpenGL 3.3 (or later) core window{why()}; "
                           "the viewer needs OpenGL 3.3 core (`cellgl info` shows what this "
                           "machine has)")

    def _take_context(self) -> None:
        """Make the window's GL context current (cellgl's headless one may be)."""
        glfw.make_context_current(self.window)

    def _init_imgui(self) -> None:
        self.imgui_ctx = imgui.create_context()
        io = imgui.get_io()
        io.set_ini_filename("")  # no imgui.ini next to the user's files
        io.config_flags |= imgui.ConfigFlags_.nav_enable_keyboard.value
        imgui.style_colors_dark()
        addr = ctypes.cast(self.window, ctypes.c_void_p).value
        assert addr is not None, "the window is open (_open_window returns only with one)"
        imgui.backends.glfw_init_for_opengl(addr, True)
        imgui.backends.opengl3_init("#version 330")

    def close(self) -> None:
        if getattr(self, "window", None) is None:
            return
        self._take_context()
        self.renderer.release()
        imgui.backends.opengl3_shutdown()
        imgui.backends.glfw_shutdown()
        imgui.destroy_context(self.imgui_ctx)
        self.ctx.release()
        glfw.destroy_window(self.window)
        del self.window      # no window now: close() again finds none (the getattr above)
        glfw.terminate()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ----------------------------------------------------------------------------------------
    # geometry

    @property
    def size(self) -> tuple[int, int]:
        """Framebuffer size (pixels)."""
        return glfw.get_framebuffer_size(self.window)

    @property
    def view_rect(self) -> tuple[int, int, int, int]:
        """(x, y, w, h) of the view area in window pixels, top-left origin."""
        w, h = self.size
        px = PANEL_WIDTH if self.panel_visible else 0
        px = min(px, w - 64)
        return px, 0, w - px, h

    def unit_square_rect(self) -> tuple[int, int, int, int]:
        """(x, y, w, h), window pixels from the top left, of texture [0, 1]^2 in the 2D view."""
        vx, vy, vw, vh = self.view_rect
        u = self.panzoom.unit(vw, vh)
        ox, oy = self.panzoom.origin
        return int(round(vx + ox)), int(round(vy + oy)), int(round(u)), int(round(u))

    # ----------------------------------------------------------------------------------------
    # frames

    def run(self) -> None:
        """Interactive loop until the window is closed (Esc or the close button)."""
        while not glfw.window_should_close(self.window) and not self._should_close:
            self.frame()
            if not self._busy():
                glfw.wait_events_timeout(0.05)

    def _busy(self) -> bool:
        return self.playing or self.renderer.needs_refine or bool(self._script)

    def script_mouse(self, events) -> None:
        """Queue mouse input for the next frames: one ``(x, y, down)`` per frame, window pixels.

        Each is fed to ImGui's IO (``add_mouse_pos_event``, ``add_mouse_button_event``) after
        the GLFW backend's own events, so it is what ImGui sees in that frame.
        """
        self._script.extend(events)

    def frame(self) -> None:
        """Run one frame."""
        t0 = time.perf_counter()
        dt = max(1e-4, t0 - self._last_time)
        self._last_time = t0
        self._take_context()
        glfw.poll_events()
        imgui.backends.opengl3_new_frame()
        imgui.backends.glfw_new_frame()
        io = imgui.get_io()
        if self._script:
            x, y, down = self._script.pop(0)
            io.add_mouse_pos_event(float(x), float(y))
            io.add_mouse_button_event(0, bool(down))
        imgui.new_frame()

        if self.mode == "anim" and self.playing:
            # A hidden window (capture) steps a fixed 1/30 s per frame: reproducible screenshots.
            step = 1.0 / 30.0 if self.hidden else min(dt, 0.1)
            if self.model.loops:
                # Orbiting points: one loop every 1 / (speed / 4) s, the phase kept in [0, 1).
                self.model.set("orbit_phase", round((self.model.get("orbit_phase") + 0.25 * self.speed * step) % 1.0, 9))
            else:
                self.model.set("time", round(self.model.get("time") + self.speed * step, 9))

        if self.panel_visible:
            from .panel import draw_panel

            draw_panel(self)
        self._view_input(io)
        imgui.render()
        # Readouts, bake and export use cellgl's headless context, which may have been made
        # current on this thread: take the window's context back before drawing.
        self._take_context()

        w, h = self.size
        vx, vy, vw, vh = self.view_rect
        if not self.panzoom.fitted:
            self.panzoom.fit(vw, vh)
        interacting = imgui.is_any_item_active() or self._view_drag or (self.mode == "anim" and self.playing)
        self.renderer.draw(self, (vx, h - vy - vh, vw, vh), (w, h), interacting)
        frame_fbo = self.renderer.frame_fbo
        assert frame_fbo is not None, "Renderer.draw made the frame's framebuffer (_frame)"
        frame_fbo.use()
        imgui.backends.opengl3_render_draw_data(imgui.get_draw_data())
        # the finished frame to the window's own framebuffer (window code: the window's screen)
        self.ctx.copy_framebuffer(self.ctx.screen, frame_fbo)
        glfw.swap_buffers(self.window)
        if glfw.window_should_close(self.window):
            self._should_close = True
        self.frame_ms = 1000.0 * (time.perf_counter() - t0)

    # ----------------------------------------------------------------------------------------
    # view input (through ImGui's IO, so scripted and real input behave the same)

    def _view_input(self, io) -> None:
        vx, vy, vw, vh = self.view_rect
        mx, my = io.mouse_pos.x, io.mouse_pos.y
        inside = vx <= mx < vx + vw and vy <= my < vy + vh
        over_ui = io.want_capture_mouse
        if imgui.is_mouse_clicked(0) and inside and not over_ui:
            self._view_drag = True
        if not io.mouse_down[0]:
            self._view_drag = False
        if self._view_drag:
            dx, dy = io.mouse_delta.x, io.mouse_delta.y
            if dx or dy:
                if self.mode == "3d":
                    self.orbit.rotate(dx, -dy)
                elif self.mode != "tiled":  # the tiled view always shows whole tiles
                    self.panzoom.pan(dx, dy)
        if inside and not over_ui and io.mouse_wheel:
            if self.mode == "3d":
                self.orbit.dolly(io.mouse_wheel)
            elif self.mode != "tiled":
                self.panzoom.zoom_at(1.15 ** io.mouse_wheel, mx - vx, my - vy)
        if not over_ui and imgui.is_key_pressed(imgui.Key.escape):
            self._should_close = True
        self._update_readout(mx, my, inside and not over_ui)

    def _update_readout(self, mx: float, my: float, inside: bool) -> None:
        if not inside:
            self.readout = None
            return
        vx, vy, vw, vh = self.view_rect
        # The centre of the pixel under the cursor (ImGui floors mouse positions), from the
        # view's top left, y down: the readout is for the pixel the user sees.
        x, y = np.floor(mx - vx) + 0.5, np.floor(my - vy) + 0.5
        if self.mode == "3d":
            pos = self.renderer.object_position_at(int(x), int(vh - 1 - y))
            if pos is None:
                self.readout = None
                return
            key = ("3d", tuple(np.round(pos, 6)), self.model.version)
        elif self.mode == "tiled":
            side = min(vw, vh) / 3.0  # tiles start at the view's top-left corner
            key = ("uv", ((x / side) % 1.0, (y / side) % 1.0), self.model.version)
        else:
            key = ("uv", self.panzoom.to_uv(x, y, vw, vh), self.model.version)
        if self.readout is not None and self.readout.get("_key") == key:
            return
        try:
            if key[0] == "3d":
                out = self.model.readout_object(key[1])
            else:
                out = self.model.readout_uv(*key[1])
        except Exception as exc:  # never let a readout kill the frame
            out = {"error": str(exc)}
        out["_key"] = key
        self.readout = out

    # ----------------------------------------------------------------------------------------
    # actions

    def set_mode(self, mode: str) -> None:
        if mode not in MODES:
            raise ValueError(f"unknown view mode {mode!r}; expected one of: {', '.join(MODES)}")
        if self.model.is_pups and mode in PUPS_REFUSED_MODES:
            self.status = (f"{MODE_LABELS[mode]}: not available for PUPs recipes (2D textures "
                           "on a periodic point set); use 2D texture or 3x3 tiled")
            return
        self.mode = mode
        if mode == "anim":
            self._ensure_4d()

    def load(self, name_or_path: str) -> None:
        """Replace the recipe (preset picker)."""
        self.model.load_into(name_or_path)
        if self.model.is_pups and self.mode in PUPS_REFUSED_MODES:
            self.status = (f"{MODE_LABELS[self.mode]}: not available for PUPs recipes; "
                           "showing the 2D texture")
            self.mode = "2d"
        if self.mode == "anim":
            self._ensure_4d()
        glfw.set_window_title(self.window, f"cellgl view: {self.model.name}")

    def _ensure_4d(self) -> None:
        if self.model.loops:
            self.status = "animation: the feature points orbit (orbit_phase loops)"
        elif int(self.model.get("dimension")) < 4:
            self.model.set("dimension", 4)
            self.status = "4D animation: dimension set to 4 (time is the 4th coordinate)"

    def grab(self) -> np.ndarray:
        """The last frame as uint8 (H, W, 3), top row first."""
        self._take_context()        # a cellgl call since the frame may have taken it
        return self.renderer.grab()

    def screenshot(self, path: str) -> str:
        """Save the last frame to ``path`` (its extension picks the format), whole or not at all.
        The folder must exist, as for every command's output (ValueError naming it otherwise: the
        panel's button shows it as its status line)."""
        from PIL import Image

        from cellgl.io.formats import atomic_path
        from cellgl.io.tempfiles import check_output

        check_output(path)
        with atomic_path(path) as tmp:
            Image.fromarray(self.grab()).save(tmp)
        self.status = f"saved screenshot {path}"
        return path

    def capture(self, path: str, frames: int = 3) -> str:
        """Render ``frames`` frames at full resolution and save the window to ``path`` (PNG)."""
        for _ in range(max(1, frames)):
            self.frame()
        while self.renderer.needs_refine:
            self.frame()
        return self.screenshot(path)

    def request_close(self) -> None:
        self._should_close = True
