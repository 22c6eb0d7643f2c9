#!/usr/bin/env python
"""Per-pixel speed of exported snippets (``cellgl export``) in a fragment shader.

Each snippet's GLSL is pasted into a fragment shader that covers an S x S target (default
1024^2) and calls its entry point once per pixel, as a game would. Next to it, in the same run,
a compact *approximate* 3x3 jitter F1 written for this benchmark (one point per cell, the 9
cells around the sample, no pruning, no exactness guarantee: the usual shader-toy cellular
noise). ``ratio`` = (snippet Mpx/s) / (compact Mpx/s): 1.0 is as fast as the approximate
snippet. The compact snippet is rendered before every row (so its median time samples the load
over the whole run, as the rows' do).

Rows: the basis snippets (``cellgl export --basis ...``: f1 with the jitter and the poisson
distribution, f1f2, edge), F1 texture recipes with both distributions, and every exportable
preset (``cellgl export PRESET``, its ``cellgl_texture(uv)``).

    python benchmarks/bench_snippets.py                   # everything, 1024^2, median of 5
    python benchmarks/bench_snippets.py --size 512 --repeats 3 f1 flagstone
    python benchmarks/bench_snippets.py --compare old/ f1     # also old/f1.glsl (an older export)
                                  # and old/basis-f1.glsl, old/basis-f1-jitter.glsl (--basis f1 --dim 2)
    python benchmarks/bench_snippets.py --stub-search flagstone   # and flagstone minus its search

``--stub-search`` adds, after each texture row, the same snippet with the body of its cellular
search (``cellgl_search_budget``) replaced by a few operations on the sample's cell and
fraction: the rate of everything else (the texture layer: noise, warp, fractal sum, colour,
features' own passes), i.e. the most the snippet could reach with a free search. The pixels of
that row are meaningless; only its time is (and where a feature runs passes of its own whose
length depends on the search's answer, edge distance or smooth F1, it is not even that).

Timings are medians of ``--repeats`` renders after one warm-up render (which compiles), the rows
interleaved so that a change of load on a shared machine hits every row alike. With
``--compare``, each snippet that has an older version gets a column ``new / old``: the median of
the per-round speed ratios of the two, rendered one right after the other. The load average is
printed with the table: above about 2 on two cores, short renders (small ``--size``, fast rows)
wait for the scheduler and the ratios of fast rows drift by 20% or more.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

_REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if _REPO not in sys.path:
    sys.path.insert(0, _REPO)

VERT = """#version 330 core
void main()
{
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""

#: the comparison: approximate F1 over the 3x3 cells around p, one jittered point per cell
COMPACT = """
uint bench_hash(uint v)
{
    v = (v ^ 61u) ^ (v >> 16);
    v *= 9u;
    v ^= v >> 4;
    v *= 0x27d4eb2du;
    return v ^ (v >> 15);
}

float bench_f1(vec2 p)
{
    vec2 i = floor(p);
    vec2 f = p - i;
    float d = 8.0;
    for (int y = -1; y <= 1; y++) {
        for (int x = -1; x <= 1; x++) {
            ivec2 c = ivec2(i) + ivec2(x, y);
            uint h = bench_hash(uint(c.x) * 73856093u ^ uint(c.y) * 19349663u);
            vec2 r = vec2(x, y) + vec2(float(h & 0xffffu), float(h >> 16)) * (1.0 / 65536.0) - f;
            d = min(d, dot(r, r));
        }
    }
    return sqrt(d);
}
"""


def frag_shader(body: str, call: str) -> str:
    return ("#version 330 core\n" + body + "\nuniform vec2 size;\nout vec4 bench_out;\n"
            "void main()\n{\n    vec2 uv = gl_FragCoord.xy / size;\n"
            f"    bench_out = {call};\n}}\n")


def stub_search(code: str) -> str | None:
    """``code`` with its cellgl_search_budget body replaced by a stand-in that fills every field
    of CellglResult from the cell and the fraction (so nothing downstream folds to a constant);
    None without one."""
    import re

    m = re.search(r"CellglResult cellgl_search_budget\(ivec4 cell, vec4 f,[^)]*\) \{\n", code)
    if not m:
        return None
    end = code.index("\n}\n", m.end())
    struct = code[code.index("struct CellglResult"):]
    struct = struct[:struct.index("};")]
    n = int(re.search(r"float F\[(\d+)\]", struct).group(1))
    body = ["    CellglResult r;", "    r.loops = loops;"]
    for k in range(n):
        body.append(f"    r.F[{k}] = f.x * {k + 1}.0 + f.y;")
        if "delta[" in struct:
            body.append(f"    r.delta[{k}] = f.yxzw * {k + 1}.0 - 0.5;")
        if "id[" in struct:
            body.append(f"    r.id[{k}] = uint(cell.x * {k + 3} + cell.y);")
    body.append("    return r;")
    return code[:m.end()] + "\n".join(body) + code[end:]


def rows(names: list[str], compare: str | None = None, stub: bool = False):
    """``[(label, fragment shader, is an older version)]``: the compact reference first."""
    from cellgl.export import snippets
    from cellgl.export.basis import basis_export
    from cellgl.recipes import list_presets, load_recipe

    def code(text):
        return text.split("\n\n", 1)[1]

    out = [("compact 3x3 jitter F1 (approximate)", frag_shader(COMPACT, "vec4(vec3(bench_f1(uv * 8.0)), 1.0)"), False)]
    basis = [("basis f1, jitter", "f1", dict(distribution="jitter")),
             ("basis f1, poisson", "f1", {}),
             ("basis f1f2, poisson", "f1f2", {}),
             ("basis edge, poisson", "edge", {})]
    for label, b, kw in basis:
        if not names or b in names:
            call = {"f1": "vec4(vec3(cellgl_f1(uv * 8.0)), 1.0)",
                    "f1f2": "vec4(cellgl_f1f2(uv * 8.0), 0.0, 1.0)",
                    "edge": "vec4(vec3(cellgl_edge(uv * 8.0)), 1.0)"}[b]
            out.append((label, frag_shader(code(basis_export(b, 2, "glsl", **kw)), call), False))
            old = os.path.join(compare, f"basis-{b}" + ("-jitter" if kw else "") + ".glsl") if compare else None
            if old and os.path.exists(old):
                with open(old, encoding="utf-8") as f:
                    out.append((f"{label} ({old})", frag_shader(code(f.read()), call), True))
    presets = [n for n, _ in list_presets() if not n.startswith("pups-")
               and load_recipe(n).values["cell_color"] != "image"
               and load_recipe(n).values["density_map"] != "image"]
    recipes = [("f1, distribution=jitter", load_recipe("f1").set_from_strings(["distribution=jitter"]))]
    recipes += [(n, load_recipe(n)) for n in presets]
    for label, r in recipes:
        if names and label.split(",")[0] not in names:
            continue
        text = code(snippets.export(r, "glsl"))
        out.append((label, frag_shader(text, "cellgl_texture(uv)"), False))
        old = os.path.join(compare, label.replace(", distribution=", "-") + ".glsl") if compare else None
        if old and os.path.exists(old):
            with open(old, encoding="utf-8") as f:
                out.append((f"{label} ({old})", frag_shader(code(f.read()), "cellgl_texture(uv)"), True))
        stubbed = stub_search(text) if stub else None
        if stubbed:
            out.append((f"{label}, search stubbed", frag_shader(stubbed, "cellgl_texture(uv)"), False))
    return out


def ratios(times: list[list[float]], old: list[bool]) -> list[tuple[float, float | None]]:
    """Per row: its median time over the compact snippet's (row 0), and, for a row followed by
    its older version (``old[k + 1]``), the median per-round speed ratio to that version, the
    two rendered one after the other (else None)."""
    ref = statistics.median(times[0])
    out = []
    for k, t in enumerate(times):
        vs_old = None
        if k + 1 < len(times) and old[k + 1] and not old[k]:
            vs_old = statistics.median(o / n for o, n in zip(times[k + 1], t))
        out.append((ref / statistics.median(t), vs_old))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", help="presets / basis names (default: all)")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--compare", metavar="DIR", default=None,
                    help="also time DIR/PRESET.glsl (GLSL snippets of the same presets exported by "
                    "another cellgl version; f1 with distribution=jitter: DIR/f1-jitter.glsl; "
                    "the 2D basis snippets: DIR/basis-NAME.glsl, DIR/basis-f1-jitter.glsl)")
    ap.add_argument("--stub-search", action="store_true",
                    help="also time each texture snippet with its cellular search stubbed out")
    args = ap.parse_args(argv)

    from cellgl.gl import context

    ctx = context.get_context()
    S = args.size
    tex = ctx.texture((S, S), 4)
    fbo = ctx.framebuffer(color_attachments=[tex])
    progs = []
    table = rows(args.names, args.compare, args.stub_search)
    for label, frag, _ in table:
        prog = ctx.program(vertex_shader=VERT, fragment_shader=frag)
        prog["size"].value = (float(S), float(S))
        progs.append((label, prog, ctx.vertex_array(prog, [])))

    def render(vao):
        fbo.use()
        vao.render(mode=ctx.TRIANGLES, vertices=3)
        fbo.read(components=1)          # waits for the frame (a 1 MB read-back)

    for _, _, vao in progs:             # warm-up: compiles the shader
        render(vao)
    def timed(vao):
        t0 = time.perf_counter()
        render(vao)
        return time.perf_counter() - t0

    # The compact snippet is rendered before every row, not once per round, so that its time
    # (the median of all those renders) samples the load over the whole run like the rows do.
    times = [[] for _ in progs]
    for _ in range(args.repeats):
        for k, (_, _, vao) in enumerate(progs):
            if k:
                times[0].append(timed(progs[0][2]))
                times[k].append(timed(vao))
    med = [statistics.median(t) for t in times]
    rel = ratios(times, [old for _, _, old in table])
    load = os.getloadavg()
    print(f"{S}x{S} fragment shader, median of {args.repeats}; load average {load[0]:.2f} "
          f"{load[1]:.2f} {load[2]:.2f}; {ctx.info.get('GL_RENDERER', '?')}")
    cmp = args.compare is not None
    print("| snippet | Mpx/s | ratio to compact |" + (" new / old |" if cmp else ""))
    print("| --- | ---: | ---: |" + (" ---: |" if cmp else ""))
    for (label, _, _), t, (r, vs_old) in zip(progs, med, rel):
        extra = (f" {vs_old:.2f} |" if vs_old is not None else " |") if cmp else ""
        print(f"| {label} | {S * S / t / 1e6:.1f} | {r:.2f} |{extra}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
