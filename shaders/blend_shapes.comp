#version 430 core
// Blend-shape job (paper eq. for T_def; docs/inputs.md "Network evaluation"):
//     deformed[i] = shaped_template[i] + sum_j blend_weights[j] * blend_shapes[j][i]
// Same loop as sdk/src/blend_shapes.c and tools/pleat/reference/blend_shapes.py: start from the shaped template
// (T + G_S(beta), cached on the CPU), add the D blend shapes in order j = 0 .. D-1. One invocation per vertex.
// PLEAT_BLEND_FP16 is injected after the #version line by sdk/src/gl/gl_deformer.c when the asset's BLND is fp16.
#ifndef PLEAT_BLEND_FP16
#define PLEAT_BLEND_FP16 0
#endif

// Batches (plStepInstances, sdk/src/gl/gl_deformer.c plGlDeformer_RunBatch): gl_WorkGroupID.y is the instance, and
// every per-instance buffer holds one block per instance at that index; a single instance is instance 0.
layout(local_size_x = 64) in;

// C twin: plGlDeformParams (sdk/src/gl/gl_types.h).
layout(std140, binding = 0) uniform plGlDeformParams
{
	uint vertex_count;    // N
	uint blend_count;     // D
	uint influence_count; // K
	uint joint_count;     // J
	uint face_count;      // F
	uint anchor_influence_count; // Ka (body_contact.comp)
	float body_contact_offset_m; // (body_contact.comp)
	uint shaped_rows;            // rows of ShapedTemplate per instance: N, or N + P with body contact
};

// [instances][shaped_rows] xyz, w = 1: T + G_S(beta) in the first N rows of each instance
layout(std430, binding = 0) restrict readonly buffer ShapedTemplate { vec4 shaped_template[]; };
#if PLEAT_BLEND_FP16
// [D][N] four halves per vertex (x, y, z, 0) in two uints: C twin plGlHalf4.
layout(std430, binding = 1) restrict readonly buffer BlendShapes { uint blend_shapes[]; };
#else
layout(std430, binding = 1) restrict readonly buffer BlendShapes { vec4 blend_shapes[]; }; // [D][N] xyz, w = 0
#endif
layout(std430, binding = 2) restrict readonly buffer BlendWeights { float blend_weights[]; }; // [instances][D]
layout(std430, binding = 3) restrict writeonly buffer Deformed { vec4 deformed[]; };          // [instances][N] T_def

vec3 blend_shape(uint j, uint i)
{
	uint e = j * vertex_count + i;
#if PLEAT_BLEND_FP16
	vec2 xy = unpackHalf2x16(blend_shapes[2u * e]);
	vec2 z_ = unpackHalf2x16(blend_shapes[2u * e + 1u]);
	return vec3(xy, z_.x);
#else
	return blend_shapes[e].xyz;
#endif
}

void main()
{
	uint i = gl_GlobalInvocationID.x;
	if (i >= vertex_count)
		return;
	uint instance = gl_WorkGroupID.y;
	vec3 x = shaped_template[instance * shaped_rows + i].xyz;
	uint w = instance * blend_count;
	for (uint j = 0u; j < blend_count; ++j)
		x += blend_weights[w + j] * blend_shape(j, i);
	deformed[instance * vertex_count + i] = vec4(x, 1.0);
}
