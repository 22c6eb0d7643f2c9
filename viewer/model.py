"""The viewer's document: one recipe (:class:`cellgl.texture.recipe.Recipe`), edited in place.

Edits go through :meth:`Recipe.replace`, so every value the panel sets is validated exactly as
a recipe file is; a rejected value leaves the recipe unchanged and the error is shown. Each
accepted change bumps :attr:`Model.version`, which the renderer uses to decide when to redraw.

Rendering uses the shared texture library only: the 2D program is ``fullscreen.vert`` +
``texture.frag`` (the texture engine's own viewer entry, panned and zoomed by its ``u_view``) and the 3D program ``viewer_object.*``, which
includes ``lib/texture.glsl``; compile-time macros and uniforms come from
:func:`cellgl.texture.defines` and :func:`cellgl.texture.shader.recipe_uniforms`, drawn by the
window context's runner (:mod:`cellgl.viewer.render`).
"""

from __future__ import annotations

import numpy as np

from cellgl.texture.params import inactive
from cellgl.recipes import is_pups as pups_recipe, list_presets, load_recipe, parameters
from cellgl.texture.recipe import Recipe

__all__ = ["Model", "DEFAULT_PRESET"]

DEFAULT_PRESET = "flagstone"
#: texture-space position of object point q (objects span [-1, 1]^3): p = q * OBJECT_SCALE + 0.5
OBJECT_SCALE = 0.5


class Model:
    """A recipe being edited, with a version counter."""

    def __init__(self, recipe: Recipe):
        self.recipe = recipe
        self.version = 0

    # ----------------------------------------------------------------------------------------
    # loading / saving

    @staticmethod
    def presets() -> list[str]:
        return [name for name, _ in list_presets()]

    @classmethod
    def load(cls, name_or_path=None) -> Model:
        return cls(cls._read(name_or_path))

    @classmethod
    def _read(cls, name_or_path) -> Recipe:
        if name_or_path is None:
            names = cls.presets()
            if DEFAULT_PRESET in names:
                name_or_path = DEFAULT_PRESET
            elif names:
                name_or_path = names[0]
            else:
                return Recipe(name="default")
        return load_recipe(name_or_path)

    def load_into(self, name_or_path) -> None:
        self.recipe = self._read(name_or_path)
        self.version += 1

    def save(self, path) -> None:
        self.recipe.save(path)

    @property
    def name(self) -> str:
        return self.recipe.name

    @property
    def is_pups(self) -> bool:
        """A PUPs recipe (:mod:`cellgl.pups.recipe`): 2D only, rendered by its own engine."""
        return pups_recipe(self.recipe)

    @property
    def params(self):
        """The parameter table the panel shows (:func:`cellgl.recipes.parameters`: every entry for
        a cellular recipe, the entries its pattern uses for a PUPs one)."""
        return parameters(self.recipe)

    def inactive(self) -> dict[str, str]:
        """``{name: what turns it on}`` of the parameters that change nothing now
        (:func:`cellgl.texture.params.inactive`; a PUPs recipe shows only the entries its
        pattern uses, so none)."""
        return {} if self.is_pups else inactive(self.recipe)

    # ----------------------------------------------------------------------------------------
    # values

    def get(self, name):
        return self.recipe.get(name)

    def set(self, name, value) -> bool:
        """Set one parameter; raises ValueError (RecipeError) naming the accepted values."""
        if self.recipe.get(name) == value:
            return False
        self.recipe = self.recipe.replace(**{name: value})
        self.version += 1
        return True

    def set_text(self, name: str, text: str) -> bool:
        """``--set name=value`` (parsed as the CLI parses it)."""
        new = self.recipe.set_from_strings([f"{name}={text}"])
        if new == self.recipe:
            return False
        self.recipe = new
        self.version += 1
        return True

    @property
    def ramp(self):
        return self.recipe.ramp

    def set_ramp(self, keys) -> bool:
        keys = sorted((tuple(float(v) for v in k) for k in keys), key=lambda k: k[0])
        return self.set("ramp", tuple(keys))

    def measure_range(self) -> None:
        """Set range_lo / range_hi from the current combination (cellgl.texture.measure_range)."""
        from cellgl import texture

        lo, hi = texture.measure_range(self.recipe)
        self.recipe = self.recipe.replace(range_lo=float(lo), range_hi=float(hi))
        self.version += 1

    # ----------------------------------------------------------------------------------------
    # the 3D view

    def object_recipe(self) -> Recipe:
        """The recipe as the 3D view evaluates it: a solid texture needs at least 3 dimensions."""
        if int(self.recipe.get("dimension")) < 3:
            return self.recipe.replace(dimension=3)
        return self.recipe

    # ----------------------------------------------------------------------------------------
    # readouts: the basis at the point under the cursor, from the same parameters

    def basis_position(self, p, dim: int | None = None) -> np.ndarray:
        """Texture-space (u, v, z) -> basis-space position (``cell_texture_position``), (dim,)."""
        v = self.recipe.values
        f = float(v["frequency"])
        x = np.array([p[0] * f + v["offset_x"], p[1] * f * v["aspect"] + v["offset_y"],
                      p[2] * f + v["offset_z"], v["time"]], dtype=np.float64)
        d = int(dim or v["dimension"])
        return x[:d]

    @property
    def loops(self) -> bool:
        """The recipe animates by orbiting feature points (``orbit_radius > 0``): a loop."""
        return not self.is_pups and float(self.recipe.get("orbit_radius")) > 0.0

    def _warped(self, p, x: np.ndarray) -> np.ndarray:
        """Basis position x of texture point p moved by the recipe's domain warp (as the texture
        samples it), or x itself without one."""
        if float(self.recipe.get("warp_amount")) == 0.0:
            return x
        from cellgl.texture import reference as texture_reference

        t = texture_reference.texture_values(self.recipe)
        s = texture_reference.texture_local(np.asarray([p], dtype=np.float64), t)
        sw, _ = texture_reference.texture_warp(s, t)
        return x + (sw - s)[0, : len(x)]

    def _cellular(self, x: np.ndarray) -> dict:
        import cellgl
        from cellgl.texture import domain as texture_domain

        v = self.recipe.values
        period = None
        if v["tileable"]:
            period = [int(round(v["frequency"])), int(round(v["frequency"] * v["aspect"]))] + [0] * (len(x) - 2)
        r = cellgl.cellular(x[None, :], 4, metric=v["metric"], distribution=v["distribution"],
                            density=v["density"], jitter=v["jitter"], min_points=v["min_points"],
                            max_points=v["max_points"], minkowski_p=v["minkowski_p"], seed=v["seed"],
                            period=period, outputs=("F", "id"), density_map=self._density_map(),
                            stretch=[1.0 / w for w in texture_domain.axis_scale(v)[: len(x)]],
                            orbit_radius=v["orbit_radius"], orbit_phase=v["orbit_phase"])
        assert r.F is not None and r.id is not None, "outputs=(\"F\", \"id\") asked for both"
        return {"F": [float(f) for f in r.F[0]], "id": int(r.id[0, 0]), "pos": tuple(float(c) for c in x)}

    def _density_map(self):
        """The recipe's density map in absolute basis units (octave 0, as the texture's first
        octave sees it: the uv map shifted by the offsets), or None."""
        from cellgl.texture import reference as texture_reference

        dm = texture_reference.density_map(self.recipe)
        if dm is None:
            return None
        v = self.recipe.values
        return dm.scaled(1.0, (v["offset_x"], v["offset_y"], v["offset_z"], v["time"]))

    def readout_uv(self, u: float, v: float) -> dict:
        """F1..F4 and the F1 feature ID at texture coordinate (u, v) (v down, as image rows)."""
        if self.is_pups:
            return {"uv": (u, v), "F": [], "id": None, "pos": (u, v)}
        out = self._cellular(self._warped((u, v, 0.0), self.basis_position((u, v, 0.0))))
        out["uv"] = (u, v)
        return out

    def readout_object(self, q) -> dict:
        """The same at object-space point ``q`` of the 3D view."""
        p = np.asarray(q, float) * OBJECT_SCALE + 0.5
        dim = max(3, int(self.recipe.get("dimension")))
        return self._cellular(self._warped(p, self.basis_position(p, dim)))
