#version 450
#include "mesh_interface.glsl"

layout(location = 0) in vec2 v_uv;
layout(location = 1) in vec4 v_color;
layout(location = 2) in vec3 v_normal;
layout(location = 3) in vec3 v_position;

// Camera-frame unit normal facing the camera (xyz) and camera-frame depth z (w; 0 = nothing).
layout(location = 0) out vec4 out_geometry;

void main() {
    vec3 n = normalize(v_normal);
    if (dot(n, v_position) > 0.0) {
        n = -n;
    }
    out_geometry = vec4(n, v_position.z);
}
