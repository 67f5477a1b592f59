// Normals of a clipmap level, once per texel (compute), after its heights and partial octaves
// were filled: the terrain pass then reads one filtered texel per level instead of evaluating
// the height four more times per fragment (issue 14's cheap terrain pass).
//
// The normal is that of the level's heights with its partial detail octaves at full weight
// (they are 100+ pixels across wherever geometry holds them, so the fragment's λ_px never
// weakens them), stored as a world-frame (ECEF) unit vector in RGBA16F: a world vector has no
// frame singularity at the poles, and bilinear filtering of it is meaningful everywhere. The
// fourth channel holds the texel's height for the fragment's colour, at the texture's
// resolution rather than the mesh's.
//
// Central differences on the grid, in the texel's own tangent frame (û, e_θ, e_φ):
//   s_θ = (h(j+1) − h(j−1)) / (2(R+h)·sin dθ),
//   s_φ = (h(i+w) − h(i−w)) / (2(R+h)·sin θ·sin(w·dφ)),   n = normalize(û − s_θ e_θ − s_φ e_φ).
// The chord between φ ± w·dφ on one θ ring lies exactly along e_φ, so w (1 away from the
// poles) grows near a pole to keep the chord about one θ step long. On a pole row itself
// (sin θ = 0) the second slope is taken along the meridian a quarter turn on (column i + S/4:
// a grid holding a pole always spans the whole circle).
// Rust twin: render::normals::texel_normal (f64, used by tests/gpu/gpu_normals.rs).
//
// The same pass writes the noise that perturbs the surface types' boundaries (issue 35: the
// look's view-independent part once per texel, not per pixel per frame): two octaves of
// world-stable value noise band-limited to the texel. The fragment reads it filtered, as it
// reads the normal, and takes the types' weights from it, its height and slope.
// Rust twin: render::normals::texel_boundary_noise.

// Rust twin: render::gpu_data::NormalParams (layout checked by tests/cpu/shader_contract.rs).
struct NormalParams {
    slot0: vec2<u32>,     // texel of the job's first grid point (toroidal)
    extent: vec2<u32>,
    layer: u32,
    size: u32,
    partial_count: u32,   // partial octaves the level's second texture holds
    quarter: u32,         // S/4 columns: a quarter turn when the grid holds a pole
    angles: vec4<f32>,    // φ0, θ0 of the anchor, dφ, dθ (radians)
    trig: vec4<f32>,      // sin θ0, cos θ0, sin φ0, cos φ0 of the anchor (from f64)
    radius_m: f32,
    pole_north: i32,      // job row of θ = 0 (−1: none)
    pole_south: i32,      // job row of θ = π (−1: none)
    offset_x: u32,        // the first texel, in grid steps from the anchor (angles, trig)
    offset_y: u32,
    ref_m: f32,           // the level's reference height: the texture holds h − ref_m
    _pad0: u32,
    _pad1: u32,
    // The boundary noise's lattices around the anchor's point at ref_m (cell, seed; remainder,
    // 1/cell), world frame.
    boundary_cell0: vec4<i32>,
    boundary_frac0: vec4<f32>,
    boundary_cell1: vec4<i32>,
    boundary_frac1: vec4<f32>,
    // The imagery's pixel coordinates of the anchor (x, y; edges at integers, y unfolded)
    // and its pixels per grid step (z, w); its width, height, mip level for this texel and
    // 1 when there is imagery; pixel rows of 90° N and 90° S and the period in columns.
    imagery_xy: vec4<f32>,
    imagery_size: vec4<f32>,
    imagery_fold: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: NormalParams;
@group(0) @binding(1) var heights: texture_2d_array<f32>;
@group(0) @binding(2) var partials: texture_2d_array<f32>;
@group(0) @binding(3) var out_normals: texture_storage_2d_array<rgba16float, write>;
@group(0) @binding(4) var out_materials: texture_storage_2d_array<rgba8unorm, write>;
@group(0) @binding(5) var out_imagery: texture_storage_2d_array<rgba8unorm, write>;
@group(0) @binding(6) var imagery: texture_2d<f32>;
@group(0) @binding(7) var imagery_sampler: sampler;

// Height of the grid point (i, j) from the job's first one: (level heights, partial octaves)
// apart, so that differences of nearby points lose nothing to the f32 sum of the two (at a
// 5 mm texel a 4 km height's f32 step would be a 5 % slope).
fn height_at(i: i32, j: i32) -> vec2<f32> {
    let s = i32(params.size);
    let x = ((i32(params.slot0.x) + i) % s + s) % s;
    let y = ((i32(params.slot0.y) + j) % s + s) % s;
    let layer = i32(params.layer);
    let h = textureLoad(heights, vec2<i32>(x, y), layer, 0).x;
    if params.partial_count == 0u {
        return vec2<f32>(h, 0.0);
    }
    let p = textureLoad(partials, vec2<i32>(x, y), layer, 0);
    let mask = select(vec4<f32>(0.0), vec4<f32>(1.0), vec4<u32>(0u, 1u, 2u, 3u) < vec4<u32>(params.partial_count));
    return vec2<f32>(h, dot(p, mask));
}

// h(a) − h(b), each part apart.
fn height_difference(a: vec2<f32>, b: vec2<f32>) -> f32 {
    let d = a - b;
    return d.x + d.y;
}

// One octave of the boundary noise at world offset wrel (m) from the lattice's anchor, faded
// out from four texels of `footprint_m` per cell to two (the texels' bilinear filter then
// reconstructs what is left without aliasing).
fn boundary_octave(cell: vec4<i32>, frac: vec4<f32>, wrel: vec3<f32>, footprint_m: f32) -> f32 {
    let x = frac.xyz + wrel * frac.w;
    let fl = floor(x);
    let v = value_noise(cell.xyz + vec3<i32>(fl), x - fl, bitcast<u32>(cell.w));
    return v * (1.0 - smoothstep(0.5, 1.0, footprint_m * frac.w));
}


// The texel's boundary noise, with `rel` its world offset from the anchor's point and
// `footprint_m` the texel's size: (½ + ½·na, ½ + ½·nb, 0, 0), the two octaves apart, so
// that a fragment can fade each out by its own footprint as well (where a pixel spans more
// than a texel) before it combines them into the surface types' perturbation.
fn texel_boundary_noise(rel: vec3<f32>, footprint_m: f32) -> vec4<f32> {
    let na = boundary_octave(params.boundary_cell0, params.boundary_frac0, rel, footprint_m);
    let nb = boundary_octave(params.boundary_cell1, params.boundary_frac1, rel, footprint_m);
    return vec4<f32>(0.5 + 0.5 * na, 0.5 + 0.5 * nb, 0.0, 0.0);
}

// Linear light → the sRGB encoding (IEC 61966-2-1): the level layer is 8 bits a channel.
fn linear_to_srgb(c: vec3<f32>) -> vec3<f32> {
    let v = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    return select(1.055 * pow(v, vec3<f32>(1.0 / 2.4)) - 0.055, 12.92 * v, v <= vec3<f32>(0.0031308));
}

// The draped image at grid point (i, j) of the job, band-limited to the texel (the mip
// level whose pixels are the texel's size: both are latitude/longitude grids, so that holds
// at every latitude), sRGB-encoded, alpha its coverage (0 outside the image). Rows past a
// pole are the point across it, half a turn on. Rust twin: render::imagery::texel_imagery.
fn texel_imagery(i: i32, j: i32) -> vec4<f32> {
    if params.imagery_size.w == 0.0 {
        return vec4<f32>(0.0);
    }
    var x = params.imagery_xy.x + f32(i + i32(params.offset_x)) * params.imagery_xy.z;
    var y = params.imagery_xy.y + f32(j + i32(params.offset_y)) * params.imagery_xy.w;
    let north = params.imagery_fold.x;
    let south = params.imagery_fold.y;
    let period = params.imagery_fold.z;
    if y < north {
        y = 2.0 * north - y;
        x += 0.5 * period;
    } else if y > south {
        y = 2.0 * south - y;
        x += 0.5 * period;
    }
    x -= floor(x / period) * period;
    let size = params.imagery_size.xy;
    let c = textureSampleLevel(imagery, imagery_sampler, vec2<f32>(x, y) / size, params.imagery_size.z);
    let inside = x <= size.x && y >= 0.0 && y <= size.y;
    return select(vec4<f32>(0.0), vec4<f32>(linear_to_srgb(c.rgb), c.a), inside);
}

@compute @workgroup_size(WORKGROUP_SIZE, WORKGROUP_SIZE, 1)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.extent.x || id.y >= params.extent.y {
        return;
    }
    let i = i32(id.x);
    let j = i32(id.y);
    let dphi = params.angles.z;
    let dtheta = params.angles.w;
    // sin/cos of θ and φ from the f64 anchor and the small offsets (rows past a pole keep
    // going: θ < 0 or θ > π give the point across it, with the frame that goes with it).
    let a = f32(j + i32(params.offset_y)) * dtheta;
    let b = f32(i + i32(params.offset_x)) * dphi;
    // trig.wgsl's forms: a and b are as small as 1e-9 rad on the finest levels.
    let sca = sin_cos_precise(a);
    let scb = sin_cos_precise(b);
    let st = params.trig.x * sca.y + params.trig.y * sca.x;
    let ct = params.trig.y * sca.y - params.trig.x * sca.x;
    let sp = params.trig.z * scb.y + params.trig.w * scb.x;
    let cp = params.trig.w * scb.y - params.trig.z * scb.x;
    let up = vec3<f32>(st * cp, st * sp, ct);
    let e_theta = vec3<f32>(ct * cp, ct * sp, -st);
    let h0 = height_at(i, j);
    let r = params.radius_m + (params.ref_m + h0.x + h0.y);
    let chord_theta = 2.0 * r * sin_precise(dtheta);
    let s_theta = height_difference(height_at(i, j + 1), height_at(i, j - 1)) / chord_theta;
    var n: vec3<f32>;
    if j == params.pole_north || j == params.pole_south {
        let q = i32(params.quarter);
        // e_θ of the meridian a quarter turn on (φ + π/2).
        let e_theta_q = vec3<f32>(-ct * sp, ct * cp, -st);
        let s_q = height_difference(height_at(i + q, j + 1), height_at(i + q, j - 1)) / chord_theta;
        n = up - s_theta * e_theta - s_q * e_theta_q;
    } else {
        let e_phi = vec3<f32>(-sp, cp, 0.0);
        let steps = dtheta / max(abs(st) * dphi, 1e-30);
        let w = i32(clamp(steps, 1.0, f32(params.quarter)) + 0.5);
        let chord_phi = 2.0 * r * st * sin_precise(f32(w) * dphi);
        let s_phi = height_difference(height_at(i + w, j), height_at(i - w, j)) / chord_phi;
        n = up - s_theta * e_theta - s_phi * e_phi;
    }
    let slot = (params.slot0 + id.xy) % vec2<u32>(params.size);
    let unit_n = normalize(n);
    let h = (params.ref_m + h0.x) + h0.y;
    // w: the height, for the fragment's colour (f16 keeps metres; colour needs no more).
    textureStore(out_normals, slot, params.layer, vec4<f32>(unit_n, h));
    // The texel's world offset from the anchor's point at ref_m, without cancellation:
    // (R + ref)(û − û0) + (h − ref)·û, û − û0 from the angle differences (noise.wgsl).
    let d_st = delta_sin(params.trig.x, params.trig.y, a);
    let d_ct = delta_cos(params.trig.x, params.trig.y, a);
    let d_sp = delta_sin(params.trig.z, params.trig.w, b);
    let d_cp = delta_cos(params.trig.z, params.trig.w, b);
    let d_up = vec3<f32>(d_st * cp + params.trig.x * d_cp, d_st * sp + params.trig.x * d_sp, d_ct);
    let rel = (params.radius_m + params.ref_m) * d_up + (h0.x + h0.y) * up;
    let footprint_m = params.radius_m * max(dtheta, abs(st) * dphi);
    textureStore(out_materials, slot, params.layer, texel_boundary_noise(rel, footprint_m));
    if params.imagery_size.w != 0.0 {
        textureStore(out_imagery, slot, params.layer, texel_imagery(i, j));
    }
}
