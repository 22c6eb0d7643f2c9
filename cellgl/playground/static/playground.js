// cellgl playground: every texture preset in the browser (written by `cellgl playground -o DIR`).
//
// The shaders are cellgl's exported snippets (GLSL ES with uniforms, one variant per set of
// compile-time choices, data in variants/*.js); this file sets their cellgl_<name> uniforms
// from the sliders, computing the derived ones as cellgl's Python does (cellgl/texture/shader.py
// uniform_values): the Poisson table, the split origins, the stretch weights, the orbit turn
// and the octave mean (measured on the GPU with the same 4096 points). The browser tests
// (tests/test_playground.py) hold every canvas to `cellgl bake`.
"use strict";
(function () {
  const SITE = window.CELLGL_SITE;
  const C = SITE.consts;
  const P = {};
  SITE.params.forEach((p) => { P[p.name] = p; });
  const PRESETS = {};
  SITE.presets.forEach((p) => { PRESETS[p.name] = p; });
  const $ = (id) => document.getElementById(id);

  // ------------------------------------------------------------------ the Python, ported
  // Python's round(): half to even (int(round(x)) in cellgl/texture/reference.py).
  function pyRound(x) {
    const f = Math.floor(x), d = x - f;
    if (d > 0.5) return f + 1;
    if (d < 0.5) return f;
    return f % 2 === 0 ? f : f + 1;
  }
  const TWO32 = 4294967296, TWO31 = 2147483648;
  const wrapI32 = (c) => ((((c + TWO31) % TWO32) + TWO32) % TWO32) - TWO31;

  // cellgl.basis.population.poisson_thresholds
  function poissonThresholds(density) {
    const out = [];
    let cdf = 0, logFact = 0;
    for (let k = 0; k < C.max_points; k++) {
      if (k > 0) logFact += Math.log(k);
      cdf += Math.exp(-density + k * Math.log(density) - logFact);
      out.push(Math.min(Math.floor(Math.min(cdf, 1) * TWO32), 0xFFFFFFFF));
    }
    return out;
  }
  // cellgl.basis.reference.axis_scale over the recipe's dimension (cellgl.texture.domain)
  function axisScale(v) {
    const dim = Math.min(v.dimension, 3);
    const s = [v.stretch_x, v.stretch_y, v.stretch_z].slice(0, dim);
    if (s.every((x) => x === 1)) return [1, 1, 1, 1];
    const g = Math.exp(s.reduce((a, x) => a + Math.log(x), 0) / dim);
    const out = s.map((x) => g / x);
    while (out.length < 4) out.push(1);
    return out;
  }
  // cellgl.basis.reference.orbit_turn: round(phase * 2^32) mod 2^32 (exact: a power-of-2 scale)
  function orbitTurn(phase) {
    const r = pyRound(phase * TWO32);
    return ((r % TWO32) + TWO32) % TWO32;
  }
  // cellgl.texture.antialias.feature_frequency
  function featureFrequency(v) {
    let density = v.density;
    if (v.distribution === "jitter" || v.distribution === "blender") density = 1;
    else if (v.distribution === "worley1996") density = 2.5;
    else if (v.density_map !== "none") density = v.density_max;
    const scale = v.distribution === "worley1996" ? C.w96 : 1;
    return scale * Math.pow(density, 1 / v.dimension);
  }
  function texturePeriod(v, octave) {
    if (!v.tileable) return [0, 0, 0, 0];
    const m = Math.pow(pyRound(v.lacunarity), octave);
    return [pyRound(v.frequency) * m, pyRound(v.frequency * v.aspect) * m, v.dimension >= 3 ? pyRound(v.frequency) * m : 0, 0];
  }
  // cellgl.texture.reference._split + shader.lattice_origins (float32 fraction, int32 cell)
  function split(x, per) {
    const cell = [], frac = [];
    for (let a = 0; a < 4; a++) {
      const fl = Math.floor(x[a]);
      let c = per[a] > 0 ? ((fl % per[a]) + per[a]) % per[a] : fl;
      let f = Math.fround(x[a] - fl);
      if (f >= 1) { c += 1; f = 0; }
      cell.push(wrapI32(c));
      frac.push(f);
    }
    return [cell, frac];
  }
  function latticeOrigins(v) {
    const O = [v.offset_x, v.offset_y, v.offset_z, v.time];
    for (let a = v.dimension; a < 4; a++) O[a] = 0;
    const ds = v.distribution === "worley1996" ? C.w96 : 1;
    const out = { origin_cell: [], origin_frac: [], noise_cell: [], noise_frac: [] };
    const nf = v.noise_frequency, nfi = pyRound(nf);
    for (let i = 0; i < C.max_octaves; i++) {
      const k = Math.pow(v.lacunarity, i);
      const per = texturePeriod(v, i);
      let [c, f] = split(O.map((o) => o * k * ds), per);
      out.origin_cell.push(c); out.origin_frac.push(f);
      [c, f] = split(O.map((o) => o * k * nf), per.map((p) => p * nfi));
      out.noise_cell.push(c); out.noise_frac.push(f);
    }
    const wf = v.warp_frequency;
    const [wc, wfr] = split(O.map((o) => o * wf), texturePeriod(v, 0).map((p) => p * pyRound(wf)));
    out.warp_cell = wc; out.warp_frac = wfr;
    return out;
  }
  // cellgl.texture.recipe.needed_n
  function neededN(v) {
    let n = 1;
    for (let i = 1; i <= 8; i++) if (v["c" + i] !== 0) n = Math.max(n, i);
    for (let i = 1; i <= 4; i++) for (let j = 1; j <= 4; j++) if (v["c" + i + j] !== 0) n = Math.max(n, i, j);
    return n;
  }
  // cellgl.texture.params.inactive: which parameters change nothing now, and what turns each on.
  // The rules are data (SITE.active_when: cellgl.texture.params.ACTIVE_WHEN); this evaluates
  // them and words the reasons as the Python does (held to it by tests/test_playground.py).
  function holds(v, name, op, arg) {
    const x = name in v ? v[name] : P[name].default;
    if (op === "in") return arg.includes(x);
    if (op === "not in") return !arg.includes(x);
    if (op === "!=") return x !== arg;
    if (op === ">") return x > arg;
    if (op === ">=") return x >= arg;
    throw new Error("active_when: unknown operator " + op);
  }
  function say(name, op, arg) {
    if (op === "in") return name + " " + arg.join(" or ");
    if (op === "not in") return name + " other than " + arg.join(" or ");
    if (op === "!=" && arg === 0) return name + " not 0";
    if (op === ">=") return name + " " + arg + " or more";
    return name + " " + op + " " + arg;
  }
  function inactive(v) {
    const out = {};
    SITE.params.forEach((p) => {
      const reqs = SITE.active_when[p.name];
      if (!reqs) return;
      const unmet = reqs.filter((req) => !req.some((a) => holds(v, a[0], a[1], a[2])));
      if (unmet.length) out[p.name] = "needs " + unmet.map((req) => req.map((a) => say(a[0], a[1], a[2])).join(" or ")).join(", and ");
    });
    return out;
  }
  // cellgl.texture.shader.defines: the macros that pick a variant (cellgl.playground.variants.KEY_MACROS)
  function variantKey(v) {
    const as = axisScale(v).slice(0, v.dimension);
    const ratio = Math.max(...as) / Math.min(...as);
    const dmap = { none: 0, ramp_x: 1, ramp_y: 1, radial: 2, image: 3 }[v.density_map];
    const d = {
      CELL_DIM: v.dimension, CELL_N: neededN(v), CELL_METRIC: P.metric.choices.indexOf(v.metric),
      CELL_DIST: P.distribution.choices.indexOf(v.distribution),
      CELL_MAX_RING: Math.min(64, SITE.consts.max_ring[v.dimension] * Math.ceil(ratio - 1e-9)),
      CELL_PERIODIC: v.tileable ? 1 : 0, CELL_DENSITY_MAP: dmap, CELL_ORBIT: v.orbit_radius > 0 ? 1 : 0,
      CELL_ANISO: as.some((x) => x !== 1) ? 1 : 0, CELL_EDGE: v.c_edge !== 0 ? 1 : 0,
      CELL_SMOOTH: v.smoothness > 0 && (v.c_smooth !== 0 || v.cell_mix !== 0) ? (v.smooth === "polynomial" ? 2 : 1) : 0,
      CELL_NSPHERE: v.c_nsphere !== 0 ? 1 : 0, CELL_TEX_CELL_IMAGE: v.cell_color === "image" ? 1 : 0,
    };
    return SITE.key_macros.map((k) => k + "=" + d[k]).join(",");
  }
  // cellgl.texture.shader.uniform_values (without the octave mean: measured by meanProbe)
  function uniformValues(v, ramp, fixed) {
    const u = {};
    SITE.params.forEach((p) => {
      if (p.compile_time || p.derived) return;
      let x = v[p.name];
      if (p.type === "enum") x = p.choices.indexOf(x);
      else if (p.type === "bool") x = x ? 1 : 0;
      u[p.name] = x;
    });
    u.thresholds = poissonThresholds(v.density);
    const keys = ramp.map((k) => [k[1], k[2], k[3], k[0]]);
    while (keys.length < C.ramp_keys) keys.push(keys[keys.length - 1]);
    u.ramp = keys; u.ramp_count = ramp.length;
    u.dist_scale = v.distribution === "worley1996" ? C.w96 : 1;
    u.feature_frequency = featureFrequency(v);
    u.orbit_turn = orbitTurn(v.orbit_phase);
    u.axis_scale = axisScale(v);
    Object.assign(u, latticeOrigins(v), fixed || {});
    return u;
  }

  // cellgl.texture.recipe._check and domain.check: the rules between parameters, as warnings
  // (the page still renders; the copied command would report the error)
  function problems(v, ramp) {
    const out = [];
    const integral = (x) => Math.abs(x - Math.round(x)) <= 1e-6 && Math.round(x) >= 1;
    if (v.min_points > v.max_points) out.push("min_points exceeds max_points");
    if (v.distribution === "worley1996" && v.dimension !== 3) out.push("worley1996 needs dimension 3");
    if (!(v.range_hi > v.range_lo)) out.push("range_hi must exceed range_lo");
    if (!(v.level_hi > v.level_lo)) out.push("level_hi must exceed level_lo");
    if (v.distribution === "blender" && v.seed !== 0) out.push("blender points have no seed (seed 0)");
    if (v.smooth === "exp" && v.smoothness > 0.25) out.push("smoothness above 0.25 needs smooth polynomial");
    if (v.ramp_mode === "spline" && ramp.length < 4) out.push("spline ramp_mode needs at least 4 ramp keys");
    ["c_edge", "c_nsphere"].forEach((t) => {
      if (v[t] !== 0 && v.metric !== "euclidean") out.push(t + " needs metric euclidean");
    });
    if (v.density_map !== "none" && v.distribution !== "poisson") out.push("a density_map needs distribution poisson");
    if (v.density_map !== "none" && v.tileable) out.push("tileable is not available with a density_map");
    if (v.tileable) {
      if (v.distribution === "worley1996") out.push("tileable is not available with worley1996");
      if (!integral(v.frequency)) out.push("tileable: frequency must be a positive integer");
      if (!integral(v.frequency * v.aspect)) out.push("tileable: frequency * aspect must be a positive integer");
      if (v.fractal !== "none" && !integral(v.lacunarity)) out.push("tileable: lacunarity must be an integer");
      if ((v.c_noise !== 0 || v.noise_color !== 0) && !integral(v.noise_frequency)) {
        out.push("tileable: noise_frequency must be an integer");
      }
      if (v.warp_amount !== 0 && !integral(v.warp_frequency)) out.push("tileable: warp_frequency must be an integer");
    }
    const stretched = axisScale(v).some((x) => x !== 1);
    const used = ["c_edge", "c_nsphere", "c_smooth"].filter((k) => v[k] !== 0);
    if (stretched && used.length) out.push(used[0] + " is not available with stretched cells");
    return out;
  }

  // ------------------------------------------------------------------ state
  const state = { preset: null, values: null, view: "2d", size: 256, renderer: "webgl2", t0: 0,
                  mean: null, meanKey: null, error: null, frameMs: 0 };
  const params = new URLSearchParams(location.search);
  if (params.get("size")) state.size = parseInt(params.get("size"), 10);

  // ------------------------------------------------------------------ variants (lazy <script src>)
  const waiting = {};
  window.cellglVariantLoaded = (id) => { (waiting[id] || []).forEach((f) => f()); delete waiting[id]; };
  function loadVariant(key) {
    const id = SITE.variants[key];
    if (!id) return Promise.resolve(null);
    if (window.CELLGL_VARIANTS[id]) return Promise.resolve(window.CELLGL_VARIANTS[id]);
    return new Promise((resolve, reject) => {
      const first = !waiting[id];
      (waiting[id] = waiting[id] || []).push(() => resolve(window.CELLGL_VARIANTS[id]));
      if (first) {
        const s = document.createElement("script");
        s.src = "variants/" + id + ".js";
        s.onerror = () => reject(new Error("cannot load variants/" + id + ".js"));
        document.head.appendChild(s);
      }
    });
  }

  // ------------------------------------------------------------------ WebGL2
  const canvas = $("view");
  const gl = canvas.getContext("webgl2", { preserveDrawingBuffer: true, antialias: false, premultipliedAlpha: false });
  const programs = {};
  const VS = "#version 300 es\nin vec2 p;\nvoid main() { gl_Position = vec4(p, 0.0, 1.0); }\n";
  const FS_MAIN = `
uniform highp vec4 pg_view;        // (width, height, tiles, probe)
uniform highp sampler2D pg_points; // the mean probe's points (xyz), one per pixel
out highp vec4 pg_color;
void main()
{
    vec2 px = floor(gl_FragCoord.xy);
    if (pg_view.w > 0.5) {
        pg_color = cellgl_playground_probe(texelFetch(pg_points, ivec2(px), 0).xyz);
        return;
    }
    vec2 xy = vec2(px.x, pg_view.y - 1.0 - px.y);     // image row 0 at the top, as a bake
    vec2 uv = fract((xy + 0.5) * pg_view.z / pg_view.xy);
    pg_color = cellgl_texture_filtered(uv, pg_view.z / pg_view.xy);
}
`;
  function compile(type, src) {
    const s = gl.createShader(type);
    gl.shaderSource(s, src);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s) || "compile failed");
    return s;
  }
  function link(fragSource) {
    const prog = gl.createProgram();
    gl.attachShader(prog, compile(gl.VERTEX_SHADER, VS));
    gl.attachShader(prog, compile(gl.FRAGMENT_SHADER, fragSource));
    gl.bindAttribLocation(prog, 0, "p");
    gl.linkProgram(prog);
    if (!gl.getProgramParameter(prog, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(prog) || "link failed");
    return prog;
  }
  // "16 * 16" -> 256 (array sizes the exporter writes as products)
  const arrayLength = (s) => s.split("*").reduce((a, x) => a * parseInt(x, 10), 1);
  // The uniform declarations of a snippet: {name: [type, array length or 0]}
  function uniformDecls(text) {
    const out = {};
    const re = /^uniform (?:highp )?(\w+) cellgl_(\w+)(?:\[([\d *]+)\])?;$/gm;
    let m;
    while ((m = re.exec(text))) out[m[2]] = [m[1], m[3] ? arrayLength(m[3]) : 0];
    return out;
  }
  function programFor(variant) {
    if (!programs[variant.id]) {
      const src = "#version 300 es\nprecision highp float;\nprecision highp int;\n" + variant.live + FS_MAIN;
      const prog = link(src);
      programs[variant.id] = { prog, decls: uniformDecls(variant.live), loc: {} };
    }
    return programs[variant.id];
  }
  function setUniforms(gp, u) {
    for (const [name, [type, n]] of Object.entries(gp.decls)) {
      if (!(name in u)) continue;
      let loc = gp.loc[name];
      if (loc === undefined) loc = gp.loc[name] = gl.getUniformLocation(gp.prog, "cellgl_" + name);
      if (loc === null) continue;
      const x = u[name];
      const flat = n ? [].concat(...x.slice(0, n).map((e) => [].concat(e))) : [].concat(x);
      if (type === "float") gl.uniform1fv(loc, flat);
      else if (type === "int") gl.uniform1iv(loc, flat);
      else if (type === "uint") gl.uniform1uiv(loc, new Uint32Array(flat));
      else if (type === "vec3") gl.uniform3fv(loc, flat);
      else if (type === "vec4") gl.uniform4fv(loc, flat);
      else if (type === "ivec4") gl.uniform4iv(loc, new Int32Array(flat));
      else throw new Error("uniform type " + type + " of cellgl_" + name);
    }
  }
  const quad = gl.createBuffer();
  gl.bindBuffer(gl.ARRAY_BUFFER, quad);
  gl.bufferData(gl.ARRAY_BUFFER, new Float32Array([-1, -1, 3, -1, -1, 3]), gl.STATIC_DRAW);
  function draw(gp, view) {
    gl.useProgram(gp.prog);
    gl.uniform4fv(gl.getUniformLocation(gp.prog, "pg_view"), view);
    gl.uniform1i(gl.getUniformLocation(gp.prog, "pg_points"), 0);
    gl.bindBuffer(gl.ARRAY_BUFFER, quad);
    gl.enableVertexAttribArray(0);
    gl.vertexAttribPointer(0, 2, gl.FLOAT, false, 0, 0);
    gl.drawArrays(gl.TRIANGLES, 0, 3);
  }

  // The octave mean (cellgl.texture.reference.octave_mean): octave 0's term averaged over the
  // same 4096 points, measured with the recipe's own shader.
  const MEAN_SIDE = 64;
  const pointTex = {};
  function pointsTexture(name) {
    if (!pointTex[name]) {
      const bytes = Uint8Array.from(atob(SITE.mean_points[name]), (c) => c.charCodeAt(0));
      const t = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, t);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, MEAN_SIDE, MEAN_SIDE, 0, gl.RGBA, gl.FLOAT, new Float32Array(bytes.buffer));
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
      pointTex[name] = t;
    }
    return pointTex[name];
  }
  let meanTarget = null;
  async function octaveMean(v, ramp, fixed) {
    let probe, points;
    if (v.density_map !== "none") {
      probe = Object.assign({}, v, { fractal: "none" });
      points = "uv";
    } else {
      probe = Object.assign({}, v, { tileable: false, fractal: "none", frequency: 1, aspect: 1, offset_x: 0,
                                     offset_y: 0, offset_z: 0, time: 0 });
      points = v.dimension === 2 ? "plane" : "solid";
    }
    const variant = await loadVariant(variantKey(probe));
    if (!variant) return null;
    const gp = programFor(variant);
    if (!meanTarget) {
      const tex = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, tex);
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, MEAN_SIDE, MEAN_SIDE, 0, gl.RGBA, gl.UNSIGNED_BYTE, null);
      meanTarget = gl.createFramebuffer();
      gl.bindFramebuffer(gl.FRAMEBUFFER, meanTarget);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, tex, 0);
    }
    gl.bindFramebuffer(gl.FRAMEBUFFER, meanTarget);
    gl.viewport(0, 0, MEAN_SIDE, MEAN_SIDE);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, pointsTexture(points));
    gl.useProgram(gp.prog);
    setUniforms(gp, uniformValues(probe, ramp, fixed));
    draw(gp, [MEAN_SIDE, MEAN_SIDE, 1, 1]);
    const bytes = new Uint8Array(MEAN_SIDE * MEAN_SIDE * 4);
    gl.readPixels(0, 0, MEAN_SIDE, MEAN_SIDE, gl.RGBA, gl.UNSIGNED_BYTE, bytes);
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    const vals = new Float32Array(bytes.buffer);
    const qin = v.fractal === "qin" || v.fractal === "qin_cube";
    let sum = 0;
    for (let i = 0; i < vals.length; i++) {
      let b = (vals[i] - v.range_lo) / (v.range_hi - v.range_lo);
      b = Math.min(Math.max(b, 0), 1);
      if (Number.isNaN(b)) b = 1;
      sum += qin ? Math.abs(0.5 - b) : b;
    }
    return Math.fround(sum / vals.length);
  }
  function meanKey(v) {
    const names = SITE.params.filter((p) => p.group === "basis" || p.group === "combination").map((p) => p.name);
    const k = names.map((n) => v[n]);
    k.push(v.fractal === "qin" || v.fractal === "qin_cube");
    if (v.density_map !== "none") k.push(v.frequency, v.aspect, v.offset_x, v.offset_y, v.offset_z, v.time);
    return JSON.stringify(k);
  }

  // ------------------------------------------------------------------ rendering
  function frameValues() {
    const v = Object.assign({}, state.values);
    if (state.view === "anim") {
      const t = (performance.now() - state.t0) / 1000;
      if (v.orbit_radius > 0) v.orbit_phase = Math.round((v.orbit_phase + t / 4) * 1000) / 1000;
      else if (v.dimension === 4) v.time = Math.round((v.time + t * 0.25) * 1000) / 1000;
      else if (v.dimension === 3) v.offset_z = Math.round((v.offset_z + t * 0.1) * 1000) / 1000;
      else v.offset_x = Math.round((v.offset_x + t * 0.25) * 1000) / 1000;
    }
    return v;
  }
  let pending = false, busy = false;
  function requestRender() {
    pending = true;
    if (!busy) renderLoop();
  }
  async function renderLoop() {
    busy = true;
    while (pending) {
      pending = false;
      try { await renderOnce(); state.error = null; } catch (e) { state.error = String(e.message || e); }
      showStatus();
    }
    busy = false;
    if (state.view === "anim") requestAnimationFrame(requestRender);
  }
  async function renderOnce() {
    const pre = PRESETS[state.preset];
    const v = frameValues();
    state.shown = v;
    const key = variantKey(v);
    const variant = await loadVariant(key);
    if (!variant) {
      state.missing = key;
      $("notice").hidden = false;
      $("notice").textContent = "This combination of compile-time choices needs a shader variant this page " +
        "does not ship (it has each preset's variant and those one choice away). The command below renders it.";
      updateCopy(v, null);
      return;
    }
    state.missing = null;
    state.problems = problems(v, pre.ramp);
    $("notice").hidden = !state.problems.length;
    $("notice").textContent = state.problems.length ? "cellgl would refuse these values: " +
      state.problems.join("; ") + "." : "";
    const mk = meanKey(v);
    if (state.meanKey !== mk) {
      state.mean = await octaveMean(v, pre.ramp, pre.fixed_uniforms);
      if (state.mean === null) state.mean = pre.octave_mean;
      state.meanKey = mk;
    }
    const u = uniformValues(v, pre.ramp, pre.fixed_uniforms);
    u.octave_mean = state.mean;
    state.uniforms = u;
    state.variant = variant;
    const gp = programFor(variant);
    const t = performance.now();
    canvas.width = canvas.height = state.size;
    gl.bindFramebuffer(gl.FRAMEBUFFER, null);
    gl.viewport(0, 0, state.size, state.size);
    gl.useProgram(gp.prog);
    setUniforms(gp, u);
    draw(gp, [state.size, state.size, state.view === "tiled" ? 3 : 1, 0]);
    gl.finish();
    state.frameMs = performance.now() - t;
    state.rendered = (state.rendered || 0) + 1;
    updateCopy(v, variant);
    if (state.renderer === "webgpu") await renderWebGPU();
  }

  // ------------------------------------------------------------------ snippets
  function fmtF(x) {
    if (!Number.isFinite(x)) throw new Error("value " + x + " is not finite");
    let s = String(x);
    if (s.includes("e")) s = x.toExponential(9);
    else if (!s.includes(".")) s += ".0";
    return s;
  }
  const SCALAR = { float: fmtF, int: (x) => String(x), uint: (x) => x + "u" };
  function glslValue(type, x, hlsl) {
    if (SCALAR[type]) return SCALAR[type](x);
    const base = type.replace(/\d$/, "");
    const ctor = hlsl ? { vec: "float", ivec: "int" }[base] + type.slice(-1) : type;
    const el = base === "ivec" ? SCALAR.int : SCALAR.float;
    return ctor + "(" + x.map(el).join(", ") + ")";
  }
  const HLSL_TYPES = { float: "float", int: "int", uint: "uint", vec3: "float3", vec4: "float4", ivec4: "int4",
                       float3: "vec3", float4: "vec4", int4: "ivec4" };
  // The uniform declarations of a GLSL ES, Godot or HLSL snippet as constants of the current values.
  function constify(text, dialect, u) {
    return text.replace(/^uniform (highp )?(\w+) cellgl_(\w+)(\[([\d *]+)\])?;$/gm, (m, hp, type, name, arr, size) => {
      if (!(name in u)) return m;
      const n = size ? arrayLength(size) : 0;
      const gt = dialect === "hlsl" ? HLSL_TYPES[type] : type;
      const val = (x) => glslValue(gt, x, dialect === "hlsl");
      if (dialect === "hlsl") {
        if (n) return `static const ${type} cellgl_${name}[${n}] = {${u[name].slice(0, n).map(val).join(", ")}};`;
        return `static const ${type} cellgl_${name} = ${val(u[name])};`;
      }
      const q = hp || "";
      if (n) return `const ${q}${type} cellgl_${name}[${n}] = ${type}[${n}](${u[name].slice(0, n).map(val).join(", ")});`;
      return `const ${q}${type} cellgl_${name} = ${val(u[name])};`;
    });
  }
  function wgslValue(type, x) {
    let m;
    if ((m = /^array<(.+), ([\d *]+)>$/.exec(type))) {
      return `${type}(${x.slice(0, arrayLength(m[2])).map((e) => wgslValue(m[1], e)).join(", ")})`;
    }
    if ((m = /^vec(\d)<(\w+)>$/.exec(type))) return `${type}(${x.map((e) => wgslValue(m[2], e)).join(", ")})`;
    if (type === "f32") return fmtF(x);
    if (type === "u32") return x + "u";
    if (type === "i32") return String(x);
    throw new Error("WGSL type " + type);
  }
  function wgslConsts(text, u) {
    return text.replace(/^const cellgl_(\w+): ([^=]+) = .*;$/gm, (m, name, type) =>
      name in u ? `const cellgl_${name}: ${type} = ${wgslValue(type.trim(), u[name])};` : m);
  }
  function setList(v) {
    const base = PRESETS[state.preset].values;
    const out = [];
    SITE.params.forEach((p) => {
      const x = v[p.name];
      if (x === base[p.name]) return;
      out.push(p.name + "=" + (p.type === "bool" ? (x ? "true" : "false") : String(x)));
    });
    return out;
  }
  function header(target, v) {
    const sets = setList(v).map((s) => " --set " + s).join("");
    const source = PRESETS[state.preset].source || state.preset;
    return `// cellgl ${SITE.version} playground: '${state.preset}'${sets ? " with" + sets : ""}.\n` +
      `// The same pixels as \`cellgl bake ${source}${sets}\`; the exporter's own version (with the\n` +
      `// recipe in its header): \`cellgl export ${source} --target ${target}${sets}\`.\n` +
      `// Entry points: cellgl_texture(uv) (fragment shaders) and cellgl_texture_filtered(uv, duv);\n` +
      `// uv in [0, 1]^2, v = 0 the top row; duv the pixel's size in uv.\n\n`;
  }
  function snippet(target, v, variant, u) {
    if (target === "gles") return header("gles", v) + constify(variant.gles, "gles", u);
    if (target === "godot") return header("godot", v) + constify(variant.godot, "godot", u);
    if (target === "hlsl") return header("hlsl", v) + constify(variant.hlsl, "hlsl", u);
    if (target === "wgsl") return header("wgsl", v) + wgslConsts(variant.wgsl, u);
    if (target === "threejs") {
      const frag = constify(variant.gles, "gles", u) + "\nin vec2 vUv;\nout vec4 cellgl_color;\n\nvoid main()\n{\n" +
        "    cellgl_color = cellgl_texture(vec2(vUv.x, 1.0 - vUv.y));\n}\n";
      const esc = (t) => t.replace(/\\/g, "\\\\").replace(/`/g, "\\`").replace(/\$\{/g, "\\${");
      return header("gles", v) +
        "import * as THREE from \"three\";\n\n" +
        "// A ShaderMaterial (GLSL ES 3.00) showing the texture on any mesh's uv, image row 0 at v = 1.\n" +
        "export const cellglMaterial = new THREE.ShaderMaterial({\n" +
        "  glslVersion: THREE.GLSL3,\n" +
        "  vertexShader: `out vec2 vUv;\nvoid main()\n{\n    vUv = uv;\n" +
        "    gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0);\n}\n`,\n" +
        "  fragmentShader: `" + esc(frag) + "`,\n});\n";
    }
    throw new Error("unknown target " + target);
  }
  function bakeCommand(v) {
    const sz = state.size;
    const quote = (s) => (/^[\w.,=:+\/-]+$/.test(s) ? s : "'" + s.replace(/'/g, "'\\''") + "'");
    const source = PRESETS[state.preset].source || state.preset;
    return ["cellgl", "bake", quote(source), "-o", state.preset + ".png", "--size", sz + "x" + sz]
      .concat(...setList(v).map((s) => ["--set", quote(s)])).join(" ");
  }
  let codeTarget = "gles";
  function updateCopy(v, variant) {
    $("command").textContent = bakeCommand(v);
    if (variant && $("code-box").open) {
      $("code").textContent = snippet(codeTarget, v, variant, state.uniforms);
      $("code-title").textContent = codeTarget;
    }
  }
  async function copyText(text) {
    try { await navigator.clipboard.writeText(text); return true; } catch (e) {
      const ta = document.createElement("textarea");
      ta.value = text; document.body.appendChild(ta); ta.select();
      let ok = false;
      try { ok = document.execCommand("copy"); } catch (e2) { ok = false; }
      ta.remove();
      return ok;
    }
  }

  // ------------------------------------------------------------------ WebGPU (the WGSL snippet)
  let gpu = null;
  async function initWebGPU() {
    if (!navigator.gpu) { $("webgpu").textContent = "WebGPU: not in this browser"; return; }
    try {
      const adapter = await navigator.gpu.requestAdapter();
      if (!adapter) throw new Error("no adapter");
      const device = await adapter.requestDevice();
      gpu = { device, cache: {} };
      $("use-webgpu").disabled = false;
      $("webgpu").textContent = "WebGPU: available";
      $("webgpu").classList.remove("dim");
    } catch (e) {
      $("webgpu").textContent = "WebGPU: " + e.message;
    }
  }
  // The WGSL snippet (the current values as constants) drawn over a full-screen triangle into
  // `view` (a texture view of `format`), like the WebGL2 canvas.
  async function drawWebGPU(variant, format, view) {
    const n = (state.view === "tiled" ? 3 : 1) / state.size;
    const code = wgslConsts(variant.wgsl, state.uniforms) + `
@vertex fn pg_vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let p = array<vec2<f32>, 3>(vec2<f32>(-1.0, -1.0), vec2<f32>(3.0, -1.0), vec2<f32>(-1.0, 3.0));
    return vec4<f32>(p[i], 0.0, 1.0);
}
@fragment fn pg_fs(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let n = ${fmtF(n)};
    let uv = fract((floor(pos.xy) + vec2<f32>(0.5)) * n);
    return cellgl_texture_filtered(uv, vec2<f32>(n, n));
}
`;
    const key = format + "\n" + code;
    let pipeline = gpu.cache[key];
    if (!pipeline) {
      const module = gpu.device.createShaderModule({ code });
      const info = await module.getCompilationInfo();
      const err = info.messages.find((m) => m.type === "error");
      if (err) throw new Error("WGSL: " + err.message + " (line " + err.lineNum + ")");
      pipeline = await gpu.device.createRenderPipelineAsync({
        layout: "auto", vertex: { module, entryPoint: "pg_vs" },
        fragment: { module, entryPoint: "pg_fs", targets: [{ format }] },
        primitive: { topology: "triangle-list" } });
      gpu.cache = { [key]: pipeline };      // keep one: every slider move is a new module
    }
    const enc = gpu.device.createCommandEncoder();
    const pass = enc.beginRenderPass({ colorAttachments: [{ view, loadOp: "clear", storeOp: "store",
                                                            clearValue: [0, 0, 0, 1] }] });
    pass.setPipeline(pipeline);
    pass.draw(3);
    pass.end();
    return enc;
  }
  // The WebGPU view: rendered offscreen, read back and shown on a 2D canvas (the same bytes the
  // tests compare; works in headless browsers, which may not present WebGPU canvases)
  async function renderWebGPU() {
    const c = $("gpuview");
    c.width = c.height = state.size;
    const bytes = await webgpuBytes();
    c.getContext("2d").putImageData(new ImageData(new Uint8ClampedArray(bytes.buffer), state.size, state.size), 0, 0);
  }
  // RGBA bytes of the WebGPU rendering (rows from the top), as pixels() for the WebGL2 canvas
  async function webgpuBytes() {
    const size = state.size, row = Math.ceil(size * 4 / 256) * 256;
    const tex = gpu.device.createTexture({ size: [size, size], format: "rgba8unorm",
      usage: GPUTextureUsage.RENDER_ATTACHMENT | GPUTextureUsage.COPY_SRC });
    const buf = gpu.device.createBuffer({ size: row * size, usage: GPUBufferUsage.COPY_DST | GPUBufferUsage.MAP_READ });
    const enc = await drawWebGPU(state.variant, "rgba8unorm", tex.createView());
    enc.copyTextureToBuffer({ texture: tex }, { buffer: buf, bytesPerRow: row }, [size, size]);
    gpu.device.queue.submit([enc.finish()]);
    await buf.mapAsync(GPUMapMode.READ);
    const src = new Uint8Array(buf.getMappedRange());
    const out = new Uint8Array(size * size * 4);
    for (let y = 0; y < size; y++) out.set(src.subarray(y * row, y * row + size * 4), y * size * 4);
    buf.unmap();
    tex.destroy();
    buf.destroy();
    return out;
  }
  const base64 = (bytes) => {
    let s = "";
    for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
    return btoa(s);
  };

  // ------------------------------------------------------------------ UI
  function decimals(p) {
    if (p.type === "int" || p.type === "enum" || p.type === "bool") return 0;
    const r = p.soft[1] - p.soft[0];
    return r > 100 ? 1 : r > 10 ? 2 : 3;
  }
  const controls = {};
  // density_map and cell_color need data only Python makes (the map's encoding, an image)
  const ALWAYS_FROZEN = ["density_map", "cell_color"];
  function frozen(name) {
    if (ALWAYS_FROZEN.includes(name)) return true;
    return state.values && state.values.density_map !== "none" && SITE.density_frozen.includes(name) &&
      PRESETS[state.preset].values.density_map !== "none";
  }
  function buildControls() {
    const groups = {};
    SITE.params.forEach((p) => {
      if (!groups[p.group]) {
        const d = document.createElement("details");
        d.open = ["basis", "combination", "fractal", "domain"].includes(p.group);
        d.innerHTML = `<summary>${p.group}</summary>`;
        groups[p.group] = d;
        $("groups").appendChild(d);
      }
      const row = document.createElement("div");
      row.className = "param";
      row.dataset.doc = p.doc + (p.compile_time ? " (compile-time: switches the shader variant)" : "");
      row.title = row.dataset.doc;
      const label = `<label for="p-${p.name}">${p.name}${p.compile_time ? ' <i class="ct">#</i>' : ""}</label>`;
      if (p.type === "enum" || p.type === "bool" || p.name === "dimension") {
        const opts = p.type === "enum" ? p.choices : p.type === "bool" ? ["false", "true"] : ["2", "3", "4"];
        row.innerHTML = label + `<select id="p-${p.name}" data-name="${p.name}">` +
          opts.map((o) => `<option>${o}</option>`).join("") + "</select>";
      } else {
        const step = p.type === "int" ? 1 : Math.pow(10, -decimals(p));
        row.innerHTML = label + `<input type="range" id="p-${p.name}" data-name="${p.name}" min="${p.soft[0]}" ` +
          `max="${p.soft[1]}" step="${step}"><input type="number" class="num" data-name="${p.name}" ` +
          `min="${p.lo}" max="${p.hi}" step="any" aria-label="${p.name} value">`;
      }
      groups[p.group].appendChild(row);
      controls[p.name] = row;
    });
    $("groups").addEventListener("input", (e) => {
      const name = e.target.dataset.name;
      if (!name) return;
      const p = P[name];
      let x = e.target.value;
      if (p.type === "bool") x = x === "true";
      else if (p.type === "enum") x = String(x);
      else {
        x = Number(x);
        if (!Number.isFinite(x)) return;
        if (p.type === "int" || p.name === "dimension") x = Math.round(x);
        x = Math.min(Math.max(x, p.lo), p.hi);
        if (e.target.type === "range") x = Number(x.toFixed(decimals(p)));
      }
      setValue(name, x, e.target);
    });
  }
  function setValue(name, x, from) {
    state.values[name] = x;
    syncControl(name, from);
    syncInactive();
    requestRender();
  }
  // grey out (and disable) what changes nothing now, as Blender's node hides such sockets; the
  // tooltip says what turns it on
  function syncInactive() {
    const off = inactive(state.values);
    Object.keys(controls).forEach((name) => {
      const row = controls[name], why = off[name];
      row.classList.toggle("inactive", !!why);
      row.title = why ? "inactive: " + why + "\n" + row.dataset.doc : row.dataset.doc;
      row.querySelectorAll("input, select").forEach((el) => { el.disabled = frozen(name) || !!why; });
    });
  }
  function syncControl(name, from) {
    const row = controls[name], p = P[name], x = state.values[name];
    row.classList.toggle("changed", x !== PRESETS[state.preset].values[name]);
    row.classList.toggle("frozen", frozen(name));
    row.querySelectorAll("input, select").forEach((el) => {
      el.disabled = frozen(name);
      if (el === from) return;
      el.value = p.type === "bool" ? String(x) : String(x);
    });
  }
  function selectPreset(name) {
    state.preset = name;
    state.values = Object.assign({}, PRESETS[name].values);
    state.meanKey = null;
    state.t0 = performance.now();
    $("preset-name").textContent = name;
    $("preset-doc").textContent = PRESETS[name].doc;
    document.querySelectorAll("#gallery .thumb").forEach((t) => t.classList.toggle("on", t.dataset.name === name));
    Object.keys(controls).forEach((n) => syncControl(n));
    syncInactive();
    if (history.replaceState) {
      const q = new URLSearchParams(location.search);
      q.set("preset", name);
      history.replaceState(null, "", "?" + q.toString());
    }
    requestRender();
  }
  function buildGallery() {
    const g = $("gallery");
    SITE.presets.forEach((p) => {
      const b = document.createElement("button");
      b.className = "thumb";
      b.dataset.name = p.name;
      b.title = p.doc;
      b.innerHTML = (p.thumb ? `<img src="${p.thumb}" alt="">` : '<span class="noimg"></span>') + `<span>${p.name}</span>`;
      b.addEventListener("click", () => selectPreset(p.name));
      g.appendChild(b);
    });
    $("filter").addEventListener("input", (e) => {
      const q = e.target.value.toLowerCase();
      g.querySelectorAll(".thumb").forEach((t) => {
        t.hidden = q && !(t.dataset.name + " " + PRESETS[t.dataset.name].doc).toLowerCase().includes(q);
      });
    });
    const refused = Object.keys(SITE.refused);
    const pups = refused.filter((n) => n.startsWith("pups-"));
    const other = refused.filter((n) => !n.startsWith("pups-"));
    let note = "";
    if (pups.length) note += `Not here: the ${pups.length} PUPs presets (pups-*): the snippet exporter refuses them ` +
      "(a snippet would need their control points and Delaunay axes as buffers); bake them with cellgl bake. ";
    other.forEach((n) => { note += `Not here: ${n} (${SITE.refused[n]}). `; });
    $("refused").textContent = note;
  }
  function showStatus() {
    const u = state.uniforms || {};
    const bits = [];
    if (state.error) bits.push("error: " + state.error);
    if (state.variant) bits.push("variant " + state.variant.id);
    if (state.mean !== null) bits.push("octave mean " + Number(state.mean).toFixed(5));
    bits.push(state.size + "\u00d7" + state.size + " in " + state.frameMs.toFixed(1) + " ms");
    if (u.thresholds) bits.push("n = " + neededN(state.values));
    $("status").textContent = bits.join(" \u00b7 ");
  }
  function bindToolbar() {
    $("views").addEventListener("click", (e) => {
      const b = e.target.closest("button");
      if (!b) return;
      state.view = b.dataset.view;
      state.t0 = performance.now();
      $("views").querySelectorAll("button").forEach((x) => x.classList.toggle("on", x === b));
      requestRender();
    });
    $("size").value = String(state.size);
    $("size").addEventListener("change", (e) => { state.size = parseInt(e.target.value, 10); requestRender(); });
    $("renderer").addEventListener("click", (e) => {
      const b = e.target.closest("button");
      if (!b || b.disabled) return;
      state.renderer = b.dataset.r;
      $("renderer").querySelectorAll("button").forEach((x) => x.classList.toggle("on", x === b));
      $("gpuview").hidden = state.renderer !== "webgpu";
      canvas.hidden = state.renderer === "webgpu";
      requestRender();
    });
    $("reset").addEventListener("click", () => selectPreset(state.preset));
    document.querySelector(".copyrow").addEventListener("click", async (e) => {
      const b = e.target.closest("button");
      if (!b) return;
      const target = b.dataset.copy;
      const text = api.copyText(target);
      if (target !== "bake") {
        codeTarget = target;
        $("code").textContent = text;
        $("code-title").textContent = target;
      }
      const ok = await copyText(text);
      $("copied").textContent = (ok ? "copied " : "select and copy: ") + (target === "bake" ? "the command" : target);
    });
    $("code-box").addEventListener("toggle", () => updateCopy(state.shown || state.values, state.variant));
  }

  // ------------------------------------------------------------------ API (the browser tests use it)
  const api = {
    presets: () => SITE.presets.map((p) => p.name),
    select(name) { selectPreset(name); return api.idle(); },
    async idle() {
      while (busy || pending) await new Promise((r) => setTimeout(r, 5));
      return api.state();
    },
    state() {
      return { preset: state.preset, view: state.view, size: state.size, error: state.error, missing: state.missing,
               variant: state.variant && state.variant.id, key: variantKey(state.values), mean: state.mean,
               sets: setList(state.shown || state.values), command: bakeCommand(state.shown || state.values),
               rendered: state.rendered || 0, problems: state.problems || [] };
    },
    inactive: (values) => inactive(Object.assign({}, state.values, values || {})),
    // RGBA bytes of the canvas, rows from the top, base64
    pixels() {
      const n = canvas.width, h = canvas.height;
      const px = new Uint8Array(n * h * 4);
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      gl.readPixels(0, 0, n, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
      const out = new Uint8Array(n * h * 4);
      for (let y = 0; y < h; y++) out.set(px.subarray((h - 1 - y) * n * 4, (h - y) * n * 4), y * n * 4);
      return base64(out);
    },
    webgpu: () => gpuReady.then(() => !!gpu),
    webgpuPixels: () => gpuReady.then(() => {
      if (!gpu) throw new Error("no WebGPU in this browser");
      return webgpuBytes().then(base64);
    }),
    copyText(target) {
      const v = state.shown || state.values;
      if (target === "bake") return bakeCommand(v);
      if (!state.variant || state.missing) throw new Error("no shader variant for these values");
      return snippet(target, v, state.variant, state.uniforms);
    },
    // compile a GLSL ES snippet (as copied) in a fresh program and render it like the canvas
    renderSnippet(text) {
      return api.renderFragment("#version 300 es\nprecision highp float;\nprecision highp int;\n" + text + `
uniform highp vec4 pg_view;
out highp vec4 pg_color;
void main()
{
    vec2 px = floor(gl_FragCoord.xy);
    vec2 xy = vec2(px.x, pg_view.y - 1.0 - px.y);
    pg_color = cellgl_texture_filtered((xy + 0.5) / pg_view.xy, 1.0 / pg_view.xy);
}
`);
    },
    // compile a whole fragment shader, draw it over the canvas, return the pixels
    renderFragment(src) {
      const prog = link(src);
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      gl.viewport(0, 0, canvas.width, canvas.height);
      draw({ prog }, [canvas.width, canvas.height, 1, 0]);
      gl.deleteProgram(prog);
      return api.pixels();
    },
  };
  window.cellglPlayground = api;

  // ------------------------------------------------------------------ start
  $("version").textContent = "cellgl " + SITE.version;
  if (!gl) {
    document.body.classList.add("nogl");
    $("notice").hidden = false;
    $("notice").textContent = "This browser has no WebGL2: the playground needs it.";
    return;
  }
  $("backend").textContent = "WebGL2 \u00b7 " + (gl.getParameter(gl.VERSION) || "");
  buildGallery();
  buildControls();
  bindToolbar();
  const gpuReady = initWebGPU();
  const first = params.get("preset");
  selectPreset(PRESETS[first] ? first : (PRESETS.flagstone ? "flagstone" : SITE.presets[0].name));
})();
