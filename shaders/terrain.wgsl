// Terrain pass of the spherical clipmap (spherical-clipmaps.md §3–5).
//
// Vertex: static ring vertex p̃ (view space) → map transform → height from the level texture
// (manual bilinear, blended into the next coarser level near the level's outer edge) →
// camera-relative position with no f32 cancellation (docs/design.md#numerics: 1 − cos θ̃ precomputed in f64).
// Fragment: the level's normal texture (world frame, filled once per texel by
// fill_normals.wgsl) turned into view space, the detail's bump octaves finer than the level
// holds, sun lighting, hypsometric colours of the height stored beside the normal (the
// texture's resolution, not the mesh's), optional level overlay.
// No height or map transform is evaluated per fragment.
//
// Prepended at build time: constants generated from Rust (render::shader::shared_constants:
// MAX_LEVELS, OVERLAY_LEVELS, TRANSFORM_*, …) and common/map_transform.wgsl.

// Rust twin: render::gpu_data::FrameUniforms (layout checked by tests/cpu/shader_contract.rs).
struct FrameUniforms {
    clip_from_view: mat4x4<f32>,
    transform: TransformUniforms,
    sun_view: vec4<f32>,
    radius_m: f32,
    eye_height_m: f32,
    blend_fraction: f32,
    texture_size: u32,
    transform_form: u32,
    approx_start_level: u32,
    coarsest_level: u32,
    finest_level: u32,
    overlay: u32,
    // altitude − eye_height_m in f64, rounded: the eye's height is eye_height_m + this.
    eye_height_lo_m: f32,
    // The ring mesh's n (φ̃ steps) and m (rings per level).
    mesh_steps: u32,
    mesh_rings: u32,
    // λ(θ̃) = clamp(x − ln θ̃ · y, 0, z): the detail octaves geometry holds (0: no detail).
    detail_lambda: vec4<f32>,
}

// Rust twin: render::gpu_data::LevelUniforms.
struct LevelUniforms {
    // Viewer's grid coordinates modulo the texture size (texel units).
    grid_x_viewer: f32,
    grid_y_viewer: f32,
    inv_dphi: f32,
    inv_dtheta: f32,
    dtheta_rad: f32,
    // Index of the level's first partial octave (the whole ones are in its heights).
    detail_full: u32,
    // One past its last partial octave: its normals hold every octave before this one.
    detail_end: u32,
    // Ring density k (every 2^k-th φ̃ step and ring) of the body, the outer and the inner ring,
    // and how far the vertices density k + 1 drops have moved onto its surface (0..1).
    density: u32,
    outer_density: u32,
    inner_density: u32,
    morph: f32,
    outer_morph: f32,
    inner_morph: f32,
    // The level's reference height minus the eye's altitude (f64, then f32): the texture holds
    // h − ref (small near the eye, so f32 steps there stay far below a pixel), so a texel's
    // height relative to the eye is what it holds plus this.
    ref_eye_m: f32,
    _pad0: u32,
    _pad1: u32,
}

// Rust twin: clipmap::RingVertex, buffer layout render::gpu_data::RING_VERTEX_ATTRIBUTES.
struct RingVertex {
    @location(0) p_tilde: vec3<f32>,
    @location(1) one_minus_cos: f32,
    @location(2) theta_tilde_rad: f32,
    @location(3) ring_t: f32,
    @location(4) level: u32,
    @location(5) seam_side: f32,
}

// The same vertices read by index (Rust twin: clipmap::RingVertex; vertex i of level l, ring j,
// column c is l·((m+1)(n+2)+1) + j·(n+2) + c).
struct MeshVertex {
    p_tilde: vec3<f32>,
    one_minus_cos: f32,
    theta_tilde_rad: f32,
    ring_t: f32,
    level: u32,
    seam_side: f32,
}

// Rust twin: render::gpu_data::BumpUniforms. The detail's octaves finer than geometry holds,
// down to two pixels, shaded as bump (the split octave, geometry-image-warping.md §4.1),
// each octave's lattice anchored at the viewer: x = frac + N·Δu (N = Q·R/L·world_from_view).
struct BumpUniforms {
    octaves: array<DetailOctave, MAX_OCTAVES>,
    amplitudes: array<vec4<f32>, DETAIL_AMPLITUDE_VECS>,
    // Amplitude floor, gain·(L_0/cell)^H, cap (m); radius (m).
    sigma: vec4<f32>,
    // λ_px(d) = clamp(x − ln d · y, 0, z): octaves of at least two pixels at distance d.
    lambda_px: vec4<f32>,
    // Rows of world_from_view (xyz); w: relief map columns, rows, 0.
    world0: vec4<f32>,
    world1: vec4<f32>,
    world2: vec4<f32>,
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    // (Δφ, Δθ) of the vertex, interpolated like the paper's texture coordinates (§4.4).
    @location(0) map_pos: vec2<f32>,
    @location(1) p_tilde: vec3<f32>,
    @location(2) coarse_blend: f32,
    @location(3) @interpolate(flat) level: u32,
    // Position relative to the eye, metres (the bump's pixel footprint).
    @location(4) rel: vec3<f32>,
    // Plane coordinates of a planar LOD method's frame (planar.wgsl): where the clipmap
    // leaves the ground to it.
    @location(8) plane_xy: vec2<f32>,
    // Wireframe overlay: the triangle's barycentric coordinates (1 at one corner each), from
    // the draws that pull their indices themselves (vs_main_wire, vs_geomip_wire), so the
    // edges need no adapter feature. (1, 1, 1) elsewhere: no edge.
    @location(9) bary: vec3<f32>,
    // Level overlay: the clipmap level, or 64 + a geomipmapping patch's tessellation level.
    @location(10) @interpolate(flat) tag: u32,
    // The bump octaves' amplitude σ (bump_sigma) at the vertex: the relief map varies over tens
    // of kilometres, so a fragment interpolates it instead of reading the map (an atan2 and four
    // reads per pixel, 7–9 % of a frame with the detail on a CPU rasteriser).
    @location(11) bump_sigma: f32,
}

// Pipeline constants (render::terrain): the morph's code only in the pipeline that draws
// morphing levels, the detail's only with detail on. A CPU rasteriser runs the code of a
// branch no lane takes, so what a draw cannot need is compiled out, not skipped.
override MORPH: bool = true;
override BLEND: bool = true;
override DETAIL: bool = true;
// The map transform's form (the same as frame.transform_form): only that form is compiled.
override TRANSFORM: u32 = TRANSFORM_STABLE;
// The look (look::LookSettings): proto-textures, water (its geometry rule max(h, level) and its
// shading), the atmosphere's haze. Off: the plain tint, one Lambert light.
override TEXTURES: bool = true;
override WATER: bool = true;
// Imagery draped (the terrain has it): a pixel's colour is the imagery's, the surface types
// only the texture inside an imagery pixel.
override IMAGERY: bool = false;
// The water's shading (WATER on): off in the pipeline that draws what the water cull proved
// dry (render::water_cull), the geometry rule max(h, level) kept.
override WET: bool = true;
override SKY: bool = true;
// A frame seen from so far that every pixel's footprint spans many texture tiles and the
// boundary noise's cells (render::terrain::FAR_FOOTPRINT_M): the proto-textures and waves read
// their coarsest mip (one texel, the tile's mean) as the trilinear filter would there, and the
// boundary octaves are 0 as their band limit makes them; none of their per-pixel work is done.
override FAR: bool = false;
// The bump octaves (bump_gradient, and σ at the vertices for them): off in the pipelines of a
// frame where no pixel can show one (render::terrain::bump_can_show).
override BUMP: bool = true;
// A planar LOD method draws near the viewer: the clipmap's fragments in its square go
// (planar.wgsl). Geomorphing of the geomipmapping patches.
override CUT: bool = false;
override GEOMORPH: bool = true;
// The projected grid's pipelines (planar.wgsl): its fragments' Δφ fix-up and cell overlay.
override GRID: bool = false;
// The overlays (render::gpu_data::Overlays): the level overlay's tint and the wireframe's edges
// (its pipelines alone; bary is (1, 1, 1) in the others).
override LEVEL_OVERLAY: bool = false;
override WIRE_OVERLAY: bool = false;

@group(0) @binding(0) var<uniform> frame: FrameUniforms;
@group(0) @binding(1) var<uniform> levels: array<LevelUniforms, MAX_LEVELS>;
@group(0) @binding(2) var heights: texture_2d_array<f32>;
// σ·t_k of each level's partial octaves (common/detail_fill.wgsl), weighted here by λ(θ̃).
@group(0) @binding(3) var partials: texture_2d_array<f32>;
@group(0) @binding(4) var<uniform> bump: BumpUniforms;
@group(0) @binding(5) var<storage, read> relief: array<f32>;
// World-frame unit normals per level texel (fill_normals.wgsl), bilinear and toroidal.
@group(0) @binding(6) var normals: texture_2d_array<f32>;
@group(0) @binding(7) var normal_sampler: sampler;
@group(0) @binding(8) var<storage, read> mesh: array<MeshVertex>;
@group(0) @binding(9) var<uniform> look: LookUniforms;
// Proto-textures, one layer per surface type (look::proto::Material), variance-reducing mips.
@group(0) @binding(10) var albedo: texture_2d_array<f32>;
// rg: wave slopes (look::proto::wave_texture).
@group(0) @binding(11) var waves: texture_2d<f32>;
@group(0) @binding(12) var look_sampler: sampler;
// The levels' boundary noise (fill_normals.wgsl): ½ + ½·na, ½ + ½·nb (its two octaves).
@group(0) @binding(13) var boundary_noise: texture_2d_array<f32>;
// The draped imagery per texel (fill_normals.wgsl texel_imagery): sRGB-encoded rgb, alpha its
// coverage.
@group(0) @binding(18) var level_imagery: texture_2d_array<f32>;
// The aerial-perspective volume (aerial.wgsl): in-scattered light and transmittance from the
// eye to each slice's distance, per cell of the frame.
@group(0) @binding(14) var aerial_inscatter: texture_3d<f32>;
@group(0) @binding(16) var aerial_transmittance: texture_3d<f32>;
@group(0) @binding(17) var aerial_sampler: sampler;
// The ring mesh's triangle list, read by the wireframe draws (vs_main_wire).
@group(0) @binding(15) var<storage, read> ring_indices: array<u32>;

fn wrap_texel(i: i32) -> i32 {
    let s = i32(frame.texture_size);
    return ((i % s) + s) % s;
}

// λ(θ̃): how many detail octaves geometry holds at view angle θ̃ from the viewer
// (procedural::Detail::lambda_at_angle).
fn detail_lambda(theta_tilde: f32) -> f32 {
    let c = frame.detail_lambda;
    return clamp(c.x - log(max(theta_tilde, 1e-30)) * c.y, 0.0, c.z);
}

// Bilinear height of level `level` at map offset d = (Δφ, Δθ) from the viewer, with its
// partial detail octaves weighted by λ (w_k = clamp(λ − k, 0, 1)), relative to the eye's
// altitude. Manual filtering in f32 (hardware filtering quantises the weights to 8 bits,
// visible up close).
fn level_height(level: u32, d: vec2<f32>, lambda: f32) -> f32 {
    let g = levels[level];
    let x = d.x * g.inv_dphi + g.grid_x_viewer;
    let y = d.y * g.inv_dtheta + g.grid_y_viewer;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let ix0 = wrap_texel(i32(x0));
    let ix1 = wrap_texel(i32(x0) + 1);
    let iy0 = wrap_texel(i32(y0));
    let iy1 = wrap_texel(i32(y0) + 1);
    let layer = i32(level);
    let h00 = textureLoad(heights, vec2<i32>(ix0, iy0), layer, 0).x;
    let h10 = textureLoad(heights, vec2<i32>(ix1, iy0), layer, 0).x;
    let h01 = textureLoad(heights, vec2<i32>(ix0, iy1), layer, 0).x;
    let h11 = textureLoad(heights, vec2<i32>(ix1, iy1), layer, 0).x;
    let h = mix(mix(h00, h10, fx), mix(h01, h11, fx), fy);
    if !DETAIL {
        return h + g.ref_eye_m;
    }
    let k0 = f32(levels[level].detail_full);
    let w = clamp(vec4<f32>(lambda) - (vec4<f32>(k0) + vec4<f32>(0.0, 1.0, 2.0, 3.0)), vec4<f32>(0.0), vec4<f32>(1.0));
    if all(w == vec4<f32>(0.0)) {
        return h + g.ref_eye_m;
    }
    let p00 = textureLoad(partials, vec2<i32>(ix0, iy0), layer, 0);
    let p10 = textureLoad(partials, vec2<i32>(ix1, iy0), layer, 0);
    let p01 = textureLoad(partials, vec2<i32>(ix0, iy1), layer, 0);
    let p11 = textureLoad(partials, vec2<i32>(ix1, iy1), layer, 0);
    return (h + dot(w, mix(mix(p00, p10, fx), mix(p01, p11, fx), fy))) + g.ref_eye_m;
}

// The eye's altitude above R (the f32 pair summed).
fn eye_altitude() -> f32 {
    return frame.eye_height_m + frame.eye_height_lo_m;
}

// Height of a point of level `level`, blended by `coarse_blend` into the next coarser level so
// that a level's outer ring equals the coarser level's inner ring exactly (no cracks).
fn terrain_height(level: u32, d: vec2<f32>, coarse_blend: f32, lambda: f32) -> f32 {
    let fine = level_height(level, d, lambda);
    if !BLEND || coarse_blend <= 0.0 {
        return fine;
    }
    return mix(fine, level_height(level - 1u, d, lambda), coarse_blend);
}

// Weight of the next coarser level: 1 on the level's outer ring, 0 from `blend_fraction` of the
// level inwards. It does not depend on which levels are drawn (the renderer always fills the
// level just outside the coarsest drawn one), so skipping a level never moves another.
fn coarse_blend_weight(level: u32, ring_t: f32) -> f32 {
    if level == 0u {
        return 0.0;
    }
    return clamp(1.0 - ring_t / frame.blend_fraction, 0.0, 1.0);
}

fn map_transform(p_tilde: vec3<f32>, seam_side: f32, level: u32, ring_t: f32) -> vec2<f32> {
    switch TRANSFORM {
        case TRANSFORM_DIRECT: {
            return map_transform_direct(frame.transform, p_tilde, seam_side);
        }
        case TRANSFORM_APPROXIMATE: {
            // By ring, continuous across level boundaries (level i, ring_t 0 ≡ level i−1,
            // ring_t 1): 0 outside approx_start_level, ramping to 1 across it (Fig. 14).
            // Only the blend ring pays for both forms; inside it the approximation alone runs
            // (the paper's speed path), outside it the stable form alone.
            let w = clamp(f32(level) + ring_t - f32(frame.approx_start_level), 0.0, 1.0);
            if w >= 1.0 {
                return map_transform_approx(frame.transform, p_tilde);
            }
            if w <= 0.0 {
                return map_transform_stable(frame.transform, p_tilde, seam_side);
            }
            return map_transform_blended(w, frame.transform, p_tilde, seam_side);
        }
        case TRANSFORM_STABLE, default: {
            return map_transform_stable(frame.transform, p_tilde, seam_side);
        }
    }
}

// A ring vertex placed on the terrain: map offset, coarse-level blend, height relative to the
// eye's altitude (h − h_eye).
struct Placed {
    d: vec2<f32>,
    blend: f32,
    h: f32,
}

fn place(p_tilde: vec3<f32>, seam_side: f32, level: u32, ring_t: f32, theta_tilde: f32) -> Placed {
    var out: Placed;
    out.d = map_transform(p_tilde, seam_side, level, ring_t);
    out.blend = coarse_blend_weight(level, ring_t);
    out.h = terrain_height(level, out.d, out.blend, detail_lambda(theta_tilde));
    if WATER {
        // The terrain function's water rule (terrain::with_water), per vertex before any
        // morph so that a morphing vertex moves onto the coarser edge exactly.
        out.h = max(out.h, (look.water_level_m - frame.eye_height_m) - frame.eye_height_lo_m);
    }
    return out;
}

// Index of the vertex of `level` on ring j at φ̃ step t (mod n), its first copy.
fn mesh_index(level: u32, j: u32, t: u32) -> u32 {
    let n = frame.mesh_steps;
    let columns = n + 2u;
    return level * ((frame.mesh_rings + 1u) * columns + 1u) + j * columns + t % n;
}

@vertex
fn vs_main(v: RingVertex, @builtin(vertex_index) index: u32) -> VertexOut {
    return with_plane_coords(ring_vertex(v, index));
}

// A planar method's plane coordinates of a clipmap vertex, in the pipelines that cut its square
// out (kept out of ring_vertex, so that the vertex pre-pass needs no planar bindings).
fn with_plane_coords(v: VertexOut) -> VertexOut {
    var out = v;
    if CUT {
        out.plane_xy = plane_coords(out.p_tilde);
    }
    return out;
}

// Mesh vertex `index` read from the storage copy, as the vertex buffer would give it (the draws
// and passes that pull their vertices: the wireframe, the vertex pre-pass).
fn mesh_vertex(index: u32) -> RingVertex {
    let m = mesh[index];
    var v: RingVertex;
    v.p_tilde = m.p_tilde;
    v.one_minus_cos = m.one_minus_cos;
    v.theta_tilde_rad = m.theta_tilde_rad;
    v.ring_t = m.ring_t;
    v.level = m.level;
    v.seam_side = m.seam_side;
    return v;
}

// Barycentric corner of the i-th vertex of a triangle list.
fn corner_bary(i: u32) -> vec3<f32> {
    let c = i % 3u;
    return vec3<f32>(f32(c == 0u), f32(c == 1u), f32(c == 2u));
}

// The wireframe overlay's draw: non-indexed, the index read here, so each triangle's three
// vertices know which corner they are.
@vertex
fn vs_main_wire(@builtin(vertex_index) i: u32) -> VertexOut {
    let index = ring_indices[i];
    var out = with_plane_coords(ring_vertex(mesh_vertex(index), index));
    out.bary = corner_bary(i);
    return out;
}

fn ring_vertex(v: RingVertex, index: u32) -> VertexOut {
    var at = place(v.p_tilde, v.seam_side, v.level, v.ring_t, v.theta_tilde_rad);
    var p = v.p_tilde;
    var one_minus_cos = v.one_minus_cos;

    // Geomorphing (clipmap::density): a vertex the next coarser density drops moves, by the
    // level's morph, to the midpoint of the two coarser vertices it lies between (along its
    // ring, across rings, or on the coarse quad's diagonal), heights included, so that the
    // switch to that density moves nothing. Edge rings morph along the ring only, with the
    // density and morph both levels sharing them agree on.
    let n = frame.mesh_steps;
    let m = frame.mesh_rings;
    let columns = n + 2u;
    let per_level = (m + 1u) * columns + 1u;
    let local = index - v.level * per_level;
    let j = local / columns;
    let column = local % columns;
    let lu = levels[v.level];
    var k = lu.density;
    var morph = lu.morph;
    let edge = j == 0u || j == m;
    if j == 0u {
        k = lu.outer_density;
        morph = lu.outer_morph;
    } else if j == m {
        k = lu.inner_density;
        morph = lu.inner_morph;
    }
    if MORPH && morph > 0.0 && local + 1u < per_level {
        // φ̃ step of this column (column n + 1 is the second copy of step n/2).
        let t = select(column, n / 2u, column == n + 1u);
        let s = 1u << k;
        let odd_step = ((t / s) & 1u) == 1u;
        let odd_ring = !edge && ((j / s) & 1u) == 1u;
        if odd_step || odd_ring {
            var ia: u32;
            var ib: u32;
            if odd_step && odd_ring {
                // The coarse quad's diagonal: (j − s, t + s) to (j + s, t − s).
                ia = mesh_index(v.level, j - s, t + s);
                ib = mesh_index(v.level, j + s, t + n - s);
            } else if odd_step {
                ia = mesh_index(v.level, j, t + s);
                ib = mesh_index(v.level, j, t + n - s);
            } else {
                ia = mesh_index(v.level, j - s, t);
                ib = mesh_index(v.level, j + s, t);
            }
            let a = mesh[ia];
            let b = mesh[ib];
            // Neighbours on a seam meridian take this vertex's side of the cut (§4.4).
            let side = select(v.seam_side, sign(v.p_tilde.y), v.p_tilde.y != 0.0);
            let pa = place(a.p_tilde, side, v.level, a.ring_t, a.theta_tilde_rad);
            let pb = place(b.p_tilde, side, v.level, b.ring_t, b.theta_tilde_rad);
            at.d = mix(at.d, 0.5 * (pa.d + pb.d), morph);
            at.blend = mix(at.blend, 0.5 * (pa.blend + pb.blend), morph);
            at.h = mix(at.h, 0.5 * (pa.h + pb.h), morph);
            p = mix(p, 0.5 * (a.p_tilde + b.p_tilde), morph);
            one_minus_cos = mix(one_minus_cos, 0.5 * (a.one_minus_cos + b.one_minus_cos), morph);
        }
    }

    // 1 − cos θ̃ from f64 (the mesh's), morphed like p̃.
    var out = placed_vertex(p, one_minus_cos, at.h, at.d, at.blend, v.level);
    out.tag = v.level;
    out.plane_xy = vec2<f32>(3.0e38);
    return out;
}

// A vertex at view direction p and height h_eye above the eye's altitude (h − h_eye), the rest
// of its placement given: the position relative to the eye (the eye is at (0, 0, R + h_eye);
// z = (h − h_eye) − (R + h)·(1 − cos θ̃), docs/design.md#numerics). Both LOD
// methods' vertex stages end here.
fn placed_vertex(p: vec3<f32>, one_minus_cos: f32, h_eye: f32, d: vec2<f32>, blend: f32, level: u32) -> VertexOut {
    let r = frame.radius_m + (eye_altitude() + h_eye);
    let rel = vec3<f32>(
        r * p.x,
        r * p.y,
        h_eye - r * one_minus_cos,
    );
    var out: VertexOut;
    out.clip = frame.clip_from_view * vec4<f32>(rel, 1.0);
    out.map_pos = d;
    out.p_tilde = p;
    out.coarse_blend = blend;
    out.level = level;
    out.rel = rel;
    out.bary = vec3<f32>(1.0);
    out.bump_sigma = 0.0;
    if DETAIL && BUMP && bump.lambda_px.z > 0.0 {
        out.bump_sigma = bump_sigma(normalize(p));
    }
    return out;
}

// The vertex pre-pass (render::placement). A CPU rasteriser places vertices on one thread and
// again for every triangle its small vertex cache misses; here each vertex a frame's draws use
// is placed once, on every core, by ring_vertex itself. The draws then read the result as
// their vertex buffer (vs_placed). Rust twin: render::gpu_data::PlacedVertex.
// 48 bytes: the clip position is the view matrix times `rel` (the draw multiplies, as
// placed_vertex does); the haze is the fragment's (aerial_at), not the vertex's.
struct PlacedVertex {
    // Position relative to the eye (m) and the level (as f32: exact).
    rel_level: vec4<f32>,
    // p̃ and the bump octaves' σ.
    p_sigma: vec4<f32>,
    // Δφ, Δθ, the coarse blend; w unused.
    map_blend: vec4<f32>,
}

// Written by cs_place only (the draws bind the same buffer as a vertex buffer).
@group(2) @binding(0) var<storage, read_write> placed_out: array<PlacedVertex>;
// Mesh vertex ids to place, padded with PLACE_NONE to whole workgroups.
@group(2) @binding(1) var<storage, read> place_work: array<u32>;

@compute @workgroup_size(PLACE_WORKGROUP)
fn cs_place(@builtin(global_invocation_id) id: vec3<u32>) {
    let index = place_work[id.x];
    if index == PLACE_NONE {
        return;
    }
    let o = ring_vertex(mesh_vertex(index), index);
    var q: PlacedVertex;
    q.rel_level = vec4<f32>(o.rel, f32(o.level));
    q.p_sigma = vec4<f32>(o.p_tilde, o.bump_sigma);
    q.map_blend = vec4<f32>(o.map_pos, o.coarse_blend, 0.0);
    placed_out[index] = q;
}

// A placed vertex as the draw reads it (render::gpu_data::PLACED_VERTEX_ATTRIBUTES).
struct PlacedIn {
    @location(0) rel_level: vec4<f32>,
    @location(1) p_sigma: vec4<f32>,
    @location(2) map_blend: vec4<f32>,
}

fn unpack_placed(q: PlacedIn) -> VertexOut {
    var out: VertexOut;
    out.rel = q.rel_level.xyz;
    out.clip = frame.clip_from_view * vec4<f32>(out.rel, 1.0);
    out.map_pos = q.map_blend.xy;
    out.coarse_blend = q.map_blend.z;
    out.bump_sigma = q.p_sigma.w;
    out.p_tilde = q.p_sigma.xyz;
    out.level = u32(q.rel_level.w);
    out.tag = out.level;
    out.bary = vec3<f32>(1.0);
    out.plane_xy = vec2<f32>(3.0e38);
    return with_plane_coords(out);
}

// The clipmap's draws from the pre-pass.
@vertex
fn vs_placed(q: PlacedIn) -> VertexOut {
    return unpack_placed(q);
}

// The relief map at world unit vector w: bilinear between cell centres (as the fills read it).
fn relief_at_world(w: vec3<f32>) -> f32 {
    let dims = vec2<i32>(i32(bump.world0.w), i32(bump.world1.w));
    let phi = atan2(w.y, w.x);
    let theta = atan2(length(w.xy), w.z);
    let x = fract(phi * 0.15915494309) * f32(dims.x) - 0.5;
    let y = theta * 0.31830988618 * f32(dims.y) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let c0 = ((i32(x0) % dims.x) + dims.x) % dims.x;
    let c1 = (c0 + 1) % dims.x;
    let r0 = clamp(i32(y0), 0, dims.y - 1);
    let r1 = clamp(i32(y0) + 1, 0, dims.y - 1);
    let top = mix(relief[r0 * dims.x + c0], relief[r0 * dims.x + c1], x - x0);
    let bottom = mix(relief[r1 * dims.x + c0], relief[r1 * dims.x + c1], x - x0);
    return mix(top, bottom, y - y0);
}

// σ of the bump octaves at view direction u: the floor plus the gain times the relief map, capped.
fn bump_sigma(u: vec3<f32>) -> f32 {
    let w = vec3<f32>(dot(bump.world0.xyz, u), dot(bump.world1.xyz, u), dot(bump.world2.xyz, u));
    return clamp(bump.sigma.x + bump.sigma.y * relief_at_world(w), 0.0, bump.sigma.z);
}

// Gradient (view space, metres per metre) of the bump octaves at view direction u, of amplitude
// sigma (bump_sigma, interpolated from the vertices): the
// octaves of at least two pixels (weights w_k(λ_px)) that the level's normals lack. Those hold
// every octave below `detail_end` at weight 1 (blended with the coarser level's near its
// outer edge), which is right wherever geometry holds an octave: its cells are then ≥ 8 × the
// distance/8 … far above two pixels. The bump octaves continue the lattices unwarped and at
// the base amplitude (no height-dependent roughness): shading only, never measured.
fn bump_gradient(u: vec3<f32>, sigma: f32, level: u32, blend: f32, footprint_dist: f32) -> vec3<f32> {
    let c = bump.lambda_px;
    if c.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    let lambda_px = clamp(c.x - log(max(footprint_dist, 1e-6)) * c.y, 0.0, c.z);
    let end_fine = levels[level].detail_end;
    var end_coarse = end_fine;
    if blend > 0.0 {
        end_coarse = levels[level - 1u].detail_end;
    }
    let k_start = min(end_fine, end_coarse);
    if lambda_px <= f32(k_start) {
        return vec3<f32>(0.0);
    }
    // Δu from the viewer (0, 0, 1) without cancellation: 1 − z = |xy|²/(1 + z).
    let xy2 = dot(u.xy, u.xy);
    let du = vec3<f32>(u.x, u.y, -xy2 / (1.0 + u.z));
    var g = vec3<f32>(0.0);
    let k_end = u32(min(ceil(lambda_px), c.z));
    for (var k = k_start; k < k_end; k++) {
        let in_texture = select(0.0, 1.0 - blend, k < end_fine) + select(0.0, blend, k < end_coarse);
        let wd = clamp(lambda_px - f32(k), 0.0, 1.0) - in_texture;
        if wd <= 0.0 {
            continue;
        }
        let o = bump.octaves[k];
        let x = vec3<f32>(
            o.m0.w + dot(o.m0.xyz, du),
            o.m1.w + dot(o.m1.xyz, du),
            o.m2.w + dot(o.m2.xyz, du),
        );
        let fl = floor(x);
        let sg = value_noise_grad(o.cell.xyz + vec3<i32>(fl), x - fl, bitcast<u32>(o.cell.w));
        // ∂S/∂u = Nᵀ·∂S/∂x.
        let grad_u = o.m0.xyz * sg.y + o.m1.xyz * sg.z + o.m2.xyz * sg.w;
        g += wd * bump.amplitudes[k / 4u][k % 4u] * grad_u;
    }
    return sigma * g / bump.sigma.w;
}

// Where map offset d from the viewer lies in `level`'s textures (normals, boundary noise).
fn level_uv(level: u32, d: vec2<f32>) -> vec2<f32> {
    let g = levels[level];
    let x = d.x * g.inv_dphi + g.grid_x_viewer;
    let y = d.y * g.inv_dtheta + g.grid_y_viewer;
    // Texel (i, j) holds grid point (i, j) mod S at its centre.
    return (vec2<f32>(x, y) + 0.5) / f32(frame.texture_size);
}

// The normal texture of `level` at `uv` (level_uv): the world-frame normal (filtered: not
// quite unit length) and, in w, the height for the colour.
fn level_normal(level: u32, uv: vec2<f32>) -> vec4<f32> {
    return textureSampleLevel(normals, normal_sampler, uv, i32(level), 0.0);
}

// The boundary noise of `level` at `uv` (filtered as the normals are).
fn level_boundary_noise(level: u32, uv: vec2<f32>) -> vec4<f32> {
    return textureSampleLevel(boundary_noise, normal_sampler, uv, i32(level), 0.0);
}

// The imagery of `level` at `uv` (sRGB-encoded rgb, coverage in a; filtered).
fn level_imagery_at(level: u32, uv: vec2<f32>) -> vec4<f32> {
    return textureSampleLevel(level_imagery, normal_sampler, uv, i32(level), 0.0);
}

// Hypsometric tint: bathymetry blues, lowland greens, upland browns, rock, snow.
fn hypsometric(h: f32) -> vec3<f32> {
    if h < 0.0 {
        let t = clamp(-h / 6000.0, 0.0, 1.0);
        return mix(vec3<f32>(0.16, 0.42, 0.62), vec3<f32>(0.02, 0.07, 0.25), sqrt(t));
    }
    // Piecewise linear through the stops (0, 300, 1000, 2200, 3800, 5200 m) as a telescoping
    // sum: each segment adds its whole step once h is past it, a fraction inside it. The same
    // colours as a search over the stops, without an array a CPU rasteriser indexes per lane.
    var c = vec3<f32>(0.20, 0.45, 0.18);
    c += vec3<f32>(0.16, 0.11, 0.06) * clamp(h / 300.0, 0.0, 1.0);
    c += vec3<f32>(0.32, 0.08, 0.14) * clamp((h - 300.0) / 700.0, 0.0, 1.0);
    c += vec3<f32>(-0.16, -0.24, -0.10) * clamp((h - 1000.0) / 1200.0, 0.0, 1.0);
    c += vec3<f32>(0.03, 0.13, 0.24) * clamp((h - 2200.0) / 1600.0, 0.0, 1.0);
    c += vec3<f32>(0.41, 0.43, 0.46) * clamp((h - 3800.0) / 1400.0, 0.0, 1.0);
    return c;
}

fn level_colour(level: u32) -> vec3<f32> {
    var palette = array<vec3<f32>, 8>(
        vec3<f32>(0.90, 0.10, 0.10),
        vec3<f32>(0.95, 0.55, 0.05),
        vec3<f32>(0.95, 0.90, 0.10),
        vec3<f32>(0.15, 0.80, 0.15),
        vec3<f32>(0.05, 0.75, 0.85),
        vec3<f32>(0.15, 0.30, 0.95),
        vec3<f32>(0.60, 0.15, 0.90),
        vec3<f32>(0.95, 0.30, 0.70),
    );
    return palette[level % 8u];
}

// A proto-texture layer at world-stable coordinates uvw, triplanar with plane weights pw
// (derivatives from the unwrapped coordinates: the mip level is continuous across tiles).
// Planes: x → (y, z), y → (z, x), z → (x, y). Written out, not looped, and the layer a
// literal in each call: lavapipe (Mesa 22.3) crashes on a dynamic component index there and
// on an array layer passed in as a parameter.
// The mip level of a proto-texture footprint (uv derivatives in tiles per pixel), as the
// hardware picks it for isotropic filtering.
fn lod_of(dx: vec2<f32>, dy: vec2<f32>) -> f32 {
    let size = f32(PROTO_TEXTURE_SIZE);
    return 0.5 * log2(max(max(dot(dx, dx), dot(dy, dy)) * size * size, 1e-12));
}

// Biplanar projection of world-stable texture coordinates: the two planes facing the
// world up vector most (x → (y, z), y → (z, x), z → (x, y)), their weights sharpened and
// normalised. Every texture read below is unconditional: lavapipe (Mesa 22.3) crashes on
// texture reads inside branches of a function called from a divergent branch.
struct Planes {
    a: u32,
    b: u32,
    wa: f32,
    wb: f32,
}

fn pick_planes(world_up: vec3<f32>) -> Planes {
    let m = abs(world_up);
    var out: Planes;
    out.a = select(select(2u, 1u, m.y >= m.z), 0u, m.x >= m.y && m.x >= m.z);
    let rest = select(select(vec2<u32>(0u, 1u), vec2<u32>(0u, 2u), out.a == 1u), vec2<u32>(1u, 2u), out.a == 0u);
    out.b = select(rest.y, rest.x, m[rest.x] >= m[rest.y]);
    let pa = pow(m[out.a], 4.0);
    let pb = pow(m[out.b], 4.0);
    // Fade the second plane out where it is far behind (its weight would be under 5 %).
    let wb = max(pb / (pa + pb) - 0.05, 0.0) / 0.95;
    out.wa = 1.0 - wb;
    out.wb = wb;
    return out;
}

fn on_plane(v: vec3<f32>, axis: u32) -> vec2<f32> {
    return select(select(v.xy, v.zx, axis == 1u), v.yz, axis == 0u);
}

// A proto-texture layer at world-stable coordinates uvw on the two planes (derivatives from
// the unwrapped coordinates: the mip level is continuous across tiles).
fn sample_albedo(layer: u32, uvw: vec3<f32>, dx: vec3<f32>, dy: vec3<f32>, pl: Planes) -> vec3<f32> {
    let l = i32(layer);
    if FAR {
        return textureSampleLevel(albedo, look_sampler, vec2<f32>(0.5), l, f32(PROTO_MIP_LEVELS - 1u)).rgb;
    }
    let a = textureSampleLevel(albedo, look_sampler, fract(on_plane(uvw, pl.a)), l, lod_of(on_plane(dx, pl.a), on_plane(dy, pl.a))).rgb;
    let b = textureSampleLevel(albedo, look_sampler, fract(on_plane(uvw, pl.b)), l, lod_of(on_plane(dx, pl.b), on_plane(dy, pl.b))).rgb;
    return pl.wa * a + pl.wb * b;
}

// A plane's 2-D vector (its two texture axes) as a world vector.
fn from_plane(v: vec2<f32>, axis: u32) -> vec3<f32> {
    return select(select(vec3<f32>(v.x, v.y, 0.0), vec3<f32>(v.y, 0.0, v.x), axis == 1u), vec3<f32>(0.0, v.x, v.y), axis == 0u);
}

// Wave slopes as a world vector from the wave texture (½ + ½·slope).
fn wave_slope(uvw: vec3<f32>, dx: vec3<f32>, dy: vec3<f32>, pl: Planes) -> vec3<f32> {
    if FAR {
        let m = textureSampleLevel(waves, look_sampler, vec2<f32>(0.5), f32(PROTO_MIP_LEVELS - 1u)).rg;
        return pl.wa * from_plane(2.0 * m - 1.0, pl.a) + pl.wb * from_plane(2.0 * m - 1.0, pl.b);
    }
    let a = textureSampleLevel(waves, look_sampler, fract(on_plane(uvw, pl.a)), lod_of(on_plane(dx, pl.a), on_plane(dy, pl.a))).rg;
    let b = textureSampleLevel(waves, look_sampler, fract(on_plane(uvw, pl.b)), lod_of(on_plane(dx, pl.b), on_plane(dy, pl.b))).rg;
    return pl.wa * from_plane(2.0 * a - 1.0, pl.a) + pl.wb * from_plane(2.0 * b - 1.0, pl.b);
}

// The largest of five weights (the first of equals) and the largest of the rest, with their
// indices. Written out with selects on constant indices: a search that indexes the array by a
// computed index makes a CPU rasteriser spill it and gather per lane.
struct TwoLargest {
    first: u32,
    second: u32,
    w1: f32,
    w2: f32,
}

fn two_largest(w: array<f32, 5>) -> TwoLargest {
    var t = TwoLargest(0u, 0u, w[0], 0.0);
    t = larger_first(t, 1u, w[1]);
    t = larger_first(t, 2u, w[2]);
    t = larger_first(t, 3u, w[3]);
    t = larger_first(t, 4u, w[4]);
    t.second = select(0u, 1u, t.first == 0u);
    t.w2 = select(w[0], w[1], t.first == 0u);
    t = larger_second(t, 0u, w[0]);
    t = larger_second(t, 1u, w[1]);
    t = larger_second(t, 2u, w[2]);
    t = larger_second(t, 3u, w[3]);
    t = larger_second(t, 4u, w[4]);
    return t;
}

fn larger_first(t: TwoLargest, k: u32, wk: f32) -> TwoLargest {
    var out = t;
    let more = wk > t.w1;
    out.first = select(t.first, k, more);
    out.w1 = select(t.w1, wk, more);
    return out;
}

fn larger_second(t: TwoLargest, k: u32, wk: f32) -> TwoLargest {
    var out = t;
    let more = k != t.first && wk > t.w2;
    out.second = select(t.second, k, more);
    out.w2 = select(t.w2, wk, more);
    return out;
}

// The haze between the eye and the point `rel` (view space, from the eye) at `altitude` (m)
// seen through framebuffer position `frag` (pixels): the aerial volume read trilinearly at
// the pixel's place in the frame and the slice coordinate of the point (aerial.wgsl): by its
// distance, w = ln(dist/d0)/ln(d1/d0), or from above the atmosphere by its altitude a,
// w = (a_hi − a)/(a_hi − a_lo).
fn aerial_at(frag: vec2<f32>, rel: vec3<f32>, altitude: f32) -> Scatter {
    let uv = 0.5 * frag * look.viewport.zw;
    let dist = length(rel);
    let by_distance = log(max(dist, look.aerial.x) / look.aerial.x) * look.aerial.y;
    let by_altitude = 1.0 - (altitude - look.aerial.x) * look.aerial.y;
    let w = clamp(select(by_distance, by_altitude, look.aerial.w > 0.5), 0.0, 1.0);
    let z = (w * f32(AERIAL_SIZE_Z - 1u) + 0.5) / f32(AERIAL_SIZE_Z);
    var out: Scatter;
    out.inscatter = textureSampleLevel(aerial_inscatter, aerial_sampler, vec3<f32>(uv, z), 0.0).rgb;
    out.transmittance = textureSampleLevel(aerial_transmittance, aerial_sampler, vec3<f32>(uv, z), 0.0).rgb;
    return out;
}

// World → view: v_view = Wᵀ·v_world (the rows of W are look.world*).
fn view_from_world(v: vec3<f32>) -> vec3<f32> {
    return v.x * look.world0.xyz + v.y * look.world1.xyz + v.z * look.world2.xyz;
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    return shade(in, in.rel);
}

// The shading of every terrain fragment, whichever LOD method placed it (the projected grid's
// ray cast moves the fragment first: planar.wgsl fs_projgrid_ray). Screen derivatives of
// positions are taken of `rel_d`: the rasterised surface's, smooth across pixels where a ray
// cast's hits jump from ridge to ridge (textures would drop to their coarsest mips there).
fn shade(in_: VertexOut, rel_d: vec3<f32>) -> vec4<f32> {
    var in = in_;
    if CUT && in_planar_cut(in.plane_xy) {
        discard;
    }
    if GRID {
        // A projected-grid triangle across the ±π meridian (near a pole) interpolates Δφ
        // through 0: recompute it from the direction there.
        if fwidth(in.map_pos.x) > 1.0 {
            let p = normalize(in.p_tilde);
            in.map_pos = map_transform(p, sign(p.y), in.level, 0.0);
        }
    }
    // Distance to the nearest edge in pixels (derivatives first: uniform control flow).
    let bary_px = in.bary / max(fwidth(in.bary), vec3<f32>(1e-6));
    // World-stable texture coordinates and their screen derivatives, first (derivatives
    // need uniform control flow). Eye-relative: small and precise near the viewer.
    let wrel = look_world(in.rel);
    let wrel_dx = look_world(dpdx(rel_d));
    let wrel_dy = look_world(dpdy(rel_d));
    let uvw = look.tex_anchor.xyz + wrel * look.tex_anchor.w;
    let uvw_dx = wrel_dx * look.tex_anchor.w;
    let uvw_dy = wrel_dy * look.tex_anchor.w;
    let drift = look.time_s * vec3<f32>(0.011, 0.007, 0.005);
    let w0 = look.wave_anchor0.xyz + wrel * look.wave_anchor0.w + drift;
    let w1 = look.wave_anchor1.xyz + wrel * look.wave_anchor1.w - 1.7 * drift;
    let w0_dx = wrel_dx * look.wave_anchor0.w;
    let w0_dy = wrel_dy * look.wave_anchor0.w;
    let w1_dx = wrel_dx * look.wave_anchor1.w;
    let w1_dy = wrel_dy * look.wave_anchor1.w;

    let level = in.level;
    let blend = clamp(in.coarse_blend, 0.0, 1.0);
    let uv = level_uv(level, in.map_pos);
    var nh = level_normal(level, uv);
    // The boundary noise (the view-independent part of the look, filled with the level;
    // 0 in FAR frames, whose every pixel fades it out): read unconditionally otherwise, as
    // every texture read here (lavapipe, see Planes).
    var noise = vec4<f32>(0.5);
    if !FAR {
        noise = level_boundary_noise(level, uv);
    }
    var img = vec4<f32>(0.0);
    if IMAGERY {
        img = level_imagery_at(level, uv);
    }
    if BLEND && blend > 0.0 {
        let uv_coarse = level_uv(level - 1u, in.map_pos);
        nh = mix(nh, level_normal(level - 1u, uv_coarse), blend);
        if !FAR {
            noise = mix(noise, level_boundary_noise(level - 1u, uv_coarse), blend);
        }
        if IMAGERY {
            img = mix(img, level_imagery_at(level - 1u, uv_coarse), blend);
        }
    }
    // Texels outside the image hold 0 in every channel, so the filtered colour over its
    // coverage is the covered texels' mean.
    let cover = img.a;
    let img_c = srgb_to_linear(img.rgb / max(img.a, 1e-4));
    let nw = nh.xyz;
    var n = normalize(view_from_world(nw));
    let n_geometry = n;
    // Each octave also faded out where a pixel spans more than a quarter of its cell (the
    // texel's band limit is the fill's).
    let footprint_m = max(length(wrel_dx), length(wrel_dy));
    let na = (2.0 * noise.x - 1.0) * (1.0 - smoothstep(0.125, 0.25, footprint_m * look.boundary_frac0.w));
    let nb = (2.0 * noise.y - 1.0) * (1.0 - smoothstep(0.125, 0.25, footprint_m * look.boundary_frac1.w));
    let q = clamp(1.6 * na + 0.8 * nb, -1.0, 1.0);
    let patches = clamp(0.5 + 1.2 * nb - 0.8 * na, 0.0, 1.0);
    if DETAIL && BUMP && bump.lambda_px.z > 0.0 {
        // The footprint along the view is stretched by 1/cos of the incidence (grazing views
        // would alias the bump otherwise), up to 10×.
        let dist = length(in.rel);
        let cos_i = max(abs(dot(n, in.rel)) / max(dist, 1e-6), 0.1);
        let gb = bump_gradient(normalize(in.p_tilde), in.bump_sigma, level, blend, dist / cos_i);
        n = normalize(n - (gb - dot(gb, n) * n));
    }

    let sun = frame.sun_view.xyz;
    let up = normalize(in.p_tilde);
    let lambert = max(dot(n, sun), 0.0);
    // Light: the sun through the atmosphere (SKY) or one white light, and an ambient term
    // that fades on the night side when the sky is on.
    var direct = vec3<f32>(look.light.z);
    var ambient = vec3<f32>(look.light.w);
    let h = nh.w;
    // The haze from the eye to this point (the aerial volume at the pixel and its distance or
    // altitude) and the sunlight reaching the point (closed form): per pixel, and at the
    // surface's height from the level texture (the water's where it is under water), not the
    // triangle's, whose chords sag kilometres below it seen from space.
    var haze: Scatter;
    haze.inscatter = vec3<f32>(0.0);
    haze.transmittance = vec3<f32>(1.0);
    if SKY {
        let altitude = max(h, look.water_level_m);
        haze = aerial_at(in.clip.xy, in.rel, altitude);
        let p = normalize(vec3<f32>(0.0, 0.0, look.eye_radius_m) + in.rel) * (look.shell.x + altitude);
        let sun_t = sun_transmittance(p, sun);
        direct = look.light.z * sun_t;
        ambient = look.light.w * sun_t * clamp(dot(up, sun) * 3.0 + 0.3, 0.0, 1.0);
    }
    let world_up = look_world(up);
    let pw = pick_planes(world_up);
    var colour: vec3<f32>;
    if WATER && WET && h < look.water_level_m {
        // Water (infinite-landscapes-projected-grid.md §4.3): a flat surface at the level with
        // small waves in the normal only, Fresnel reflection of the sky, a sun glint and a
        // body colour by depth (shallow water shows its sandy bottom).
        let depth = look.water_level_m - h;
        let to_eye = -in.rel / max(length(in.rel), 1e-6);
        let slope = wave_slope(w0, w0_dx, w0_dy, pw) + 0.6 * wave_slope(w1, w1_dx, w1_dy, pw);
        let g = view_from_world(slope) * (0.18 * smoothstep(0.0, 8.0, depth));
        let nwater = normalize(up - (g - dot(g, up) * up));
        let cos_v = max(dot(nwater, to_eye), 0.0);
        let fresnel = 0.02 + 0.98 * pow(1.0 - cos_v, 5.0);
        let reflected = reflect(-to_eye, nwater);
        let elevation = clamp(dot(reflected, up), 0.0, 1.0);
        let sky = mix(look.sky_horizon.rgb, look.sky_zenith.rgb, sqrt(elevation));
        let body_light = ambient + direct * max(dot(up, sun), 0.0);
        let deep = mix(vec3<f32>(0.05, 0.30, 0.33), vec3<f32>(0.008, 0.035, 0.09), 1.0 - exp(-depth / 60.0));
        let bottom = vec3<f32>(0.74, 0.66, 0.47) * exp(-depth / 3.0);
        let body = mix(deep, bottom, exp(-depth / 3.0)) * body_light;
        let half_v = normalize(to_eye + sun);
        let glint = direct * 40.0 * fresnel * pow(max(dot(nwater, half_v), 0.0), 500.0);
        colour = (1.0 - fresnel) * body + fresnel * sky + glint;
        if TEXTURES {
            // Sea ice toward the poles (from 77° to 80° of latitude, the edge perturbed like
            // the land's boundaries): a surface type, not geometry (the surface stays at the
            // water level).
            let ice = smoothstep(0.974, 0.985, abs(world_up.z) + 0.01 * na);
            let ice_c = sample_albedo(4u, uvw, uvw_dx, uvw_dy, pw) * (ambient + direct * max(dot(up, sun), 0.0));
            colour = mix(colour, ice_c, ice);
        }
    } else if TEXTURES && (h >= 0.0 || cover > 0.0) {
        // Proto-texturing (§4.2) by height, slope and latitude, boundaries perturbed by the
        // noise the normal pass wrote per texel.
        let slope_v = 1.0 - clamp(dot(n_geometry, up), 0.0, 1.0);
        let wts = material_weights(h, slope_v, abs(world_up.z), q, patches);
        // The layered weights (each type over the ones before it) as one weight per type,
        // then the two largest: a third type rarely shows (lavapipe also needs the layer to
        // be a computed value, not a constant per call).
        let keep = (1.0 - wts.w) * (1.0 - wts.z);
        var types = array<f32, 5>(
            keep * (1.0 - wts.y) * (1.0 - wts.x),
            keep * (1.0 - wts.y) * wts.x,
            keep * wts.y,
            (1.0 - wts.w) * wts.z,
            wts.w,
        );
        if IMAGERY && cover > 0.0 {
            // Under imagery the types are those whose prototypes are nearest its colour (a
            // desert pixel makes sand, a dark green one forest, a white one snow).
            let wi = imagery_weights(img_c, q);
            let total = max(wi[0] + wi[1] + wi[2] + wi[3] + wi[4], 1e-12);
            for (var k = 0u; k < 5u; k++) {
                types[k] = mix(types[k], wi[k] / total, cover);
            }
        }
        let top = two_largest(types);
        let a1 = sample_albedo(top.first, uvw, uvw_dx, uvw_dy, pw);
        let a2 = sample_albedo(top.second, uvw, uvw_dx, uvw_dy, pw);
        let t = top.w2 / max(top.w1 + top.w2, 1e-6);
        var albedo_c = mix(a1, a2, t);
        if IMAGERY {
            // The imagery's colour, textured inside its pixel by the types' proto-textures
            // over their means: the mean stays the imagery's at every distance (far away the
            // textures' mips are their means and the ratio is 1).
            let m1 = look.type_means[top.first].rgb;
            let m2 = look.type_means[top.second].rgb;
            let ratio = mix(a1 / max(m1, vec3<f32>(1e-3)), a2 / max(m2, vec3<f32>(1e-3)), t);
            albedo_c = mix(albedo_c, img_c * ratio, cover);
        }
        colour = albedo_c * (ambient + direct * lambert);
    } else if IMAGERY && cover > 0.0 {
        // --textures off: the imagery's own colour, lit.
        colour = mix(hypsometric(h), img_c, cover) * (ambient + direct * lambert);
    } else {
        colour = hypsometric(h) * (ambient + direct * lambert);
    }
    if SKY {
        colour = tone_map(colour * haze.transmittance + haze.inscatter);
    }
    if LEVEL_OVERLAY {
        var tint = level_colour(in.tag);
        if GRID && in.tag >= GRID_TAG {
            // Projected-grid cells by their normalised error (eq. 4): 0 green, → 1 red.
            let e = grid_cells[in.tag - GRID_TAG].z;
            tint = mix(vec3<f32>(0.2, 0.85, 0.3), vec3<f32>(0.95, 0.1, 0.05), clamp(e, 0.0, 1.0));
        } else if in.tag >= 64u {
            // Geomipmapping patches by tessellation level: finest white, then yellow to red.
            let k = f32(in.tag - 64u);
            tint = mix(vec3<f32>(1.0, 1.0, 1.0), vec3<f32>(0.9, 0.1, 0.05), clamp(k / 4.0, 0.0, 1.0)) * vec3<f32>(1.0, 1.0 - 0.12 * k, 0.6);
        }
        colour = mix(colour, tint * (0.35 + 0.65 * lambert), 0.6);
    }
    if WIRE_OVERLAY {
        let edge = 1.0 - smoothstep(0.5, 1.5, min(bary_px.x, min(bary_px.y, bary_px.z)));
        colour = mix(colour, vec3<f32>(0.02, 0.02, 0.03), edge);
    }
    return vec4<f32>(colour, 1.0);
}

// Pass-through (the benchmark's raster-limit reference, `globe bench --passthrough`): the
// same vertices and triangles placed on the bare sphere, no map transform, no texture reads,
// one flat colour. The terrain pass's GPU time over this one's says how close to the raster
// limit the terrain shading runs.
@vertex
fn vs_passthrough(v: RingVertex) -> @builtin(position) vec4<f32> {
    let r = frame.radius_m;
    let rel = vec3<f32>(
        r * v.p_tilde.x,
        r * v.p_tilde.y,
        (-frame.eye_height_m - frame.eye_height_lo_m) - r * v.one_minus_cos,
    );
    return frame.clip_from_view * vec4<f32>(rel, 1.0);
}

@fragment
fn fs_passthrough() -> @location(0) vec4<f32> {
    return vec4<f32>(0.5, 0.5, 0.5, 1.0);
}
