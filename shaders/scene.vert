#version 450
// The scene panel's points, lines and triangles: world positions through one clip-from-world
// matrix (reverse Z, infinite far plane), linear-light colour with straight alpha.
layout(push_constant) uniform Push {
    mat4 clip_from_world;
    float point_size;
} pc;

layout(location = 0) in vec3 position;
layout(location = 1) in vec4 colour;
layout(location = 0) out vec4 v_colour;

void main() {
    gl_Position = pc.clip_from_world * vec4(position, 1.0);
    gl_PointSize = pc.point_size;
    v_colour = colour;
}
