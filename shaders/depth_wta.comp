#version 450
// Winner-take-all over the planes, streamed chunk by chunk (the whole cost volume is never
// held): PASS 0 folds the aggregated costs of a chunk into each pixel's state; PASS 1 turns the
// state into the result: the winning plane refined by the parabola through its neighbours,
// and the confidence (c2 - c1) / (c2 + eps) with c2 the best cost at least pc.conf_gap planes
// away from the winner.
#include "depth_interface.glsl"

layout(constant_id = 0) const uint PASS = 0;
// Sub-plane refinement: 0 parabola, 1 equiangular (V) fit.
layout(constant_id = 1) const uint REFINE = 0;
layout(local_size_x = 64) in;

void main() {
    uint pixel = gl_GlobalInvocationID.x;
    uint n = pc.width * pc.height;
    if (pixel >= n) {
        return;
    }
    WtaState s;
    if (PASS == 0u && pc.plane_first == 0u) {
        s.best = vec4(BIG, 0.0, BIG, BIG);
        s.run = vec4(BIG, BIG, 0.0, 0.0);
    } else {
        s = state[pixel];
    }
    if (PASS == 0u) {
        uint gap = pc.conf_gap;
        uint ring = pixel * gap;
        for (uint k = 0u; k < pc.plane_count; ++k) {
            uint g = pc.plane_first + k;
            float c = cost[k * n + pixel];
            // run.x: min over planes <= g - gap (the ring still holds plane g - gap).
            if (g >= gap) {
                s.run.x = min(s.run.x, history[ring + g % gap]);
            }
            float previous = g >= 1u ? history[ring + (g - 1u) % gap] : BIG;
            if (c < s.best.x) {
                // Planes <= g - gap are the candidates for c2 so far.
                s.run.y = s.run.x;
                s.best = vec4(c, float(g), previous, BIG);
            } else {
                if (float(g) == s.best.y + 1.0) {
                    s.best.w = c;
                }
                if (float(g) >= s.best.y + float(gap)) {
                    s.run.y = min(s.run.y, c);
                }
            }
            history[ring + g % gap] = c;
        }
        state[pixel] = s;
        return;
    }
    float k1 = s.best.y;
    float index = k1;
    float l = s.best.z;
    float r = s.best.w;
    if (l < BIG && r < BIG) {
        if (REFINE == 1u) {
            // Equiangular (V) fit: the lines through the winner's neighbours with equal and
            // opposite slopes (Shimizu & Okutomi 2001: unbiased for absolute-difference costs).
            float rise = max(l, r) - s.best.x;
            if (rise > 0.0) {
                index += clamp(0.5 * (l - r) / rise, -0.5, 0.5);
            }
        } else {
            float denom = l - 2.0 * s.best.x + r;
            if (denom > 0.0) {
                index += clamp(0.5 * (l - r) / denom, -0.5, 0.5);
            }
        }
    }
    float c2 = s.run.y;
    float conf = c2 < BIG ? clamp((c2 - s.best.x) / (c2 + pc.conf_eps), 0.0, 1.0) : 0.0;
    result[pixel] = vec4(index, conf, s.best.x, c2);
}
