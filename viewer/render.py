"""GL side of the viewer: offscreen targets, the view renderers, the copy to the window.

The view (2D texture, 3D object, 3x3 tiles, animation) is rendered into its own texture only
when what it shows changes (a key of the recipe version, view state and size), then copied to
the frame. While the user drags a slider or the view, it is rendered at 1/2 or 1/4 resolution
(chosen from the measured cost of the last full-resolution render) and upscaled; once input
stops the next frame renders at full resolution ("refine").

Every target, texture and draw goes through the window context's runner
(:meth:`cellgl.gl.runner.Runner.draw`), whose program cache keys programs by their ``#define``s: a
shader is compiled only when a compile-time parameter changes.
"""

from __future__ import annotations

import time

import numpy as np

from cellgl.gl import runner

from . import meshes

__all__ = ["Renderer"]

#: target frame time while interacting (seconds); the preview scale is chosen to meet it
INTERACTIVE_BUDGET = 0.05

SCALES = (1, 2, 4)


def _mat(m: np.ndarray) -> np.ndarray:
    """A float64 4x4 (column vectors) as the column-major float32 GLSL expects (rows of m.T)."""
    return np.ascontiguousarray(m.T, dtype=np.float32)


class Renderer:
    def __init__(self, ctx, model, take_context=lambda: None):
        self.ctx = ctx
        self.model = model
        #: the window context's runner: every target, texture and draw of the viewer is its
        self.runner = runner.runner(ctx)
        # Makes the window's context current again after a cellgl API call (which makes
        # cellgl's headless context current).
        self.take_context = take_context
        self.frame_fbo = None
        self._frame_size = None
        self._targets: dict[str, runner.Target] = {}
        self._key = None
        self._scale = 1
        self.needs_refine = False
        self.full_cost = None   # seconds per megapixel of the last full-resolution render
        self.compiles = 0       # programs built (a new set of #defines)
        self._programs_seen: set[int] = set()
        self.last_scale = 1
        self.renders = 0
        self.budget = None      # seconds per interactive frame (None: INTERACTIVE_BUDGET)
        self.render_ms = 0.0
        self._pups_key = None
        self._pups_src = None

    def release(self) -> None:
        for key in ("frame", "view", "tile", "object", "pups_src", "mesh"):
            self.runner.release("viewer." + key)
        self._targets.clear()
        self.frame_fbo = None

    # ----------------------------------------------------------------------------------------
    # targets

    def _frame(self, size) -> None:
        if self._frame_size != size:
            self.frame_fbo = self.runner.target("viewer.frame", size, (("f1", 4),), depth=True).fbo
            self._frame_size = size

    def grab(self) -> np.ndarray:
        """The last frame as uint8 (H, W, 3), top row first."""
        t = self.runner.target("viewer.frame", self._frame_size, (("f1", 4),), depth=True)
        w, h = t.size
        return self.runner.read(t, np.empty((h, w, 3), np.uint8))[::-1].copy()

    def _target(self, name: str, size, position: bool = False) -> runner.Target:
        """A colour texture + framebuffer (+ a float position texture and depth for the 3D view)."""
        t = self.runner.target("viewer." + name, size, (("f1", 4),) + ((("f4", 4),) if position else ()),
                               depth=position)
        self._targets[name] = t
        return t

    def _note_program(self, prog) -> None:
        if prog.glo not in self._programs_seen:
            self._programs_seen.add(prog.glo)
            self.compiles += 1

    # ----------------------------------------------------------------------------------------
    # drawing

    def _choose_scale(self, interacting: bool, w: int, h: int) -> int:
        if not interacting or self.full_cost is None:
            return 1
        mp = w * h / 1e6
        budget = INTERACTIVE_BUDGET if self.budget is None else self.budget
        for s in SCALES:
            if self.full_cost * mp / (s * s) <= budget:
                return s
        return SCALES[-1]

    def draw(self, viewer, viewport, window_size, interacting: bool) -> bool:
        """Render the view (if needed) and copy it into ``viewport`` (x, y, w, h; GL, y up).
        True when the view was rendered anew (not only copied)."""
        self._frame(window_size)
        vx, vy, vw, vh = viewport
        mode = viewer.mode
        scale = self._choose_scale(interacting, vw, vh)
        # what the view shows: the mode's own state is appended to the common part
        key: tuple = (mode, self.model.version, vw, vh, scale)
        if mode == "3d":
            o = viewer.orbit
            key += (viewer.shape, o.yaw, o.pitch, o.distance, viewer.bump_view)
        elif mode == "tiled":
            key += ()
        else:
            key += (viewer.panzoom.origin, viewer.panzoom.zoom)
        if mode != "3d":
            key += (viewer.channel,)
        rendered = False
        if key != self._key:
            t0 = time.perf_counter()
            self._render_view(viewer, mode, vw // scale if scale > 1 else vw,
                              vh // scale if scale > 1 else vh, vw, vh)
            self.runner.finish()
            dt = time.perf_counter() - t0
            if scale == 1:
                self.full_cost = dt / max(1e-6, vw * vh / 1e6)
            self._key = key
            self.last_scale = scale
            self.render_ms = 1000.0 * dt
            viewer.render_ms = self.render_ms
            self.renders += 1
            rendered = True
        self.needs_refine = self.last_scale > 1 and not interacting
        self._compose(viewer, mode, viewport, window_size)
        return rendered

    def _render_view(self, viewer, mode, w, h, full_w, full_h) -> None:
        if self.model.is_pups:
            self._render_pups(viewer, mode, w, h, full_w, full_h)
            return
        if mode == "3d":
            self._render_object(viewer, w, h)
        elif mode == "tiled":
            side = max(8, min(full_w, full_h) // 3)
            if w != full_w:
                side = max(8, side * w // full_w)
            self._render_texture(self._target("tile", (side, side)), (0.0, 0.0), (1.0, 1.0), viewer.channel)
        else:
            # Same pixel -> uv mapping as the full-resolution view (pixel centres scale along).
            uv0, ext = viewer.panzoom.window(full_w, full_h)
            self._render_texture(self._target("view", (w, h)), uv0, ext, viewer.channel)

    def _render_texture(self, target, uv0, ext, channel: str = "color") -> None:
        from cellgl.texture import shader as texture
        from cellgl.texture.recipe import CHANNELS

        # texture.frag: uv = u_view.xy + (v_uv.x, 1 - v_uv.y) * u_view.zw, v = 0 at the top. The
        # pan uv0 goes into the split origins in float64 and u_view.xy = 0, so a view panned far
        # from the origin stays as sharp as at it (cellgl.texture.view_uniforms).
        recipe = self.model.recipe
        uniforms = texture.view_uniforms(recipe, uv0, ext, ctx=self.ctx)
        uniforms["u_channel"] = CHANNELS.index(channel)
        prog = self.runner.draw(runner.Draw("fullscreen.vert", "texture.frag", target,
                                            texture.defines(recipe, (channel,)), uniforms=uniforms,
                                            clear=(0.0, 0.0, 0.0, 1.0)))
        self._note_program(prog)

    def _pups_texture(self, side: int, channel: str):
        """The PUPs recipe baked at ``side x side`` (one period of its point set) by
        :func:`cellgl.recipes.render`, the function behind ``cellgl bake``, as a repeating
        nearest-sampled texture (row 0 = the image's top row at t = 0). Cached by recipe
        version, size and channel."""
        from cellgl import recipes

        key = (self.model.version, side, channel)
        if self._pups_src is not None and self._pups_key == key:
            return self._pups_src
        res = recipes.render(self.model.recipe, side, side, channels=(channel,))[channel]
        self.take_context()
        rgba = res if res.ndim == 3 else np.dstack([res, res, res, np.ones_like(res)])
        self._pups_src = self.runner.image("viewer.pups_src", rgba)
        self._pups_key = key
        return self._pups_src

    def _render_pups(self, viewer, mode, w, h, full_w, full_h) -> None:
        """PUPs recipes (2D only): the bake's pixels, panned and zoomed like the 2D view.

        At zoom 1 the unit square fills the shorter side, ``N = min(w, h)`` pixels: the source
        is the PUPs render of ``N x N`` (one period), so a view pixel is the bake's pixel.
        While interacting (reduced resolution) the cached full-resolution source is reused."""
        channel = viewer.channel if viewer.channel in ("color", "height") else "color"
        if mode == "tiled":
            side = max(8, min(full_w, full_h) // 3)
            src = self._pups_texture(side, channel)
            if w != full_w:
                side = max(8, side * w // full_w)
            target = self._target("tile", (side, side))
            uv0, ext = (0.0, 0.0), (1.0, 1.0)
        else:
            n = max(1, min(full_w, full_h))
            src = self._pups_texture(n, channel)
            target = self._target("view", (w, h))
            uv0, ext = viewer.panzoom.window(full_w, full_h)
        # viewer_blit: tex coord = u_offset + p * u_scale, p in [0, 1] with p.y = 0 at the
        # bottom; the view shows uv = uv0 + (p.x, 1 - p.y) * ext, texture t = v.
        self.runner.draw(runner.Draw(
            "viewer_blit.vert", "viewer_blit.frag", target, clear=(0.0, 0.0, 0.0, 1.0),
            uniforms={"u_offset": (float(uv0[0]), float(uv0[1] + ext[1])),
                      "u_scale": (float(ext[0]), -float(ext[1])), "u_grid": 0.0, "u_tex": 0},
            textures={0: runner.Sampler(src, linear=False, repeat=True)}))

    def _render_object(self, viewer, w, h) -> None:
        from cellgl.texture import shader as texture

        from .model import OBJECT_SCALE

        target = self._target("object", (w, h), position=True)
        recipe = self.model.object_recipe()
        view, proj = viewer.orbit.matrices(w / h)
        uniforms = texture.recipe_uniforms(recipe, ctx=self.ctx)
        uniforms.update(u_object_scale=OBJECT_SCALE, u_model=_mat(np.eye(4)), u_view=_mat(view),
                        u_proj=_mat(proj), u_eye=tuple(float(v) for v in viewer.orbit.eye()),
                        u_bump_view=float(viewer.bump_view))
        verts, idx = meshes.mesh(viewer.shape)
        # The position attachment is cleared to w = 0: "no object here" for the readout.
        prog = self.runner.draw(runner.Draw(
            "viewer_object.vert", "viewer_object.frag", target, texture.defines(recipe), uniforms=uniforms,
            vertices=runner.Vertices(verts, "3f 3f", ("in_position", "in_normal"), idx, key="viewer.mesh"),
            clear=(0.11, 0.12, 0.14, 1.0), depth_test=True))
        self._note_program(prog)

    def object_position_at(self, x: int, y: int):
        """Object-space position under view pixel (x, y) (GL, y up, full resolution), or None."""
        t = self._targets.get("object")
        if t is None or self._key is None or self._key[0] != "3d":
            return None
        s = self.last_scale
        px, py = int(x) // s, int(y) // s
        if not (0 <= px < t.size[0] and 0 <= py < t.size[1]):
            return None
        data = self.runner.read(t, attachment=1, viewport=(px, py, 1, 1))[0, 0]
        return data[:3].astype(float) if data[3] > 0.5 else None

    def _compose(self, viewer, mode, viewport, window_size) -> None:
        name = {"3d": "object", "tiled": "tile"}.get(mode, "view")
        tex = self._targets[name].textures[0]
        linear = self.last_scale != 1
        repeat = False
        if mode == "tiled":
            vw, vh = viewport[2:]
            repeat = True
            # 3 tiles along the shorter side, square tiles.
            side = min(vw, vh) / 3.0
            sx, sy = vw / side, vh / side
            # A tile corner at the view's top-left corner (texture rows run top down).
            uniforms = {"u_scale": (sx, sy), "u_offset": (0.0, float(np.ceil(sy) - sy)),
                        "u_grid": 0.004 if viewer.tile_borders else 0.0}
            linear = abs(side - tex.size[0]) > 0.5
        else:
            uniforms = {"u_scale": (1.0, 1.0), "u_offset": (0.0, 0.0), "u_grid": 0.0}
        uniforms["u_tex"] = 0
        frame = self.runner.target("viewer.frame", window_size, (("f1", 4),), depth=True)
        self.runner.draw(runner.Draw("viewer_blit.vert", "viewer_blit.frag", frame, uniforms=uniforms,
                                     textures={0: runner.Sampler(tex, linear=linear, repeat=repeat)},
                                     viewport=tuple(viewport), clear=(0.06, 0.06, 0.07, 1.0)))
        frame.fbo.viewport = (0, 0, *window_size)
