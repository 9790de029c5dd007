#version 450
#include "mesh_interface.glsl"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec3 in_normal;
layout(location = 2) in vec2 in_uv;
layout(location = 3) in vec4 in_color;

layout(location = 0) out vec2 v_uv;
layout(location = 1) out vec4 v_color;
layout(location = 2) out vec3 v_normal;
layout(location = 3) out vec3 v_position;

// The depth pre-pass and the colour pass must produce identical depths (GREATER_OR_EQUAL test):
// both pipelines use this module with the same fragment shader and differ only in fixed-function
// state. (`invariant gl_Position` would say so explicitly, but Mesa warns about the decoration
// on the gl_PerVertex member on every pipeline creation.)

void main() {
    vec4 p = vec4(in_position, 1.0);
    gl_Position = pc.clip_from_world * p;
    v_uv = in_uv;
    v_color = in_color;
    v_normal = mat3(pc.camera_from_world) * in_normal;
    v_position = (pc.camera_from_world * p).xyz;
}
