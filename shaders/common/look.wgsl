// The look of the planet (docs/look.md#the-look): atmosphere (single scattering), proto-textures
// and water. Shared by terrain.wgsl (aerial perspective, materials, water) and sky.wgsl.
// Rust twins: look::atmosphere (scattering, Chapman column), look::proto (material weights).
// The pass declares `var<uniform> look: LookUniforms` (the functions read it as a global: a
// software adapter, lavapipe, crashes on this struct passed by value).

// Rust twin: render::gpu_data::LookUniforms (layout checked by tests/cpu/shader_contract.rs).
struct LookUniforms {
    // Clip → view space (rays of the sky pass; the eye is the origin).
    view_from_clip: mat4x4<f32>,
    // Rows of world_from_view (xyz), w unused: world offsets of eye-relative view vectors.
    world0: vec4<f32>,
    world1: vec4<f32>,
    world2: vec4<f32>,
    // frac(E / L) of the eye's ECEF position E for the proto-textures' tile L (xyz) and 1/L (w):
    // texture coordinates are this plus (W·rel)/L, so they are world-stable and small near the
    // viewer (no f32 world coordinates).
    tex_anchor: vec4<f32>,
    // The surface types' boundary noise (common/noise.wgsl's value noise over the world
    // lattice of cell L, not a tiled texture): two octaves, each the eye's lattice cell
    // (xyz) with the octave's seed (w), and frac(E/L) (xyz) with 1/L (w).
    boundary_cell0: vec4<i32>,
    boundary_frac0: vec4<f32>,
    boundary_cell1: vec4<i32>,
    boundary_frac1: vec4<f32>,
    // The same as tex_anchor for the two wave scales.
    wave_anchor0: vec4<f32>,
    wave_anchor1: vec4<f32>,
    // Rayleigh scattering β_R (1/m, rgb) and 1/H_R.
    rayleigh: vec4<f32>,
    // Mie scattering β_M (1/m, rgb) and 1/H_M.
    mie: vec4<f32>,
    // Planet radius R (m), atmosphere top radius (m), Mie extinction / scattering, Mie g.
    shell: vec4<f32>,
    // Sun radiance scale, exposure (tone map 1 − exp(−k·c)), direct and ambient light.
    light: vec4<f32>,
    // Sky colour at the zenith and the horizon at the viewer (water reflections), rgb.
    sky_zenith: vec4<f32>,
    sky_horizon: vec4<f32>,
    // Unit vector to the sun, view space (xyz).
    sun: vec4<f32>,
    // The eye's distance from the planet's centre (m), water level (m), cosine of the sun
    // disk's angular radius, time (s).
    eye_radius_m: f32,
    water_level_m: f32,
    sun_cos: f32,
    time_s: f32,
    // View → clip space (the sky ring's vertices).
    clip_from_view: mat4x4<f32>,
    // Frame width, height (pixels), 2/width, 2/height.
    viewport: vec4<f32>,
    // The sky ring (look::SkyRing, sky.wgsl vs_sky_ring): tan of its inner and outer vertices'
    // angle from −z̃, their distance (m), unused.
    sky_ring: vec4<f32>,
    // The aerial-perspective volume's slices (aerial.wgsl): the first one's distance d0 (m),
    // 1/ln(d1/d0), ln(d1/d0), unused.
    aerial: vec4<f32>,
    // Each surface type's proto-texture mean (linear rgb; its coarsest mip), and its imagery
    // prototype's features (imagery_features), in the albedo array's order.
    type_means: array<vec4<f32>, 5>,
    type_features: array<vec4<f32>, 5>,
}

// Unit view vector → world (ECEF) vector.
fn look_world(v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(look.world0.xyz, v), dot(look.world1.xyz, v), dot(look.world2.xyz, v));
}

// ---------------------------------------------------------------------------------------------
// Atmosphere: exponential Rayleigh and Mie layers, single scattering (a documented
// approximation of Bruneton & Neyret 2008 / Hillaire 2020: no multiple scattering, no tables).

// exp(y²)·erfc(y) for y ≥ 0 (relative error < 4e-4): Abramowitz & Stegun 7.1.26 below 2,
// Laplace's continued fraction above. Rust twin: look::atmosphere::erfcx.
fn erfcx(y: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.3275911 * y);
    let small = t * (0.25482959 + t * (-0.28449672 + t * (1.4214138 + t * (-1.4531521 + t * 1.0614054))));
    let yl = max(y, 2.0);
    let large = 0.56418958 / (yl + 0.5 / (yl + 1.0 / (yl + 1.5 / (yl + 2.0 / yl))));
    return select(large, small, y < 2.0);
}

// Column of an exponential layer (scale height H, x = R/H) from radius r along zenith cosine
// mu to infinity, in metres of ground-density air: the Chapman function in its large-x form
// Ch(X, μ) = √(πX/2)·erfcx(√(X/2)·μ) (X = r/H; exact to O(1/X), X ≥ 800 here), and below the
// horizon the column through the tangent point minus the one beyond it. Rust twin:
// look::atmosphere::chapman_column_m.
fn chapman_column(r: f32, mu: f32, radius: f32, inv_h: f32) -> f32 {
    let x = radius * inv_h;
    let h = max(r - radius, 0.0) * inv_h;
    let big_x = x + h;
    let toward = 1.2533141 * sqrt(big_x) * erfcx(sqrt(0.5 * big_x) * abs(mu)) * exp(-h);
    let x0 = sqrt(max(1.0 - mu * mu, 0.0)) * big_x;
    // A ray whose tangent point lies inside the planet (x0 < x) hits it: no light (a huge
    // column, not exp(x − x0) overflowing into inf·0 = NaN).
    let below = select(1e30, 2.0 * 1.2533141 * sqrt(x0) * exp(min(x - x0, 0.0)) - toward, x0 >= x);
    return select(below, toward, mu >= 0.0) / inv_h;
}

struct Scatter {
    // Light scattered toward the eye along the segment (scaled radiance, rgb).
    inscatter: vec3<f32>,
    // Transmittance of the segment.
    transmittance: vec3<f32>,
}

// Single scattering along the segment from o (relative to the planet's centre, view space)
// in unit direction d for distance t_max, with `samples` midpoint samples. The segment is
// clipped to the atmosphere's shell first. Rust twin: look::atmosphere::Atmosphere::scatter.
fn atmosphere_scatter(o: vec3<f32>, d: vec3<f32>, t_max: f32, sun: vec3<f32>, samples: u32) -> Scatter {
    let radius = look.shell.x;
    let top = look.shell.y;
    // Ray ∩ top sphere, with the perpendicular distance formed directly (no b² − c
    // cancellation). A ray that misses the shell gets an empty segment, not an early return:
    // lavapipe (Mesa 22.3) crashes on this function's returns in divergent control flow.
    let b = dot(o, d);
    let perp = o - b * d;
    let p = sqrt(dot(perp, perp));
    let half_chord = sqrt(max((top - p) * (top + p), 0.0));
    let t0 = max(-b - half_chord, 0.0);
    let t1 = select(min(-b + half_chord, t_max), t0, p >= top);
    let dt = max(t1 - t0, 0.0) / f32(samples);
    let inv_h = vec2<f32>(look.rayleigh.w, look.mie.w);
    let mie_ext = look.mie.xyz * look.shell.z;
    var column = vec2<f32>(0.0);
    var sum_r = vec3<f32>(0.0);
    var sum_m = vec3<f32>(0.0);
    for (var i = 0u; i < samples; i++) {
        let t = t0 + (f32(i) + 0.5) * dt;
        let q = o + t * d;
        let r = length(q);
        let dens = exp(-max(r - radius, 0.0) * inv_h) * dt;
        let here = column + 0.5 * dens;
        column += dens;
        let mu_s = dot(q, sun) / r;
        let sun_col = vec2<f32>(
            chapman_column(r, mu_s, radius, inv_h.x),
            chapman_column(r, mu_s, radius, inv_h.y),
        );
        // min(): a sample in the planet's shadow has an infinite column (exp → 0, no NaN).
        let tau = min(look.rayleigh.xyz * (here.x + sun_col.x) + mie_ext * (here.y + sun_col.y), vec3<f32>(1e30));
        let tr = exp(-tau);
        sum_r += dens.x * tr;
        sum_m += dens.y * tr;
    }
    let mu = dot(d, sun);
    let g = look.shell.w;
    let phase_r = 0.0596831 * (1.0 + mu * mu);
    let denom = max(1.0 + g * g - 2.0 * g * mu, 1e-4);
    let phase_m = 0.1193662 * (1.0 - g * g) * (1.0 + mu * mu) / ((2.0 + g * g) * denom * sqrt(denom));
    var out: Scatter;
    out.inscatter = look.light.x * (look.rayleigh.xyz * phase_r * sum_r + look.mie.xyz * phase_m * sum_m);
    out.transmittance = exp(-(look.rayleigh.xyz * column.x + mie_ext * column.y));
    return out;
}

// Sunlight reaching radius r (view space point p) through the atmosphere.
fn sun_transmittance(p: vec3<f32>, sun: vec3<f32>) -> vec3<f32> {
    let r = length(p);
    let mu_s = dot(p, sun) / r;
    let radius = look.shell.x;
    let col_r = chapman_column(r, mu_s, radius, look.rayleigh.w);
    let col_m = chapman_column(r, mu_s, radius, look.mie.w);
    return exp(-(look.rayleigh.xyz * col_r + look.mie.xyz * look.shell.z * col_m));
}

// Tone map of the sky-on image: 1 − exp(−k·c) (k = light.y).
fn tone_map(c: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(1.0) - exp(-look.light.y * max(c, vec3<f32>(0.0)));
}

// ---------------------------------------------------------------------------------------------
// Proto-texturing (infinite-landscapes-projected-grid.md §4.2).

// Surface-type weights from height h (m), slope s = 1 − n·up, the sine of the latitude and the
// perturbation q ∈ [−1, 1] (the noise texture: boundaries are not contour lines).
// x: forest over grass, y: sand, z: rock, w: snow — applied in that order, each over the
// result so far. Rust twin: look::proto::material_weights.
fn material_weights(h: f32, s: f32, sin_lat: f32, q: f32, patches: f32) -> vec4<f32> {
    let hp = h + 260.0 * q;
    let sp = s + 0.06 * q;
    let snow_line = 5400.0 - 5600.0 * sin_lat * sin_lat;
    let tree_line = snow_line - 1500.0;
    let forest = smoothstep(120.0, 500.0, hp) * (1.0 - smoothstep(tree_line - 250.0, tree_line + 250.0, hp))
        * smoothstep(0.42, 0.58, patches) * (1.0 - smoothstep(0.12, 0.2, sp));
    let sand = 1.0 - smoothstep(3.0, 18.0, h + 10.0 * q);
    let rock = smoothstep(0.16, 0.26, sp);
    let snow = smoothstep(snow_line - 150.0, snow_line + 150.0, hp) * (1.0 - smoothstep(0.32, 0.45, sp));
    return vec4<f32>(forest, sand, rock, snow);
}

// Where a colour (linear rgb) lies among the types' imagery prototypes: (½·log₂ luminance,
// log₂ r/g, log₂ b/g). Rust twin: look::proto::imagery_features.
fn imagery_features(c: vec3<f32>) -> vec3<f32> {
    let v = max(c, vec3<f32>(1e-4));
    let l = dot(v, vec3<f32>(0.2126, 0.7152, 0.0722));
    return vec3<f32>(0.5 * log2(l), log2(v.r / v.g), log2(v.b / v.g));
}

// The surface types' weights under imagery of colour c (linear rgb; not normalised), the
// luminance feature moved by the boundary noise q: the nearest prototypes win
// (2^(−8·d²)). Rust twin: look::proto::imagery_weights.
fn imagery_weights(c: vec3<f32>, q: f32) -> array<f32, 5> {
    let f = imagery_features(c) + vec3<f32>(0.25 * q, 0.0, 0.0);
    var w: array<f32, 5>;
    for (var k = 0u; k < 5u; k++) {
        let d = f - look.type_features[k].xyz;
        w[k] = exp2(-8.0 * dot(d, d));
    }
    return w;
}

// The sRGB encoding (IEC 61966-2-1) → linear light.
fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + 0.055) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
}
