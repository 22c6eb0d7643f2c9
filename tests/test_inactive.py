"""Inactive parameters (issue 33, item 13): one derivation from the parameter table
(:func:`cellgl.texture.params.inactive`) for the viewer, the playground and the Blender panel."""
import numpy as np
import pytest

from cellgl.recipes import load_recipe
from cellgl.texture import params as P
from cellgl.texture.recipe import RecipeError
from cellgl.texture import reference


def test_the_issue_examples():
    off = P.inactive({})            # the table defaults: 2D poisson, euclidean, no density map
    for name in ("density_min", "density_max", "density_start", "density_end", "density_center_x",
                 "density_center_y", "density_radius", "minkowski_p", "jitter", "stretch_z", "time",
                 "offset_z", "octaves", "lacunarity", "gain", "orbit_phase"):
        assert name in off, name
    assert off["minkowski_p"] == "needs metric minkowski"
    assert off["stretch_z"] == "needs dimension 3 or more"
    assert off["jitter"] == "needs distribution jitter or blender"
    for name in ("density", "metric", "seed", "frequency", "c1", "c44", "min_points", "c_edge"):
        assert name not in off, name
    on = P.inactive({"metric": "minkowski", "density_map": "radial", "distribution": "poisson",
                     "dimension": 4, "fractal": "sum", "orbit_radius": 0.1})
    for name in ("minkowski_p", "density_min", "density_radius", "stretch_z", "time", "gain", "orbit_phase"):
        assert name not in on, name
    assert on["density"] == "needs density_map none"
    assert on["density_start"] == "needs density_map ramp_x or ramp_y"
    assert on["c_edge"] == "needs metric euclidean"


def test_reasons_name_every_unmet_requirement():
    off = P.inactive({"distribution": "jitter"})
    assert off["density_radius"] == "needs distribution poisson, and density_map radial"
    assert off["smooth"] == "needs c_smooth not 0 or cell_mix not 0, and smoothness > 0"
    assert P.inactive({"distribution": "blender"})["seed"] == "needs distribution other than blender"


def test_accepts_a_recipe_and_keeps_table_order():
    r = load_recipe("flagstone")
    assert P.inactive(r) == P.inactive(r.values)
    names = [p.name for p in P.PARAMS]
    got = list(P.inactive({}))
    assert got == sorted(got, key=names.index)


def test_the_table_names_real_parameters_and_values():
    for name, reqs in P.ACTIVE_WHEN.items():
        assert name in P.PARAMS_BY_NAME, name
        assert reqs and all(isinstance(req, tuple) and req for req in reqs), name
        for req in reqs:
            for cond, op, arg in req:
                p = P.PARAMS_BY_NAME[cond]
                assert cond != name, name
                assert op in ("in", "not in", "!=", ">", ">="), (name, op)
                if op in ("in", "not in"):
                    allowed = p.choices if p.type == "enum" else range(int(p.lo), int(p.hi) + 1)
                    assert all(a in allowed for a in arg), (name, cond, arg)
                else:
                    assert p.type in ("float", "int"), (name, cond)


def _other(p, value):
    """A value of table entry p other than ``value`` (for a float: the far end of its range)."""
    if p.type == "enum":
        return next(c for c in p.choices if c != value)
    if p.type == "bool":
        return not value
    if p.type == "int":
        return int(p.hi) if value != int(p.hi) else int(p.lo)
    far = p.hi if abs(p.hi - value) >= abs(value - p.lo) else p.lo
    return float(min(far, 1e3) if far > 0 else max(far, -1e3))


PTS = np.random.default_rng(7).uniform(0.0, 1.0, size=(48, 3))


@pytest.mark.parametrize("preset", ["flagstone", "blender-voronoi", "density", "hull", "caustics"])
def test_an_inactive_parameter_changes_nothing(preset):
    """Every parameter :func:`inactive` names either is refused when moved (the recipe's rules
    lock it: seed with blender points) or leaves the texture's bits unchanged."""
    r = load_recipe(preset)
    base = reference.evaluate(r, PTS, ("color", "height", "value", "id"))
    off = P.inactive(r)
    assert off
    for name in off:
        p = P.PARAMS_BY_NAME[name]
        try:
            moved = r.replace(**{name: _other(p, r.values[name])})
        except RecipeError:
            continue
        got = reference.evaluate(moved, PTS, ("color", "height", "value", "id"))
        for k in base:
            assert np.array_equal(base[k], got[k]), (preset, name, k)
