#version 450
// Photo-consistency cost of every plane of a chunk at one reference pixel: each matched view is
// sampled (bilinear, clamp to edge) where the plane puts the pixel, and compared with the
// reference colour (mean absolute difference of the sRGB-encoded channels, truncated). Views
// whose sample is behind them or outside their image do not count.
// Bilinear interpolation at fraction f blurs a view by a kernel of variance f(1 - f) along each
// axis, but not at whole offsets, which pulls the costs of fine textures towards whole-pixel
// disparities ("pixel locking"). The reference is blurred to match, per sample: by
// [a, 1 - 2a, a] with a = f(1 - f)/2 along each axis (same variance).
//   COST 0 (robust): the mean of the two best half-aperture means (an occluder hides the
//          pixel from the views on one side of it only);
//   COST 1 (mean): the mean over all views (plain SAD);
//   COST 2 (drop-worst): the mean of the three best half-aperture means.
#include "depth_interface.glsl"

layout(constant_id = 0) const uint COST = 0;
// TRANSLATION 1: every warp is a translation (A' = [I | t], b'.z = 0: parallel cameras of equal
// intrinsics, or classic shift-and-sum), so a view's sample is the pixel plus an offset shared by
// all pixels; a view in the reference's row or column then needs two texels, not four.
layout(constant_id = 1) const uint TRANSLATION = 0;
// UNIFORM_VIEWS 1: the view records come from the uniform buffer (binding 9; at most
// UBO_VIEWS views), 0: from the storage buffer (any number).
layout(constant_id = 2) const uint UNIFORM_VIEWS = 0;
layout(local_size_x = 8, local_size_y = 8) in;

// View v's record from whichever buffer holds it. Member by member: the two blocks' structs
// have different layouts (std140, std430), and glslang rejects a conditional choosing between
// them.
SweepView view_of(uint v) {
    SweepView r;
    if (UNIFORM_VIEWS != 0u) {
        r.a0 = views_u[v].a0;
        r.a1 = views_u[v].a1;
        r.a2 = views_u[v].a2;
        r.b = views_u[v].b;
        r.halves = views_u[v].halves;
        r.info = views_u[v].info;
    } else {
        r.a0 = views[v].a0;
        r.a1 = views[v].a1;
        r.a2 = views[v].a2;
        r.b = views[v].b;
        r.halves = views[v].halves;
        r.info = views[v].info;
    }
    return r;
}

vec3 texel(uint base, ivec2 p) {
    p = clamp(p, ivec2(0), ivec2(pc.width - 1u, pc.height - 1u));
    return unpackUnorm4x8(texels[base + uint(p.y) * pc.width + uint(p.x)]).rgb;
}

vec3 bilinear(uint base, vec2 p) {
    vec2 f0 = floor(p);
    vec2 f = p - f0;
    ivec2 i = ivec2(f0);
    if (TRANSLATION == 1u) {
        // f is the same for every pixel here, so these branches do not diverge.
        if (f.y == 0.0) {
            return mix(texel(base, i), texel(base, i + ivec2(1, 0)), f.x);
        }
        if (f.x == 0.0) {
            return mix(texel(base, i), texel(base, i + ivec2(0, 1)), f.y);
        }
    }
    vec3 top = mix(texel(base, i), texel(base, i + ivec2(1, 0)), f.x);
    vec3 bottom = mix(texel(base, i + ivec2(0, 1)), texel(base, i + ivec2(1, 1)), f.x);
    return mix(top, bottom, f.y);
}

void main() {
    uvec2 px = gl_GlobalInvocationID.xy;
    if (px.x >= pc.width || px.y >= pc.height) {
        return;
    }
    uint n = pc.width * pc.height;
    uint pixel = px.y * pc.width + px.x;
    vec3 x = vec3(vec2(px), 1.0);
    vec3 ref = unpackUnorm4x8(texels[pc.ref_texel + pixel]).rgb;
    ivec2 ip = ivec2(px);
    // Second differences of the reference along x and y (clamped at the border).
    vec3 ddx = texel(pc.ref_texel, ip - ivec2(1, 0)) + texel(pc.ref_texel, ip + ivec2(1, 0))
        - 2.0 * ref;
    vec3 ddy = texel(pc.ref_texel, ip - ivec2(0, 1)) + texel(pc.ref_texel, ip + ivec2(0, 1))
        - 2.0 * ref;
    vec2 hi = vec2(float(pc.width), float(pc.height)) - 0.5;
    for (uint k = 0u; k < pc.plane_count; ++k) {
        float p = pc.p0 + float(pc.plane_first + k) * pc.dp;
        vec4 sum = vec4(0.0);
        vec4 count = vec4(0.0);
        float total = 0.0;
        float used = 0.0;
        for (uint v = 0u; v < pc.view_count; ++v) {
            SweepView sv = view_of(v);
            vec2 q;
            if (TRANSLATION == 1u) {
                q = x.xy + sv.a2.xy + sv.b.xy * p;
            } else {
                vec3 y = mat3(sv.a0.xyz, sv.a1.xyz, sv.a2.xyz) * x + sv.b.xyz * p;
                if (y.z <= 0.0) {
                    continue; // behind view v
                }
                q = y.xy / y.z;
            }
            if (any(lessThan(q, vec2(-0.5))) || any(greaterThan(q, hi))) {
                continue; // outside view v
            }
            vec4 halves = sv.halves;
            vec2 f = q - floor(q);
            vec2 a = 0.5 * f * (1.0 - f);
            vec3 d = abs(bilinear(sv.info.x, q) - (ref + a.x * ddx + a.y * ddy));
            float e = min((d.r + d.g + d.b) * (1.0 / 3.0), pc.truncation);
            sum += e * halves;
            count += halves;
            total += e;
            used += 1.0;
        }
        float c;
        if (COST == 1u) {
            c = used > 0.0 ? total / used : pc.truncation;
        } else {
            vec4 m = mix(vec4(BIG), sum / max(count, vec4(1.0)), greaterThan(count, vec4(0.0)));
            float a = min(m.x, m.y);
            float b = max(m.x, m.y);
            float cc = min(m.z, m.w);
            float dd = max(m.z, m.w);
            float first = min(a, cc);
            float second = min(max(a, cc), min(b, dd));
            float third = max(max(a, cc), min(b, dd));
            if (COST == 2u && third < BIG) {
                c = (first + second + third) * (1.0 / 3.0);
            } else {
                c = second < BIG ? 0.5 * (first + second) : (first < BIG ? first : pc.truncation);
            }
        }
        cost[k * n + pixel] = c;
    }
}
