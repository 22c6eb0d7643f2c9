"""GL side of the viewer: offscreen targets, the view renderers, the copy to the window.

The view (2D texture, 3D object, 3x3 tiles, animation) is rendered into its own texture only
when what it shows changes (a key of the recipe version, view state and size), then copied to
the frame. While the user drags a slider or the view, it is rendered at 1/2 or 1/4 resolution
(chosen from the measured cost of the last full-resolution render) and upscaled; once input
stops the next frame renders at full resolution ("refine").

Programs come from :func:`cellgl.gl.context.program`, which caches them by their ``#define``s: a
shader is compiled only when a compile-time parameter changes.
"""

from __future__ import annotations

import time

import numpy as np

from cellgl.gl import context

from . import meshes

__all__ = ["Renderer"]

#: target frame time while interacting (seconds); the preview scale is chosen to meet it
INTERACTIVE_BUDGET = 0.05

SCALES = (1, 2, 4)


def _mat(m: np.ndarray) -> bytes:
    """A float64 4x4 (column vectors) as the column-major float32 bytes GLSL expects."""
    return np.ascontiguousarray(m.T, dtype=np.float32).tobytes()


class Renderer:
    def __init__(self, ctx, model, take_context=lambda: None):
        self.ctx = ctx
        self.model = model
        # Makes the window's context current again after a cellgl API call (which makes
        # cellgl's headless context current).
        self.take_context = take_context
        self.vao_empty = ctx.vertex_array(context.program("viewer_blit.vert", "viewer_blit.frag", ctx=ctx), [])
        self.blit = context.program("viewer_blit.vert", "viewer_blit.frag", ctx=ctx)
        self.frame_fbo = None
        self._frame_size = None
        self._targets: dict[str, tuple] = {}
        self._meshes: dict[str, tuple] = {}
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

    def release(self) -> None:
        for objects in self._targets.values():
            # (tex, fbo, *extra): the framebuffer first, then its attachments; ("pups_src"): (tex,)
            for o in (objects[1:2] + objects[:1] + objects[2:]):
                o.release()
        for vbo, ibo, vao in self._meshes.values():
            vao.release()
            vbo.release()
            ibo.release()
        if self.frame_fbo is not None:
            self.frame_fbo.release()

    # ----------------------------------------------------------------------------------------
    # targets

    def _frame(self, size) -> None:
        if self._frame_size != size:
            if self.frame_fbo is not None:
                self.frame_fbo.release()
            self.frame_fbo = self.ctx.simple_framebuffer(size, components=4)
            self._frame_size = size

    def _target(self, name: str, size, position: bool = False):
        """A colour texture + framebuffer (+ position texture and depth for the 3D view)."""
        size = (max(1, int(size[0])), max(1, int(size[1])))
        old = self._targets.get(name)
        if old is not None and old[0].size == size:
            return old
        if old is not None:
            for o in old:
                o.release()
        tex = self.ctx.texture(size, 4)
        tex.filter = (0x2601, 0x2601)  # GL_LINEAR: the reduced preview is upscaled smoothly
        attachments = [tex]
        extra = []
        if position:
            pos = self.ctx.texture(size, 4, dtype="f4")
            pos.filter = (0x2600, 0x2600)
            depth = self.ctx.depth_renderbuffer(size)
            attachments.append(pos)
            extra = [pos, depth]
            fbo = self.ctx.framebuffer(attachments, depth)
        else:
            fbo = self.ctx.framebuffer(attachments)
        entry = (tex, fbo, *extra)
        self._targets[name] = entry
        return entry

    def _mesh(self, prog, shape: str):
        key = (shape, prog.glo)
        if key not in self._meshes:
            verts, idx = meshes.mesh(shape)
            vbo = self.ctx.buffer(verts.tobytes())
            ibo = self.ctx.buffer(idx.tobytes())
            vao = self.ctx.vertex_array(prog, [(vbo, "3f 3f", "in_position", "in_normal")], ibo)
            self._meshes[key] = (vbo, ibo, vao)
        return self._meshes[key][2]

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

    def draw(self, viewer, viewport, window_size, interacting: bool) -> None:
        """Render the view (if needed) and copy it into ``viewport`` (x, y, w, h; GL, y up)."""
        self._frame(window_size)
        vx, vy, vw, vh = viewport
        mode = viewer.mode
        scale = self._choose_scale(interacting, vw, vh)
        key = (mode, self.model.version, vw, vh, scale)
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
            self.ctx.finish()
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
            tex, fbo = self._target("tile", (side, side))[:2]
            self._render_texture(fbo, (0.0, 0.0), (1.0, 1.0), viewer.channel)
        else:
            tex, fbo = self._target("view", (w, h))[:2]
            # Same pixel -> uv mapping as the full-resolution view (pixel centres scale along).
            uv0, ext = viewer.panzoom.window(full_w, full_h)
            self._render_texture(fbo, uv0, ext, viewer.channel)

    def _render_texture(self, fbo, uv0, ext, channel: str = "color") -> None:
        from cellgl.texture.recipe import CHANNELS

        prog = self.model.program_2d(self.ctx, channel)
        self._note_program(prog)
        self.model.set_uniforms(prog)
        # texture.frag: uv = u_view.xy + (v_uv.x, 1 - v_uv.y) * u_view.zw, v = 0 at the top. The
        # pan uv0 goes into the split origins in float64 and u_view.xy = 0, so a view panned far
        # from the origin stays as sharp as at it (cellgl.texture.set_view).
        from cellgl.texture import shader as texture

        texture.set_view(prog, self.model.recipe, uv0, ext)
        if "u_channel" in prog:
            prog["u_channel"].value = CHANNELS.index(channel)
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 1.0)
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND | self.ctx.CULL_FACE)
        vao = self.ctx.vertex_array(prog, [])
        vao.render(mode=self.ctx.TRIANGLES, vertices=3)
        vao.release()

    def _pups_texture(self, side: int, channel: str):
        """The PUPs recipe baked at ``side x side`` (one period of its point set) by
        :func:`cellgl.recipes.render`, the function behind ``cellgl bake``, as a repeating
        nearest-sampled texture (row 0 = the image's top row at t = 0). Cached by recipe
        version, size and channel."""
        from cellgl import recipes

        key = (self.model.version, side, channel)
        old = self._targets.get("pups_src")
        if old is not None and self._pups_key == key:
            return old[0]
        res = recipes.render(self.model.recipe, side, side, channels=(channel,))[channel]
        self.take_context()
        rgba = res if res.ndim == 3 else np.dstack([res, res, res, np.ones_like(res)])
        if old is not None:
            for o in old:
                o.release()
        tex = self.ctx.texture((side, side), 4, np.ascontiguousarray(rgba, np.float32).tobytes(),
                               dtype="f4")
        tex.filter = (0x2600, 0x2600)
        tex.repeat_x = tex.repeat_y = True
        self._targets["pups_src"] = (tex,)
        self._pups_key = key
        return tex

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
            tex, fbo = self._target("tile", (side, side))[:2]
            uv0, ext = (0.0, 0.0), (1.0, 1.0)
        else:
            n = max(1, min(full_w, full_h))
            src = self._pups_texture(n, channel)
            tex, fbo = self._target("view", (w, h))[:2]
            uv0, ext = viewer.panzoom.window(full_w, full_h)
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 1.0)
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND | self.ctx.CULL_FACE)
        # viewer_blit: tex coord = u_offset + p * u_scale, p in [0, 1] with p.y = 0 at the
        # bottom; the view shows uv = uv0 + (p.x, 1 - p.y) * ext, texture t = v.
        self.blit["u_offset"].value = (float(uv0[0]), float(uv0[1] + ext[1]))
        self.blit["u_scale"].value = (float(ext[0]), -float(ext[1]))
        self.blit["u_grid"].value = 0.0
        src.use(0)
        self.blit["u_tex"].value = 0
        self.vao_empty.render(mode=self.ctx.TRIANGLES, vertices=3)

    def _render_object(self, viewer, w, h) -> None:
        tex, fbo, pos, depth = self._target("object", (w, h), position=True)
        prog = self.model.program_object(self.ctx)
        self._note_program(prog)
        self.model.set_uniforms(prog, object_view=True)
        view, proj = viewer.orbit.matrices(w / h)
        from .model import OBJECT_SCALE

        prog["u_object_scale"].value = OBJECT_SCALE
        model = np.eye(4)
        prog["u_model"].write(_mat(model))
        prog["u_view"].write(_mat(view))
        prog["u_proj"].write(_mat(proj))
        if "u_eye" in prog:
            prog["u_eye"].value = tuple(float(v) for v in viewer.orbit.eye())
        if "u_bump_view" in prog:
            prog["u_bump_view"].value = float(viewer.bump_view)
        fbo.use()
        fbo.clear(0.11, 0.12, 0.14, 1.0, depth=1.0)
        # The position attachment is cleared to w = 0: "no object here" for the readout.
        self.ctx.enable(self.ctx.DEPTH_TEST)
        self.ctx.disable(self.ctx.BLEND | self.ctx.CULL_FACE)
        self._mesh(prog, viewer.shape).render()
        self.ctx.disable(self.ctx.DEPTH_TEST)

    def object_position_at(self, x: int, y: int):
        """Object-space position under view pixel (x, y) (GL, y up, full resolution), or None."""
        t = self._targets.get("object")
        if t is None or self._key is None or self._key[0] != "3d":
            return None
        tex, fbo, pos, depth = t
        s = self.last_scale
        px, py = int(x) // s, int(y) // s
        if not (0 <= px < pos.size[0] and 0 <= py < pos.size[1]):
            return None
        data = np.frombuffer(fbo.read(viewport=(px, py, 1, 1), components=4, attachment=1, dtype="f4"),
                             np.float32)
        return data[:3].astype(float) if data[3] > 0.5 else None

    def _compose(self, viewer, mode, viewport, window_size) -> None:
        self.frame_fbo.use()
        self.ctx.viewport = (0, 0, *window_size)
        self.frame_fbo.clear(0.06, 0.06, 0.07, 1.0)
        self.ctx.viewport = viewport
        self.ctx.disable(self.ctx.DEPTH_TEST | self.ctx.BLEND | self.ctx.CULL_FACE)
        name = {"3d": "object", "tiled": "tile"}.get(mode, "view")
        tex = self._targets[name][0]
        nearest = self.last_scale == 1
        tex.filter = (0x2600, 0x2600) if nearest else (0x2601, 0x2601)
        if mode == "tiled":
            vw, vh = viewport[2:]
            tex.repeat_x = tex.repeat_y = True
            # 3 tiles along the shorter side, square tiles.
            side = min(vw, vh) / 3.0
            sx, sy = vw / side, vh / side
            self.blit["u_scale"].value = (sx, sy)
            # A tile corner at the view's top-left corner (texture rows run top down).
            self.blit["u_offset"].value = (0.0, float(np.ceil(sy) - sy))
            self.blit["u_grid"].value = 0.004 if viewer.tile_borders else 0.0
            tex.filter = (0x2601, 0x2601) if abs(side - tex.size[0]) > 0.5 else (0x2600, 0x2600)
        else:
            self.blit["u_scale"].value = (1.0, 1.0)
            self.blit["u_offset"].value = (0.0, 0.0)
            self.blit["u_grid"].value = 0.0
        tex.use(0)
        self.blit["u_tex"].value = 0
        self.vao_empty.render(mode=self.ctx.TRIANGLES, vertices=3)
        self.ctx.viewport = (0, 0, *window_size)

    def present(self, window_size) -> None:
        """Copy the finished frame to the window's default framebuffer."""
        self.ctx.copy_framebuffer(self.ctx.screen, self.frame_fbo)
