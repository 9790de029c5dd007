#version 450
// Defocused views (refocus::defocus, docs/conventions.md §11): each view of a draw box-filtered
// over the footprint its aperture cell sweeps at every one of its pixels, so the refocus sum
// reads it once per view (DEFOCUS in refocus_accumulate.glsl). Three stages, one dispatch each,
// over the views [first_view, first_view + view_count) of the uploaded plan, each view in the
// layer of its footprint's map index (vis.y):
//   STAGE 0: the summed-area table's rows: one invocation per (row, view) adds the view's texels
//            (in the averaging space, as `texel` reads them, minus an offset near the view's mean
//            so that f32 keeps the small boxes' precision; the offset is kept in alpha) along
//            the row;
//   STAGE 1: its columns: one invocation per (column, view) adds the row sums down the column;
//   STAGE 2: the box: one invocation per (texel, view) finds the reference ray that samples the
//            view there (the inverse homography), the footprint at the depth the view sees
//            there (binding 8 holds the filled maps), and reads the box's mean from four
//            bilinear fetches of the table.
#include "refocus_accumulate.glsl"

layout(local_size_x = 8, local_size_y = 8) in;
layout(constant_id = 8) const uint STAGE = 0;
// (W + 1) x (H + 1) texels a layer: texel (i, j) holds the sum of the texels [0, i) x [0, j)
// minus the offset in rgb, and the offset in alpha (a constant: any bilinear read returns it).
// The tables depend on the views alone, so the pass builds them once per upload.
layout(set = 1, binding = 0, rgba32f) uniform image2DArray sat_image;
layout(set = 1, binding = 1, rgba16f) uniform writeonly image2DArray defocused_image;

// The offset subtracted from every texel of view `layer`: its prefilter pyramid's last level
// (about the view's mean; any value serves, it only keeps the table's magnitude down).
vec3 offset_of(int layer) {
    int last = textureQueryLevels(views) - 1;
    return decode(texelFetch(views, ivec3(0, 0, layer), last).rgb);
}

// The width of the texel box that stands for a footprint `extent` pixels long
// (refocus::defocus::box_width): the box whose discrete weights have variance extent^2 / 12.
float box_width(float extent) {
    float v = extent * extent / 12.0;
    if (!(v > 0.0)) {
        return 0.0;
    }
    float m = max(floor((sqrt(12.0 * v + 1.0) + 1.0) * 0.5), 1.0);
    float c = (m - 1.0) * m * (2.0 * m - 1.0) / 3.0;
    float b = (m * m * (2.0 * m - 1.0) - c) / (m * m - v);
    if (m * m <= v || b > 2.0 * m + 1.0) {
        m += 1.0;
    } else if (m > 1.0) {
        float m1 = m - 1.0;
        float c1 = (m1 - 1.0) * m1 * (2.0 * m1 - 1.0) / 3.0;
        float b1 = (m1 * m1 * (2.0 * m1 - 1.0) - c1) / (m1 * m1 - v);
        if (b1 <= 2.0 * m - 1.0 && m1 * m1 > v) {
            m = m1;
        }
    }
    c = (m - 1.0) * m * (2.0 * m - 1.0) / 3.0;
    b = (m * m * (2.0 * m - 1.0) - c) / (m * m - v);
    return clamp(b, 2.0 * m - 1.0, 2.0 * m + 1.0);
}

// The table at edge coordinates e in [0, W] x [0, H] (bilinear between its corners in f32,
// refocus::defocus::SummedArea::integral: the integral of the texels as squares over
// [0, e.x] x [0, e.y]). Loads rather than a sampler: exact weights (a sampler snaps them to 8
// bits), and linear filtering of f32 images is optional in Vulkan (on llvmpipe the loads
// measured no slower).
vec4 integral(vec2 e, float layer) {
    vec2 f0 = min(floor(e), pc.view_size - 1.0);
    vec2 f = e - f0;
    ivec3 i = ivec3(ivec2(f0), int(layer));
    vec4 a = imageLoad(sat_image, i);
    vec4 b = imageLoad(sat_image, i + ivec3(1, 0, 0));
    vec4 c = imageLoad(sat_image, i + ivec3(0, 1, 0));
    vec4 d = imageLoad(sat_image, i + ivec3(1, 1, 0));
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

void main() {
    uvec3 id = gl_GlobalInvocationID;
    if (id.z >= pc.view_count) {
        return;
    }
    uint k = pc.first_view + id.z;
    ViewWarp w = warp_of(k);
    int layer = int(w.a0.w);
    int map = int(footprints[k].vis.y);
    ivec2 size = ivec2(pc.view_size);
    if (STAGE == 0u) {
        int j = int(id.x);
        if (id.y != 0u || j > size.y) {
            return;
        }
        vec3 offset = offset_of(layer);
        float o = dot(offset, vec3(1.0)) / 3.0;
        imageStore(sat_image, ivec3(0, j, map), vec4(vec3(0.0), o));
        vec3 run = vec3(0.0);
        for (int i = 0; i < size.x; ++i) {
            if (j > 0) {
                run += texel(ivec2(i, j - 1), layer) - o;
            }
            imageStore(sat_image, ivec3(i + 1, j, map), vec4(run, o));
        }
        return;
    }
    if (STAGE == 1u) {
        int i = int(id.x);
        if (id.y != 0u || i > size.x) {
            return;
        }
        vec3 run = vec3(0.0);
        for (int j = 1; j <= size.y; ++j) {
            vec4 row = imageLoad(sat_image, ivec3(i, j, map));
            run += row.rgb;
            imageStore(sat_image, ivec3(i, j, map), vec4(run, row.a));
        }
        return;
    }
    ivec2 px = ivec2(id.xy);
    if (any(greaterThanEqual(px, size))) {
        return;
    }
    uint n = uint(size.x) * uint(size.y);
    float sigma = view_sigma(uint(map) * n + uint(px.y) * uint(size.x) + uint(px.x));
    bool boxed = false;
    vec3 result = vec3(0.0);
    mat3 a = mat3(w.a0.xyz, w.a1.xyz, w.a2.xyz);
    vec3 m = pc.plane.xyz;
    // H = A + b m^T, column by column.
    mat3 h = mat3(a[0] + w.b_weight.xyz * m.x, a[1] + w.b_weight.xyz * m.y,
                  a[2] + w.b_weight.xyz * m.z);
    vec3 xh = inverse(h) * vec3(vec2(px), 1.0);
    if (sigma >= 0.0 && xh.z != 0.0) {
        vec3 x = vec3(xh.xy / xh.z, 1.0);
        float s = surface_s(x, max(dot(m, x), 0.0));
        vec3 y0 = a * x + w.b_weight.xyz * s;
        float d = s - sigma;
        if (y0.z > 0.0) {
            // The footprint's extent: the bounding box of the cell's four corners.
            vec2 p0 = y0.xy / y0.z;
            vec2 lo = vec2(1e30);
            vec2 hi = vec2(-1e30);
            for (int c = 0; c < 4; ++c) {
                vec2 uv = vec2(float(c & 1), float(c >> 1));
                vec3 q = y0 + (footprints[k].origin.xyz + uv.x * footprints[k].span_s.xyz
                               + uv.y * footprints[k].span_t.xyz) * d;
                vec2 p = q.z > 0.0 ? q.xy / q.z : p0;
                lo = min(lo, p);
                hi = max(hi, p);
            }
            vec2 half_box = vec2(box_width(hi.x - lo.x), box_width(hi.y - lo.y)) * 0.5;
            if (half_box != vec2(0.0)) {
                vec2 e0 = clamp(vec2(px) - half_box + 0.5, vec2(0.0), pc.view_size);
                vec2 e1 = clamp(vec2(px) + half_box + 0.5, vec2(0.0), pc.view_size);
                float area = (e1.x - e0.x) * (e1.y - e0.y);
                if (area > 0.0) {
                    float l = float(map);
                    vec4 a11 = integral(e1, l);
                    vec3 box = a11.rgb - integral(vec2(e0.x, e1.y), l).rgb
                             - integral(vec2(e1.x, e0.y), l).rgb + integral(e0, l).rgb;
                    result = box / area + a11.a;
                    boxed = true;
                }
            }
        }
    }
    if (!boxed) {
        result = texel(px, layer);
    }
    imageStore(defocused_image, ivec3(px, map), vec4(result, 1.0));
}
