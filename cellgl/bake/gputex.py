"""GPU texture bakes: a recipe rendered into ``.dds`` and ``.ktx2`` files (:func:`cellgl.bake.core.bake`
hands them here; ``cellgl bake -o X.dds``, docs/bake.md "GPU texture files").

With ``mips`` every level is rendered from the recipe at its own size (:mod:`cellgl.bake.mips`,
``rounding="down"``: the levels DDS and KTX2 define), never downsampled; ``layers`` (``--frames``)
makes each file an array texture. The files themselves (the format each channel takes, the
samples, the blocks, the container) are :mod:`cellgl.io.gpu_textures`'s.
"""
from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

from cellgl.bake import mips
from cellgl.io.gpu_textures import TexOutput, level_data, memory_need, texel_samples, write_container
from cellgl.bake.request import RENDER_BYTES_PER_PIXEL
from cellgl.io.spec import BakeError
from cellgl.io.tempfiles import atomic_paths

__all__ = ["bake_texture"]


def _tile_side(channels, budget: int) -> int:
    per_px = RENDER_BYTES_PER_PIXEL * (1 + len(channels)) // 2 + 16 * len(channels)
    return max(16, min(2048, math.isqrt(max(1, budget // 2) // per_px) // 16 * 16))


def bake_texture(recipe, outputs: list[TexOutput], ext: str, size, *, samples: int, tile, budget: int,
                 mip_chain: bool, supercompression, progress: Callable, meta: Callable,
                 layers=None) -> list[Path]:
    """Render and write ``outputs`` (from :func:`plan_outputs`), all or none; ``layers`` (recipes)
    makes each file an array texture of one layer per recipe (``--frames``)."""
    w, h, d = size
    recipes = [recipe] if layers is None else list(layers)
    nlayers = None if layers is None else len(recipes)
    chain = mips.mip_sizes(w, h, d, rounding="down") if mip_chain else [(w, h) + ((d,) if d else ())]
    need = memory_need(outputs, chain) * len(recipes)
    if need > budget:
        mb = -(-need // (1 << 20))
        raise BakeError(f"size {w}x{h}{'' if d is None else f'x{d}'} to {ext}: the bake holds level 0's "
                        f"samples and the files' bytes, about {mb} MB, more than --memory {budget >> 20} MB; "
                        f"accepted --memory {mb} or more, fewer channels a bake, or a smaller --size")
    channels = tuple(o.channel for o in outputs)
    side = int(tile) if tile else _tile_side(channels, budget)
    with atomic_paths([o.path for o in outputs]) as tmps:
        per_out: list[list[bytes]] = [[] for _ in outputs]
        what = f"{len(chain)} level(s)" + (f" x {nlayers} layers" if nlayers else "")
        bar = progress(len(chain) * len(recipes), f"baking {what} of {outputs[0].path.name}", unit="levels")
        with bar:
            for k in range(len(chain)):     # one level's samples held at a time; blocks on every core
                convert = {o.channel: (lambda a, o=o: texel_samples(o.fmt, o.channel, a)) for o in outputs}
                parts: list[list[bytes]] = [[] for _ in outputs]
                for r in recipes:
                    res = mips.render_level(r, w, h, k, depth=d, channels=channels, samples=samples, tile=side,
                                            rounding="down", convert=convert)
                    for i, o in enumerate(outputs):
                        parts[i].append(level_data(o, res.pop(o.channel), d))
                    del res
                    bar.step()
                for i in range(len(outputs)):
                    per_out[i].append(b"".join(parts[i]))
        for o, data, tmp in zip(outputs, per_out, tmps):
            info = json.dumps({**json.loads(meta(o.channel)), "format": o.fmt.name,
                               "levels": len(data), **({"layers": nlayers} if nlayers else {})}, sort_keys=True)
            with open(tmp, "wb") as f:
                write_container(f, ext, o.fmt, (w, h, d), data, supercompression=supercompression,
                                metadata=info, layers=nlayers)
    return [o.path for o in outputs]
