#version 450
// Separable box filters over the planes of a chunk (windows of radius pc.radius, truncated at
// the border, means divided by the pixels in the window), and the guided filter built on them
// (He, Sun, Tang 2010; src/depth/guide.rs states the equations):
//   PASS 0: row sums of (p, p I) from the raw costs          (guided, first box)
//   PASS 1: row sums of the coefficients (a, b)               (guided, second box)
//   PASS 2: row sums of p                                     (box aggregation)
//   PASS 3: column sums -> means -> a, b into `coeffs`        (guided, first box)
//   PASS 4: column sums -> means -> q = mean(a) . I + mean(b) into `cost` (guided, second box)
//   PASS 5: column sums -> mean of p into `cost`              (box aggregation)
// Rows: invocation x is a row, y a plane; columns: invocation x is a column, y a plane. Each
// keeps a running window sum, so the cost per pixel does not depend on the radius.
#include "depth_interface.glsl"

layout(constant_id = 0) const uint PASS = 0;
layout(local_size_x = 64) in;

vec4 row_input(uint i, uint pixel) {
    if (PASS == 0u) {
        float p = cost[i];
        return vec4(p, p * guide[pixel].colour.rgb);
    }
    if (PASS == 1u) {
        return coeffs[i];
    }
    return vec4(cost[i], 0.0, 0.0, 0.0);
}

float count_of(int i, int size, int r) {
    return float(min(i + r, size - 1) - max(i - r, 0) + 1);
}

void rows_pass(uint y, uint k) {
    int w = int(pc.width);
    int r = int(pc.radius);
    uint n = pc.width * pc.height;
    uint line = y * pc.width;
    uint base = k * n + line;
    vec4 s = vec4(0.0);
    for (int x = 0; x < min(r, w); ++x) {
        s += row_input(base + uint(x), line + uint(x));
    }
    for (int x = 0; x < w; ++x) {
        if (x + r < w) {
            s += row_input(base + uint(x + r), line + uint(x + r));
        }
        if (x - r - 1 >= 0) {
            s -= row_input(base + uint(x - r - 1), line + uint(x - r - 1));
        }
        rows[base + uint(x)] = s;
    }
}

void columns_pass(uint x, uint k) {
    int w = int(pc.width);
    int h = int(pc.height);
    int r = int(pc.radius);
    uint n = pc.width * pc.height;
    uint base = k * n + x;
    float cx = count_of(int(x), w, r);
    vec4 s = vec4(0.0);
    for (int y = 0; y < min(r, h); ++y) {
        s += rows[base + uint(y * w)];
    }
    for (int y = 0; y < h; ++y) {
        if (y + r < h) {
            s += rows[base + uint((y + r) * w)];
        }
        if (y - r - 1 >= 0) {
            s -= rows[base + uint((y - r - 1) * w)];
        }
        vec4 mean = s / (cx * count_of(y, h, r));
        uint pixel = uint(y * w) + x;
        uint i = k * n + pixel;
        if (PASS == 3u) {
            GuidePixel g = guide[pixel];
            vec3 cov = mean.yzw - g.mean.rgb * mean.x;
            mat3 inv = mat3(g.inv0.x, g.inv0.y, g.inv0.z,
                            g.inv0.y, g.inv0.w, g.inv1.x,
                            g.inv0.z, g.inv1.x, g.inv1.y);
            vec3 a = inv * cov;
            coeffs[i] = vec4(a, mean.x - dot(a, g.mean.rgb));
        } else if (PASS == 4u) {
            cost[i] = dot(mean.xyz, guide[pixel].colour.rgb) + mean.w;
        } else {
            cost[i] = mean.x;
        }
    }
}

void main() {
    uint line = gl_GlobalInvocationID.x;
    uint k = gl_GlobalInvocationID.y;
    if (k >= pc.plane_count) {
        return;
    }
    if (PASS <= 2u) {
        if (line < pc.height) {
            rows_pass(line, k);
        }
    } else if (line < pc.width) {
        columns_pass(line, k);
    }
}
