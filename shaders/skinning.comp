#version 430 core
// Skinning job, linear blend skinning with K sparse influences (docs/inputs.md "Network evaluation"):
//     positions[i] = sum_k skin_weights[i][k] * M_{skin_indices[i][k]} * (deformed[i], 1)
// Same loop as sdk/src/skinning.c and tools/pleat/reference/skinning.py: for each influence k in order, transform
// the vertex by that joint's 3x4 matrix and accumulate weighted. One invocation per vertex.

layout(local_size_x = 64) in;

// C twin: plGlDeformParams (sdk/src/gl/gl_types.h).
layout(std140, binding = 0) uniform plGlDeformParams
{
	uint vertex_count;    // N
	uint blend_count;     // D
	uint influence_count; // K
	uint joint_count;     // J
};

layout(std430, binding = 3) restrict readonly buffer Deformed { vec4 deformed[]; };         // [N] T_def, w = 1
layout(std430, binding = 4) restrict readonly buffer SkinIndices { uint skin_indices[]; };  // [N][K] (u16 widened)
layout(std430, binding = 5) restrict readonly buffer SkinWeights { float skin_weights[]; }; // [N][K]
// [J][3] rows of the row-major 3x4 rest -> output matrix: row r = (M[r][0], M[r][1], M[r][2], M[r][3]).
layout(std430, binding = 6) restrict readonly buffer SkinMatrices { vec4 skin_matrices[]; };
layout(std430, binding = 7) restrict writeonly buffer Positions { vec4 positions[]; };      // [N] xyz, w = 1

void main()
{
	uint i = gl_GlobalInvocationID.x;
	if (i >= vertex_count)
		return;
	vec4 p = vec4(deformed[i].xyz, 1.0);
	vec3 x = vec3(0.0);
	for (uint k = 0u; k < influence_count; ++k)
	{
		uint e = i * influence_count + k;
		float w = skin_weights[e];
		uint m = 3u * skin_indices[e];
		x += w * vec3(dot(skin_matrices[m], p), dot(skin_matrices[m + 1u], p), dot(skin_matrices[m + 2u], p));
	}
	positions[i] = vec4(x, 1.0);
}
