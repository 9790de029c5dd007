#version 450
// Boxed footprints (refocus::boxed, docs/antialias.md "Boxed footprints"): the default
// anti-aliasing's fast path, four dispatches before the accumulation, over every view of the
// uploaded plan. Every pixel ends with a record in `results` (binding 10 of the accumulation's
// input set, so refocus_accumulate.glsl reads it): (sum, weight) where this stage decides the
// pixel, alpha -1 where the sub-samples do (BOXED in refocus_accumulate.glsl).
//   STAGE 0 (sums): one invocation per pixel samples every view at its cell's centroid for the
//            pixel's own residual and sums the samples per cell group, written into the group's
//            table as 16-bit fixed point; the same loop's plain samples feed the focus test.
//            Where the views agree: their plain sum; no depth: the plain sum; own surface in
//            focus, a nearer surface the rays reach (refocus::boxed::needs_tests) or a footprint
//            under the plan's minimum: -1 (sub-samples); else -2 (the box, stage 3).
//   STAGE 1 (rows): one invocation per (table row, group) adds the row up in place (uint, so
//            modulo 2^32: a box's sum is exact while it holds at most 65536 pixels).
//   STAGE 2 (columns): the same down the columns: a summed-area table per group.
//   STAGE 3 (box): one invocation per pixel marked -2: each group's mean over the footprint's
//            box from sixteen reads of its table, summed over the groups.
#include "refocus_accumulate.glsl"

layout(constant_id = 8) const uint STAGE = 0u;
layout(local_size_x_id = 9, local_size_y_id = 10) in;

const uint MAX_GROUPS = 8u;   // refocus::layered::MAX_GROUPS
const uint FRONT_LEVELS = 7u; // refocus::boxed::FRONT_LEVELS
const float MAX_BOX_PX = 255.0; // refocus::boxed::MAX_BOX_PX
const float QUANT = 16384.0;  // refocus::boxed::QUANT: table units per unit of colour

// Mirrored by `GpuBoxParams` (src/passes/refocus/boxed.rs).
layout(std140, set = 1, binding = 0) uniform BoxParams {
    ivec4 header;   // group count, fronts present (1) or not (0)
    vec4 scale;     // x: the rays' longest parallax (px per unit residual); y: the smallest
                    // footprint boxed (px, of a full cell); z: a full cell's footprint px per
                    // unit residual; w: 1 / the plan's total weight (the table's scale)
    vec4 units[MAX_GROUPS];          // xy: group g's footprint px per unit residual
    uvec4 group_of4[UBO_WARPS / 4u]; // view k's group at [k / 4][k % 4]
} bp;
// Per level j and pixel: the nearest sigma within 2^j px (refocus::boxed::front_levels).
layout(std430, set = 1, binding = 1) readonly buffer Fronts { float fronts[]; };
// Per group: (W + 1) x (H + 1) texels of (colour, weight) sums / total weight * QUANT.
layout(std430, set = 1, binding = 2) buffer Tables { uvec4 tables[]; };
layout(std430, set = 1, binding = 3) buffer Results { vec4 results[]; };

uint table_index(uint g, int i, int j) {
    uint tw = uint(pc.view_size.x) + 1u;
    uint th = uint(pc.view_size.y) + 1u;
    return (g * th + uint(j)) * tw + uint(i);
}

// The own surface's slope along x plus along y (refocus::boxed::own_slope).
float own_slope(ivec2 p, float c) {
    ivec2 size = ivec2(pc.view_size);
    float total = 0.0;
    for (int axis = 0; axis < 2; ++axis) {
        ivec2 step = axis == 0 ? ivec2(1, 0) : ivec2(0, 1);
        ivec2 qa = p + step;
        ivec2 qb = p - step;
        bool ina = all(greaterThanEqual(qa, ivec2(0))) && all(lessThan(qa, size));
        bool inb = all(greaterThanEqual(qb, ivec2(0))) && all(lessThan(qb, size));
        float a = ina ? scene_sigma[2 * (qa.y * size.x + qa.x)] : -1.0;
        float b = inb ? scene_sigma[2 * (qb.y * size.x + qb.x)] : -1.0;
        if (a >= 0.0 && b >= 0.0) {
            total += min(abs(a - c), abs(c - b));
        } else if (a >= 0.0) {
            total += abs(a - c);
        } else if (b >= 0.0) {
            total += abs(b - c);
        }
    }
    return total;
}

// refocus::boxed::needs_tests in f32.
bool needs_tests(ivec2 p, float s, float sigma) {
    float ray = bp.scale.x;
    if (bp.header.y == 0 || ray <= 0.0) {
        return false;
    }
    uint n = uint(pc.view_size.x) * uint(pc.view_size.y);
    uint i = uint(p.y) * uint(pc.view_size.x) + uint(p.x);
    float slope = own_slope(p, sigma);
    for (uint j = 0u; j < FRONT_LEVELS; ++j) {
        float near = fronts[j * n + i];
        float r = float(1u << j);
        float step = near - sigma - slope * r;
        float dmin = j == 0u ? 1.0 : float(1u << (j - 1u)) + 1.0;
        float reach = ray * max(abs(s - near), abs(s - sigma) + near - sigma) + 2.0;
        if (step * ray >= 1.0 && reach >= dmin) {
            return true;
        }
    }
    return false;
}

uint group_of(uint k) {
    return bp.group_of4[k >> 2][k & 3u];
}

// The exact sum of a group's table over the box [e0, e1] (edge coordinates, texels as
// squares): the integral's large terms cancel in uint (modulo 2^32) before any fraction is
// applied, so the sum keeps every bit whatever the table's magnitude.
vec4 box_sum(uint g, vec2 e0, vec2 e1) {
    ivec2 hi = ivec2(pc.view_size) - 1;
    ivec2 i0 = min(ivec2(floor(e0)), hi);
    ivec2 i1 = min(ivec2(floor(e1)), hi);
    vec2 f0 = e0 - vec2(i0);
    vec2 f1 = e1 - vec2(i1);
    int cols[4] = int[4](i0.x, i0.x + 1, i1.x, i1.x + 1);
    int rows[4] = int[4](i0.y, i0.y + 1, i1.y, i1.y + 1);
    // Per row r: the three column differences whose combination is the x-integral up to r.
    uvec4 da[4];
    uvec4 db[4];
    uvec4 dc[4];
    for (int r = 0; r < 4; ++r) {
        uvec4 t0 = tables[table_index(g, cols[0], rows[r])];
        uvec4 t1 = tables[table_index(g, cols[1], rows[r])];
        uvec4 t2 = tables[table_index(g, cols[2], rows[r])];
        uvec4 t3 = tables[table_index(g, cols[3], rows[r])];
        da[r] = t2 - t0; // columns [i0, i1)
        db[r] = t3 - t2; // column i1
        dc[r] = t1 - t0; // column i0
    }
    // Down the rows the same way: rows [j0, j1), row j1, row j0.
    vec4 a = vec4(da[2] - da[0]) + f1.y * vec4(da[3] - da[2]) - f0.y * vec4(da[1] - da[0]);
    vec4 b = vec4(db[2] - db[0]) + f1.y * vec4(db[3] - db[2]) - f0.y * vec4(db[1] - db[0]);
    vec4 c = vec4(dc[2] - dc[0]) + f1.y * vec4(dc[3] - dc[2]) - f0.y * vec4(dc[1] - dc[0]);
    return a + f1.x * b - f0.x * c;
}

// One axis of a box centred on pixel centre c with width e, clipped to [0, n] in edge
// coordinates; an empty interval becomes the texel under c (refocus::boxed::nearest_box).
vec2 box_axis(float c, float e, float n) {
    float a = max(c - 0.5 * e + 0.5, 0.0);
    float b = min(c + 0.5 * e + 0.5, n);
    if (!(b > a)) {
        a = clamp(floor(c + 0.5), 0.0, n - 1.0);
        b = a + 1.0;
    }
    return vec2(a, b);
}

void main() {
    ivec2 size = ivec2(pc.view_size);
    uint groups = uint(bp.header.x);
    if (STAGE == 1u || STAGE == 2u) {
        // One invocation per line of one group's table.
        uint g = gl_GlobalInvocationID.y;
        int line = int(gl_GlobalInvocationID.x);
        if (g >= groups) {
            return;
        }
        if (STAGE == 1u) {
            if (line > size.y) {
                return;
            }
            tables[table_index(g, 0, line)] = uvec4(0u);
            uvec4 run = uvec4(0u);
            for (int i = 1; i <= size.x; ++i) {
                uint t = table_index(g, i, line);
                run += line == 0 ? uvec4(0u) : tables[t];
                tables[t] = run;
            }
        } else {
            if (line > size.x) {
                return;
            }
            uvec4 run = uvec4(0u);
            for (int j = 1; j <= size.y; ++j) {
                uint t = table_index(g, line, j);
                run += tables[t];
                tables[t] = run;
            }
        }
        return;
    }
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, size))) {
        return;
    }
    uint i = uint(p.y * size.x + p.x);
    vec3 x = vec3(vec2(p), 1.0);
    float s = surface_s(x, max(dot(pc.plane.xyz, x), 0.0));
    float sigma = scene_sigma[2 * i];
    float d = sigma >= 0.0 ? s - sigma : 0.0;
    if (STAGE == 3u) {
        if (results[i].a != -2.0) {
            return;
        }
        vec4 total = vec4(0.0);
        for (uint g = 0u; g < groups; ++g) {
            vec2 e = min(bp.units[g].xy * abs(d), vec2(MAX_BOX_PX));
            vec2 bx = box_axis(float(p.x), e.x, pc.view_size.x);
            vec2 by = box_axis(float(p.y), e.y, pc.view_size.y);
            float area = (bx.y - bx.x) * (by.y - by.x);
            total += box_sum(g, vec2(bx.x, by.x), vec2(bx.y, by.y)) / area;
        }
        results[i] = total / (QUANT * bp.scale.w);
        return;
    }
    // STAGE 0.
    vec2 lo = vec2(-0.5);
    vec2 hi = pc.view_size - 0.5;
    vec4 sums[MAX_GROUPS];
    for (uint g = 0u; g < MAX_GROUPS; ++g) {
        sums[g] = vec4(0.0);
    }
    vec3 plain = vec3(0.0);
    float plain_w = 0.0;
    vec3 lin = vec3(0.0);
    vec3 root = vec3(0.0);
    for (uint k = 0u; k < pc.total_views; ++k) {
        ViewWarp w = warp_of(k);
        vec3 y0 = mat3(w.a0.xyz, w.a1.xyz, w.a2.xyz) * x + w.b_weight.xyz * s;
        if (y0.z <= 0.0) {
            continue;
        }
        float wk = w.b_weight.w;
        vec2 p0 = y0.xy / y0.z;
        bool in0 = all(greaterThanEqual(p0, lo)) && all(lessThanEqual(p0, hi));
        vec3 c0 = in0 ? fetch(p0, w.a0.w) : vec3(0.0);
        if (in0) {
            plain += wk * c0;
            plain_w += wk;
            vec3 cp = max(c0, vec3(0.0));
            lin += wk * cp;
            root += wk * sqrt(cp);
        }
        // The cell's centroid for the pixel's own residual (the plain sample for full cells).
        vec3 centre = footprints[k].origin.xyz
                    + 0.5 * (footprints[k].span_s.xyz + footprints[k].span_t.xyz);
        vec3 yc = y0 + centre * d;
        vec3 cc = c0;
        bool inc = in0;
        if (centre * d != vec3(0.0)) {
            inc = yc.z > 0.0;
            vec2 pcen = inc ? yc.xy / yc.z : vec2(0.0);
            inc = inc && all(greaterThanEqual(pcen, lo)) && all(lessThanEqual(pcen, hi));
            cc = inc ? fetch(pcen, w.a0.w) : vec3(0.0);
        }
        if (inc) {
            sums[group_of(k)] += vec4(wk * cc, wk);
        }
    }
    for (uint g = 0u; g < groups; ++g) {
        vec4 q = clamp(sums[g] * bp.scale.w, 0.0, 65535.0 / QUANT) * QUANT;
        tables[table_index(g, p.x + 1, p.y + 1)] = uvec4(q + 0.5);
    }
    float threshold = footprints[0].vis.w;
    bool agreed = false;
    if (threshold > 0.0 && sigma >= 0.0 && plain_w > 0.0) {
        vec3 mean = root / plain_w;
        vec3 spread = max(lin / plain_w - mean * mean, vec3(0.0));
        agreed = max(spread.r, max(spread.g, spread.b)) <= threshold * threshold;
    }
    vec4 result;
    if (agreed) {
        result = vec4(plain, plain_w);
    } else if (sigma < 0.0) {
        vec4 t = vec4(0.0);
        for (uint g = 0u; g < groups; ++g) {
            t += sums[g];
        }
        result = t;
    } else if (abs(d) < pc.focused_reach || abs(d) * bp.scale.z < bp.scale.y
               || needs_tests(p, s, sigma)) {
        result = vec4(0.0, 0.0, 0.0, -1.0);
    } else {
        result = vec4(0.0, 0.0, 0.0, -2.0);
    }
    results[i] = result;
}
