"""The viewer's document: one recipe, edited in place, with a version counter for redraws.

INTERIM: until cellgl.recipe / cellgl.texture land this renders the plain basis (F1 grey)
through shaders/viewer_basis.frag; values live in a dict keyed by the parameter table.
"""

from __future__ import annotations

import numpy as np

from cellgl import context
from cellgl.gpu import defines_for
from cellgl.core import make_params
from cellgl.params import PARAMS, PARAMS_BY_NAME

__all__ = ["Model"]


class Model:
    def __init__(self, values: dict, name: str = "untitled"):
        self.values = values
        self.name = name
        self.version = 0
        self.params = PARAMS
        self.ramp = [[0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0]]

    @classmethod
    def load(cls, name_or_path=None) -> "Model":
        return cls({p.name: p.default for p in PARAMS}, name_or_path or "default")

    @staticmethod
    def presets() -> list[str]:
        return []

    def get(self, name):
        return self.values[name]

    def set(self, name, value) -> bool:
        if self.values.get(name) == value:
            return False
        self.values[name] = value
        self.version += 1
        return True

    def set_text(self, name, text) -> bool:
        p = PARAMS_BY_NAME[name]
        v = {"float": float, "int": int, "bool": lambda t: t.lower() in ("1", "true", "yes"),
             "enum": str}.get(p.type, str)(text)
        return self.set(name, v)

    def _basis(self, dim=2):
        v = self.values
        return make_params(dim, metric=v["metric"], distribution=v["distribution"], density=v["density"],
                           jitter=v["jitter"], min_points=v["min_points"], max_points=v["max_points"],
                           minkowski_p=v["minkowski_p"], seed=v["seed"])

    def defines(self) -> dict:
        dim = int(self.values["dimension"])
        return defines_for(self._basis(4), 4)

    def program_2d(self, ctx):
        return context.program("viewer_2d.vert", "viewer_basis.frag", self.defines(), ctx=ctx)

    def program_object(self, ctx):
        raise NotImplementedError

    def set_uniforms(self, prog):
        p = self._basis(4)
        for k, val in (("u_seed", int(p.seed)), ("u_jitter", float(p.jitter)),
                       ("u_min_points", int(p.min_points)), ("u_max_points", int(p.max_points)),
                       ("u_minkowski_p", float(p.minkowski_p)), ("u_scale", float(self.values["frequency"])),
                       ("u_time", float(self.values["time"]))):
            if k in prog:
                prog[k].value = val
        if "u_thresholds" in prog:
            prog["u_thresholds"].write(p.thresholds.astype(np.uint32).tobytes())

    def readout_uv(self, u, v):
        import cellgl

        f = float(self.values["frequency"])
        r = cellgl.cellular(np.array([[u * f, v * f, 0.0, self.values["time"]]]), 4,
                            seed=int(self.values["seed"]), density=self.values["density"])
        return {"uv": (u, v), "F": r.F[0].tolist(), "id": int(r.id[0, 0])}

    def readout_object(self, pos):
        return {"pos": tuple(pos)}
