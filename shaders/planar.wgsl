// Close-up LOD methods on the tangent plane (planar module docs): geomipmapping's patches
// (geomipmapping-geomorphing.md), placed on the same terrain function as the clipmap's rings.
//
// Appended to terrain.wgsl (same module: the level textures, `place`, VertexOut, fs_main).
// A plane point (x, y) metres from the anchor goes to the sphere by the gnomonic map
// p̃ = normalise(a + e·x/R + n·y/R), with a, e, n the anchor and its axes in view space
// (f64 → f32 once per frame, planar::LocalFrame::view_basis); from p̃ on the vertex is a clipmap
// vertex: the level whose ring holds its θ̃, the map transform, the height with the coarser
// level's blend, the camera-relative position.

// Rust twin: render::gpu_data::PlanarUniforms.
struct PlanarUniforms {
    anchor: vec4<f32>,
    east: vec4<f32>,
    north: vec4<f32>,
    // The clipmap's fragments inside this square of the plane (min xy, max xy) are not drawn:
    // the planar mesh covers it (and a band beyond, where both draw the same surface).
    cut: vec4<f32>,
    spacing_m: f32,
    patch_cells: u32,
    skirt_m: f32,
    // 1 when a planar mode draws this frame (the clipmap then cuts its square out).
    drawing: u32,
    // The projected grid's cells per row and rows, its ray-march step in pixels' footprint
    // and λ, pixels per radian (eq. 3).
    grid_cols: u32,
    grid_rows: u32,
    ray_step_px: f32,
    px_per_rad: f32,
}

// Rust twin: render::gpu_data::PatchGpu. One geomipmapping patch of this frame.
struct PatchGpu {
    // Lattice coordinates of its south-west corner (units of spacing_m).
    corner: vec2<i32>,
    // Continuous level ℓ = k + tween factor (planar::geomip::continuous_level).
    level: f32,
    // Δφ of the patch's centre from the viewer's (coarse: it only picks the side of ±π).
    centre_dphi: f32,
    // Border levels ℓ_e (south, east, north, west).
    sides: vec4<f32>,
}

@group(1) @binding(0) var<uniform> planar: PlanarUniforms;
@group(1) @binding(1) var<storage, read> patches: array<PatchGpu>;
// Geomipmapping's triangle lists, read by the wireframe draw (vs_geomip_wire).
@group(1) @binding(2) var<storage, read> patch_indices: array<u32>;

// Plane coordinates of view-space unit vector u (the inverse of the gnomonic map); far from
// the anchor's hemisphere, a point no square contains.
fn plane_coords(u: vec3<f32>) -> vec2<f32> {
    let d = dot(u, planar.anchor.xyz);
    if d <= 1e-3 {
        return vec2<f32>(3.0e38);
    }
    return frame.radius_m * vec2<f32>(dot(u, planar.east.xyz), dot(u, planar.north.xyz)) / d;
}

// The clipmap's fragment lies in the square a planar mode draws.
fn in_planar_cut(q: vec2<f32>) -> bool {
    return planar.drawing != 0u && all(q > planar.cut.xy) && all(q < planar.cut.zw);
}

// A plane point as a clipmap vertex would place it.
struct PlanarPoint {
    p: vec3<f32>,
    one_minus_cos: f32,
    level: u32,
    at: Placed,
}

fn planar_point(q: vec2<f32>) -> PlanarPoint {
    let r = frame.radius_m;
    let p = normalize(planar.anchor.xyz + planar.east.xyz * (q.x / r) + planar.north.xyz * (q.y / r));
    let s2 = dot(p.xy, p.xy);
    // 1 − cos θ̃ = |p̃xy|²/(1 + p̃z): no cancellation (docs/design.md#numerics).
    return unit_point(p, s2 / (1.0 + p.z), atan2(sqrt(s2), p.z));
}

// View direction p̃ (with its 1 − cos θ̃ and θ̃ from the viewer) placed as a clipmap vertex
// would be: the level whose ring holds θ̃, the map transform, the height.
fn unit_point(p: vec3<f32>, one_minus_cos: f32, theta: f32) -> PlanarPoint {
    var out: PlanarPoint;
    out.p = p;
    out.one_minus_cos = one_minus_cos;
    // Level i holds θ̃ ∈ (2^−(i+1)π, 2^−iπ], ring_t = log2(2^−iπ/θ̃) (clipmap::mesh).
    let lf = log2(3.14159265 / max(theta, 1e-30));
    var level = u32(clamp(floor(lf), f32(frame.coarsest_level), f32(frame.finest_level)));
    var ring_t = clamp(lf - f32(level), 0.0, 1.0);
    if lf >= f32(frame.finest_level) + 1.0 {
        ring_t = 1.0;
    }
    out.level = level;
    out.at = place(p, 0.0, level, ring_t, theta);
    return out;
}

// Lattice point t along border `side` of a patch of n cells (twin: planar::geomip).
fn border_point(side: u32, t: u32, n: u32) -> vec2<u32> {
    switch side {
        case 0u: { return vec2<u32>(t, 0u); }
        case 1u: { return vec2<u32>(n, t); }
        case 2u: { return vec2<u32>(t, n); }
        default: { return vec2<u32>(0u, t); }
    }
}

fn border_of(x: u32, y: u32, n: u32) -> u32 {
    if y == 0u { return 0u; }
    if y == n { return 2u; }
    if x == 0u { return 3u; }
    if x == n { return 1u; }
    return 4u;
}

// The height a vertex is drawn at is a linear combination of lattice heights (its own, its
// morph target's neighbours, a coarser border's line): collected here as (x, y, weight) terms,
// then sampled in one loop, so the shader holds one copy of the height lookup (a CPU
// rasteriser compiles every inlined copy).
struct Terms {
    t: array<vec3<f32>, 16>,
    n: u32,
}

fn add_term(terms: ptr<function, Terms>, p: vec2<u32>, w: f32) {
    if w != 0.0 && (*terms).n < 16u {
        (*terms).t[(*terms).n] = vec3<f32>(f32(p.x), f32(p.y), w);
        (*terms).n += 1u;
    }
}

// A border's vertex at t as drawn: morphed along the border by its tween factor f.
fn add_border_vertex(terms: ptr<function, Terms>, side: u32, t: u32, n: u32, s: u32, f: f32, w: f32) {
    let p = border_point(side, t, n);
    if ((t / s) & 1u) == 0u || f <= 0.0 || s >= n {
        add_term(terms, p, w);
        return;
    }
    add_term(terms, p, w * (1.0 - f));
    add_term(terms, border_point(side, t - s, n), 0.5 * w * f);
    add_term(terms, border_point(side, t + s, n), 0.5 * w * f);
}

// The border `side` as drawn at t (linear between its vertices): twin planar::geomip::border_height.
fn add_border(terms: ptr<function, Terms>, pd: PatchGpu, side: u32, t: u32, n: u32, w: f32) {
    let le = pd.sides[side];
    let s = 1u << u32(floor(le));
    let f = le - floor(le);
    let t0 = t / s * s;
    if t0 == t {
        add_border_vertex(terms, side, t0, n, s, f, w);
        return;
    }
    let a = f32(t - t0) / f32(s);
    add_border_vertex(terms, side, t0, n, s, f, w * (1.0 - a));
    add_border_vertex(terms, side, t0 + s, n, s, f, w * a);
}

// A morph target's neighbour as drawn: on a border coarser than the interior, that border's line.
fn add_neighbour(terms: ptr<function, Terms>, pd: PatchGpu, k: u32, x: u32, y: u32, n: u32, w: f32) {
    let side = border_of(x, y, n);
    if side < 4u && u32(floor(pd.sides[side])) > k {
        add_border(terms, pd, side, select(y, x, side == 0u || side == 2u), n, w);
        return;
    }
    add_term(terms, vec2<u32>(x, y), w);
}

// Geomipmapping (twin: planar::geomip::morphed_height): vertex_index is the local lattice
// index (i + j·(n + 1)), or past (n + 1)² a skirt's lowered copy of border vertex t of side s
// ((n + 1)² + s·(n + 1) + t); instance_index picks the patch.
@vertex
fn vs_geomip(@builtin(vertex_index) index: u32, @builtin(instance_index) instance: u32) -> VertexOut {
    return geomip_vertex(index, instance);
}

// The wireframe overlay's draw (non-indexed: the index read here, the corner known).
@vertex
fn vs_geomip_wire(@builtin(vertex_index) i: u32, @builtin(instance_index) instance: u32) -> VertexOut {
    var out = geomip_vertex(patch_indices[i], instance);
    out.bary = corner_bary(i);
    return out;
}

fn geomip_vertex(index: u32, instance: u32) -> VertexOut {
    let pd = patches[instance];
    let n = planar.patch_cells;
    let size = n + 1u;
    var x = index % size;
    var y = index / size;
    var skirt = false;
    if index >= size * size {
        let j = index - size * size;
        let p = border_point(j / size, j % size, n);
        x = p.x;
        y = p.y;
        skirt = true;
    }
    let c = pd.corner;
    let q = vec2<f32>(c + vec2<i32>(i32(x), i32(y))) * planar.spacing_m;
    let pt = planar_point(q);
    var h = pt.at.h;
    if GEOMORPH {
        var terms: Terms;
        terms.n = 0u;
        let side = border_of(x, y, n);
        if side < 4u {
            add_border(&terms, pd, side, select(y, x, side == 0u || side == 2u), n, 1.0);
        } else {
            let k = u32(floor(pd.level));
            let s = 1u << k;
            let f = pd.level - floor(pd.level);
            let odd_x = ((x / s) & 1u) == 1u;
            let odd_y = ((y / s) & 1u) == 1u;
            if f > 0.0 && s < n && (odd_x || odd_y) {
                add_term(&terms, vec2<u32>(x, y), 1.0 - f);
                var a = vec2<u32>(x, y - s);
                var b = vec2<u32>(x, y + s);
                if odd_x && odd_y {
                    // The coarser quad's diagonal (4-8 pattern: planar::geomip::main_diagonal).
                    let on_main = (((x - s) / (2u * s) + (y - s) / (2u * s)) & 1u) == 0u;
                    a = select(vec2<u32>(x - s, y + s), vec2<u32>(x - s, y - s), on_main);
                    b = select(vec2<u32>(x + s, y - s), vec2<u32>(x + s, y + s), on_main);
                } else if odd_x {
                    a = vec2<u32>(x - s, y);
                    b = vec2<u32>(x + s, y);
                }
                add_neighbour(&terms, pd, k, a.x, a.y, n, 0.5 * f);
                add_neighbour(&terms, pd, k, b.x, b.y, n, 0.5 * f);
            }
        }
        // The vertex alone, unmorphed: its own height is already at hand.
        if !(terms.n == 1u && all(terms.t[0].xy == vec2<f32>(f32(x), f32(y)))) && terms.n > 0u {
            h = 0.0;
            for (var i = 0u; i < terms.n; i++) {
                let tq = (vec2<f32>(c) + terms.t[i].xy) * planar.spacing_m;
                h += terms.t[i].z * planar_point(tq).at.h;
            }
        }
    }
    if skirt {
        h -= planar.skirt_m;
    }

    // Δφ near the patch's own: a patch around a pole must not interpolate across the ±π cut.
    var d = pt.at.d;
    d.x -= 6.28318531 * round((d.x - pd.centre_dphi) / 6.28318531);

    var out = placed_vertex(pt.p, pt.one_minus_cos, h, d, pt.at.blend, pt.level);
    out.plane_xy = q;
    out.tag = 64u + u32(floor(pd.level));
    return out;
}

// ---------------------------------------------------------------------------------------------
// The error-bounded projected grid (error-bounded-projective-grid.md, plan::projgrid): a grid
// of view directions planned in f64 on the CPU each frame (the projector around the nadir,
// optionally warped by importance), each vertex placed like a clipmap vertex at its θ̃, and a
// per-cell error buffer (eq. 2–4): the fragments of cells with ρ > γ march their pixel ray
// through the terrain function instead of trusting the mesh (fs_projgrid_ray).

// Rust twin: render::gpu_data::GridVertexGpu: p̃x, p̃y, 1 − cos θ̃, θ̃ (f64 → f32 on the CPU,
// so a vertex a metre from the viewer keeps its precision, as the ring mesh's do).
@group(1) @binding(3) var<storage, read> grid_vertices: array<vec4<f32>>;
// Per cell: the terrain's bounds inside it (min, max metres; min > max: no ray cast), the
// normalised error of eq. 4 (the level overlay) and 0.
@group(1) @binding(4) var<storage, read> grid_cells: array<vec4<f32>>;
// The grid's triangle list, read by the wireframe draw (vs_projgrid_wire).
@group(1) @binding(5) var<storage, read> grid_indices: array<u32>;

// GRID_TAG (planar::projgrid): a projected-grid fragment's tag is this bit or'ed with its cell
// (each cell's two triangles start at the cell's first vertex, which provides the flat value).
// RAY_STEPS, RAY_BISECTIONS: the ray march's steps at most per fragment, then bisection steps on
// the bracketed crossing.

@vertex
fn vs_projgrid(@builtin(vertex_index) index: u32) -> VertexOut {
    return grid_vertex(index);
}

@vertex
fn vs_projgrid_wire(@builtin(vertex_index) i: u32) -> VertexOut {
    var out = grid_vertex(grid_indices[i]);
    out.bary = corner_bary(i);
    return out;
}

fn grid_vertex(index: u32) -> VertexOut {
    let g = grid_vertices[index];
    let pt = unit_point(vec3<f32>(g.x, g.y, 1.0 - g.z), g.z, g.w);
    var out = placed_vertex(pt.p, pt.one_minus_cos, pt.at.h, pt.at.d, pt.at.blend, pt.level);
    let cols = planar.grid_cols;
    let i = min(index % (cols + 1u), cols - 1u);
    let j = min(index / (cols + 1u), planar.grid_rows - 1u);
    out.tag = GRID_TAG | (j * cols + i);
    out.plane_xy = vec2<f32>(3.0e38);
    return out;
}

// The point `rel` metres from the eye as a direction from the planet's centre, placed.
// |E + rel| with E = (0, 0, R + h_eye): the small terms kept apart so a metre near the eye
// keeps its precision (only ratios of the big ones are used).
fn rel_point(rel: vec3<f32>) -> PlanarPoint {
    let zc = frame.radius_m + (eye_altitude() + rel.z);
    let s2 = dot(rel.xy, rel.xy);
    let len = sqrt(zc * zc + s2);
    let omc = s2 / (len * (len + zc));
    return unit_point(vec3<f32>(rel.xy / len, 1.0 - omc), omc, atan2(sqrt(s2), zc));
}

// Height of the point `rel` from the eye above the eye's altitude:
// rel.z + |rel.xy|²/(|E + rel| + zc).
fn rel_altitude(rel: vec3<f32>) -> f32 {
    let zc = frame.radius_m + (eye_altitude() + rel.z);
    let s2 = dot(rel.xy, rel.xy);
    let len = sqrt(zc * zc + s2);
    return rel.z + s2 / (len + zc);
}

// Clearance of the ray's point at t above the terrain function (negative: inside); both
// heights relative to the eye's altitude.
fn clearance(dir: vec3<f32>, t: f32) -> f32 {
    let rel = dir * t;
    return rel_altitude(rel) - rel_point(rel).at.h;
}

// Distances along the eye ray `dir` where it enters the shell [R + lo, R + hi] and where it
// reaches R + lo (or leaves R + hi); x > y: it never enters (projgrid::shell_interval's twin,
// c = |E|² − r² = (h_eye − h)(2R + h_eye + h), the near root c/(−b + √disc)).
fn shell_interval(dir: vec3<f32>, lo: f32, hi: f32) -> vec2<f32> {
    let r = frame.radius_m;
    let he = eye_altitude();
    let b = (r + he) * dir.z;
    let c_hi = (he - hi) * (2.0 * r + he + hi);
    let disc_hi = b * b - c_hi;
    if c_hi > 0.0 && (b >= 0.0 || disc_hi < 0.0) {
        return vec2<f32>(1.0, 0.0);
    }
    let sq = sqrt(max(disc_hi, 0.0));
    let t_in = select(0.0, c_hi / (-b + sq), c_hi > 0.0);
    let c_lo = (he - lo) * (2.0 * r + he + lo);
    let disc_lo = b * b - c_lo;
    var t_out = -b + sq;
    if c_lo <= 0.0 {
        t_out = t_in;
    } else if b < 0.0 && disc_lo >= 0.0 {
        t_out = c_lo / (-b + sqrt(disc_lo));
    }
    return vec2<f32>(t_in, t_out);
}

// The first crossing of the terrain along `dir` within the shell of the cell's bounds
// (projgrid::ray_cast's twin): footprint-sized steps of planar.ray_step_px pixels (at least
// 1/RAY_STEPS of the interval), then bisection. y = 1: a hit at x; 0: no hit (footprint
// steps all along); 2: not decided (steps ran out, or a coarse march missed).
fn ray_cast(dir: vec3<f32>, lo: f32, hi: f32) -> vec2<f32> {
    let span = shell_interval(dir, lo, hi);
    if span.x > span.y {
        return vec2<f32>(0.0);
    }
    var a = span.x;
    if clearance(dir, a) <= 0.0 {
        return vec2<f32>(a, 1.0);
    }
    let per_m = planar.ray_step_px / planar.px_per_rad;
    let min_step = (span.y - span.x) / f32(RAY_STEPS);
    // Some step was longer than the footprint's: a thin ridge may have been stepped over, so
    // a miss is not trusted.
    var coarse = false;
    for (var k = 0u; k < RAY_STEPS; k++) {
        let fine = per_m * max(a, 1e-3);
        coarse = coarse || min_step > fine;
        var z = min(a + max(fine, min_step), span.y);
        if clearance(dir, z) <= 0.0 {
            for (var m = 0u; m < RAY_BISECTIONS; m++) {
                let mid = 0.5 * (a + z);
                if clearance(dir, mid) > 0.0 {
                    a = mid;
                } else {
                    z = mid;
                }
            }
            return vec2<f32>(0.5 * (a + z), 1.0);
        }
        a = z;
        if a >= span.y {
            return vec2<f32>(0.0, select(0.0, 2.0, coarse));
        }
    }
    // Steps ran out before the interval did, or a coarse march missed (a long grazing ray):
    // keep the mesh's fragment.
    return vec2<f32>(0.0, 2.0);
}

struct RayCastOut {
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

// Fragments of cells whose ρ exceeds γ are moved to their pixel ray's first hit (depth and
// shading); a ray that grazes the cell without a hit is discarded (the terrain behind shows).
@fragment
fn fs_projgrid_ray(in: VertexOut) -> RayCastOut {
    var v = in;
    var depth = in.clip.z;
    let cell = grid_cells[in.tag & ~GRID_TAG];
    if cell.x <= cell.y {
        let dir = normalize(in.rel);
        let hit = ray_cast(dir, cell.x, cell.y);
        if hit.y == 0.0 {
            discard;
        }
        if hit.y == 1.0 || hit.y == 3.0 {
            let rel = dir * hit.x;
            let clip = frame.clip_from_view * vec4<f32>(rel, 1.0);
            depth = clip.z / clip.w;
            let pt = rel_point(rel);
            v.rel = rel;
            v.p_tilde = pt.p;
            v.map_pos = pt.at.d;
            v.level = pt.level;
            v.coarse_blend = pt.at.blend;
        }
    }
    var out: RayCastOut;
    out.colour = shade(v, in.rel);
    out.depth = depth;
    return out;
}
