// The sky pass (docs/look.md#the-look): one full-screen triangle drawn after the terrain at the far
// depth (reversed-Z 0), so it shades only the pixels the terrain left empty; from outside the
// atmosphere, only the ring of directions that can meet the shell (vs_sky_ring: a CPU
// rasteriser pays for every pixel a pass covers). Each pixel's ray from the eye is integrated
// through the atmosphere (common/look.wgsl): the sky from the ground, the thin glow around the
// disk from space, the sun's disk; black beyond the shell. Where the ray meets the planet's
// sphere (no terrain drawn there), it stops there.
//
// With the eye inside the atmosphere the integral is taken once per frame per direction of a
// sky-view table (cs_sky_table, after Hillaire 2020) instead of once per pixel: the sky is a
// smooth function of the direction, and a pixel then reads one filtered texel. From space the
// glow is a ring a few milliradians wide, too thin for the table's rows: there every pixel
// integrates its own ray (TABLE off).

@group(0) @binding(0) var<uniform> look: LookUniforms;
// The sky-view table (TABLE): in-scattered light per direction at sky_table_uv, filtered
// (linear, azimuth repeating).
@group(0) @binding(1) var sky_table: texture_2d<f32>;
@group(0) @binding(2) var sky_sampler: sampler;
// The table's texels, written by cs_sky_table.
@group(1) @binding(0) var sky_table_out: texture_storage_2d<rgba16float, write>;

override TABLE: bool = false;

struct SkyOut {
    @builtin(position) clip: vec4<f32>,
}

@vertex
fn vs_sky(@builtin(vertex_index) index: u32) -> SkyOut {
    // (−1, −1), (3, −1), (−1, 3): covers the screen.
    let x = f32((index & 1u) * 4u) - 1.0;
    let y = f32((index & 2u) * 2u) - 1.0;
    var out: SkyOut;
    out.clip = vec4<f32>(x, y, 0.0, 1.0);
    return out;
}

// From outside the shell: the ring of directions between the cone of rays that meet a sphere
// inside all terrain and the cone of rays that meet the shell (look::SkyRing, whose `contains`
// is this polygon's Rust twin), SKY_RING_SEGMENTS quads of two triangles each: corners inner k,
// outer k, outer k+1 and inner k, outer k+1, inner k+1. The vertices lie far beyond all terrain,
// so the depth test still leaves the terrain's pixels alone; the rest of the frame keeps the
// clear colour, the black the pass would give there.
@vertex
fn vs_sky_ring(@builtin(vertex_index) index: u32) -> SkyOut {
    let corner = index % 6u;
    let next = corner == 2u || corner == 4u || corner == 5u;
    let outer = corner == 1u || corner == 2u || corner == 4u;
    let k = (index / 6u + select(0u, 1u, next)) % SKY_RING_SEGMENTS;
    let azimuth = f32(k) * (6.28318530718 / f32(SKY_RING_SEGMENTS));
    let t = select(look.sky_ring.x, look.sky_ring.y, outer);
    let sc = sin_cos_precise(azimuth);
    let rel = vec3<f32>(t * sc.y, t * sc.x, -1.0) * look.sky_ring.z;
    var out: SkyOut;
    out.clip = look.clip_from_view * vec4<f32>(rel, 1.0);
    return out;
}

// Elevation of the planet's horizon seen from the eye (the tangent to its sphere), radians:
// −acos(R/r) as an atan2 with no cancellation just above the ground. The table's angles use
// trig.wgsl's forms: a driver's builtins may be 2^-11 off, half a pixel at the horizon's rows.
fn horizon_elevation() -> f32 {
    let r = max(look.eye_radius_m, look.shell.x);
    return -atan2_precise(sqrt((r - look.shell.x) * (r + look.shell.x)), look.shell.x);
}

// Table coordinates of view direction d (z̃ up at the eye): u the azimuth, v the elevation
// through the horizon's, a square root on each side so that the rows crowd at the horizon
// where the sky changes fastest: v = ½(1 − √((e − e_h)/(π/2 − e_h))) above it, ½(1 + √((e_h −
// e)/(e_h + π/2))) below.
fn sky_table_uv(d: vec3<f32>) -> vec2<f32> {
    let e_h = horizon_elevation();
    let e = atan2_precise(d.z, length(d.xy));
    let above = sqrt(clamp((e - e_h) / (1.5707964 - e_h), 0.0, 1.0));
    let below = sqrt(clamp((e_h - e) / (e_h + 1.5707964), 0.0, 1.0));
    let v = select(0.5 + 0.5 * below, 0.5 - 0.5 * above, e >= e_h);
    let u = atan2_precise(d.y, d.x) * 0.15915494 + 0.5;
    return vec2<f32>(u, v);
}

// The direction of table coordinates (u, v): sky_table_uv inverted.
fn sky_table_dir(uv: vec2<f32>) -> vec3<f32> {
    let e_h = horizon_elevation();
    let a = 1.0 - 2.0 * uv.y;
    let b = 2.0 * uv.y - 1.0;
    let e = select(e_h - b * b * (e_h + 1.5707964), e_h + a * a * (1.5707964 - e_h), uv.y < 0.5);
    let az = (uv.x - 0.5) * 6.2831853;
    let se = sin_cos_precise(e);
    let sa = sin_cos_precise(az);
    return vec3<f32>(se.y * sa.y, se.y * sa.x, se.x);
}

// Where the ray from the eye in direction d meets the planet's sphere (perpendicular form, as
// in atmosphere_scatter): the distance, or 3e38 when it misses.
fn sphere_hit(eye: vec3<f32>, d: vec3<f32>) -> f32 {
    let radius = look.shell.x;
    let b = dot(eye, d);
    let perp = eye - b * d;
    let p2 = dot(perp, perp);
    var t_max = 3.0e38;
    if p2 < radius * radius && b < 0.0 {
        t_max = -b - sqrt((radius - sqrt(p2)) * (radius + sqrt(p2)));
    }
    return t_max;
}

@compute @workgroup_size(8, 8, 1)
fn cs_sky_table(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(sky_table_out);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let uv = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(size);
    let d = sky_table_dir(uv);
    let eye = vec3<f32>(0.0, 0.0, look.eye_radius_m);
    let s = atmosphere_scatter(eye, d, sphere_hit(eye, d), look.sun.xyz, 16u);
    textureStore(sky_table_out, id.xy, vec4<f32>(s.inscatter, 1.0));
}

@fragment
fn fs_sky(in: SkyOut) -> @location(0) vec4<f32> {
    // The pixel's centre in NDC (the same whichever geometry covers it).
    let ndc = vec2<f32>(in.clip.x * look.viewport.z - 1.0, 1.0 - in.clip.y * look.viewport.w);
    let p = look.view_from_clip * vec4<f32>(ndc, 1.0, 1.0);
    let d = normalize(p.xyz / p.w);
    let eye = vec3<f32>(0.0, 0.0, look.eye_radius_m);
    let sun = look.sun.xyz;
    let t_max = sphere_hit(eye, d);
    let hits = t_max < 3.0e38;
    var c: vec3<f32>;
    var sun_t: vec3<f32>;
    if TABLE {
        c = textureSampleLevel(sky_table, sky_sampler, sky_table_uv(d), 0.0).rgb;
        // The air in front of the sun's disk, as the haze's sunlight takes it.
        sun_t = sun_transmittance(eye, d);
    } else {
        // Rays that miss the shell (most of the screen from space) are black: skip the integral.
        let top = look.shell.y;
        let b = dot(eye, d);
        let perp = eye - b * d;
        if dot(perp, perp) >= top * top {
            return vec4<f32>(0.0, 0.0, 0.0, 1.0);
        }
        let s = atmosphere_scatter(eye, d, t_max, sun, 16u);
        c = s.inscatter;
        sun_t = s.transmittance;
    }
    if !hits && dot(d, sun) > look.sun_cos {
        // The sun's disk, dimmed and reddened by the air in front of it.
        c += look.light.x * sun_t;
    }
    return vec4<f32>(tone_map(c), 1.0);
}
