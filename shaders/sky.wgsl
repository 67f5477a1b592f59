// The sky pass (README "The look"): one full-screen triangle drawn after the terrain at the far
// depth (reversed-Z 0), so it shades only the pixels the terrain left empty. Each pixel's ray
// from the eye is integrated through the atmosphere (common/look.wgsl): the sky from the
// ground, the thin glow around the disk from space, the sun's disk; black beyond the shell.
// Where the ray meets the planet's sphere (no terrain drawn there), it stops there.

@group(0) @binding(0) var<uniform> look: LookUniforms;

struct SkyOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) ndc: vec2<f32>,
}

@vertex
fn vs_sky(@builtin(vertex_index) index: u32) -> SkyOut {
    // (−1, −1), (3, −1), (−1, 3): covers the screen.
    let x = f32((index & 1u) * 4u) - 1.0;
    let y = f32((index & 2u) * 2u) - 1.0;
    var out: SkyOut;
    out.clip = vec4<f32>(x, y, 0.0, 1.0);
    out.ndc = vec2<f32>(x, y);
    return out;
}

@fragment
fn fs_sky(in: SkyOut) -> @location(0) vec4<f32> {
    let p = look.view_from_clip * vec4<f32>(in.ndc, 1.0, 1.0);
    let d = normalize(p.xyz / p.w);
    let eye = vec3<f32>(0.0, 0.0, look.eye_radius_m);
    let sun = look.sun.xyz;
    // The planet's sphere ahead? (perpendicular form, as in atmosphere_scatter)
    let radius = look.shell.x;
    let b = dot(eye, d);
    let perp = eye - b * d;
    let p2 = dot(perp, perp);
    var t_max = 3.0e38;
    var hits = false;
    if p2 < radius * radius && b < 0.0 {
        t_max = -b - sqrt((radius - sqrt(p2)) * (radius + sqrt(p2)));
        hits = true;
    }
    // Rays that miss the shell (most of the screen from space) are black: skip the integral.
    let top = look.shell.y;
    if p2 >= top * top {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let s = atmosphere_scatter(eye, d, t_max, sun, 16u);
    var c = s.inscatter;
    if !hits && dot(d, sun) > look.sun_cos {
        // The sun's disk, dimmed and reddened by the air in front of it.
        c += look.light.x * s.transmittance;
    }
    return vec4<f32>(tone_map(c), 1.0);
}
