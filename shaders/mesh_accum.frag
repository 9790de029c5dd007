#version 450
#include "mesh_interface.glsl"

layout(location = 0) in vec2 v_uv;
layout(location = 1) in vec4 v_color;
layout(location = 2) in vec3 v_normal;
layout(location = 3) in vec3 v_position;

// Linear-light albedo with coverage 1 in alpha, added into the float accumulation target.
layout(location = 0) out vec4 out_color;

void main() {
    vec3 c = texture(base_color, v_uv).rgb * v_color.rgb;
    out_color = vec4(c, 1.0);
}
