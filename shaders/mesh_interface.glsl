// Shared by mesh.vert, mesh_accum.frag and mesh_geom.frag (the raster pass, src/passes/raster.rs).

// 128 bytes: the minimum push constant size every device supports.
layout(push_constant) uniform MeshPush {
    // World → Vulkan clip space: rows (2/W)·p0 + c_x·p2, (2/H)·p1 + c_y·p2, (0,0,0,near), p2 of
    // the 3×4 projection P = K [R | t] (pixel-index coordinates, reverse Z).
    mat4 clip_from_world;
    // World → camera frame [R | t] (x right, y down, z forward).
    mat4 camera_from_world;
} pc;

layout(set = 0, binding = 0) uniform sampler2D base_color;
