"""The ``Regenerate (do not edit)`` command of a snippet's header: a ``cellgl export`` command
line that writes the same snippet, byte for byte (in the directory it was run from, for a
recipe file given by a relative path).

The command line passes what it was given (:func:`recipe_command`); from Python,
:func:`cellgl.export.snippets.export` derives it from the recipe: a preset or file name as
given, and a :class:`~cellgl.texture.recipe.Recipe` object as its preset plus one ``--set`` per
parameter that differs. A recipe object that no preset and ``--set`` list reproduces (another
name, another ramp) gets ``cellgl export RECIPE.json``: the header's ``Recipe:`` line saved as
``RECIPE.json`` makes that command write the same snippet.
"""
from __future__ import annotations

import json
import os
import shlex

__all__ = ["recipe_command", "command_for"]


def recipe_command(recipe: str, sets=(), *, fold: bool = True) -> str:
    """``cellgl export RECIPE [--set NAME=VALUE ...] [--no-fold]`` (the target and
    ``--uniforms`` are added by the header), each word quoted for a POSIX shell."""
    words = ["cellgl", "export", str(recipe)]
    for s in sets:
        words += ["--set", str(s)]
    if not fold:
        words.append("--no-fold")
    return shlex.join(words)


def _text(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return json.dumps(value, separators=(",", ":"))
    return repr(value) if isinstance(value, float) else str(value)


def command_for(recipe, *, fold: bool = True) -> str:
    """The command for ``recipe`` as :func:`cellgl.export.snippets.export` received it."""
    from cellgl.recipes import load_recipe

    if isinstance(recipe, (str, os.PathLike)):
        return recipe_command(os.fspath(recipe), fold=fold)
    try:
        base = load_recipe(recipe.name)
    except (ValueError, OSError):
        base = None
    if base is not None and type(base) is type(recipe):
        sets = [f"{k}={_text(v)}" for k, v in recipe.values.items() if base.values[k] != v]
        try:
            same = base.set_from_strings(sets) == recipe if sets else base == recipe
        except ValueError:
            same = False
        if same:
            return recipe_command(recipe.name, sets, fold=fold)
    return recipe_command("RECIPE.json", fold=fold)     # the header's Recipe line, saved
