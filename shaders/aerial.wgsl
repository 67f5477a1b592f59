// The aerial-perspective volume (issue 35: the haze per pixel from a table, not per vertex;
// after Hillaire, EGSR 2020, "A Scalable and Production Ready Sky and Atmosphere Rendering
// Technique", §5.3): a froxel grid over the frame, AERIAL_SIZE_X × AERIAL_SIZE_Y cells across
// the image and AERIAL_SIZE_Z slices along each cell's ray, holding the light scattered in
// between the eye and the slice's distance and the transmittance of that segment. A terrain
// fragment reads both filtered at its pixel and its distance (terrain.wgsl aerial_at), so the
// haze no longer depends on where the mesh has vertices.
//
// Slices (LookUniforms.aerial, render::aerial::slices):
// - with the eye inside the atmosphere, by distance, spaced geometrically between the nearest
//   distance terrain can be at, d0, and the farthest it can be seen at, d1: slice k at
//   d0·(d1/d0)^(k/(Z−1));
// - from above the atmosphere, by the altitude the ray descends to, evenly from the highest
//   terrain a_hi down to the lowest a_lo: slice k where the ray first meets the sphere of
//   radius R + a_hi − k·(a_hi − a_lo)/(Z−1) (at its closest approach where it passes above).
//   Seen from space all the haze lies in the last few kilometres above the ground, which
//   distance slices a hundred kilometres apart would step through in rings; a terrain point's
//   altitude places it among these slices as finely as the terrain's relief needs.
// One thread per cell marches its ray slice by slice, integrating each segment with
// atmosphere_scatter (common/look.wgsl) and composing: I ← I + T·I_seg, T ← T·T_seg.

@group(0) @binding(0) var<uniform> look: LookUniforms;
@group(1) @binding(0) var aerial_inscatter_out: texture_storage_3d<rgba16float, write>;
@group(1) @binding(1) var aerial_transmittance_out: texture_storage_3d<rgba16float, write>;

// Distance of slice k (m) along the unit ray d from the eye.
fn slice_distance(k: u32, eye: vec3<f32>, d: vec3<f32>) -> f32 {
    let f = f32(k) / f32(AERIAL_SIZE_Z - 1u);
    if look.aerial.w < 0.5 {
        return look.aerial.x * exp(f * look.aerial.z);
    }
    // The ray's first meeting with the sphere of radius r (perpendicular form, as in
    // atmosphere_scatter), or its closest approach to the centre where it passes above.
    let r = look.shell.x + look.aerial.x + (1.0 - f) * look.aerial.z;
    let b = dot(eye, d);
    let perp = eye - b * d;
    let p = sqrt(dot(perp, perp));
    let half_chord = sqrt(max((r - p) * (r + p), 0.0));
    return max(-b - half_chord, 0.0);
}

// The ray d from the eye, or by altitude where it misses the sphere of the lowest terrain,
// the ray tangent to it toward d (selects, not branches: every lane runs both on a CPU).
fn limb_ray(d: vec3<f32>, eye: vec3<f32>) -> vec3<f32> {
    let lowest = look.shell.x + look.aerial.x;
    let e = length(eye);
    let n = -eye / e;
    let b = dot(eye, d);
    let perp = eye - b * d;
    let misses = look.aerial.w > 0.5 && (dot(perp, perp) > lowest * lowest || b > 0.0);
    let side = d - dot(d, n) * n;
    let u = side / max(length(side), 1e-20);
    let sin_a = min(lowest / e, 1.0);
    let tangent = n * sqrt(max(1.0 - sin_a * sin_a, 0.0)) + u * sin_a;
    return select(d, tangent, misses);
}

@compute @workgroup_size(8, 8, 1)
fn cs_aerial(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= AERIAL_SIZE_X || id.y >= AERIAL_SIZE_Y {
        return;
    }
    // The cell's ray: through its centre's pixel position (u = x_px / width at the texel's
    // centre), from the eye at the origin of view space.
    let uv = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(f32(AERIAL_SIZE_X), f32(AERIAL_SIZE_Y));
    let ndc = vec2<f32>(2.0 * uv.x - 1.0, 1.0 - 2.0 * uv.y);
    let p = look.view_from_clip * vec4<f32>(ndc, 1.0, 1.0);
    let eye = vec3<f32>(0.0, 0.0, look.eye_radius_m);
    // By altitude, a cell whose centre's ray passes beside the planet (at the limb) takes the
    // ray tangent to the lowest terrain's sphere in the same plane instead: its pixels that
    // do meet terrain see it along such grazing rays, and the filter then mixes the limb's
    // cells with values of the same kind (a ray that misses would carry only the thin air
    // above its closest approach, a dark band a cell wide).
    let d = limb_ray(normalize(p.xyz / p.w), eye);
    let sun = look.sun.xyz;
    // The segment from the eye to the first slice: the whole atmosphere above the nearest
    // terrain seen from space, so more samples.
    let d0 = slice_distance(0u, eye, d);
    let first = atmosphere_scatter(eye, d, d0, sun, 8u);
    var inscatter = first.inscatter;
    var transmittance = first.transmittance;
    textureStore(aerial_inscatter_out, vec3<u32>(id.xy, 0u), vec4<f32>(inscatter, 0.0));
    textureStore(aerial_transmittance_out, vec3<u32>(id.xy, 0u), vec4<f32>(transmittance, 0.0));
    var t = d0;
    for (var k = 1u; k < AERIAL_SIZE_Z; k++) {
        let t_next = max(slice_distance(k, eye, d), t);
        let s = atmosphere_scatter(eye + t * d, d, t_next - t, sun, 1u);
        inscatter += transmittance * s.inscatter;
        transmittance *= s.transmittance;
        t = t_next;
        textureStore(aerial_inscatter_out, vec3<u32>(id.xy, k), vec4<f32>(inscatter, 0.0));
        textureStore(aerial_transmittance_out, vec3<u32>(id.xy, k), vec4<f32>(transmittance, 0.0));
    }
}
